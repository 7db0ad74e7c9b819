//! Wall time to reach a mixed error <= 1e-4 at t_end on the stiff test set,
//! for hookean-ode's variable-order BDF (`Method::VariableBdf`) and diffsol's BDF (dense nalgebra matrices and
//! LU, the Jacobian from analytic Jacobian-vector products; on the spring
//! chain also faer's sparse matrices and sparse LU, the sparsity detected
//! from the same products), with the statistics of that run. For each solver and problem the loosest `rtol`
//! of the ladder 1e-2, 3e-3, 1e-3, ..., 1e-10 whose error is <= 1e-4 is
//! taken and timed (median of `repeats` runs), and the time at exactly
//! 1e-4 is interpolated on the work-precision curve (see `compare`).
//!
//! usage: stiff-compare [repeats]
//!        stiff-compare fit [repeats]
//!        stiff-compare prof PROBLEM RTOL SOLVER [RUNS]
//! (the second form, for `valgrind --tool=callgrind`: RUNS solves of one
//! problem, by name as in the CSV, with `ours`, `diffsol` or
//! `diffsol-sparse`, and one line of the first run's error, statistics and
//! final state).
//! CSV columns: problem,solver,rtol,error,steps,jac_evals,lu_setups,rhs_evals,newton_iters,wall_s,wall_s_at_1e-4
//! (the statistics and `wall_s` of the first rung meeting the target; the last column interpolated).
//!
//! The error of either solver is not monotone in `rtol`: between neighbouring
//! rungs it jumps by up to 20x (diffsol on Robertson-1e5: 1.3e-3 at rtol
//! 1.78e-3, 6.8e-5 at 1e-3, 1.3e-4 at 5.6e-4), so the time at the first
//! rung below the target depends on where the ladder's rungs fall. The
//! `fit` form runs the ladder of quarter decades `10^(-2 - i/4)` down to an
//! error of 1e-6 and fits `ln t = a + b ln err` by least squares to every
//! rung with an error in `[1e-5, 1e-3]` (a decade either side of the
//! target), for the time, the steps and the Newton iterations at 1e-4.
//! CSV columns: problem,solver,rungs,wall_s_fit_1e-4,steps_fit,newton_fit,slope

use std::cell::RefCell;
use std::time::Instant;

use diffsol::{
    FaerSparseLU, FaerSparseMat, NalgebraLU, NalgebraMat, OdeBuilder, OdeSolverMethod,
    OdeSolverStopReason, Vector,
};
use hookean_ode::testset::{
    E5, Hires, Orego, Robertson, SpringChain, TestProblem, VanDerPol, mixed_error, options,
};
use hookean_ode::{FirstOrderIntegrator, Integrator, Method};

/// One run's result: the final state and (steps, jac_evals, lu_setups,
/// rhs_evals, newton_iters).
type Run = Option<(Vec<f64>, [usize; 5])>;

fn ours<P: TestProblem + Clone + Send + 'static>(p: &P, rtol: f64) -> Run {
    let opts = options(p, rtol);
    let mut s = FirstOrderIntegrator::new(p.clone(), Method::variable_bdf(), 0.0, &p.y0(), opts).ok()?;
    let st = s.integrate(p.t_end()).ok()?.stats;
    Some((
        s.y().to_vec(),
        [
            st.num_steps,
            st.num_jac_evals,
            st.num_lin_solv_setups,
            st.num_rhs_evals,
            st.num_nonlin_solv_iters,
        ],
    ))
}

