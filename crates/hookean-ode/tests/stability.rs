//! Stability functions, A-stability, BDF coefficients and boundary loci,
//! and the stability limits of the tutorial's section 2.2 on example 1.

use hookean_ode::Integrator;
use hookean_ode::stability::{
    ComplexGrid, amplification, is_a_stable, oscillator_spectral_radius, sample_region,
    stability_function,
};
use hookean_ode::tutorial::Dahlquist;
use hookean_ode::{BdfCoefficients, ButcherTableau, FirstOrderIntegrator, Method, SolverOptions};
use num_complex::Complex64;

fn c(re: f64, im: f64) -> Complex64 {
    Complex64::new(re, im)
}

fn samples() -> Vec<Complex64> {
    vec![
        c(-0.5, 0.3),
        c(-2.0, 1.5),
        c(0.7, -0.2),
        c(-10.0, 0.0),
        c(0.0, 3.0),
        c(-0.1, -4.0),
    ]
}

#[test]
fn stability_functions_match_closed_forms() {
    let one = c(1.0, 0.0);
    for z in samples() {
        let cases: [(Method, Complex64); 5] = [
            (Method::ExplicitEuler, one + z),         // eq. (29)
            (Method::ImplicitEuler, one / (one - z)), // eq. (30)
            (Method::ImplicitMidpoint, (one + z / 2.0) / (one - z / 2.0)), // eq. (33)
            (Method::Midpoint, one + z + z * z / 2.0), // Taylor to order 2
            (
                Method::Rk4,
                one + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0,
            ), // to order 4
        ];
        for (m, expected) in cases {
            let r = stability_function(&m, z).unwrap();
            assert!(
                (r - expected).norm() <= 1e-13 * (1.0 + expected.norm()),
                "{m} at {z}: {r} vs {expected}"
            );
        }
        // BDF1 is implicit Euler.
        let r = stability_function(&Method::Bdf(1), z).unwrap();
        assert!((r - one / (one - z)).norm() < 1e-13 * (1.0 + r.norm()));
    }
    assert!(stability_function(&Method::Bdf(2), c(0.0, 0.0)).is_none());
    assert!(stability_function(&Method::Verlet, c(0.0, 0.0)).is_none());
}

#[test]
fn a_stability() {
    for m in [
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(1),
        Method::Bdf(2),
        Method::Bdf2Variable,
    ] {
        assert_eq!(is_a_stable(&m), Some(true), "{m}");
    }
    // Explicit methods have bounded stability regions; BDF3-6 are only A(alpha)-stable.
    for m in [
        Method::ExplicitEuler,
        Method::Midpoint,
        Method::Rk4,
        Method::Bdf(3),
        Method::Bdf(4),
        Method::Bdf(5),
        Method::Bdf(6),
    ] {
        assert_eq!(is_a_stable(&m), Some(false), "{m}");
    }
    assert_eq!(is_a_stable(&Method::Verlet), None);
}

#[test]
fn a_custom_tableau_has_the_order_and_stability_it_should() {
    // Kutta's 3/8 rule: order 4, and every 4-stage explicit method of order
    // 4 has the RK4 stability polynomial.
    let t = ButcherTableau::new(
        "3/8-rule",
        &[
            vec![0.0, 0.0, 0.0, 0.0],
            vec![1.0 / 3.0, 0.0, 0.0, 0.0],
            vec![-1.0 / 3.0, 1.0, 0.0, 0.0],
            vec![1.0, -1.0, 1.0, 0.0],
        ],
        &[0.125, 0.375, 0.375, 0.125],
        &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0],
    )
    .unwrap();
    assert!(t.is_explicit());
    assert_eq!(t.order(1e-14), 4);
    for z in samples() {
        let rk4 = ButcherTableau::rk4().stability_function(z);
        assert!((t.stability_function(z) - rk4).norm() < 1e-12 * (1.0 + rk4.norm()));
    }
    assert_eq!(ButcherTableau::explicit_euler().order(1e-14), 1);
    assert_eq!(ButcherTableau::explicit_midpoint().order(1e-14), 2);
    assert_eq!(ButcherTableau::implicit_midpoint().order(1e-14), 2);
    assert_eq!(ButcherTableau::implicit_euler().order(1e-14), 1);
    // Ragged tableau and implicit tableau as an explicit method are typed errors.
    assert!(ButcherTableau::new("bad", &[vec![0.0]], &[0.5, 0.5], &[0.0, 1.0]).is_err());
    let imp = Method::ExplicitRk(ButcherTableau::implicit_midpoint());
    assert!(
        FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            imp,
            0.0,
            &[1.0],
            SolverOptions::default()
        )
        .is_err()
    );
}

