//! The IMEX scheme of Eberhardt, Etzmuss and Hauth (2000) against the
//! math: on a linear force it is implicit Euler (so unconditionally stable
//! on the linear part), on a nonlinear one it converges with order 1, and a
//! problem without a linear part is refused. Inexact simplified Newton
//! (algorithm 3) solves implicit Euler's stages with the same isotropic
//! matrix, kept until the step size or the material changes.

use hookean_ode::Integrator;
use std::sync::Arc;

use hookean_ode::{
    ForcingTerm, Method, NewtonMethod, OdeError, SecondOrderIntegrator, SecondOrderProblem,
    SolverOptions,
};
use hookean_sparse::block::{IDENTITY, scale};
use hookean_sparse::{BlockPattern, Constraints, IsoBlockMatrix, SymBlockMatrix};

/// A chain of `n` particles of mass `m` joined by zero-rest-length springs
/// (stiffness `k`, damping `d`) in all three coordinates, particle 0
/// pinned, plus a cubic spring to the origin `-c |x|^2 x` on every particle
/// (the nonlinear remainder; `c = 0`: a linear force). The linear part is
/// the chain: `f_lin = K x + D v`.
struct Chain {
    n: usize,
    k: f64,
    d: f64,
    c: f64,
    mass: Vec<f64>,
    pattern: Arc<BlockPattern>,
    /// Bumped when `k` or `d` change.
    revision: u64,
    /// Calls of `force_jacobians` (the full 3x3-block Jacobian).
    full_jacobians: std::sync::atomic::AtomicUsize,
}

