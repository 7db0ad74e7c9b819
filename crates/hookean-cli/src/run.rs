//! `hookean run SCENE`: simulate a scene file and write its statistics,
//! per-step CSV, OBJ frames and a rendered picture of the last frame.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::Args;
use hookean::scene::Scene;
use hookean::sinks::{self, ObjFrames, ProgressInfo, StepsCsv};
use hookean::{HookeanError, RunSummary, Simulation, Sink, StateRecord};
use hookean_ode::tutorial::LinearOscillator;
use hookean_ode::{OdeError, StepReport};
use hookean_sparse::Short;
use indicatif::{ProgressBar, ProgressDrawTarget};
use serde::Serialize;

use crate::CliError;
use crate::render::{RenderScene, render};
use crate::run_outputs::Outputs;
use crate::run_resume::{Checkpoints, RunEnd, RunFolder, resume_scene, stopped, write_checkpoint};
use crate::scene::{PictureScene, ProgramKeys};
use crate::thin::Thinned;
use crate::view::{
    FrameEnergies, MeshFile, MeshFileKind, SummaryCollider, ViewCollider, ViewFrame, ViewRun,
};

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The scene file (TOML), e.g. scenes/drape.toml.
    pub(crate) scene: PathBuf,
    /// Output folder (default: out/<scene name>). It must not exist unless --force.
    #[arg(long)]
    pub(crate) out: Option<PathBuf>,
    /// Override a scene value: --set cloth.n=32 --set integrator.method=fb-euler
    /// (`hookean scene-keys` lists every key with its units and default).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub(crate) set: Vec<String>,
    /// Replace an existing output folder of an earlier run (once this run succeeds).
    #[arg(long)]
    pub(crate) force: bool,
    /// Continue the stopped run in RUN_FOLDER from its checkpoint (written
    /// every output.checkpoint_every seconds and at SIGINT/SIGTERM), with
    /// the scene and --set it was started with; the rest of its outputs go
    /// into RUN_FOLDER.
    #[arg(long, value_name = "RUN_FOLDER", conflicts_with_all = ["out", "force"])]
    pub(crate) resume: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Refuse scenes whose model would need more memory than this (GiB), in (0, the machine's memory].
    #[arg(
        long,
        value_name = "GIB",
        default_value_t = 8.0,
        allow_negative_numbers = true
    )]
    pub(crate) max_memory: f64,
    #[command(flatten)]
    work: crate::work::WorkCap,
}

/// The statistics of a run, as written to `summary.json`.
#[derive(Debug, Serialize)]
pub struct RunRecord {
    pub scene: String,
    pub method: String,
    pub particles: usize,
    pub springs: usize,
    pub steps: usize,
    pub rejected_steps: usize,
    pub newton_iterations: usize,
    pub cg_iterations: usize,
    pub f_evals: usize,
    pub jacobian_evals: usize,
    pub linear_setups: usize,
    pub wall_s: f64,
    /// Where `wall_s` went, in seconds: forming the Newton matrices,
    /// setting up the preconditioner, the linear solves, and the rest.
    pub phases_s: PhaseSeconds,
    /// Worker threads of the kernels (`--threads`, the scene's `threads`,
    /// `RAYON_NUM_THREADS` or all cores, in that order).
    pub threads: usize,
    pub simulated_s: f64,
    pub simulated_s_per_wall_s: f64,
    pub final_kinetic_energy: f64,
    pub final_total_energy: f64,
    pub frames: usize,
    /// OBJ frames per simulated second (`output.frame_rate`).
    pub frame_rate: f64,
    /// Simulated time of each `frame-NNNN.obj`.
    pub frame_times: Vec<f64>,
    /// The colliders, for viewers (`hookean view`): meshes by their file.
    pub colliders: Vec<SummaryCollider>,
}

