//! The outputs of a run as [`Sink`]s a program attaches to
//! [`Simulation::run_with_sinks`]: the per-step CSV, OBJ frames at a rate of
//! simulated time, and progress: the files a run writes (`steps.csv`,
//! `frame-NNNN.obj`).
//!
//! ```no_run
//! use hookean::prelude::*;
//! use hookean::sinks::{ObjFrames, Progress, StepsCsv};
//!
//! let (model, state) = cloth(&ClothParams { nu: 32, nv: 32, ..Default::default() })?;
//! let mut sim = Simulation::new(model, state, SimulationOptions::default())?;
//! std::fs::create_dir_all("drape")?;
//! let mut csv = StepsCsv::create("drape/steps.csv")?;
//! let mut frames = ObjFrames::new("drape", 25.0)?; // 25 frames per simulated second
//! let mut progress = Progress::stderr(2.0);
//! sim.run_with_sinks(2.0, &mut [&mut csv, &mut frames, &mut progress])?;
//! println!("{} frames", frames.times().len());
//! # Ok::<(), hookean::HookeanError>(())
//! ```

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use hookean_ode::StepReport;

use crate::{HookeanError, RunSummary, Simulation, Sink};

/// The header of the per-step CSV.
pub const STEPS_CSV_HEADER: &str =
    "t,h,newton_iterations,cg_iterations,kinetic,gravitational,spring,total";

/// One CSV row per accepted step: time, step size, Newton and CG iterations
/// of the step, and the energies after it (J; [`STEPS_CSV_HEADER`]).
#[derive(Debug)]
pub struct StepsCsv<W: Write> {
    out: W,
    /// Named in errors.
    path: Option<PathBuf>,
}

impl StepsCsv<BufWriter<File>> {
    /// A CSV at `path`, which must not exist yet (an existing file is never
    /// overwritten).
    ///
    /// # Errors
    /// [`HookeanError::Io`] naming `path`, e.g. when it exists.
    pub fn create(path: impl AsRef<Path>) -> Result<Self, HookeanError> {
        let path = path.as_ref();
        let file = create_new(path)?;
        let mut csv = Self::new(BufWriter::new(file))?;
        csv.path = Some(path.to_path_buf());
        Ok(csv)
    }
}

impl StepsCsv<BufWriter<File>> {
    /// The CSV at `path` of a run being resumed: cut at `len` bytes (the
    /// length it had at the checkpoint; rows written after it are
    /// dropped, the resumed run writes them again) and appended to.
    ///
    /// # Errors
    /// [`HookeanError::Io`] naming `path` if it is missing, shorter than
    /// `len`, or cannot be cut.
    pub fn resume(path: impl AsRef<Path>, len: u64) -> Result<Self, HookeanError> {
        let path = path.as_ref();
        let file = std::fs::OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(|e| HookeanError::io(path, e))?;
        let found = file
            .metadata()
            .map_err(|e| HookeanError::io(path, e))?
            .len();
        if found < len {
            return Err(HookeanError::io(
                path,
                std::io::Error::other(format!(
                    "{found} bytes, shorter than the {len} it had at the checkpoint"
                )),
            ));
        }
        file.set_len(len).map_err(|e| HookeanError::io(path, e))?;
        let mut file = file;
        std::io::Seek::seek(&mut file, std::io::SeekFrom::End(0))
            .map_err(|e| HookeanError::io(path, e))?;
        Ok(Self {
            out: BufWriter::new(file),
            path: Some(path.to_path_buf()),
        })
    }
}

impl StepsCsv<BufWriter<File>> {
    /// Writes the buffered rows out and returns the file's length (bytes),
    /// for a checkpoint.
    ///
    /// # Errors
    /// [`HookeanError::Io`] naming the file.
    pub fn flushed_len(&mut self) -> Result<u64, HookeanError> {
        self.out.flush().map_err(|e| self.error(e))?;
        let meta = self.out.get_ref().metadata();
        meta.map(|m| m.len()).map_err(|e| self.error(e))
    }
}

impl<W: Write> StepsCsv<W> {
    /// Writes the buffered rows out (before a checkpoint records the
    /// file's length).
    ///
    /// # Errors
    /// [`HookeanError::Io`] naming the file.
    pub fn flush(&mut self) -> Result<(), HookeanError> {
        self.out.flush().map_err(|e| self.error(e))
    }

    /// A CSV written to `out`, starting with the header.
    ///
    /// # Errors
    /// [`HookeanError::Io`] if writing the header fails.
    pub fn new(mut out: W) -> Result<Self, HookeanError> {
        writeln!(out, "{STEPS_CSV_HEADER}")?;
        Ok(Self { out, path: None })
    }

