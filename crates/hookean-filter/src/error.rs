//! The error type of `hookean-filter`.

use hookean_massspring::MassSpringError;
use hookean_ode::OdeError;
use hookean_sparse::{Short, SparseError};
use thiserror::Error;

/// Everything that can go wrong in `hookean-filter`.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum FilterError {
    /// The filter parameter lambda must be a positive finite number.
    #[error("filter parameter lambda must be positive and finite, got {lambda:?}")]
    InvalidLambda {
        /// The value given.
        lambda: f64,
    },
    /// The neighbourhood radius (rings of the spring graph) must be at least 1.
    #[error("neighbourhood radius must be at least 1 ring, got {rings:?}")]
    InvalidRadius {
        /// The value given.
        rings: usize,
    },
    /// A vector has the wrong length.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was checked.
        what: &'static str,
        /// Required length.
        expected: usize,
        /// Given length.
        found: usize,
    },
    /// A spring names a particle that does not exist, or has a bad rest length.
    #[error("invalid spring {index}: {message}")]
    InvalidSpring {
        /// Index of the spring in the list given.
        index: usize,
        /// What is wrong.
        message: String,
    },
    /// A NaN or infinity in the input.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// Where.
        what: &'static str,
    },
    /// A grid analysis was asked of data that is not an `nx x ny` grid.
    #[error("grid of {nx} x {ny} particles does not match {particles} particles")]
    GridMismatch {
        /// Grid columns.
        nx: usize,
        /// Grid rows.
        ny: usize,
        /// Particles given.
        particles: usize,
    },
    /// A parameter out of its range (step size, run length, bisection bracket, ...).
    #[error("invalid parameter {name} = {value:?}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The admissible range.
        reason: &'static str,
    },
    /// [`measure_stable_step`](crate::measure_stable_step) found no
    /// bracket of a stable and an unstable step within its
    /// [`max_runs`](crate::BisectionOptions::max_runs) trial runs: every
    /// step it tried, from the guess `from` to `to`, was stable (or every
    /// one unstable), so the model has no stability limit in that range.
    #[error(
        "no stability limit found in {runs} trial runs: every step from h = {from} s to {to} s was {}",
        if *.stable { "stable" } else { "unstable" },
        from = Short(*.from),
        to = Short(*.to)
    )]
    NoStabilityBracket {
        /// Trial runs made.
        runs: usize,
        /// The first trial step (the guess).
        from: f64,
        /// The last trial step.
        to: f64,
        /// Whether every trial was stable (else every one blew up).
        stable: bool,
    },
    /// Velocity filtering wraps explicit integrators only (implicit ones filter by themselves).
    #[error("method {method} is implicit: velocity filtering wraps explicit integrators")]
    ImplicitMethod {
        /// The method's name.
        method: String,
    },
    /// The stable step of eq. 11 is not known for this method.
    #[error(
        "the stable step of eq. 11 is known for explicit-euler, fb-euler, verlet and rk4, not {method}"
    )]
    NoStableStep {
        /// The method's name.
        method: String,
    },
    /// A coupling name that is not one of `"increment"`, `"velocity"`, `"positions"`.
    #[error("unknown filter coupling '{name}' (\"increment\", \"velocity\" or \"positions\")")]
    UnknownCoupling {
        /// The name given.
        name: String,
    },
    /// The power method failed.
    #[error(transparent)]
    Sparse(#[from] SparseError),
    /// The wrapped integrator failed.
    #[error(transparent)]
    Ode(#[from] OdeError),
    /// The mass-spring model rejected a state or parameter.
    #[error(transparent)]
    MassSpring(#[from] MassSpringError),
}
