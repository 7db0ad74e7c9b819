//! `hookean run` for `[tutorial]` scenes: the tutorial's scalar examples 1
//! and 2 integrated as first-order systems, with the exact solution beside
//! the numerical one in `steps.csv`, `summary.json` and `final.png`.

use hookean_ode::Integrator;
use std::io::Write as _;
use std::path::Path;
use std::time::Instant;

use hookean::scene::Scene;
use hookean_ode::tutorial::{Dahlquist, LinearOscillator};
use hookean_ode::{FirstOrderIntegrator, FirstOrderProblem};
use serde::Serialize;

use crate::CliError;
use crate::scene::{PictureScene, TutorialScene};
use crate::thin::Thinned;

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

/// Runs a `[tutorial]` scene into `out`; returns the one-line report
/// (`None` when `quiet`).
pub fn run(
    scene: &Scene,
    t: &TutorialScene,
    picture: &PictureScene,
    scene_path: &Path,
    out: &Path,
    quiet: bool,
) -> Result<Option<String>, CliError> {
    match t.example {
        1 => {
            let p = Dahlquist { lambda: t.lambda };
            integrate(
                (scene, t, picture),
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
                (scene, t, picture),
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
fn integrate<P: FirstOrderProblem + Send + 'static>(
    (scene, tutorial, picture): (&Scene, &TutorialScene, &PictureScene),
    problem: P,
    y0: &[f64],
    exact: impl Fn(f64) -> f64,
    scene_path: &Path,
    out: &Path,
    quiet: bool,
) -> Result<Option<String>, CliError> {
    let options = scene.simulation_options();
    let method = options.method.clone();
    let mut ode = FirstOrderIntegrator::new(problem, method, 0.0, y0, options.solver)
        .map_err(|e| CliError::Input(e.to_string()))?;
    // steps.csv is streamed; the picture's points are thinned (crate::thin).
    let csv_path = out.join("steps.csv");
    let csv_error = |e: std::io::Error| CliError::Failed(format!("{}: {e}", csv_path.display()));
    let mut csv = std::io::BufWriter::new(crate::output::new_file(&csv_path).map_err(csv_error)?);
    writeln!(csv, "t,h,newton_iterations,linear_iterations,y,exact,error").map_err(csv_error)?;
    let mut points = Thinned::new(crate::thin::PLOT_POINTS);
    points.push((0.0, y0[0], exact(0.0)));
    let start = Instant::now();
    while ode.t() < scene.duration - 1e-12 * scene.duration {
        let r = ode.step().map_err(|e| {
            CliError::Failed(format!(
                "{}: the run stopped at t = {}: {e}",
                scene_path.display(),
                hookean_sparse::Short(ode.t())
            ))
        })?;
        let (y, e) = (ode.y()[0], exact(ode.t()));
        writeln!(
            csv,
            "{},{},{},{},{},{},{}",
            ode.t(),
            r.h,
            r.newton_iterations,
            r.linear_iterations,
            y,
            e,
            y - e
        )
        .map_err(csv_error)?;
        points.push((ode.t(), y, e));
        if ode.t() >= scene.duration {
            break;
        }
    }
    let wall = start.elapsed().as_secs_f64();
    let write = |name: &str, text: String| -> Result<(), CliError> {
        let path = out.join(name);
        crate::output::write_text(&path, &text)
    };
    csv.flush().map_err(csv_error)?;
    let s = ode.stats();
    let (y, e) = (ode.y()[0], exact(ode.t()));
    let record = TutorialRecord {
        scene: scene_path.display().to_string(),
        example: tutorial.example,
        method: ode.method().to_string(),
        steps: s.num_steps,
        rejected_steps: s.num_rejected_steps(),
        newton_iterations: s.num_nonlin_solv_iters,
        f_evals: s.num_rhs_evals_total(),
        jacobian_evals: s.num_jac_evals,
        wall_s: wall,
        simulated_s: ode.t(),
        y_final: y,
        exact_final: e,
        error_final: (y - e).abs(),
    };
    write("summary.json", crate::to_json(&record, true)? + "\n")?;
    let example = tutorial.example;
    let title = match example {
        1 => format!("Tutorial example 1: y' = {} y, y(0) = 1", tutorial.lambda),
        _ => "Tutorial example 2: y'' = -5/2 y - 5 y'".to_string(),
    };
    crate::plot::TimePlot {
        title: &title,
        y_label: "y",
        numerical: &format!("{} (h = {} s)", ode.method(), ode.options().h),
        points: points.items(),
    }
    .draw(picture.width, picture.height)
    .and_then(|c| c.write_png(&out.join("final.png")))
    .map_err(CliError::Failed)?;
    Ok((!quiet).then(|| {
        format!(
            "tutorial example {example}: {} steps, y({:.3}) = {y:.6e}, exact {e:.6e}, error {:.2e}",
            s.num_steps,
            ode.t(),
            (y - e).abs(),
        )
    }))
}

/// Refuses the tables of a `[tutorial]` scene that its scalar example
/// would ignore, naming the table, as the facade refuses a `[filter]` on an
/// implicit method: the examples have no particles to filter, collide or
/// pin.
pub(crate) fn check_tables(scene: &Scene, path: &Path) -> Result<(), CliError> {
    let ignored = if scene.filter.is_some() {
        Some("[filter]")
    } else if !scene.colliders.is_empty() {
        Some("[collider 1]")
    } else if scene.contact.self_collision {
        Some("[contact]")
    } else {
        None
    };
    match ignored {
        Some(table) => Err(CliError::Input(format!(
            "{}: {table}: a [tutorial] scene is a scalar ODE without particles; \
             its example would ignore this table (remove it, or use a model table)",
            path.display()
        ))),
        None => Ok(()),
    }
}
