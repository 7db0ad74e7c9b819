//! `hookean run SCENE`: simulate a scene file and write its statistics,
//! per-step CSV, OBJ frames and a rendered picture of the last frame.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use hookean::scene::Scene;
use hookean::{HookeanError, RunSummary, Simulation, Sink};
use hookean_ode::StepReport;
use hookean_ode::tutorial::LinearOscillator;
use indicatif::{ProgressBar, ProgressDrawTarget};
use serde::Serialize;

use crate::CliError;
use crate::render::{RenderScene, render};
use crate::view::{FrameEnergies, ViewCollider, ViewFrame, ViewRun};

#[derive(Debug, Args)]
pub struct RunArgs {
    /// The scene file (TOML), e.g. scenes/drape.toml.
    scene: PathBuf,
    /// Output folder (default: out/<scene name>). It must not exist unless --force.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override a scene value: --set cloth.n=32 --set integrator.method=fb-euler
    /// (`hookean scene-keys` lists every key with its units and default).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Replace an existing output folder of an earlier run (once this run succeeds).
    #[arg(long)]
    force: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Refuse scenes whose model would need more memory than this (GiB).
    #[arg(
        long,
        value_name = "GIB",
        default_value_t = 8.0,
        allow_negative_numbers = true
    )]
    max_memory: f64,
    #[command(flatten)]
    work: crate::work::WorkCap,
}

/// `--max-memory` in bytes.
pub fn max_memory_bytes(gib: f64) -> Result<u64, CliError> {
    if gib > 0.0 && gib.is_finite() {
        Ok((gib * (1u64 << 30) as f64).min(u64::MAX as f64) as u64)
    } else {
        Err(CliError::Input(format!(
            "--max-memory must be a positive number of GiB, got {gib:?}"
        )))
    }
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
    /// Simulated time of each `frame-NNNN.obj`.
    pub frame_times: Vec<f64>,
    /// The colliders, for viewers (`hookean view`).
    pub colliders: Vec<ViewCollider>,
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

/// One row per accepted step.
struct StepsCsv {
    out: BufWriter<File>,
    path: PathBuf,
}

impl StepsCsv {
    fn create(path: PathBuf) -> Result<Self, HookeanError> {
        let file = crate::output::new_file(&path).map_err(|e| io_error(&path, e))?;
        let mut out = BufWriter::new(file);
        writeln!(
            out,
            "t,h,newton_iterations,cg_iterations,kinetic,gravitational,spring,total"
        )
        .map_err(|e| io_error(&path, e))?;
        Ok(Self { out, path })
    }
}

impl Sink for StepsCsv {
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
        .map_err(|e| io_error(&self.path, e))
    }

    fn finish(&mut self, _: &Simulation, _: &RunSummary) -> Result<(), HookeanError> {
        self.out.flush().map_err(|e| io_error(&self.path, e))
    }
}

/// OBJ frames at a fixed rate of simulated time, coloured by speed, and the
/// same frames kept for `view.html`.
struct ObjFrames {
    dir: PathBuf,
    interval: f64,
    next: f64,
    count: usize,
    view: Vec<ViewFrame>,
}

