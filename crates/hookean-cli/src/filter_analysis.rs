//! `hookean filter-analysis SCENE --plot DIR`: the filtering paper's figures
//! 4 (velocities over time as RGB, one row per step), 5 (2D spectrum of the
//! final velocity field) and 6 (stable step against the filter's lambda),
//! for the cloth of a scene (its stiffness, damping and mass; the analysis
//! runs on an `--n x --n` grid so that explicit runs stay affordable).

use std::path::{Path, PathBuf};

use clap::Args;
use hookean::scene::Scene;
use hookean_filter::{
    BisectionOptions, DrapeMethod, ExplicitScheme, FilterOptions, RunOptions, VelocityImage,
    drape_velocity_run, fftshift, predict_dt_max, stable_step_against_lambda,
};
use hookean_massspring::{ClothParams, cloth as cloth_model};
use hookean_ode::Method;
use serde::Serialize;

use indicatif::ProgressBar;
use plotters::prelude::*;

use crate::CliError;
use crate::lineplot::{LogLogPlot, Series};
use crate::plot::{colour_bar, draw_error, draw_on, labelled_chart};
use crate::render::Canvas;

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
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    t_end: f64,
    /// Step of the figure-4 runs, as a fraction of the unfiltered FB Euler limit dt_max.
    #[arg(long, default_value_t = 0.9, allow_negative_numbers = true)]
    step_fraction: f64,
    /// Write into an existing folder.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    work: crate::work::WorkCap,
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
    /// Why figures 4 and 5 run at this step and not the paper's 0.01 s.
    step_choice: String,
    figure4: Vec<Figure4Row>,
    figure6: Vec<Figure6Row>,
}

/// The step the paper quotes (for its implicit and IMEX runs, section 5):
/// it gives none for figures 4 and 5.
const PAPER_STEP: f64 = 0.01;

