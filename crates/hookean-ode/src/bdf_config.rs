//! [`BdfConfig`]: the settings that belong to the variable-order BDF alone
//! (the formula, the order limit, the simplified Newton's iteration limit
//! and linear tolerance, the re-use of the Jacobian and of the Newton
//! matrix, the tolerance mapping, the first-order linear solver, the
//! step-size change limits: no hidden constant). The tolerances, step
//! bounds, step cap and retries are [`SolverOptions`](crate::SolverOptions)'.
//!
//! The value travels with the method, [`Method::VariableBdf`](crate::Method::VariableBdf)`(BdfConfig)`,
//! as diffsol's `BdfConfig` travels with its BDF: one door to the engine,
//! and no method's settings inside the options of every method.

use crate::NonExhaustive;
use hookean_sparse::PreconditionerOptions;

use crate::error::OdeError;

/// The highest order of the variable-order BDF.
pub const MAX_ORDER: usize = 5;

/// The exponent of the tolerance mapping ([`BdfConfig::exponent`]) at
/// the default order limit [`MAX_ORDER`]: the local error test runs at
/// `rtol^1.2`. With error per step `tol`, order `k` takes steps
/// `h ~ tol^(1/(k+1))`, so the global error, the sum of the local errors,
/// grows like `tol^(k/(k+1))`; `tol = rtol^((k+1)/k)` makes it follow
/// `rtol`. The steps of the stiff test set are mostly of order 5: `6/5`.
/// (Measured with exponent 1: the error grows like `rtol^0.84..rtol^1.03`
/// and is 2.6 to 45 times `rtol` at `rtol = 1e-8`; with 1.2 at most 4.9
/// times over 25 tolerances from 1e-4 to 1e-8, E5's reference-limited 12.8
/// apart; docs/PERFORMANCE.md, issue 17.)
pub const TOLERANCE_EXPONENT: f64 = 1.2;

/// The multistep family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Formula {
    /// The numerical differentiation formulas of Klopfenstein and Shampine
    /// (more accurate than the BDF at the same stability for orders 1-4).
    #[default]
    Ndf,
    /// The classical backward differentiation formulas.
    Bdf,
}

/// The linear solver of the Newton systems `(I - c J) x = r` of a
/// first-order problem. (Second-order problems always solve the reduced
/// stage equations by PCG, with [`SolverOptions::linear`](crate::SolverOptions::linear).)
#[derive(Debug, Clone, PartialEq, Default)]
pub enum BdfLinearSolver {
    /// LU factors kept across steps: faer's dense LU, or faer's sparse LU
    /// on the problem's pattern when it gives one
    /// ([`FirstOrderProblem::sparse_jacobian_pattern`](crate::FirstOrderProblem::sparse_jacobian_pattern)).
    /// The default.
    #[default]
    Direct,
    /// Matrix-free GMRES(`krylov_dim`) ([Saad-Schultz 1986], hookean-sparse's
    /// [`gmres`](hookean_sparse::gmres) through
    /// [`GmresSolver`](hookean_nonlinear::GmresSolver)): each product
    /// `J v` is one evaluation of `f`, `(f(y + s v) - f(y)) / s` with
    /// `s = 1 / ||v||` (CVODE's difference-quotient `jtimes`); right
    /// preconditioned by a hookean-sparse preconditioner set up on the
    /// sparse `I - c J` when it is kept (the problem must give its sparse
    /// pattern and values unless `preconditioner` is
    /// [`PrecondKind::None`](hookean_sparse::PrecondKind::None)); run on the system scaled by the error
    /// weights and stopped at 0.05 of the Newton tolerance (CVODE's
    /// `eplifac`). The products use the current iterate and `c`, so Newton
    /// is an inexact Newton rather than the simplified one.
    Gmres {
        /// Krylov dimension per cycle (CVODE's `maxl`, 5 there).
        krylov_dim: usize,
        /// Restarts after the first cycle (CVODE's `maxrs`, 0 there).
        restarts: usize,
        /// The preconditioner with its settings, set up on `I - c J`.
        preconditioner: PreconditionerOptions,
    },
}

