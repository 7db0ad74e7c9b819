//! The step-wise API, the driver, the reduced velocity form, constraints,
//! energy behaviour, variable-step BDF2 and the typed failures.

use hookean_ode::Integrator;
use std::ops::ControlFlow;

use hookean_ode::tutorial::{Dahlquist, LinearOscillator};
use hookean_ode::workprecision::{self, Sweep};
use hookean_ode::{
    FirstOrderForm, FirstOrderIntegrator, FirstOrderProblem, ForcingTerm, Method, NewtonMethod,
    NewtonOptions, OdeError, SecondOrderIntegrator, SolverOptions, StepControl, StepSizePolicy,
};
use hookean_testkit::springs::SpringChain;

fn tight(h: f64) -> SolverOptions {
    SolverOptions {
        h,
        newton: NewtonOptions {
            rtol: 1e-13,
            atol: 1e-14,
            linear_rtol: 1e-13,
            ..SolverOptions::default_newton()
        },
        ..SolverOptions::default()
    }
}

/// Three particles, two springs, stretched and moving: one implicit step in
/// the reduced velocity form (PCG) equals the step on the 6N first-order
/// system (6) with Newton and a dense LU.
#[test]
fn reduced_form_and_first_order_form_give_the_same_step() {
    // No damping and stretched springs: the clamped spring Jacobian is then
    // exact, so both Newton iterations converge fast to the same root.
    let chain = SpringChain::new(3, 0.2, 50.0, 0.0, 1.0, 9.81);
    let (mut x0, mut v0) = chain.initial_state(1.2);
    x0[4] = 0.3; // bend the chain
    x0[8] = -0.2;
    v0[0] = 0.5;
    v0[5] = -1.0;
    for method in [
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(2),
        Method::Bdf(3),
    ] {
        let h = 0.02;
        let mut reduced =
            SecondOrderIntegrator::new(chain.clone(), method.clone(), 0.0, &x0, &v0, tight(h))
                .unwrap();
        let mut y0 = x0.clone();
        y0.extend_from_slice(&v0);
        let mut full = FirstOrderIntegrator::new(
            FirstOrderForm::new(chain.clone()),
            method.clone(),
            0.0,
            &y0,
            tight(h),
        )
        .unwrap();
        // While the springs stay stretched (the clamp inactive).
        for _ in 0..4 {
            reduced.step().unwrap();
            full.step().unwrap();
        }
        let diff = reduced
            .state()
            .iter()
            .zip(full.y())
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff < 1e-10, "{method}: max difference {diff}");
        // The step really moved the system.
        let moved = reduced
            .state()
            .iter()
            .zip(&y0)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(moved > 1e-3);
        assert_eq!(reduced.stats().num_rejected_steps(), 0);
        assert_eq!(full.stats().num_rejected_steps(), 0);
        assert!(reduced.stats().num_lin_iters > 0);
        assert_eq!(full.stats().num_lin_iters, 0);
    }
}

#[test]
fn pinned_particles_stay_put() {
    let mut chain = SpringChain::new(10, 0.01, 1e3, 0.1, 0.1, 9.81);
    chain.pinned = vec![0, 9];
    let (x0, v0) = chain.initial_state(1.0);
    for method in [
        Method::ImplicitEuler,
        Method::Bdf(2),
        Method::Bdf2Variable,
        Method::FbEuler,
        Method::Verlet,
        Method::Rk4,
        Method::ImplicitMidpoint,
        Method::Bdf(4),
    ] {
        let h = if method.is_implicit() { 1e-2 } else { 1e-4 };
        let mut ode = SecondOrderIntegrator::new(
            chain.clone(),
            method.clone(),
            0.0,
            &x0,
            &v0,
            SolverOptions::with_h(h),
        )
        .unwrap();
        ode.integrate(0.2).unwrap();
        for p in [0, 9] {
            for c in 0..3 {
                assert_eq!(ode.v()[3 * p + c], 0.0, "{method}");
                assert!(
                    (ode.x()[3 * p + c] - x0[3 * p + c]).abs() < 1e-12,
                    "{method}"
                );
            }
        }
        // The middle sagged under gravity.
        assert!(
            ode.x()[3 * 5 + 2] < -1e-3,
            "{method}: {}",
            ode.x()[3 * 5 + 2]
        );
        assert_eq!(ode.constraints().len(), 2);
    }
}

