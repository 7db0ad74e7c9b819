//! `hookean export-system SCENE --at T --out DIR`: the linearised
//! implicit-Euler system of a scene's state at time `T` as Matrix Market
//! files, for `hookean solve` or any other solver.
//!
//! The scene is simulated as `hookean run` would (same integrator, solver
//! and step sizes) until `T` (`T = 0`: the initial state); then
//! `DIR/A.mtx` (`coordinate real symmetric`) and `DIR/b.mtx` (an array)
//! hold `A = M - h df/dv - h^2 df/dx`, `b = h (f + h df/dx v)` at that
//! state with the scene's `integrator.h` (one Newton step of implicit
//! Euler in the velocity form). One JSON line on stdout describes the
//! export.
//!
//! `hookean export-system SCENE --every K --out DIR` instead runs the scene
//! to its `duration` and writes every K-th linear system that Newton hands
//! to PCG (the 1st, the K+1-th, ...), numbered from 1 with their starting
//! guesses, constraints and `index.csv` (the folder layout of
//! [`crate::system_sequence`]): the input of `hookean bench --sequence`.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use clap::Args;
use serde::Serialize;

use crate::CliError;
use crate::run::Progress;
use crate::system_sequence::SequenceWriter;

#[derive(Debug, Args)]
pub struct ExportSystemArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Simulated time of the exported state (s); 0 (default) is the initial state.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "every")]
    at: Option<f64>,
    /// Run the scene to its duration and write every K-th linear system Newton hands to PCG
    /// (system-00001-A.mtx, -b.mtx, ... and index.csv), for `hookean bench --sequence`.
    #[arg(long, value_name = "K")]
    every: Option<usize>,
    /// Output folder (created; must not exist unless --force).
    #[arg(long)]
    out: PathBuf,
    /// Scene overrides key=value (as in `hookean run`).
    #[arg(long = "set")]
    set: Vec<String>,
    /// Replace an existing --out that holds nothing but an earlier hookean output.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    work: crate::work::WorkCap,
}

#[derive(Debug, Serialize)]
struct ExportRecord {
    scene: String,
    t: f64,
    h: f64,
    steps: usize,
    rows: usize,
    matrix: String,
    rhs: String,
}

fn input<E: std::fmt::Display>(e: E) -> CliError {
    CliError::Input(e.to_string())
}

/// The scene's simulation, built once its work to `until` (named `key` in
/// messages) is within `--max-work`, as `run` counts it (a variable-step
/// method: its step cap): checked at the scene's `h` before the build and
/// at the built simulation's first step (`"auto"` is known only then).
fn build_checked(
    scene: &hookean::scene::Scene,
    args: &ExportSystemArgs,
    until: f64,
    key: &str,
) -> Result<hookean::Simulation, CliError> {
    let (particles, _) = scene.particle_count();
    let check_work = |h: f64| -> Result<(), CliError> {
        let (steps, cause) = crate::work::scene_steps(scene, &args.scene, until, key, h)?;
        args.work.check(
            steps,
            particles.map_or(f64::INFINITY, |p| {
                (p as f64).max(crate::work::MIN_STEP_WORK)
            }),
            &cause,
        )
    };
    if let Some(h) = scene.integrator.h.value() {
        check_work(h)?;
    }
    let sim = scene
        .build()
        .map_err(|e| input(format!("{}: {e}", args.scene.display())))?;
    check_work(sim.h_next())?;
    Ok(sim)
}

pub fn run(args: &ExportSystemArgs) -> Result<(), CliError> {
    if let Some(every) = args.every {
        return export_sequence(args, every);
    }
    let at = args.at.unwrap_or(0.0);
    if !(at >= 0.0 && at.is_finite()) {
        return Err(CliError::Input(format!(
            "--at must be a non-negative time, got {at:?}"
        )));
    }
    // Refused before the simulation: an --out that exists (or holds the scene).
    let staging = crate::output::Staging::new(
        "export-system",
        &args.out,
        "--out",
        args.force,
        &[&args.scene],
    )?;
    let (scene, _) = crate::scene::read_scene(&args.scene, &args.set)?;
    let mut sim = build_checked(&scene, args, at, "--at")?;
    let mut steps = 0;
    if at > 0.0 {
        // A bar on a terminal: simulating to a late --at can take a while.
        let mut progress = Progress::new(at, false);
        let result = sim.run_until_with(at, |sim, r| {
            progress.update(sim, r);
            std::ops::ControlFlow::Continue(())
        });
        progress.clear();
        // A blow-up or a solver failure of a valid scene: a failed run (exit 1).
        let summary = result.map_err(|e| {
            CliError::Failed(format!(
                "{}: simulation to t = {:?} failed: {e}",
                args.scene.display(),
                at
            ))
        })?;
        steps = summary.stats.num_steps;
    }
    // The exported step: the integrator's next one; the variable-order BDF
    // before its first step has none yet (it picks it from rtol and atol),
    // so its system is the one of the scene's integrator.h, within h_max.
    let h = match sim.h_next() {
        h if h.is_finite() && h > 0.0 => h,
        _ => scene
            .integrator
            .h
            .value()
            .unwrap_or(scene.integrator.h_max)
            .min(scene.integrator.h_max),
    };
    let (a_path, b_path) = (args.out.join("A.mtx"), args.out.join("b.mtx"));
    let dir = staging.dir();
    if let Err(e) = sim.model().export_implicit_euler_system(
        h,
        sim.x(),
        sim.v(),
        dir.join("A.mtx"),
        dir.join("b.mtx"),
    ) {
        return Err(staging.abandon(CliError::Failed(e.to_string())));
    }
    staging.commit()?;
    let record = ExportRecord {
        scene: args.scene.display().to_string(),
        t: sim.t(),
        h,
        steps,
        rows: sim.x().len(),
        matrix: a_path.display().to_string(),
        rhs: b_path.display().to_string(),
    };
    crate::outln!("{}", crate::to_json(&record, false)?)?;
    Ok(())
}

