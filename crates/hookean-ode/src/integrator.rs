//! The public integrators: [`FirstOrderIntegrator`] for `y' = f(t, y)` and
//! [`SecondOrderIntegrator`] for `M x'' = f(t, x, v)`, for every
//! [`Method`]: one [`OdeIntegrator`] holding the engine the method runs on
//! (the core of the one-step, fixed-step multistep and variable-step BDF2
//! methods, or the variable-order BDF). The engine keeps the stepping
//! contract ([`Integrator`]); the integrator passes its required methods on
//! to the engine (the one forwarding frame) and adds only what is its own:
//! construction from a [`Method`], the options, and the second-order
//! state's halves.

use std::marker::PhantomData;

use hookean_sparse::Constraints;

use crate::bdf::Bdf;
use crate::core::Core;
use crate::error::OdeError;
use crate::method::Method;
use crate::options::SolverOptions;
use crate::stage::{FirstSys, SecondSys};
use crate::stats::{Stats, StepReport};
use crate::stepping::Integrator;
use hookean_problem::{FirstOrderProblem, SecondOrderProblem};

/// What an engine on the problem `P` offers besides the stepping contract:
/// the step's constraints (second-order problems), its options, and
/// in-place writes of a second-order state `[x; v]`.
pub(crate) trait Engine<P>: Integrator<Problem = P> {
    /// The constraints set by the last `begin_step` of a second-order
    /// problem; `None` for a first-order one.
    fn constraints(&self) -> Option<&Constraints>;
    /// The options.
    fn options(&self) -> &SolverOptions;
    /// A new state from its halves `[x; v]`, copied in place (no
    /// allocation); multistep history restarts, the growth bound is kept.
    fn set_state_parts(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError>;
    /// The halves `[x; v]` edited in place by `f` between steps; history
    /// restarts, the next step checks the state is finite.
    fn modify_state_parts(&mut self, f: &mut dyn FnMut(&mut [f64], &mut [f64]));
}

/// The engine of `method` on the stage system `sys` from `(t0, s0)`.
fn engine<S>(
    sys: S,
    method: Method,
    t0: f64,
    s0: Vec<f64>,
    options: SolverOptions,
) -> Result<Box<dyn Engine<S::Problem> + Send>, OdeError>
where
    S: crate::bdf::Corrector + Send + 'static,
    S::Data: Send,
{
    Ok(match method {
        Method::VariableBdf(config) => Box::new(Bdf::new(sys, t0, &s0, options, config)?),
        _ => Box::new(Core::new(sys, method, t0, s0, options)?),
    })
}

/// An integrator of the problem `P` of the kind `K` ([`FirstOrder`] or
/// [`SecondOrder`]) with the engine its [`Method`] runs on:
/// [`FirstOrderIntegrator`] or [`SecondOrderIntegrator`]. Stepping, dense
/// output, `step_to`, `integrate`, `solve_at` and events are the stepping
/// contract's ([`Integrator`]; import the trait).
pub struct OdeIntegrator<P, K> {
    /// `Send`, so that an integrator (and a simulation) can move to
    /// another thread: the problem must be `Send` too.
    engine: Box<dyn Engine<P> + Send>,
    method: Method,
    kind: PhantomData<K>,
}

/// The kind of an [`OdeIntegrator`] of first-order problems `y' = f(t, y)`.
#[derive(Debug)]
pub enum FirstOrder {}

/// The kind of an [`OdeIntegrator`] of second-order problems `M x'' = f(t, x, v)`.
#[derive(Debug)]
pub enum SecondOrder {}

/// Integrates a first-order problem `y' = f(t, y)` (eq. 7) with any
/// [`Method`] except the second-order-only ones (FB Euler, Verlet).
/// Implicit methods run Newton with the matrix `I - c h df/dy`: dense LU
/// (`df/dy` from [`FirstOrderProblem::jacobian`] or forward differences), or
/// sparse LU when the problem has a
/// [`sparse_jacobian_pattern`](FirstOrderProblem::sparse_jacobian_pattern).
/// [`Method::VariableBdf`] runs the variable-order BDF with its settings ([`crate::bdf`]'s engine).
pub type FirstOrderIntegrator<P> = OdeIntegrator<P, FirstOrder>;

impl<P: FirstOrderProblem + Send + 'static> OdeIntegrator<P, FirstOrder> {
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
            engine: engine(sys, method.clone(), t0, y0.to_vec(), options)?,
            method,
            kind: PhantomData,
        })
    }
}