/// Starting each step's first PCG solve from the previous step's velocity
/// change (with pins, i.e. filtered PCG) reaches the same Newton root with
/// fewer PCG iterations on a smoothly sagging chain.
#[test]
fn warm_started_linear_solves_reach_the_same_steps_in_fewer_iterations() {
    let mut chain = SpringChain::new(12, 0.01, 1e3, 0.1, 0.1, 9.81);
    chain.pinned = vec![0, 11];
    let (x0, v0) = chain.initial_state(1.0);
    for method in [Method::ImplicitEuler, Method::Bdf(2)] {
        let run = |warm_start: bool| {
            let mut opts = SolverOptions::with_h(0.01);
            opts.newton = NewtonOptions {
                method: NewtonMethod::Inexact(ForcingTerm::Constant(0.1)),
                rtol: 1e-10,
                atol: 1e-14,
                max_iter: 30,
                ..SolverOptions::default_newton()
            };
            opts.warm_start = warm_start;
            let mut ode =
                SecondOrderIntegrator::new(chain.clone(), method.clone(), 0.0, &x0, &v0, opts)
                    .unwrap();
            ode.integrate(0.3).unwrap();
            (ode.state().to_vec(), ode.stats().num_lin_iters)
        };
        let (cold, cold_its) = run(false);
        let (warm, warm_its) = run(true);
        let diff = cold
            .iter()
            .zip(&warm)
            .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(diff < 1e-8, "{method}: states differ by {diff}");
        assert!(
            warm_its < cold_its,
            "{method}: {warm_its} warm-started vs {cold_its} cold PCG iterations"
        );
    }
}

/// Verlet keeps the energy of y'' = -5 y in a bounded band over 1000
/// periods; explicit Euler multiplies it by 1 + h^2 omega^2 every step.
#[test]
fn verlet_energy_is_bounded_explicit_euler_grows() {
    let o = LinearOscillator::undamped(5.0);
    let omega = 5f64.sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    let h = 0.05;
    let e0 = o.energy(o.z0, o.v0);
    let mut band = 0.0_f64;
    let mut ode = SecondOrderIntegrator::new(
        o.particle(),
        Method::Verlet,
        0.0,
        &o.x0(),
        &o.v0_vec(),
        SolverOptions::with_h(h),
    )
    .unwrap();
    ode.integrate_with(1000.0 * period, |_, s| {
        // The state is [x; v] (3 + 3 components).
        band = band.max((o.energy(s[2], s[5]) / e0 - 1.0).abs());
        ControlFlow::Continue(())
    })
    .unwrap();
    // The modified energy of Verlet differs from E by O((h omega)^2): (h omega)^2 / 4 = 0.3 %.
    assert!(band < (h * omega).powi(2) / 2.0, "band {band}");
    let steps = ode.stats().num_steps;
    assert!(steps >= (1000.0 * period / h) as usize);

    let mut ode = SecondOrderIntegrator::new(
        o.particle(),
        Method::ExplicitEuler,
        0.0,
        &o.x0(),
        &o.v0_vec(),
        SolverOptions::with_h(h),
    )
    .unwrap();
    let n = (10.0 * period / h).round() as i32;
    for _ in 0..n {
        ode.step().unwrap();
    }
    let e = o.energy(ode.x()[2], ode.v()[2]);
    let expected = e0 * (1.0 + h * h * omega * omega).powi(n);
    assert!((e / expected - 1.0).abs() < 1e-9, "{e} vs {expected}");
    assert!(e > 100.0 * e0);
}

