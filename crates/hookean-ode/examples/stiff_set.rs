//! Runs the variable-order BDF solver on the stiff test set
//! ([`hookean_ode::testset`]) over a range of tolerances, one set of default
//! options, and prints one CSV row per run: the mixed error at `t_end`
//! against the published reference, the statistics, the median wall
//! time of `repeats` runs, and the largest mixed error along the trajectory
//! (`trajectory_error`, see [`trajectory_times`]).
//!
//! ```text
//! cargo run --release -p hookean-ode --example stiff_set -- [--exponent p] [repeats] [rtol...]
//! ```
//!
//! `--exponent p` replaces the default
//! [`BdfConfig::tolerance_exponent`](hookean_ode::BdfConfig::tolerance_exponent) (for the trade-off study of
//! docs/PERFORMANCE.md, issue 17); everything else stays the defaults.

use std::sync::OnceLock;
use std::time::Instant;

use hookean_ode::testset::{
    E5, Hires, Orego, Robertson, SpringChain, TestProblem, VanDerPol, mixed_error, options,
};
use hookean_ode::{
    BdfConfig, FirstOrderIntegrator, Integrator, Method, OdeError, SolverOptions, Stats,
};

/// The `--exponent` argument, if given.
static EXPONENT: OnceLock<f64> = OnceLock::new();

/// The variable-order BDF with the default settings, but for the
/// `--exponent` override.
fn sweep_method() -> Method {
    Method::VariableBdf(BdfConfig {
        tolerance_exponent: EXPONENT.get().copied(),
        ..Default::default()
    })
}

/// The output times of the trajectory error, the same rule for every
/// problem: 20 equidistant times `t_end i / 20`, `i = 1..=20`, and 19
/// logarithmically spaced ones `t_end 10^(-10 + i / 2)`, `i = 1..=19` (these see the
/// early transients of Robertson and E5, whose solutions at `t_end` have
/// decayed or settled).
fn trajectory_times(t_end: f64) -> Vec<f64> {
    let mut t: Vec<f64> = (1..=20)
        .map(|i| t_end * i as f64 / 20.0)
        .chain((1..20).map(|i| t_end * 10f64.powf(-10.0 + i as f64 / 2.0)))
        .collect();
    t.sort_by(f64::total_cmp);
    t
}

/// The reference trajectory at [`trajectory_times`]: the same solver at
/// `rtol = 1e-12`, `atol_i = 1e-12 floor_i`, with the plain error-per-step
/// control (`tolerance_exponent = 1`). Its value at `t_end` agrees with the
/// published reference to 3e-10 in the mixed error (E5: 2.6e-8, the
/// published reference's own accuracy; printed on stderr).
fn reference_trajectory<P: TestProblem + Clone + Send + 'static>(
    p: &P,
    times: &[f64],
) -> Option<Vec<Vec<f64>>> {
    let opts = SolverOptions {
        max_steps: 10_000_000,
        ..options(p, 1e-12)
    };
    let method = Method::VariableBdf(BdfConfig {
        tolerance_exponent: Some(1.0),
        ..Default::default()
    });
    let sol = FirstOrderIntegrator::new(p.clone(), method, 0.0, &p.y0(), opts)
        .and_then(|mut s| s.solve_at(times))
        .ok()?;
    Some((0..times.len()).map(|i| sol.y(i).to_vec()).collect())
}

/// The largest mixed error over [`trajectory_times`] of a run at `rtol`
/// against the reference trajectory (`inf` when the run fails).
fn trajectory_error<P: TestProblem + Clone + Send + 'static>(
    p: &P,
    rtol: f64,
    reference: &[Vec<f64>],
) -> f64 {
    let times = trajectory_times(p.t_end());
    let floor = p.floor();
    FirstOrderIntegrator::new(p.clone(), sweep_method(), 0.0, &p.y0(), options(p, rtol))
        .and_then(|mut s| s.solve_at(&times))
        .map(|sol| {
            (0..times.len())
                .map(|i| mixed_error(sol.y(i), &reference[i], &floor))
                .fold(0.0, f64::max)
        })
        .unwrap_or(f64::INFINITY)
}

