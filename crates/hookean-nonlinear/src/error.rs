//! The one error type of `hookean-nonlinear`.

use hookean_sparse::{Short, SparseError};
use thiserror::Error;

use crate::stats::NewtonStats;

/// Why an iteration was declared divergent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DivergenceReason {
    /// The contraction rate `theta_k = |s_k| / |s_{k-1}|` was `>= 1` in two
    /// consecutive iterations (the last value is given).
    Contraction {
        /// The last contraction rate.
        theta: f64,
    },
    /// `|G(Y_k)| / |G(Y_0)|` exceeded
    /// [`NewtonOptions::max_residual_growth`](crate::NewtonOptions::max_residual_growth).
    ResidualGrowth {
        /// The ratio reached.
        ratio: f64,
    },
}

impl std::fmt::Display for DivergenceReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::Contraction { theta } => {
                write!(f, "contraction rate {} >= 1 twice in a row", Short(theta))
            }
            Self::ResidualGrowth { ratio } => {
                write!(f, "the residual grew by a factor of {}", Short(ratio))
            }
        }
    }
}

/// Everything that can go wrong in `hookean-nonlinear`.
///
/// The failures of the Newton iteration itself ([`Diverged`](Self::Diverged),
/// [`MaxIterations`](Self::MaxIterations), [`NonFinite`](Self::NonFinite),
/// [`LinearNotConverged`](Self::LinearNotConverged)) carry the statistics of
/// the work done so far, so that an integrator can count it, reject the step
/// and retry with a smaller `h` ([`is_step_failure`](Self::is_step_failure)).
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum NonlinearError {
    /// The Newton iteration diverged.
    #[error("Newton iteration diverged after {} iterations: {reason}", stats.iterations)]
    Diverged {
        /// What was seen.
        reason: DivergenceReason,
        /// Statistics up to the failure.
        stats: Box<NewtonStats>,
    },
    /// The iteration limit was reached without convergence.
    #[error("Newton iteration did not converge in {} iterations (|G| = {})", stats.iterations, Short(stats.final_residual()))]
    MaxIterations {
        /// Statistics up to the failure.
        stats: Box<NewtonStats>,
    },
    /// A residual or a correction contained NaN or infinity.
    #[error("non-finite residual or correction after {} Newton iterations", stats.iterations)]
    NonFinite {
        /// Statistics up to the failure.
        stats: Box<NewtonStats>,
    },
    /// The linear solver missed the tolerance it was asked for.
    #[error(
        "linear solver did not reach relative residual {tolerance} in {iterations} iterations (reached {relative_residual})",
        tolerance = Short(*.tolerance),
        relative_residual = Short(*.relative_residual)
    )]
    LinearNotConverged {
        /// Linear iterations spent on the failing solve.
        iterations: usize,
        /// The requested relative residual (the forcing term).
        tolerance: f64,
        /// The relative residual reached.
        relative_residual: f64,
        /// Newton statistics up to the failure.
        stats: Box<NewtonStats>,
    },
    /// An error of the sparse linear algebra (PCG breakdown, sizes, ...).
    #[error(transparent)]
    Linear(#[from] SparseError),
    /// An LU factorisation met a zero (or negligible) pivot.
    #[error("the Jacobian is singular (LU pivot {pivot} is {value})", value = Short(*.value))]
    SingularJacobian {
        /// Index of the offending pivot (for sparse LU, the elimination step).
        pivot: usize,
        /// Its value (0 when the structure itself is singular).
        value: f64,
    },
    /// A vector or matrix has the wrong size.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was checked.
        what: &'static str,
        /// The size required.
        expected: usize,
        /// The size given.
        found: usize,
    },
    /// An option or argument is out of its admissible range.
    #[error("invalid parameter {name}: {message}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The nonlinear system itself reported a failure.
    #[error("nonlinear system: {message}")]
    System {
        /// The system's message.
        message: String,
    },
    /// The solver was used before it had what it needs (e.g. `solve` before `setup`).
    #[error("{0}")]
    NotReady(&'static str),
}

impl NonlinearError {
    /// Whether this is a failure of the iteration on the given step (divergence,
    /// iteration limit, NaN, linear solver short of its tolerance, singular
    /// or indefinite Jacobian) for which retrying with a smaller time step is
    /// the natural reaction, as opposed to a programming error (sizes,
    /// parameters).
    pub fn is_step_failure(&self) -> bool {
        matches!(
            self,
            Self::Diverged { .. }
                | Self::MaxIterations { .. }
                | Self::NonFinite { .. }
                | Self::LinearNotConverged { .. }
                | Self::SingularJacobian { .. }
                | Self::Linear(SparseError::NotPositiveDefinite { .. })
                | Self::Linear(SparseError::PreconditionerNotPositiveDefinite { .. })
                | Self::Linear(SparseError::NonFinite { .. })
                | Self::Linear(SparseError::NotConverged { .. })
        )
    }

    /// The Newton statistics carried by an iteration failure, if any.
    pub fn stats(&self) -> Option<&NewtonStats> {
        match self {
            Self::Diverged { stats, .. }
            | Self::MaxIterations { stats }
            | Self::NonFinite { stats }
            | Self::LinearNotConverged { stats, .. } => Some(stats),
            _ => None,
        }
    }
}

/// Checks that `v` has length `expected`.
pub(crate) fn check_len(
    what: &'static str,
    v: &[f64],
    expected: usize,
) -> Result<(), NonlinearError> {
    if v.len() == expected {
        Ok(())
    } else {
        Err(NonlinearError::DimensionMismatch {
            what,
            expected,
            found: v.len(),
        })
    }
}

/// Error for an out-of-range parameter.
pub(crate) fn invalid(name: &'static str, message: impl Into<String>) -> NonlinearError {
    NonlinearError::InvalidParameter {
        name,
        message: message.into(),
    }
}