/// Steps and the largest error over the trajectory (at the step points,
/// against the exact solution) of a run on example 3 (first-order form).
fn trajectory_error(method: Method, opts: SolverOptions) -> (usize, f64, f64) {
    let o = LinearOscillator::example3();
    let mut ode = FirstOrderIntegrator::new(o.first_order(), method, 0.0, &o.y0(), opts).unwrap();
    let mut max_err = 0.0_f64;
    ode.integrate_with(o.t_end, |r, y| {
        let e = o.exact(r.t);
        max_err = max_err.max(((y[0] - e[0]).powi(2) + (y[1] - e[1]).powi(2)).sqrt());
        ControlFlow::Continue(())
    })
    .unwrap();
    let e = o.exact(o.t_end);
    let end_err = ((ode.y()[0] - e[0]).powi(2) + (ode.y()[1] - e[1]).powi(2)).sqrt();
    (ode.stats().num_steps, max_err, end_err)
}

/// Variable-step BDF2 meets a tolerance on example 3 with fewer steps than
/// fixed-step BDF2 needs for the same accuracy. Accuracy is the largest
/// error over the trajectory: the error at t_end alone rewards any step
/// size early on, because the problem damps early errors by e^{-10}.
#[test]
fn variable_bdf2_beats_fixed_bdf2_on_example_3() {
    let var = |tol: f64| {
        trajectory_error(
            Method::Bdf2Variable,
            SolverOptions {
                h: 1e-3,
                rtol: tol,
                atol: tol.into(),
                ..SolverOptions::default()
            },
        )
    };
    let (steps_5, max_5, _) = var(1e-5);
    let (steps_7, max_7, end_7) = var(1e-7);
    // Tighter tolerance: more steps, smaller errors (order 2: the error
    // follows tol^{2/3} for a local error ~ h^3).
    assert!(steps_7 > steps_5);
    assert!(max_7 < max_5 / 10.0, "{max_7} vs {max_5}");
    // The end-point error is of the order of the tolerance.
    assert!(end_7 < 50.0 * 1e-7, "{end_7}");
    for tol in [1e-5, 1e-7] {
        let (steps, max_err, _) = var(tol);
        // Fixed-step BDF2: the fewest steps (by doubling) that reach the same accuracy.
        let mut n = 100;
        let needed = loop {
            let (s, e, _) = trajectory_error(Method::Bdf(2), SolverOptions::with_h(2.0 / n as f64));
            if e <= max_err {
                break s;
            }
            n *= 2;
            assert!(n < 100_000);
        };
        assert!(
            steps < needed,
            "tol {tol}: variable {steps} steps (error {max_err:e}) vs fixed {needed} steps"
        );
    }
}

/// The particle (reduced velocity form) and the first-order form of
/// variable-step BDF2 take the same steps on example 3.
#[test]
fn variable_bdf2_particle_matches_first_order_form() {
    let o = LinearOscillator::example3();
    let exact = o.exact(o.t_end);
    let base = SolverOptions {
        h: 1e-3,
        ..tight(1e-3)
    };
    let sweep = Sweep::Tolerances(vec![1e-6]);
    let first = workprecision::first_order(
        || o.first_order(),
        &Method::Bdf2Variable,
        0.0,
        &o.y0(),
        o.t_end,
        &exact,
        &sweep,
        &base,
    )
    .unwrap();
    let particle = workprecision::second_order(
        || o.particle(),
        &Method::Bdf2Variable,
        0.0,
        &o.x0(),
        &o.v0_vec(),
        o.t_end,
        &o.exact_particle(o.t_end),
        &sweep,
        &base,
    )
    .unwrap();
    // The particle's error norm averages over six components (four of
    // them zero), so the step counts differ a little; the accuracy is alike.
    for r in [&first[0], &particle[0]] {
        assert!(r.error < 50.0 * 1e-6, "{}", r.error);
    }
    let ratio = first[0].stats.num_steps as f64 / particle[0].stats.num_steps as f64;
    assert!((0.5..2.0).contains(&ratio), "{ratio}");
}

