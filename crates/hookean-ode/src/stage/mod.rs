//! The two problem kinds seen by the integrators as "a state vector and a
//! stage equation": first-order `y' = f(t, y)` (Newton with a dense or
//! sparse LU; the variable-order BDF's corrector adds matrix-free GMRES,
//! `bdf/first_order.rs`) and second-order `M x'' = f(t, x, v)` (the
//! reduced velocity form with PCG). Every stage equation is solved by
//! `hookean-nonlinear`'s [`Newton`](hookean_nonlinear::Newton); the fixed-
//! and variable-step methods of `core.rs` and the variable-order BDF
//! (`bdf/`) share these systems. Private except for [`FirstOrderForm`].
//!
//! - `first_order.rs`: the stage `K = psi + gh f(tau, K)` as a nonlinear
//!   system on a dense or sparse Jacobian, and [`FirstSys`];
//! - `second_order.rs`: the reduced velocity form and [`SecondSys`];
//! - `linearized.rs`: eq. 50's isotropic Newton matrix (inexact simplified Newton);
//! - `checkpoint.rs`: [`SecondSys`]'s checkpoint, and that of a Newton
//!   solver with PCG (its kept Jacobian, its multigrid);
//! - `first_order_form.rs`: [`FirstOrderForm`], a second-order problem as a
//!   first-order one.

mod checkpoint;
mod first_order;
mod first_order_form;
mod linearized;
mod second_order;

pub(crate) use checkpoint::{
    NewtonRecord, matrix_entry, matrix_values, save_newton, set_matrix_values,
};
pub(crate) use first_order::{
    FirstStage, FirstSys, SparseFirstStage, diagonal_positions, forward_difference_jacobian,
};
pub use first_order_form::FirstOrderForm;
pub(crate) use second_order::{ReducedStage, SecondSys, begin_stage};

use hookean_nonlinear::{NewtonStats, NonlinearError};

use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::stats::Stats;

/// Where a stage's Newton matrix takes the problem's Jacobian from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum JacobianSource {
    /// Evaluated at the iterate where Newton asks for it.
    Evaluate,
    /// The one the caller keeps (the variable-order BDF evaluates it at its
    /// predictor, by its own re-use rules); only the Newton matrix is
    /// formed from it with the current `gh`.
    Kept,
}

/// Why one attempt at solving a stage equation failed.
#[derive(Debug)]
pub(crate) enum StageFailure {
    /// No convergence within the iteration limit, or divergence.
    NoConvergence { iterations: usize, update_norm: f64 },
    /// The linear solver failed (did not converge, or a `hookean-sparse` error).
    Linear(NonlinearError),
    /// The dense Newton matrix is singular.
    Singular { pivot: usize },
    /// IMEX on a problem whose linear part (eq. 50) is gone.
    NoLinearPart,
    /// Any other error of the Newton solver (not worth a retry).
    Other(NonlinearError),
}

/// Newton statistics of one successful stage solve.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct StageInfo {
    pub iterations: usize,
}

