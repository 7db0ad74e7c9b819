//! The paper's figure 8: wall time to simulate the drape for particle counts
//! and stiffness levels `k0`, with FB Euler, filtered FB Euler, RK4, filtered
//! RK4 and implicit Euler with PCG. Prints a markdown table.
//!
//! Usage: `cargo run --release -p hookean-filter --example figure8 -- [T_END] [N,N,...] [K0,K0,...]`
//! (defaults: 10 s, sizes 16,32,64,128, k0 1e4,1e5,1e6).
//!
//! The stiffness `k` is scaled so that the plain power method's `k0` at the
//! flat rest state equals the requested value. The drape stretches as it
//! falls, which raises `k0`: implicit Euler runs first (h = 0.01, Newton and
//! PCG to a relative 1e-2 as in the paper's section 7.2), `k0` is taken at
//! the end of every simulated second (not timed), and the explicit steps are
//! `min(0.01, 0.95 c / sqrt(max k0))` (eq. 11, `c = 2`; RK4 `sqrt(8.75)`),
//! the filtered ones 1.25 times that (the paper's section 7.1). The spring
//! damping is scaled with `sqrt(k)` (constant damping ratio).

use std::time::Instant;

use hookean_filter::{
    ExplicitScheme, FilterCoupling, FilterOptions, ModelIntegrator, RunOptions, predict_dt_max,
    run_bounded,
};
use hookean_massspring::{ClothParams, cloth};
use hookean_ode::{Method, NewtonOptions, SolverOptions};
use hookean_sparse::PowerParams;

fn list(arg: Option<String>, default: &[f64]) -> Vec<f64> {
    arg.map(|s| s.split(',').map(|x| x.parse().expect("a number")).collect())
        .unwrap_or_else(|| default.to_vec())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let t_end: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(10.0);
    let sizes = list(args.next(), &[16.0, 32.0, 64.0, 128.0]);
    let k0s = list(args.next(), &[1e4, 1e5, 1e6]);
    let power = PowerParams {
        rtol: 1e-4,
        ..Default::default()
    };
    let fb = ExplicitScheme::ForwardBackwardEuler;
    println!("| N | k0 (rest) | k0 (run max) | method | h (s) | steps | bounded | time (s) |");
    println!("|---|---|---|---|---|---|---|---|");
    for &n in &sizes {
        let n = n as usize;
        let reference = ClothParams::drape(n);
        let (model, state) = cloth(&reference)?;
        let k0_ref = predict_dt_max(&model, &state.x, None, fb, &power)?.k0;
        for &k0 in &k0s {
            // Damping scaled with sqrt(k) keeps the damping ratio of the
            // reference drape (explicit damping has a step limit of its own).
            let ratio = k0 / k0_ref;
            let scene = reference.clone().with_stiffness(
                reference.structural.stiffness * ratio,
                reference.structural.damping * ratio.sqrt(),
            );
            // Implicit Euler first: its states give the run's largest k0.
            let (model, state) = cloth(&scene)?;
            let options = SolverOptions {
                newton: NewtonOptions {
                    rtol: 1e-2,
                    linear_rtol: 1e-2,
                    ..SolverOptions::default_newton()
                },
                ..SolverOptions::with_h(0.01)
            };
            let mut sim =
                ModelIntegrator::new(model, &state, Method::ImplicitEuler, options, None)?;
            let mut k0_run = k0;
            let mut secs = 0.0;
            let mut bounded = true;
            let mut second = 1.0f64;
            while second <= t_end + 1e-9 && bounded {
                let start = Instant::now();
                let out = run_bounded(
                    &mut sim,
                    &RunOptions {
                        t_end: second.min(t_end),
                        energy_bound: 1.0,
                        check_every: 1000,
                    },
                )?;
                secs += start.elapsed().as_secs_f64();
                bounded = out.bounded;
                k0_run = k0_run.max(predict_dt_max(sim.model(), sim.x(), None, fb, &power)?.k0);
                second += 1.0;
            }
            println!(
                "| {n}x{n} | {k0:.0e} | {k0_run:.2e} | implicit Euler (PCG) | 1.00e-2 | {} | {bounded} | {secs:.2} |",
                sim.stats().steps
            );
            let runs: [(&str, Method, f64, bool); 4] = [
                ("FB Euler", Method::FbEuler, 2.0, false),
                ("filtered FB Euler", Method::FbEuler, 2.0, true),
                ("RK4", Method::Rk4, 8.75f64.sqrt(), false),
                ("filtered RK4", Method::Rk4, 8.75f64.sqrt(), true),
            ];
            for (name, method, c, filtered) in runs {
                let mut h = (0.95 * c / k0_run.sqrt()).min(0.01);
                if filtered {
                    h *= 1.25;
                }
                let (model, state) = cloth(&scene)?;
                let filter =
                    filtered.then(|| (FilterOptions::default(), FilterCoupling::default()));
                let mut sim =
                    ModelIntegrator::new(model, &state, method, SolverOptions::with_h(h), filter)?;
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
                    "| {n}x{n} | {k0:.0e} | {k0_run:.2e} | {name} | {h:.2e} | {} | {} | {secs:.2} |",
                    out.steps, out.bounded
                );
            }
        }
    }
    Ok(())
}
