//! The corrector of one BDF step, `d = c F(t, y^(0) + d) - psi` for the
//! new point `K = y^(0) + d` (the order-`k` formula with `c = h / alpha_k`;
//! the stage `K = (y^(0) - psi) + c F(t, K)`), solved by `hookean-nonlinear`'s
//! simplified Newton with CVODE's rate test: the part of the variable-order
//! BDF that depends on the problem's kind. First-order problems
//! (`first_order.rs`) solve it on `I - c J` (dense or sparse LU, or GMRES);
//! second-order ones (`second_order.rs`) in the reduced velocity form on
//! `M - c df/dv - c^2 df/dx` with PCG.

use hookean_nonlinear::{
    LinearSolveStats, LinearSolver, NewtonMethod, NewtonOptions, NonlinearError,
};

use crate::bdf_config::BdfConfig;
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::stage::System;
use crate::stats::Stats;

/// One step's data for the corrector.
pub(crate) struct CorrectorStep<'a> {
    /// The time `t_{n+1}` of the new point.
    pub t: f64,
    /// `c = h / alpha_k`.
    pub c: f64,
    /// Set up the Newton matrix again (with the kept Jacobian and this `c`)
    /// before the iteration.
    pub refactor: bool,
    /// The contraction rate of the Newton iteration when it is known: `0`
    /// for a linear problem (a constant Jacobian) with the Newton matrix
    /// set up at this `c`, whose first correction solves the corrector.
    pub known_rate: Option<f64>,
    /// CVODE's correction `2 / (1 + c / c_lu)` of an update solved with a
    /// Newton matrix factored at `c_lu != c` (1 otherwise).
    pub scale: f64,
    /// The predictor `y^(0)`.
    pub y_pred: &'a [f64],
    /// `psi = sum_{j=1..k} gamma_j D_j / alpha_k`: the corrector is
    /// `d = c F(t, y^(0) + d) - psi` for the correction `d = K - y^(0)`.
    pub psi: &'a [f64],
    /// The error weights `w_i = atol_i + rtol |y^(0)_i|` of the rate test.
    pub weights: &'a [f64],
}

/// How one attempt at the corrector ended.
#[derive(Debug)]
pub(crate) enum Attempt {
    /// Converged after this many iterations; `dcor = K - y^(0)` written.
    Converged(usize),
    /// Failed (diverging or too slow, a non-finite value, a singular or
    /// unusable Newton matrix): the step is retried; `cause` keeps a
    /// linear-solver error for the report should the run fail.
    Failed {
        iterations: usize,
        update_norm: f64,
        cause: Option<NonlinearError>,
    },
}

impl Attempt {
    /// Maps a Newton result: step failures are attempts to retry, other
    /// errors (sizes, the problem's own) end the run.
    #[inline]
    pub fn from_newton<T>(
        result: Result<T, NonlinearError>,
        converged: impl FnOnce(T) -> usize,
        t: f64,
    ) -> Result<Self, OdeError> {
        match result {
            Ok(v) => Ok(Attempt::Converged(converged(v))),
            Err(e) if e.is_step_failure() || matches!(e, NonlinearError::Linear(_)) => {
                let (iterations, update_norm) = e
                    .stats()
                    .map_or((0, f64::NAN), |s| (s.iterations, s.final_step()));
                let linear = matches!(
                    e,
                    NonlinearError::Linear(_)
                        | NonlinearError::LinearNotConverged { .. }
                        | NonlinearError::SingularJacobian { .. }
                );
                Ok(Attempt::Failed {
                    iterations,
                    update_norm,
                    cause: linear.then_some(e),
                })
            }
            Err(source) => Err(OdeError::NewtonSolver { t, source }),
        }
    }
}

/// The corrector of a problem kind: its Newton, the Jacobian it keeps and
/// its scratch ([`Corrector::Data`]), created once per solver.
pub(crate) trait Corrector: System {
    /// The corrector's Newton solver, kept Jacobian and work vectors.
    type Data;

    /// The corrector for a run with `opts` and the BDF's `config`;
    /// `newton_tol` is the rate test's tolerance, `atol` and `rtol` the
    /// (mapped) error tolerances.
    fn corrector(
        &self,
        opts: &SolverOptions,
        config: &BdfConfig,
        newton_tol: f64,
        atol: &[f64],
        rtol: f64,
    ) -> Result<Self::Data, OdeError>;