/// The steps' wall time by phase (s), summed over the run's Newton solves.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PhaseSeconds {
    /// Forming `A = M - h df/dv - h^2 df/dx` (the Jacobian sweep).
    pub assembly: f64,
    /// Preconditioner set-ups and refills (MIC(0) factorisations, AMG hierarchies).
    pub preconditioner_setup: f64,
    /// PCG iterations with their preconditioner applications.
    pub solve: f64,
    /// Everything else in the steps: force evaluations, vector updates,
    /// filters, contact.
    pub other: f64,
}

impl PhaseSeconds {
    /// The phases of `stats` within the steps' wall time `wall`.
    pub fn of(stats: &hookean_ode::Stats, wall: f64) -> Self {
        let p = &stats.phases;
        let (assembly, preconditioner_setup, solve) = (
            p.assembly.as_secs_f64(),
            p.setup.as_secs_f64(),
            p.solve.as_secs_f64(),
        );
        Self {
            assembly,
            preconditioner_setup,
            solve,
            other: (wall - assembly - preconditioner_setup - solve).max(0.0),
        }
    }
}

/// The OBJ frames of a run ([`ObjFrames`]) and the same frames kept for
/// `view.html` (thinned within `thin::VIEW_BYTES`).
pub(crate) struct Frames {
    pub obj: ObjFrames,
    pub view: Thinned<ViewFrame>,
}

impl Frames {
    fn write_if_due(&mut self, sim: &Simulation) -> Result<(), HookeanError> {
        if self.obj.write_if_due(sim)? {
            self.view.push(view_frame(sim)?);
        }
        Ok(())
    }
}

impl Sink for Frames {
    fn start(&mut self, sim: &Simulation) -> Result<(), HookeanError> {
        self.write_if_due(sim)
    }

    fn step(&mut self, sim: &Simulation, _: &StepReport) -> Result<(), HookeanError> {
        self.write_if_due(sim)
    }
}

/// The current state as a frame of `view.html`.
fn view_frame(sim: &Simulation) -> Result<ViewFrame, HookeanError> {
    let e = sim.energies()?;
    Ok(ViewFrame {
        t: sim.t(),
        x: sim.x().to_vec(),
        speed: sim
            .v()
            .chunks_exact(3)
            .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
            .collect(),
        energies: Some(FrameEnergies {
            kinetic: e.kinetic,
            gravitational: e.gravitational,
            spring: e.spring,
        }),
    })
}

/// The model's colliders as viewers draw them.
fn colliders(sim: &Simulation) -> Vec<ViewCollider> {
    sim.model()
        .colliders()
        .iter()
        .map(ViewCollider::from)
        .collect()
}

/// The model's colliders as `summary.json` records them: planes and
/// spheres as drawn, each mesh by the file `scene` names for it (the
/// model's colliders are the scene's `[[collider]]` tables, in order).
fn summary_colliders(scene: &Scene, sim: &Simulation) -> Vec<SummaryCollider> {
    use hookean::massspring::Collider;
    use hookean::scene::ColliderScene;
    let model = sim.model().colliders();
    let by_table = model.len() == scene.colliders.len();
    model
        .iter()
        .enumerate()
        .map(|(k, c)| match (c, by_table.then(|| &scene.colliders[k])) {
            (
                Collider::Mesh { mesh, .. },
                Some(ColliderScene::Mesh {
                    path,
                    scale,
                    offset,
                    frames,
                    frame_interval,
                    ..
                }),
            ) => {
                let file = scene.resolve(path);
                let m = crate::view::rigid_motion_of(mesh);
                let absolute = |p: &std::path::PathBuf| {
                    let f = scene.resolve(p);
                    std::path::absolute(&f).unwrap_or(f)
                };
                let (keys, smooth) = match mesh.motion() {
                    hookean::massspring::ColliderMotion::Path(p) => crate::view::path_keys(p),
                    _ => (Vec::new(), false),
                };
                SummaryCollider::File(MeshFile {
                    kind: MeshFileKind::MeshFile,
                    path: path.clone(),
                    file: std::path::absolute(&file).unwrap_or(file),
                    scale: *scale,
                    offset: *offset,
                    vertices: mesh.mesh().vertices().len(),
                    triangles: mesh.mesh().triangles().len(),
                    velocity: m.velocity,
                    angular_velocity: m.angular_velocity,
                    pivot: m.pivot,
                    keys,
                    smooth,
                    frames: frames.iter().map(absolute).collect(),
                    frame_interval: (!frames.is_empty()).then_some(*frame_interval),
                })
            }
            (c, _) => SummaryCollider::Drawn(ViewCollider::from(c)),
        })
        .collect()
}