impl BdfLinearSolver {
    /// GMRES with Krylov dimension 10, two restarts and `preconditioner`
    /// (a [`PrecondKind`](hookean_sparse::PrecondKind) or
    /// [`PreconditionerOptions`]).
    pub fn gmres(preconditioner: impl Into<PreconditionerOptions>) -> Self {
        BdfLinearSolver::Gmres {
            krylov_dim: 10,
            restarts: 2,
            preconditioner: preconditioner.into(),
        }
    }
}

/// The settings of the variable-order BDF
/// ([`Method::VariableBdf`](crate::Method::VariableBdf)). The defaults are meant to serve
/// the whole stiff test set; only the tolerances of
/// [`SolverOptions`](crate::SolverOptions) are problem-dependent.
#[derive(Debug, Clone, PartialEq)]
pub struct BdfConfig {
    /// NDF (default) or BDF.
    pub formula: Formula,
    /// Highest order used, 1 to 5. Default 5. Orders above 2 are not
    /// A-stable (stability angles 86, 73 and 52 degrees for BDF3-5, smaller
    /// for the NDFs): on lightly damped oscillators (springs, whose
    /// eigenvalues lie near the imaginary axis) they hold the step to the
    /// oscillation periods, where 2 lets accuracy alone set it (the scenes'
    /// `integrator.max_order` defaults to 2).
    pub max_order: usize,
    /// Initial step size; `None` (default) for Hairer-Wanner's estimate.
    pub initial_step: Option<f64>,
    /// Newton iterations per attempt at the corrector. Default 4 (SciPy's
    /// `NEWTON_MAXITER`; CVODE's `NLS_MAXCOR` is 3). Not
    /// [`SolverOptions::newton`](crate::SolverOptions::newton)'s `max_iter`
    /// (10 by default, 8 in the scenes), because it means something else
    /// here: the corrector's Newton is simplified, with a Jacobian and a
    /// Newton matrix kept over many steps, and its rate test gives up as soon
    /// as the predicted contraction cannot reach the tolerance within this
    /// many iterations; a failed attempt is cheap (a fresh Jacobian, then
    /// half the step), and the limit sets the step-size safety factor
    /// `0.9 (2 m + 1) / (2 m + iterations)`. The one-step methods' Newton
    /// is the whole solve of a stage, exact or inexact, from a cold start.
    /// The number of failed attempts per step is
    /// [`SolverOptions::max_retries`](crate::SolverOptions::max_retries),
    /// shared with every method.
    pub max_newton_iterations: usize,
    /// Error test failures on one step before the run fails. Default 20
    /// (CVODE's `MXNEF` is 7, SciPy has no limit; 7 stopped Van der Pol at
    /// `rtol = 1.5e-4` in its steep transition, where 20 gets through).
    pub max_error_test_failures: usize,
    /// The Newton matrix `I - c J` is set up again (refactored) when
    /// `|c / c_lu - 1|` exceeds this. Default 0.3 (CVODE's `DGMAX`).
    pub max_gamma_change: f64,
    /// The Newton matrix is set up again after this many steps. Default 20 (CVODE's `MSBP`).
    pub steps_per_factorization: usize,
    /// The Jacobian is re-evaluated after this many steps (CVODE's `MSBJ`,
    /// 50 there). Default `None`: only when Newton fails with a Jacobian of
    /// an earlier step (as SciPy does), which needs fewer evaluations on the
    /// test set at the same accuracy.
    pub steps_per_jacobian: Option<usize>,
    /// The local error test runs with the tolerances
    /// `rtol_local = rtol^p` and `atol_local = atol rtol^(p - 1)` for this
    /// exponent `p` (a tolerance-proportional mapping, as RADAU5 maps its
    /// tolerances): with a local error per step of `rtol_local`, the global
    /// error of order `k` grows like `rtol_local^(k/(k+1))` (times the number
    /// of steps), so `p = (k+1)/k` makes the achieved error follow `rtol`
    /// itself. Default `None`: `(q+1)/q` for the order limit `q =`
    /// [`max_order`](Self::max_order) ([`exponent`](Self::exponent);
    /// [`TOLERANCE_EXPONENT`] = 1.2 at the default limit 5, 1.5 at the
    /// scenes' limit 2, where 1.2 let the error grow like `rtol^0.8` and
    /// left it 1-2 orders of magnitude above `rtol` on the drape,
    /// docs/PERFORMANCE.md). `Some(1.0)` gives the plain error-per-step
    /// control of SciPy and CVODE.
    pub tolerance_exponent: Option<f64>,
    /// The linear solver of first-order problems' Newton systems. Default
    /// [`BdfLinearSolver::Direct`]. (The one-step methods solve first-order
    /// stages by LU only; [`SolverOptions::linear`](crate::SolverOptions::linear)
    /// is the PCG of second-order stages, which this BDF uses as well.)
    pub linear_solver: BdfLinearSolver,
    /// The largest factor by which the step grows after an accepted step.
    /// Default 10 (Shampine-Reichelt's, and SciPy's `MAX_FACTOR`).
    pub max_step_growth: f64,
    /// The smallest factor by which the step shrinks after a failed error
    /// test. Default 0.2 (SciPy's `MIN_FACTOR`).
    pub min_step_shrink: f64,
    /// After an accepted step, the step size and the order are kept while
    /// the proposed factor lies strictly inside this band (CVODE's
    /// hysteresis: the kept Newton matrix stays valid). Default `(0.9, 1.5)`.
    pub keep_step_band: (f64, f64),
    /// The Jacobian is re-evaluated before a step whose `c = h / alpha_k`
    /// exceeds this multiple of the `c` at which it was evaluated. The
    /// Newton matrix `I - c J` errs by `c (J_old - J)`: a Jacobian kept from
    /// a fast transient (a Van der Pol jump, `h ~ 1e-7`) and used at steps
    /// 1e6 times longer can make the simplified Newton iteration take tiny
    /// updates that pass the convergence test without solving the
    /// corrector, and the error estimate, built from those updates, then
    /// accepts a wrong solution. Default 100.
    pub jacobian_c_growth: f64,
    /// The Newton tolerance as a fraction of the local error tolerance (the
    /// error test is `||err|| <= 1` in the same norm), floored at
    /// `10 eps / rtol`. CVODE's test is `0.1 / tq[4]`-scaled, about the
    /// same; SciPy uses `min(0.03, sqrt(rtol))`, which at tight tolerances
    /// costs Newton failures and Jacobians for no measurable gain in
    /// accuracy (docs/PERFORMANCE.md). Default 0.03.
    pub newton_tol: f64,
    /// The relative residual to which PCG solves each Newton correction of a
    /// second-order problem (the preconditioner and iteration limit are
    /// [`SolverOptions::linear`](crate::SolverOptions::linear)'s). The rate
    /// test needs corrections accurate well below its tolerance: a
    /// correction `s` with `|A s + G| <= eta |G|` contracts the Newton
    /// iteration by about `eta` more. Default `1e-3`. Not
    /// [`SolverOptions::newton`](crate::SolverOptions::newton)'s
    /// `linear_rtol`, which the one-step methods' exact Newton solves to
    /// (`1e-10` by default, or the inexact Newton's forcing term): here the
    /// accuracy is set against the rate test's tolerance
    /// ([`newton_tol`](Self::newton_tol)), not against Newton's own stop.
    pub linear_rtol: f64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for BdfConfig {
    fn default() -> Self {
        Self {
            formula: Formula::Ndf,
            max_order: MAX_ORDER,
            initial_step: None,
            max_newton_iterations: 4,
            max_error_test_failures: 20,
            max_gamma_change: 0.3,
            steps_per_factorization: 20,
            steps_per_jacobian: None,
            tolerance_exponent: None,
            linear_solver: BdfLinearSolver::Direct,
            linear_rtol: 1e-3,
            max_step_growth: 10.0,
            min_step_shrink: 0.2,
            keep_step_band: (0.9, 1.5),
            jacobian_c_growth: 100.0,
            newton_tol: 0.03,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> OdeError {
    OdeError::InvalidParameter {
        name,
        value,
        reason,
    }
}

impl BdfConfig {
    /// The exponent `p` of the tolerance mapping `rtol -> rtol^p`
    /// ([`tolerance_exponent`](Self::tolerance_exponent)): the one set, else
    /// `(q+1)/q` for the order limit `q`, so that the global error of the
    /// highest order in use follows `rtol`.
    pub fn exponent(&self) -> f64 {
        self.tolerance_exponent.unwrap_or_else(|| {
            let q = self.max_order.clamp(1, MAX_ORDER) as f64;
            (q + 1.0) / q
        })
    }

    /// Checks every field's range.
    pub(crate) fn check(&self) -> Result<(), OdeError> {
        if !(1..=MAX_ORDER).contains(&self.max_order) {
            return Err(invalid("max_order", self.max_order as f64, "must be 1..=5"));
        }
        if let Some(h0) = self.initial_step
            && !(h0 > 0.0 && h0.is_finite())
        {
            return Err(invalid("initial_step", h0, "must be positive and finite"));
        }
        if !(self.max_gamma_change >= 0.0) {
            return Err(invalid(
                "max_gamma_change",
                self.max_gamma_change,
                "must be non-negative",
            ));
        }
        if let Some(p) = self.tolerance_exponent
            && !(1.0..=2.0).contains(&p)
        {
            return Err(invalid("tolerance_exponent", p, "must be in [1, 2]"));
        }
        if !(self.linear_rtol > 0.0 && self.linear_rtol < 1.0) {
            return Err(invalid(
                "linear_rtol",
                self.linear_rtol,
                "must be in (0, 1)",
            ));
        }
        if !(self.max_step_growth > 1.0 && self.max_step_growth.is_finite()) {
            return Err(invalid(
                "max_step_growth",
                self.max_step_growth,
                "must be finite and greater than 1",
            ));
        }
        if !(self.min_step_shrink > 0.0 && self.min_step_shrink < 1.0) {
            return Err(invalid(
                "min_step_shrink",
                self.min_step_shrink,
                "must be in (0, 1)",
            ));
        }
        let (low, high) = self.keep_step_band;
        if !(low > 0.0 && low <= 1.0) {
            return Err(invalid("keep_step_band.0", low, "must be in (0, 1]"));
        }
        if !(high >= 1.0 && high <= self.max_step_growth) {
            return Err(invalid(
                "keep_step_band.1",
                high,
                "must be in [1, max_step_growth]",
            ));
        }
        if !(self.jacobian_c_growth >= 1.0) {
            return Err(invalid(
                "jacobian_c_growth",
                self.jacobian_c_growth,
                "must be at least 1",
            ));
        }
        if !(self.newton_tol > 0.0 && self.newton_tol < 1.0) {
            return Err(invalid("newton_tol", self.newton_tol, "must be in (0, 1)"));
        }
        if let BdfLinearSolver::Gmres { krylov_dim, .. } = self.linear_solver
            && krylov_dim == 0
        {
            return Err(invalid("krylov_dim", 0.0, "must be at least 1"));
        }
        for (name, v) in [
            ("max_newton_iterations", self.max_newton_iterations),
            ("max_error_test_failures", self.max_error_test_failures),
            ("steps_per_factorization", self.steps_per_factorization),
            ("steps_per_jacobian", self.steps_per_jacobian.unwrap_or(1)),
        ] {
            if v == 0 {
                return Err(invalid(name, 0.0, "must be at least 1"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_exponent_follows_the_order_limit() {
        let mut c = BdfConfig::default();
        // Bitwise the old constant at the default limit: the stiff set's runs are unchanged.
        assert_eq!(c.exponent().to_bits(), TOLERANCE_EXPONENT.to_bits());
        for (q, p) in [(1, 2.0), (2, 1.5), (3, 4.0 / 3.0), (4, 1.25)] {
            c.max_order = q;
            assert_eq!(c.exponent(), p, "order limit {q}");
        }
        c.tolerance_exponent = Some(1.0);
        assert_eq!(c.exponent(), 1.0);
        c.tolerance_exponent = Some(2.5);
        assert!(c.check().is_err());
    }
}
