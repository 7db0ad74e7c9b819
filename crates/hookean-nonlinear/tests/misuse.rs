//! API misuse of hookean-nonlinear (issue 28): what a user can get wrong
//! through the public API returns a typed error, never a panic or a run
//! without bound: absurd options, a Jacobian of the wrong size, a starting
//! point of the wrong length, residuals that turn NaN, a singular Jacobian,
//! an empty system, an iteration limit of a billion.

use hookean_nonlinear::*;

/// `G(y) = A y - b` for a dense `A` given row-major, optionally NaN from
/// the `nan_after`-th residual on.
struct Linear {
    a: Vec<f64>,
    b: Vec<f64>,
    calls: usize,
    nan_after: Option<usize>,
}

impl Linear {
    fn new(a: Vec<f64>, b: Vec<f64>) -> Self {
        Self {
            a,
            b,
            calls: 0,
            nan_after: None,
        }
    }
}

impl NonlinearSystem for Linear {
    type Jacobian = faer::Mat<f64>;
    fn dim(&self) -> usize {
        self.b.len()
    }
    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.calls += 1;
        let n = self.b.len();
        for i in 0..n {
            g[i] = (0..n).map(|j| self.a[i * n + j] * y[j]).sum::<f64>() - self.b[i];
        }
        if self.nan_after.is_some_and(|k| self.calls > k) {
            g[0] = f64::NAN;
        }
        Ok(())
    }
    fn jacobian(&mut self, _y: &[f64], jac: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
        let n = self.b.len();
        for i in 0..n {
            for j in 0..n {
                jac[(i, j)] = self.a[i * n + j];
            }
        }
        Ok(())
    }
}

fn newton(
    n: usize,
    options: NewtonOptions,
) -> Result<Newton<faer::Mat<f64>, DenseLu>, NonlinearError> {
    Newton::new(options, faer::Mat::zeros(n, n), DenseLu::new())
}

#[test]
fn absurd_options_are_refused_when_the_solver_is_built() {
    let cases: Vec<(&str, NewtonOptions)> = vec![
        (
            "rtol NaN",
            NewtonOptions {
                rtol: f64::NAN,
                ..Default::default()
            },
        ),
        (
            "atol negative",
            NewtonOptions {
                atol: -1.0,
                ..Default::default()
            },
        ),
        (
            "rtol infinite",
            NewtonOptions {
                rtol: f64::INFINITY,
                ..Default::default()
            },
        ),
        (
            "linear_rtol NaN",
            NewtonOptions {
                linear_rtol: f64::NAN,
                ..Default::default()
            },
        ),
        (
            "max_iter 0",
            NewtonOptions {
                max_iter: 0,
                ..Default::default()
            },
        ),
    ];
    for (what, options) in cases {
        match newton(2, options) {
            Err(e) => assert!(!e.to_string().is_empty(), "{what}"),
            Ok(_) => panic!("{what}: accepted"),
        }
    }
}

#[test]
fn a_billion_iterations_allowed_reserve_nothing_and_a_linear_system_stops_at_once() {
    // The limit is a bound on work, not a reservation (it once reserved 8 GB).
    let options = NewtonOptions {
        max_iter: 1_000_000_000,
        ..Default::default()
    };
    let mut solver = newton(2, options).unwrap();
    let mut sys = Linear::new(vec![2.0, 0.0, 0.0, 4.0], vec![2.0, 4.0]);
    let mut y = [0.0, 0.0];
    let stats = solver.solve(&mut sys, &mut y).unwrap();
    assert!(stats.iterations <= 2, "{stats:?}");
    assert!((y[0] - 1.0).abs() < 1e-12 && (y[1] - 1.0).abs() < 1e-12);
}

#[test]
fn wrong_lengths_nan_residuals_and_singular_jacobians_are_typed_errors() {
    let mut solver = newton(2, NewtonOptions::default()).unwrap();
    let mut sys = Linear::new(vec![2.0, 0.0, 0.0, 4.0], vec![2.0, 4.0]);
    // A starting point of the wrong length.
    let mut y3 = [0.0; 3];
    assert!(solver.solve(&mut sys, &mut y3).is_err());
    // A NaN starting point.
    let mut y = [f64::NAN, 0.0];
    assert!(solver.solve(&mut sys, &mut y).is_err());
    // A residual that turns NaN after the first evaluation.
    let mut sys_nan = Linear::new(vec![2.0, 1.0, 1.0, 4.0], vec![2.0, 4.0]);
    sys_nan.nan_after = Some(1);
    let mut y = [0.0, 0.0];
    let e = solver.solve(&mut sys_nan, &mut y).unwrap_err();
    assert!(matches!(e, NonlinearError::NonFinite { .. }), "{e:?}");
    // A singular Jacobian: an error, not a panic or an infinite correction.
    let mut singular = Linear::new(vec![1.0, 1.0, 1.0, 1.0], vec![1.0, 2.0]);
    let mut y = [0.0, 0.0];
    assert!(solver.solve(&mut singular, &mut y).is_err());
    // A Jacobian storage of another size than the system.
    let mut wrong = newton(3, NewtonOptions::default()).unwrap();
    let mut y = [0.0, 0.0];
    assert!(wrong.solve(&mut sys, &mut y).is_err());
}

#[test]
fn an_empty_system_is_refused() {
    let mut solver = newton(0, NewtonOptions::default());
    let mut sys = Linear::new(Vec::new(), Vec::new());
    let mut y: [f64; 0] = [];
    match &mut solver {
        Ok(s) => assert!(s.solve(&mut sys, &mut y).is_err(), "solved nothing"),
        Err(e) => assert!(!e.to_string().is_empty()),
    }
}