    /// The writer, flushed by [`Sink::finish`] at the end of a run.
    pub fn into_inner(self) -> W {
        self.out
    }

    fn error(&self, source: std::io::Error) -> HookeanError {
        HookeanError::Io {
            path: self.path.clone(),
            source,
        }
    }
}

impl<W: Write> Sink for StepsCsv<W> {
    fn step(&mut self, sim: &Simulation, r: &StepReport) -> Result<(), HookeanError> {
        let e = sim.energies()?;
        writeln!(
            self.out,
            "{},{},{},{},{},{},{},{}",
            r.t,
            r.h,
            r.newton_iterations,
            r.linear_iterations,
            e.kinetic,
            e.gravitational,
            e.spring,
            e.total()
        )
        .map_err(|e| self.error(e))
    }

    fn finish(&mut self, _: &Simulation, _: &RunSummary) -> Result<(), HookeanError> {
        self.out.flush().map_err(|e| self.error(e))
    }
}

/// OBJ frames `frame-0000.obj`, `frame-0001.obj`, ... in a folder, one per
/// `1 / frame_rate` seconds of simulated time (the first at the start of the
/// run), written by [`Simulation::write_obj`] (vertices coloured by speed).
/// A frame is due when the time reaches its slot (within `1e-9` of the
/// interval); with steps longer than the interval, one frame per step.
#[derive(Debug, Clone)]
pub struct ObjFrames {
    dir: PathBuf,
    interval: f64,
    next: f64,
    times: Vec<f64>,
}

impl ObjFrames {
    /// Frames into the existing folder `dir` at `frame_rate` per simulated
    /// second. Existing files are never overwritten: a frame whose name is
    /// taken is an error.
    ///
    /// # Errors
    /// [`HookeanError::Io`] if `dir` is not a folder;
    /// [`HookeanError::InvalidOption`] unless `frame_rate` is finite and positive.
    pub fn new(dir: impl Into<PathBuf>, frame_rate: f64) -> Result<Self, HookeanError> {
        let dir = dir.into();
        if !(frame_rate.is_finite() && frame_rate > 0.0) {
            return Err(HookeanError::InvalidOption {
                name: "frame_rate".into(),
                message: format!("must be finite and positive, got {frame_rate:?}"),
            });
        }
        if !dir.is_dir() {
            return Err(HookeanError::io(
                &dir,
                std::io::Error::new(std::io::ErrorKind::NotFound, "not a folder"),
            ));
        }
        Ok(Self {
            dir,
            interval: 1.0 / frame_rate,
            next: f64::NEG_INFINITY,
            times: Vec::new(),
        })
    }

    /// The simulated time of every frame written, in order.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// The time the next frame is due (`-inf` before the first), for a
    /// checkpoint.
    pub fn next_due(&self) -> f64 {
        self.next
    }

    /// Frames of a run being resumed into `dir`: `times` already written,
    /// the next due at `next` ([`next_due`](Self::next_due)). Frame files
    /// past `times` (written after the checkpoint) are removed: the
    /// resumed run writes them again.
    ///
    /// # Errors
    /// As [`new`](Self::new); [`HookeanError::Io`] if a later frame
    /// cannot be removed.
    pub fn resume(
        dir: impl Into<PathBuf>,
        frame_rate: f64,
        next: f64,
        times: Vec<f64>,
    ) -> Result<Self, HookeanError> {
        let mut f = Self::new(dir, frame_rate)?;
        for k in times.len().. {
            let path = f.path(k);
            match std::fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => break,
                Err(e) => return Err(HookeanError::io(&path, e)),
            }
        }
        f.next = next;
        f.times = times;
        Ok(f)
    }

    /// The path of frame `k` ([`frame_path`]).
    pub fn path(&self, k: usize) -> PathBuf {
        frame_path(&self.dir, k)
    }

    /// Writes a frame if one is due at the simulation's time; returns whether it did.
    ///
    /// # Errors
    /// As [`Simulation::write_obj`]; [`HookeanError::Io`] if the frame's file exists.
    pub fn write_if_due(&mut self, sim: &Simulation) -> Result<bool, HookeanError> {
        let t = sim.t();
        if self.next.is_finite() && t < self.next - 1e-9 * self.interval {
            return Ok(false);
        }
        let path = self.path(self.times.len());
        let file = create_new(&path)?;
        let mut w = BufWriter::new(file);
        sim.write_obj_to(&mut w).map_err(|e| e.at_path(&path))?;
        // Flushed here: a write that fails on a full disk is an error, not
        // lost when the writer is dropped.
        w.flush().map_err(|e| HookeanError::io(&path, e))?;
        // Slots are `interval` apart from the first frame; a step past
        // several slots writes one frame and the next steps catch up.
        self.next = if self.times.is_empty() { t } else { self.next } + self.interval;
        self.times.push(t);
        Ok(true)
    }
}

