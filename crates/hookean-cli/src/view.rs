//! `view.html`: one self-contained page that plays a run in the browser
//! (WebGL), and `hookean view OUT_DIR`, which writes it for an existing run
//! folder.
//!
//! The page is the template `view.html` (HTML, CSS and the player's
//! JavaScript, included with `include_str!`) with two blocks filled in: a
//! JSON block (the run's summary, frame times and energies, the fixed speed
//! scale, colliders) and a base64 block of zlib-compressed binary data
//! (topology, then per frame the positions quantised to `u16` over the
//! bounding box of all frames, stored as wrapping differences to the
//! previous frame, then the speeds quantised to `u8` over the fixed colour
//! scale). The browser inflates it with its built-in `DecompressionStream`:
//! nothing is fetched from the network.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use base64::Engine as _;
use clap::Args;
use hookean::massspring::parse_obj;
use serde::Serialize;

use crate::CliError;
use crate::plot::linear_ticks;

mod colliders;
pub use colliders::{
    MeshFile, MeshFileKind, SummaryCollider, ViewCollider, path_keys, rigid_motion_of,
};

/// The player: HTML, CSS and JavaScript with `{{META}}` and `{{DATA}}` slots.
const TEMPLATE: &str = include_str!("view.html");

/// Kinetic, gravitational and spring energy of a frame (J).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameEnergies {
    /// Kinetic energy.
    pub kinetic: f64,
    /// Gravitational potential energy.
    pub gravitational: f64,
    /// Elastic energy of the springs.
    pub spring: f64,
}

/// One frame of a run.
#[derive(Debug, Clone)]
pub struct ViewFrame {
    /// Simulated time (s).
    pub t: f64,
    /// Positions, `3 n` values.
    pub x: Vec<f64>,
    /// Particle speeds `|v_p|` (m/s), `n` values.
    pub speed: Vec<f64>,
    /// Energies, when known.
    pub energies: Option<FrameEnergies>,
}

/// Everything the page shows.
#[derive(Debug, Clone)]
pub struct ViewRun {
    /// The run's `summary.json`.
    pub summary: serde_json::Value,
    /// Triangles (drawn shaded); empty for ropes and lattices.
    pub faces: Vec<[usize; 3]>,
    /// Segments drawn as lines when there are no faces (springs).
    pub segments: Vec<(usize, usize)>,
    /// Planes, spheres and meshes.
    pub colliders: Vec<ViewCollider>,
    /// The frames, in time order; at least one.
    pub frames: Vec<ViewFrame>,
    /// Where the speeds come from (shown on the page).
    pub speed_source: String,
}

/// The metadata block of the page.
#[derive(Debug, Serialize)]
struct Meta<'a> {
    summary: &'a serde_json::Value,
    particles: usize,
    faces: usize,
    segments: usize,
    times: Vec<f64>,
    energies: Vec<Option<FrameEnergies>>,
    lo: [f64; 3],
    hi: [f64; 3],
    speed_max: f64,
    speed_ticks: Vec<f64>,
    speed_source: &'a str,
    colliders: &'a [ViewCollider],
}

