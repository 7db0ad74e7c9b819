//! The BDF corrector of a second-order problem `M x'' = f(t, x, v)`, whose
//! state is `y = [x; v]` and right-hand side `F(t, y) = [v; M^-1 f]`.
//!
//! The corrector `K = psi + c F(t, K)` in its halves, `X = psi_x + c V` and
//! `V = psi_v + c M^-1 f(t, X, V)`, is the implicit stage of the reduced
//! velocity form (`stage/second_order.rs`) with `gh = c`:
//! `G(V) = M (V - psi_v) - c f(t, psi_x + c V, V) = 0`, with the sparse SPD
//! Newton matrix `M - c df/dv - c^2 df/dx` on the model's 3x3-block pattern
//! and (filtered) PCG, where the first-order form would need a dense
//! `2n x 2n` LU. The Jacobians `df/dx`, `df/dv` are evaluated at the
//! predictor and kept by the BDF's rules; the Newton matrix is assembled
//! from them with the current `c` when it is set up.
//!
//! CVODE's rate test measures the corrections of the whole state
//! `[c dV; dV]`; in the weighted RMS norm over `2n` components that is the
//! norm over the `n` velocity corrections with the weights
//! `w_i = sqrt(2) / sqrt(c^2 / w_x,i^2 + 1 / w_v,i^2)`.

use hookean_nonlinear::{Newton, PcgSolver};
use hookean_problem::SecondOrderProblem;
use hookean_sparse::{AnyPreconditioner, SymBlockMatrix};

use super::corrector::{Attempt, Corrector, CorrectorStep, account, newton_options};
use crate::bdf_config::BdfConfig;
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::stage::{
    JacobianSource, NewtonRecord, ReducedStage, SecondSys, begin_stage, matrix_entry,
    matrix_values, save_newton, set_matrix_values,
};
use crate::stats::Stats;

/// The Newton solver, the kept Jacobians and the work vectors of a
/// second-order BDF corrector.
pub(crate) struct SecondCorrector {
    newton: Newton<SymBlockMatrix, PcgSolver<AnyPreconditioner>>,
    dfdx: SymBlockMatrix,
    dfdv: SymBlockMatrix,
    /// The values of the previous Jacobian evaluation (`df/dx` then
    /// `df/dv`), and whether the last one repeated them.
    previous: Vec<f64>,
    constant: bool,
    /// The new velocity `V` (Newton's unknown), the stage's `psi`,
    /// positions, force.
    v: Vec<f64>,
    psi: Vec<f64>,
    x: Vec<f64>,
    force: Vec<f64>,
}

impl<P: SecondOrderProblem> Corrector for SecondSys<P> {
    type Data = SecondCorrector;

    fn corrector(
        &self,
        opts: &SolverOptions,
        config: &BdfConfig,
        newton_tol: f64,
        _atol: &[f64],
        _rtol: f64,
    ) -> Result<SecondCorrector, OdeError> {
        let problem = &self.problem;
        let n = problem.dim();
        let pattern = problem.jacobian_pattern();
        let options = newton_options(newton_tol, config.max_newton_iterations, config.linear_rtol);
        let linear = PcgSolver::from_options(&opts.linear)?;
        let mut newton = Newton::new(options, SymBlockMatrix::new(pattern.clone()), linear)?;
        newton.time_phases(true);
        Ok(SecondCorrector {
            newton,
            dfdx: SymBlockMatrix::new(pattern.clone()),
            dfdv: SymBlockMatrix::new(pattern),
            previous: Vec::new(),
            constant: false,
            v: vec![0.0; n],
            psi: vec![0.0; 2 * n],
            x: vec![0.0; n],
            force: vec![0.0; n],
        })
    }

    fn evaluate_jacobian(
        &mut self,
        data: &mut SecondCorrector,
        t: f64,
        y: &[f64],
        stats: &mut Stats,
    ) -> Result<bool, OdeError> {
        stats.num_jac_evals += 1;
        let (x, v) = y.split_at(y.len() / 2);
        self.problem
            .force_jacobians(t, x, v, &mut data.dfdx, &mut data.dfdv);
        let values = || {
            data.dfdx
                .values()
                .iter()
                .chain(data.dfdv.values())
                .flatten()
                .flatten()
                .copied()
        };
        let finite = values().all(|v| v.is_finite());
        let constant = finite && data.previous.iter().copied().eq(values());
        let mut previous = std::mem::take(&mut data.previous);
        previous.clear();
        previous.extend(values());
        data.previous = previous;
        data.constant = constant;
        Ok(finite)
    }

    fn jacobian_is_constant(data: &SecondCorrector) -> bool {
        data.constant
    }

