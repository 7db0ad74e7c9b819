//! The reference drape (`scenes/drape.toml`) with the variable-order BDF
//! (`integrator.method = "bdf"`, error control by `rtol`, `atol`) against a
//! tight-tolerance reference: the position error at `T` and what each run
//! cost, next to the scene's implicit Euler.
//!
//! ```text
//! cargo run --release -p hookean --example bdf_drape -- [N] [T] [REFERENCE_RTOL] [RTOL...]
//! ```
//!
//! Defaults: `N = 64`, `T = 1`, the reference at `rtol = 1e-6`, the runs
//! at `rtol = 1e-2, 1e-3, 1e-4`; every run sets `atol = rtol / 10` (metres
//! and metres per second: the relative test governs states of order one).
//! One CSV row per run: `method,rtol,max_position_error,rms_position_error,
//! steps,rejected,newton,cg,wall_s,wall_s_per_simulated_s`; the errors are
//! the largest and the RMS particle distance from the reference at `T`.

use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use hookean::prelude::*;
use hookean::scene::Scene;

/// Runs the drape scene with `overrides` to `t_end`; the positions and the CSV tail.
fn run(n: usize, t_end: f64, overrides: &[String]) -> Result<(Vec<f64>, String), HookeanError> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/drape.toml");
    let mut all = vec![format!("cloth.n={n}"), format!("duration={t_end}")];
    all.extend_from_slice(overrides);
    let all: Vec<&str> = all.iter().map(String::as_str).collect();
    let scene = Scene::from_file(&path, &all)?;
    let mut sim = scene.build()?;
    let start = Instant::now();
    let summary = sim.run_until(t_end, |_, _| ControlFlow::Continue(()))?;
    let wall = start.elapsed().as_secs_f64();
    let s = summary.stats;
    let tail = format!(
        "{},{},{},{},{wall:.3},{:.3}",
        s.num_steps,
        s.num_rejected_steps(),
        s.num_nonlin_solv_iters,
        s.num_lin_iters,
        wall / t_end
    );
    Ok((sim.x().to_vec(), tail))
}

/// The largest and the RMS distance between the particles of `x` and `y`.
fn distances(x: &[f64], y: &[f64]) -> (f64, f64) {
    let d2: Vec<f64> = x
        .chunks_exact(3)
        .zip(y.chunks_exact(3))
        .map(|(a, b)| (0..3).map(|i| (a[i] - b[i]).powi(2)).sum())
        .collect();
    let max = d2.iter().fold(0.0f64, |m, v| m.max(*v)).sqrt();
    let rms = (d2.iter().sum::<f64>() / d2.len() as f64).sqrt();
    (max, rms)
}

fn bdf(rtol: f64) -> Vec<String> {
    vec![
        "integrator.method=bdf".into(),
        format!("integrator.rtol={rtol}"),
        format!("integrator.atol={}", rtol / 10.0),
    ]
}

fn main() -> Result<(), HookeanError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(64);
    let t_end: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1.0);
    let reference_rtol: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1e-6);
    let mut rtols: Vec<f64> = args[3.min(args.len())..]
        .iter()
        .filter_map(|s| s.parse().ok())
        .collect();
    if rtols.is_empty() {
        rtols = vec![1e-2, 1e-3, 1e-4];
    }
    println!(
        "method,rtol,max_position_error,rms_position_error,steps,rejected,newton,cg,wall_s,wall_s_per_simulated_s"
    );
    let (reference, tail) = run(n, t_end, &bdf(reference_rtol))?;
    println!("bdf,{reference_rtol:e},0,0,{tail}");
    for rtol in rtols {
        let (x, tail) = run(n, t_end, &bdf(rtol))?;
        let (max, rms) = distances(&x, &reference);
        println!("bdf,{rtol:e},{max:.3e},{rms:.3e},{tail}");
    }
    let (x, tail) = run(n, t_end, &[])?;
    let (max, rms) = distances(&x, &reference);
    println!("implicit-euler (the scene's),,{max:.3e},{rms:.3e},{tail}");
    Ok(())
}
