//! The public integrators: [`FirstOrderIntegrator`] for `y' = f(t, y)` and
//! [`SecondOrderIntegrator`] for `M x'' = f(t, x, v)`, for every
//! [`Method`]. Both keep the stepping contract ([`Integrator`]: `step`,
//! `step_to`, dense output, `solve_at`, events) and offer the driver
//! ([`integrate`](FirstOrderIntegrator::integrate),
//! [`integrate_with`](FirstOrderIntegrator::integrate_with)).

use std::ops::ControlFlow;

use hookean_sparse::Constraints;

use crate::bdf::Bdf;
use crate::core::Core;
use crate::error::OdeError;
use crate::method::Method;
use crate::options::SolverOptions;
use crate::stage::{FirstSys, SecondSys};
use crate::stats::{IntegrateInfo, Stats, StepReport};
use crate::stepping::Integrator;
use hookean_problem::{FirstOrderProblem, SecondOrderProblem};

/// What runs a method: the core of the one-step, fixed-step multistep and
/// variable-step BDF2 methods, or the variable-order BDF.
enum Engine<S: crate::bdf::Corrector> {
    Core(Box<Core<S>>),
    Bdf(Box<Bdf<S>>),
}

impl<S: crate::bdf::Corrector> Engine<S> {
    fn new(
        sys: S,
        method: Method,
        t0: f64,
        s0: Vec<f64>,
        options: SolverOptions,
    ) -> Result<Self, OdeError> {
        Ok(match method {
            Method::VariableBdf => Engine::Bdf(Box::new(Bdf::new(sys, t0, &s0, options)?)),
            _ => Engine::Core(Box::new(Core::new(sys, method, t0, s0, options)?)),
        })
    }

    fn sys(&self) -> &S {
        match self {
            Engine::Core(c) => &c.sys,
            Engine::Bdf(b) => &b.sys,
        }
    }

    /// The system, mutably: cached values that depend on the problem are dropped.
    fn sys_mut(&mut self) -> &mut S {
        match self {
            Engine::Core(c) => {
                c.problem_changed();
                &mut c.sys
            }
            Engine::Bdf(b) => {
                b.problem_changed();
                &mut b.sys
            }
        }
    }

    fn t(&self) -> f64 {
        match self {
            Engine::Core(c) => c.t,
            Engine::Bdf(b) => b.t(),
        }
    }

    fn t_prev(&self) -> f64 {
        match self {
            Engine::Core(c) => c.t_prev(),
            Engine::Bdf(b) => b.t_prev(),
        }
    }

    fn state(&self) -> &[f64] {
        match self {
            Engine::Core(c) => &c.s,
            Engine::Bdf(b) => b.state(),
        }
    }

    fn stats(&self) -> Stats {
        match self {
            Engine::Core(c) => c.stats,
            Engine::Bdf(b) => *b.stats(),
        }
    }

    fn options(&self) -> &SolverOptions {
        match self {
            Engine::Core(c) => c.options(),
            Engine::Bdf(b) => b.options(),
        }
    }

    fn h_next(&self) -> f64 {
        match self {
            Engine::Core(c) => c.h_next(),
            Engine::Bdf(b) => b.h_next(),
        }
    }

    fn step(&mut self) -> Result<StepReport, OdeError> {
        match self {
            Engine::Core(c) => c.step(None),
            Engine::Bdf(b) => b.step(),
        }
    }

    fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, OdeError> {
        match self {
            Engine::Core(c) => c.step_to(t_end),
            Engine::Bdf(b) => b.step_to(t_end),
        }
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        match self {
            Engine::Core(c) => c.interpolate(t, out),
            Engine::Bdf(b) => b.interpolate(t, out),
        }
    }

    fn set_state(&mut self, t: f64, s: &[f64]) -> Result<(), OdeError> {
        match self {
            Engine::Core(c) => c.set_state(t, s),
            Engine::Bdf(b) => b.set_state(t, s),
        }
    }

    fn count_event_evaluations(&mut self, n: usize) {
        match self {
            Engine::Core(c) => c.stats.num_g_evals += n,
            Engine::Bdf(b) => b.count_event_evaluations(n),
        }
    }

