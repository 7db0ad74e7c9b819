//! The paper's literal filter (section 4.1: the new velocities replaced,
//! `coupling = "velocity"`) next to ours (the step's velocity change
//! filtered, `"increment"`) and the position-corrected variant
//! (`"positions"`): the stable FB Euler step on the 12x12 reference drape
//! by bisection (energy bounded over 0.5 s), lambda = 1, symmetric and
//! plain forms, and with time-dependent distances (the paper's
//! `beta^{t + dt}`). Prints a markdown table (docs/perf/filter.md).
//!
//! Usage: `cargo run --release -p hookean-filter --example couplings`

use hookean_filter::{
    BisectionOptions, FilterCoupling, FilterError, FilterOptions, Form, RunOptions,
    measure_stable_step,
};
use hookean_massspring::{ClothParams, cloth};
use hookean_ode::Method;

fn main() -> Result<(), FilterError> {
    let build = || Ok(cloth(&ClothParams::drape(12))?);
    let opts = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        rel_tol: 0.01,
        max_runs: 60,
        ..Default::default()
    };
    let guess = 5e-4;
    let none = measure_stable_step(&build, &Method::FbEuler, None, guess, &opts)?.lo;
    println!("| form | distances | coupling | stable step (s) | / unfiltered |");
    println!("|---|---|---|---|---|");
    println!("| (no filter) | - | - | {none:.3e} | 1.00 |");
    for form in [Form::Symmetric, Form::Plain] {
        for current in [false, true] {
            for coupling in FilterCoupling::ALL {
                let filter = FilterOptions {
                    form,
                    current_distances: current,
                    ..FilterOptions::default()
                };
                let s = measure_stable_step(
                    &build,
                    &Method::FbEuler,
                    Some((filter, coupling)),
                    guess,
                    &opts,
                )?;
                println!(
                    "| {form:?} | {} | {coupling} | {:.3e} | {:.2} |",
                    if current { "current" } else { "rest" },
                    s.lo,
                    s.lo / none
                );
            }
        }
    }
    Ok(())
}