#[test]
fn bdf_coefficients_are_consistent_and_of_order_k() {
    // Eq. (37) and the normalised rows of table 3 (derived independently:
    // alpha_0 = sum 1/j, e.g. 11/6 for k = 3 and 147/60 for k = 6).
    let b2 = BdfCoefficients::new(2).unwrap();
    let expect2 = [1.0, -4.0 / 3.0, 1.0 / 3.0];
    for (a, e) in b2.alpha.iter().zip(expect2) {
        assert!((a - e).abs() < 1e-15);
    }
    assert!((b2.beta - 2.0 / 3.0).abs() < 1e-15);
    let b3 = BdfCoefficients::new(3).unwrap();
    for (a, e) in b3
        .alpha
        .iter()
        .zip([1.0, -18.0 / 11.0, 9.0 / 11.0, -2.0 / 11.0])
    {
        assert!((a - e).abs() < 1e-15);
    }
    assert!((BdfCoefficients::new(6).unwrap().beta - 60.0 / 147.0).abs() < 1e-15);
    for k in 1..=6 {
        let b = BdfCoefficients::new(k).unwrap();
        for q in 0..=k as u32 {
            assert!(
                b.order_residual(q).abs() < 1e-11,
                "k {k} q {q}: {}",
                b.order_residual(q)
            );
        }
        assert!(
            b.order_residual(k as u32 + 1).abs() > 1e-3,
            "k {k} has order exactly k"
        );
    }
    assert!(BdfCoefficients::new(0).is_err());
    assert!(BdfCoefficients::new(7).is_err());
}

#[test]
fn bdf_boundary_locus() {
    // BDF1: z = 1 - e^{-i theta}, the circle |z - 1| = 1.
    for z in BdfCoefficients::new(1).unwrap().boundary_locus(64) {
        assert!(((z - c(1.0, 0.0)).norm() - 1.0).abs() < 1e-14);
    }
    for k in 1..=6 {
        let b = BdfCoefficients::new(k).unwrap();
        let locus = b.boundary_locus(720);
        // On the locus a root of the characteristic polynomial has modulus 1
        // (an independent check of the root finder and the locus).
        for z in locus.iter().skip(1).step_by(37) {
            let r = b.max_root_modulus(*z);
            assert!(
                (r - 1.0).abs() < 1e-6,
                "k {k}: max root {r} on the locus at {z}"
            );
        }
        // The locus enters the left half-plane exactly when BDF(k) is not A-stable.
        let min_re = locus.iter().map(|z| z.re).fold(f64::INFINITY, f64::min);
        if k <= 2 {
            assert!(min_re > -1e-12, "k {k}: {min_re}");
        } else {
            assert!(min_re < -1e-3, "k {k}: {min_re}");
        }
    }
}

#[test]
fn sampled_region_of_explicit_euler_is_the_unit_disc_around_minus_one() {
    let grid = ComplexGrid::default();
    let region = sample_region(&Method::ExplicitEuler, &grid).unwrap();
    for iy in 0..grid.ny {
        for ix in 0..grid.nx {
            let z = grid.point(ix, iy);
            let d = (z + c(1.0, 0.0)).norm();
            if (d - 1.0).abs() > 1e-9 {
                assert_eq!(region.is_stable(ix, iy), d < 1.0, "at {z}");
            }
        }
    }
    // Area pi of an 8 x 8 window, up to the grid resolution.
    assert!((region.stable_fraction() - std::f64::consts::PI / 64.0).abs() < 0.005);
    // BDF2 region: the whole left half of the window is stable.
    let bdf2 = sample_region(&Method::Bdf(2), &grid).unwrap();
    for iy in 0..grid.ny {
        for ix in 0..grid.nx {
            if grid.point(ix, iy).re < 0.0 {
                assert!(bdf2.is_stable(ix, iy));
            }
        }
    }
    assert!(sample_region(&Method::Verlet, &grid).is_err());
    assert!(sample_region(&Method::Rk4, &ComplexGrid { nx: 1, ..grid }).is_err());
}

/// |y_N| after N steps of `method` on y' = -15 y.
fn run_dahlquist(method: Method, h: f64, steps: usize) -> f64 {
    let mut ode = FirstOrderIntegrator::new(
        Dahlquist { lambda: -15.0 },
        method,
        0.0,
        &[1.0],
        SolverOptions::with_h(h),
    )
    .unwrap();
    for _ in 0..steps {
        ode.step().unwrap();
    }
    ode.y()[0].abs()
}

