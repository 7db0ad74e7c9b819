//! [`NewtonOptions`]: the options of Newton's iteration, and only those
//! (each linear solver owns its own, e.g. [`PcgOptions`](crate::PcgOptions)).

use crate::NonExhaustive;
use crate::convergence::Convergence;
use crate::error::{NonlinearError, invalid};
use crate::forcing::ForcingTerm;

/// Which Newton variant [`Newton::solve`](crate::Newton::solve) runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NewtonMethod {
    /// Algorithm 1: the Jacobian is evaluated at every iterate and
    /// `J s = -G` is solved "exactly" (an iterative solver to
    /// [`NewtonOptions::linear_rtol`]). Quadratic convergence.
    Exact,
    /// Algorithm 2: Jacobian at every iterate, linear solves only to
    /// `|r_k| <= eta_k |G(Y_k)|` with the given forcing term.
    Inexact(ForcingTerm),
    /// Simplified Newton: the Jacobian of the first iterate is kept and
    /// solved exactly; it is re-evaluated at the current iterate when the
    /// contraction rate `theta_k = |s_k| / |s_{k-1}|` exceeds
    /// [`NewtonOptions::refresh_theta`], and kept across calls while the
    /// last solve contracted faster than [`NewtonOptions::keep_jacobian_theta`]
    /// and the caller does not call
    /// [`Newton::invalidate_jacobian`](crate::Newton::invalidate_jacobian)
    /// (RADAU5's rule). A failure with a kept Jacobian is retried once with
    /// a fresh one unless [`NewtonOptions::retry_fresh`] is off.
    Simplified,
    /// Algorithm 3: the system's cheap approximate Jacobian
    /// ([`NonlinearSystem::approximate_jacobian`](crate::NonlinearSystem::approximate_jacobian),
    /// for cloth the constant linearised Jacobian of eq. 50; the exact one
    /// at the first iterate if the system has none) is evaluated once and
    /// kept across calls until
    /// [`Newton::invalidate_jacobian`](crate::Newton::invalidate_jacobian)
    /// (call it when `h` or the material changes); linear solves use the
    /// forcing term. If the system has no approximation, a failure with a
    /// kept Jacobian is retried once with a freshly evaluated one.
    InexactSimplified(ForcingTerm),
}

impl NewtonMethod {
    pub(crate) fn forcing(&self) -> Option<ForcingTerm> {
        match *self {
            Self::Inexact(f) | Self::InexactSimplified(f) => Some(f),
            _ => None,
        }
    }

    pub(crate) fn keeps_jacobian(&self) -> bool {
        matches!(self, Self::Simplified | Self::InexactSimplified(_))
    }
}

/// Options of [`Newton`](crate::Newton); every field has a documented
/// default. The linear solver's settings (preconditioner, iteration limit)
/// belong to the linear solver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// The variant. Default [`NewtonMethod::Exact`].
    pub method: NewtonMethod,
    /// The stopping test. Default [`Convergence::Residual`], whose
    /// tolerances are `atol`, `rtol` and `step_tol`.
    pub convergence: Convergence,
    /// Converged when `|G(Y_k)| <= atol + rtol |G(Y_0)|` (Euclidean norms).
    /// Default `1e-12`.
    pub atol: f64,
    /// See [`atol`](Self::atol). Default `1e-8`.
    pub rtol: f64,
    /// Also converged when `|s_k| theta_k / (1 - theta_k) <= step_tol`
    /// (Hairer-Wanner, Solving ODEs II, section IV.8: an estimate of the
    /// remaining error `|Y_{k+1} - Y*|`), for `k >= 1` and `theta_k < 1`. `0` disables it.
    /// Default `0`.
    pub step_tol: f64,
    /// Newton iteration limit per solve. Default `50`.
    pub max_iter: usize,
    /// Relative tolerance of the linear solves of [`NewtonMethod::Exact`]
    /// and [`NewtonMethod::Simplified`] with an iterative solver. Default `1e-10`.
    pub linear_rtol: f64,
    /// First forcing term `eta_0` of the Eisenstat-Walker choices. Default `0.5`.
    pub eta_initial: f64,
    /// Upper bound `eta_max` of every adaptive forcing term. Default `0.9`.
    pub eta_max: f64,
    /// [`NewtonMethod::Simplified`] re-evaluates the Jacobian at the current
    /// iterate when `theta_k > refresh_theta` (infinite: never). Default `0.5`.
    pub refresh_theta: f64,
    /// [`NewtonMethod::Simplified`] keeps its Jacobian for the next call
    /// when the last contraction rate of a converged solve is at most this
    /// (RADAU5's `THET`, whose default is `0.001`; infinite: always, until
    /// [`Newton::invalidate_jacobian`](crate::Newton::invalidate_jacobian)).
    /// Default `0.001`.
    pub keep_jacobian_theta: f64,
    /// A failure with a Jacobian kept from an earlier call is retried once
    /// from the start with a fresh one (RADAU5). Off, the failure is
    /// returned and the caller decides (an ODE solver that manages its own
    /// Jacobian, as CVODE does). Default `true`.
    pub retry_fresh: bool,
    /// Diverged when `|G(Y_k)| > max_residual_growth |G(Y_0)|`. Default `1e6`.
    pub max_residual_growth: f64,
    /// Record the histories of [`NewtonStats`](crate::NewtonStats)
    /// (`residual_norms`, `step_norms`, `forcing_terms`), which allocates
    /// at every solve. Default `false`: the last norms are kept in plain
    /// fields and a solve allocates nothing.
    pub record_history: bool,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            method: NewtonMethod::Exact,
            convergence: Convergence::Residual,
            atol: 1e-12,
            rtol: 1e-8,
            step_tol: 0.0,
            max_iter: 50,
            linear_rtol: 1e-10,
            eta_initial: 0.5,
            eta_max: 0.9,
            refresh_theta: 0.5,
            keep_jacobian_theta: 1e-3,
            retry_fresh: true,
            max_residual_growth: 1e6,
            record_history: false,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

