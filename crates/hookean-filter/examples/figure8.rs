//! The paper's figure 8 (section 7.2) with [`figure8_runs`]: wall time to
//! simulate the drape for particle counts and stiffness levels `k0`, with
//! FB Euler, Verlet and RK4 (each filtered and not), backward Euler as
//! Baraff and Witkin and the IMEX scheme of EEH00. Prints a markdown table.
//! (`hookean reproduce` runs the same, with the project's best implicit
//! settings as a further series, and plots both panels.)
//!
//! Usage: `cargo run --release -p hookean-filter --example figure8 -- [T_END] [N,N,...] [K0,K0,...]`
//! (defaults: 10 s, sizes 16,32,64, k0 1e4,1e5,1e6).

use hookean_filter::{Figure8Method, figure8_runs};
use hookean_ode::SolverOptions;

fn list(arg: Option<String>, default: &[f64]) -> Result<Vec<f64>, std::num::ParseFloatError> {
    match arg {
        Some(s) => s.split(',').map(str::parse).collect(),
        None => Ok(default.to_vec()),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let t_end: f64 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(10.0);
    let sizes = list(args.next(), &[16.0, 32.0, 64.0])?;
    let k0s = list(args.next(), &[1e4, 1e5, 1e6])?;
    let methods: Vec<Figure8Method> = Figure8Method::ALL
        .into_iter()
        .filter(|m| *m != Figure8Method::BackwardEulerBest)
        .collect();
    println!(
        "| N | k0 (rest) | k0 (run max) | method | h (s) | steps | CG its | bounded | time (s) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for &n in &sizes {
        for &k0 in &k0s {
            figure8_runs(
                n as usize,
                k0,
                t_end,
                &methods,
                &SolverOptions::default(),
                |r| {
                    println!(
                        "| {n}x{n} | {k0:.0e} | {:.2e} | {} | {:.2e} | {} | {} | {} | {:.3} |",
                        r.k0_run,
                        r.method.name(),
                        r.h,
                        r.steps,
                        r.linear_iterations,
                        r.bounded,
                        r.seconds
                    );
                },
            )?;
        }
    }
    Ok(())
}