#[test]
fn newton_iteration_controller_runs_example_3() {
    let o = LinearOscillator::example3();
    let opts = SolverOptions {
        h: 1e-3,
        step: StepSizePolicy {
            control: StepControl::newton_iterations(),
            ..StepSizePolicy::default()
        },
        ..SolverOptions::default()
    };
    let mut ode =
        FirstOrderIntegrator::new(o.first_order(), Method::Bdf2Variable, 0.0, &o.y0(), opts)
            .unwrap();
    ode.integrate(o.t_end).unwrap();
    assert_eq!(ode.t(), o.t_end);
    // A linear problem converges in one Newton iteration (the residual
    // test after the update), so the controller grows h by 1.5 each step.
    let s = ode.stats();
    assert_eq!(s.num_nonlin_solv_iters, s.num_steps);
    assert!(s.num_steps < 30, "{}", s.num_steps);
}

#[test]
fn statistics_count_what_the_methods_do() {
    let p = Dahlquist { lambda: -2.0 };
    let run = |m: Method| {
        let mut ode =
            FirstOrderIntegrator::new(p, m, 0.0, &[1.0], SolverOptions::with_h(0.01)).unwrap();
        ode.integrate(1.0).unwrap().stats
    };
    let s = run(Method::Rk4);
    assert_eq!(
        (s.num_steps, s.num_rhs_evals_total(), s.num_jac_evals),
        (100, 400, 0)
    );
    let s = run(Method::Midpoint);
    assert_eq!(s.num_rhs_evals_total(), 200);
    // Linear problem, analytic Jacobian: one Newton iteration per step (two
    // residual evaluations: before and after the update).
    let s = run(Method::ImplicitEuler);
    assert_eq!(
        (
            s.num_steps,
            s.num_nonlin_solv_iters,
            s.num_jac_evals,
            s.num_lin_solv_setups,
            s.num_rhs_evals_total()
        ),
        (100, 100, 100, 100, 200)
    );
    // Simplified Newton keeps the Jacobian across steps of the same h.
    let mut opts = SolverOptions::with_h(0.01);
    opts.newton.method = NewtonMethod::Simplified;
    let mut ode = FirstOrderIntegrator::new(p, Method::ImplicitEuler, 0.0, &[1.0], opts).unwrap();
    let s = ode.integrate(1.0).unwrap().stats;
    assert!(s.num_jac_evals < 10, "{s:?}");
    assert!((ode.y()[0] - (1.0f64 / 1.02).powi(100)).abs() < 1e-12);
    // Without an analytic Jacobian: one extra f evaluation per column.
    struct NoJac;
    impl FirstOrderProblem for NoJac {
        fn dim(&self) -> usize {
            1
        }
        fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
            dy[0] = -2.0 * y[0];
        }
    }
    let mut ode = FirstOrderIntegrator::new(
        NoJac,
        Method::ImplicitEuler,
        0.0,
        &[1.0],
        SolverOptions::with_h(0.01),
    )
    .unwrap();
    let s = ode.integrate(1.0).unwrap().stats;
    // Two residuals, and f at y plus one column for the difference quotient.
    assert_eq!(s.num_rhs_evals_total(), 4 * s.num_steps);
    assert!((ode.y()[0] - (1.0f64 / 1.02).powi(100)).abs() < 1e-9);
    // Verlet: one force per step (plus the first).
    let o = LinearOscillator::undamped(5.0);
    let mut ode = SecondOrderIntegrator::new(
        o.particle(),
        Method::Verlet,
        0.0,
        &o.x0(),
        &o.v0_vec(),
        SolverOptions::with_h(0.01),
    )
    .unwrap();
    let s = ode.integrate(1.0).unwrap().stats;
    assert_eq!((s.num_steps, s.num_rhs_evals_total()), (100, 101));
}