    fn solve_corrector(
        &mut self,
        data: &mut SecondCorrector,
        step: &CorrectorStep<'_>,
        dcor: &mut [f64],
        stats: &mut Stats,
    ) -> Result<Attempt, OdeError> {
        let n = data.v.len();
        let c = step.c;
        let (w_x, w_v) = step.weights.split_at(n);
        let weights = data.newton.weights_mut(n);
        for ((w, wx), wv) in weights.iter_mut().zip(w_x).zip(w_v) {
            *w = 2f64.sqrt() / ((c / wx).powi(2) + (1.0 / wv).powi(2)).sqrt();
        }
        if step.refactor {
            data.newton.invalidate_jacobian();
        }
        data.newton.set_known_rate(step.known_rate);
        // The stage `K = psi + c F(t, K)` with `psi = y^(0) - psi_bdf`.
        for ((p, y), q) in data.psi.iter_mut().zip(step.y_pred).zip(step.psi) {
            *p = y - q;
        }
        let (psi_x, psi_v) = data.psi.split_at(n);
        data.v.copy_from_slice(&step.y_pred[n..]);
        begin_stage(
            data.newton.linear_solver_mut(),
            &self.constraints,
            &mut data.v,
            psi_v,
            None,
        );
        let mut stage = ReducedStage {
            problem: &self.problem,
            tau: step.t,
            gh: c,
            psi_x,
            psi_v,
            x: &mut data.x,
            force: &mut data.force,
            dfdx: &mut data.dfdx,
            dfdv: &mut data.dfdv,
            source: JacobianSource::Kept,
            constraints: &self.constraints,
            filter_matrix: false,
        };
        let result = data.newton.solve(&mut stage, &mut data.v);
        account(
            match &result {
                Ok(s) => Some(s),
                Err(e) => e.stats(),
            },
            stats,
        );
        let attempt = Attempt::from_newton(result, |ns| ns.iterations, step.t)?;
        if let Attempt::Converged(_) = attempt {
            let (dx, dv) = dcor.split_at_mut(n);
            let (x_pred, v_pred) = step.y_pred.split_at(n);
            for i in 0..n {
                dx[i] = psi_x[i] + c * data.v[i] - x_pred[i];
                dv[i] = data.v[i] - v_pred[i];
            }
        }
        Ok(attempt)
    }

    /// The corrector's Newton solver under `bdf.corrector`
    /// ([`save_newton`]), its kept Newton matrix `M - c df/dv - c^2 df/dx`
    /// (`bdf.corrector.kept`, its values, empty for none) and the kept
    /// Jacobians `df/dx`, `df/dv` (`bdf.corrector.jacobians`: the values of
    /// the last evaluation, which is also what the next evaluation is
    /// compared with to find a constant Jacobian; empty before the first)
    /// with that comparison's result. `V`, `psi`, the positions and the
    /// force are written before they are read.
    fn save_corrector(
        &self,
        data: &SecondCorrector,
        r: &mut crate::StateRecord,
    ) -> Result<(), OdeError> {
        save_newton(&data.newton, "bdf.corrector", r)?;
        let kept = if data.newton.jacobian_is_kept() {
            matrix_values(data.newton.jacobian())
        } else {
            Vec::new()
        };
        r.put("bdf.corrector.kept", &kept);
        r.put("bdf.corrector.jacobians", &data.previous);
        r.put_scalar("bdf.corrector.constant", f64::from(u8::from(data.constant)));
        Ok(())
    }

    fn restore_corrector(
        &mut self,
        data: &mut SecondCorrector,
        r: &crate::StateRecord,
    ) -> Result<(), OdeError> {
        let pattern = data.newton.jacobian().pattern().clone();
        let newton = NewtonRecord::read(r, "bdf.corrector", &pattern, data.newton.linear_solver())?;
        let kept = matrix_entry(r, "bdf.corrector.kept", &pattern)?;
        let jacobians = r.get("bdf.corrector.jacobians")?;
        let blocks = 9 * pattern.col_idx().len();
        if newton.kept() == kept.is_empty()
            || !(jacobians.is_empty() || jacobians.len() == 2 * blocks)
        {
            return Err(OdeError::Checkpoint {
                reason: "the BDF corrector's entries do not fit this run's matrices".into(),
            });
        }
        let constant = r.flag("bdf.corrector.constant")?;
        newton.restore(&mut data.newton, data.v.len(), |a| {
            set_matrix_values(a, kept);
        })?;
        if !jacobians.is_empty() {
            let (dfdx, dfdv) = jacobians.split_at(blocks);
            set_matrix_values(&mut data.dfdx, dfdx);
            set_matrix_values(&mut data.dfdv, dfdv);
        }
        data.previous.clear();
        data.previous.extend_from_slice(jacobians);
        data.constant = constant;
        Ok(())
    }
}
