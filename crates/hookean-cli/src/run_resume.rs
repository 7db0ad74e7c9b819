//! `hookean run`'s checkpoints and `--resume` (docs/OUTPUTS.md,
//! "Checkpoint and resume"): where a run writes (a staging folder moved
//! into place before its first scheduled checkpoint, or a resumed run's
//! folder in place), writing a checkpoint, and resuming from one.

use std::path::{Path, PathBuf};

use hookean::scene::Scene;
use hookean::{Simulation, StateRecord};
use hookean_sparse::Short;

use crate::CliError;
use crate::run::{RunArgs, failed, run_model};
use crate::run_outputs::Outputs;
use crate::scene::ProgramKeys;

/// How a run ended: finished (with its one-line report), or stopped by a
/// signal at time `t` after writing a checkpoint.
pub(crate) enum RunEnd {
    Done(Option<String>),
    Stopped(f64),
}

/// The failure (exit 1) of a run stopped by a signal at `t`, naming its
/// checkpoint in `out` and the command that continues it.
pub(crate) fn stopped(args: &RunArgs, t: f64, out: &Path) -> CliError {
    let mut command = format!(
        "hookean run {} --resume {}",
        args.scene.display(),
        out.display()
    );
    for s in &args.set {
        command += &format!(" --set {s}");
    }
    CliError::Failed(format!(
        "stopped by a signal at t = {} s; the checkpoint is {}; continue with: {command}",
        Short(t),
        crate::checkpoint::path(out).display()
    ))
}

/// The checkpoints of a run: the scene's hash, the schedule
/// (`output.checkpoint_every`) and, for `--resume`, the record to start from.
pub(crate) struct Checkpoints {
    pub hash: String,
    pub every: Option<f64>,
    pub resume: Option<(PathBuf, StateRecord)>,
}

impl Checkpoints {
    pub(crate) fn new(
        args: &RunArgs,
        program: &ProgramKeys,
        resume: Option<(PathBuf, StateRecord)>,
    ) -> Result<Self, CliError> {
        Ok(Self {
            hash: crate::checkpoint::scene_hash(&args.scene, &args.set)?,
            every: program.output.checkpoint_every,
            resume,
        })
    }
}

/// `hookean run SCENE --resume DIR`: checks the checkpoint in `dir` fits
/// the scene (before anything is written), then runs on in `dir`.
pub(crate) fn resume_scene(
    args: &RunArgs,
    scene: &Scene,
    program: &ProgramKeys,
    name: &str,
    max_bytes: u64,
    dir: &Path,
) -> Result<(), CliError> {
    if program.tutorial.is_some() {
        return Err(CliError::Input(format!(
            "--resume: {} is a [tutorial] scene, whose runs write no checkpoints",
            args.scene.display()
        )));
    }
    if !dir.is_dir() {
        return Err(CliError::Input(format!(
            "--resume {}: no such run folder",
            dir.display()
        )));
    }
    let mut checkpoints = Checkpoints::new(args, program, None)?;
    let (_, record) = crate::checkpoint::read(dir, &checkpoints.hash)?;
    if !crate::output::is_partial_run(dir) {
        return Err(CliError::Input(format!(
            "--resume {}: not the output of a stopped `hookean run` (its {} does not say so)",
            dir.display(),
            crate::output::MARKER
        )));
    }
    checkpoints.resume = Some((dir.to_path_buf(), record));
    let end = run_model(
        args,
        scene,
        &program.output,
        name,
        max_bytes,
        &mut InPlace(dir.to_path_buf()),
        &checkpoints,
    );
    let partial = |dir: &Path| crate::output::mark(dir, Some("run"));
    match end {
        Ok(RunEnd::Done(line)) => {
            crate::checkpoint::remove(dir);
            crate::output::mark(dir, None)
                .map_err(|e| failed(format!("{}: {e}", dir.display())))?;
            if let Some(line) = line {
                crate::errln!("{line}; wrote {}", dir.display());
            }
            Ok(())
        }
        Ok(RunEnd::Stopped(t)) => {
            let _ = partial(dir);
            Err(stopped(args, t, dir))
        }
        Err(e) => {
            let _ = partial(dir);
            Err(e)
        }
    }
}

/// Where a run writes: a staging folder (moved into place as a partial
/// output before its first scheduled checkpoint) or, resumed, the run
/// folder itself.
pub(crate) trait RunFolder {
    /// The folder written into now.
    fn dir(&self) -> &Path;
    /// Makes the folder the one `--resume` will find (before a scheduled
    /// checkpoint).
    fn publish(&mut self) -> Result<(), CliError>;
    /// Whether the folder is in place (checkpoints then rewrite its marker).
    fn in_place(&self) -> bool;
}

impl RunFolder for crate::output::Staging {
    fn dir(&self) -> &Path {
        crate::output::Staging::dir(self)
    }
    fn publish(&mut self) -> Result<(), CliError> {
        crate::output::Staging::publish(self)
    }
    fn in_place(&self) -> bool {
        self.is_published()
    }
}

/// A resumed run's folder, written in place.
struct InPlace(PathBuf);

impl RunFolder for InPlace {
    fn dir(&self) -> &Path {
        &self.0
    }
    fn publish(&mut self) -> Result<(), CliError> {
        Ok(())
    }
    fn in_place(&self) -> bool {
        true
    }
}

/// Writes a checkpoint of `sim` and `outputs` into `folder` (its marker
/// rewritten when the folder is in place); returns its size in bytes.
pub(crate) fn write_checkpoint(
    sim: &Simulation,
    outputs: &mut Outputs,
    folder: &dyn RunFolder,
    hash: &str,
) -> Result<u64, CliError> {
    let mut record = StateRecord::default();
    sim.save_state(&mut record).map_err(failed)?;
    outputs.save(&mut record).map_err(failed)?;
    let bytes = crate::checkpoint::write(folder.dir(), &record, hash, sim.t())?;
    if folder.in_place() {
        crate::output::mark(folder.dir(), Some("run"))
            .map_err(|e| failed(format!("{}: {e}", folder.dir().display())))?;
    }
    Ok(bytes)
}