/// The smallest "nice" number (1, 2, 2.5 or 5 times a power of ten) at or
/// above `v`; 1 for `v <= 0` or non-finite `v`.
pub fn nice_ceiling(v: f64) -> f64 {
    if !(v > 0.0 && v.is_finite()) {
        return 1.0;
    }
    let p = 10f64.powf(v.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|&s| s >= v * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
}

/// Quantises `x` in `[lo, hi]` to `0..=65535`.
fn quantise(x: f64, lo: f64, hi: f64) -> u16 {
    if hi > lo {
        ((x - lo) / (hi - lo) * 65535.0).round().clamp(0.0, 65535.0) as u16
    } else {
        0
    }
}

impl ViewRun {
    /// The bounding box of every frame's finite positions.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for f in &self.frames {
            for p in f.x.chunks_exact(3) {
                for c in 0..3 {
                    if p[c].is_finite() {
                        lo[c] = lo[c].min(p[c]);
                        hi[c] = hi[c].max(p[c]);
                    }
                }
            }
        }
        for c in 0..3 {
            if !lo[c].is_finite() {
                (lo[c], hi[c]) = (0.0, 0.0);
            }
        }
        (lo, hi)
    }

    /// The top of the fixed colour scale: the largest speed of any frame,
    /// rounded up to a nice number.
    pub fn speed_max(&self) -> f64 {
        let top = self
            .frames
            .iter()
            .flat_map(|f| f.speed.iter().copied())
            .filter(|s| s.is_finite())
            .fold(0.0, f64::max);
        nice_ceiling(top)
    }

    /// The page: the template with this run filled in.
    pub fn html(&self) -> Result<String, CliError> {
        let n = self.frames.first().map_or(0, |f| f.x.len() / 3);
        let (lo, hi) = self.bounds();
        let speed_max = self.speed_max();
        let segments: &[(usize, usize)] = if self.faces.is_empty() {
            &self.segments
        } else {
            &[]
        };
        let mut bin = Vec::with_capacity(
            12 * self.faces.len() + 8 * segments.len() + self.frames.len() * 7 * n,
        );
        for f in &self.faces {
            for &i in f {
                bin.extend_from_slice(&(i as u32).to_le_bytes());
            }
        }
        for &(i, j) in segments {
            bin.extend_from_slice(&(i as u32).to_le_bytes());
            bin.extend_from_slice(&(j as u32).to_le_bytes());
        }
        let mut previous = vec![0u16; 3 * n];
        for f in &self.frames {
            for (k, (&x, prev)) in f.x.iter().zip(previous.iter_mut()).enumerate() {
                let q = quantise(x, lo[k % 3], hi[k % 3]);
                bin.extend_from_slice(&q.wrapping_sub(*prev).to_le_bytes());
                *prev = q;
            }
        }
        for f in &self.frames {
            bin.extend(f.speed.iter().map(|&s| {
                if s.is_finite() {
                    (s / speed_max * 255.0).round().clamp(0.0, 255.0) as u8
                } else {
                    255
                }
            }));
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        let memory = |e: std::io::Error| CliError::Failed(format!("compressing view.html: {e}"));
        z.write_all(&bin).map_err(memory)?;
        let compressed = z.finish().map_err(memory)?;
        let data = base64::engine::general_purpose::STANDARD.encode(compressed);
        let meta = Meta {
            summary: &self.summary,
            particles: n,
            faces: self.faces.len(),
            segments: segments.len(),
            times: self.frames.iter().map(|f| f.t).collect(),
            energies: self.frames.iter().map(|f| f.energies).collect(),
            lo,
            hi,
            speed_max,
            speed_ticks: linear_ticks(0.0, speed_max),
            speed_source: &self.speed_source,
            colliders: &self.colliders,
        };
        // `</` may not appear inside a script element; `<\/` is the same JSON string.
        let meta = crate::to_json(&meta, false)?.replace("</", "<\\/");
        Ok(TEMPLATE
            .replacen("{{META}}", &meta, 1)
            .replacen("{{DATA}}", &data, 1))
    }

    /// Writes the page to `path`, replacing it whole (a link there is
    /// replaced, never written through: `output::replace_file`).
    pub fn write(&self, path: &Path) -> Result<(), CliError> {
        let html = self.html()?;
        crate::output::replace_file(path, |w| w.write_all(html.as_bytes()))
            .map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))
    }
}

/// Speeds `|x_{k+1} - x_{k-1}| / (t_{k+1} - t_{k-1})` by central differences
/// of the frames (one-sided at the ends; zero for a single frame).
fn finite_difference_speeds(frames: &mut [ViewFrame]) {
    let m = frames.len();
    if m < 2 {
        for f in frames.iter_mut() {
            f.speed = vec![0.0; f.x.len() / 3];
        }
        return;
    }
    let speeds: Vec<Vec<f64>> = (0..m)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(m - 1));
            let dt = frames[b].t - frames[a].t;
            frames[a]
                .x
                .chunks_exact(3)
                .zip(frames[b].x.chunks_exact(3))
                .map(|(p, q)| {
                    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / dt.max(1e-300)
                })
                .collect()
        })
        .collect();
    for (f, s) in frames.iter_mut().zip(speeds) {
        f.speed = s;
    }
}