/// What `--every` prints: one JSON line.
#[derive(Debug, Serialize)]
struct SequenceRecord {
    scene: String,
    t: f64,
    steps: usize,
    every: usize,
    /// Linear solves of the run, and the systems written.
    solves: usize,
    systems: usize,
    out: String,
    index: String,
}

/// `--every K`: the scene run to its duration, every K-th PCG system written.
fn export_sequence(args: &ExportSystemArgs, every: usize) -> Result<(), CliError> {
    if every == 0 {
        return Err(CliError::Input(
            "--every must be at least 1 (1 writes every system)".into(),
        ));
    }
    let staging = crate::output::Staging::new(
        "export-system",
        &args.out,
        "--out",
        args.force,
        &[&args.scene],
    )?;
    match record_sequence(args, every, staging.dir()) {
        Ok(record) => {
            staging.commit()?;
            crate::outln!("{}", crate::to_json(&record, false)?)?;
            Ok(())
        }
        Err(e) => Err(staging.abandon(e)),
    }
}

/// Runs the scene with a [`SequenceWriter`] in its PCG solver, writing into `dir`.
fn record_sequence(
    args: &ExportSystemArgs,
    every: usize,
    dir: &std::path::Path,
) -> Result<SequenceRecord, CliError> {
    let (scene, _) = crate::scene::read_scene(&args.scene, &args.set)?;
    let mut sim = build_checked(&scene, args, scene.duration, "duration")?;
    let writer = Arc::new(Mutex::new(SequenceWriter::new(dir, every)));
    let shared: hookean::nonlinear::SharedRecorder = writer.clone();
    if !sim.record_linear_solves(Some(shared)) {
        return Err(CliError::Input(format!(
            "{}: integrator.method = \"{}\" solves no linear systems with PCG that can be recorded \
             (explicit methods, IMEX, the variable-order BDF and inexact simplified Newton do not); \
             --every needs an implicit method with Newton and PCG",
            args.scene.display(),
            sim.method()
        )));
    }
    let lock = |w: &Mutex<SequenceWriter>| {
        // The writer keeps its own errors: a poisoned lock holds nothing broken.
        let mut g = w.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        std::mem::replace(&mut *g, SequenceWriter::new(dir, every))
    };
    let mut progress = Progress::new(scene.duration, false);
    let result = sim.run_until_with(scene.duration, |sim, r| {
        progress.update(sim, r);
        let mut w = writer
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        w.next_step(sim.t());
        if w.error.is_some() {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        }
    });
    progress.clear();
    sim.record_linear_solves(None);
    let writer = lock(&writer);
    if let Some(e) = writer.error {
        return Err(CliError::Failed(e));
    }
    let summary = result.map_err(|e| {
        CliError::Failed(format!(
            "{}: simulation to t = {:?} failed: {e}",
            args.scene.display(),
            scene.duration
        ))
    })?;
    let (solves, systems) = writer.counts();
    if systems == 0 {
        return Err(CliError::Input(format!(
            "{}: the run to duration = {:?} s solved no linear system",
            args.scene.display(),
            scene.duration
        )));
    }
    let index = dir.join("index.csv");
    crate::output::write_text(&index, &writer.index())?;
    Ok(SequenceRecord {
        scene: args.scene.display().to_string(),
        t: sim.t(),
        steps: summary.stats.num_steps,
        every,
        solves,
        systems,
        out: args.out.display().to_string(),
        index: args.out.join("index.csv").display().to_string(),
    })
}
