//! The reference drape (`scenes/drape.toml`) with the variable-order BDF
//! (`integrator.method = "bdf"`, error control by `rtol`, `atol`) against an
//! independent reference: the position error at the times `T` and what
//! each run cost, next to the scene's implicit Euler.
//!
//! ```text
//! cargo run --release -p hookean --example bdf_drape -- [N] [T,T,...] [REFERENCE_H] [RTOL...]
//! ```
//!
//! Defaults: `N = 64`, `T = 1`, the reference RK4 at `h = 1e-5` (explicit,
//! far below the stiffest spring period at every `N` up to 64), the runs at
//! `rtol = 1e-2, 1e-3, 1e-4`; every run sets `atol = rtol / 10` (metres
//! and metres per second). Two more RK4 runs say how well the reference
//! itself is determined: at `2 h` (its discretisation error), and at `h`
//! from initial positions moved by 1e-15 m (round-off: the drape buckles,
//! and on 32 x 32 and 64 x 64 particles such a perturbation reaches
//! millimetres within a second, docs/PERFORMANCE.md).
//!
//! One CSV row per run and time: `method,rtol_or_h,t,max_position_error,
//! rms_position_error,steps,rejected,newton,cg,wall_s,wall_s_per_simulated_s`;
//! the errors are the largest and the RMS particle distance from the
//! reference at `t`.

use std::path::Path;
use std::time::Instant;

use hookean::prelude::*;
use hookean::scene::Scene;

/// Runs the drape scene with `overrides` (initial positions moved by
/// `perturb` m) through the times `ts`; the positions at each and the CSV
/// tail of the run.
fn run(
    n: usize,
    ts: &[f64],
    overrides: &[String],
    perturb: f64,
) -> Result<(Vec<Vec<f64>>, String), HookeanError> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/drape.toml");
    let t_end = ts.iter().copied().fold(0.0, f64::max);
    let mut all = vec![format!("cloth.n={n}"), format!("duration={t_end}")];
    all.extend_from_slice(overrides);
    let all: Vec<&str> = all.iter().map(String::as_str).collect();
    let scene = Scene::from_file(&path, &all)?;
    let mut sim = if perturb == 0.0 {
        scene.build()?
    } else {
        let params = scene.cloth_params().expect("the drape is a cloth");
        let (model, mut state) = hookean::massspring::cloth(&params)?;
        // A fixed pattern of amplitude `perturb` (free particles only: the
        // pins reset theirs).
        for (i, x) in state.x.iter_mut().enumerate() {
            *x += perturb * (1.2345 * i as f64).sin();
        }
        Simulation::new(model, state, scene.simulation_options())?
    };
    let start = Instant::now();
    let mut out = Vec::new();
    for &t in ts {
        sim.run_until(t)?;
        out.push(sim.x().to_vec());
    }
    let wall = start.elapsed().as_secs_f64();
    let s = sim.stats();
    let tail = format!(
        "{},{},{},{},{wall:.3},{:.3}",
        s.num_steps,
        s.num_rejected_steps(),
        s.num_nonlin_solv_iters,
        s.num_lin_iters,
        wall / t_end
    );
    Ok((out, tail))
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

fn rk4(h: f64) -> Vec<String> {
    vec!["integrator.method=rk4".into(), format!("integrator.h={h}")]
}

fn main() -> Result<(), HookeanError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(64);
    let ts: Vec<f64> = args
        .get(1)
        .map(|s| s.split(',').filter_map(|t| t.parse().ok()).collect())
        .unwrap_or_else(|| vec![1.0]);
    let h: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1e-5);
    let mut rtols: Vec<f64> = args[3.min(args.len())..]
        .iter()
        .filter_map(|s| s.parse().ok())
        .collect();
    if rtols.is_empty() {
        rtols = vec![1e-2, 1e-3, 1e-4];
    }
    println!(
        "method,rtol_or_h,t,max_position_error,rms_position_error,steps,rejected,newton,cg,wall_s,wall_s_per_simulated_s"
    );
    let (reference, tail) = run(n, &ts, &rk4(h), 0.0)?;
    let print = |name: &str, x: &[Vec<f64>], tail: &str| {
        for ((t, x), r) in ts.iter().zip(x).zip(&reference) {
            let (max, rms) = distances(x, r);
            println!("{name},{t},{max:.3e},{rms:.3e},{tail}");
        }
    };
    print(&format!("rk4 (the reference),{h:e}"), &reference, &tail);
    let (x, tail) = run(n, &ts, &rk4(2.0 * h), 0.0)?;
    print(&format!("rk4,{:e}", 2.0 * h), &x, &tail);
    let (x, tail) = run(n, &ts, &rk4(h), 1e-15)?;
    print(&format!("rk4 x0 + 1e-15 m,{h:e}"), &x, &tail);
    for rtol in rtols {
        let (x, tail) = run(n, &ts, &bdf(rtol), 0.0)?;
        print(&format!("bdf,{rtol:e}"), &x, &tail);
    }
    let (x, tail) = run(n, &ts, &[], 0.0)?;
    print("implicit-euler (the scene's),", &x, &tail);
    Ok(())
}