/// Where the RK4 polynomial leaves the unit disc on the negative real
/// axis: R(-x) = 1 with x in (2, 3), by bisection on the polynomial itself
/// (x = 2.7853...).
fn rk4_real_limit() -> f64 {
    let r = |x: f64| 1.0 - x + x * x / 2.0 - x.powi(3) / 6.0 + x.powi(4) / 24.0 - 1.0;
    let (mut lo, mut hi) = (2.0, 3.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if r(mid) < 0.0 { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

#[test]
fn stability_limits_on_example_1() {
    let lambda: f64 = 15.0;
    // Explicit Euler: |1 + h lambda| < 1 iff h < 2/15.
    let h = 2.0 / lambda;
    assert!(run_dahlquist(Method::ExplicitEuler, 0.99 * h, 2000) < 1e-6);
    assert!(run_dahlquist(Method::ExplicitEuler, 1.01 * h, 2000) > 1e6);
    // RK4: bounded below |h lambda| = 2.785, unbounded above.
    let x = rk4_real_limit();
    assert!((x - 2.785).abs() < 1e-3);
    assert!(run_dahlquist(Method::Rk4, 0.99 * x / lambda, 4000) < 1e-3);
    assert!(run_dahlquist(Method::Rk4, 1.01 * x / lambda, 4000) > 1e3);
    assert!(amplification(&Method::Rk4, c(-0.99 * x, 0.0)).unwrap() < 1.0);
    assert!(amplification(&Method::Rk4, c(-1.01 * x, 0.0)).unwrap() > 1.0);
    // A-stable methods with h = 1 (h lambda = -15).
    for m in [
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(2),
    ] {
        let y = run_dahlquist(m.clone(), 1.0, 200);
        assert!(y <= 1.0, "{m}: {y}");
    }
    // Implicit Euler damps strongly: (1/16)^200.
    assert!(run_dahlquist(Method::ImplicitEuler, 1.0, 10) < 1e-11);
}

#[test]
fn symplectic_stability_limit_h_omega_2() {
    let omega = 5f64.sqrt();
    for m in [Method::Verlet, Method::FbEuler] {
        let below = oscillator_spectral_radius(&m, 1.99 / omega, omega, 0.0).unwrap();
        let above = oscillator_spectral_radius(&m, 2.01 / omega, omega, 0.0).unwrap();
        assert!((below - 1.0).abs() < 1e-12, "{m}: {below}");
        assert!(above > 1.1, "{m}: {above}");
        // Damping makes it contractive below the limit.
        assert!(oscillator_spectral_radius(&m, 1.0 / omega, omega, 0.5).unwrap() < 1.0);
    }
    assert!(oscillator_spectral_radius(&Method::Rk4, 0.1, 1.0, 0.0).is_none());
}

#[test]
fn variable_bdf2_is_exact_for_quadratics_and_has_the_stated_error_constant() {
    use hookean_ode::bdf::{variable_bdf2, variable_bdf2_error_constant};
    for omega in [0.5, 1.0, 1.7, 2.2] {
        let (a1, a2, beta) = variable_bdf2(omega);
        let h = 0.3;
        // Grid t_{n+1} = 0, t_n = -h, t_{n-1} = -h - h/omega.
        let tn = -h;
        let tnm1 = -h - h / omega;
        let apply = |y: &dyn Fn(f64) -> f64, dy: &dyn Fn(f64) -> f64| {
            y(0.0) + a1 * y(tn) + a2 * y(tnm1) - h * beta * dy(0.0)
        };
        for q in 0..=2 {
            let r = apply(&|t: f64| (t + 0.4).powi(q), &|t: f64| {
                q as f64 * (t + 0.4).powi(q - 1)
            });
            assert!(r.abs() < 1e-14, "omega {omega} q {q}: {r}");
        }
        // On y = t^3 / 6 (y''' = 1) the residual is -C(omega) h^3.
        let r = apply(&|t: f64| t.powi(3) / 6.0, &|t: f64| t * t / 2.0);
        assert!(
            (r + variable_bdf2_error_constant(omega) * h.powi(3)).abs() < 1e-15,
            "omega {omega}"
        );
    }
    assert!((variable_bdf2_error_constant(1.0) - 2.0 / 9.0).abs() < 1e-15);
}
