#![doc = include_str!("../README.md")]
//!
//! # The crate's map
//!
//! - The contracts, [`FirstOrderProblem`] `y' = f(t, y)` and
//!   [`SecondOrderProblem`] `M x'' = f(t, x, v)` (lumped `M`, 3x3-block
//!   Jacobians), live in the small `hookean-problem` crate (re-exported
//!   here), so that models need not depend on the integrators.
//! - [`Method`]: explicit Euler, explicit midpoint, RK4, any explicit
//!   [`ButcherTableau`], FB Euler, Stoermer-Verlet, implicit Euler, implicit
//!   midpoint, fixed-step BDF(1..6), variable-step BDF2, IMEX, and the
//!   variable-order BDF ([`Method::VariableBdf`], `"bdf"`, the recommended
//!   stiff solver); by name through `FromStr`/`Display`.
//! - [`SolverOptions`]: the one options struct of every method: step size,
//!   tolerances (`atol` per component, [`Tolerance`]), the step-size policy
//!   ([`StepSizePolicy`]: bounds, BDF2's controller of [`control`]), Newton's
//!   options and the linear solver's ([`PcgOptions`]); the variable-order
//!   BDF's own settings travel with its method ([`BdfConfig`] in
//!   [`Method::VariableBdf`]). [`Stats`]: the one set of counters,
//!   named after CVODE's.
//! - [`Integrator`]: the stepping contract every engine implements once:
//!   one bounded step (returning a [`StepReport`]) and `interpolate`, dense
//!   output on the last step; `step`, `step_to` (landing on an end time,
//!   one rule), `integrate`, `solve_at` and events ([`Events`]) are its
//!   default methods, written once (diffsol's `OdeSolverMethod` shape).
//!   [`FirstOrderIntegrator`] and [`SecondOrderIntegrator`] run every
//!   method; [`Method::VariableBdf`] is the variable-order BDF/NDF for stiff
//!   problems in the quasi-constant-step form of SciPy and ode15s with
//!   CVODE's Jacobian and Newton-matrix re-use ([`bdf`]).
//! - [`stability`]: stability functions `R(z)`, BDF boundary loci,
//!   [`is_a_stable`](stability::is_a_stable), region sampling (figure 4).
//! - [`testset`]: the standard stiff test problems with published
//!   reference solutions. `sprs` and `faer` are re-exported.
//! - [`tutorial`]: the tutorial's examples 1-3 (Dahlquist's equation, the
//!   overdamped wave equation, the particle on a spring) with exact solutions.
//! - [`workprecision`]: error against work over step sizes or tolerances
//!   (figures 3, 5, 7) and observed orders.
//!
//! Every implicit step is a stage equation `K = psi + c h F(tau, K)` (`c = 1`
//! implicit Euler, `1/2` midpoint, `beta_k` BDF(k), `1 / alpha_k` the
//! variable-order BDF) solved by `hookean-nonlinear`'s Newton (exact,
//! inexact, simplified or inexact simplified, [`NewtonOptions::method`]; the
//! variable-order BDF's simplified Newton with CVODE's rate test): a dense
//! or sparse LU (or GMRES) for first-order problems, the reduced velocity
//! form with (filtered) PCG for second-order ones. Fixed-step BDF(k) starts
//! with the implicit midpoint rule extrapolated from 2, 4 and 6 substeps
//! (local error `O(h^7)`); variable-step BDF2 starts with implicit Euler and
//! is driven by the PI controller of [`control`] (or its Newton-iteration
//! controller of the tutorial's section 3.4, [`StepControl`]).
//!
//! ```
//! use hookean_ode::{FirstOrderIntegrator, FirstOrderProblem, Integrator, Method, SolverOptions};
//!
//! /// Dahlquist's equation y' = lambda y (the tutorial's eq. 20).
//! struct Dahlquist(f64);
//! impl FirstOrderProblem for Dahlquist {
//!     fn dim(&self) -> usize { 1 }
//!     fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) { dy[0] = self.0 * y[0]; }
//! }
//!
//! let method: Method = "bdf2".parse()?;
//! let mut ode = FirstOrderIntegrator::new(Dahlquist(-15.0), method, 0.0, &[1.0], SolverOptions::with_h(1e-3))?;
//! let info = ode.integrate(1.0)?;
//! assert!((ode.y()[0] - (-15.0f64).exp()).abs() < 1e-6);
//! assert_eq!(info.stats.num_steps, 1000);
//! # Ok::<(), hookean_ode::OdeError>(())
//! ```
//!
//! The stiff solver on Van der Pol's oscillator (`mu = 1000`), with the
//! solution at requested times and its statistics:
//!
//! ```
//! use hookean_ode::testset::{TestProblem, VanDerPol, mixed_error};
//! use hookean_ode::{FirstOrderIntegrator, Integrator, Method, SolverOptions};
//!
//! let opts = SolverOptions::with_tolerances(1e-6, 1e-6);
//! let mut solver = FirstOrderIntegrator::new(VanDerPol, Method::variable_bdf(), 0.0, &[2.0, 0.0], opts)?;
//! let sol = solver.solve_at(&[0.5, 1.0, 1.5, 2.0])?;
//! // The IVP test set's reference value at t = 2 (Mazzia-Magherini).
//! assert!(mixed_error(sol.y(3), &VanDerPol.reference(), &VanDerPol.floor()) < 1e-4);
//! assert!(sol.stats.num_jac_evals < sol.stats.num_steps / 10);
//! # Ok::<(), hookean_ode::OdeError>(())
//! ```
//!
//! # Options structs
//!
//! [`SolverOptions`], [`StepSizePolicy`], [`BdfConfig`],
//! [`IterationControllerOptions`] and [`PiControllerOptions`] have a `Default`:
//! construct them with `..Default::default()`. Each has a hidden field, so
//! that a later version may add an option without breaking your code; a
//! literal naming every field does not compile outside this crate.
//!
//! ```
//! use hookean_ode::{NewtonOptions, SolverOptions, StepSizePolicy};
//! let options = SolverOptions {
//!     h: 1e-3,
//!     step: StepSizePolicy { h_max: 0.1, ..Default::default() },
//!     newton: NewtonOptions { max_iter: 20, ..Default::default() },
//!     ..Default::default()
//! };
//! assert_eq!((options.h, options.step.h_max, options.newton.max_iter), (1e-3, 0.1, 20));
//! assert_eq!(options.step.h_min, StepSizePolicy::default().h_min);
//! ```
//!
//! ```compile_fail
//! // Every field named, none left to the default: refused outside the crate.
//! let control = hookean_ode::IterationControllerOptions {
//!     few_iterations: 2,
//!     many_iterations: 6,
//!     grow_factor: 1.5,
//!     shrink_factor: 0.7,
//!     failure_factor: 0.5,
//! };
//! ```
//!
//! ```compile_fail
//! // Nor can the seal be written: only hookean-ode makes a `NonExhaustive`.
//! let control = hookean_ode::IterationControllerOptions {
//!     few_iterations: 2,
//!     many_iterations: 6,
//!     grow_factor: 1.5,
//!     shrink_factor: 0.7,
//!     failure_factor: 0.5,
//!     non_exhaustive: hookean_ode::NonExhaustive(()),
//! };
//! ```