/// Why figures 4 and 5 run at `h = fraction dt_max`: one step for the three
/// schemes, which FB Euler (stable below `dt_max`, eq. 11) must survive.
fn step_choice(h: f64, fraction: f64, dt_max: f64) -> String {
    format!(
        "figures 4 and 5 run all three schemes at one step, h = {h:.3e} s = {fraction} dt_max. The paper does not give the step of these figures; the only step it quotes, {PAPER_STEP} s, is that of its implicit and IMEX runs (figure 8). On this cloth FB Euler is stable only below dt_max = {dt_max:.3e} s (eq. 11, 2 / sqrt(k0) with k0 from the modified power method), so at {PAPER_STEP} s ({:.0} dt_max) it blows up within a few steps and there would be no FB Euler picture to compare",
        PAPER_STEP / dt_max
    )
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

pub fn run(args: &FilterAnalysisArgs) -> Result<(), CliError> {
    let (scene, _) = crate::scene::read_scene(&args.scene, &[])?;
    let cloth = scene.cloth_params().ok_or_else(|| {
        CliError::Input(format!(
            "{}: filter-analysis needs a [cloth] scene",
            args.scene.display()
        ))
    })?;
    if args.n < 4 {
        return Err(CliError::Input(format!(
            "--n must be at least 4, got {:?}",
            args.n
        )));
    }
    if !(args.t_end > 0.0 && args.t_end.is_finite()) {
        return Err(CliError::Input(format!(
            "--t-end must be positive, got {:?}",
            args.t_end
        )));
    }
    if !(args.step_fraction > 0.0 && args.step_fraction <= 2.0) {
        return Err(CliError::Input(format!(
            "--step-fraction must lie in (0, 2], got {:?}",
            args.step_fraction
        )));
    }
    // The analysed cloth is the scene's at --n particles per side: refuse
    // one that would not fit in memory before anything is allocated.
    let mut sized = scene.clone();
    if let Some(c) = sized.cloth.as_mut() {
        c.n = args.n;
    }
    let (bytes, _) = sized.memory_estimate();
    if bytes.is_none_or(|b| b > Scene::DEFAULT_MAX_BYTES) {
        return Err(CliError::Input(format!(
            "--n {}: {}",
            args.n,
            hookean::HookeanError::TooLarge {
                key: "cloth.n",
                bytes,
                max_bytes: Scene::DEFAULT_MAX_BYTES,
            }
        )));
    }
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
    // Three runs of --t-end at h, and figure 6's bisections: 8 settings of
    // about 12 runs of 0.5 s at steps no shorter than dt_max.
    args.work.check(
        3.0 * args.t_end / h + 8.0 * 12.0 * 0.5 / plain.dt_max,
        (args.n * args.n) as f64,
        &format!(
            "--t-end {:?} s at h = {:.3e} s ({} x dt_max) with --n {}",
            args.t_end, h, args.step_fraction, args.n
        ),
    )?;
    // The figures are written into a staging folder moved to --plot at the
    // end, as `run` does (crate::output).
    let staging = crate::output::Staging::new(
        "filter-analysis",
        &args.plot,
        "--plot",
        args.force,
        &[&args.scene],
    )?;
    match analyse(args, &drape, h, plain.dt_max, staging.dir()) {
        Ok(()) => staging.commit(),
        Err(e) => Err(staging.abandon(e)),
    }
}

/// Figures 4, 5 and 6 and analysis.json of the cloth `drape` into `dir`, at
/// the FB Euler step `h` (the unfiltered stable step is `dt_max`).
fn analyse(
    args: &FilterAnalysisArgs,
    drape: &ClothParams,
    h: f64,
    dt_max: f64,
    dir: &Path,
) -> Result<(), CliError> {
    // Figures 4 and 5 (three runs), then figure 6: a bar on a terminal.
    let bar = ProgressBar::new(4);
    bar.set_style(crate::bar_style(
        "{bar:30} {pos}/{len} {msg} [{elapsed_precise}]",
    ));
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
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
        bar.set_message(format!("figures 4 and 5: {name} run"));
        let run = drape_velocity_run(drape, method, h, args.t_end, VELOCITY_SCALE, 0.5)
            .map_err(failed)?;
        bar.inc(1);
        write_png(
            &figure4_picture(&run.image, name, h).map_err(CliError::Failed)?,
            &dir.join(format!("fig4-{name}.png")),
        )?;
        let spec = fftshift(&run.spectrum, args.n, args.n);
        write_png(
            &figure5_picture(&spec, args.n, name).map_err(CliError::Failed)?,
            &dir.join(format!("fig5-{name}.png")),
        )?;
        figure4.push(Figure4Row {
            method: name,
            h,
            bounded: run.outcome.bounded,
            final_high_frequency_fraction: run.final_high_frequency_fraction,
            mean_high_frequency_fraction: run.mean_high_frequency_fraction,
        });
    }

    // Figure 6.
    bar.set_message("figure 6: stable step by bisection for 7 lambdas");
    let lambdas = [0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0];
    let build = || cloth_model(drape).map_err(hookean_filter::FilterError::from);
    let options = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        ..Default::default()
    };
    // No bracket: the scene's cloth (what the user set) has no explicit
    // stability limit in the steps tried, not a bisection option of theirs.
    let rows = stable_step_against_lambda(&build, &Method::FbEuler, &lambdas, &options).map_err(
        |e| match e {
            hookean_filter::FilterError::NoStabilityBracket { .. } => CliError::Failed(format!(
                "{}: [cloth]: figure 6 measures FB Euler's stable step by bisection, but {e}: \
                 the cloth's stiffness, damping and mass (at --n {}) set no limit there",
                args.scene.display(),
                args.n
            )),
            e => failed(e),
        },
    )?;
    bar.finish_and_clear();
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
    let svg_path = dir.join("fig6.svg");
    crate::output::write_text(&svg_path, &plot.render().map_err(CliError::Failed)?)?;

    let analysis = Analysis {
        n: args.n,
        stiffness: drape.structural.stiffness,
        damping: drape.structural.damping,
        dt_max_unfiltered: dt_max,
        step_choice: step_choice(h, args.step_fraction, dt_max),
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
    let json_path = dir.join("analysis.json");
    crate::output::write_text(&json_path, &(crate::to_json(&analysis, true)? + "\n"))?;
    crate::outln!("{}", crate::to_json(&analysis, false)?)?;
    Ok(())
}

fn write_png(canvas: &Canvas, path: &Path) -> Result<(), CliError> {
    canvas.write_png(path).map_err(CliError::Failed)
}

/// Velocities of figure 4 map `[-VELOCITY_SCALE, VELOCITY_SCALE]` m/s to `[1, 255]`.
const VELOCITY_SCALE: f64 = 1.0;

