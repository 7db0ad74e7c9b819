//! The crate's error type.

use hookean_nonlinear::NonlinearError;
use hookean_sparse::{Short, SparseError};

/// Everything that can go wrong in `hookean-ode`. Errors raised during a
/// run carry the time `t` reached when they happened, in the same shape
/// for every method; the counters up to the failure are the integrator's
/// [`stats`](crate::Integrator::stats).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OdeError {
    /// A vector or matrix has the wrong size.
    #[error("dimension mismatch in {what}: expected {expected}, found {found}")]
    DimensionMismatch {
        /// What was checked.
        what: &'static str,
        /// The expected size.
        expected: usize,
        /// The size found.
        found: usize,
    },
    /// A parameter is out of its admissible range.
    #[error("invalid parameter {name} = {value:?}: {reason}")]
    InvalidParameter {
        /// Name of the parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// NaN or infinity in the state, the right-hand side or the input.
    #[error("non-finite value in {what} at t = {t}", t = Short(*.t))]
    NonFinite {
        /// Where the value was found.
        what: &'static str,
        /// The time reached.
        t: f64,
    },
    /// The step size became smaller than `h_min` ([`StepSizePolicy`](crate::StepSizePolicy))
    /// or too small to advance `t`.
    #[error("step size underflow at t = {t}: h = {h}", t = Short(*.t), h = Short(*.h))]
    StepSizeUnderflow {
        /// The time reached.
        t: f64,
        /// The step size that underflowed.
        h: f64,
    },
    /// Newton's method failed on the step from `t` even after `retries`
    /// retries with smaller steps.
    #[error(
        "Newton iteration failed on the step from t = {t} (h = {h}) after {retries} retries: \
         {iterations} iterations, last update norm {update_norm}", t = Short(*.t), h = Short(*.h), update_norm = Short(*.update_norm))]
    NewtonFailed {
        /// The time reached.
        t: f64,
        /// The last step size tried.
        h: f64,
        /// Number of retries made.
        retries: usize,
        /// Newton iterations of the last attempt.
        iterations: usize,
        /// Norm of the last Newton update (NaN if non-finite).
        update_norm: f64,
    },
    /// The linear solver inside Newton failed on the step from `t` even
    /// after the allowed retries.
    #[error("linear solver failed on the step from t = {t} after {retries} retries: {source}", t = Short(*.t))]
    LinearSolver {
        /// The time reached.
        t: f64,
        /// Number of retries made.
        retries: usize,
        /// The linear solver's error as Newton reported it (not converged
        /// to the forcing term, or a `hookean-sparse` error).
        #[source]
        source: NonlinearError,
    },
    /// The dense Jacobian of a first-order Newton step is singular.
    #[error("singular Newton matrix at t = {t} (pivot {pivot} is zero)", t = Short(*.t))]
    SingularMatrix {
        /// The time reached.
        t: f64,
        /// The zero pivot.
        pivot: usize,
    },
    /// The method does not apply to this kind of problem (for example
    /// Stoermer-Verlet on a first-order problem).
    #[error("method {method} does not apply to {problem} problems")]
    UnsupportedMethod {
        /// The method's name.
        method: String,
        /// The problem kind.
        problem: &'static str,
    },
    /// The integrator (or a part of it) cannot save or restore its state
    /// for a checkpoint ([`crate::StateRecord`]).
    #[error("checkpoints do not cover {what}")]
    NoCheckpoint {
        /// What is not covered (a method, a solver option).
        what: String,
    },
    /// A checkpoint's record does not fit this integrator.
    #[error("the checkpoint does not fit this run: {reason}")]
    Checkpoint {
        /// What does not fit.
        reason: String,
    },
    /// A Butcher tableau is malformed (sizes, implicit where explicit is needed).
    #[error("invalid Butcher tableau: {reason}")]
    InvalidTableau {
        /// What is wrong.
        reason: &'static str,
    },
    /// A method name that [`Method`](crate::Method)'s `FromStr` does not know.
    #[error("unknown method {name:?}")]
    UnknownMethod {
        /// The name given.
        name: String,
    },
    /// A step-size controller option or argument is out of range.
    #[error("invalid step-size controller parameter {name}: {message}")]
    InvalidController {
        /// The parameter.
        name: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The maximum number of steps was taken before the end time was reached.
    #[error("{max_steps} steps taken without reaching the end time (at t = {t})", t = Short(*.t))]
    TooManySteps {
        /// The time reached.
        t: f64,
        /// The limit.
        max_steps: usize,
    },
    /// The state grew past the admissible bound (the run has blown up):
    /// `max_i |y_i| > bound`.
    #[error("the state grew past the bound at t = {t}: max |y_i| = {norm} > {bound}", t = Short(*.t), norm = Short(*.norm), bound = Short(*.bound))]
    StateGrowth {
        /// The time reached.
        t: f64,
        /// `max_i |y_i|` of the state.
        norm: f64,
        /// The bound it passed.
        bound: f64,
    },
    /// The local error test failed too often on one step.
    #[error(
        "the local error test failed {failures} times on the step from t = {t} (last h = {h})", t = Short(*.t), h = Short(*.h))]
    ErrorTestFailed {
        /// The time reached.
        t: f64,
        /// The last step size tried.
        h: f64,
        /// Failed attempts on this step.
        failures: usize,
    },
    /// The correction a wrapper makes after each step of the integrator it
    /// wraps failed (for example the velocity filter of `hookean-filter`
    /// on a blown-up state).
    #[error("the correction after the step to t = {} failed: {source}", Short(*.t))]
    AfterStep {
        /// The time reached.
        t: f64,
        /// The wrapper's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// An error of `hookean-sparse` outside a Newton solve (set-up, constraints).
    #[error(transparent)]
    Sparse(#[from] SparseError),
    /// An error of `hookean-nonlinear` while setting up Newton (bad options).
    #[error(transparent)]
    Nonlinear(#[from] NonlinearError),
    /// An error of `hookean-nonlinear` during the step from `t` that a
    /// smaller step would not cure (for example an error of the problem).
    #[error("Newton solver error on the step from t = {t}: {source}", t = Short(*.t))]
    NewtonSolver {
        /// The time reached.
        t: f64,
        /// The solver's error.
        #[source]
        source: NonlinearError,
    },
}
