//! `hookean run` for `[tutorial]` scenes: the tutorial's scalar examples 1
//! and 2 integrated as first-order systems, with the exact solution beside
//! the numerical one in `steps.csv`, `summary.json` and `final.png`.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use hookean::scene::{Scene, TutorialScene};
use hookean_ode::tutorial::{Dahlquist, LinearOscillator};
use hookean_ode::{FirstOrderIntegrator, FirstOrderProblem};
use serde::Serialize;

use crate::CliError;
use crate::render::Canvas;

#[derive(Debug, Serialize)]
struct TutorialRecord {
    scene: String,
    example: u8,
    method: String,
    steps: usize,
    rejected_steps: usize,
    newton_iterations: usize,
    f_evals: usize,
    jacobian_evals: usize,
    wall_s: f64,
    simulated_s: f64,
    y_final: f64,
    exact_final: f64,
    error_final: f64,
}

/// Runs a `[tutorial]` scene into `out`.
pub fn run(
    scene: &Scene,
    t: &TutorialScene,
    scene_path: &Path,
    out: &Path,
    quiet: bool,
) -> Result<(), CliError> {
    match t.example {
        1 => {
            let p = Dahlquist { lambda: t.lambda };
            integrate(
                scene,
                t.example,
                p,
                &[1.0],
                |s| p.exact(s),
                scene_path,
                out,
                quiet,
            )
        }
        _ => {
            let osc = LinearOscillator::example2();
            integrate(
                scene,
                t.example,
                osc.first_order(),
                &osc.y0(),
                |s| osc.exact(s)[0],
                scene_path,
                out,
                quiet,
            )
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn integrate<P: FirstOrderProblem>(
    scene: &Scene,
    example: u8,
    problem: P,
    y0: &[f64],
    exact: impl Fn(f64) -> f64,
    scene_path: &Path,
    out: &Path,
    quiet: bool,
) -> Result<(), CliError> {
    let options = scene.simulation_options();
    let method = options.method.clone();
    let mut ode = FirstOrderIntegrator::new(problem, method, 0.0, y0, options.solver)
        .map_err(|e| CliError::Input(e.to_string()))?;
    let mut csv = String::from("t,h,newton_iterations,linear_iterations,y,exact,error\n");
    let mut points = vec![(0.0, y0[0], exact(0.0))];
    let start = Instant::now();
    while ode.t() < scene.duration - 1e-12 * scene.duration {
        let r = ode.step().map_err(|e| {
            CliError::Failed(format!(
                "{}: the run stopped at t = {:.4}: {e}",
                scene_path.display(),
                ode.t()
            ))
        })?;
        let (y, e) = (ode.y()[0], exact(ode.t()));
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{}",
            ode.t(),
            r.h,
            r.newton_iterations,
            r.linear_iterations,
            y,
            e,
            y - e
        );
        points.push((ode.t(), y, e));
        if ode.t() >= scene.duration {
            break;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let write = |name: &str, text: String| -> Result<(), CliError> {
        let path = out.join(name);
        std::fs::write(&path, text)
            .map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))
    };
    write("steps.csv", csv)?;
    let s = ode.stats();
    let (y, e) = (ode.y()[0], exact(ode.t()));
    let record = TutorialRecord {
        scene: scene_path.display().to_string(),
        example,
        method: ode.method().to_string(),
        steps: s.steps,
        rejected_steps: s.rejected_steps,
        newton_iterations: s.newton_iterations,
        f_evals: s.f_evals,
        jacobian_evals: s.jacobian_evals,
        wall_s: wall,
        simulated_s: ode.t(),
        y_final: y,
        exact_final: e,
        error_final: (y - e).abs(),
    };
    write(
        "summary.json",
        serde_json::to_string_pretty(&record).expect("serialises") + "\n",
    )?;
    plot(&points, scene.output.width, scene.output.height)
        .write_png(&out.join("final.png"))
        .map_err(CliError::Failed)?;
    if !quiet {
        eprintln!(
            "tutorial example {example}: {} steps, y({:.3}) = {y:.6e}, exact {e:.6e}, error {:.2e}; wrote {}",
            s.steps,
            ode.t(),
            (y - e).abs(),
            out.display()
        );
    }
    Ok(())
}

/// The numerical solution (blue) over the exact one (grey) against time.
fn plot(points: &[(f64, f64, f64)], width: usize, height: usize) -> Canvas {
    let mut c = Canvas::new(width, height);
    let t_end = points.last().map_or(1.0, |p| p.0).max(1e-12);
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            let (a, b) = (p.1.min(p.2), p.1.max(p.2));
            let (a, b) = if a.is_finite() && b.is_finite() {
                (a, b)
            } else {
                (lo, hi)
            };
            (lo.min(a), hi.max(b))
        });
    let span = (hi - lo).max(1e-12);
    let margin = 0.08;
    let px = |t: f64, y: f64| -> [f64; 2] {
        let x = (margin + (1.0 - 2.0 * margin) * t / t_end) * width as f64;
        let y = (1.0 - margin - (1.0 - 2.0 * margin) * (y - lo) / span) * height as f64;
        [x, y.clamp(-10.0, height as f64 + 10.0)]
    };
    // Axes: t along the bottom, y at the left.
    let axis = [90, 90, 90];
    c.thick_line(px(0.0, lo), px(t_end, lo), 1.0, axis);
    c.thick_line(px(0.0, lo), px(0.0, hi), 1.0, axis);
    for w in points.windows(2) {
        c.thick_line(px(w[0].0, w[0].2), px(w[1].0, w[1].2), 3.0, [170, 170, 170]);
    }
    for w in points.windows(2) {
        if w[0].1.is_finite() && w[1].1.is_finite() {
            c.thick_line(px(w[0].0, w[0].1), px(w[1].0, w[1].1), 1.5, [30, 80, 200]);
        }
    }
    c
}