/// Figure 4: the velocity image (one row per step, one column per particle,
/// RGB = the velocity's x, y, z components) on axes of particle index and
/// time, with one colour bar per channel.
fn figure4_picture(img: &VelocityImage, name: &str, h: f64) -> Result<Canvas, String> {
    let (cols, rows) = (img.width().max(1), img.height().max(1));
    let t_end = rows as f64 * h;
    let mut canvas = Canvas::new(900, 560);
    let (xr, yr) = draw_on(&mut canvas, |root| {
        root.fill(&WHITE).map_err(draw_error)?;
        let (left, right) = root.split_horizontally(690);
        let chart = labelled_chart(
            &left,
            &format!("Figure 4: velocities over time, {name}, h = {h:.3e} s"),
            (0.0..cols as f64, "particle index (grid row by row)"),
            (0.0..t_end, "time t (s)"),
            false,
        )?;
        for (c, label) in ["R = v_x", "G = v_y", "B = v_z"].iter().enumerate() {
            colour_bar(
                &right,
                (12 + 70 * c as i32, 80, 16, 380),
                (-VELOCITY_SCALE, VELOCITY_SCALE),
                |v| {
                    let mut p = [128u8; 3];
                    p[c] = (128.0 + 127.0 * v / VELOCITY_SCALE)
                        .round()
                        .clamp(0.0, 255.0) as u8;
                    RGBColor(p[0], p[1], p[2])
                },
                Some(vec![-1.0, -0.5, 0.0, 0.5, 1.0]),
                label,
            )?;
        }
        right
            .draw(&Text::new(
                "velocity (m/s), clamped",
                (40, 490),
                ("sans-serif", 14).into_font(),
            ))
            .map_err(draw_error)?;
        Ok(chart.plotting_area().get_pixel_range())
    })?;
    // The image, nearest neighbour, time upwards.
    let px = img.pixels();
    let (w, h_px) = ((xr.end - xr.start).max(1), (yr.end - yr.start).max(1));
    for y in yr.clone() {
        let row = (((yr.end - 1 - y) as f64 / h_px as f64) * rows as f64) as usize;
        for x in xr.clone() {
            let col = (((x - xr.start) as f64 / w as f64) * cols as f64) as usize;
            if let Some(p) = px.get(row.min(rows - 1) * cols + col.min(cols - 1)) {
                canvas.set(x as usize, y as usize, *p);
            }
        }
    }
    Ok(canvas)
}

/// Figure 5: the power spectrum of the final velocity field (zero frequency
/// at the centre) in decibels below its peak, on axes of spatial frequency.
fn figure5_picture(spec: &[f64], n: usize, name: &str) -> Result<Canvas, String> {
    let top = spec.iter().copied().fold(0.0, f64::max).max(1e-300);
    // log10 of the power relative to the peak, clamped to 12 decades.
    let level = |p: f64| {
        if p > 0.0 {
            (p / top).log10().clamp(-12.0, 0.0)
        } else {
            -12.0
        }
    };
    let grey = |l: f64| {
        let g = ((1.0 + l / 12.0) * 255.0).round() as u8;
        RGBColor(g, g, g)
    };
    // Cell k of a shifted axis is centred on the frequency (k - n/2) / n.
    let cell = 1.0 / n as f64;
    let f_lo = -((n / 2) as f64 + 0.5) * cell;
    let f_hi = f_lo + 1.0;
    let mut canvas = Canvas::new(700, 560);
    draw_on(&mut canvas, |root| {
        root.fill(&WHITE).map_err(draw_error)?;
        let (left, right) = root.split_horizontally(570);
        let mut chart = labelled_chart(
            &left,
            &format!("Figure 5: spectrum of the final velocities, {name}"),
            (f_lo..f_hi, "frequency k_x (cycles per particle spacing)"),
            (f_lo..f_hi, "frequency k_y (cycles per spacing)"),
            false,
        )?;
        chart
            .draw_series((0..n * n).map(|k| {
                let (i, j) = (k % n, k / n);
                let (x, y) = (f_lo + i as f64 * cell, f_lo + j as f64 * cell);
                Rectangle::new(
                    [(x, y), (x + cell, y + cell)],
                    grey(level(spec[k])).filled(),
                )
            }))
            .map_err(draw_error)?;
        colour_bar(
            &right,
            (20, 80, 20, 400),
            (-12.0, 0.0),
            grey,
            None,
            "log10(power / peak)",
        )
    })?;
    Ok(canvas)
}
