//! The filtered FB Euler step against the plain one through the facade's
//! [`Simulation`] (what `hookean run` steps), on the N x N drape:
//!
//! ```text
//! cargo run --release -p hookean --example filter_overhead -- [N] [ROUNDS] [THREADS]
//! ```
//!
//! Defaults: N = 64, 400 rounds, 1 thread; the filter's defaults
//! (increment coupling). Each round
//! takes 10 steps of the plain simulation, then 10 of the filtered one
//! (interleaved, so a noisy neighbour slows all alike); the table gives
//! the median and the best round per step and the filtered / plain
//! ratio of both. The step is half the unfiltered `dt_max`, so every run
//! stays bounded. The bar of issue 18: the filtered step costs at most
//! 1.08x the plain one.

use std::time::Instant;

use hookean::filter::{ExplicitScheme, predict_dt_max};
use hookean::prelude::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(64);
    let rounds: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(400);
    let threads: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()?;
    let (model, state) = cloth(&ClothParams::drape(n))?;
    let dt = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )?
    .dt_max;
    let options = |filter: Option<FilterOptions>| SimulationOptions {
        method: Method::FbEuler,
        solver: SolverOptions::with_h(0.5 * dt),
        filter,
        ..SimulationOptions::default()
    };
    let mut sims = [
        Simulation::new(model.clone(), state.clone(), options(None))?,
        Simulation::new(model, state, options(Some(FilterOptions::default())))?,
    ];
    const BATCH: usize = 10;
    let mut times = vec![Vec::with_capacity(rounds); sims.len()];
    for _ in 0..rounds {
        for (sim, t) in sims.iter_mut().zip(&mut times) {
            let start = Instant::now();
            for _ in 0..BATCH {
                sim.step()?;
            }
            t.push(start.elapsed().as_secs_f64() / BATCH as f64);
        }
    }
    let stat = |t: &mut Vec<f64>| {
        t.sort_by(f64::total_cmp);
        (t[t.len() / 2], t[0])
    };
    let (plain_med, plain_best) = stat(&mut times[0]);
    println!(
        "N = {n}, {rounds} rounds of {BATCH} steps, {threads} thread(s), h = {:.3e} s",
        0.5 * dt
    );
    println!("| step | median (us) | best (us) | median / plain | best / plain |");
    println!("|---|---|---|---|---|");
    println!(
        "| plain FB Euler | {:.1} | {:.1} | 1.000 | 1.000 |",
        plain_med * 1e6,
        plain_best * 1e6
    );
    let (med, best) = stat(&mut times[1]);
    println!(
        "| filtered FB Euler | {:.1} | {:.1} | {:.3} | {:.3} |",
        med * 1e6,
        best * 1e6,
        med / plain_med,
        best / plain_best
    );
    Ok(())
}
