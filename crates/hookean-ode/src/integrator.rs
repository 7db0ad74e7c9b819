//! The public integrators: [`FirstOrderIntegrator`] for `y' = f(t, y)` and
//! [`SecondOrderIntegrator`] for `M x'' = f(t, x, v)`. Both offer the
//! step-wise API ([`step`](FirstOrderIntegrator::step)) and the driver
//! ([`integrate`](FirstOrderIntegrator::integrate),
//! [`integrate_with`](FirstOrderIntegrator::integrate_with)).

use std::ops::ControlFlow;

use hookean_sparse::Constraints;

use crate::core::Core;
use crate::error::OdeError;
use crate::method::Method;
use crate::options::{IntegrateInfo, SolverOptions, Stats, StepReport};
use crate::system::{FirstSys, SecondSys};
use hookean_problem::{FirstOrderProblem, SecondOrderProblem};

/// Integrates a first-order problem `y' = f(t, y)` (eq. 7) with any
/// [`Method`] except the second-order-only ones (FB Euler, Verlet).
/// Implicit methods run Newton with the matrix `I - c h df/dy`: dense LU
/// (`df/dy` from [`FirstOrderProblem::jacobian`] or forward differences), or
/// sparse LU when the problem has a
/// [`sparse_jacobian_pattern`](FirstOrderProblem::sparse_jacobian_pattern).
pub struct FirstOrderIntegrator<P: FirstOrderProblem> {
    core: Core<FirstSys<P>>,
}

impl<P: FirstOrderProblem> FirstOrderIntegrator<P> {
    /// A new integrator at `(t0, y0)`.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`] if `y0.len() != problem.dim()`,
    /// [`OdeError::NonFinite`] for NaN in `y0`, [`OdeError::InvalidParameter`]
    /// for bad options, [`OdeError::UnsupportedMethod`] for FB Euler and Verlet.
    pub fn new(
        problem: P,
        method: Method,
        t0: f64,
        y0: &[f64],
        options: SolverOptions,
    ) -> Result<Self, OdeError> {
        let sys = FirstSys::new(problem, &options)?;
        Ok(Self {
            core: Core::new(sys, method, t0, y0.to_vec(), options)?,
        })
    }

    /// Advances one (accepted) step and reports what happened. Between
    /// steps the caller may change the problem ([`problem_mut`](Self::problem_mut))
    /// or the state ([`set_state`](Self::set_state)).
    ///
    /// # Errors
    /// [`OdeError::NonFinite`] for NaN in the state, [`OdeError::StepSizeUnderflow`],
    /// [`OdeError::NewtonFailed`] / [`OdeError::SingularMatrix`] after the
    /// allowed retries; each carries the time reached.
    pub fn step(&mut self) -> Result<StepReport, OdeError> {
        self.core.step(None)
    }

    /// One step that does not pass `t_end`, or `None` once `t_end` is
    /// reached: the landing rule of every driver (a nominal step that ends
    /// within `max(1e-9 h, 8 eps |t_end|)` of `t_end` is taken and ends
    /// exactly on it; a longer one is shortened to end on it).
    ///
    /// # Errors
    /// As [`step`](Self::step); [`OdeError::InvalidParameter`] for a
    /// non-finite `t_end` or one before the current time.
    pub fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, OdeError> {
        self.core.step_to(t_end)
    }

    /// Integrates to `t_end` (the last step is shortened to land on it).
    ///
    /// # Errors
    /// As [`step`](Self::step), and [`OdeError::InvalidParameter`] for a
    /// `t_end` before the current time.
    pub fn integrate(&mut self, t_end: f64) -> Result<IntegrateInfo, OdeError> {
        self.core.integrate(t_end, |_, _| ControlFlow::Continue(()))
    }

    /// Integrates to `t_end`, calling `callback(report, y)` after every
    /// step; `ControlFlow::Break(())` stops the run.
    ///
    /// # Errors
    /// As [`integrate`](Self::integrate).
    pub fn integrate_with<F>(&mut self, t_end: f64, callback: F) -> Result<IntegrateInfo, OdeError>
    where
        F: FnMut(&StepReport, &[f64]) -> ControlFlow<()>,
    {
        self.core.integrate(t_end, callback)
    }

    /// The current time.
    pub fn t(&self) -> f64 {
        self.core.t
    }

    /// The current state `y`.
    pub fn y(&self) -> &[f64] {
        &self.core.s
    }