/// The integrator core's view of a problem.
pub(crate) trait System {
    /// The user's problem.
    type Problem;
    /// The user's problem.
    fn problem(&self) -> &Self::Problem;
    /// The user's problem, mutably.
    fn problem_mut(&mut self) -> &mut Self::Problem;
    /// The step's constraints (second-order problems).
    fn constraints(&self) -> Option<&hookean_sparse::Constraints> {
        None
    }
    /// Length of the state vector (`y`, or `[x; v]`).
    fn state_len(&self) -> usize;
    /// True for second-order problems (state `[x; v]`).
    fn is_second_order(&self) -> bool;
    /// Time derivative of the state: `f(t, y)`, or `[v; M^{-1} f(t, x, v)]`.
    fn derivative(&mut self, t: f64, s: &[f64], ds: &mut [f64], stats: &mut Stats);
    /// Lets the model adjust the state and set constraints before a step.
    fn begin_step(&mut self, t: f64, s: &mut [f64]);
    /// Lets the model correct the state after an accepted step from `t`
    /// of size `h` that started at `start`; true if it changed `s`.
    fn end_step(&mut self, t: f64, h: f64, start: &[f64], s: &mut [f64]) -> bool;
    /// Imposes the step's velocity constraints on a state (second order).
    fn impose(&self, s: &mut [f64]);
    /// Solves the stage equation `K = psi + gh F(tau, K)` for `K` (in: the
    /// initial guess, out: the solution); the shape shared by implicit
    /// Euler, the implicit midpoint rule and BDF(k).
    fn solve_stage(
        &mut self,
        tau: f64,
        gh: f64,
        psi: &[f64],
        k: &mut [f64],
        opts: &SolverOptions,
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure>;
    /// For second-order systems: writes `M^{-1} f(t, x, v)` into `acc` and
    /// returns `true`; first-order systems return `false`.
    fn acceleration(
        &mut self,
        t: f64,
        x: &[f64],
        v: &[f64],
        acc: &mut [f64],
        stats: &mut Stats,
    ) -> bool;
    /// Adds what the next stage solve reuses (warm start, Newton's carried
    /// state, the preconditioner's reused parts) to a checkpoint.
    fn save_state(&self, record: &mut crate::StateRecord) -> Result<(), OdeError> {
        let _ = record;
        Err(crate::snapshot::not_covered("first-order problems"))
    }
    /// Restores [`save_state`](Self::save_state) into a system of a run
    /// with the options `opts` (what the saved system built lazily from
    /// them is built again).
    fn restore_state(
        &mut self,
        record: &crate::StateRecord,
        opts: &SolverOptions,
    ) -> Result<(), OdeError> {
        let _ = (record, opts);
        Err(crate::snapshot::not_covered("first-order problems"))
    }
    /// Installs `recorder` in the stage equations' PCG solver
    /// ([`Integrator::record_linear_solves`](crate::Integrator::record_linear_solves));
    /// `false` for systems solved otherwise (LU, GMRES).
    fn record_linear_solves(
        &mut self,
        recorder: Option<hookean_nonlinear::SharedRecorder>,
    ) -> bool {
        let _ = recorder;
        false
    }
    /// One step of the IMEX scheme ([`crate::imex`]) on the state `s`
    /// (second-order systems with a linear part only; the integrator
    /// checks that at construction).
    fn imex_step(
        &mut self,
        t: f64,
        h: f64,
        s: &mut [f64],
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure>;
}

/// The failure of an IMEX step as a stage failure: a `hookean-sparse`
/// error (the factorisation, or PCG short of its tolerance) is a
/// linear-solver failure, and the step is retried with substeps.
fn imex_failure(e: crate::imex::ImexFailure) -> StageFailure {
    use crate::imex::ImexFailure;
    match e {
        ImexFailure::Sparse(e) => StageFailure::Linear(NonlinearError::Linear(e)),
        ImexFailure::NoLinearPart => StageFailure::NoLinearPart,
    }
}

/// Books a Newton run (successful or not) into the counters and maps the result.
pub(crate) fn account(
    result: Result<NewtonStats, NonlinearError>,
    extra_f_evals: usize,
    stats: &mut Stats,
) -> Result<StageInfo, StageFailure> {
    let ns = match &result {
        Ok(s) => Some(s),
        Err(e) => e.stats(),
    };
    stats.num_lin_rhs_evals += extra_f_evals;
    if let Some(ns) = ns {
        stats.num_rhs_evals += ns.residual_evaluations;
        stats.num_jac_evals += ns.jacobian_evaluations;
        stats.num_nonlin_solv_iters += ns.iterations;
        stats.num_lin_iters += ns.linear_iterations;
        stats.num_lin_solv_setups += ns.linear_setups;
        stats
            .phases
            .add_seconds(ns.jacobian_seconds, ns.setup_seconds, ns.solve_seconds);
    }
    match result {
        Ok(ns) => Ok(StageInfo {
            iterations: ns.iterations,
        }),
        Err(e @ (NonlinearError::LinearNotConverged { .. } | NonlinearError::Linear(_))) => {
            Err(StageFailure::Linear(e))
        }
        Err(NonlinearError::SingularJacobian { pivot, .. }) => {
            Err(StageFailure::Singular { pivot })
        }
        Err(e) if e.is_step_failure() => {
            let (iterations, update_norm) = e
                .stats()
                .map_or((0, f64::NAN), |s| (s.iterations, s.final_step()));
            Err(StageFailure::NoConvergence {
                iterations,
                update_norm,
            })
        }
        Err(e) => Err(StageFailure::Other(e)),
    }
}
