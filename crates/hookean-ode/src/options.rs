//! Options, statistics and step reports of the integrators.

use hookean_nonlinear::NewtonOptions;

use crate::control::{IterationControllerOptions, PiControllerOptions};

use crate::error::OdeError;

/// The default growth bound of a run of an implicit method (relative to
/// `max(1, max |y0|)`): far above any decaying or oscillating solution,
/// far below a blown-up run (a fixed-step BDF4 outside its stability region
/// reached `4e70`).
pub const DEFAULT_MAX_GROWTH: f64 = 1e30;

/// The starting guess `Y_0` of the Newton iteration of an implicit Euler step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Predictor {
    /// The current state: `Y_0 = y_n` (for second-order problems: the new
    /// velocity starts at `v_n`, i.e. `dv = 0`).
    #[default]
    Previous,
    /// Linear extrapolation of the last two accepted states of the same step
    /// size, `Y_0 = 2 y_n - y_{n-1}` (the previous step's velocity change as
    /// the guess of this one's); falls back to `Previous` after a restart.
    /// With a tight (or absolute) Newton tolerance this saves Newton and PCG
    /// iterations when the motion is smooth. With a loose relative tolerance
    /// beware: a Newton iteration stopped early then errs in the direction
    /// of the extrapolation (anti-damping, where `Previous` errs toward
    /// `y_n`, like damping), which pumped energy into the swinging drape
    /// (docs/PERFORMANCE.md).
    Extrapolate,
}

/// How the variable-step method chooses its step sizes: one of
/// the controllers of [`control`](crate::control). Their `h_min`/`h_max` are replaced by
/// [`SolverOptions::h_min`] (at least `1e-300`) and [`SolverOptions::h_max`].
#[derive(Debug, Clone, PartialEq)]
pub enum StepControl {
    /// The error-based (PI) controller: accept when the weighted RMS norm
    /// of the local error estimate is `<= 1`, next step from the error
    /// ([`PiController`](crate::PiController)).
    ErrorBased(PiControllerOptions),
    /// The Newton-iteration controller of the tutorial's section 3.4: the
    /// number of Newton iterations decides whether `h` grows or shrinks;
    /// every converged step is accepted, no error estimate is used
    /// ([`IterationController`](crate::IterationController)).
    NewtonIterations(IterationControllerOptions),
}

impl StepControl {
    /// The PI controller for BDF2 (`order = 2`) with its default gains and
    /// the step ratio capped at 2 (`max_factor`), below BDF2's
    /// zero-stability bound `1 + sqrt 2`.
    pub fn error_based() -> Self {
        StepControl::ErrorBased(PiControllerOptions {
            order: 2,
            max_factor: 2.0,
            ..PiControllerOptions::default()
        })
    }

    /// The Newton-iteration controller with its default thresholds.
    pub fn newton_iterations() -> Self {
        StepControl::NewtonIterations(IterationControllerOptions::default())
    }
}

impl Default for StepControl {
    fn default() -> Self {
        Self::error_based()
    }
}

/// Options of an integrator run.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverOptions {
    /// The step size of the fixed-step methods and the initial step size
    /// of the variable-step method. Default `1e-2` (the reference drape, docs/ARCHITECTURE.md).
    pub h: f64,
    /// Relative tolerance of the variable-step method. Default `1e-6`.
    pub rtol: f64,
    /// Absolute tolerance of the variable-step method. Default `1e-8`.
    pub atol: f64,
    /// Smallest admissible step size (variable step and retries). Default `1e-14`.
    pub h_min: f64,
    /// Largest step size of the variable-step method. Default infinite.
    pub h_max: f64,
    /// Step-size control of the variable-step method. Default error-based.
    pub control: StepControl,
    /// How often a step whose Newton iteration failed is retried with a
    /// smaller step (`h/4` for the variable-step method, `2^r` substeps
    /// for the fixed-step methods; implicit Euler substeps for BDF(k)) before
    /// the run fails. Default 6.
    pub max_retries: usize,
    /// The Newton iteration of the implicit methods (the tutorial's
    /// section 3) and its linear solver: `hookean-nonlinear`'s options, with
    /// the integrators' defaults (see [`SolverOptions::default_newton`]).
    /// For second-order problems `M x'' = f` the Newton residual
    /// `M (V - psi_v) - gh f` is a momentum: its absolute tolerance
    /// `newton.atol` is read as a velocity and multiplied by the mean
    /// particle mass, so that the same `k/m` gives the same motion in any
    /// mass unit.
    pub newton: NewtonOptions,
    /// Starting guess of implicit Euler's Newton iteration. Default
    /// [`Predictor::Previous`].
    pub predictor: Predictor,
    /// Starts the first linear solve of each step (second-order problems)
    /// from the previous step's velocity change instead of from zero
    /// ([`PcgSolver::arm_guess`](hookean_nonlinear::PcgSolver::arm_guess)).
    /// The Newton start and its stop `|G| <= rtol |G(Y_0)|` stay as they
    /// are; only PCG begins closer to the answer. Ignored after a change of
    /// step size. Default `false`.
    pub warm_start: bool,
    /// A run of an implicit method fails with [`OdeError::StateGrowth`] once `max_i |y_i|` of the
    /// state exceeds `max_growth * max(1, max_i |y0_i|)` (`y0` the state at
    /// construction or at the last `set_state`; not `set_state_parts`): a blown-up run is an error,
    /// not `Ok` with a huge state. Default [`DEFAULT_MAX_GROWTH`]` = 1e30`;
    /// infinite turns the check off. Explicit methods are not checked: their
    /// growth outside the stability region is the tutorial's demonstration
    /// (RK4 just outside its interval grows by about `1e73` in 4000 steps).
    pub max_growth: f64,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            h: 1e-2,
            rtol: 1e-6,
            atol: 1e-8,
            h_min: 1e-14,
            h_max: f64::INFINITY,
            control: StepControl::default(),
            max_retries: 6,
            newton: Self::default_newton(),
            predictor: Predictor::Previous,
            warm_start: false,
            max_growth: DEFAULT_MAX_GROWTH,
        }
    }
}