/// `hookean view OUT_DIR`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// A folder written by `hookean run` (summary.json, steps.csv, frame-*.obj).
    dir: PathBuf,
    /// Replace an existing view.html.
    #[arg(long)]
    force: bool,
}

fn input(e: impl std::fmt::Display) -> CliError {
    CliError::Input(e.to_string())
}

/// Energies of `steps.csv` rows by time (`t,h,newton,cg,kinetic,gravitational,spring,total`).
fn read_step_energies(path: &Path, times: &[f64]) -> Result<Vec<Option<FrameEnergies>>, CliError> {
    let lines = hookean_io::file_lines(path, hookean_io::LineLimits::default())
        .map_err(|e| input(format!("{}: {e}", path.display())))?;
    // Rows and frame times both ascend: one pass matches them, keeping only
    // the rows of frames (the file may hold millions of steps).
    let mut energies = vec![None; times.len()];
    let mut next = 0;
    for (k, line) in lines.enumerate().skip(1) {
        let line = line.map_err(|e| input(format!("{}: {e}", path.display())))?;
        let v: Vec<f64> = line
            .split(',')
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| input(format!("{}:{}: {e}", path.display(), k + 1)))?;
        if v.len() < 7 {
            return Err(input(format!(
                "{}:{}: expected at least 7 columns, found {}",
                path.display(),
                k + 1,
                v.len()
            )));
        }
        let t = v[0];
        while next < times.len() && times[next] < t - 1e-9 * times[next].abs().max(1.0) {
            next += 1;
        }
        if next < times.len() && (times[next] - t).abs() <= 1e-9 * t.abs().max(1.0) {
            energies[next] = Some(FrameEnergies {
                kinetic: v[4],
                gravitational: v[5],
                spring: v[6],
            });
        }
    }
    Ok(energies)
}

/// The `l i j` records of an OBJ file (springs of ropes and lattices), 0-based.
fn read_obj_lines(text: &str) -> Vec<(usize, usize)> {
    text.lines()
        .filter_map(|l| {
            let mut t = l.split_whitespace();
            (t.next()? == "l").then_some(())?;
            let i: usize = t.next()?.parse().ok()?;
            let j: usize = t.next()?.parse().ok()?;
            (i > 0 && j > 0).then(|| (i - 1, j - 1))
        })
        .collect()
}

/// The frames of a run folder as its `summary.json` records them.
pub struct RunFrames {
    /// `dir/summary.json`.
    pub summary_path: PathBuf,
    /// Its content.
    pub summary: serde_json::Value,
    /// The simulated time of each `frame-NNNN.obj` (at least one frame).
    pub times: Vec<f64>,
}

impl RunFrames {
    /// Reads `dir/summary.json`: the frame count and times (older summaries
    /// without `frame_times`: frames evenly spread over the simulated time).
    ///
    /// # Errors
    /// [`CliError::Input`] for a missing or malformed summary, a run without
    /// frames or with more than a run writes.
    pub fn read(dir: &Path) -> Result<Self, CliError> {
        let summary_path = dir.join("summary.json");
        let text = read_text(&summary_path, SUMMARY_BYTES)?;
        let summary: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| input(format!("{}: {e}", summary_path.display())))?;
        let count = summary["frames"].as_u64().ok_or_else(|| {
            input(format!(
                "{}: no \"frames\" count (not written by `hookean run` of a mass-spring scene)",
                summary_path.display()
            ))
        })?;
        if count == 0 {
            return Err(input(format!(
                "{}: the run wrote no frames (output.frame_rate = 0)",
                dir.display()
            )));
        }
        if count > crate::run::MAX_FRAMES as u64 {
            return Err(input(format!(
                "{}: {count} frames, more than a run writes ({})",
                summary_path.display(),
                crate::run::MAX_FRAMES
            )));
        }
        let count = count as usize;
        let times: Vec<f64> = match summary["frame_times"].as_array() {
            Some(a) => a.iter().filter_map(serde_json::Value::as_f64).collect(),
            None => {
                let t_end = summary["simulated_s"].as_f64().unwrap_or(0.0);
                (0..count)
                    .map(|k| t_end * k as f64 / (count.max(2) - 1) as f64)
                    .collect()
            }
        };
        if times.len() != count {
            return Err(input(format!(
                "{}: {} frame times for {count} frames",
                summary_path.display(),
                times.len()
            )));
        }
        Ok(RunFrames {
            summary_path,
            summary,
            times,
        })
    }
}