#[test]
fn step_wise_api_and_callback() {
    // Change lambda between steps: the solution follows e^{-t} then e^{-3 (t - 0.5)}.
    let mut ode = FirstOrderIntegrator::new(
        Dahlquist { lambda: -1.0 },
        Method::Rk4,
        0.0,
        &[1.0],
        SolverOptions::with_h(1e-3),
    )
    .unwrap();
    while ode.t() < 0.5 - 1e-12 {
        let r = ode.step().unwrap();
        assert!((r.h - 1e-3).abs() < 1e-18 && r.rejected == 0);
    }
    ode.problem_mut().lambda = -3.0;
    ode.integrate(1.0).unwrap();
    let expected = (-0.5f64).exp() * (-1.5f64).exp();
    assert!(
        (ode.y()[0] - expected).abs() < 1e-12,
        "{} vs {expected}",
        ode.y()[0]
    );
    assert_eq!(ode.t(), 1.0);
    // A callback stops the run.
    let mut ode = FirstOrderIntegrator::new(
        Dahlquist { lambda: -1.0 },
        Method::Bdf(3),
        0.0,
        &[1.0],
        SolverOptions::with_h(0.01),
    )
    .unwrap();
    let mut calls = 0;
    let info = ode
        .integrate_with(1.0, |_, _| {
            calls += 1;
            if calls == 10 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
    assert!(info.stopped_by_callback);
    assert!((info.t - 0.1).abs() < 1e-12);
    assert_eq!(info.stats.num_steps, 10);
    // The last step is shortened to land on t_end.
    let mut ode = FirstOrderIntegrator::new(
        Dahlquist { lambda: -1.0 },
        Method::Bdf(2),
        0.0,
        &[1.0],
        SolverOptions::with_h(0.3),
    )
    .unwrap();
    ode.integrate(1.0).unwrap();
    assert_eq!(ode.t(), 1.0);
    assert_eq!(ode.stats().num_steps, 4);
    // set_state restarts; a state of the wrong size is a typed error.
    assert!(matches!(
        ode.restart(0.0, &[1.0, 2.0]),
        Err(OdeError::DimensionMismatch { .. })
    ));
    ode.restart(0.0, &[1.0]).unwrap();
    ode.integrate(0.3).unwrap();
    assert!((ode.y()[0] - (-0.3f64).exp()).abs() < 1e-3);
}

#[test]
fn method_names_round_trip() {
    for m in Method::all_named() {
        let name = m.to_string();
        assert_eq!(name.parse::<Method>().unwrap(), m);
    }
    assert_eq!(Method::all_named().len(), 14);
    assert!(matches!(
        "bdf7".parse::<Method>(),
        Err(OdeError::UnknownMethod { .. })
    ));
    assert!(matches!(
        "rk5".parse::<Method>(),
        Err(OdeError::UnknownMethod { .. })
    ));
    // Second-order-only methods on a first-order problem.
    assert!(matches!(
        FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            Method::Verlet,
            0.0,
            &[1.0],
            SolverOptions::default()
        ),
        Err(OdeError::UnsupportedMethod { .. })
    ));
}

/// y' = lambda y that turns bad after `t_bad`: NaN right-hand side, or a
/// Jacobian with the wrong sign.
struct Faulty {
    lambda: f64,
    t_bad: f64,
    nan: bool,
}

impl FirstOrderProblem for Faulty {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = if self.nan && t > self.t_bad {
            f64::NAN
        } else {
            self.lambda * y[0]
        };
    }
    fn jacobian(&self, t: f64, _y: &[f64], jac: &mut [f64]) -> bool {
        jac[0] = if !self.nan && t > self.t_bad {
            -self.lambda
        } else {
            self.lambda
        };
        true
    }
}