hookean_sparse::non_exhaustive_seal!();

pub mod bdf;
mod bdf_config;
pub mod control;
mod core;
pub mod error;
pub mod events;
pub mod imex;
pub mod integrator;
pub mod method;
pub mod options;
mod phases;
pub mod snapshot;
pub mod stability;
mod stage;
pub mod stats;
pub mod stepping;
pub mod tableau;
pub mod testset;
pub mod tutorial;
pub mod workprecision;

pub use bdf::{
    BdfCoefficients, BdfConfig, BdfLinearSolver, Formula, MAX_ORDER, TOLERANCE_EXPONENT,
};
pub use control::{
    IterationController, IterationControllerOptions, NewtonOutcome, PiController,
    PiControllerOptions, StepDecision,
};
pub use error::OdeError;
pub use events::{Direction, EventHit, Events};
/// The dense linear algebra crate of the first-order Newton matrices.
pub use faer;
pub use hookean_nonlinear::{ForcingTerm, NewtonMethod, NewtonOptions, PcgOptions};
pub use hookean_problem::{FirstOrderProblem, SecondOrderProblem};
/// The preconditioners of [`PcgOptions`] and [`BdfLinearSolver::Gmres`].
pub use hookean_sparse::{PrecondKind, PreconditionerOptions};
pub use integrator::{
    FirstOrder, FirstOrderIntegrator, OdeIntegrator, SecondOrder, SecondOrderIntegrator,
};
pub use method::Method;
pub use options::{DEFAULT_STEP, Predictor, SolverOptions, StepControl, StepSizePolicy, Tolerance};
pub use phases::PhaseTimes;
pub use snapshot::StateRecord;
/// The sparse matrix crate of [`FirstOrderProblem::sparse_jacobian_pattern`]
/// and [`FirstOrderProblem::jacobian_sparse`], re-exported so that users
/// need not match its version by hand.
pub use sprs;
pub use stage::FirstOrderForm;
pub use stats::{IntegrateInfo, Stats, StepReport};
pub use stepping::{EventRun, Integrator, Solution, landing_slack};
pub use tableau::ButcherTableau;