impl<P> OdeIntegrator<P, FirstOrder> {
    /// The current state `y`.
    pub fn y(&self) -> &[f64] {
        self.engine.state()
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
/// use hookean_ode::{Integrator, Method, SecondOrderIntegrator, SolverOptions};
/// use hookean_ode::tutorial::LinearOscillator;
///
/// // The tutorial's example 3: a particle on a damped spring under gravity.
/// let ex3 = LinearOscillator::example3();
/// let mut ode = SecondOrderIntegrator::new(
///     ex3.particle(), Method::Bdf(2), 0.0, &ex3.x0(), &ex3.v0_vec(), SolverOptions::with_h(1e-3),
/// )?;
/// ode.integrate(ex3.t_end)?; // the stepping contract, `Integrator`
/// let [z, v] = ex3.exact(ex3.t_end);
/// assert!((ode.x()[2] - z).abs() < 1e-5 && (ode.v()[2] - v).abs() < 1e-4);
/// assert!(ode.stats().num_lin_iters > 0); // PCG on the reduced form
///
/// // The variable-order BDF with error control on the same problem.
/// let opts = SolverOptions::with_tolerances(1e-6, 1e-8);
/// let mut bdf = SecondOrderIntegrator::new(
///     ex3.particle(), Method::variable_bdf(), 0.0, &ex3.x0(), &ex3.v0_vec(), opts,
/// )?;
/// bdf.integrate(ex3.t_end)?;
/// assert!((bdf.x()[2] - z).abs() < 1e-5 && (bdf.v()[2] - v).abs() < 1e-4);
/// assert!(bdf.stats().num_steps < 1000);
/// # Ok::<(), hookean_ode::OdeError>(())
/// ```
pub type SecondOrderIntegrator<P> = OdeIntegrator<P, SecondOrder>;

impl<P: SecondOrderProblem + Send + 'static> OdeIntegrator<P, SecondOrder> {
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
            engine: engine(sys, method.clone(), t0, s0, options)?,
            method,
            kind: PhantomData,
        })
    }
}

impl<P> OdeIntegrator<P, SecondOrder> {
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

    /// Replaces time, positions and velocities, copying the halves in
    /// place (no allocation, so that wrappers may hand a post-processed
    /// state back after every step); multistep history restarts, the
    /// growth bound stays ([`Integrator::restart`] takes a new one).
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`], [`OdeError::InvalidParameter`].
    pub fn set_state(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError> {
        self.engine.set_state_parts(t, x, v)
    }

    /// Edits the positions and velocities in place between steps:
    /// `f(x, v)` may change both (a velocity filter after an explicit step
    /// does). The time stays; cached forces and multistep history are
    /// dropped as by [`set_state`](Self::set_state), but nothing is copied
    /// and the growth bound is kept. A non-finite value written here is
    /// caught by the next step ([`OdeError::NonFinite`]). Returns what `f`
    /// returns.
    pub fn modify_state<R>(&mut self, f: impl FnOnce(&mut [f64], &mut [f64]) -> R) -> R {
        let mut f = Some(f);
        let mut result = None;
        self.engine.modify_state_parts(&mut |x, v| {
            if let Some(f) = f.take() {
                result = Some(f(x, v));
            }
        });
        result.expect("the engine edits the state once")
    }

    /// The constraints set by the last [`SecondOrderProblem::begin_step`].
    pub fn constraints(&self) -> &Constraints {
        self.engine
            .constraints()
            .expect("a second-order engine keeps the step's constraints")
    }
}

impl<P, K> OdeIntegrator<P, K> {
    /// The method.
    pub fn method(&self) -> &Method {
        &self.method
    }

    /// The options.
    pub fn options(&self) -> &SolverOptions {
        self.engine.options()
    }
}

/// The stepping contract, passed on to the engine.
impl<P, K> Integrator for OdeIntegrator<P, K> {
    type Problem = P;

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
    fn problem(&self) -> &P {
        self.engine.problem()
    }
    fn problem_mut(&mut self) -> &mut P {
        self.engine.problem_mut()
    }
    fn step_bounded(&mut self, t_bound: f64) -> Result<StepReport, OdeError> {
        self.engine.step_bounded(t_bound)
    }
    fn land_on(&mut self, t_end: f64) {
        self.engine.land_on(t_end);
    }
    fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        self.engine.interpolate(t, out)
    }
    fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        self.engine.restart(t, y)
    }
    fn count_event_evaluations(&mut self, n: usize) {
        self.engine.count_event_evaluations(n);
    }
    fn save_state(&self, record: &mut crate::StateRecord) -> Result<(), OdeError> {
        self.engine.save_state(record)
    }
    fn restore_state(&mut self, record: &crate::StateRecord) -> Result<(), OdeError> {
        self.engine.restore_state(record)
    }
    fn record_linear_solves(
        &mut self,
        recorder: Option<hookean_nonlinear::SharedRecorder>,
    ) -> bool {
        self.engine.record_linear_solves(recorder)
    }
}