#[test]
fn failures_are_typed_and_carry_the_time_reached() {
    // NaN in the state.
    let p = Faulty {
        lambda: -1.0,
        t_bad: 0.3,
        nan: true,
    };
    let mut ode =
        FirstOrderIntegrator::new(p, Method::Rk4, 0.0, &[1.0], SolverOptions::with_h(0.01))
            .unwrap();
    match ode.integrate(1.0) {
        Err(OdeError::NonFinite { t, .. }) => assert!((t - 0.3).abs() < 0.011, "t = {t}"),
        other => panic!("expected NonFinite, got {other:?}"),
    }
    assert!(
        FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            Method::Rk4,
            0.0,
            &[f64::NAN],
            SolverOptions::default()
        )
        .is_err()
    );

    // Newton failure after the allowed retries (fixed step).
    let p = Faulty {
        lambda: -50.0,
        t_bad: 0.5,
        nan: true,
    };
    let opts = SolverOptions {
        h: 0.1,
        max_retries: 2,
        ..SolverOptions::default()
    };
    let mut ode = FirstOrderIntegrator::new(p, Method::ImplicitEuler, 0.0, &[1.0], opts).unwrap();
    match ode.integrate(2.0) {
        Err(OdeError::NewtonFailed { t, retries, .. }) => {
            assert!((t - 0.5).abs() < 1e-9, "t = {t}");
            assert_eq!(retries, 2);
        }
        other => panic!("expected NewtonFailed, got {other:?}"),
    }
    assert!((ode.t() - 0.5).abs() < 1e-9);
    assert_eq!(ode.stats().num_rejected_steps(), 3);

    // The variable-step method shrinks h after Newton failures until it underflows.
    let p = Faulty {
        lambda: -50.0,
        t_bad: 0.5,
        nan: true,
    };
    let opts = SolverOptions {
        h: 0.1,
        step: StepSizePolicy {
            h_min: 1e-3,
            ..StepSizePolicy::default()
        },
        max_retries: 20,
        rtol: 1e-2,
        atol: 1e-2.into(),
        ..SolverOptions::default()
    };
    let mut ode = FirstOrderIntegrator::new(p, Method::Bdf2Variable, 0.0, &[1.0], opts).unwrap();
    match ode.integrate(2.0) {
        Err(OdeError::StepSizeUnderflow { t, h }) => {
            assert!(t > 0.4 && t <= 0.5, "t = {t}");
            assert!(h < 1e-3);
        }
        other => panic!("expected StepSizeUnderflow, got {other:?}"),
    }

    // Bad options and inputs.
    let bad = SolverOptions {
        h: -1.0,
        ..SolverOptions::default()
    };
    assert!(matches!(
        FirstOrderIntegrator::new(Dahlquist { lambda: -1.0 }, Method::Rk4, 0.0, &[1.0], bad),
        Err(OdeError::InvalidParameter { name: "h", .. })
    ));
    let o = LinearOscillator::example3();
    assert!(matches!(
        SecondOrderIntegrator::new(
            o.particle(),
            Method::Verlet,
            0.0,
            &[0.0; 2],
            &o.v0_vec(),
            SolverOptions::default()
        ),
        Err(OdeError::DimensionMismatch { .. })
    ));
    let mut ode = FirstOrderIntegrator::new(
        Dahlquist { lambda: -1.0 },
        Method::Rk4,
        0.0,
        &[1.0],
        SolverOptions::default(),
    )
    .unwrap();
    ode.integrate(0.5).unwrap();
    assert!(matches!(
        ode.integrate(0.1),
        Err(OdeError::InvalidParameter { .. })
    ));
}

/// The heat equation y_i' = c (y_{i-1} - 2 y_i + y_{i+1}) on n points with
/// zero boundary values, with a sparse (tridiagonal) Jacobian or none.
struct Heat {
    n: usize,
    c: f64,
    sparse: bool,
}