impl SolverOptions {
    /// Default options with step size `h`.
    pub fn with_h(h: f64) -> Self {
        Self {
            h,
            ..Self::default()
        }
    }

    /// The Newton options of the integrators: `hookean-nonlinear`'s
    /// defaults (exact Newton, block-Jacobi PCG to `linear_rtol = 1e-10`)
    /// with at most 10 iterations per step attempt and `rtol = 1e-10` (a
    /// failed attempt is retried with a smaller step).
    pub fn default_newton() -> NewtonOptions {
        NewtonOptions {
            max_iter: 10,
            rtol: 1e-10,
            ..NewtonOptions::default()
        }
    }

    pub(crate) fn check(&self) -> Result<(), OdeError> {
        let positive = [("h", self.h), ("rtol", self.rtol), ("h_max", self.h_max)];
        for (name, value) in positive {
            if value.is_nan() || value <= 0.0 {
                return Err(OdeError::InvalidParameter {
                    name,
                    value,
                    reason: "must be positive",
                });
            }
        }
        for (name, value) in [("atol", self.atol), ("h_min", self.h_min)] {
            if !(value >= 0.0 && value.is_finite()) {
                return Err(OdeError::InvalidParameter {
                    name,
                    value,
                    reason: "must be finite and non-negative",
                });
            }
        }
        if !self.h.is_finite() {
            return Err(OdeError::InvalidParameter {
                name: "h",
                value: self.h,
                reason: "must be finite",
            });
        }
        if !(self.max_growth > 1.0) {
            return Err(OdeError::InvalidParameter {
                name: "max_growth",
                value: self.max_growth,
                reason: "must exceed 1",
            });
        }
        self.newton.validate()?;
        Ok(())
    }
}

/// Counters of a run (cumulative since the integrator was built).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Accepted steps.
    pub steps: usize,
    /// Rejected step attempts (error test or Newton failure).
    pub rejected_steps: usize,
    /// Evaluations of the right-hand side `f` (or of the force).
    pub f_evals: usize,
    /// Evaluations of the Jacobian (analytic, or by finite differences).
    pub jacobian_evals: usize,
    /// Newton iterations.
    pub newton_iterations: usize,
    /// Linear-solver iterations (PCG; 0 for direct solves).
    pub linear_iterations: usize,
    /// Linear-solver set-ups (LU factorisations, preconditioner set-ups).
    pub linear_setups: usize,
    /// Wall time of the Newton solves' phases (assembly, linear-solver
    /// set-up, linear solves).
    pub phases: crate::phases::PhaseTimes,
}

/// What one call of `step()` did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The time reached.
    pub t: f64,
    /// The step size taken (the sum of the substeps for a retried fixed step).
    pub h: f64,
    /// Rejected attempts before this step was accepted.
    pub rejected: usize,
    /// Newton iterations of this step (all attempts).
    pub newton_iterations: usize,
    /// Linear iterations of this step (all attempts).
    pub linear_iterations: usize,
    /// The weighted RMS norm of the local error estimate (variable step only).
    pub error_estimate: Option<f64>,
    /// The step size proposed for the next step.
    pub h_next: f64,
}

/// What `integrate()` did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntegrateInfo {
    /// The time reached.
    pub t: f64,
    /// True when the callback stopped the run before `t_end`.
    pub stopped_by_callback: bool,
    /// The integrator's counters after the run.
    pub stats: Stats,
}