    /// Replaces time and state; multistep history restarts.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`], [`OdeError::InvalidParameter`].
    pub fn set_state(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        self.core.set_state(t, y)
    }

    /// The counters of the run so far.
    pub fn stats(&self) -> Stats {
        self.core.stats
    }

    /// The method.
    pub fn method(&self) -> &Method {
        self.core.method()
    }

    /// The options.
    pub fn options(&self) -> &SolverOptions {
        self.core.options()
    }

    /// The step size the next step will try.
    pub fn h_next(&self) -> f64 {
        self.core.h_next()
    }

    /// The problem.
    pub fn problem(&self) -> &P {
        &self.core.sys.problem
    }

    /// The problem, mutably (cached right-hand-side values are dropped).
    pub fn problem_mut(&mut self) -> &mut P {
        self.core.problem_changed();
        &mut self.core.sys.problem
    }
}

/// Integrates a second-order problem `M x'' = f(t, x, v)` (setting (5)/(6))
/// with any [`Method`]. Explicit Runge-Kutta methods run on the first-order
/// form (6); FB Euler and Verlet are the symplectic schemes; the implicit
/// methods solve the reduced velocity form of docs/ARCHITECTURE.md (unknown `V`, size
/// `dim`, SPD matrix `M - c h df/dv - (c h)^2 df/dx`, PCG, filtered by the
/// constraints that [`SecondOrderProblem::begin_step`] sets).
///
/// Constraints prescribe the velocity solved for: the new velocity for
/// implicit Euler and BDF, the stage velocity `(v_n + v_{n+1})/2` for the
/// implicit midpoint rule; explicit and symplectic methods remove the
/// constrained components of the acceleration and impose the prescribed
/// velocities on the velocities they compute.
///
/// ```
/// use hookean_ode::{Method, SecondOrderIntegrator, SolverOptions};
/// use hookean_ode::tutorial::LinearOscillator;
///
/// // The tutorial's example 3: a particle on a damped spring under gravity.
/// let ex3 = LinearOscillator::example3();
/// let mut ode = SecondOrderIntegrator::new(
///     ex3.particle(), Method::Bdf(2), 0.0, &ex3.x0(), &ex3.v0_vec(), SolverOptions::with_h(1e-3),
/// )?;
/// ode.integrate(ex3.t_end)?;
/// let [z, v] = ex3.exact(ex3.t_end);
/// assert!((ode.x()[2] - z).abs() < 1e-5 && (ode.v()[2] - v).abs() < 1e-4);
/// assert!(ode.stats().linear_iterations > 0); // PCG on the reduced form
/// # Ok::<(), hookean_ode::OdeError>(())
/// ```
pub struct SecondOrderIntegrator<P: SecondOrderProblem> {
    core: Core<SecondSys<P>>,
}

impl<P: SecondOrderProblem> SecondOrderIntegrator<P> {
    /// A new integrator at `(t0, x0, v0)`.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`] if `x0`, `v0`, the mass or the
    /// Jacobian pattern do not match `problem.dim()` (a multiple of 3),
    /// [`OdeError::NonFinite`], [`OdeError::InvalidParameter`] (also for a
    /// non-positive mass), [`OdeError::Sparse`] for a bad preconditioner.
    pub fn new(
        problem: P,
        method: Method,
        t0: f64,
        x0: &[f64],
        v0: &[f64],
        options: SolverOptions,
    ) -> Result<Self, OdeError> {
        let n = problem.dim();
        if !n.is_multiple_of(3) {
            return Err(OdeError::DimensionMismatch {
                what: "problem dimension (3 x particles)",
                expected: 3 * n.div_ceil(3),
                found: n,
            });
        }
        for (what, len) in [
            ("x0", x0.len()),
            ("v0", v0.len()),
            ("mass", problem.mass().len()),
        ] {
            if len != n {
                return Err(OdeError::DimensionMismatch {
                    what,
                    expected: n,
                    found: len,
                });
            }
        }
        if let Some(&m) = problem
            .mass()
            .iter()
            .find(|m| !(**m > 0.0 && m.is_finite()))
        {
            return Err(OdeError::InvalidParameter {
                name: "mass",
                value: m,
                reason: "lumped masses must be positive and finite",
            });
        }
        if method == Method::Imex {
            let pattern = problem.jacobian_pattern();
            let (mut k, mut d) = (
                hookean_sparse::IsoBlockMatrix::new(pattern.clone()),
                hookean_sparse::IsoBlockMatrix::new(pattern),
            );
            if !problem.linearized_jacobians_iso(&mut k, &mut d) {
                return Err(OdeError::UnsupportedMethod {
                    method: method.to_string(),
                    problem: "second-order without a linear part (SecondOrderProblem::linearized_jacobians_iso, eq. 50)",
                });
            }
        }
        let sys = SecondSys::new(problem, &options)?;
        let mut s0 = x0.to_vec();
        s0.extend_from_slice(v0);
        Ok(Self {
            core: Core::new(sys, method, t0, s0, options)?,
        })
    }

