//! Work-precision runs on the tutorial's example 3 (figures 3, 5, 7) for
//! every method, written to CSV, and a markdown table of observed orders.
//!
//! ```text
//! cargo run --release -p hookean-ode --example workprecision -- target/ode-workprecision.csv
//! ```
//!
//! Run again, it replaces the table it wrote before (a file that starts with
//! the table's header) and keeps any other file at the path unless `--force`.
//!
//! Example 3 runs as the one-particle second-order problem (so FB Euler and
//! Verlet apply; the implicit methods use the reduced velocity form). Fixed
//! step methods use `n = 25 * 2^i` steps on `[0, 2]` (`i = 0..=10`),
//! variable-step BDF2 the tolerances `1e-2 .. 1e-9`. The observed order is
//! the least-squares slope over the five smallest step sizes (four halvings).
//! For comparison the table also fits the orders on example 2 (`n = 100 *
//! 2^i`, `i = 0..=4`) and on example 1 with `lambda = 2` (`n = 32 * 2^i`).

use std::process::ExitCode;

use hookean_ode::tutorial::{Dahlquist, LinearOscillator};
use hookean_ode::workprecision::{self, Sweep, WorkPrecisionRow, observed_order};
use hookean_ode::{Method, NewtonOptions, SolverOptions};

fn options() -> SolverOptions {
    SolverOptions {
        h: 1e-3,
        newton: NewtonOptions {
            rtol: 1e-13,
            atol: 1e-14,
            linear_rtol: 1e-13,
            ..SolverOptions::default_newton()
        },
        ..SolverOptions::default()
    }
}

fn particle_rows(o: LinearOscillator, m: &Method, sweep: &Sweep) -> Vec<WorkPrecisionRow> {
    workprecision::second_order(
        || o.particle(),
        m,
        0.0,
        &o.x0(),
        &o.v0_vec(),
        o.t_end,
        &o.exact_particle(o.t_end),
        sweep,
        &options(),
    )
    .expect("valid set-up")
}

fn tail_order(rows: &[WorkPrecisionRow]) -> Option<f64> {
    let finite: Vec<WorkPrecisionRow> = rows
        .iter()
        .filter(|r| r.error.is_finite())
        .cloned()
        .collect();
    let start = finite.len().saturating_sub(5);
    observed_order(&finite[start..])
}

fn fmt(q: Option<f64>) -> String {
    q.map_or("-".to_string(), |q| format!("{q:.2}"))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let force = args.iter().any(|a| a == "--force");
    let Some(path) = args.iter().find(|a| !a.starts_with("--")).cloned() else {
        eprintln!("usage: workprecision <output.csv> [--force]");
        return ExitCode::FAILURE;
    };
    let ex3 = LinearOscillator::example3();
    let ex2 = LinearOscillator::example2();
    let ex1 = Dahlquist { lambda: 2.0 };
    let mut all = Vec::new();
    println!(
        "| method | theory | example 3 (fit over 5 smallest h) | example 2 | example 1 (lambda = 2) | example 3: steps / f evals / Newton / linear its at the finest h | wall time (s) |"
    );
    println!("|---|---|---|---|---|---|---|");
    for m in Method::all_named() {
        let (rows, q2, q1) = if m.is_variable_step() {
            let tols: Vec<f64> = (2..=9).map(|e| 10f64.powi(-e)).collect();
            let rows = particle_rows(ex3, &m, &Sweep::Tolerances(tols.clone()));
            let r2 = particle_rows(ex2, &m, &Sweep::Tolerances(tols));
            (rows, tail_order(&r2), None)
        } else {
            let rows = particle_rows(ex3, &m, &Sweep::halvings(25, 11));
            let q2 = observed_order(&particle_rows(ex2, &m, &Sweep::halvings(100, 5)));
            let q1 = if m.is_second_order_only() {
                None
            } else {
                let r1 = workprecision::first_order(
                    || ex1,
                    &m,
                    0.0,
                    &[1.0],
                    1.0,
                    &[ex1.exact(1.0)],
                    &Sweep::halvings(32, 5),
                    &options(),
                )
                .expect("valid set-up");
                observed_order(&r1)
            };
            (rows, q2, q1)
        };
        let last = rows.last().expect("rows");
        let wall: f64 = rows.iter().map(|r| r.wall_time_s).sum();
        println!(
            "| {m} | {} | {} | {} | {} | {} / {} / {} / {} | {wall:.3} |",
            m.order(),
            fmt(tail_order(&rows)),
            fmt(q2),
            fmt(q1),
            last.stats.num_steps,
            last.stats.num_rhs_evals_total(),
            last.stats.num_nonlin_solv_iters,
            last.stats.num_lin_iters,
        );
        all.extend(rows);
    }
    let mut table = Vec::new();
    if let Err(e) = workprecision::write_csv(&mut table, &all) {
        eprintln!("cannot write the table: {e}");
        return ExitCode::FAILURE;
    }
    // A file that starts with the table's header is an earlier run's: replaced.
    let header = format!("{}\n", workprecision::WorkPrecisionRow::CSV_HEADER);
    let own = |old: &[u8]| old.starts_with(header.as_bytes());
    if let Err(e) = hookean_io::write_own(&path, &table, own, force) {
        eprintln!("{e}");
        return ExitCode::FAILURE;
    }
    eprintln!("wrote {} rows to {path}", all.len());
    ExitCode::SUCCESS
}