fn diffsol_bdf<P: TestProblem + Clone + Send + 'static>(p: &P, rtol: f64) -> Run {
    let n = p.dim();
    let y0 = p.y0();
    let atol: Vec<f64> = p.floor().iter().map(|f| f * rtol).collect();
    let (pr, pj) = (p.clone(), p.clone());
    let jac = RefCell::new(vec![0.0; n * n]);
    let problem = OdeBuilder::<NalgebraMat<f64>>::new()
        .rtol(rtol)
        .atol(atol)
        .rhs_implicit(
            move |x: &[f64], _p: &[f64], t: f64, y: &mut [f64]| pr.rhs(t, x, y),
            move |x: &[f64], _p: &[f64], t: f64, v: &[f64], y: &mut [f64]| {
                let mut j = jac.borrow_mut();
                pj.jacobian(t, x, &mut j);
                for i in 0..n {
                    y[i] = (0..n).map(|k| j[i * n + k] * v[k]).sum();
                }
            },
        )
        .init(
            move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0),
            n,
        )
        .build()
        .ok()?;
    let mut solver = problem.bdf::<NalgebraLU<f64>>().ok()?;
    solver.set_stop_time(p.t_end()).ok()?;
    loop {
        match solver.step() {
            Ok(OdeSolverStopReason::TstopReached) => break,
            Ok(_) => {}
            Err(_) => return None,
        }
    }
    let y = solver.state().y.clone_as_vec();
    let st = solver.get_statistics();
    Some((
        y,
        [
            st.number_of_steps,
            st.number_of_linear_solver_setups,
            st.number_of_linear_solver_setups,
            0,
            st.number_of_nonlinear_solver_iterations,
        ],
    ))
}

/// diffsol's BDF with faer's sparse matrices and sparse LU, the Jacobian
/// assembled from products with the problem's sparse Jacobian (diffsol
/// detects the pattern from them).
fn diffsol_bdf_sparse<P: TestProblem + Clone + Send + 'static>(p: &P, rtol: f64) -> Run {
    let n = p.dim();
    let y0 = p.y0();
    let atol: Vec<f64> = p.floor().iter().map(|f| f * rtol).collect();
    let (pr, pj) = (p.clone(), p.clone());
    let jac = RefCell::new(p.sparse_jacobian_pattern()?);
    let problem = OdeBuilder::<FaerSparseMat<f64>>::new()
        .rtol(rtol)
        .atol(atol)
        .rhs_implicit(
            move |x: &[f64], _p: &[f64], t: f64, y: &mut [f64]| pr.rhs(t, x, y),
            move |x: &[f64], _p: &[f64], t: f64, v: &[f64], y: &mut [f64]| {
                let mut j = jac.borrow_mut();
                pj.jacobian_sparse(t, x, &mut j);
                y.fill(0.0);
                for (&val, (r, c)) in j.iter() {
                    y[r] += val * v[c];
                }
            },
        )
        .init(
            move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0),
            n,
        )
        .build()
        .ok()?;
    let mut solver = problem.bdf::<FaerSparseLU<f64>>().ok()?;
    solver.set_stop_time(p.t_end()).ok()?;
    loop {
        match solver.step() {
            Ok(OdeSolverStopReason::TstopReached) => break,
            Ok(_) => {}
            Err(_) => return None,
        }
    }
    let y = solver.state().y.clone_as_vec();
    let st = solver.get_statistics();
    Some((
        y,
        [
            st.number_of_steps,
            st.number_of_linear_solver_setups,
            st.number_of_linear_solver_setups,
            0,
            st.number_of_nonlinear_solver_iterations,
        ],
    ))
}

/// The quarter-decade ladder of the `fit` form, `10^(-2 - i/4)` to 1e-9.
fn fine_ladder() -> Vec<f64> {
    (0..=28)
        .map(|i| 10f64.powf(-2.0 - f64::from(i) / 4.0))
        .collect()
}

/// The least-squares line through `(x_i, y_i)`: `(value at x, slope)`.
fn fit_line(points: &[(f64, f64)], x: f64) -> (f64, f64) {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let b = sxy / sxx;
    (my + b * (x - mx), b)
}

