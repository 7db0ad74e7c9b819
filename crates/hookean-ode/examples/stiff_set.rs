//! Runs the variable-order BDF solver on the stiff test set
//! ([`hookean_ode::testset`]) over a range of tolerances, one set of default
//! options, and prints one CSV row per run: the mixed error at `t_end`
//! against the published reference, the statistics, and the median wall
//! time of `repeats` runs.
//!
//! ```text
//! cargo run --release -p hookean-ode --example stiff_set -- [repeats] [rtol...]
//! ```

use std::time::Instant;

use hookean_ode::testset::{
    E5, Hires, Orego, Robertson, SpringChain, TestProblem, VanDerPol, mixed_error, options,
};
use hookean_ode::{BdfSolver, BdfStats, OdeError};

fn run<P: TestProblem + Clone>(p: &P, rtol: f64) -> Result<(Vec<f64>, BdfStats), OdeError> {
    let opts = options(p, rtol);
    let mut s = BdfSolver::new(p.clone(), 0.0, &p.y0(), opts)?;
    let stats = s.solve_to(p.t_end())?;
    Ok((s.y().to_vec(), stats))
}

fn report<P: TestProblem + Clone>(p: &P, rtol: f64, repeats: usize) {
    let reference = p.reference();
    let floor = p.floor();
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..repeats.max(1) {
        let start = Instant::now();
        let r = run(p, rtol);
        times.push(start.elapsed().as_secs_f64());
        last = Some(r);
    }
    times.sort_by(f64::total_cmp);
    let median = times[times.len() / 2];
    match last.expect("at least one run") {
        Ok((y, st)) => println!(
            "{},{:e},{:.3e},{},{},{},{},{},{},{},{:.6e},ok",
            p.name(),
            rtol,
            mixed_error(&y, &reference, &floor),
            st.num_steps,
            st.num_rhs_evals,
            st.num_jac_evals,
            st.num_lin_solv_setups,
            st.num_nonlin_solv_iters,
            st.num_err_test_fails,
            st.num_nonlin_solv_conv_fails,
            median
        ),
        Err(e) => println!("{},{:e},inf,,,,,,,,{:.6e},\"{e}\"", p.name(), rtol, median),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let repeats = args.first().and_then(|a| a.parse().ok()).unwrap_or(1);
    let mut rtols: Vec<f64> = args.iter().skip(1).filter_map(|a| a.parse().ok()).collect();
    if rtols.is_empty() {
        rtols = vec![1e-4, 1e-5, 1e-6, 1e-7, 1e-8];
    }
    println!(
        "problem,rtol,error,steps,rhs_evals,jac_evals,lu_setups,newton_iters,err_test_fails,conv_fails,wall_s,status"
    );
    for &rtol in &rtols {
        report(&Robertson { t_end: 40.0 }, rtol, repeats);
        report(&Robertson { t_end: 1e5 }, rtol, repeats);
        report(&VanDerPol, rtol, repeats);
        report(&Hires, rtol, repeats);
        report(&Orego, rtol, repeats);
        report(&E5, rtol, repeats);
        report(&SpringChain::new(false), rtol, repeats);
        report(&SpringChain::new(true), rtol, repeats);
    }
}
