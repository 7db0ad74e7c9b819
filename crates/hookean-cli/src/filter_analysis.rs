//! `hookean filter-analysis SCENE --plot DIR`: the filtering paper's figures
//! 4 (velocities over time as RGB, one row per step), 5 (2D spectrum of the
//! final velocity field) and 6 (stable step against the filter's lambda),
//! for the cloth of a scene (its stiffness, damping and mass; the analysis
//! runs on an `--n x --n` grid so that explicit runs stay affordable).

use std::path::{Path, PathBuf};

use clap::Args;
use hookean::scene::Scene;
use hookean_filter::{
    BisectionOptions, DrapeMethod, ExplicitScheme, FilterOptions, RunOptions, drape_velocity_run,
    fftshift, predict_dt_max, stable_step_against_lambda,
};
use hookean_massspring::{ClothParams, cloth as cloth_model};
use hookean_ode::Method;
use serde::Serialize;

use crate::CliError;
use crate::render::Canvas;
use crate::svg::{LogLogPlot, Series};

#[derive(Debug, Args)]
pub struct FilterAnalysisArgs {
    /// A scene with a [cloth] table (e.g. scenes/drape.toml).
    scene: PathBuf,
    /// Output folder for fig4-*.png, fig5-*.png, fig6.svg and analysis.json.
    #[arg(long)]
    plot: PathBuf,
    /// Particles per side of the analysed cloth.
    #[arg(long, default_value_t = 16)]
    n: usize,
    /// Simulated seconds of the figure-4 runs.
    #[arg(long, default_value_t = 1.0)]
    t_end: f64,
    /// Step of the figure-4 runs, as a fraction of the unfiltered FB Euler limit dt_max.
    #[arg(long, default_value_t = 0.9)]
    step_fraction: f64,
    /// Write into an existing folder.
    #[arg(long)]
    force: bool,
}

#[derive(Debug, Serialize)]
struct Figure4Row {
    method: &'static str,
    h: f64,
    bounded: bool,
    final_high_frequency_fraction: f64,
    mean_high_frequency_fraction: f64,
}

#[derive(Debug, Serialize)]
struct Figure6Row {
    lambda: Option<f64>,
    measured_dt: f64,
    predicted_dt: f64,
    k0: f64,
}

#[derive(Debug, Serialize)]
struct Analysis {
    n: usize,
    stiffness: f64,
    damping: f64,
    dt_max_unfiltered: f64,
    figure4: Vec<Figure4Row>,
    figure6: Vec<Figure6Row>,
}

