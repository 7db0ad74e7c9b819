//! [`Convergence`]: when Newton's iteration stops. The residual test of the
//! tutorial's algorithms, or the rate-based test on the corrections that
//! CVODE and diffsol use inside their ODE solvers.

use crate::error::{NonlinearError, invalid};

/// The stopping test of [`Newton::solve`](crate::Newton::solve).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Convergence {
    /// Converged when `|G(Y_k)| <= atol + rtol |G(Y_0)|` (Euclidean norms,
    /// [`NewtonOptions::atol`](crate::NewtonOptions::atol),
    /// [`NewtonOptions::rtol`](crate::NewtonOptions::rtol)), or by the
    /// step test of [`NewtonOptions::step_tol`](crate::NewtonOptions::step_tol).
    /// The residual is evaluated at every iterate. The default.
    #[default]
    Residual,
    /// CVODE's rate-based test on the corrections `s_k` (the CVODE user
    /// guide, "Mathematical considerations"; diffsol's `Convergence`), in the
    /// weighted RMS norm `||s|| = sqrt(1/n sum (s_i / w_i)^2)` with the
    /// weights of [`Newton::weights_mut`](crate::Newton::weights_mut) (an ODE
    /// solver's error weights `w_i = atol_i + rtol |y_i|`, so that `tol` is a
    /// fraction of the local error tolerance):
    ///
    /// - the contraction rate `rho_k = ||s_k|| / ||s_{k-1}||` is measured
    ///   from the second iteration on; the estimate `rho` (CVODE's `crate`)
    ///   is `max(0.3 rho, rho_k)`, carried across calls and reset to 1 at
    ///   every set-up of the linear solver;
    /// - converged when `rho < 1` and `rho / (1 - rho) ||s_k|| <= tol` (an
    ///   estimate of the distance to the solution), or when `||s_k|| = 0`; in
    ///   the first iteration, where no rate is measured yet and the carried
    ///   one may be stale (a step-size change, a transient: accepting on it
    ///   cost the stiff test set up to 40 times its error), also only if
    ///   `||s_0|| <= tol`, unless the caller knows the rate
    ///   ([`Newton::set_known_rate`](crate::Newton::set_known_rate): `0` for
    ///   a linear system with its exact Newton matrix, whose first correction
    ///   solves it);
    /// - failed when `rho_k >= 1`, or when `rho_k` cannot reach `tol` in the
    ///   iterations left: `rho_k^(max_iter - k) / (1 - rho_k) ||s_k|| > tol`
    ///   (SciPy's BDF rule).
    ///
    /// The residual is evaluated only where the next correction needs it:
    /// a converged iteration costs one evaluation less than with
    /// [`Residual`](Self::Residual).
    Rate {
        /// The tolerance on the estimated remaining error, in the weighted norm.
        tol: f64,
    },
}

impl Convergence {
    pub(crate) fn validate(&self) -> Result<(), NonlinearError> {
        match *self {
            Self::Rate { tol } if !(tol > 0.0 && tol.is_finite()) => Err(invalid(
                "Convergence::Rate",
                format!("tol must be positive and finite, got {tol:?}"),
            )),
            _ => Ok(()),
        }
    }
}

/// The carried rate estimate decays by at most this factor per measured
/// call (CVODE's `CRDOWN`).
const RATE_DECAY: f64 = 0.3;

/// The state of the rate test across calls: CVODE's carried estimate
/// `crate`, and the rate the caller knows ([`Newton::set_known_rate`](crate::Newton::set_known_rate)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct RateEstimate {
    pub rate: f64,
    pub known: Option<f64>,
}

impl Default for RateEstimate {
    fn default() -> Self {
        Self {
            rate: 1.0,
            known: None,
        }
    }
}

/// What the rate test says about iteration `k` with correction norm `norm`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum RateVerdict {
    /// `rho_k >= 1`, or too slow to reach `tol` in the iterations left:
    /// the correction is not applied.
    Diverged { rate: f64 },
    /// Apply the correction, then [`RateEstimate::converged`] decides.
    Apply,
}