impl ViewRun {
    /// Rebuilds a run from its folder: positions and topology from the
    /// `frame-NNNN.obj` files, frame times and colliders from
    /// `summary.json` (older summaries without `frame_times`: frames evenly
    /// spread over the simulated time), energies from the `steps.csv` row
    /// at each frame's time, speeds by finite differences of the frames
    /// (OBJ files hold no velocities).
    pub fn from_folder(dir: &Path) -> Result<Self, CliError> {
        let RunFrames {
            summary_path,
            summary,
            times,
        } = RunFrames::read(dir)?;
        let count = times.len();
        let recorded: Vec<SummaryCollider> = match summary.get("colliders") {
            Some(c) => serde_json::from_value(c.clone())
                .map_err(|e| input(format!("{}: colliders: {e}", summary_path.display())))?,
            None => Vec::new(),
        };
        // A mesh whose file is gone or changed is left out of the page, with a warning.
        let colliders: Vec<ViewCollider> = recorded
            .into_iter()
            .enumerate()
            .filter_map(|(k, c)| match c {
                SummaryCollider::Drawn(c) => Some(c),
                SummaryCollider::File(m) => m
                    .load()
                    .inspect_err(|why| {
                        crate::errln!(
                            "hookean: warning: {}: collider {}: {why}; view.html shows the run without it",
                            summary_path.display(),
                            k + 1
                        );
                    })
                    .ok(),
            })
            .collect();
        // Frame 0 gives the mesh and the particle count; the frames read
        // are every stride-th (and the last) within crate::thin::VIEW_BYTES.
        let frame_path = |k: usize| dir.join(format!("frame-{k:04}.obj"));
        let first_text = read_text(&frame_path(0), FRAME_BYTES)?;
        let first = parse_obj(first_text.as_bytes())
            .map_err(|e| input(format!("{}: {e}", frame_path(0).display())))?;
        let particles = first.positions.len();
        let stride = count
            .div_ceil(crate::thin::max_view_frames(particles) - 1)
            .max(1);
        let mut picked: Vec<usize> = (0..count).step_by(stride).collect();
        if picked.last() != Some(&(count - 1)) {
            picked.push(count - 1);
        }
        let picked_times: Vec<f64> = picked.iter().map(|&k| times[k]).collect();
        // Energies are optional (a folder without steps.csv still plays), a malformed file is not.
        let steps_path = dir.join("steps.csv");
        let energies = if steps_path.exists() {
            read_step_energies(&steps_path, &picked_times)?
        } else {
            vec![None; picked.len()]
        };
        let faces = first.triangles;
        let segments = read_obj_lines(&first_text);
        let mut frames = Vec::with_capacity(picked.len());
        for (&k, energies) in picked.iter().zip(energies) {
            let path = frame_path(k);
            let positions = if k == 0 {
                first.positions.clone()
            } else {
                let file = hookean_io::open_regular(&path)
                    .map_err(|e| input(format!("{}: {e}", path.display())))?;
                parse_obj(std::io::BufReader::new(file))
                    .map_err(|e| input(format!("{}: {e}", path.display())))?
                    .positions
            };
            if positions.len() != particles {
                return Err(input(format!(
                    "{}: {} vertices, frame 0 has {particles}",
                    path.display(),
                    positions.len(),
                )));
            }
            frames.push(ViewFrame {
                t: times[k],
                x: positions.iter().flatten().copied().collect(),
                speed: Vec::new(),
                energies,
            });
        }
        finite_difference_speeds(&mut frames);
        Ok(ViewRun {
            summary,
            faces,
            segments,
            colliders,
            frames,
            speed_source: "finite differences of the OBJ frames".into(),
        })
    }
}

