//! Point caches (`[output] cache`, `hookean export-cache`): read back by
//! readers written here from the formats' definitions (not the library's
//! writer), and played in Blender (Debian's `blender`, headless) through
//! its Mesh Cache modifier on the exported rest mesh.
//!
//! Without Blender the Blender test prints why and passes, except under CI
//! (`CI=true`), where a missing Blender is a failure: `.ci/run` installs it.

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::Command;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-cache-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A falling cloth of 7 x 7 vertices with 7 frames (0.3 s at 20 per second).
const SCENE: &str = "duration = 0.3\n[cloth]\nn = 7\n[output]\nframe_rate = 20\nwidth = 8\nheight = 8\ncache = \"pc2\"\n";

/// Runs [`SCENE`] (with `sets`) into `dir/out`; returns the output folder.
fn run_scene(dir: &Path, sets: &[&str]) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    assert_ok(&hookean(&args));
    out
}

/// The positions of an OBJ frame, read from its `v` records.
fn obj_positions(path: &Path) -> Vec<f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| l.starts_with("v "))
        .flat_map(|l| {
            l.split_whitespace()
                .skip(1)
                .take(3)
                .map(|t| t.parse::<f64>().unwrap())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Every frame of a run folder, in order, and their times from summary.json.
fn run_frames(out: &Path) -> (Vec<Vec<f64>>, Vec<f64>) {
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let times: Vec<f64> = summary["frame_times"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_f64().unwrap())
        .collect();
    let frames = (0..times.len())
        .map(|k| obj_positions(&out.join(format!("frame-{k:04}.obj"))))
        .collect();
    (frames, times)
}

fn le_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn le_f32(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn be_i32(b: &[u8], at: usize) -> i32 {
    i32::from_be_bytes(b[at..at + 4].try_into().unwrap())
}
fn be_f32(b: &[u8], at: usize) -> f32 {
    f32::from_be_bytes(b[at..at + 4].try_into().unwrap())
}

/// PC2 as 3ds Max defines it: `char[12] "POINTCACHE2\0"`, `int version`,
/// `int numPoints`, `float startFrame`, `float sampleRate`, `int
/// numSamples`, then `numSamples x numPoints` little-endian float triples.
/// Returns (start frame, sampling, frames).
fn read_pc2(bytes: &[u8]) -> (f32, f32, Vec<Vec<f64>>) {
    assert_eq!(&bytes[..12], b"POINTCACHE2\0");
    assert_eq!(le_i32(bytes, 12), 1, "version");
    let (points, samples) = (le_i32(bytes, 16) as usize, le_i32(bytes, 28) as usize);
    assert_eq!(
        bytes.len(),
        32 + samples * points * 12,
        "size from the header"
    );
    let frames = (0..samples)
        .map(|s| {
            (0..3 * points)
                .map(|c| f64::from(le_f32(bytes, 32 + 4 * (s * 3 * points + c))))
                .collect()
        })
        .collect();
    (le_f32(bytes, 20), le_f32(bytes, 24), frames)
}

/// MDD as LightWave defines it, big-endian: `int frames`, `int points`,
/// `float time[frames]`, then `frames x points` float triples.
fn read_mdd(bytes: &[u8]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let (frames, points) = (be_i32(bytes, 0) as usize, be_i32(bytes, 4) as usize);
    let data = 8 + 4 * frames;
    assert_eq!(
        bytes.len(),
        data + frames * points * 12,
        "size from the header"
    );
    let times = (0..frames)
        .map(|k| f64::from(be_f32(bytes, 8 + 4 * k)))
        .collect();
    let x = (0..frames)
        .map(|k| {
            (0..3 * points)
                .map(|c| f64::from(be_f32(bytes, data + 4 * (k * 3 * points + c))))
                .collect()
        })
        .collect();
    (times, x)
}

/// The largest difference of two frame lists of equal shape.
fn max_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    assert_eq!(a.len(), b.len(), "frame counts");
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| {
            assert_eq!(x.len(), y.len(), "vertex counts");
            x.iter().zip(y).map(|(p, q)| (p - q).abs())
        })
        .fold(0.0, f64::max)
}

/// The tolerance of a float32 copy of coordinates of order 1 (m).
const F32_TOL: f64 = 1e-6;

#[test]
fn the_pc2_of_a_run_holds_its_frames() {
    let out = run_scene(&scratch("pc2"), &[]);
    let (frames, times) = run_frames(&out);
    assert_eq!(times.len(), 7);
    let (start, sampling, cached) = read_pc2(&std::fs::read(out.join("cache.pc2")).unwrap());
    assert_eq!((start, sampling), (0.0, 1.0));
    // The cloth fell: the frames differ, so equality is not trivial.
    assert!(max_difference(&frames[..1], &frames[6..]) > 0.1);
    assert!(max_difference(&cached, &frames) < F32_TOL);
    // The rest mesh: frame 0's positions and every face, no colours.
    let rest = std::fs::read_to_string(out.join("cache-rest.obj")).unwrap();
    let frame0 = std::fs::read_to_string(out.join("frame-0000.obj")).unwrap();
    let faces = |t: &str| t.lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(faces(&rest), faces(&frame0));
    assert!(faces(&rest) > 0);
    assert!(
        rest.lines()
            .filter(|l| l.starts_with("v "))
            .all(|l| l.split_whitespace().count() == 4)
    );
    assert_eq!(obj_positions(&out.join("cache-rest.obj")), frames[0]);
}

#[test]
fn export_cache_writes_an_mdd_with_the_frame_times() {
    let out = run_scene(&scratch("mdd"), &["output.cache=\"mdd\""]);
    assert!(out.join("cache.mdd").is_file() && !out.join("cache.pc2").exists());
    let written = std::fs::read(out.join("cache.mdd")).unwrap();
    std::fs::remove_file(out.join("cache.mdd")).unwrap();
    // From the run's frames afterwards: the same bytes.
    assert_ok(&hookean(&[
        "export-cache",
        out.to_str().unwrap(),
        "--format",
        "mdd",
    ]));
    assert_eq!(std::fs::read(out.join("cache.mdd")).unwrap(), written);
    let (frames, times) = run_frames(&out);
    let (cached_times, cached) = read_mdd(&written);
    assert!(max_difference(&cached, &frames) < F32_TOL);
    for (a, b) in cached_times.iter().zip(&times) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
    // And a PC2 beside it, equal to the frames too.
    assert_ok(&hookean(&[
        "export-cache",
        out.to_str().unwrap(),
        "--format",
        "pc2",
    ]));
    let (_, _, pc2) = read_pc2(&std::fs::read(out.join("cache.pc2")).unwrap());
    assert!(max_difference(&pc2, &frames) < F32_TOL);
    // A second export of one format needs --force, and then replaces it.
    let again = hookean(&["export-cache", out.to_str().unwrap(), "--format", "pc2"]);
    assert_input_error(&again, "--force");
    assert_ok(&hookean(&[
        "export-cache",
        out.to_str().unwrap(),
        "--format",
        "pc2",
        "--force",
    ]));
}

#[test]
fn bad_caches_are_refused_and_write_nothing() {
    let dir = scratch("bad");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.join("out");
    let (s, o) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let no_frames = hookean(&["run", s, "--out", o, "--set", "output.frame_rate=0"]);
    assert_input_error(&no_frames, "output.cache");
    let unknown = hookean(&["run", s, "--out", o, "--set", "output.cache=\"abc\""]);
    assert_input_error(&unknown, "pc2");
    assert!(!out.exists());
    // A frame missing from an earlier run: named, and nothing written.
    let run = run_scene(&scratch("bad-run"), &[]);
    std::fs::remove_file(run.join("frame-0003.obj")).unwrap();
    let missing = hookean(&["export-cache", run.to_str().unwrap(), "--format", "mdd"]);
    assert_input_error(&missing, "frame-0003.obj");
    assert!(!run.join("cache.mdd").exists());
    let not_a_run = hookean(&["export-cache", dir.to_str().unwrap(), "--format", "mdd"]);
    assert_input_error(&not_a_run, "summary.json");
}

/// Blender to drive: `$HOOKEAN_BLENDER` or `blender` on the PATH; `None`
/// (with the reason printed) without one outside CI, a panic under CI.
fn blender() -> Option<PathBuf> {
    let found = std::env::var_os("HOOKEAN_BLENDER")
        .map(PathBuf::from)
        .or_else(|| {
            let path = std::env::var_os("PATH")?;
            std::env::split_paths(&path)
                .map(|dir| dir.join("blender"))
                .find(|p| p.is_file())
        });
    if found.is_none() {
        assert!(
            std::env::var("CI").map_or(true, |v| v != "true"),
            "CI=true but no blender on the PATH: .ci/run must install it (apt-get install blender)"
        );
        eprintln!(
            "SKIPPED: no blender on the PATH (set HOOKEAN_BLENDER or install Debian's blender)"
        );
    }
    found
}

/// Blender's evaluated vertex positions at each of `frames`
/// (tests/blender/mesh_cache.py: the rest mesh imported, a Mesh Cache
/// modifier on the cache).
fn blender_positions(
    blender: &Path,
    out: &Path,
    cache: &str,
    format: &str,
    frames: &[usize],
) -> Vec<Vec<f64>> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/blender/mesh_cache.py");
    let mut cmd = Command::new(blender);
    cmd.args(["-b", "--factory-startup", "--python"])
        .arg(&script)
        .arg("--")
        .arg(out.join("cache-rest.obj"))
        .arg(out.join(cache))
        .arg(format)
        .args(frames.iter().map(ToString::to_string))
        // Blender writes its settings and caches under HOME.
        .env("HOME", out.join("blender-home"));
    let result = cmd.output().expect("blender starts");
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        result.status.success(),
        "blender failed: {stdout}\n{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let played: Vec<Vec<f64>> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("HOOKEAN-FRAME "))
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            v["x"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| c.as_f64().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(played.len(), frames.len(), "one line per frame: {stdout}");
    played
}

#[test]
fn blender_plays_the_pc2_and_mdd_as_the_frames() {
    let Some(blender) = blender() else { return };
    let out = run_scene(&scratch("blender"), &[]);
    assert_ok(&hookean(&[
        "export-cache",
        out.to_str().unwrap(),
        "--format",
        "mdd",
    ]));
    let (frames, _) = run_frames(&out);
    let picked = [0, frames.len() / 2, frames.len() - 1];
    let expected: Vec<Vec<f64>> = picked.iter().map(|&k| frames[k].clone()).collect();
    for (cache, format) in [("cache.pc2", "PC2"), ("cache.mdd", "MDD")] {
        let played = blender_positions(&blender, &out, cache, format, &picked);
        let d = max_difference(&played, &expected);
        assert!(
            d < F32_TOL,
            "{format}: Blender's positions differ from the frames by {d} m"
        );
    }
}