/// `view.html`'s content: the run's `summary` and recorded `frames` on the
/// model's triangles (or springs) and colliders.
fn view_of(sim: &Simulation, summary: serde_json::Value, frames: Vec<ViewFrame>) -> ViewRun {
    ViewRun {
        summary,
        faces: sim.model().faces().to_vec(),
        segments: sim.model().springs().iter().map(|s| (s.i, s.j)).collect(),
        colliders: colliders(sim),
        frames,
        speed_source: "particle velocities of the run".into(),
    }
}

/// `(t, z, exact z)` of the moving particle of the tutorial's example 3
/// (thinned within `thin::PLOT_POINTS`).
pub(crate) struct ParticleTrace {
    pub points: Thinned<(f64, f64, f64)>,
    exact: Option<LinearOscillator>,
}

impl ParticleTrace {
    fn push(&mut self, sim: &Simulation) {
        let t = sim.t();
        let exact = self.exact.map_or(f64::NAN, |o| o.exact(t)[0]);
        // Particle 0 is the pinned anchor; particle 1 moves along z.
        self.points.push((t, sim.x()[3 + 2], exact));
    }
}

impl Sink for ParticleTrace {
    fn step(&mut self, sim: &Simulation, _: &StepReport) -> Result<(), HookeanError> {
        self.push(sim);
        Ok(())
    }
}

/// The exact solution of example 3 when the scene keeps its model (the
/// default damping, no air friction, g = -10 m/s^2); `None` otherwise.
fn exact_example3(scene: &Scene) -> Option<LinearOscillator> {
    let m = &scene.model;
    (m.gravity == [0.0, 0.0, -10.0]
        && m.air_friction == 0.0
        && m.damping == hookean::scene::DampingScene::Projected)
        .then(LinearOscillator::example3)
}

/// What the facade's progress sink calls with each report.
type OnProgress = Box<dyn FnMut(&ProgressInfo)>;

/// The progress bar of a simulation up to `t_end`: simulated time, steps
/// per second, current step size (the facade's [`sinks::Progress`], drawn
/// by indicatif). Drawn only on a terminal, never if `quiet`.
pub struct Progress {
    bar: ProgressBar,
    inner: sinks::Progress<OnProgress>,
}

impl Progress {
    /// A bar over `[0, t_end]` simulated seconds.
    pub fn new(t_end: f64, quiet: bool) -> Self {
        let bar = ProgressBar::new((t_end * 1000.0) as u64);
        bar.set_draw_target(if quiet {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        });
        bar.set_style(crate::bar_style(
            "{bar:40} {percent:>3}% {msg} [{elapsed_precise}]",
        ));
        let drawn = bar.clone();
        let draw: OnProgress = Box::new(move |p: &ProgressInfo| {
            drawn.set_position((p.t * 1000.0) as u64);
            drawn.set_message(format!(
                "t = {:.3} s, {:.0} steps/s, h = {:.2e}",
                p.t, p.steps_per_s, p.h
            ));
        });
        Self {
            bar,
            inner: sinks::Progress::new(t_end, Duration::from_millis(100), draw),
        }
    }

    /// Records an accepted step.
    pub fn update(&mut self, sim: &Simulation, r: &StepReport) {
        // The facade's progress never fails.
        let _ = self.inner.step(sim, r);
    }

    /// Removes the bar.
    pub fn clear(&self) {
        self.bar.finish_and_clear();
    }
}

impl Sink for Progress {
    fn step(&mut self, sim: &Simulation, r: &StepReport) -> Result<(), HookeanError> {
        self.update(sim, r);
        Ok(())
    }

