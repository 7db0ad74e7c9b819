//! The variable-order BDF on second-order problems (`Method::variable_bdf()`
//! through `SecondOrderIntegrator`): the reduced stage equations on the
//! sparse block matrix with PCG, checked against the same solver on the
//! problem's first-order form (a dense LU on the `2n x 2n` Jacobian: other
//! equations, other linear algebra), for accuracy against `rtol`, and for
//! pins.

use hookean_ode::{
    FirstOrderForm, FirstOrderIntegrator, Integrator, Method, SecondOrderIntegrator, SolverOptions,
};
use hookean_testkit::springs::SpringChain;

/// A free chain of 6 stiff, damped springs stretched by 20 %, no gravity.
fn chain() -> SpringChain {
    SpringChain::new(6, 0.05, 400.0, 0.2, 0.1, 0.0)
}

fn reduced(rtol: f64, t_end: f64) -> (Vec<f64>, hookean_ode::Stats) {
    let p = chain();
    let (x0, v0) = p.initial_state(1.2);
    let opts = SolverOptions::with_tolerances(rtol, rtol / 100.0);
    let mut ode =
        SecondOrderIntegrator::new(p, Method::variable_bdf(), 0.0, &x0, &v0, opts).unwrap();
    ode.integrate(t_end).unwrap();
    assert_eq!(ode.t(), t_end);
    (ode.state().to_vec(), ode.stats())
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).abs())
        .fold(0.0, f64::max)
}

#[test]
fn the_reduced_form_agrees_with_the_first_order_form() {
    let t_end = 0.5;
    let p = chain();
    let (x0, v0) = p.initial_state(1.2);
    let mut y0 = x0.clone();
    y0.extend_from_slice(&v0);
    let opts = SolverOptions::with_tolerances(1e-10, 1e-12);
    let mut dense = FirstOrderIntegrator::new(
        FirstOrderForm::new(p),
        Method::variable_bdf(),
        0.0,
        &y0,
        opts,
    )
    .unwrap();
    dense.integrate(t_end).unwrap();
    let reference = dense.y().to_vec();
    // The springs oscillate: the state is of order 0.1 m and 1 m/s.
    let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.1, "{scale}");
    let (y, stats) = reduced(1e-8, t_end);
    assert!(
        max_diff(&y, &reference) < 1e-6 * scale,
        "{}",
        max_diff(&y, &reference)
    );
    // PCG on the reduced form; the Jacobians kept for many steps.
    assert!(stats.num_lin_iters > 0);
    assert!(4 * stats.num_jac_evals < stats.num_steps, "{stats:?}");
}

#[test]
fn the_error_follows_the_tolerance() {
    let t_end = 0.5;
    let (reference, _) = reduced(1e-10, t_end);
    let errors: Vec<f64> = [1e-3, 1e-4, 1e-5]
        .iter()
        .map(|&rtol| max_diff(&reduced(rtol, t_end).0, &reference))
        .collect();
    for w in errors.windows(2) {
        assert!(w[1] < w[0] / 3.0, "{errors:?}");
    }
    assert!(errors[0] < 1e-2, "{errors:?}");
}

#[test]
fn pinned_particles_stay_put() {
    // A hanging chain under gravity, pinned at its first particle.
    let mut p = SpringChain::new(5, 0.05, 200.0, 0.2, 0.1, 9.81);
    p.pinned = vec![0];
    let (x0, v0) = p.initial_state(1.0);
    let opts = SolverOptions::with_tolerances(1e-6, 1e-8);
    let mut ode =
        SecondOrderIntegrator::new(p, Method::variable_bdf(), 0.0, &x0, &v0, opts).unwrap();
    let sol = ode.solve_at(&[0.1, 0.2, 0.3]).unwrap();
    for i in 0..3 {
        let y = sol.y(i);
        assert_eq!(&y[..3], &x0[..3], "pinned position at t = {}", sol.t[i]);
        let n = y.len() / 2;
        assert!(y[n..n + 3].iter().all(|v| v.abs() < 1e-12));
        // The free end fell.
        assert!(y[n - 1] < -0.01, "{}", y[n - 1]);
    }
}
