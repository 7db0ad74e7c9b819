//! Newton variants on standard test functions with known solutions:
//! Rosenbrock, Powell singular, a discretised Bratu problem.

use hookean_nonlinear::*;
use hookean_sparse::{Identity, Ssor};

// ---------------------------------------------------------------- dense systems

/// A dense test system that records every iterate at which `G` is evaluated.
struct Dense<F, Jf> {
    n: usize,
    g: F,
    j: Jf,
    iterates: Vec<Vec<f64>>,
}

impl<F, Jf> Dense<F, Jf>
where
    F: FnMut(&[f64], &mut [f64]),
    Jf: FnMut(&[f64], &mut faer::Mat<f64>),
{
    fn new(n: usize, g: F, j: Jf) -> Self {
        Self {
            n,
            g,
            j,
            iterates: Vec::new(),
        }
    }
}

impl<F, Jf> NonlinearSystem for Dense<F, Jf>
where
    F: FnMut(&[f64], &mut [f64]),
    Jf: FnMut(&[f64], &mut faer::Mat<f64>),
{
    type Jacobian = faer::Mat<f64>;
    fn dim(&self) -> usize {
        self.n
    }
    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.iterates.push(y.to_vec());
        (self.g)(y, g);
        Ok(())
    }
    fn jacobian(&mut self, y: &[f64], jac: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
        (self.j)(y, jac);
        Ok(())
    }
}