    fn finish(&mut self, _: &Simulation, _: &RunSummary) -> Result<(), HookeanError> {
        self.clear();
        Ok(())
    }
}

pub(crate) fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

/// The most OBJ frames one run writes (10 000 s at the default 10 per second).
pub(crate) const MAX_FRAMES: usize = 100_000;

/// `hookean run`; `threads` is the command's `--threads`, which wins over
/// the scene's `threads` key.
pub fn run(args: &RunArgs, threads: Option<usize>) -> Result<(), CliError> {
    let (scene, program) = crate::scene::read_scene(&args.scene, &args.set)?;
    match (threads, program.threads) {
        (None, Some(t)) => crate::threads::install(Some(t), || run_scene(args, &scene, &program))?,
        _ => run_scene(args, &scene, &program),
    }
}

fn run_scene(args: &RunArgs, scene: &Scene, program: &ProgramKeys) -> Result<(), CliError> {
    let max_bytes = crate::memory::cap_bytes(args.max_memory)?;
    if program.tutorial.is_some() {
        crate::tutorial_run::check_tables(scene, &args.scene)?;
        // A [tutorial] scene's step is a number (the scene refuses "auto").
        let h = scene.integrator.h.value().unwrap_or(f64::MIN_POSITIVE);
        check_work(args, scene, 1, h)?;
    }
    let name = args
        .scene
        .file_stem()
        .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
    if let Some(dir) = &args.resume {
        return resume_scene(args, scene, program, &name, max_bytes, dir);
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&name));
    let mut staging =
        crate::output::Staging::new("run", &out, "--out", args.force, &[&args.scene])?;
    let report = if let Some(t) = &program.tutorial {
        crate::tutorial_run::run(
            scene,
            t,
            &program.output,
            &args.scene,
            staging.dir(),
            args.quiet,
        )
        .map(RunEnd::Done)
    } else {
        let checkpoints = Checkpoints::new(args, program, None)?;
        run_model(
            args,
            scene,
            &program.output,
            &name,
            max_bytes,
            &mut staging,
            &checkpoints,
        )
    };
    match report {
        Ok(RunEnd::Stopped(t)) => {
            // Moved into place as a partial output, where --resume finds it.
            staging.publish()?;
            Err(stopped(args, t, &out))
        }
        Ok(RunEnd::Done(report)) => {
            staging.commit()?;
            if let Some(line) = report {
                crate::errln!("{line}; wrote {}", out.display());
            }
            Ok(())
        }
        Err(e) => Err(staging.abandon(e)),
    }
}

/// Why [`run_steps`] stopped short.
enum StepsFailed {
    /// The simulation (or an output sink) failed.
    Run(HookeanError),
    /// A checkpoint could not be written.
    Output(CliError),
}

/// Steps `sim` to `t_end`, writing `outputs` after every step and then
/// calling `after` (the checkpoints), which returns whether to stop now.
fn run_steps(
    sim: &mut Simulation,
    t_end: f64,
    outputs: &mut Outputs,
    mut after: impl FnMut(&Simulation, &mut Outputs) -> Result<bool, CliError>,
) -> Result<RunSummary, StepsFailed> {
    outputs.start(sim).map_err(StepsFailed::Run)?;
    let mut failure = None;
    let summary = sim
        .run_until_with(t_end, |sim, report| {
            if let Err(e) = outputs.step(sim, report) {
                failure = Some(StepsFailed::Run(e));
                return ControlFlow::Break(());
            }
            match after(sim, outputs) {
                Ok(false) => ControlFlow::Continue(()),
                Ok(true) => ControlFlow::Break(()),
                Err(e) => {
                    failure = Some(StepsFailed::Output(e));
                    ControlFlow::Break(())
                }
            }
        })
        .map_err(StepsFailed::Run)?;
    if let Some(e) = failure {
        return Err(e);
    }
    outputs.finish(sim, &summary).map_err(StepsFailed::Run)?;
    Ok(summary)
}

