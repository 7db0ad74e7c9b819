//! API misuse of hookean-ode (issue 28): what a user can get wrong through
//! the public API returns a typed error, never a panic or a run without
//! bound: absurd step sizes and tolerances, per-component tolerances of the
//! wrong length, a state of the wrong length or with NaN, end times that are
//! NaN or in the past, a right-hand side that turns NaN, an empty problem,
//! BDF orders outside 1..=5 and limits of a billion.

use hookean_ode::tutorial::Dahlquist;
use hookean_ode::{
    BdfConfig, FirstOrderIntegrator, FirstOrderProblem, Integrator, Method, OdeError,
    SolverOptions, Tolerance,
};

/// `y' = -y` that returns NaN once `t` passes `nan_after`.
struct TurnsNan {
    nan_after: f64,
}

impl FirstOrderProblem for TurnsNan {
    fn dim(&self) -> usize {
        1
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = if t > self.nan_after { f64::NAN } else { -y[0] };
    }
}

/// A problem of no unknowns.
struct Empty;

impl FirstOrderProblem for Empty {
    fn dim(&self) -> usize {
        0
    }
    fn rhs(&self, _t: f64, _y: &[f64], _dy: &mut [f64]) {}
}

fn euler(opts: SolverOptions) -> Result<FirstOrderIntegrator<Dahlquist>, OdeError> {
    FirstOrderIntegrator::new(
        Dahlquist { lambda: -1.0 },
        Method::ImplicitEuler,
        0.0,
        &[1.0],
        opts,
    )
}

#[test]
fn absurd_options_are_refused_when_the_integrator_is_built() {
    let base = SolverOptions::default;
    let cases: Vec<(&str, SolverOptions)> = vec![
        ("h = 0", SolverOptions { h: 0.0, ..base() }),
        ("h < 0", SolverOptions { h: -0.01, ..base() }),
        (
            "h NaN",
            SolverOptions {
                h: f64::NAN,
                ..base()
            },
        ),
        (
            "h infinite",
            SolverOptions {
                h: f64::INFINITY,
                ..base()
            },
        ),
        (
            "rtol < 0",
            SolverOptions {
                rtol: -1e-3,
                ..base()
            },
        ),
        (
            "rtol NaN",
            SolverOptions {
                rtol: f64::NAN,
                ..base()
            },
        ),
        (
            "atol infinite",
            SolverOptions {
                atol: Tolerance::Scalar(f64::INFINITY),
                ..base()
            },
        ),
        (
            "atol of 2 for 1 unknown",
            SolverOptions {
                atol: Tolerance::Vector(vec![1e-6; 2]),
                ..base()
            },
        ),
    ];
    for (what, opts) in cases {
        match euler(opts.clone()) {
            Err(e) => assert!(!e.to_string().is_empty(), "{what}"),
            Ok(_) => panic!("{what}: accepted by the implicit Euler integrator"),
        }
        let bdf = FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            Method::variable_bdf(),
            0.0,
            &[1.0],
            opts,
        );
        assert!(
            bdf.is_err() || what.starts_with('h'),
            "{what}: accepted by the BDF"
        );
    }
    for order in [0, 6, 1_000_000] {
        let opts = SolverOptions::with_tolerances(1e-6, 1e-8);
        let method = Method::VariableBdf(BdfConfig {
            max_order: order,
            ..Default::default()
        });
        assert!(
            FirstOrderIntegrator::new(Dahlquist { lambda: -1.0 }, method, 0.0, &[1.0], opts)
                .is_err(),
            "max_order {order}"
        );
    }
}

#[test]
fn states_and_end_times_that_cannot_be_are_typed_errors() {
    let opts = SolverOptions::default;
    // A state of the wrong length, or with NaN.
    assert!(
        FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            Method::ImplicitEuler,
            0.0,
            &[1.0, 2.0],
            opts()
        )
        .is_err()
    );
    assert!(
        FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            Method::Rk4,
            0.0,
            &[f64::NAN],
            opts()
        )
        .is_err()
    );
    assert!(
        FirstOrderIntegrator::new(
            Dahlquist { lambda: -1.0 },
            Method::variable_bdf(),
            f64::NAN,
            &[1.0],
            opts()
        )
        .is_err()
    );
    // End times that are NaN or behind.
    let mut int = euler(opts()).unwrap();
    assert!(int.step_to(f64::NAN).is_err());
    int.step_to(0.05).unwrap();
    assert!(int.step_to(0.0).is_err());
    let mut bdf = FirstOrderIntegrator::new(
        Dahlquist { lambda: -1.0 },
        Method::variable_bdf(),
        0.0,
        &[1.0],
        opts(),
    )
    .unwrap();
    assert!(bdf.step_to(f64::INFINITY).is_err());
    // An empty problem is refused, not integrated.
    assert!(FirstOrderIntegrator::new(Empty, Method::ImplicitEuler, 0.0, &[], opts()).is_err());
    assert!(FirstOrderIntegrator::new(Empty, Method::variable_bdf(), 0.0, &[], opts()).is_err());
}

#[test]
fn a_right_hand_side_that_turns_nan_stops_the_run_with_an_error() {
    for method in [
        Method::ExplicitEuler,
        Method::Rk4,
        Method::ImplicitEuler,
        Method::Bdf(2),
    ] {
        let opts = SolverOptions {
            h: 0.01,
            ..SolverOptions::default()
        };
        let mut int = FirstOrderIntegrator::new(
            TurnsNan { nan_after: 0.1 },
            method.clone(),
            0.0,
            &[1.0],
            opts,
        )
        .unwrap();
        let mut result = Ok(None);
        for _ in 0..100 {
            result = int.step_to(1.0);
            if result.is_err() {
                break;
            }
        }
        assert!(
            result.is_err(),
            "{method:?}: NaN integrated without an error"
        );
        assert!(
            int.t() <= 0.11 + 1e-12,
            "{method:?}: went on to t = {}",
            int.t()
        );
    }
    let mut bdf = FirstOrderIntegrator::new(
        TurnsNan { nan_after: 0.1 },
        Method::variable_bdf(),
        0.0,
        &[1.0],
        SolverOptions::with_tolerances(1e-6, 1e-8),
    )
    .unwrap();
    let mut steps = 0;
    let result = loop {
        match bdf.step_to(1.0) {
            Ok(Some(_)) if steps < 10_000 => steps += 1,
            other => break other,
        }
    };
    assert!(
        result.is_err(),
        "the BDF integrated NaN: {result:?} after {steps} steps"
    );
    assert!(
        bdf.t() <= 0.11 + 1e-12,
        "the BDF went on to t = {}",
        bdf.t()
    );
}

#[test]
fn a_billion_steps_allowed_reserve_nothing() {
    let opts = SolverOptions {
        max_steps: 1_000_000_000,
        ..SolverOptions::with_tolerances(1e-6, 1e-8)
    };
    let method = Method::VariableBdf(BdfConfig {
        max_newton_iterations: 1_000_000_000,
        ..Default::default()
    });
    let mut bdf =
        FirstOrderIntegrator::new(Dahlquist { lambda: -1.0 }, method, 0.0, &[1.0], opts).unwrap();
    while bdf.step_to(1.0).unwrap().is_some() {}
    assert!((bdf.y()[0] - (-1.0f64).exp()).abs() < 1e-4);
}