    /// Evaluates the Jacobian at `(t, y)` and keeps it (a no-op for a
    /// matrix-free solver without a preconditioner); `Ok(false)` if it is
    /// not finite (a recoverable failure: the step is retried smaller).
    fn evaluate_jacobian(
        &mut self,
        data: &mut Self::Data,
        t: f64,
        y: &[f64],
        stats: &mut Stats,
    ) -> Result<bool, OdeError>;

    /// Whether the last two Jacobian evaluations gave the same values
    /// bitwise: the problem is linear (affine) in the state, at least where
    /// it has been.
    fn jacobian_is_constant(data: &Self::Data) -> bool;

    /// Solves the corrector from `d = 0`, writing `dcor = d = K - y^(0)`
    /// on success.
    fn solve_corrector(
        &mut self,
        data: &mut Self::Data,
        step: &CorrectorStep<'_>,
        dcor: &mut [f64],
        stats: &mut Stats,
    ) -> Result<Attempt, OdeError>;

    /// Adds what the corrector carries from step to step (its Newton
    /// solver's state, the kept Jacobian and Newton matrix) to a checkpoint.
    ///
    /// # Errors
    /// [`OdeError::NoCheckpoint`] for a corrector that is not covered (the
    /// default).
    fn save_corrector(
        &self,
        data: &Self::Data,
        record: &mut crate::StateRecord,
    ) -> Result<(), OdeError> {
        let _ = (data, record);
        Err(crate::snapshot::not_covered(
            "the variable-order BDF on first-order problems",
        ))
    }

    /// Restores [`save_corrector`](Self::save_corrector).
    ///
    /// # Errors
    /// As [`save_corrector`](Self::save_corrector); [`OdeError::Checkpoint`]
    /// for a record that does not fit.
    fn restore_corrector(
        &mut self,
        data: &mut Self::Data,
        record: &crate::StateRecord,
    ) -> Result<(), OdeError> {
        let _ = (data, record);
        Err(crate::snapshot::not_covered(
            "the variable-order BDF on first-order problems",
        ))
    }
}

/// The options of the corrector's Newton: simplified Newton (the matrix is
/// kept across steps until the BDF's rules set it up again, never
/// refreshed or retried by Newton itself) with CVODE's rate test at `tol`
/// and at most `max_iter` iterations; linear solves to `linear_rtol`.
pub(crate) fn newton_options(tol: f64, max_iter: usize, linear_rtol: f64) -> NewtonOptions {
    NewtonOptions {
        method: NewtonMethod::Simplified,
        convergence: hookean_nonlinear::Convergence::Rate { tol },
        max_iter,
        linear_rtol,
        refresh_theta: f64::INFINITY,
        keep_jacobian_theta: f64::INFINITY,
        retry_fresh: false,
        ..NewtonOptions::default()
    }
}

/// A direct solver of a Newton matrix factored at `c_lu`, used at `c`: its
/// solution scaled by `2 / (1 + c / c_lu)` (CVODE's correction for a stale
/// `gamma`, `cvNlsLSolve`).
#[derive(Debug)]
pub(crate) struct Rescaled<L> {
    pub inner: L,
    pub scale: f64,
}

impl<J, L: LinearSolver<J>> LinearSolver<J> for Rescaled<L> {
    fn setup(&mut self, jac: &J) -> Result<(), NonlinearError> {
        self.inner.setup(jac)
    }

    fn solve(
        &mut self,
        jac: &J,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let stats = self.inner.solve(jac, rhs, x, rtol)?;
        if self.scale != 1.0 {
            for v in x.iter_mut() {
                *v *= self.scale;
            }
        }
        Ok(stats)
    }

    fn is_direct(&self) -> bool {
        self.inner.is_direct()
    }
}

/// Books a corrector's Newton run into the counters.
pub(crate) fn account(ns: Option<&hookean_nonlinear::NewtonStats>, stats: &mut Stats) {
    if let Some(ns) = ns {
        stats.num_rhs_evals += ns.residual_evaluations;
        stats.num_nonlin_solv_iters += ns.iterations;
        stats.num_lin_solv_setups += ns.linear_setups;
        stats.num_lin_iters += ns.linear_iterations;
    }
}
