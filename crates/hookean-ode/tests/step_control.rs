//! Newton-driven step-size control (the tutorial's section 3.4) on implicit
//! Euler for the stiff scalar ODE y' = -y^3, y(0) = 10, whose solution is
//! y(t) = 10 / sqrt(1 + 200 t).

use hookean_nonlinear::*;
use hookean_ode::control::*;

struct EulerStep {
    h: f64,
    y0: f64,
}

impl NonlinearSystem for EulerStep {
    type Jacobian = faer::Mat<f64>;
    fn dim(&self) -> usize {
        1
    }
    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        g[0] = y[0] + self.h * y[0].powi(3) - self.y0;
        Ok(())
    }
    fn jacobian(&mut self, y: &[f64], j: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
        j[(0, 0)] = 1.0 + 3.0 * self.h * y[0] * y[0];
        Ok(())
    }
}

#[test]
fn iteration_controller_drives_implicit_euler() {
    // The step-size bound is the integrator's (here this loop's), not the
    // controller's.
    let h_max = 0.05;
    let opts = IterationControllerOptions::default();
    let mut control = IterationController::new(opts.clone()).unwrap();
    // At most 4 Newton iterations per step: large steps from a poor start fail.
    let newton_opts = NewtonOptions {
        max_iter: 4,
        rtol: 1e-10,
        ..Default::default()
    };
    let mut newton = Newton::new(newton_opts, faer::Mat::zeros(1, 1), DenseLu::new()).unwrap();
    let (mut t, mut y, mut h) = (0.0, 10.0, 0.01);
    let (mut accepted, mut failures) = (0, 0);
    let mut last_failed = false;
    while t < 2.0 {
        let mut yn = [y]; // start from the previous value
        let result = newton.solve(&mut EulerStep { h, y0: y }, &mut yn);
        let outcome = NewtonOutcome::from_result(&result).expect("only step failures");
        let decision = control.decide(h, outcome).unwrap();
        // The documented rule, recomputed here.
        let expected = match outcome {
            NewtonOutcome::Failed => StepDecision::Retry {
                h: h * opts.failure_factor,
            },
            NewtonOutcome::Converged { iterations } => {
                let mut f = if iterations <= opts.few_iterations {
                    opts.grow_factor
                } else if iterations >= opts.many_iterations {
                    opts.shrink_factor
                } else {
                    1.0
                };
                if last_failed {
                    f = f.min(1.0);
                }
                StepDecision::Accept { h_next: h * f }
            }
        };
        assert_eq!(decision, expected);
        match decision {
            StepDecision::Accept { h_next } => {
                t += h;
                y = yn[0];
                h = h_next.min(h_max);
                accepted += 1;
                last_failed = false;
            }
            StepDecision::Retry { h: smaller } => {
                h = smaller;
                failures += 1;
                last_failed = true;
            }
        }
    }
    // The solution decays from 10 to 10/sqrt(401) = 0.4994; implicit Euler
    // is first order, and the steps grew to h_max = 0.05 once the problem
    // got easy.
    let exact = 10.0 / (1.0 + 200.0 * t).sqrt();
    assert!((y - exact).abs() < 0.05 * exact, "{y} vs {exact}");
    assert!(failures >= 1, "the first large steps should fail");
    assert!(h == 0.05);
    // Fewer steps than the initial h = 0.01 kept fixed would take (200).
    assert!(accepted < 200, "{accepted}");
}