/// The `fit` form for one problem (see the crate docs).
fn fit_with<P: TestProblem + Clone + Send + 'static>(
    p: &P,
    repeats: usize,
    solvers: &[(&str, Solver<P>)],
) {
    const TARGET: f64 = 1e-4;
    const WINDOW: (f64, f64) = (1e-5, 1e-3);
    let (reference, floor) = (p.reference(), p.floor());
    for &(name, solve) in solvers {
        // (ln err, ln t, ln steps, ln newton) of the rungs in the window.
        let mut rungs: Vec<[f64; 4]> = Vec::new();
        for rtol in fine_ladder() {
            let Some((y, stats)) = solve(p, rtol) else {
                continue;
            };
            let err = mixed_error(&y, &reference, &floor);
            if (WINDOW.0..=WINDOW.1).contains(&err) {
                let t = time(solve, p, rtol, repeats);
                let (steps, newton) = (stats[0] as f64, stats[4] as f64);
                rungs.push([err.ln(), t.ln(), steps.ln(), newton.ln()]);
            }
            if err < 1e-6 {
                break;
            }
        }
        if rungs.len() < 2 {
            println!("{},{name},{},,,,", p.name(), rungs.len());
            continue;
        }
        let at = |k: usize| {
            let pts: Vec<(f64, f64)> = rungs.iter().map(|r| (r[0], r[k])).collect();
            fit_line(&pts, TARGET.ln())
        };
        let (t, slope) = at(1);
        println!(
            "{},{name},{},{:.6e},{:.0},{:.0},{slope:.3}",
            p.name(),
            rungs.len(),
            t.exp(),
            at(2).0.exp(),
            at(3).0.exp(),
        );
    }
}

fn ladder() -> Vec<f64> {
    let mut r = Vec::new();
    for e in 2..=10 {
        let d = 10f64.powi(-e);
        r.push(d);
        if e < 10 {
            r.push(d * 0.3);
        }
    }
    r
}

/// Times `solve` at `rtol` (median of `repeats` runs).
fn time<P>(solve: fn(&P, f64) -> Run, p: &P, rtol: f64, repeats: usize) -> f64 {
    let mut times: Vec<f64> = (0..repeats.max(1))
        .map(|_| {
            let start = Instant::now();
            let r = solve(p, rtol);
            let dt = start.elapsed().as_secs_f64();
            assert!(r.is_some());
            dt
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Runs the rtol ladder until the error is below the target; prints the
/// first rung that meets it, and the work-precision estimate of the time
/// at error 1e-4 (log time interpolated linearly in log error between the
/// last rung above the target and the first one below it).
fn compare<P: TestProblem + Clone + Send + 'static>(p: &P, repeats: usize) {
    compare_with(
        p,
        repeats,
        &[("hookean-ode", ours::<P>), ("diffsol", diffsol_bdf::<P>)],
    );
}

fn compare_sparse<P: TestProblem + Clone + Send + 'static>(p: &P, repeats: usize) {
    compare_with(
        p,
        repeats,
        &[
            ("hookean-ode sparse LU", ours::<P>),
            ("diffsol faer sparse LU", diffsol_bdf_sparse::<P>),
        ],
    );
}

type Solver<P> = fn(&P, f64) -> Run;

fn compare_with<P: TestProblem + Clone + Send + 'static>(
    p: &P,
    repeats: usize,
    solvers: &[(&str, Solver<P>)],
) {
    const TARGET: f64 = 1e-4;
    let reference = p.reference();
    let floor = p.floor();
    for &(name, solve) in solvers {
        let mut above: Option<(f64, f64)> = None;
        let mut found = false;
        for rtol in ladder() {
            let Some((y, stats)) = solve(p, rtol) else {
                continue;
            };
            let err = mixed_error(&y, &reference, &floor);
            let t = time(solve, p, rtol, repeats);
            if !(err <= TARGET) {
                above = Some((err, t));
                continue;
            }
            let at_target = match above {
                Some((e0, t0)) if e0.is_finite() && err > 0.0 => {
                    let w = (TARGET.ln() - e0.ln()) / (err.ln() - e0.ln());
                    (t0.ln() + w * (t.ln() - t0.ln())).exp()
                }
                _ => t,
            };
            println!(
                "{},{name},{rtol:e},{err:.3e},{},{},{},{},{},{t:.6e},{at_target:.6e}",
                p.name(),
                stats[0],
                stats[1],
                stats[2],
                stats[3],
                stats[4],
            );
            found = true;
            break;
        }
        if !found {
            println!("{},{name},,,,,,,,,failed at every rtol", p.name());
        }
    }
}

