//! The forcing terms of inexact Newton: how tightly each linear solve is
//! done (the tutorial's Algorithm 2, step 4; Eisenstat and Walker 1996).

use crate::error::{NonlinearError, invalid};
use crate::options::NewtonOptions;

/// The golden ratio `(1 + sqrt 5) / 2`, the exponent of Eisenstat-Walker
/// choice 1 and of its safeguard.
const GOLDEN: f64 = 1.618_033_988_749_895;

/// How the forcing term `eta_k` of an inexact Newton method is chosen: the
/// linear solve of iteration `k` stops when `|J s_k + G(Y_k)| <= eta_k |G(Y_k)|`
/// (the tutorial's Algorithm 2, step 4).
///
/// The adaptive choices are those of Eisenstat and Walker (SIAM J. Sci.
/// Comput. 17, 1996) with the safeguards KINSOL documents; every `eta_k` is
/// then capped by [`NewtonOptions::eta_max`] and, for the adaptive choices,
/// raised to at least `0.5 tol / |G(Y_k)|` (Kelley's guard against
/// oversolving the last iteration, `tol = atol + rtol |G(Y_0)|`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ForcingTerm {
    /// A constant `eta` in `(0, 1)`; the tutorial uses `0.02` (section 3.2).
    Constant(f64),
    /// Eisenstat-Walker choice 1:
    /// `eta_k = | |G(Y_k)| - |G(Y_{k-1}) + J_{k-1} s_{k-1}| | / |G(Y_{k-1})|`,
    /// safeguarded by `eta_k >= eta_{k-1}^phi` when `eta_{k-1}^phi > 0.1`,
    /// `phi = (1 + sqrt 5) / 2`. Convergence is superlinear (q-order phi).
    EisenstatWalker1,
    /// Eisenstat-Walker choice 2: `eta_k = gamma (|G(Y_k)| / |G(Y_{k-1})|)^alpha`,
    /// safeguarded by `eta_k >= gamma eta_{k-1}^alpha` when that is `> 0.1`.
    /// KINSOL's defaults are `gamma = 0.9`, `alpha = 2`
    /// ([`ForcingTerm::EW2_DEFAULT`]).
    EisenstatWalker2 {
        /// Factor `gamma` in `(0, 1]`.
        gamma: f64,
        /// Exponent `alpha` in `(1, 2]`.
        alpha: f64,
    },
}

impl ForcingTerm {
    /// The tutorial's constant forcing term `eta = 0.02` (section 3.2).
    pub const TUTORIAL: Self = Self::Constant(0.02);
    /// Eisenstat-Walker choice 2 with KINSOL's `gamma = 0.9`, `alpha = 2`.
    pub const EW2_DEFAULT: Self = Self::EisenstatWalker2 {
        gamma: 0.9,
        alpha: 2.0,
    };

    pub(crate) fn validate(&self) -> Result<(), NonlinearError> {
        match *self {
            Self::Constant(eta) if !(eta > 0.0 && eta < 1.0) => Err(invalid(
                "ForcingTerm::Constant",
                format!("eta must lie in (0, 1), got {eta:?}"),
            )),
            Self::EisenstatWalker2 { gamma, alpha }
                if !(gamma > 0.0 && gamma <= 1.0 && alpha > 1.0 && alpha <= 2.0) =>
            {
                Err(invalid(
                    "ForcingTerm::EisenstatWalker2",
                    format!("need gamma in (0, 1] and alpha in (1, 2], got {gamma:?}, {alpha:?}"),
                ))
            }
            _ => Ok(()),
        }
    }
}

/// The forcing term `eta_k` (see [`ForcingTerm`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn forcing_term(
    f: ForcingTerm,
    k: usize,
    opts: &NewtonOptions,
    gnorm: f64,
    gnorm_prev: f64,
    linres_prev: f64,
    eta_prev: f64,
    tol: f64,
) -> f64 {
    let eta = match f {
        ForcingTerm::Constant(eta) => return eta,
        _ if k == 0 => opts.eta_initial,
        ForcingTerm::EisenstatWalker1 => {
            let mut eta = (gnorm - linres_prev).abs() / gnorm_prev;
            let safe = eta_prev.powf(GOLDEN);
            if safe > 0.1 {
                eta = eta.max(safe);
            }
            eta
        }
        ForcingTerm::EisenstatWalker2 { gamma, alpha } => {
            let mut eta = gamma * (gnorm / gnorm_prev).powf(alpha);
            let safe = gamma * eta_prev.powf(alpha);
            if safe > 0.1 {
                eta = eta.max(safe);
            }
            eta
        }
    };
    let eta = eta.min(opts.eta_max);
    // Kelley: do not oversolve the last linear system.
    eta.max(0.5 * tol / gnorm).min(opts.eta_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forcing_terms_follow_eisenstat_walker_with_safeguards() {
        let opts = NewtonOptions::default();
        // First iteration: eta_initial.
        assert_eq!(
            forcing_term(
                ForcingTerm::EW2_DEFAULT,
                0,
                &opts,
                1.0,
                f64::NAN,
                f64::NAN,
                0.5,
                0.0
            ),
            0.5
        );
        // Choice 2: gamma (|G_k|/|G_{k-1}|)^alpha = 0.9 * 0.01 = 0.009, but the
        // safeguard gamma eta_prev^alpha = 0.9 * 0.25 = 0.225 > 0.1 wins.
        let e = forcing_term(ForcingTerm::EW2_DEFAULT, 1, &opts, 0.1, 1.0, 0.0, 0.5, 0.0);
        approx::assert_abs_diff_eq!(e, 0.225, epsilon = 1e-15);
        // With eta_prev = 0.3 the safeguard is 0.081 < 0.1: not applied.
        let e = forcing_term(ForcingTerm::EW2_DEFAULT, 1, &opts, 0.1, 1.0, 0.0, 0.3, 0.0);
        approx::assert_abs_diff_eq!(e, 0.009, epsilon = 1e-15);
        // Choice 1: | |G_k| - |lin res| | / |G_{k-1}| = |0.1 - 0.05| / 1 = 0.05;
        // safeguard 0.3^phi = 0.1431 > 0.1 wins.
        let e = forcing_term(
            ForcingTerm::EisenstatWalker1,
            2,
            &opts,
            0.1,
            1.0,
            0.05,
            0.3,
            0.0,
        );
        approx::assert_abs_diff_eq!(e, 0.3f64.powf(GOLDEN), epsilon = 1e-15);
        let e = forcing_term(
            ForcingTerm::EisenstatWalker1,
            2,
            &opts,
            0.1,
            1.0,
            0.05,
            0.2,
            0.0,
        );
        approx::assert_abs_diff_eq!(e, 0.05, epsilon = 1e-15);
        // eta_max caps: |G| grew.
        let e = forcing_term(ForcingTerm::EW2_DEFAULT, 1, &opts, 3.0, 1.0, 0.0, 0.2, 0.0);
        assert_eq!(e, 0.9);
        // Kelley's oversolving guard: 0.5 tol / |G_k| = 0.5 * 1e-3 / 1e-3 = 0.5.
        let e = forcing_term(
            ForcingTerm::EW2_DEFAULT,
            1,
            &opts,
            1e-3,
            1.0,
            0.0,
            0.2,
            1e-3,
        );
        assert_eq!(e, 0.5);
        // Constant is constant.
        assert_eq!(
            forcing_term(ForcingTerm::TUTORIAL, 5, &opts, 1e-3, 1.0, 0.0, 0.2, 1e-3),
            0.02
        );
    }
}