impl Sink for ObjFrames {
    fn start(&mut self, sim: &Simulation) -> Result<(), HookeanError> {
        self.write_if_due(sim).map(drop)
    }

    fn step(&mut self, sim: &Simulation, _: &StepReport) -> Result<(), HookeanError> {
        self.write_if_due(sim).map(drop)
    }
}

/// The OBJ frame `k` of a run folder `dir`: `dir/frame-0000.obj`, ...
/// (the one place of the frames' names).
pub fn frame_path(dir: &Path, k: usize) -> PathBuf {
    dir.join(format!("frame-{k:04}.obj"))
}

/// Where a run is, as [`Progress`] reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProgressInfo {
    /// Simulated time.
    pub t: f64,
    /// The end time of the run.
    pub t_end: f64,
    /// Accepted steps since the progress started.
    pub steps: usize,
    /// Accepted steps per wall-clock second.
    pub steps_per_s: f64,
    /// The last step's size.
    pub h: f64,
}

impl ProgressInfo {
    /// The fraction of the run done, in [0, 1].
    pub fn fraction(&self) -> f64 {
        if self.t_end > 0.0 {
            (self.t / self.t_end).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

impl std::fmt::Display for ProgressInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "t = {:.3} s of {} s ({:.0}%), {:.0} steps/s, h = {:.2e} s",
            self.t,
            self.t_end,
            100.0 * self.fraction(),
            self.steps_per_s,
            self.h
        )
    }
}

/// Progress of a run: calls `report` with a [`ProgressInfo`] at most once
/// per `every` of wall-clock time (and once at the end), so a slow or a
/// fast run reports at the same pace.
pub struct Progress<F: FnMut(&ProgressInfo)> {
    t_end: f64,
    every: Duration,
    start: Instant,
    last: Option<Instant>,
    steps: usize,
    h: f64,
    report: F,
}

impl<F: FnMut(&ProgressInfo)> std::fmt::Debug for Progress<F> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Progress")
            .field("t_end", &self.t_end)
            .field("every", &self.every)
            .field("steps", &self.steps)
            .finish_non_exhaustive()
    }
}

impl<F: FnMut(&ProgressInfo)> Progress<F> {
    /// Progress of a run to `t_end`, reported to `report` every `every`.
    pub fn new(t_end: f64, every: Duration, report: F) -> Self {
        Self {
            t_end,
            every,
            start: Instant::now(),
            last: None,
            steps: 0,
            h: 0.0,
            report,
        }
    }

    fn info(&self, t: f64) -> ProgressInfo {
        ProgressInfo {
            t,
            t_end: self.t_end,
            steps: self.steps,
            steps_per_s: self.steps as f64 / self.start.elapsed().as_secs_f64().max(1e-9),
            h: self.h,
        }
    }
}

impl Progress<fn(&ProgressInfo)> {
    /// A line on stderr every second: `t = 0.500 s of 2 s (25%), 180 steps/s, h = 1.00e-2 s`.
    pub fn stderr(t_end: f64) -> Self {
        fn line(p: &ProgressInfo) {
            // A closed or full stderr must not stop a simulation.
            let _ = writeln!(std::io::stderr(), "{p}");
        }
        Progress::new(t_end, Duration::from_secs(1), line)
    }
}

impl<F: FnMut(&ProgressInfo)> Sink for Progress<F> {
    fn step(&mut self, sim: &Simulation, r: &StepReport) -> Result<(), HookeanError> {
        self.steps += 1;
        self.h = r.h;
        let now = Instant::now();
        let due = self
            .last
            .is_none_or(|l| now.duration_since(l) >= self.every);
        if due {
            self.last = Some(now);
            let info = self.info(sim.t());
            (self.report)(&info);
        }
        Ok(())
    }

    fn finish(&mut self, sim: &Simulation, _: &RunSummary) -> Result<(), HookeanError> {
        let info = self.info(sim.t());
        (self.report)(&info);
        Ok(())
    }
}

/// A new file at `path`; an existing one is an error, never truncated.
fn create_new(path: &Path) -> Result<File, HookeanError> {
    File::options()
        .write(true)
        .create_new(true)
        .open(path)
        .map_err(|e| HookeanError::io(path, e))
}