impl RateEstimate {
    /// Forgets the measured rate (a new Newton matrix).
    pub fn reset(&mut self) {
        self.rate = 1.0;
    }

    /// Measures `rho_k = norm / previous` (from the second iteration on)
    /// and updates the estimate unless the iteration diverges.
    pub fn measure(
        &mut self,
        k: usize,
        max_iter: usize,
        norm: f64,
        previous: f64,
        tol: f64,
    ) -> RateVerdict {
        if k == 0 {
            return RateVerdict::Apply;
        }
        let rate = norm / previous;
        if rate >= 1.0 || rate.powi((max_iter - k) as i32) / (1.0 - rate) * norm > tol {
            return RateVerdict::Diverged { rate };
        }
        self.rate = (RATE_DECAY * self.rate).max(rate);
        RateVerdict::Apply
    }

    /// Whether iteration `k`, whose correction had the norm `norm`, converged.
    pub fn converged(&self, k: usize, norm: f64, tol: f64) -> bool {
        let rho = self.rate;
        let estimated = rho < 1.0 && rho / (1.0 - rho) * norm < tol && (k > 0 || norm < tol);
        let known = k == 0
            && self
                .known
                .is_some_and(|r| r < 1.0 && r / (1.0 - r) * norm < tol);
        norm == 0.0 || estimated || known
    }
}

/// The weighted RMS norm `sqrt(1/n sum (v_i / w_i)^2)` of [`Convergence::Rate`]
/// (and of the error control of ODE solvers).
pub fn weighted_rms(v: &[f64], w: &[f64]) -> f64 {
    let n = v.len().max(1);
    (v.iter().zip(w).map(|(a, b)| (a / b).powi(2)).sum::<f64>() / n as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_test_follows_cvode() {
        let tol = 0.03;
        let mut r = RateEstimate::default();
        // First iteration: no rate, the carried 1 cannot converge.
        assert_eq!(r.measure(0, 4, 2.0, f64::NAN, tol), RateVerdict::Apply);
        assert!(!r.converged(0, 2.0, tol));
        // Second: rate 0.01, estimate max(0.3, 0.01) = 0.3: 0.3/0.7 * 0.02 < 0.03.
        assert_eq!(r.measure(1, 4, 0.02, 2.0, tol), RateVerdict::Apply);
        approx::assert_abs_diff_eq!(r.rate, 0.3, epsilon = 1e-15);
        assert!(r.converged(1, 0.02, tol));
        assert!(!r.converged(1, 0.1, tol));
        // A growing correction diverges; one too slow for the iterations left too:
        // rate 0.9, 0.9^2 / 0.1 * 1.8 = 14.6 > tol.
        assert!(matches!(
            r.measure(1, 4, 3.0, 2.0, tol),
            RateVerdict::Diverged { .. }
        ));
        assert!(matches!(
            r.measure(2, 4, 1.8, 2.0, tol),
            RateVerdict::Diverged { .. }
        ));
        // The estimate decays by 0.3 per measurement of a faster rate.
        r.measure(1, 4, 1e-6, 1.0, tol);
        approx::assert_abs_diff_eq!(r.rate, 0.09, epsilon = 1e-15);
        // In the first iteration a small carried rate counts only with ||s|| < tol ...
        assert!(!r.converged(0, 0.1, tol));
        assert!(r.converged(0, 0.01, tol));
        // ... unless the caller knows the rate (0: a linear system, exact matrix).
        r.known = Some(0.0);
        assert!(r.converged(0, 5.0, tol));
        assert!(!r.converged(0, f64::NAN, tol));
        r.reset();
        assert_eq!(r.rate, 1.0);
    }

    #[test]
    fn the_weighted_norm_is_an_rms() {
        // (1/2, 2/4, 3/6) -> sqrt(3 * 1/4 / 3) = 0.5.
        let n = weighted_rms(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0]);
        approx::assert_abs_diff_eq!(n, 0.5, epsilon = 1e-15);
        assert!(Convergence::Rate { tol: 0.0 }.validate().is_err());
        assert!(Convergence::Rate { tol: 0.03 }.validate().is_ok());
    }
}