fn input(e: impl std::fmt::Display) -> CliError {
    CliError::Input(e.to_string())
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

pub fn run(args: &FilterAnalysisArgs) -> Result<(), CliError> {
    let scene = Scene::from_file(&args.scene, &[]).map_err(input)?;
    let cloth = scene.cloth_params().ok_or_else(|| {
        CliError::Input(format!(
            "{}: filter-analysis needs a [cloth] scene",
            args.scene.display()
        ))
    })?;
    if args.n < 4 {
        return Err(CliError::Input(format!(
            "--n must be at least 4, got {}",
            args.n
        )));
    }
    if !(args.t_end > 0.0 && args.t_end.is_finite()) {
        return Err(CliError::Input(format!(
            "--t-end must be positive, got {}",
            args.t_end
        )));
    }
    if !(args.step_fraction > 0.0 && args.step_fraction <= 2.0) {
        return Err(CliError::Input(format!(
            "--step-fraction must lie in (0, 2], got {}",
            args.step_fraction
        )));
    }
    if args.plot.exists() && !args.force {
        return Err(CliError::Input(format!(
            "output folder {} exists; pass --force to write into it",
            args.plot.display()
        )));
    }
    std::fs::create_dir_all(&args.plot)
        .map_err(|e| input(format!("{}: {e}", args.plot.display())))?;
    let drape = ClothParams {
        nu: args.n,
        nv: args.n,
        ..cloth.clone()
    };
    let (model, state) = cloth_model(&drape).map_err(failed)?;
    let plain = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .map_err(failed)?;
    let h = args.step_fraction * plain.dt_max;

    // Figures 4 and 5.
    let methods: [(&'static str, DrapeMethod); 3] = [
        ("fb-euler", DrapeMethod::FbEuler),
        ("backward-euler", DrapeMethod::BackwardEuler),
        (
            "filtered-fb-euler",
            DrapeMethod::FilteredFbEuler(FilterOptions::default()),
        ),
    ];
    let mut figure4 = Vec::new();
    for (name, method) in &methods {
        let run = drape_velocity_run(&drape, method, h, args.t_end, 1.0, 0.5).map_err(failed)?;
        let img = &run.image;
        let mut canvas = Canvas::new(img.width(), img.height().max(1));
        for (k, px) in img.pixels().iter().enumerate() {
            canvas.set(k % img.width(), k / img.width(), *px);
        }
        write_png(&canvas, &args.plot.join(format!("fig4-{name}.png")))?;
        // Figure 5: log power spectrum, zero frequency at the centre, 8x enlarged.
        let spec = fftshift(&run.spectrum, args.n, args.n);
        let top = spec.iter().copied().fold(0.0, f64::max).max(1e-300);
        let scale = 8;
        let mut canvas = Canvas::new(args.n * scale, args.n * scale);
        for y in 0..args.n * scale {
            for x in 0..args.n * scale {
                let v = spec[(y / scale) * args.n + x / scale] / top;
                let level = if v > 0.0 {
                    (1.0 + v.log10() / 12.0).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let g = (level * 255.0).round() as u8;
                canvas.set(x, y, [g, g, g]);
            }
        }
        write_png(&canvas, &args.plot.join(format!("fig5-{name}.png")))?;
        figure4.push(Figure4Row {
            method: name,
            h,
            bounded: run.outcome.bounded,
            final_high_frequency_fraction: run.final_high_frequency_fraction,
            mean_high_frequency_fraction: run.mean_high_frequency_fraction,
        });
    }

    // Figure 6.
    let lambdas = [0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0];
    let build = || cloth_model(&drape).map_err(hookean_filter::FilterError::from);
    let options = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        ..Default::default()
    };
    let rows =
        stable_step_against_lambda(&build, &Method::FbEuler, &lambdas, &options).map_err(failed)?;
    let unfiltered = rows
        .iter()
        .find(|r| r.lambda.is_none())
        .map_or(f64::NAN, |r| r.measured_dt);
    let filtered: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| r.lambda.map(|l| (l, r.measured_dt)))
        .collect();
    let predicted: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| r.lambda.map(|l| (l, r.predicted_dt)))
        .collect();
    let plot = LogLogPlot {
        title: "Stable FB Euler step against the filter's lambda (figure 6)".into(),
        x_label: "lambda".into(),
        y_label: "stable step h (s)".into(),
        series: vec![
            Series {
                name: "measured (bisection)".into(),
                points: filtered,
            },
            Series {
                name: "predicted 2/sqrt(k0)".into(),
                points: predicted,
            },
            Series {
                name: "unfiltered (measured)".into(),
                points: lambdas.iter().map(|&l| (l, unfiltered)).collect(),
            },
        ],
    };
    let svg_path = args.plot.join("fig6.svg");
    std::fs::write(&svg_path, plot.render())
        .map_err(|e| failed(format!("{}: {e}", svg_path.display())))?;

    let analysis = Analysis {
        n: args.n,
        stiffness: cloth.structural.stiffness,
        damping: cloth.structural.damping,
        dt_max_unfiltered: plain.dt_max,
        figure4,
        figure6: rows
            .iter()
            .map(|r| Figure6Row {
                lambda: r.lambda,
                measured_dt: r.measured_dt,
                predicted_dt: r.predicted_dt,
                k0: r.k0,
            })
            .collect(),
    };
    let json_path = args.plot.join("analysis.json");
    std::fs::write(
        &json_path,
        serde_json::to_string_pretty(&analysis).expect("serialises") + "\n",
    )
    .map_err(|e| failed(format!("{}: {e}", json_path.display())))?;
    println!("{}", serde_json::to_string(&analysis).expect("serialises"));
    Ok(())
}

fn write_png(canvas: &Canvas, path: &Path) -> Result<(), CliError> {
    canvas.write_png(path).map_err(CliError::Failed)
}