/// Refuses a run of `particles` particles at step `h` whose work is above
/// `--max-work` (a step counts at least [`MIN_STEP_WORK`](crate::work::MIN_STEP_WORK);
/// a variable-step method its step cap, [`scene_steps`](crate::work::scene_steps)).
fn check_work(args: &RunArgs, scene: &Scene, particles: usize, h: f64) -> Result<(), CliError> {
    let (steps, cause) =
        crate::work::scene_steps(scene, &args.scene, scene.duration, "duration", h)?;
    args.work.check(
        steps,
        (particles as f64).max(crate::work::MIN_STEP_WORK),
        &cause,
    )
}

/// What to change when a run stopped at its step cap (the library's
/// `TooManySteps`, in the user's key).
fn step_cap_hint(e: &HookeanError, scene: &Scene) -> String {
    // The facade's `Ode` is transparent (its `source` is the ODE error's
    // own), so the ODE error is looked at first, then every error in the
    // chain (a wrapper's cause).
    let mut next: Option<&(dyn std::error::Error + 'static)> = match e {
        HookeanError::Ode(ode) => Some(ode as &(dyn std::error::Error + 'static)),
        other => Some(other as &(dyn std::error::Error + 'static)),
    };
    let mut capped = false;
    while let Some(err) = next {
        let ode = err
            .downcast_ref::<OdeError>()
            .or_else(|| err.downcast_ref::<Box<OdeError>>().map(|b| &**b));
        capped |= matches!(ode, Some(OdeError::TooManySteps { .. }));
        next = err.source();
    }
    if capped {
        format!(
            "; raise integrator.max_steps = {} (range 1 to 1000000000), or loosen integrator.rtol / integrator.atol",
            scene.integrator.max_steps
        )
    } else {
        String::new()
    }
}

/// Runs a mass-spring scene, writing into `folder`; returns the one-line
/// report, or the time a signal stopped it (after a checkpoint).
pub(crate) fn run_model(
    args: &RunArgs,
    scene: &Scene,
    picture: &PictureScene,
    name: &str,
    max_bytes: u64,
    folder: &mut dyn RunFolder,
    checkpoints: &Checkpoints,
) -> Result<RunEnd, CliError> {
    let mut sim = scene.build_within(max_bytes).map_err(|e| match e {
        HookeanError::TooLarge { .. } => CliError::Input(format!(
            "{}: {e} (--max-memory raises the cap)",
            args.scene.display()
        )),
        e => CliError::Input(format!("{}: {e}", args.scene.display())),
    })?;
    // A variable-step method counts its step cap (h is only its first step).
    let h = sim.h_next();
    check_work(args, scene, sim.model().n_particles(), h)?;
    // At most one OBJ frame per step and MAX_FRAMES in all.
    let steps = if h.is_finite() {
        scene.duration / h
    } else {
        scene.integrator.max_steps as f64
    };
    let frames = (scene.duration * scene.output.frame_rate).min(steps) + 1.0;
    if scene.output.frame_rate > 0.0 && !(frames <= MAX_FRAMES as f64) {
        return Err(CliError::Input(format!(
            "{}: output.frame_rate = {:?} for duration = {:?} s is about {frames:.3e} frames, more than {MAX_FRAMES}; lower output.frame_rate",
            args.scene.display(),
            scene.output.frame_rate,
            scene.duration
        )));
    }
    // Whether this run can write checkpoints (its integrator, solver and
    // model are covered); with output.checkpoint_every a signal stops it
    // with one (without, a signal ends it as docs/RELIABILITY.md says).
    let covered = sim.save_state(&mut StateRecord::default());
    if let (Some(_), Err(e)) = (checkpoints.every, &covered) {
        return Err(CliError::Input(format!(
            "{}: output.checkpoint_every: {e}",
            args.scene.display()
        )));
    }
    if let Some((dir, record)) = &checkpoints.resume {
        let file = crate::checkpoint::path(dir);
        sim.restore_state(record)
            .map_err(|e| CliError::Input(format!("--resume {}: {e}", file.display())))?;
    }
    if checkpoints.every.is_some() {
        folder.publish()?;
    }
    if checkpoints.every.is_some() {
        crate::output::stop_at_signals();
    }
    let out = folder.dir().to_path_buf();

    let csv = match &checkpoints.resume {
        Some((_, record)) => {
            let len = record.count("out.csv_len").map_err(failed)?;
            StepsCsv::resume(out.join("steps.csv"), len as u64).map_err(failed)?
        }
        None => StepsCsv::create(out.join("steps.csv")).map_err(failed)?,
    };
    // No frames at output.frame_rate = 0.
    let frames = match scene.output.frame_rate {
        r if r > 0.0 => Some(Frames {
            obj: ObjFrames::new(&out, r).map_err(failed)?,
            view: Thinned::new(crate::thin::max_view_frames(sim.model().n_particles())),
        }),
        _ => None,
    };
    let progress = Progress::new(scene.duration, args.quiet);
    // The tutorial's example 3 ([particle]) is pictured as z(t) against its exact solution.
    let mut trace = scene.particle.as_ref().map(|_| ParticleTrace {
        points: Thinned::new(crate::thin::PLOT_POINTS),
        exact: exact_example3(scene),
    });
    if let (Some(t), None) = (&mut trace, &checkpoints.resume) {
        t.push(&sim);
    }
    let mut outputs = Outputs {
        csv,
        progress,
        trace,
        frames,
    };
    if let Some((dir, record)) = &checkpoints.resume {
        let file = crate::checkpoint::path(dir);
        let n = sim.model().n_particles();
        outputs = outputs.resume(record, &out, scene.output.frame_rate, n, &file)?;
    }
    let mut schedule = checkpoints
        .every
        .map(|every| crate::checkpoint::Schedule::new(every, sim.t()));
    let mut stop = None;
    let summary = run_steps(&mut sim, scene.duration, &mut outputs, |sim, outputs| {
        let signalled = crate::output::stop_requested();
        let due = schedule.as_ref().is_some_and(|s| s.due(sim.t()));
        if signalled || due {
            write_checkpoint(sim, outputs, &*folder, &checkpoints.hash)?;
            if let Some(s) = &mut schedule {
                s.pass(sim.t());
            }
        }
        if signalled {
            stop = Some(sim.t());
        }
        Ok(signalled)
    });
    if let (Ok(_), Some(t)) = (&summary, stop) {
        return Ok(RunEnd::Stopped(t));
    }
    // A finished run's folder holds what an uninterrupted one's does.
    crate::checkpoint::remove(&out);
    let (mut frames, trace) = (outputs.frames, outputs.trace);
    let summary = match summary {
        Ok(s) => s,
        Err(StepsFailed::Output(e)) => return Err(e),
        Err(StepsFailed::Run(e)) => {
            let mut message = if matches!(
                e,
                HookeanError::BlowUp { .. } | HookeanError::EnergyGain { .. }
            ) {
                format!("{}: {e}", args.scene.display())
            } else {
                format!(
                    "{}: the run stopped at t = {} s: {e}{}",
                    args.scene.display(),
                    Short(sim.t()),
                    step_cap_hint(&e, scene)
                )
            };
            // The frames up to the failure show how it went wrong.
            if let Some(frames) = frames.as_mut().filter(|f| !f.view.items().is_empty()) {
                let stats = sim.stats();
                let summary = serde_json::json!({
                    "scene": args.scene.display().to_string(),
                    "method": sim.method().to_string(),
                    "error": message,
                    "steps": stats.num_steps,
                    "rejected_steps": stats.num_rejected_steps(),
                    "newton_iterations": stats.num_nonlin_solv_iters,
                    "cg_iterations": stats.num_lin_iters,
                });
                let view = view_of(&sim, summary, frames.view.take());
                if view.write(&out.join("view.html")).is_ok() {
                    message += &format!(
                        "; {} shows the frames before",
                        out.join("view.html").display()
                    );
                }
            }
            return Err(CliError::Failed(message));
        }
    };
    let energies = sim.energies().map_err(failed)?;
    let s = summary.stats;
    // The whole run's (a resumed run's too: its first part's are in the
    // checkpoint; the run starts at t = 0).
    let wall = sim.wall().as_secs_f64();
    let record = RunRecord {
        scene: args.scene.display().to_string(),
        method: sim.method().to_string(),
        particles: sim.model().n_particles(),
        springs: sim.model().springs().len(),
        steps: s.num_steps,
        rejected_steps: s.num_rejected_steps(),
        newton_iterations: s.num_nonlin_solv_iters,
        cg_iterations: s.num_lin_iters,
        f_evals: s.num_rhs_evals_total(),
        jacobian_evals: s.num_jac_evals,
        linear_setups: s.num_lin_solv_setups,
        wall_s: wall,
        phases_s: PhaseSeconds::of(&s, wall),
        threads: crate::threads::current(),
        simulated_s: sim.t(),
        simulated_s_per_wall_s: sim.t() / wall.max(1e-12),
        final_kinetic_energy: energies.kinetic,
        final_total_energy: energies.total(),
        frames: frames.as_ref().map_or(0, |f| f.obj.times().len()),
        frame_rate: scene.output.frame_rate,
        frame_times: frames
            .as_ref()
            .map_or_else(Vec::new, |f| f.obj.times().to_vec()),
        colliders: summary_colliders(scene, &sim),
    };
    // The point cache of the frames (the scene refuses a cache without frames).
    if let Some(format) = scene.output.cache {
        crate::export_cache::write_in_run(
            &out,
            &record.frame_times,
            scene.output.frame_rate,
            format,
        )?;
    }
    let json = crate::to_json(&record, true)?;
    let summary_path = out.join("summary.json");
    crate::output::write_text(&summary_path, &(json + "\n"))?;

    // view.html: the recorded frames (the last state alone without frames).
    let mut view_frames = frames.as_mut().map_or_else(Vec::new, |f| f.view.take());
    let last = view_frame(&sim).map_err(failed)?;
    let last_is_a_frame = view_frames.last().is_some_and(|f| f.t == last.t);
    if !last_is_a_frame {
        view_frames.push(last);
    }
    let view = view_of(
        &sim,
        serde_json::to_value(&record).map_err(failed)?,
        view_frames,
    );

    // final.png: the last state on the run's scale (box and speeds of every frame).
    let canvas = match &trace {
        Some(ParticleTrace { points, .. }) => crate::plot::TimePlot {
            title: "Tutorial example 3: particle on a damped spring",
            y_label: "height z (m)",
            numerical: &format!("{} (h = {} s)", sim.method(), sim.h_next()),
            points: points.items(),
        }
        .draw(picture.width, picture.height),
        None => render(
            &RenderScene {
                x: sim.x(),
                v: sim.v(),
                faces: &view.faces,
                segments: &view.segments,
                colliders: &view.colliders,
                bounds: view.bounds(),
                speed_max: view.speed_max(),
                t: sim.t(),
            },
            picture.width,
            picture.height,
        ),
    }
    .map_err(CliError::Failed)?;
    canvas
        .write_png(&out.join("final.png"))
        .map_err(CliError::Failed)?;
    let mut view = view;
    if !last_is_a_frame {
        view.frames.pop();
    }
    if view.frames.is_empty() {
        view.frames.push(view_frame(&sim).map_err(failed)?);
    }
    view.write(&out.join("view.html"))?;
    let p = &record.phases_s;
    Ok(RunEnd::Done(Some(format!(
        "{}: {} steps, {} Newton and {} CG iterations, {:.2} s wall (assembly {:.2}, preconditioner set-up {:.2}, solve {:.2}, other {:.2}) for {:.2} s simulated ({:.2}x real time)",
        name,
        s.num_steps,
        s.num_nonlin_solv_iters,
        s.num_lin_iters,
        record.wall_s,
        p.assembly,
        p.preconditioner_setup,
        p.solve,
        p.other,
        record.simulated_s,
        record.simulated_s_per_wall_s,
    ))))
}