/// One problem with one solver `runs` times (for callgrind): prints the
/// error and the statistics of the first run.
fn prof<P: TestProblem + Clone + Send + 'static>(p: &P, rtol: f64, solver: &str, runs: usize) {
    let solve: Solver<P> = match solver {
        "ours" => ours::<P>,
        "diffsol" => diffsol_bdf::<P>,
        "diffsol-sparse" => diffsol_bdf_sparse::<P>,
        _ => panic!("solver: ours, diffsol or diffsol-sparse"),
    };
    let (y, stats) = solve(p, rtol).expect("the solve failed");
    for _ in 1..runs {
        std::hint::black_box(solve(p, rtol));
    }
    let err = mixed_error(&y, &p.reference(), &p.floor());
    println!("{},{solver},{rtol:e},{err:.3e},{stats:?},{y:?}", p.name());
}

fn prof_main(args: &[String]) {
    let name = args.first().map_or("", String::as_str);
    let rtol: f64 = args.get(1).and_then(|a| a.parse().ok()).expect("RTOL");
    let solver = args.get(2).map_or("ours", String::as_str);
    let runs = args.get(3).and_then(|a| a.parse().ok()).unwrap_or(1);
    match name {
        "robertson-40" => prof(&Robertson { t_end: 40.0 }, rtol, solver, runs),
        "robertson-1e5" => prof(&Robertson { t_end: 1e5 }, rtol, solver, runs),
        "vanderpol-1000" => prof(&VanDerPol, rtol, solver, runs),
        "hires" => prof(&Hires, rtol, solver, runs),
        "orego" => prof(&Orego, rtol, solver, runs),
        "e5" => prof(&E5, rtol, solver, runs),
        "spring-chain-50" => prof(&SpringChain::new(false), rtol, solver, runs),
        "spring-chain-50-sparse" => prof(&SpringChain::new(true), rtol, solver, runs),
        _ => panic!("unknown problem {name}"),
    }
}

/// The `fit` form on the problems of the comparison (the chain with dense
/// and with sparse LU, as in `main`).
fn fit_main(repeats: usize) {
    println!("problem,solver,rungs,wall_s_fit_1e-4,steps_fit,newton_fit,slope");
    macro_rules! both {
        ($p:expr) => {{
            let p = $p;
            fit_with(
                &p,
                repeats,
                &[("hookean-ode", ours), ("diffsol", diffsol_bdf)],
            );
        }};
    }
    both!(Robertson { t_end: 40.0 });
    both!(Robertson { t_end: 1e5 });
    both!(VanDerPol);
    both!(Hires);
    both!(Orego);
    both!(E5);
    both!(SpringChain::new(false));
    fit_with(
        &SpringChain::new(true),
        repeats,
        &[
            ("hookean-ode sparse LU", ours),
            ("diffsol faer sparse LU", diffsol_bdf_sparse),
        ],
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("prof") {
        prof_main(&args[1..]);
        return;
    }
    if args.first().map(String::as_str) == Some("fit") {
        fit_main(args.get(1).and_then(|a| a.parse().ok()).unwrap_or(11));
        return;
    }
    let repeats = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(11);
    println!(
        "problem,solver,rtol,error,steps,jac_evals,lu_setups,rhs_evals,newton_iters,wall_s,wall_s_at_1e-4"
    );
    compare(&Robertson { t_end: 40.0 }, repeats);
    compare(&Robertson { t_end: 1e5 }, repeats);
    compare(&VanDerPol, repeats);
    compare(&Hires, repeats);
    compare(&Orego, repeats);
    compare(&E5, repeats);
    compare(&SpringChain::new(false), repeats);
    // Both with a sparse LU on the chain's pattern (the rows above are dense).
    compare_sparse(&SpringChain::new(true), repeats);
}