    fn integrate<F>(&mut self, t_end: f64, mut callback: F) -> Result<IntegrateInfo, OdeError>
    where
        F: FnMut(&StepReport, &[f64]) -> ControlFlow<()>,
    {
        while let Some(report) = self.step_to(t_end)? {
            if callback(&report, self.state()).is_break() {
                return Ok(IntegrateInfo {
                    t: self.t(),
                    stopped_by_callback: true,
                    stats: self.stats(),
                });
            }
        }
        Ok(IntegrateInfo {
            t: self.t(),
            stopped_by_callback: false,
            stats: self.stats(),
        })
    }
}

/// Integrates a first-order problem `y' = f(t, y)` (eq. 7) with any
/// [`Method`] except the second-order-only ones (FB Euler, Verlet).
/// Implicit methods run Newton with the matrix `I - c h df/dy`: dense LU
/// (`df/dy` from [`FirstOrderProblem::jacobian`] or forward differences), or
/// sparse LU when the problem has a
/// [`sparse_jacobian_pattern`](FirstOrderProblem::sparse_jacobian_pattern).
/// [`Method::VariableBdf`] runs the variable-order BDF ([`BdfSolver`](crate::BdfSolver)).
pub struct FirstOrderIntegrator<P: FirstOrderProblem> {
    engine: Engine<FirstSys<P>>,
    method: Method,
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
            engine: Engine::new(sys, method.clone(), t0, y0.to_vec(), options)?,
            method,
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
        self.engine.step()
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
        self.engine.step_to(t_end)
    }

    /// Integrates to `t_end` (the last step is shortened to land on it).
    ///
    /// # Errors
    /// As [`step`](Self::step), and [`OdeError::InvalidParameter`] for a
    /// `t_end` before the current time.
    pub fn integrate(&mut self, t_end: f64) -> Result<IntegrateInfo, OdeError> {
        self.engine
            .integrate(t_end, |_, _| ControlFlow::Continue(()))
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
        self.engine.integrate(t_end, callback)
    }

    /// The current time.
    pub fn t(&self) -> f64 {
        self.engine.t()
    }

    /// The current state `y`.
    pub fn y(&self) -> &[f64] {
        self.engine.state()
    }

    /// Replaces time and state; multistep history restarts.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`], [`OdeError::InvalidParameter`].
    pub fn set_state(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        self.engine.set_state(t, y)
    }

    /// The counters of the run so far.
    pub fn stats(&self) -> Stats {
        self.engine.stats()
    }

    /// The method.
    pub fn method(&self) -> &Method {
        &self.method
    }

    /// The options.
    pub fn options(&self) -> &SolverOptions {
        self.engine.options()
    }

    /// The step size the next step will try.
    pub fn h_next(&self) -> f64 {
        self.engine.h_next()
    }

    /// The problem.
    pub fn problem(&self) -> &P {
        &self.engine.sys().problem
    }

    /// The problem, mutably (cached right-hand-side values are dropped, the
    /// variable-order BDF evaluates its Jacobian again).
    pub fn problem_mut(&mut self) -> &mut P {
        &mut self.engine.sys_mut().problem
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
/// assert!(ode.stats().num_lin_iters > 0); // PCG on the reduced form
///
/// // The variable-order BDF with error control on the same problem.
/// let opts = SolverOptions::with_tolerances(1e-6, 1e-8);
/// let mut bdf = SecondOrderIntegrator::new(
///     ex3.particle(), Method::VariableBdf, 0.0, &ex3.x0(), &ex3.v0_vec(), opts,
/// )?;
/// bdf.integrate(ex3.t_end)?;
/// assert!((bdf.x()[2] - z).abs() < 1e-5 && (bdf.v()[2] - v).abs() < 1e-4);
/// assert!(bdf.stats().num_steps < 1000);
/// # Ok::<(), hookean_ode::OdeError>(())
/// ```
pub struct SecondOrderIntegrator<P: SecondOrderProblem> {
    engine: Engine<SecondSys<P>>,
    method: Method,
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
            engine: Engine::new(sys, method.clone(), t0, s0, options)?,
            method,
        })
    }

    /// Advances one (accepted) step; see [`FirstOrderIntegrator::step`].
    ///
    /// # Errors
    /// As [`FirstOrderIntegrator::step`], plus [`OdeError::LinearSolver`]
    /// when PCG fails after the allowed retries.
    pub fn step(&mut self) -> Result<StepReport, OdeError> {
        self.engine.step()
    }

    /// One step that does not pass `t_end`, or `None` once `t_end` is
    /// reached; see [`FirstOrderIntegrator::step_to`].
    ///
    /// # Errors
    /// As [`FirstOrderIntegrator::step_to`].
    pub fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, OdeError> {
        self.engine.step_to(t_end)
    }

    /// Integrates to `t_end`.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn integrate(&mut self, t_end: f64) -> Result<IntegrateInfo, OdeError> {
        self.engine
            .integrate(t_end, |_, _| ControlFlow::Continue(()))
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
        let n = self.engine.state().len() / 2;
        self.engine.integrate(t_end, |r, s| {
            let (x, v) = s.split_at(n);
            callback(r, x, v)
        })
    }

    /// The current time.
    pub fn t(&self) -> f64 {
        self.engine.t()
    }

    /// The current positions.
    pub fn x(&self) -> &[f64] {
        let s = self.engine.state();
        &s[..s.len() / 2]
    }

    /// The current velocities.
    pub fn v(&self) -> &[f64] {
        let s = self.engine.state();
        &s[s.len() / 2..]
    }

    /// The state `[x; v]` (the first-order form (6)).
    pub fn state(&self) -> &[f64] {
        self.engine.state()
    }

    /// Replaces time, positions and velocities; multistep history restarts.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`], [`OdeError::InvalidParameter`].
    pub fn set_state(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError> {
        // Copies the halves in place: no allocation, so that wrappers may
        // hand a post-processed state back after every step.
        match &mut self.engine {
            Engine::Core(c) => c.set_state_parts(t, x, v),
            Engine::Bdf(b) => b.set_state_parts(t, x, v),
        }
    }

    /// Edits the positions and velocities in place between steps:
    /// `f(x, v)` may change both (a velocity filter after an explicit step
    /// does). The time stays; cached forces and multistep history are
    /// dropped as by [`set_state`](Self::set_state), but nothing is copied
    /// and the growth bound is kept. A non-finite value written here is
    /// caught by the next step ([`OdeError::NonFinite`]). Returns what `f`
    /// returns.
    pub fn modify_state<R>(&mut self, f: impl FnOnce(&mut [f64], &mut [f64]) -> R) -> R {
        match &mut self.engine {
            Engine::Core(c) => c.modify_state_parts(f),
            Engine::Bdf(b) => b.modify_state_parts(f),
        }
    }

    /// The constraints set by the last [`SecondOrderProblem::begin_step`].
    pub fn constraints(&self) -> &Constraints {
        &self.engine.sys().constraints
    }

    /// The counters of the run so far.
    pub fn stats(&self) -> Stats {
        self.engine.stats()
    }

    /// The method.
    pub fn method(&self) -> &Method {
        &self.method
    }

    /// The options.
    pub fn options(&self) -> &SolverOptions {
        self.engine.options()
    }

    /// The step size the next step will try.
    pub fn h_next(&self) -> f64 {
        self.engine.h_next()
    }

    /// The problem.
    pub fn problem(&self) -> &P {
        &self.engine.sys().problem
    }

    /// The problem, mutably (cached forces are dropped, the variable-order
    /// BDF evaluates its Jacobians again).
    pub fn problem_mut(&mut self) -> &mut P {
        &mut self.engine.sys_mut().problem
    }
}

/// The stepping contract of both integrators, by delegation.
macro_rules! integrator_impl {
    ($ty:ident, $bound:ident) => {
        impl<P: $bound> Integrator for $ty<P> {
            fn t(&self) -> f64 {
                self.engine.t()
            }
            fn t_prev(&self) -> f64 {
                self.engine.t_prev()
            }
            fn state(&self) -> &[f64] {
                self.engine.state()
            }
            fn stats(&self) -> Stats {
                self.engine.stats()
            }
            fn h_next(&self) -> f64 {
                self.engine.h_next()
            }
            fn step(&mut self) -> Result<StepReport, OdeError> {
                self.engine.step()
            }
            fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, OdeError> {
                self.engine.step_to(t_end)
            }
            fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
                self.engine.interpolate(t, out)
            }
            fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
                self.engine.set_state(t, y)
            }
            fn count_event_evaluations(&mut self, n: usize) {
                self.engine.count_event_evaluations(n);
            }
        }
    };
}

integrator_impl!(FirstOrderIntegrator, FirstOrderProblem);
integrator_impl!(SecondOrderIntegrator, SecondOrderProblem);