impl NewtonOptions {
    /// Options with the given method and the other defaults.
    pub fn with_method(method: NewtonMethod) -> Self {
        Self {
            method,
            ..Self::default()
        }
    }

    /// Checks every field's range.
    ///
    /// # Errors
    /// [`NonlinearError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), NonlinearError> {
        let nonneg = |name, v: f64| {
            if v >= 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(invalid(name, format!("must be finite and >= 0, got {v:?}")))
            }
        };
        nonneg("atol", self.atol)?;
        nonneg("rtol", self.rtol)?;
        nonneg("step_tol", self.step_tol)?;
        if !(self.keep_jacobian_theta >= 0.0) {
            return Err(invalid(
                "keep_jacobian_theta",
                format!("must be >= 0, got {:?}", self.keep_jacobian_theta),
            ));
        }
        if self.max_iter == 0 {
            return Err(invalid("max_iter", "must be at least 1"));
        }
        if !(self.linear_rtol >= 0.0 && self.linear_rtol < 1.0) {
            return Err(invalid(
                "linear_rtol",
                format!("must lie in [0, 1), got {:?}", self.linear_rtol),
            ));
        }
        for (name, v) in [("eta_initial", self.eta_initial), ("eta_max", self.eta_max)] {
            if !(v > 0.0 && v < 1.0) {
                return Err(invalid(name, format!("must lie in (0, 1), got {v:?}")));
            }
        }
        if !(self.refresh_theta > 0.0) {
            return Err(invalid(
                "refresh_theta",
                format!("must be > 0, got {:?}", self.refresh_theta),
            ));
        }
        if !(self.max_residual_growth > 1.0) {
            return Err(invalid(
                "max_residual_growth",
                format!("must be > 1, got {:?}", self.max_residual_growth),
            ));
        }
        if let Some(f) = self.method.forcing() {
            f.validate()?;
        }
        self.convergence.validate()
    }
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_are_validated() {
        assert!(NewtonOptions::default().validate().is_ok());
        let bad = [
            NewtonOptions {
                rtol: -1.0,
                ..Default::default()
            },
            NewtonOptions {
                max_iter: 0,
                ..Default::default()
            },
            NewtonOptions {
                linear_rtol: 1.0,
                ..Default::default()
            },
            NewtonOptions {
                eta_max: 1.0,
                ..Default::default()
            },
            NewtonOptions::with_method(NewtonMethod::Inexact(ForcingTerm::Constant(1.5))),
            NewtonOptions::with_method(NewtonMethod::Inexact(ForcingTerm::EisenstatWalker2 {
                gamma: 0.9,
                alpha: 3.0,
            })),
            NewtonOptions {
                atol: f64::NAN,
                ..Default::default()
            },
        ];
        for o in bad {
            assert!(
                matches!(o.validate(), Err(NonlinearError::InvalidParameter { .. })),
                "{o:?}"
            );
        }
    }
}
