//! [`SolverOptions`]: the one options struct of every method, with the
//! tolerances ([`Tolerance`] per component), the step-size policy
//! ([`StepSizePolicy`]), the step cap, the retries, and Newton's and the
//! linear solver's options. The settings that belong to one method travel
//! with the method (diffsol's shape): the variable-order BDF's are
//! [`Method::VariableBdf`](crate::Method::VariableBdf)'s [`BdfConfig`](crate::BdfConfig).

use crate::NonExhaustive;
use hookean_nonlinear::{NewtonOptions, PcgOptions};

use crate::control::{IterationControllerOptions, PiControllerOptions};
use crate::error::OdeError;

/// The default growth bound of a run of an implicit method (relative to
/// `max(1, max |y0|)`): far above any decaying or oscillating solution,
/// far below a blown-up run (a fixed-step BDF4 outside its stability region
/// reached `4e70`).
pub const DEFAULT_MAX_GROWTH: f64 = 1e30;

/// The default step size `h` (s): the reference drape's (docs/ARCHITECTURE.md),
/// the one value of [`SolverOptions::default`], of the facade's drape
/// settings and of a scene without `integrator.h`.
pub const DEFAULT_STEP: f64 = 1e-2;

/// The absolute tolerance: one value for every component or one per component.
#[derive(Debug, Clone, PartialEq)]
pub enum Tolerance {
    /// The same `atol` for every component.
    Scalar(f64),
    /// `atol_i` per component (length: the state's, `dim` for first-order
    /// problems, `2 dim` for second-order ones, positions first).
    Vector(Vec<f64>),
}

impl From<f64> for Tolerance {
    fn from(v: f64) -> Self {
        Tolerance::Scalar(v)
    }
}

impl From<Vec<f64>> for Tolerance {
    fn from(v: Vec<f64>) -> Self {
        Tolerance::Vector(v)
    }
}

impl Tolerance {
    /// `atol_i` for a state of length `n`.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`] for a vector of another length,
    /// [`OdeError::InvalidParameter`] for a negative or non-finite entry.
    pub fn expand(&self, n: usize) -> Result<Vec<f64>, OdeError> {
        let atol = match self {
            Tolerance::Scalar(a) => vec![*a; n],
            Tolerance::Vector(v) => {
                if v.len() != n {
                    return Err(OdeError::DimensionMismatch {
                        what: "atol",
                        expected: n,
                        found: v.len(),
                    });
                }
                v.clone()
            }
        };
        if let Some(a) = atol.iter().find(|a| !(**a >= 0.0 && a.is_finite())) {
            return Err(OdeError::InvalidParameter {
                name: "atol",
                value: *a,
                reason: "must be finite and non-negative",
            });
        }
        Ok(atol)
    }
}

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

/// How variable-step BDF2 chooses its step sizes: one of the controllers
/// of [`control`](crate::control), within the bounds of [`StepSizePolicy`].
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

