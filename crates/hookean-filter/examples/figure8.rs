//! The paper's figure 8: wall time to simulate the drape for particle counts
//! and stiffness levels `k0`, with FB Euler, filtered FB Euler, RK4, filtered
//! RK4 and implicit Euler with PCG. Prints a markdown table.
//!
//! Usage: `cargo run --release -p hookean-filter --example figure8 -- [T_END] [N,N,...] [K0,K0,...]`
//! (defaults: 10 s, sizes 16,32,64,128, k0 1e4,1e5,1e6).
//!
//! The stiffness `k` is scaled so that the plain power method's `k0` at the
//! flat rest state equals the requested value. Explicit steps are
//! `min(0.01, 0.95 dt_max)` (eq. 11; RK4 with `sqrt(8.75)`), filtered ones
//! 1.25 times that (the paper's section 7.1); implicit Euler takes 0.01.

use std::time::Instant;

use hookean_filter::{
    DrapeScene, ExplicitScheme, FilterCoupling, FilterOptions, RunOptions, Simulation,
    predict_dt_max, run_bounded,
};
use hookean_ode::Method;

fn list(arg: Option<String>, default: &[f64]) -> Vec<f64> {
    arg.map(|s| s.split(',').map(|x| x.parse().expect("a number")).collect())
        .unwrap_or_else(|| default.to_vec())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let t_end: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(10.0);
    let sizes = list(args.next(), &[16.0, 32.0, 64.0, 128.0]);
    let k0s = list(args.next(), &[1e4, 1e5, 1e6]);
    println!("| N | k0 | method | h (s) | steps | bounded | time (s) |");
    println!("|---|---|---|---|---|---|---|");
    for &n in &sizes {
        let n = n as usize;
        let reference = DrapeScene {
            n,
            ..Default::default()
        };
        let (model, state) = reference.build()?;
        let k0_ref = predict_dt_max(
            &model,
            &state.x,
            None,
            ExplicitScheme::ForwardBackwardEuler,
            &Default::default(),
        )?
        .k0;
        for &k0 in &k0s {
            let scene = DrapeScene {
                stiffness: reference.stiffness * k0 / k0_ref,
                ..reference.clone()
            };
            let runs: [(&str, Method, f64, bool); 5] = [
                ("FB Euler", Method::FbEuler, 2.0, false),
                ("filtered FB Euler", Method::FbEuler, 2.0, true),
                ("RK4", Method::Rk4, 8.75f64.sqrt(), false),
                ("filtered RK4", Method::Rk4, 8.75f64.sqrt(), true),
                (
                    "implicit Euler (PCG)",
                    Method::ImplicitEuler,
                    f64::INFINITY,
                    false,
                ),
            ];
            for (name, method, c, filtered) in runs {
                let mut h = (0.95 * c / k0.sqrt()).min(0.01);
                if filtered {
                    h = (1.25 * h).min(0.0125);
                }
                let (model, state) = scene.build()?;
                let filter =
                    filtered.then(|| (FilterOptions::default(), FilterCoupling::default()));
                let mut sim = Simulation::new(model, &state, method, h, filter)?;
                let start = Instant::now();
                let out = run_bounded(
                    &mut sim,
                    &RunOptions {
                        t_end,
                        energy_bound: 1.0,
                        check_every: 1000,
                    },
                )?;
                let secs = start.elapsed().as_secs_f64();
                println!(
                    "| {n}x{n} | {k0:.0e} | {name} | {h:.2e} | {} | {} | {secs:.2} |",
                    out.steps, out.bounded
                );
            }
        }
    }
    Ok(())
}