impl ObjFrames {
    fn write(&mut self, sim: &Simulation) -> Result<(), HookeanError> {
        let path = self.dir.join(format!("frame-{:04}.obj", self.count));
        let file = crate::output::new_file(&path).map_err(|e| io_error(&path, e))?;
        let colours = hookean::massspring::speed_colours(sim.v(), 0.0);
        sim.model()
            .write_obj(BufWriter::new(file), sim.x(), Some(&colours))?;
        self.view.push(view_frame(sim)?);
        self.count += 1;
        self.next += self.interval;
        Ok(())
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

impl Sink for ObjFrames {
    fn step(&mut self, sim: &Simulation, _: &StepReport) -> Result<(), HookeanError> {
        if sim.t() >= self.next - 1e-9 * self.interval {
            self.write(sim)?;
        }
        Ok(())
    }
}

/// The model's colliders as viewers draw them.
fn colliders(sim: &Simulation) -> Vec<ViewCollider> {
    sim.model()
        .colliders()
        .iter()
        .map(ViewCollider::from)
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

/// `(t, z, exact z)` of the moving particle of the tutorial's example 3.
struct ParticleTrace {
    points: Vec<(f64, f64, f64)>,
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

/// The progress bar of a simulation up to `t_end`: simulated time, steps
/// per second, current step size. Drawn only on a terminal, never if `quiet`.
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    steps: usize,
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
        Self {
            bar,
            start: Instant::now(),
            steps: 0,
        }
    }

    /// Records an accepted step (redraws every 8 steps).
    pub fn update(&mut self, sim: &Simulation, r: &StepReport) {
        self.steps += 1;
        if self.steps.is_multiple_of(8) {
            let rate = self.steps as f64 / self.start.elapsed().as_secs_f64().max(1e-9);
            self.bar.set_position((sim.t() * 1000.0) as u64);
            self.bar.set_message(format!(
                "t = {:.3} s, {rate:.0} steps/s, h = {:.2e}",
                sim.t(),
                r.h
            ));
        }
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

fn io_error(path: &Path, e: std::io::Error) -> HookeanError {
    HookeanError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

/// `hookean run`; `threads` is the command's `--threads`, which wins over
/// the scene's `threads` key.
pub fn run(args: &RunArgs, threads: Option<usize>) -> Result<(), CliError> {
    let scene =
        Scene::from_file(&args.scene, &args.set).map_err(|e| CliError::Input(e.to_string()))?;
    match (threads, scene.threads) {
        (None, Some(t)) => crate::threads::install(Some(t), || run_scene(args, &scene))?,
        _ => run_scene(args, &scene),
    }
}

fn run_scene(args: &RunArgs, scene: &Scene) -> Result<(), CliError> {
    let max_bytes = max_memory_bytes(args.max_memory)?;
    if scene.tutorial.is_some() {
        // A [tutorial] scene's step is a number (the scene refuses "auto").
        let h = scene.integrator.h.value().unwrap_or(f64::MIN_POSITIVE);
        check_work(args, scene, 1, h)?;
    }
    let name = args
        .scene
        .file_stem()
        .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join(&name));
    let staging = crate::output::Staging::new(&out, "--out", args.force, &[&args.scene])?;
    let report = if let Some(t) = &scene.tutorial {
        crate::tutorial_run::run(scene, t, &args.scene, staging.dir(), args.quiet)
    } else {
        run_model(args, scene, &name, max_bytes, staging.dir())
    };
    match report {
        Ok(report) => {
            staging.commit()?;
            if let Some(line) = report {
                eprintln!("{line}; wrote {}", out.display());
            }
            Ok(())
        }
        Err(e) => Err(staging.abandon(e)),
    }
}

/// Refuses a run of `particles` particles at step `h` whose work is above `--max-work`.
fn check_work(args: &RunArgs, scene: &Scene, particles: usize, h: f64) -> Result<(), CliError> {
    let auto = if scene.integrator.h.value().is_none() {
        " (\"auto\")"
    } else {
        ""
    };
    args.work.check(
        scene.duration / h,
        particles as f64,
        &format!(
            "{}: duration = {:?} s at integrator.h = {h:?} s{auto}",
            args.scene.display(),
            scene.duration,
        ),
    )
}

/// Runs a mass-spring scene, writing into `out`; returns the one-line report.
fn run_model(
    args: &RunArgs,
    scene: &Scene,
    name: &str,
    max_bytes: u64,
    out: &Path,
) -> Result<Option<String>, CliError> {
    let out = out.to_path_buf();
    let mut sim = scene.build_within(max_bytes).map_err(|e| match e {
        HookeanError::TooLarge { .. } => CliError::Input(format!(
            "{}: {e} (--max-memory raises the cap)",
            args.scene.display()
        )),
        e => CliError::Input(format!("{}: {e}", args.scene.display())),
    })?;
    check_work(args, scene, sim.model().n_particles(), sim.h_next())?;

    let mut csv = StepsCsv::create(out.join("steps.csv")).map_err(failed)?;
    let mut frames = ObjFrames {
        dir: out.clone(),
        interval: if scene.output.frame_rate > 0.0 {
            1.0 / scene.output.frame_rate
        } else {
            f64::INFINITY
        },
        next: 0.0,
        count: 0,
        view: Vec::new(),
    };
    if scene.output.frame_rate > 0.0 {
        frames.write(&sim).map_err(failed)?;
    }
    let mut progress = Progress::new(scene.duration, args.quiet);
    // The tutorial's example 3 ([particle]) is pictured as z(t) against its exact solution.
    let mut trace = scene.particle.as_ref().map(|_| ParticleTrace {
        points: vec![],
        exact: exact_example3(scene),
    });
    if let Some(t) = &mut trace {
        t.push(&sim);
    }
    let summary = {
        let mut sinks: Vec<&mut dyn Sink> = vec![&mut csv, &mut progress];
        if let Some(t) = &mut trace {
            sinks.push(t);
        }
        if scene.output.frame_rate > 0.0 {
            sinks.push(&mut frames);
        }
        sim.run_with_sinks(scene.duration, &mut sinks)
    };
    let summary = match summary {
        Ok(s) => s,
        Err(e) => {
            let mut message = if matches!(e, HookeanError::BlowUp { .. }) {
                format!("{}: {e}", args.scene.display())
            } else {
                format!(
                    "{}: the run stopped at t = {:.4} s: {e}",
                    args.scene.display(),
                    sim.t()
                )
            };
            // The frames up to the failure show how it went wrong.
            if !frames.view.is_empty() {
                let stats = sim.stats();
                let summary = serde_json::json!({
                    "scene": args.scene.display().to_string(),
                    "method": sim.method().to_string(),
                    "error": message,
                    "steps": stats.steps,
                    "rejected_steps": stats.rejected_steps,
                    "newton_iterations": stats.newton_iterations,
                    "cg_iterations": stats.linear_iterations,
                });
                let view = view_of(&sim, summary, std::mem::take(&mut frames.view));
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
    let record = RunRecord {
        scene: args.scene.display().to_string(),
        method: sim.method().to_string(),
        particles: sim.model().n_particles(),
        springs: sim.model().springs().len(),
        steps: s.steps,
        rejected_steps: s.rejected_steps,
        newton_iterations: s.newton_iterations,
        cg_iterations: s.linear_iterations,
        f_evals: s.f_evals,
        jacobian_evals: s.jacobian_evals,
        linear_setups: s.linear_setups,
        wall_s: summary.wall.as_secs_f64(),
        phases_s: PhaseSeconds::of(&s, summary.wall.as_secs_f64()),
        threads: crate::threads::current(),
        simulated_s: summary.simulated,
        simulated_s_per_wall_s: summary.speed(),
        final_kinetic_energy: energies.kinetic,
        final_total_energy: energies.total(),
        frames: frames.count,
        frame_times: frames.view.iter().map(|f| f.t).collect(),
        colliders: colliders(&sim),
    };
    let json = crate::to_json(&record, true)?;
    let summary_path = out.join("summary.json");
    crate::output::write_text(&summary_path, &(json + "\n"))?;

    // view.html: the recorded frames (the last state alone without frames).
    let mut view_frames = std::mem::take(&mut frames.view);
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
            points,
        }
        .draw(scene.output.width, scene.output.height),
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
            scene.output.width,
            scene.output.height,
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
    Ok(Some(format!(
        "{}: {} steps, {} Newton and {} CG iterations, {:.2} s wall (assembly {:.2}, preconditioner set-up {:.2}, solve {:.2}, other {:.2}) for {:.2} s simulated ({:.2}x real time)",
        name,
        s.steps,
        s.newton_iterations,
        s.linear_iterations,
        record.wall_s,
        p.assembly,
        p.preconditioner_setup,
        p.solve,
        p.other,
        record.simulated_s,
        record.simulated_s_per_wall_s,
    )))
}