/// The step-size policy of every method: the bounds every step size keeps,
/// and the controller of variable-step BDF2. (The variable-order BDF picks
/// order and step from its error estimates, Shampine-Reichelt's rule,
/// within the same bounds.)
#[derive(Debug, Clone, PartialEq)]
pub struct StepSizePolicy {
    /// Smallest admissible step size (variable steps and retries); below it
    /// a run fails with [`OdeError::StepSizeUnderflow`]. Default 0 (a step
    /// too small to advance `t` still fails).
    pub h_min: f64,
    /// Largest step size of the variable-step methods. Default infinite.
    pub h_max: f64,
    /// Step-size control of variable-step BDF2. Default error-based.
    pub control: StepControl,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for StepSizePolicy {
    fn default() -> Self {
        Self {
            h_min: 0.0,
            h_max: f64::INFINITY,
            control: StepControl::default(),
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// Options of an integrator run: the one options struct of every method.
#[derive(Debug, Clone, PartialEq)]
pub struct SolverOptions {
    /// The step size of the fixed-step methods and the initial step size
    /// of variable-step BDF2 (the variable-order BDF estimates its own
    /// unless [`BdfConfig::initial_step`](crate::BdfConfig::initial_step) is set). Default
    /// [`DEFAULT_STEP`]` = 1e-2` (the reference drape).
    pub h: f64,
    /// Relative tolerance of the variable-step methods. Default `1e-6`.
    pub rtol: f64,
    /// Absolute tolerance of the variable-step methods, one value or one
    /// per state component. Default `1e-8`.
    pub atol: Tolerance,
    /// Step-size bounds and BDF2's controller.
    pub step: StepSizePolicy,
    /// How often a step whose Newton iteration failed is retried with a
    /// smaller step before the run fails: `h/4` for variable-step BDF2,
    /// `2^r` substeps for the fixed-step methods (implicit Euler substeps
    /// for BDF(k)), `h/2` (after a fresh Jacobian) for the variable-order
    /// BDF. Default 6.
    pub max_retries: usize,
    /// A run of a variable-step method (the variable-order BDF and
    /// variable-step BDF2, [`Method::Bdf2Variable`](crate::Method::Bdf2Variable))
    /// fails with [`OdeError::TooManySteps`] after this many accepted
    /// steps. Default 100 000.
    pub max_steps: usize,
    /// The Newton iteration of the implicit methods (the tutorial's
    /// section 3): `hookean-nonlinear`'s options, with the integrators'
    /// defaults (see [`SolverOptions::default_newton`]). For second-order
    /// problems `M x'' = f` the Newton residual `M (V - psi_v) - gh f` is a
    /// momentum: its absolute tolerance `newton.atol` is read as a velocity
    /// and multiplied by the mean particle mass, so that the same `k/m`
    /// gives the same motion in any mass unit. The variable-order BDF runs
    /// the same Newton as a simplified Newton with CVODE's rate test, whose
    /// iteration limit and linear tolerance are
    /// [`BdfConfig::max_newton_iterations`](crate::BdfConfig::max_newton_iterations)
    /// and [`BdfConfig::linear_rtol`](crate::BdfConfig::linear_rtol) (they
    /// mean something else there: see those fields).
    pub newton: NewtonOptions,
    /// The linear solver of second-order Newton steps: PCG's preconditioner,
    /// multigrid options, iteration limit and curvature policy
    /// (`hookean-nonlinear`'s [`PcgOptions`]).
    pub linear: PcgOptions,
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
    /// Runs each Newton step's PCG of a constrained second-order stage on
    /// the filtered matrix `P A P + (I - P) s (I - P)`
    /// ([`Constraints::filter_matrix`](hookean_sparse::Constraints::filter_matrix)),
    /// from which the preconditioner is then set up: the constrained
    /// particles (contacts, pins) become the Dirichlet boundary they are for
    /// the step, instead of couplings the filtered solve never uses. Same
    /// corrections in exact arithmetic; on the contact scenes MIC(0) needs a
    /// third of the PCG iterations (docs/PERFORMANCE.md, "Contact (issue
    /// 26)"). Only with Jacobians evaluated at every Newton iteration
    /// (exact and inexact Newton): a kept Jacobian would carry the
    /// constraints of the step it was built in. Default `false`.
    pub filter_matrix: bool,
    /// A run of an implicit method fails with [`OdeError::StateGrowth`] once `max_i |y_i|` of the
    /// state exceeds `max_growth * max(1, max_i |y0_i|)` (`y0` the state at
    /// construction or at the last `set_state`; not `set_state_parts`): a blown-up run is an error,
    /// not `Ok` with a huge state. Default [`DEFAULT_MAX_GROWTH`]` = 1e30`;
    /// infinite turns the check off. Explicit methods are not checked: their
    /// growth outside the stability region is the tutorial's demonstration
    /// (RK4 just outside its interval grows by about `1e73` in 4000 steps).
    pub max_growth: f64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            h: DEFAULT_STEP,
            rtol: 1e-6,
            atol: Tolerance::Scalar(1e-8),
            step: StepSizePolicy::default(),
            max_retries: 6,
            max_steps: 100_000,
            newton: Self::default_newton(),
            linear: PcgOptions::default(),
            predictor: Predictor::Previous,
            warm_start: false,
            filter_matrix: false,
            max_growth: DEFAULT_MAX_GROWTH,
            non_exhaustive: NonExhaustive(()),
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

    /// Default options with the tolerances `rtol` and `atol`.
    pub fn with_tolerances(rtol: f64, atol: impl Into<Tolerance>) -> Self {
        Self {
            rtol,
            atol: atol.into(),
            ..Self::default()
        }
    }

    /// The Newton options of the integrators: `hookean-nonlinear`'s
    /// defaults (exact Newton, linear solves to `linear_rtol = 1e-10`)
    /// with at most 10 iterations per step attempt and `rtol = 1e-10` (a
    /// failed attempt is retried with a smaller step).
    pub fn default_newton() -> NewtonOptions {
        NewtonOptions {
            max_iter: 10,
            rtol: 1e-10,
            ..NewtonOptions::default()
        }
    }

    /// Checks every field's range; `n` is the state's length (for a vector `atol`).
    pub(crate) fn check(&self, n: usize) -> Result<Vec<f64>, OdeError> {
        let positive = [
            ("h", self.h),
            ("rtol", self.rtol),
            ("h_max", self.step.h_max),
        ];
        for (name, value) in positive {
            if value.is_nan() || value <= 0.0 {
                return Err(OdeError::InvalidParameter {
                    name,
                    value,
                    reason: "must be positive",
                });
            }
        }
        let h_min = self.step.h_min;
        if !(h_min >= 0.0 && h_min.is_finite()) {
            return Err(OdeError::InvalidParameter {
                name: "h_min",
                value: h_min,
                reason: "must be finite and non-negative",
            });
        }
        if !(self.step.h_max > h_min) {
            return Err(OdeError::InvalidParameter {
                name: "h_max",
                value: self.step.h_max,
                reason: "must exceed h_min",
            });
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
        self.atol.expand(n)
    }
}