impl Chain {
    fn new(n: usize, k: f64, d: f64, c: f64) -> Self {
        let m = 0.1;
        Self {
            n,
            k,
            d,
            c,
            mass: vec![m; 3 * n],
            pattern: Arc::new(BlockPattern::new(n, (1..n).map(|i| (i - 1, i))).unwrap()),
            revision: 0,
            full_jacobians: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    fn start(&self) -> (Vec<f64>, Vec<f64>) {
        let x = (0..3 * self.n)
            .map(|q| {
                if q < 3 {
                    0.0
                } else {
                    0.3 * ((q as f64) * 0.7).sin()
                }
            })
            .collect();
        let v = (0..3 * self.n)
            .map(|q| {
                if q < 3 {
                    0.0
                } else {
                    0.5 * ((q as f64) * 1.3).cos()
                }
            })
            .collect();
        (x, v)
    }
}

impl SecondOrderProblem for Chain {
    fn dim(&self) -> usize {
        3 * self.n
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    fn force(&self, _t: f64, x: &[f64], v: &[f64], f: &mut [f64]) {
        f.fill(0.0);
        for i in 1..self.n {
            for c in 0..3 {
                let (a, b) = (3 * (i - 1) + c, 3 * i + c);
                let s = self.k * (x[b] - x[a]) + self.d * (v[b] - v[a]);
                f[a] += s;
                f[b] -= s;
            }
        }
        for p in x.chunks(3).enumerate().map(|(i, _)| i) {
            let q = &x[3 * p..3 * p + 3];
            let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            for c in 0..3 {
                f[3 * p + c] -= self.c * r2 * q[c];
            }
        }
    }

    fn jacobian_pattern(&self) -> Arc<BlockPattern> {
        self.pattern.clone()
    }

    fn force_jacobians(
        &self,
        _t: f64,
        x: &[f64],
        _v: &[f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    ) {
        self.full_jacobians
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        dfdx.set_zero();
        dfdv.set_zero();
        for i in 1..self.n {
            for (m, s) in [(&mut *dfdx, self.k), (&mut *dfdv, self.d)] {
                m.add_to_block(i - 1, i, &scale(&IDENTITY, s)).unwrap();
                m.add_to_block(i - 1, i - 1, &scale(&IDENTITY, -s)).unwrap();
                m.add_to_block(i, i, &scale(&IDENTITY, -s)).unwrap();
            }
        }
        // d/dx of -c |x|^2 x = -c (|x|^2 I + 2 x x^T).
        for p in 0..self.n {
            let q = &x[3 * p..3 * p + 3];
            let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            let mut b = scale(&IDENTITY, -self.c * r2);
            for (r, row) in b.iter_mut().enumerate() {
                for (s, e) in row.iter_mut().enumerate() {
                    *e -= 2.0 * self.c * q[r] * q[s];
                }
            }
            dfdx.add_to_block(p, p, &b).unwrap();
        }
    }

    fn linearized_jacobians_iso(&self, k: &mut IsoBlockMatrix, d: &mut IsoBlockMatrix) -> bool {
        k.set_zero();
        d.set_zero();
        for i in 1..self.n {
            for (m, s) in [(&mut *k, self.k), (&mut *d, self.d)] {
                m.add_to_block(i - 1, i, s).unwrap();
                m.add_to_block(i - 1, i - 1, -s).unwrap();
                m.add_to_block(i, i, -s).unwrap();
            }
        }
        true
    }

    fn material_revision(&self) -> u64 {
        self.revision
    }

    fn begin_step(&mut self, _t: f64, x: &mut [f64], v: &mut [f64], c: &mut Constraints) {
        x[..3].fill(0.0);
        v[..3].fill(0.0);
        c.pin(0, [0.0; 3]).unwrap();
    }
}

fn run(problem: Chain, method: Method, h: f64, t_end: f64, newton_rtol: f64) -> Vec<f64> {
    let (x0, v0) = problem.start();
    let mut options = SolverOptions::with_h(h);
    options.newton.rtol = newton_rtol;
    options.newton.linear_rtol = 1e-13;
    let mut ode = SecondOrderIntegrator::new(problem, method, 0.0, &x0, &v0, options).unwrap();
    ode.integrate(t_end).unwrap();
    ode.state().to_vec()
}

/// On a linear force the split has no remainder: IMEX is implicit Euler
/// (Newton on a linear stage equation converges in one exact step), here
/// far outside every explicit stability limit (`h^2 k / m = 1e4`, FB
/// Euler's limit is `h^2 k0 < 4` with `k0 ~ 4 k / m`), and bounded.
#[test]
fn on_a_linear_force_imex_is_implicit_euler_and_stable() {
    let (k, d) = (1e4, 0.0);
    let h = 0.1;
    let imex = run(Chain::new(8, k, d, 0.0), Method::Imex, h, 2.0, 1e-13);
    let ie = run(
        Chain::new(8, k, d, 0.0),
        Method::ImplicitEuler,
        h,
        2.0,
        1e-13,
    );
    let scale = ie.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = imex
        .iter()
        .zip(&ie)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        diff <= 1e-9 * scale.max(1.0),
        "IMEX vs implicit Euler: {diff:e}"
    );
    // Implicit Euler damps the undamped chain: the state shrank.
    let (x0, v0) = Chain::new(8, k, d, 0.0).start();
    let start = x0.iter().chain(&v0).fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale < start, "{scale} vs {start}");
}

/// With the cubic remainder treated explicitly the scheme is first order:
/// halving `h` halves the error at `t = 0.2` (reference: RK4 at a step
/// 100x smaller). Mild stiffness so that the errors are in the asymptotic
/// range.
#[test]
fn with_a_nonlinear_remainder_imex_converges_with_order_one() {
    let make = || Chain::new(5, 50.0, 0.05, 20.0);
    let reference = run(make(), Method::Rk4, 1e-5, 0.2, 1e-10);
    let err = |h: f64| {
        let s = run(make(), Method::Imex, h, 0.2, 1e-10);
        s.iter()
            .zip(&reference)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
    };
    let hs = [1e-3, 5e-4, 2.5e-4];
    let errs: Vec<f64> = hs.iter().map(|&h| err(h)).collect();
    for w in errs.windows(2) {
        let order = (w[0] / w[1]).log2();
        assert!(
            (0.85..1.2).contains(&order),
            "observed order {order} ({errs:?})"
        );
    }
}

/// A step limited by the linear part only: at `h = 0.05` on a stiff chain
/// with a small remainder IMEX stays bounded where FB Euler (the explicit
/// scheme it reduces to without the linear part) blows up.
#[test]
fn the_linear_part_lifts_the_explicit_limit() {
    let make = || Chain::new(6, 1e4, 1.0, 1.0);
    let imex = run(make(), Method::Imex, 0.05, 1.0, 1e-10);
    assert!(imex.iter().all(|v| v.is_finite() && v.abs() < 10.0));
    let (x0, v0) = make().start();
    let mut fb = SecondOrderIntegrator::new(
        make(),
        Method::FbEuler,
        0.0,
        &x0,
        &v0,
        SolverOptions::with_h(0.05),
    )
    .unwrap();
    let blew_up = match fb.integrate(1.0) {
        Err(_) => true,
        Ok(_) => fb.state().iter().any(|v| !v.is_finite() || v.abs() > 1e3),
    };
    assert!(blew_up);
}

/// A problem without a linear part is refused at construction, and IMEX
/// is a second-order method.
#[test]
fn imex_needs_a_linear_part() {
    struct NoLinear(Chain);
    impl SecondOrderProblem for NoLinear {
        fn dim(&self) -> usize {
            self.0.dim()
        }
        fn mass(&self) -> &[f64] {
            self.0.mass()
        }
        fn force(&self, t: f64, x: &[f64], v: &[f64], f: &mut [f64]) {
            self.0.force(t, x, v, f)
        }
        fn jacobian_pattern(&self) -> Arc<BlockPattern> {
            self.0.jacobian_pattern()
        }
        fn force_jacobians(
            &self,
            t: f64,
            x: &[f64],
            v: &[f64],
            a: &mut SymBlockMatrix,
            b: &mut SymBlockMatrix,
        ) {
            self.0.force_jacobians(t, x, v, a, b)
        }
    }
    let c = Chain::new(3, 1.0, 0.0, 0.0);
    let (x0, v0) = c.start();
    assert!(matches!(
        SecondOrderIntegrator::new(
            NoLinear(c),
            Method::Imex,
            0.0,
            &x0,
            &v0,
            SolverOptions::default()
        ),
        Err(OdeError::UnsupportedMethod { .. })
    ));
    assert_eq!("imex".parse::<Method>().unwrap(), Method::Imex);
    assert_eq!(Method::Imex.to_string(), "imex");
    assert!(Method::Imex.is_second_order_only() && Method::Imex.order() == 1);
}

/// Inexact simplified Newton with eq. 50's matrix `M - h D - h^2 K`
/// (isotropic, the cubic remainder left out of it) reaches the stage
/// solution of exact Newton on the cubic chain, evaluating the matrix once
/// for all steps of one `h`, and once more after a material change (`k`
/// doubled, the revision bumped); the missing cubic term costs it more
/// iterations than exact Newton.
#[test]
fn inexact_simplified_newton_keeps_eq50_until_h_or_the_material_changes() {
    let make = || Chain::new(8, 1e3, 0.1, 20.0);
    let (x0, v0) = make().start();
    let options = |method: NewtonMethod| {
        let mut o = SolverOptions::with_h(0.01);
        o.newton.method = method;
        o.newton.rtol = 1e-12;
        o.newton.atol = 1e-14;
        o.newton.linear_rtol = 1e-13;
        o.newton.max_iter = 100;
        o
    };
    let start = |method| {
        SecondOrderIntegrator::new(
            make(),
            Method::ImplicitEuler,
            0.0,
            &x0,
            &v0,
            options(method),
        )
        .unwrap()
    };
    let mut eq50 = start(NewtonMethod::InexactSimplified(ForcingTerm::Constant(1e-8)));
    let mut exact = start(NewtonMethod::Exact);
    let agree = |a: &SecondOrderIntegrator<Chain>, b: &SecondOrderIntegrator<Chain>| {
        let scale = b.state().iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = a
            .state()
            .iter()
            .zip(b.state())
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        assert!(diff <= 1e-9 * scale, "{diff:e} of {scale:e}");
    };
    for _ in 0..20 {
        eq50.step().unwrap();
        exact.step().unwrap();
    }
    agree(&eq50, &exact);
    assert_eq!(eq50.stats().num_jac_evals, 1);
    assert!(eq50.stats().num_nonlin_solv_iters > exact.stats().num_nonlin_solv_iters);
    for ode in [&mut eq50, &mut exact] {
        let p = ode.problem_mut();
        p.k *= 2.0;
        p.revision += 1;
    }
    for _ in 0..5 {
        eq50.step().unwrap();
        exact.step().unwrap();
    }
    agree(&eq50, &exact);
    assert_eq!(eq50.stats().num_jac_evals, 2);
    // The matrices were eq. 50's isotropic ones: the full 3x3-block Jacobian
    // was never assembled on this path (exact Newton assembles it at every
    // iteration).
    let full = |ode: &SecondOrderIntegrator<Chain>| {
        ode.problem()
            .full_jacobians
            .load(std::sync::atomic::Ordering::Relaxed)
    };
    assert_eq!(full(&eq50), 0);
    assert!(full(&exact) >= exact.stats().num_nonlin_solv_iters);
}