/// The largest `summary.json` `hookean view` reads.
const SUMMARY_BYTES: u64 = 64 << 20;
/// The largest OBJ frame `hookean view` reads as one text (frame 0).
const FRAME_BYTES: u64 = 1 << 30;

/// The text of `path`, at most `max` bytes.
fn read_text(path: &Path, max: u64) -> Result<String, CliError> {
    hookean_io::read_file(path, max).map_err(|e| input(format!("{}: {e}", path.display())))
}

/// `hookean view OUT_DIR`: writes `OUT_DIR/view.html`.
pub fn run(args: &ViewArgs) -> Result<(), CliError> {
    let path = args.dir.join("view.html");
    if std::fs::symlink_metadata(&path).is_ok() {
        if !args.force {
            return Err(CliError::Input(format!(
                "{} exists; pass --force to replace it",
                path.display()
            )));
        }
        // --force replaces a view.html hookean wrote, nothing of the user's.
        if !crate::output::is_listed_file(&args.dir, "view.html") {
            return Err(CliError::Input(format!(
                "{} was not written by hookean (it is not a file listed in {}): \
                 remove it yourself, or copy the run to a new folder",
                path.display(),
                args.dir.join(crate::output::MARKER).display()
            )));
        }
    }
    let view = ViewRun::from_folder(&args.dir)?;
    view.write(&path)?;
    crate::output::add_to_marker(&args.dir, "view.html")
        .map_err(|e| CliError::Failed(format!("{}: {e}", args.dir.display())))?;
    crate::errln!(
        "wrote {} ({} frames, {:.1} MB)",
        path.display(),
        view.frames.len(),
        std::fs::metadata(&path).map_or(0.0, |m| m.len() as f64 / 1e6)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_ceiling_is_the_next_nice_number() {
        assert_eq!(nice_ceiling(0.0), 1.0);
        assert_eq!(nice_ceiling(0.7), 1.0);
        assert_eq!(nice_ceiling(1.0), 1.0);
        assert_eq!(nice_ceiling(1.3), 2.0);
        assert_eq!(nice_ceiling(2.2), 2.5);
        assert_eq!(nice_ceiling(3.1), 5.0);
        assert!((nice_ceiling(3.1e-4) - 5e-4).abs() < 1e-18);
    }

    #[test]
    fn quantisation_error_is_half_a_level() {
        let (lo, hi) = (-1.5, 2.0);
        for k in 0..=1000 {
            let x = lo + (hi - lo) * k as f64 / 1000.0;
            let back = lo + quantise(x, lo, hi) as f64 / 65535.0 * (hi - lo);
            assert!((back - x).abs() <= 0.5 * (hi - lo) / 65535.0 + 1e-15);
        }
    }

    /// A particle moving at constant velocity has that speed by finite differences.
    #[test]
    fn finite_differences_recover_a_constant_speed() {
        let mut frames: Vec<ViewFrame> = (0..4)
            .map(|k| {
                let t = 0.1 * k as f64;
                ViewFrame {
                    t,
                    x: vec![3.0 * t, 4.0 * t, 1.0],
                    speed: vec![],
                    energies: None,
                }
            })
            .collect();
        finite_difference_speeds(&mut frames);
        for f in &frames {
            assert!((f.speed[0] - 5.0).abs() < 1e-12, "{:?}", f.speed);
        }
    }

    #[test]
    fn obj_lines_are_zero_based() {
        assert_eq!(
            read_obj_lines("v 0 0 0\nv 1 0 0\nl 1 2\n# l 3 4\nl 0 1\n"),
            vec![(0, 1)]
        );
    }
}