impl FirstOrderProblem for Heat {
    fn dim(&self) -> usize {
        self.n
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        for i in 0..self.n {
            let l = if i > 0 { y[i - 1] } else { 0.0 };
            let r = if i + 1 < self.n { y[i + 1] } else { 0.0 };
            dy[i] = self.c * (l - 2.0 * y[i] + r);
        }
    }
    fn sparse_jacobian_pattern(&self) -> Option<sprs::CsMat<f64>> {
        if !self.sparse {
            return None;
        }
        let mut tri = sprs::TriMat::new((self.n, self.n));
        for i in 0..self.n {
            for j in i.saturating_sub(1)..(i + 2).min(self.n) {
                tri.add_triplet(i, j, 0.0);
            }
        }
        Some(tri.to_csr())
    }
    fn jacobian_sparse(&self, _t: f64, _y: &[f64], jac: &mut sprs::CsMat<f64>) -> bool {
        let c = self.c;
        for (i, mut row) in jac.outer_iterator_mut().enumerate() {
            for (j, v) in row.iter_mut() {
                *v = if i == j { -2.0 * c } else { c };
            }
        }
        true
    }
}

#[test]
fn sparse_jacobians_give_the_exact_implicit_steps() {
    let (n, c) = (20, 100.0);
    // The first eigenvector of the discrete Laplacian and its eigenvalue.
    let theta = std::f64::consts::PI / (n + 1) as f64;
    let v: Vec<f64> = (1..=n).map(|j| (theta * j as f64).sin()).collect();
    let mu = -4.0 * c * (theta / 2.0).sin().powi(2);
    let (h, steps) = (0.01, 50);
    for (method, r) in [
        (Method::ImplicitEuler, 1.0 / (1.0 - h * mu)),
        (
            Method::ImplicitMidpoint,
            (1.0 + h * mu / 2.0) / (1.0 - h * mu / 2.0),
        ),
    ] {
        let mut sparse = FirstOrderIntegrator::new(
            Heat { n, c, sparse: true },
            method.clone(),
            0.0,
            &v,
            SolverOptions::with_h(h),
        )
        .unwrap();
        sparse.integrate(h * steps as f64).unwrap();
        let factor = r.powi(steps);
        for j in 0..n {
            assert!(
                (sparse.y()[j] - factor * v[j]).abs() < 1e-12,
                "{method}: {} vs {}",
                sparse.y()[j],
                factor * v[j]
            );
        }
        let mut dense = FirstOrderIntegrator::new(
            Heat {
                n,
                c,
                sparse: false,
            },
            method.clone(),
            0.0,
            &v,
            SolverOptions::with_h(h),
        )
        .unwrap();
        dense.integrate(h * steps as f64).unwrap();
        for j in 0..n {
            assert!((sparse.y()[j] - dense.y()[j]).abs() < 1e-8);
        }
        // No finite differences with the sparse Jacobian: two residuals per step.
        assert_eq!(sparse.stats().num_rhs_evals_total(), 2 * steps as usize);
    }
    // A pattern without the diagonal is rejected.
    struct NoDiag;
    impl FirstOrderProblem for NoDiag {
        fn dim(&self) -> usize {
            2
        }
        fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
            dy.copy_from_slice(y);
        }
        fn sparse_jacobian_pattern(&self) -> Option<sprs::CsMat<f64>> {
            let mut tri = sprs::TriMat::new((2, 2));
            tri.add_triplet(0, 1, 0.0);
            tri.add_triplet(1, 0, 0.0);
            Some(tri.to_csr())
        }
    }
    assert!(matches!(
        FirstOrderIntegrator::new(
            NoDiag,
            Method::ImplicitEuler,
            0.0,
            &[1.0, 1.0],
            SolverOptions::default()
        ),
        Err(OdeError::InvalidParameter { .. })
    ));
}