fn dense_newton(n: usize, options: NewtonOptions) -> Newton<faer::Mat<f64>, DenseLu> {
    Newton::new(options, faer::Mat::zeros(n, n), DenseLu::new()).unwrap()
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[test]
fn rosenbrock_standard_form_is_solved_in_two_newton_steps() {
    // F = (10 (y - x^2), 1 - x): the second equation is linear, so one step
    // puts x = 1 exactly; the first is then linear in y: the second step lands on (1, 1).
    let mut sys = Dense::new(
        2,
        |y: &[f64], g: &mut [f64]| {
            g[0] = 10.0 * (y[1] - y[0] * y[0]);
            g[1] = 1.0 - y[0];
        },
        |y: &[f64], j: &mut faer::Mat<f64>| {
            j[(0, 0)] = -20.0 * y[0];
            j[(0, 1)] = 10.0;
            j[(1, 0)] = -1.0;
            j[(1, 1)] = 0.0;
        },
    );
    let mut y = [-1.2, 1.0];
    let stats = dense_newton(2, NewtonOptions::default())
        .solve(&mut sys, &mut y)
        .unwrap();
    assert_eq!(stats.iterations, 2);
    assert!(dist(&y, &[1.0, 1.0]) < 1e-14);
    // Hand computation of the first step: x1 = 1, y1 = 1 + (-4.84) ... = -3.84.
    assert!(dist(&sys.iterates[1], &[1.0, -3.84]) < 1e-12);
}

#[test]
fn newton_converges_quadratically_on_the_rosenbrock_gradient() {
    // grad f for f = (1 - x)^2 + 100 (y - x^2)^2; root (1, 1); Jacobian = Hessian.
    let mut sys = Dense::new(
        2,
        |p: &[f64], g: &mut [f64]| {
            let (x, y) = (p[0], p[1]);
            g[0] = -2.0 * (1.0 - x) - 400.0 * x * (y - x * x);
            g[1] = 200.0 * (y - x * x);
        },
        |p: &[f64], j: &mut faer::Mat<f64>| {
            let (x, y) = (p[0], p[1]);
            j[(0, 0)] = 2.0 - 400.0 * (y - 3.0 * x * x);
            j[(0, 1)] = -400.0 * x;
            j[(1, 0)] = -400.0 * x;
            j[(1, 1)] = 200.0;
        },
    );
    let mut y = [-1.2, 1.0];
    let options = NewtonOptions {
        rtol: 1e-15,
        atol: 1e-13,
        ..Default::default()
    };
    let stats = dense_newton(2, options).solve(&mut sys, &mut y).unwrap();
    assert!(dist(&y, &[1.0, 1.0]) < 1e-12);
    assert!(stats.iterations <= 10, "{}", stats.iterations);
    let e: Vec<f64> = sys.iterates.iter().map(|p| dist(p, &[1.0, 1.0])).collect();
    // Quadratic: e_{k+1} <= C e_k^2 once close (C about |J^-1| |G''| / 2).
    let mut checked = 0;
    for k in 0..e.len() - 1 {
        if e[k] < 0.1 && e[k + 1] > 1e-14 {
            assert!(e[k + 1] / (e[k] * e[k]) < 20.0, "k = {k}: {e:?}");
            checked += 1;
        }
    }
    assert!(checked >= 2, "{e:?}");
}

// The closures' types cannot be named; `impl` in both places is the simplest.
#[allow(clippy::type_complexity)]
fn powell() -> Dense<impl FnMut(&[f64], &mut [f64]), impl FnMut(&[f64], &mut faer::Mat<f64>)> {
    let s5 = 5f64.sqrt();
    let s10 = 10f64.sqrt();
    Dense::new(
        4,
        move |x: &[f64], g: &mut [f64]| {
            g[0] = x[0] + 10.0 * x[1];
            g[1] = s5 * (x[2] - x[3]);
            g[2] = (x[1] - 2.0 * x[2]).powi(2);
            g[3] = s10 * (x[0] - x[3]).powi(2);
        },
        move |x: &[f64], j: &mut faer::Mat<f64>| {
            j.fill(0.0);
            j[(0, 0)] = 1.0;
            j[(0, 1)] = 10.0;
            j[(1, 2)] = s5;
            j[(1, 3)] = -s5;
            let a = 2.0 * (x[1] - 2.0 * x[2]);
            j[(2, 1)] = a;
            j[(2, 2)] = -2.0 * a;
            let b = 2.0 * s10 * (x[0] - x[3]);
            j[(3, 0)] = b;
            j[(3, 3)] = -b;
        },
    )
}

#[test]
fn newton_is_only_linear_on_powell_singular() {
    // Root 0 with a singular Jacobian there: the quadratic parts halve each
    // step (for g(t) = t^2, Newton gives t/2), so e_{k+1}/e_k -> 1/2.
    let mut sys = powell();
    let mut y = [3.0, -1.0, 0.0, 1.0];
    let options = NewtonOptions {
        atol: 1e-16,
        rtol: 1e-14,
        ..Default::default()
    };
    let stats = dense_newton(4, options).solve(&mut sys, &mut y).unwrap();
    assert!(dist(&y, &[0.0; 4]) < 1e-6);
    assert!(stats.iterations > 15, "linear convergence needs many steps");
    let e: Vec<f64> = sys.iterates.iter().map(|p| dist(p, &[0.0; 4])).collect();
    for k in 5..e.len() - 1 {
        let ratio = e[k + 1] / e[k];
        assert!((ratio - 0.5).abs() < 0.02, "k = {k}: ratio {ratio}");
    }
    // theta = |s_k| / |s_{k-1}| estimates the same rate.
    assert!((stats.contraction_rate.unwrap() - 0.5).abs() < 0.02);
}

#[test]
fn iteration_limit_carries_statistics() {
    let mut sys = powell();
    let mut y = [3.0, -1.0, 0.0, 1.0];
    let options = NewtonOptions {
        max_iter: 3,
        record_history: true,
        ..Default::default()
    };
    match dense_newton(4, options).solve(&mut sys, &mut y) {
        Err(NonlinearError::MaxIterations { stats }) => {
            assert_eq!(stats.iterations, 3);
            assert_eq!(stats.residual_norms.len(), 4);
            assert_eq!(stats.jacobian_evaluations, 3);
            assert_eq!(stats.linear_setups, 3);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn diverging_and_nan_iterations_are_typed_errors() {
    // Newton on atan from y0 = 2 overshoots further every step.
    let mut atan = Dense::new(
        1,
        |y: &[f64], g: &mut [f64]| g[0] = y[0].atan(),
        |y: &[f64], j: &mut faer::Mat<f64>| j[(0, 0)] = 1.0 / (1.0 + y[0] * y[0]),
    );
    let mut y = [2.0];
    let err = dense_newton(1, NewtonOptions::default())
        .solve(&mut atan, &mut y)
        .unwrap_err();
    assert!(err.is_step_failure());
    match err {
        NonlinearError::Diverged {
            reason: DivergenceReason::Contraction { theta },
            stats,
        } => {
            assert!(theta >= 1.0);
            assert!(stats.iterations >= 3 && stats.iterations <= 6);
        }
        other => panic!("{other:?}"),
    }
    assert!(y[0].is_finite());

    // ln(y) from 3: the first step goes to 3 - 3 ln 3 < 0, where ln is NaN.
    let mut ln = Dense::new(
        1,
        |y: &[f64], g: &mut [f64]| g[0] = y[0].ln(),
        |y: &[f64], j: &mut faer::Mat<f64>| j[(0, 0)] = 1.0 / y[0],
    );
    let mut y = [3.0];
    match dense_newton(1, NewtonOptions::default()).solve(&mut ln, &mut y) {
        Err(NonlinearError::NonFinite { stats }) => assert_eq!(stats.iterations, 1),
        other => panic!("{other:?}"),
    }

    // Residual growth: G(y) = exp(y) - 1 from y = -20 (J tiny): s = e^20.
    let mut exp = Dense::new(
        1,
        |y: &[f64], g: &mut [f64]| g[0] = y[0].exp() - 1.0,
        |y: &[f64], j: &mut faer::Mat<f64>| j[(0, 0)] = y[0].exp(),
    );
    let mut y = [-20.0];
    let err = dense_newton(1, NewtonOptions::default())
        .solve(&mut exp, &mut y)
        .unwrap_err();
    assert!(
        matches!(
            err,
            NonlinearError::Diverged {
                reason: DivergenceReason::ResidualGrowth { .. },
                ..
            } | NonlinearError::NonFinite { .. }
        ),
        "{err:?}"
    );

    // Singular Jacobian: G(y) = y^2 + 1 at y = 0.
    let mut sing = Dense::new(
        1,
        |y: &[f64], g: &mut [f64]| g[0] = y[0] * y[0] + 1.0,
        |y: &[f64], j: &mut faer::Mat<f64>| j[(0, 0)] = 2.0 * y[0],
    );
    let err = dense_newton(1, NewtonOptions::default())
        .solve(&mut sing, &mut [0.0])
        .unwrap_err();
    assert!(matches!(
        err,
        NonlinearError::SingularJacobian { pivot: 0, .. }
    ));

    // Wrong sizes and NaN input.
    let err = dense_newton(1, NewtonOptions::default())
        .solve(&mut sing, &mut [0.0, 1.0])
        .unwrap_err();
    assert!(matches!(err, NonlinearError::DimensionMismatch { .. }));
    let err = dense_newton(1, NewtonOptions::default())
        .solve(&mut sing, &mut [f64::NAN])
        .unwrap_err();
    assert!(matches!(err, NonlinearError::NonFinite { .. }));
}

#[test]
fn a_kept_jacobian_that_fails_is_refreshed_once() {
    // Keep J = 10 from G_a(y) = 10 y - 1, then solve G_b(y) = 1 - y with it:
    // e_{k+1} = 1.1 e_k diverges; the RADAU5 rule retries from y0 with a fresh J.
    struct Lin(f64, f64);
    impl NonlinearSystem for Lin {
        type Jacobian = faer::Mat<f64>;
        fn dim(&self) -> usize {
            1
        }
        fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
            g[0] = self.0 * y[0] - self.1;
            Ok(())
        }
        fn jacobian(&mut self, _y: &[f64], j: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
            j[(0, 0)] = self.0;
            Ok(())
        }
    }
    // With the default refresh bound (0.5) the solve itself re-evaluates J as
    // soon as theta = 1.1 is seen; a huge bound leaves it to the restart rule.
    let options = NewtonOptions {
        keep_jacobian_theta: 1.0,
        refresh_theta: 10.0,
        ..NewtonOptions::with_method(NewtonMethod::Simplified)
    };
    let mut newton = dense_newton(1, options);
    let mut y = [0.0];
    let s = newton.solve(&mut Lin(10.0, 1.0), &mut y).unwrap();
    assert_eq!((s.iterations, s.jacobian_evaluations), (1, 1));
    assert!((y[0] - 0.1).abs() < 1e-15);
    assert!(newton.jacobian_is_kept());
    let mut y = [0.0];
    let s = newton.solve(&mut Lin(-1.0, -1.0), &mut y).unwrap();
    assert!(s.jacobian_reused);
    assert_eq!(s.restarts, 1);
    assert_eq!(s.jacobian_evaluations, 1);
    assert!((y[0] - 1.0).abs() < 1e-14);
    newton.invalidate_jacobian();
    assert!(!newton.jacobian_is_kept());

    let mut newton = dense_newton(
        1,
        NewtonOptions {
            keep_jacobian_theta: 1.0,
            ..NewtonOptions::with_method(NewtonMethod::Simplified)
        },
    );
    newton.solve(&mut Lin(10.0, 1.0), &mut [0.0]).unwrap();
    let mut y = [0.0];
    let s = newton.solve(&mut Lin(-1.0, -1.0), &mut y).unwrap();
    assert_eq!((s.restarts, s.jacobian_evaluations), (0, 1));
    assert!((y[0] - 1.0).abs() < 1e-14);
}

// ---------------------------------------------------------------- Bratu

/// `-u'' = lambda e^u` on (0, 1), `u(0) = u(1) = 0`, central differences on
/// `n` interior points, scaled by `dx^2`:
/// `G_i = 2 u_i - u_{i-1} - u_{i+1} - dx^2 lambda e^{u_i}`.
/// The Jacobian (tridiagonal, SPD below the fold) is a `sprs` CSR matrix
/// refilled in place. Its approximate Jacobian is the constant `lambda = 0`
/// operator (the analogue of the tutorial's linearised Jacobian).
struct Bratu {
    n: usize,
    lambda: f64,
    diag: Vec<usize>,
    iterates: Vec<Vec<f64>>,
}

impl Bratu {
    fn new(n: usize, lambda: f64) -> (Self, sprs::CsMat<f64>) {
        let mut t = sprs::TriMat::new((n, n));
        for i in 0..n {
            if i > 0 {
                t.add_triplet(i, i - 1, -1.0);
            }
            t.add_triplet(i, i, 2.0);
            if i + 1 < n {
                t.add_triplet(i, i + 1, -1.0);
            }
        }
        let m: sprs::CsMat<f64> = t.to_csr();
        let diag = (0..n)
            .map(|i| m.nnz_index(i, i).expect("diagonal").0)
            .collect();
        (
            Self {
                n,
                lambda,
                diag,
                iterates: Vec::new(),
            },
            m,
        )
    }

    fn dx2(&self) -> f64 {
        let dx = 1.0 / (self.n + 1) as f64;
        dx * dx
    }
}

impl NonlinearSystem for Bratu {
    type Jacobian = sprs::CsMat<f64>;
    fn dim(&self) -> usize {
        self.n
    }
    fn residual(&mut self, u: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.iterates.push(u.to_vec());
        let c = self.dx2() * self.lambda;
        for i in 0..self.n {
            let l = if i > 0 { u[i - 1] } else { 0.0 };
            let r = if i + 1 < self.n { u[i + 1] } else { 0.0 };
            g[i] = 2.0 * u[i] - l - r - c * u[i].exp();
        }
        Ok(())
    }
    fn jacobian(&mut self, u: &[f64], j: &mut sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        let c = self.dx2() * self.lambda;
        let data = j.data_mut();
        for (i, &k) in self.diag.iter().enumerate() {
            data[k] = 2.0 - c * u[i].exp();
        }
        Ok(())
    }
    fn approximate_jacobian(
        &mut self,
        _u: &[f64],
        j: &mut sprs::CsMat<f64>,
    ) -> Result<bool, NonlinearError> {
        let data = j.data_mut();
        for &k in &self.diag {
            data[k] = 2.0;
        }
        Ok(true)
    }
}

/// The exact solution for lambda = 1 (lower branch):
/// `u(x) = -2 ln(cosh((x - 1/2) theta / 2) / cosh(theta / 4))`,
/// `theta = sqrt(2 lambda) cosh(theta / 4)`.
fn bratu_exact(n: usize) -> Vec<f64> {
    // theta by scalar Newton on q(t) = t - sqrt2 cosh(t/4), from 1.
    let s2 = 2f64.sqrt();
    let mut t = 1.0f64;
    for _ in 0..50 {
        let q = t - s2 * (t / 4.0).cosh();
        let dq = 1.0 - s2 * (t / 4.0).sinh() / 4.0;
        t -= q / dq;
    }
    assert!((t - s2 * (t / 4.0).cosh()).abs() < 1e-14);
    (1..=n)
        .map(|i| {
            let x = i as f64 / (n + 1) as f64;
            -2.0 * (((x - 0.5) * t / 2.0).cosh() / (t / 4.0).cosh()).ln()
        })
        .collect()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Residual reduction ratios |G_{k+1}| / |G_k|.
fn ratios(stats: &NewtonStats) -> Vec<f64> {
    stats
        .residual_norms
        .windows(2)
        .map(|w| w[1] / w[0])
        .collect()
}

/// |G_0| is about 1e-5 (G is scaled by dx^2) and rounding leaves about
/// 5e-16: a relative tolerance of 1e-9 is well above that floor.
fn tight() -> NewtonOptions {
    NewtonOptions {
        atol: 0.0,
        rtol: 1e-9,
        record_history: true,
        ..Default::default()
    }
}

#[test]
fn bratu_matches_the_closed_form_within_discretisation_error() {
    // Error O(dx^2): halving dx divides it by about 4.
    let mut errs = Vec::new();
    for n in [499, 999] {
        let (mut sys, j) = Bratu::new(n, 1.0);
        let mut newton = Newton::new(tight(), j, SparseLu::new()).unwrap();
        let mut u = vec![0.0; n];
        let stats = newton.solve(&mut sys, &mut u).unwrap();
        assert!(stats.iterations <= 6);
        assert_eq!(stats.linear_iterations, 0);
        errs.push(max_diff(&u, &bratu_exact(n)));
    }
    assert!(errs[1] < 1e-6, "{errs:?}");
    let order = (errs[0] / errs[1]).log2();
    assert!((order - 2.0).abs() < 0.05, "observed order {order}");
}

/// The discrete solution to 1e-13, as reference for error histories.
fn bratu_reference(n: usize) -> Vec<f64> {
    let (mut sys, j) = Bratu::new(n, 1.0);
    let mut newton = Newton::new(
        NewtonOptions {
            atol: 1e-15,
            rtol: 0.0,
            ..Default::default()
        },
        j,
        SparseLu::new(),
    )
    .unwrap();
    let mut u = vec![0.0; n];
    newton.solve(&mut sys, &mut u).unwrap();
    u
}

const N: usize = 2000;

fn pcg_newton(options: NewtonOptions) -> (Bratu, Newton<sprs::CsMat<f64>, PcgSolver<Ssor>>) {
    let (sys, j) = Bratu::new(N, 1.0);
    let pcg = PcgSolver::new(Ssor::new(1.9).unwrap()).with_max_iter(Some(20 * N));
    (sys, Newton::new(options, j, pcg).unwrap())
}

#[test]
fn bratu_exact_newton_with_pcg_converges_quadratically() {
    let reference = bratu_reference(N);
    let (mut sys, mut newton) = pcg_newton(tight());
    let mut u = vec![0.0; N];
    let stats = newton.solve(&mut sys, &mut u).unwrap();
    assert!(max_diff(&u, &reference) < 1e-10);
    assert!(max_diff(&u, &bratu_exact(N)) < 1e-6);
    assert!(stats.linear_iterations > 0);
    assert_eq!(stats.jacobian_evaluations, stats.iterations);
    let e: Vec<f64> = sys
        .iterates
        .iter()
        .map(|p| max_diff(p, &reference))
        .collect();
    // e_0 ~ 0.14; quadratic: e_{k+1} <= C e_k^2 with C of order
    // |J^-1| |G''| (here about 1 in the max norm).
    for k in 0..e.len() - 1 {
        if e[k + 1] > 1e-11 {
            assert!(e[k + 1] <= 2.0 * e[k] * e[k], "k = {k}: {e:?}");
        }
    }
    assert!(stats.iterations <= 4, "{e:?}");
}

#[test]
fn bratu_inexact_newton_with_constant_eta_converges_linearly_at_rate_eta() {
    let eta = 0.1;
    let (mut sys, mut newton) = pcg_newton(NewtonOptions {
        method: NewtonMethod::Inexact(ForcingTerm::Constant(eta)),
        ..tight()
    });
    let mut u = vec![0.0; N];
    let stats = newton.solve(&mut sys, &mut u).unwrap();
    assert!(max_diff(&u, &bratu_exact(N)) < 1e-6);
    assert!(stats.forcing_terms.iter().all(|&f| f == eta));
    // |G_{k+1}| ~ |r_k| + O(|s_k|^2) <= eta |G_k| + ...: the rate is about eta
    // (CG may overshoot its tolerance, so the ratio can also be smaller).
    let r = ratios(&stats);
    for (k, q) in r.iter().enumerate() {
        assert!(*q <= 1.2 * eta, "k = {k}: {r:?}");
    }
    // ... and not faster than linear: log(1e-9)/log(0.1) = 9 would be the
    // count at exactly rate eta; CG overshoot makes it somewhat fewer.
    assert!(stats.iterations >= 5, "{r:?}");

    // Exact Newton needs more CG iterations in total on the same problem.
    let (mut sys2, mut exact) = pcg_newton(tight());
    let mut u2 = vec![0.0; N];
    let s2 = exact.solve(&mut sys2, &mut u2).unwrap();
    assert!(s2.iterations < stats.iterations);
    assert!(max_diff(&u, &u2) < 1e-10);
}

#[test]
fn bratu_eisenstat_walker_forcing_is_superlinear() {
    for forcing in [ForcingTerm::EisenstatWalker1, ForcingTerm::EW2_DEFAULT] {
        let (mut sys, mut newton) = pcg_newton(NewtonOptions {
            method: NewtonMethod::Inexact(forcing),
            ..tight()
        });
        let mut u = vec![0.0; N];
        let stats = newton.solve(&mut sys, &mut u).unwrap();
        assert!(max_diff(&u, &bratu_exact(N)) < 1e-6);
        let r = ratios(&stats);
        // Superlinear: the reduction ratio tends to zero, and so do the forcing terms.
        let last = *r.last().unwrap();
        assert!(last < 0.2 * r[0] && last < 1e-2, "{forcing:?}: {r:?}");
        let eta = &stats.forcing_terms;
        assert_eq!(eta[0], 0.5);
        assert!(
            eta[eta.len() - 1] < 0.2 * eta[1].max(eta[0]),
            "{forcing:?}: {eta:?}"
        );
        assert!(stats.iterations <= 10, "{forcing:?}: {r:?}");
    }
}

#[test]
fn bratu_simplified_newton_is_linear_with_one_jacobian() {
    let (mut sys, j) = Bratu::new(N, 1.0);
    let options = NewtonOptions::with_method(NewtonMethod::Simplified);
    let mut newton = Newton::new(
        NewtonOptions {
            rtol: 1e-9,
            atol: 0.0,
            record_history: true,
            ..options
        },
        j,
        SparseLu::new(),
    )
    .unwrap();
    let mut u = vec![0.0; N];
    let stats = newton.solve(&mut sys, &mut u).unwrap();
    assert!(max_diff(&u, &bratu_exact(N)) < 1e-6);
    assert_eq!(stats.jacobian_evaluations, 1);
    assert_eq!(stats.linear_setups, 1);
    // Linear: |G_{k+1}| / |G_k| settles at a constant rate in (0, 1)
    // (here about |I - J_0^-1 J*| ~ lambda (e^{max u} - 1) / pi^2 ~ 0.015).
    let r = ratios(&stats);
    assert!(stats.iterations >= 4, "{r:?}");
    for w in r[1..].windows(2) {
        assert!(w[1] / w[0] > 0.3 && w[1] / w[0] < 3.0, "{r:?}");
    }
    assert!(r.iter().all(|&q| q > 1e-4 && q < 0.1), "{r:?}");
    let theta = stats.contraction_rate.unwrap();
    assert!(theta > 1e-3 && theta < 0.1);
    // theta > keep_jacobian_theta (RADAU5's 0.001): not kept for the next call.
    assert!(!newton.jacobian_is_kept());

    // A tiny refresh bound re-evaluates the Jacobian whenever theta exceeds it.
    let (mut sys, j) = Bratu::new(N, 1.0);
    let mut newton = Newton::new(
        NewtonOptions {
            refresh_theta: 1e-6,
            rtol: 1e-9,
            atol: 0.0,
            ..options
        },
        j,
        SparseLu::new(),
    )
    .unwrap();
    let mut u = vec![0.0; N];
    let s = newton.solve(&mut sys, &mut u).unwrap();
    assert!(s.jacobian_evaluations > 1);
    assert!(s.iterations < stats.iterations);
}

#[test]
fn bratu_inexact_simplified_with_approximate_jacobian_reuses_it() {
    let (mut sys, j) = Bratu::new(N, 1.0);
    let pcg = PcgSolver::new(Ssor::new(1.9).unwrap()).with_max_iter(Some(20 * N));
    let options = NewtonOptions {
        method: NewtonMethod::InexactSimplified(ForcingTerm::Constant(0.05)),
        rtol: 1e-10,
        atol: 0.0,
        record_history: true,
        ..Default::default()
    };
    let mut newton = Newton::new(options, j, pcg).unwrap();
    let mut u = vec![0.0; N];
    let s1 = newton.solve(&mut sys, &mut u).unwrap();
    assert!(max_diff(&u, &bratu_exact(N)) < 1e-6);
    assert_eq!(s1.jacobian_evaluations, 1);
    assert!(!s1.jacobian_reused);
    assert!(newton.jacobian_is_kept());
    // The kept matrix is the lambda = 0 approximation, not the Jacobian.
    assert_eq!(newton.jacobian().data()[0], 2.0);
    // Second call (another start): no new Jacobian, no new setup.
    let mut u = vec![0.05; N];
    let s2 = newton.solve(&mut sys, &mut u).unwrap();
    assert!(s2.jacobian_reused);
    assert_eq!((s2.jacobian_evaluations, s2.linear_setups), (0, 0));
    assert!(max_diff(&u, &bratu_exact(N)) < 1e-6);
    // Linear convergence: each step contracts by at most eta + |I - J~^-1 J|.
    for q in ratios(&s2) {
        assert!(q < 0.2, "{q}");
    }
}

#[test]
fn linear_solver_failures_are_reported() {
    // PCG limited to 3 iterations cannot reach 1e-10 on Bratu.
    let (mut sys, j) = Bratu::new(200, 1.0);
    let pcg = PcgSolver::new(Identity).with_max_iter(Some(3));
    let options = NewtonOptions::default();
    let mut newton = Newton::new(options, j, pcg).unwrap();
    let err = newton.solve(&mut sys, &mut vec![0.0; 200]).unwrap_err();
    match &err {
        NonlinearError::LinearNotConverged {
            iterations,
            tolerance,
            stats,
            ..
        } => {
            assert_eq!(*iterations, 3);
            assert_eq!(*tolerance, 1e-10);
            assert_eq!(stats.linear_iterations, 3);
        }
        other => panic!("{other:?}"),
    }
    assert!(err.is_step_failure());

    // Beyond the fold (lambda = 4 > 3.51) the Jacobian at the iterates turns
    // indefinite or the iteration fails: either way a typed step failure.
    let (mut sys, j) = Bratu::new(200, 4.0);
    let mut newton = Newton::new(NewtonOptions::default(), j, PcgSolver::new(Identity)).unwrap();
    let mut u = vec![0.0; 200];
    let err = newton.solve(&mut sys, &mut u).unwrap_err();
    assert!(err.is_step_failure(), "{err:?}");
}

/// The Bratu Jacobian as a matrix-free operator: `J x = T x - dx^2 lambda e^u x`
/// with `T = tridiag(-1, 2, -1)`; it stores `dx^2 lambda e^{u_i}`.
struct BratuOperator {
    c: Vec<f64>,
}

impl hookean_sparse::LinearOperator for BratuOperator {
    fn nrows(&self) -> usize {
        self.c.len()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let n = x.len();
        for i in 0..n {
            let l = if i > 0 { x[i - 1] } else { 0.0 };
            let r = if i + 1 < n { x[i + 1] } else { 0.0 };
            y[i] = (2.0 - self.c[i]) * x[i] - l - r;
        }
    }
}

struct BratuMatrixFree(Bratu);

impl NonlinearSystem for BratuMatrixFree {
    type Jacobian = BratuOperator;
    fn dim(&self) -> usize {
        self.0.n
    }
    fn residual(&mut self, u: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.0.residual(u, g)
    }
    fn jacobian(&mut self, u: &[f64], j: &mut BratuOperator) -> Result<(), NonlinearError> {
        let c = self.0.dx2() * self.0.lambda;
        for (ci, ui) in j.c.iter_mut().zip(u) {
            *ci = c * ui.exp();
        }
        Ok(())
    }
}

#[test]
fn matrix_free_jacobian_with_unpreconditioned_cg() {
    let n = 300;
    let (sys, _) = Bratu::new(n, 1.0);
    let mut sys = BratuMatrixFree(sys);
    let pcg = PcgSolver::new(Identity).with_max_iter(Some(10 * n));
    let options = NewtonOptions {
        method: NewtonMethod::Inexact(ForcingTerm::EW2_DEFAULT),
        ..tight()
    };
    let mut newton = Newton::new(options, BratuOperator { c: vec![0.0; n] }, pcg).unwrap();
    let mut u = vec![0.0; n];
    let stats = newton.solve(&mut sys, &mut u).unwrap();
    assert!(stats.linear_iterations > 0);
    // Same discrete solution as a direct solve on the assembled Jacobian.
    let (mut direct, j) = Bratu::new(n, 1.0);
    let mut lu = Newton::new(tight(), j, SparseLu::new()).unwrap();
    let mut u2 = vec![0.0; n];
    lu.solve(&mut direct, &mut u2).unwrap();
    assert!(max_diff(&u, &u2) < 1e-9);
    assert!(max_diff(&u, &bratu_exact(n)) < 1e-5);
}

#[test]
fn step_criterion_estimates_the_remaining_error() {
    // On Powell singular, Newton contracts linearly with theta = 1/2, so
    // |s_k| theta / (1 - theta) = |s_k| estimates |Y_{k+1} - Y*| (Hairer-Wanner).
    let mut sys = powell();
    let mut y = [3.0, -1.0, 0.0, 1.0];
    let options = NewtonOptions {
        atol: 0.0,
        rtol: 0.0,
        step_tol: 1e-6,
        ..Default::default()
    };
    let stats = dense_newton(4, options).solve(&mut sys, &mut y).unwrap();
    assert_eq!(stats.converged_by, Some(ConvergedBy::Step));
    // The estimate is as good as theta (0.5 within a few per cent) ...
    let e = dist(&y, &[0.0; 4]);
    assert!(e <= 1.05e-6, "{e}");
    // ... and the iteration stopped as soon as it fell below 1e-6: the
    // error of the previous iterate was still above the tolerance.
    let prev = dist(&sys.iterates[sys.iterates.len() - 2], &[0.0; 4]);
    assert!(prev > 1e-6 && prev < 2.5e-6, "{prev}");
}

// ------------------------------------------------- convection-diffusion Bratu

/// Bratu with a convection term, scaled by `dx^2`:
/// `G_i = 2 u_i - u_{i-1} - u_{i+1} + (b dx / 2) (u_{i+1} - u_{i-1}) - dx^2 lambda e^{u_i}`,
/// a nonsymmetric tridiagonal Jacobian (CSR), and its product with a vector
/// computed from the formula (no matrix).
struct Convection {
    n: usize,
    lambda: f64,
    b: f64,
    /// `e^{u_i}` at the iterate of the last residual.
    exp_u: Vec<f64>,
    residuals: usize,
}

impl Convection {
    fn new(n: usize) -> (Self, sprs::CsMat<f64>) {
        let mut t = sprs::TriMat::new((n, n));
        for i in 0..n {
            for j in i.saturating_sub(1)..(i + 2).min(n) {
                t.add_triplet(i, j, 0.0);
            }
        }
        let sys = Self {
            n,
            lambda: 1.0,
            b: 30.0,
            exp_u: vec![1.0; n],
            residuals: 0,
        };
        (sys, t.to_csr())
    }

    fn coefficients(&self) -> (f64, f64, f64) {
        let dx = 1.0 / (self.n + 1) as f64;
        // (sub-diagonal, super-diagonal, dx^2 lambda)
        (
            -1.0 - 0.5 * self.b * dx,
            -1.0 + 0.5 * self.b * dx,
            dx * dx * self.lambda,
        )
    }
}

impl NonlinearSystem for Convection {
    type Jacobian = sprs::CsMat<f64>;
    fn dim(&self) -> usize {
        self.n
    }
    fn residual(&mut self, u: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.residuals += 1;
        let (lo, up, c) = self.coefficients();
        for i in 0..self.n {
            let l = if i > 0 { u[i - 1] } else { 0.0 };
            let r = if i + 1 < self.n { u[i + 1] } else { 0.0 };
            self.exp_u[i] = u[i].exp();
            g[i] = 2.0 * u[i] + lo * l + up * r - c * self.exp_u[i];
        }
        Ok(())
    }
    fn jacobian(&mut self, u: &[f64], j: &mut sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        let (lo, up, c) = self.coefficients();
        for (i, mut row) in j.outer_iterator_mut().enumerate() {
            for (col, v) in row.iter_mut() {
                *v = if col + 1 == i {
                    lo
                } else if col == i {
                    2.0 - c * u[i].exp()
                } else {
                    up
                };
            }
        }
        Ok(())
    }
    fn jacobian_product(
        &mut self,
        _u: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) -> Result<bool, NonlinearError> {
        let (lo, up, c) = self.coefficients();
        for i in 0..self.n {
            let l = if i > 0 { v[i - 1] } else { 0.0 };
            let r = if i + 1 < self.n { v[i + 1] } else { 0.0 };
            out[i] = (2.0 - c * self.exp_u[i]) * v[i] + lo * l + up * r;
        }
        Ok(true)
    }
}

#[test]
fn gmres_solves_a_nonsymmetric_newton_problem_stored_or_matrix_free() {
    let n = 200;
    // The reference: exact Newton with the sparse LU.
    let (mut sys, j) = Convection::new(n);
    let mut lu = Newton::new(tight(), j, SparseLu::new()).unwrap();
    let mut reference = vec![0.0; n];
    lu.solve(&mut sys, &mut reference).unwrap();
    let params = hookean_sparse::GmresParams {
        krylov_dim: 60,
        restarts: 20,
        ..Default::default()
    };
    for (matrix_free, precond) in [
        (false, PrecondKind::None),
        (true, PrecondKind::None),
        (true, PrecondKind::Jacobi),
    ] {
        let (mut sys, j) = Convection::new(n);
        let mut gmres = GmresSolver::new(params.clone(), &precond.into()).unwrap();
        if matrix_free {
            gmres = gmres.matrix_free();
        }
        assert_eq!(gmres.is_matrix_free(), matrix_free);
        let mut newton = Newton::new(tight(), j, gmres).unwrap();
        let mut u = vec![0.0; n];
        let stats = newton.solve(&mut sys, &mut u).unwrap();
        assert!(stats.linear_iterations > 0);
        assert!(
            max_diff(&u, &reference) < 1e-9,
            "{matrix_free} {precond:?}: {}",
            max_diff(&u, &reference)
        );
        let counters = newton.linear_solver().counters();
        assert_eq!(counters.products > 0, matrix_free);
        assert_eq!(
            counters.convergence_failures, 0,
            "{matrix_free} {precond:?}"
        );
        assert_eq!(
            counters.preconditioner_setups > 0,
            precond != PrecondKind::None
        );
    }
    // A matrix-free solver on a system without products is a typed error.
    let (mut sys, j) = Bratu::new(20, 1.0);
    let gmres = GmresSolver::new(params, &PrecondKind::None.into())
        .unwrap()
        .matrix_free();
    let mut newton = Newton::new(tight(), j, gmres).unwrap();
    assert!(matches!(
        newton.solve(&mut sys, &mut [0.0; 20]),
        Err(NonlinearError::NotReady(_))
    ));
}

#[test]
fn the_rate_test_stops_within_its_tolerance_and_saves_the_last_residual() {
    // Simplified Newton with the sparse LU and CVODE's rate test in the
    // weighted norm with w_i = 1e-8 (an absolute error tolerance): the
    // distance to the root the residual test finds is below tol w.
    let n = 200;
    let (mut sys, j) = Convection::new(n);
    let mut exact = Newton::new(tight(), j, SparseLu::new()).unwrap();
    let mut reference = vec![0.0; n];
    exact.solve(&mut sys, &mut reference).unwrap();

    let tol = 0.03;
    let (mut sys, j) = Convection::new(n);
    let options = NewtonOptions {
        method: NewtonMethod::Simplified,
        convergence: Convergence::Rate { tol },
        max_iter: 20,
        record_history: true,
        ..Default::default()
    };
    let mut newton = Newton::new(options, j, SparseLu::new()).unwrap();
    newton.weights_mut(n).fill(1e-8);
    let mut u = vec![0.0; n];
    let stats = newton.solve(&mut sys, &mut u).unwrap();
    assert_eq!(stats.converged_by, Some(ConvergedBy::Rate));
    assert!(
        max_diff(&u, &reference) < tol * 1e-8,
        "{}",
        max_diff(&u, &reference)
    );
    // One residual per correction that did not end the iteration: one
    // fewer than the residual test, which evaluates G after the last one.
    assert_eq!(stats.residual_evaluations, stats.iterations);
    assert_eq!(sys.residuals, stats.iterations);
    // The carried estimate is the measured rate (max(0.3 rho, rho_k)).
    let rates: Vec<f64> = stats.step_norms.windows(2).map(|w| w[1] / w[0]).collect();
    assert!(rates.iter().all(|&r| r < 1.0), "{rates:?}");
    assert!(newton.rate_estimate() >= *rates.last().unwrap());
    // Without weights the rate test refuses to start.
    let (mut sys, j) = Convection::new(n);
    let mut newton = Newton::new(options, j, SparseLu::new()).unwrap();
    assert!(matches!(
        newton.solve(&mut sys, &mut vec![0.0; n]),
        Err(NonlinearError::DimensionMismatch { .. })
    ));
}
