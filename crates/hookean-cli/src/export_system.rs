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

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use crate::CliError;
use crate::run::Progress;

#[derive(Debug, Args)]
pub struct ExportSystemArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Simulated time of the exported state (s); 0 is the initial state.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    at: f64,
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

pub fn run(args: &ExportSystemArgs) -> Result<(), CliError> {
    if !(args.at >= 0.0 && args.at.is_finite()) {
        return Err(CliError::Input(format!(
            "--at must be a non-negative time, got {:?}",
            args.at
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
    let (particles, _) = scene.particle_count();
    // Steps to --at as `run` counts them (a variable-step method: its step cap).
    let check_work = |h: f64| -> Result<(), CliError> {
        let (steps, cause) = crate::work::scene_steps(&scene, &args.scene, args.at, "--at", h)?;
        args.work.check(
            steps,
            particles.map_or(f64::INFINITY, |p| {
                (p as f64).max(crate::work::MIN_STEP_WORK)
            }),
            &cause,
        )
    };
    // "auto" is known once the model is built.
    if let Some(h) = scene.integrator.h.value() {
        check_work(h)?;
    }
    let mut sim = scene
        .build()
        .map_err(|e| input(format!("{}: {e}", args.scene.display())))?;
    check_work(sim.h_next())?;
    let mut steps = 0;
    if args.at > 0.0 {
        // A bar on a terminal: simulating to a late --at can take a while.
        let mut progress = Progress::new(args.at, false);
        let result = sim.run_until_with(args.at, |sim, r| {
            progress.update(sim, r);
            std::ops::ControlFlow::Continue(())
        });
        progress.clear();
        // A blow-up or a solver failure of a valid scene: a failed run (exit 1).
        let summary = result.map_err(|e| {
            CliError::Failed(format!(
                "{}: simulation to t = {:?} failed: {e}",
                args.scene.display(),
                args.at
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