fn run<P: TestProblem + Clone + Send + 'static>(
    p: &P,
    rtol: f64,
) -> Result<(Vec<f64>, Stats), OdeError> {
    let opts = options(p, rtol);
    let mut s = FirstOrderIntegrator::new(p.clone(), sweep_method(), 0.0, &p.y0(), opts)?;
    let info = s.integrate(p.t_end())?;
    Ok((s.y().to_vec(), info.stats))
}

/// [`reference_trajectory`] once per problem, its `t_end` value checked
/// against the published reference (on stderr).
fn checked_reference<P: TestProblem + Clone + Send + 'static>(p: &P) -> Option<Vec<Vec<f64>>> {
    let reference_run = reference_trajectory(p, &trajectory_times(p.t_end()));
    if let Some(at_end) = reference_run.as_ref().and_then(|r| r.last()) {
        eprintln!(
            "{}: the reference trajectory at t_end against the published reference: {:.1e}",
            p.name(),
            mixed_error(at_end, &p.reference(), &p.floor())
        );
    }
    reference_run
}

fn report<P: TestProblem + Clone + Send + 'static>(
    p: &P,
    rtol: f64,
    repeats: usize,
    reference_run: Option<&[Vec<f64>]>,
) {
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
    let traj = reference_run.map_or(f64::NAN, |r| trajectory_error(p, rtol, r));
    match last.expect("at least one run") {
        Ok((y, st)) => println!(
            "{},{:e},{:.3e},{},{},{},{},{},{},{},{:.6e},ok,{:.3e}",
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
            median,
            traj
        ),
        Err(e) => println!(
            "{},{:e},inf,,,,,,,,{:.6e},\"{e}\",{:.3e}",
            p.name(),
            rtol,
            median,
            traj
        ),
    }
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().is_some_and(|a| a == "--exponent") {
        let p = args.get(1).and_then(|a| a.parse().ok());
        let Some(p) = p else {
            eprintln!("stiff_set: --exponent needs a number (1 to 2)");
            std::process::exit(2);
        };
        EXPONENT.set(p).expect("set once");
        args.drain(..2);
    }
    let repeats = args.first().and_then(|a| a.parse().ok()).unwrap_or(1);
    let mut rtols: Vec<f64> = args.iter().skip(1).filter_map(|a| a.parse().ok()).collect();
    if rtols.is_empty() {
        rtols = vec![1e-4, 1e-5, 1e-6, 1e-7, 1e-8];
    }
    println!(
        "problem,rtol,error,steps,rhs_evals,jac_evals,lu_setups,newton_iters,err_test_fails,conv_fails,wall_s,status,trajectory_error"
    );
    let (rob40, rob1e5) = (Robertson { t_end: 40.0 }, Robertson { t_end: 1e5 });
    let (chain, sparse_chain) = (SpringChain::new(false), SpringChain::new(true));
    // The rtol-1e-12 reference runs, once per problem for all tolerances.
    let refs = [
        checked_reference(&rob40),
        checked_reference(&rob1e5),
        checked_reference(&VanDerPol),
        checked_reference(&Hires),
        checked_reference(&Orego),
        checked_reference(&E5),
        checked_reference(&chain),
        checked_reference(&sparse_chain),
    ];
    let r = |i: usize| refs[i].as_deref();
    for &rtol in &rtols {
        report(&rob40, rtol, repeats, r(0));
        report(&rob1e5, rtol, repeats, r(1));
        report(&VanDerPol, rtol, repeats, r(2));
        report(&Hires, rtol, repeats, r(3));
        report(&Orego, rtol, repeats, r(4));
        report(&E5, rtol, repeats, r(5));
        report(&chain, rtol, repeats, r(6));
        report(&sparse_chain, rtol, repeats, r(7));
    }
}
