//! [`NewtonStats`]: what one [`Newton::solve`](crate::Newton::solve) did.

/// Which test declared convergence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConvergedBy {
    /// `|G(Y_k)| <= atol + rtol |G(Y_0)|`.
    Residual,
    /// `|s_k| theta_k / (1 - theta_k) <= step_tol`.
    Step,
    /// The rate test of [`Convergence::Rate`](crate::Convergence::Rate).
    Rate,
}

/// Statistics of one [`Newton::solve`](crate::Newton::solve) call: plain
/// counters, the first and last norms, and, with
/// [`NewtonOptions::record_history`](crate::NewtonOptions::record_history),
/// the histories.
///
/// Histories hold one entry per evaluation, in order; they include the
/// attempt that failed when a kept Jacobian was refreshed and the solve
/// restarted ([`restarts`](Self::restarts)).
#[derive(Debug, Clone, PartialEq)]
pub struct NewtonStats {
    /// Newton iterations (linear solves and updates `Y <- Y + s`).
    pub iterations: usize,
    /// Evaluations of `G`.
    pub residual_evaluations: usize,
    /// Evaluations of the Jacobian (exact or approximate).
    pub jacobian_evaluations: usize,
    /// Linear-solver setups (factorisations, preconditioner setups).
    pub linear_setups: usize,
    /// Linear iterations in total (CG iterations; 0 for direct solvers).
    pub linear_iterations: usize,
    /// `|G(Y_k)|` for `k = 0, 1, ...` (recorded histories only).
    pub residual_norms: Vec<f64>,
    /// `|s_k|` for `k = 0, 1, ...` (recorded histories only; in the weighted
    /// norm for [`Convergence::Rate`](crate::Convergence::Rate)).
    pub step_norms: Vec<f64>,
    /// The forcing terms `eta_k` handed to the linear solver (recorded
    /// histories only; empty for direct solvers, `linear_rtol` for the exact
    /// variants).
    pub forcing_terms: Vec<f64>,
    /// The last contraction rate `theta_k = |s_k| / |s_{k-1}|` (`None`
    /// before the second iteration): the convergence rate estimate.
    pub contraction_rate: Option<f64>,
    /// Which test stopped the iteration (`None` unless converged).
    pub converged_by: Option<ConvergedBy>,
    /// Whether the solve started with a Jacobian kept from an earlier call.
    pub jacobian_reused: bool,
    /// Restarts from `Y_0` with a fresh Jacobian after a failure with a kept one.
    pub restarts: usize,
    /// Linear solves truncated on a direction of non-positive curvature
    /// ([`PcgOptions::negative_curvature`](crate::PcgOptions::negative_curvature))
    /// whose iterate so far was taken as the correction, with a backtracking
    /// line search on `|G|`.
    pub truncated_solves: usize,
    /// Wall time of the Jacobian evaluations (assembly), seconds; recorded
    /// only when [`Newton::time_phases`](crate::Newton::time_phases) is on.
    pub jacobian_seconds: f64,
    /// Wall time of the linear solver's set-ups (factorisations,
    /// preconditioner set-ups), seconds; as `jacobian_seconds`.
    pub setup_seconds: f64,
    /// Wall time of the linear solves, seconds; as `jacobian_seconds`.
    pub solve_seconds: f64,
    /// `|G(Y_0)|` and the last `|G(Y_k)|` computed.
    first_residual: Option<f64>,
    last_residual: f64,
    /// The last `|s_k|` (NaN before any).
    last_step: f64,
    record: bool,
}

impl Default for NewtonStats {
    fn default() -> Self {
        Self {
            iterations: 0,
            residual_evaluations: 0,
            jacobian_evaluations: 0,
            linear_setups: 0,
            linear_iterations: 0,
            residual_norms: Vec::new(),
            step_norms: Vec::new(),
            forcing_terms: Vec::new(),
            contraction_rate: None,
            converged_by: None,
            jacobian_reused: false,
            restarts: 0,
            truncated_solves: 0,
            jacobian_seconds: 0.0,
            setup_seconds: 0.0,
            solve_seconds: 0.0,
            first_residual: None,
            last_residual: f64::NAN,
            last_step: f64::NAN,
            record: false,
        }
    }
}

impl NewtonStats {
    /// Empty statistics; with `record`, histories with room for `max_iter`
    /// iterations (this allocates).
    #[inline]
    pub(crate) fn new(max_iter: usize, record: bool) -> Self {
        if !record {
            return Self::default();
        }
        // At most 16 iterations reserved: the histories grow as they go, so an
        // iteration limit of 10^9 does not reserve 10^9 entries (issue 28).
        let cap = max_iter.min(16) + 1;
        Self {
            residual_norms: Vec::with_capacity(cap),
            step_norms: Vec::with_capacity(cap),
            forcing_terms: Vec::with_capacity(cap),
            record,
            ..Self::default()
        }
    }

    #[inline]
    pub(crate) fn push_residual(&mut self, norm: f64) {
        self.first_residual.get_or_insert(norm);
        self.last_residual = norm;
        if self.record {
            self.residual_norms.push(norm);
        }
    }

    #[inline]
    pub(crate) fn push_step(&mut self, norm: f64) {
        self.last_step = norm;
        if self.record {
            self.step_norms.push(norm);
        }
    }

    /// Shortens the last step norm by the line search's factor.
    pub(crate) fn scale_last_step(&mut self, lambda: f64) {
        self.last_step *= lambda;
        if let Some(last) = self.step_norms.last_mut() {
            *last *= lambda;
        }
    }

    pub(crate) fn push_forcing(&mut self, eta: f64) {
        if self.record {
            self.forcing_terms.push(eta);
        }
    }

    /// The last residual norm `|G(Y_k)|` (NaN if none was computed).
    pub fn final_residual(&self) -> f64 {
        self.last_residual
    }

    /// `|G(Y_0)|` (NaN if none was computed).
    pub fn initial_residual(&self) -> f64 {
        self.first_residual.unwrap_or(f64::NAN)
    }

    /// The last correction norm `|s_k|` (NaN if none was computed).
    pub fn final_step(&self) -> f64 {
        self.last_step
    }

    /// Whether the solve converged.
    pub fn converged(&self) -> bool {
        self.converged_by.is_some()
    }
}
