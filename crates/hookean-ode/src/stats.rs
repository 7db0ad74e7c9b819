//! [`Stats`]: the one set of counters of every method, named after CVODE's
//! `CVodeGetNum*` functions; and what one step and one run report
//! ([`StepReport`], [`IntegrateInfo`]).

/// Counters of a run, cumulative since the integrator was built, shared by
/// every method and named after CVODE's `CVodeGetNum*` functions (the
/// statistics of diffsol's `OdeSolverStatistics` likewise serve all of its
/// methods). A counter a method has no use for stays zero.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stats {
    /// Accepted steps (`CVodeGetNumSteps`).
    pub num_steps: usize,
    /// Evaluations of the right-hand side `f` (or of the force), not
    /// counting those for difference-quotient Jacobians and products
    /// (`CVodeGetNumRhsEvals`).
    pub num_rhs_evals: usize,
    /// Evaluations of `f` for difference-quotient Jacobians and
    /// Jacobian-vector products (`CVodeGetNumLinRhsEvals`).
    pub num_lin_rhs_evals: usize,
    /// Jacobian evaluations, analytic or by differences (`CVodeGetNumJacEvals`).
    pub num_jac_evals: usize,
    /// Set-ups of the linear solver of Newton's iteration: LU
    /// factorisations, preconditioner set-ups (`CVodeGetNumLinSolvSetups`).
    pub num_lin_solv_setups: usize,
    /// Newton iterations (`CVodeGetNumNonlinSolvIters`).
    pub num_nonlin_solv_iters: usize,
    /// Step attempts whose Newton iteration (or its linear solver) failed
    /// (`CVodeGetNumNonlinSolvConvFails`).
    pub num_nonlin_solv_conv_fails: usize,
    /// Step attempts rejected by the local error test or the step-size
    /// controller (`CVodeGetNumErrTestFails`).
    pub num_err_test_fails: usize,
    /// Evaluations of event functions (`CVodeGetNumGEvals`).
    pub num_g_evals: usize,
    /// The order of the last step (`CVodeGetLastOrder`; the method's order
    /// for one-step and fixed-order methods).
    pub last_order: usize,
    /// The size of the last step (`CVodeGetLastStep`).
    pub last_step: f64,
    /// Iterations of the iterative linear solver: PCG, GMRES
    /// (`CVodeGetNumLinIters`; 0 for direct solves).
    pub num_lin_iters: usize,
    /// Linear solves that stopped short of their tolerance (`CVodeGetNumLinConvFails`).
    pub num_lin_conv_fails: usize,
    /// Jacobian-vector products by difference quotients (`CVodeGetNumJtimesEvals`).
    pub num_jtimes_evals: usize,
    /// Preconditioner set-ups of a Krylov solver run by the linear solver
    /// (`CVodeGetNumPrecEvals`).
    pub num_prec_evals: usize,
    /// Preconditioner applications of GMRES (`CVodeGetNumPrecSolves`).
    pub num_prec_solves: usize,
    /// Wall time of the Newton solves' phases (assembly, linear-solver
    /// set-up, linear solves) of second-order problems (cloth), where the
    /// integrator clocks them; zero for first-order problems.
    pub phases: crate::phases::PhaseTimes,
}

impl Stats {
    /// Rejected step attempts: Newton failures and error-test failures.
    pub fn num_rejected_steps(&self) -> usize {
        self.num_nonlin_solv_conv_fails + self.num_err_test_fails
    }

    /// Every evaluation of `f`, for the integrator and for its Jacobians:
    /// the work measure of the tutorial's work-precision diagrams.
    pub fn num_rhs_evals_total(&self) -> usize {
        self.num_rhs_evals + self.num_lin_rhs_evals
    }
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
    /// The weighted RMS norm of the local error estimate (variable-step
    /// methods only).
    pub error_estimate: Option<f64>,
    /// The step size proposed for the next step.
    pub h_next: f64,
}

impl StepReport {
    /// The report of the step from `before` to `after` (counter snapshots).
    pub(crate) fn between(
        before: &Stats,
        after: &Stats,
        t: f64,
        h: f64,
        error_estimate: Option<f64>,
        h_next: f64,
    ) -> Self {
        Self {
            t,
            h,
            rejected: after.num_rejected_steps() - before.num_rejected_steps(),
            newton_iterations: after.num_nonlin_solv_iters - before.num_nonlin_solv_iters,
            linear_iterations: after.num_lin_iters - before.num_lin_iters,
            error_estimate,
            h_next,
        }
    }
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
