//! Step-size controllers for implicit integrators: the Newton-iteration
//! controller of the tutorial's section 3.4 and an error-based PI
//! controller whose safety factor can account for Newton's iteration count
//! (as SciPy's BDF and RADAU5 do).
//!
//! Both are small state machines with pure, documented rules: feed them the
//! outcome of a step, they answer [`StepDecision::Accept`] with the next step
//! size or [`StepDecision::Retry`] with a smaller one.

use crate::NonExhaustive;
use hookean_nonlinear::{NewtonStats, NonlinearError};

use crate::error::OdeError;

/// Error for an out-of-range controller option or argument.
fn invalid(name: &'static str, message: impl Into<String>) -> OdeError {
    OdeError::InvalidController {
        name,
        message: message.into(),
    }
}

/// What a controller tells the integrator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepDecision {
    /// Keep the step; take the next one with `h_next`.
    Accept {
        /// The next step size.
        h_next: f64,
    },
    /// Reject the step; redo it from the same state with `h`.
    Retry {
        /// The smaller step size to retry with.
        h: f64,
    },
}

impl StepDecision {
    /// The step size to use next (for the next step or the retry).
    pub fn step_size(&self) -> f64 {
        match *self {
            Self::Accept { h_next } => h_next,
            Self::Retry { h } => h,
        }
    }

    /// Whether the step is accepted.
    pub fn is_accept(&self) -> bool {
        matches!(self, Self::Accept { .. })
    }
}

/// How Newton's iteration ended on a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NewtonOutcome {
    /// Converged after this many iterations.
    Converged {
        /// Newton iterations used.
        iterations: usize,
    },
    /// Diverged, hit its limit, met NaN, or its linear solver failed.
    Failed,
}

impl NewtonOutcome {
    /// Classifies the result of [`Newton::solve`](hookean_nonlinear::Newton::solve):
    /// `Some(Converged)` on success, `Some(Failed)` for errors that call for a
    /// smaller step ([`NonlinearError::is_step_failure`]), `None` for other
    /// errors (wrong sizes, bad parameters), which the integrator should
    /// propagate instead.
    pub fn from_result(result: &Result<NewtonStats, NonlinearError>) -> Option<Self> {
        match result {
            Ok(stats) => Some(Self::Converged {
                iterations: stats.iterations,
            }),
            Err(e) if e.is_step_failure() => Some(Self::Failed),
            Err(_) => None,
        }
    }
}

fn check_h(h: f64) -> Result<(), OdeError> {
    if h > 0.0 && h.is_finite() {
        Ok(())
    } else {
        Err(invalid(
            "h",
            format!("step size must be finite and > 0, got {h:?}"),
        ))
    }
}