    /// Advances one (accepted) step; see [`FirstOrderIntegrator::step`].
    ///
    /// # Errors
    /// As [`FirstOrderIntegrator::step`], plus [`OdeError::LinearSolver`]
    /// when PCG fails after the allowed retries.
    pub fn step(&mut self) -> Result<StepReport, OdeError> {
        self.core.step(None)
    }

    /// One step that does not pass `t_end`, or `None` once `t_end` is
    /// reached; see [`FirstOrderIntegrator::step_to`].
    ///
    /// # Errors
    /// As [`FirstOrderIntegrator::step_to`].
    pub fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, OdeError> {
        self.core.step_to(t_end)
    }

    /// Integrates to `t_end`.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn integrate(&mut self, t_end: f64) -> Result<IntegrateInfo, OdeError> {
        self.core.integrate(t_end, |_, _| ControlFlow::Continue(()))
    }

    /// Integrates to `t_end`, calling `callback(report, x, v)` after every
    /// step; `ControlFlow::Break(())` stops the run.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn integrate_with<F>(
        &mut self,
        t_end: f64,
        mut callback: F,
    ) -> Result<IntegrateInfo, OdeError>
    where
        F: FnMut(&StepReport, &[f64], &[f64]) -> ControlFlow<()>,
    {
        let n = self.core.s.len() / 2;
        self.core.integrate(t_end, |r, s| {
            let (x, v) = s.split_at(n);
            callback(r, x, v)
        })
    }

    /// The current time.
    pub fn t(&self) -> f64 {
        self.core.t
    }

    /// The current positions.
    pub fn x(&self) -> &[f64] {
        &self.core.s[..self.core.s.len() / 2]
    }

    /// The current velocities.
    pub fn v(&self) -> &[f64] {
        &self.core.s[self.core.s.len() / 2..]
    }

    /// The state `[x; v]` (the first-order form (6)).
    pub fn state(&self) -> &[f64] {
        &self.core.s
    }

    /// Replaces time, positions and velocities; multistep history restarts.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`], [`OdeError::InvalidParameter`].
    pub fn set_state(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError> {
        // Copies the halves in place: no allocation, so that wrappers may
        // hand a post-processed state back after every step.
        self.core.set_state_parts(t, x, v)
    }

    /// Edits the positions and velocities in place between steps:
    /// `f(x, v)` may change both (a velocity filter after an explicit step
    /// does). The time stays; cached forces and multistep history are
    /// dropped as by [`set_state`](Self::set_state), but nothing is copied
    /// and the growth bound is kept. A non-finite value written here is
    /// caught by the next step ([`OdeError::NonFinite`]). Returns what `f`
    /// returns.
    pub fn modify_state<R>(&mut self, f: impl FnOnce(&mut [f64], &mut [f64]) -> R) -> R {
        self.core.modify_state_parts(f)
    }

    /// The constraints set by the last [`SecondOrderProblem::begin_step`].
    pub fn constraints(&self) -> &Constraints {
        &self.core.sys.constraints
    }

    /// The counters of the run so far.
    pub fn stats(&self) -> Stats {
        self.core.stats
    }

    /// The method.
    pub fn method(&self) -> &Method {
        self.core.method()
    }

    /// The options.
    pub fn options(&self) -> &SolverOptions {
        self.core.options()
    }

    /// The step size the next step will try.
    pub fn h_next(&self) -> f64 {
        self.core.h_next()
    }

    /// The problem.
    pub fn problem(&self) -> &P {
        &self.core.sys.problem
    }

    /// The problem, mutably (cached forces are dropped).
    pub fn problem_mut(&mut self) -> &mut P {
        self.core.problem_changed();
        &mut self.core.sys.problem
    }
}