/// Options of [`IterationController`].
#[derive(Debug, Clone, PartialEq)]
pub struct IterationControllerOptions {
    /// A step that converged in at most this many Newton iterations grows
    /// `h`. Default `2`.
    pub few_iterations: usize,
    /// A step that needed at least this many iterations shrinks `h`
    /// (it is still accepted). Default `6`.
    pub many_iterations: usize,
    /// Growth ratio after an easy step; it is the maximum growth ratio
    /// `h_next / h` of the controller. Default `1.5`.
    pub grow_factor: f64,
    /// Shrink ratio after a hard (but converged) step. Default `0.7`.
    pub shrink_factor: f64,
    /// Shrink ratio for the retry after a Newton failure. Default `0.5`.
    pub failure_factor: f64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for IterationControllerOptions {
    fn default() -> Self {
        Self {
            few_iterations: 2,
            many_iterations: 6,
            grow_factor: 1.5,
            shrink_factor: 0.7,
            failure_factor: 0.5,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// The Newton-iteration step controller of the tutorial's section 3.4:
/// the number of Newton iterations decides whether `h` grows or shrinks.
///
/// The rule, for a step of size `h`:
/// - converged in `i <= few_iterations`: `h_next = h grow_factor`;
/// - converged in `i >= many_iterations`: `h_next = h shrink_factor`;
/// - converged otherwise: `h_next = h`;
/// - right after a failure, an accepted step never grows (`h_next <= h`,
///   Hairer-Wanner's rule after a rejection);
/// - failed: retry with `h failure_factor`.
///
/// The step-size bounds are the integrator's ([`StepSizePolicy`](crate::StepSizePolicy)).
///
/// ```
/// use hookean_ode::control::*;
/// let mut c = IterationController::new(IterationControllerOptions::default())?;
/// assert_eq!(c.decide(0.01, NewtonOutcome::Converged { iterations: 1 })?,
///            StepDecision::Accept { h_next: 0.015 });
/// assert_eq!(c.decide(0.015, NewtonOutcome::Failed)?, StepDecision::Retry { h: 0.0075 });
/// # Ok::<(), hookean_ode::OdeError>(())
/// ```
#[derive(Debug, Clone)]
pub struct IterationController {
    options: IterationControllerOptions,
    last_failed: bool,
}

impl IterationController {
    /// A controller with validated options.
    ///
    /// # Errors
    /// [`OdeError::InvalidController`] unless `grow_factor >= 1`,
    /// `0 < shrink_factor <= 1`, `0 < failure_factor < 1` and
    /// `few_iterations < many_iterations`.
    pub fn new(options: IterationControllerOptions) -> Result<Self, OdeError> {
        let o = &options;
        if !(o.grow_factor >= 1.0 && o.grow_factor.is_finite()) {
            return Err(invalid(
                "grow_factor",
                format!("must be finite and >= 1, got {:?}", o.grow_factor),
            ));
        }
        if !(o.shrink_factor > 0.0 && o.shrink_factor <= 1.0) {
            return Err(invalid(
                "shrink_factor",
                format!("must lie in (0, 1], got {:?}", o.shrink_factor),
            ));
        }
        if !(o.failure_factor > 0.0 && o.failure_factor < 1.0) {
            return Err(invalid(
                "failure_factor",
                format!("must lie in (0, 1), got {:?}", o.failure_factor),
            ));
        }
        if o.few_iterations >= o.many_iterations {
            return Err(invalid(
                "few_iterations",
                format!(
                    "must be < many_iterations ({} >= {})",
                    o.few_iterations, o.many_iterations
                ),
            ));
        }
        Ok(Self {
            options,
            last_failed: false,
        })
    }

    /// The options.
    pub fn options(&self) -> &IterationControllerOptions {
        &self.options
    }

    /// Forgets the last failure (e.g. at a restart of the integration).
    pub fn reset(&mut self) {
        self.last_failed = false;
    }

    /// What the controller remembers between steps (`[last_failed]`, a
    /// flag), for a checkpoint.
    pub(crate) fn memory(&self) -> [f64; 1] {
        [f64::from(u8::from(self.last_failed))]
    }

    /// Restores [`memory`](Self::memory).
    pub(crate) fn set_memory(&mut self, m: &[f64]) {
        self.last_failed = m.first() == Some(&1.0);
    }

    /// Applies the rule (see the type's docs) to a step of size `h`.
    ///
    /// # Errors
    /// [`OdeError::InvalidController`] for a non-positive or non-finite `h`.
    pub fn decide(&mut self, h: f64, outcome: NewtonOutcome) -> Result<StepDecision, OdeError> {
        check_h(h)?;
        let o = &self.options;
        match outcome {
            NewtonOutcome::Failed => {
                self.last_failed = true;
                Ok(StepDecision::Retry {
                    h: h * o.failure_factor,
                })
            }
            NewtonOutcome::Converged { iterations } => {
                let mut factor = if iterations <= o.few_iterations {
                    o.grow_factor
                } else if iterations >= o.many_iterations {
                    o.shrink_factor
                } else {
                    1.0
                };
                if self.last_failed {
                    factor = factor.min(1.0);
                }
                self.last_failed = false;
                Ok(StepDecision::Accept { h_next: h * factor })
            }
        }
    }
}

/// Options of [`PiController`].
#[derive(Debug, Clone, PartialEq)]
pub struct PiControllerOptions {
    /// Order `q` of the error estimate (`err ~ h^(q+1)`); the exponents use
    /// `k = q + 1`. Default `2` (variable-step BDF2).
    pub order: usize,
    /// Safety factor. Default `0.9`.
    pub safety: f64,
    /// Integral gain: exponent `beta1 / k` on the current error. Default `0.7`.
    pub beta1: f64,
    /// Proportional gain: exponent `beta2 / k` on the previous accepted
    /// error. Default `0.4` (Gustafsson's PI controller).
    pub beta2: f64,
    /// Smallest factor `h_new / h`. Default `0.2`.
    pub min_factor: f64,
    /// Largest factor `h_new / h` (1 right after a rejection). Default `5`.
    pub max_factor: f64,
    /// Factor for the retry after a Newton failure. Default `0.5`.
    pub failure_factor: f64,
    /// If `Some(n_max)`, the safety factor is scaled by
    /// `(2 n_max + 1) / (2 n_max + n_iter)` with the Newton iterations
    /// `n_iter` of the step (RADAU5's and SciPy BDF's rule): steps whose
    /// Newton iteration struggled grow less. Default `None`.
    pub newton_max_iter: Option<usize>,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for PiControllerOptions {
    fn default() -> Self {
        Self {
            order: 2,
            safety: 0.9,
            beta1: 0.7,
            beta2: 0.4,
            min_factor: 0.2,
            max_factor: 5.0,
            failure_factor: 0.5,
            newton_max_iter: None,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// An error-based PI step-size controller (Gustafsson; Hairer-Wanner II,
/// IV.2 and IV.8) for integrators with an error estimate, e.g. the
/// variable-step BDF2 of hookean-ode.
///
/// `err` is the error estimate in the integrator's weighted norm, so that a
/// step is acceptable when `err <= 1`. With `k = order + 1` and the safety
/// factor `s` (scaled by Newton's iteration count if
/// [`newton_max_iter`](PiControllerOptions::newton_max_iter) is set):
/// - accepted (`err <= 1`): `factor = s err^(-beta1/k) err_prev^(beta2/k)`,
///   where `err_prev` is the previous accepted error (floored at `1e-4`);
///   for the first accepted step (no `err_prev`) the I controller
///   `factor = s err^(-1/k)`; `err = 0` gives `max_factor`. The factor is
///   clamped to `[min_factor, max_factor]`, with `max_factor` replaced by 1
///   right after a rejection; `h_next = h factor`.
/// - rejected (`err > 1`, or `err` not finite): retry with
///   `h max(min_factor, s err^(-1/k))` (`min_factor` for non-finite `err`);
/// - Newton failure: retry with `h failure_factor`.
///
/// The step-size bounds are the integrator's ([`StepSizePolicy`](crate::StepSizePolicy)).
#[derive(Debug, Clone)]
pub struct PiController {
    options: PiControllerOptions,
    err_prev: Option<f64>,
    last_rejected: bool,
}

impl PiController {
    /// A controller with validated options.
    ///
    /// # Errors
    /// [`OdeError::InvalidController`] unless `order >= 1`,
    /// `0 < safety <= 1`, `beta1 > 0`, `beta2 >= 0`,
    /// `0 < min_factor < 1 <= max_factor`, `0 < failure_factor < 1` and
    /// `newton_max_iter != Some(0)`.
    pub fn new(options: PiControllerOptions) -> Result<Self, OdeError> {
        let o = &options;
        if o.order == 0 {
            return Err(invalid("order", "must be at least 1"));
        }
        if !(o.safety > 0.0 && o.safety <= 1.0) {
            return Err(invalid(
                "safety",
                format!("must lie in (0, 1], got {:?}", o.safety),
            ));
        }
        if !(o.beta1 > 0.0 && o.beta1.is_finite() && o.beta2 >= 0.0 && o.beta2.is_finite()) {
            return Err(invalid(
                "beta1/beta2",
                format!(
                    "need beta1 > 0 and beta2 >= 0, got {:?}, {:?}",
                    o.beta1, o.beta2
                ),
            ));
        }
        if !(o.min_factor > 0.0
            && o.min_factor < 1.0
            && o.max_factor >= 1.0
            && o.max_factor.is_finite())
        {
            return Err(invalid(
                "min_factor/max_factor",
                format!(
                    "need 0 < min_factor < 1 <= max_factor, got {:?}, {:?}",
                    o.min_factor, o.max_factor
                ),
            ));
        }
        if !(o.failure_factor > 0.0 && o.failure_factor < 1.0) {
            return Err(invalid(
                "failure_factor",
                format!("must lie in (0, 1), got {:?}", o.failure_factor),
            ));
        }
        if o.newton_max_iter == Some(0) {
            return Err(invalid("newton_max_iter", "must be at least 1"));
        }
        Ok(Self {
            options,
            err_prev: None,
            last_rejected: false,
        })
    }

    /// The options.
    pub fn options(&self) -> &PiControllerOptions {
        &self.options
    }

    /// Forgets the error history (e.g. after a discontinuity).
    pub fn reset(&mut self) {
        self.err_prev = None;
        self.last_rejected = false;
    }

    /// What the controller remembers between steps (`[has err_prev,
    /// err_prev, last_rejected]`), for a checkpoint.
    pub(crate) fn memory(&self) -> [f64; 3] {
        [
            f64::from(u8::from(self.err_prev.is_some())),
            self.err_prev.unwrap_or(0.0),
            f64::from(u8::from(self.last_rejected)),
        ]
    }

    /// Restores [`memory`](Self::memory).
    pub(crate) fn set_memory(&mut self, m: &[f64]) {
        self.err_prev = (m.first() == Some(&1.0)).then(|| m.get(1).copied().unwrap_or(0.0));
        self.last_rejected = m.get(2) == Some(&1.0);
    }

    /// The safety factor for a step whose Newton iteration took `newton_iterations`.
    pub fn safety(&self, newton_iterations: usize) -> f64 {
        let o = &self.options;
        match o.newton_max_iter {
            Some(n) => o.safety * (2 * n + 1) as f64 / (2 * n + newton_iterations) as f64,
            None => o.safety,
        }
    }

    /// Accepts or rejects a step of size `h` whose error estimate is `err`
    /// and whose Newton iteration converged in `newton_iterations`.
    ///
    /// # Errors
    /// [`OdeError::InvalidController`] for a bad `h` or a negative `err`.
    pub fn decide(
        &mut self,
        h: f64,
        err: f64,
        newton_iterations: usize,
    ) -> Result<StepDecision, OdeError> {
        check_h(h)?;
        if err < 0.0 {
            return Err(invalid(
                "err",
                format!("error estimate must be >= 0, got {err:?}"),
            ));
        }
        let s = self.safety(newton_iterations);
        let o = &self.options;
        let k = (o.order + 1) as f64;
        if err <= 1.0 {
            let factor = if err == 0.0 {
                o.max_factor
            } else {
                match self.err_prev {
                    Some(ep) => s * err.powf(-o.beta1 / k) * ep.powf(o.beta2 / k),
                    None => s * err.powf(-1.0 / k),
                }
            };
            let max = if self.last_rejected {
                1.0
            } else {
                o.max_factor
            };
            let factor = factor.clamp(o.min_factor, max);
            self.err_prev = Some(err.max(1e-4));
            self.last_rejected = false;
            Ok(StepDecision::Accept { h_next: h * factor })
        } else {
            // err > 1 or NaN/inf.
            let factor = if err.is_finite() {
                (s * err.powf(-1.0 / k)).max(o.min_factor)
            } else {
                o.min_factor
            };
            self.last_rejected = true;
            Ok(StepDecision::Retry { h: h * factor })
        }
    }

    /// A step whose Newton iteration failed: retry with `h failure_factor`.
    ///
    /// # Errors
    /// [`OdeError::InvalidController`] for a bad `h`.
    pub fn newton_failed(&mut self, h: f64) -> Result<StepDecision, OdeError> {
        check_h(h)?;
        self.last_rejected = true;
        Ok(StepDecision::Retry {
            h: h * self.options.failure_factor,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn conv(i: usize) -> NewtonOutcome {
        NewtonOutcome::Converged { iterations: i }
    }

    #[test]
    fn iteration_controller_follows_its_rule_exactly() {
        let mut c = IterationController::new(IterationControllerOptions::default()).unwrap();
        // (h, outcome) -> expected decision, computed from the documented rule.
        let script: [(f64, NewtonOutcome, StepDecision); 10] = [
            (0.01, conv(2), StepDecision::Accept { h_next: 0.015 }), // few: x1.5
            (0.015, conv(4), StepDecision::Accept { h_next: 0.015 }), // middle: keep
            (
                0.015,
                conv(6),
                StepDecision::Accept {
                    h_next: 0.015 * 0.7,
                },
            ), // many: x0.7
            (
                0.0105,
                NewtonOutcome::Failed,
                StepDecision::Retry { h: 0.00525 },
            ),
            (0.00525, conv(1), StepDecision::Accept { h_next: 0.00525 }), // no growth after failure
            (0.00525, conv(1), StepDecision::Accept { h_next: 0.007875 }),
            (0.04, conv(0), StepDecision::Accept { h_next: 0.06 }), // few: x1.5
            (
                0.0015,
                NewtonOutcome::Failed,
                StepDecision::Retry { h: 7.5e-4 },
            ),
            (7.5e-4, conv(7), StepDecision::Accept { h_next: 5.25e-4 }), // many: x0.7
            (5.25e-4, conv(5), StepDecision::Accept { h_next: 5.25e-4 }),
        ];
        for (n, (h, outcome, expected)) in script.into_iter().enumerate() {
            let got = c.decide(h, outcome).unwrap();
            assert!(
                (got.step_size() - expected.step_size()).abs() <= 1e-15 * expected.step_size()
                    && got.is_accept() == expected.is_accept(),
                "step {n}: {got:?} != {expected:?}"
            );
        }
        assert!(c.decide(0.0, conv(1)).is_err());
        assert!(c.decide(f64::NAN, conv(1)).is_err());
    }

    #[test]
    fn iteration_controller_rejects_bad_options() {
        for o in [
            IterationControllerOptions {
                grow_factor: 0.9,
                ..Default::default()
            },
            IterationControllerOptions {
                failure_factor: 1.0,
                ..Default::default()
            },
            IterationControllerOptions {
                few_iterations: 6,
                ..Default::default()
            },
        ] {
            assert!(matches!(
                IterationController::new(o),
                Err(OdeError::InvalidController { .. })
            ));
        }
    }

    #[test]
    fn pi_controller_follows_its_rule_exactly() {
        let mut c = PiController::new(PiControllerOptions::default()).unwrap();
        let k = 3.0;
        // First accepted step: I controller 0.9 * 0.5^(-1/3).
        let d = c.decide(0.01, 0.5, 2).unwrap();
        let f1 = 0.9 * 0.5f64.powf(-1.0 / k);
        assert!(d.is_accept() && (d.step_size() - 0.01 * f1).abs() < 1e-15);
        // Second: PI with err_prev = 0.5: 0.9 * 0.25^(-0.7/3) * 0.5^(0.4/3).
        let h = d.step_size();
        let d = c.decide(h, 0.25, 2).unwrap();
        let f2 = 0.9 * 0.25f64.powf(-0.7 / k) * 0.5f64.powf(0.4 / k);
        assert!(d.is_accept() && (d.step_size() - h * f2).abs() < 1e-15 * h);
        // Rejection: 0.9 * 8^(-1/3) = 0.45.
        let h = d.step_size();
        let d = c.decide(h, 8.0, 2).unwrap();
        assert!(!d.is_accept() && (d.step_size() - h * 0.45).abs() < 1e-15 * h);
        // Huge error: min_factor 0.2.
        let h = d.step_size();
        let d = c.decide(h, 1e6, 2).unwrap();
        assert!(!d.is_accept() && (d.step_size() - h * 0.2).abs() < 1e-15 * h);
        // Accepted right after a rejection: no growth even for a tiny error.
        let h = d.step_size();
        let d = c.decide(h, 1e-8, 2).unwrap();
        assert!(d.is_accept() && d.step_size() == h);
        // Then err = 0 gives max_factor.
        let d = c.decide(h, 0.0, 2).unwrap();
        assert!((d.step_size() - 5.0 * h).abs() < 1e-15 * h);
        // Newton failure halves.
        let d = c.newton_failed(0.02).unwrap();
        assert_eq!(d, StepDecision::Retry { h: 0.01 });
        // NaN error estimate is a rejection with min_factor.
        let d = c.decide(0.01, f64::NAN, 1).unwrap();
        assert!(!d.is_accept() && (d.step_size() - 0.002).abs() < 1e-18);
        assert!(c.decide(0.01, -1.0, 1).is_err());
    }

    #[test]
    fn pi_controller_newton_aware_safety() {
        let mut c = PiController::new(PiControllerOptions {
            newton_max_iter: Some(4),
            ..Default::default()
        })
        .unwrap();
        // s = 0.9 * 9 / (8 + n_iter).
        assert!((c.safety(1) - 0.9).abs() < 1e-15);
        assert!((c.safety(4) - 0.9 * 9.0 / 12.0).abs() < 1e-15);
        let d = c.decide(1.0, 0.125, 4).unwrap();
        // I controller: 0.675 * 0.125^(-1/3) = 1.35.
        assert!((d.step_size() - 1.35).abs() < 1e-14);
    }
}
