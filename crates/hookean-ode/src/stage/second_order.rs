//! Second-order problems `M x'' = f(t, x, v)`: the stage equation in the
//! reduced velocity form (docs/ARCHITECTURE.md) as a nonlinear system in
//! the new velocity, with the SPD Newton matrix `M - gh df/dv - gh^2 df/dx`
//! and (filtered) PCG, and [`SecondSys`], the integrators' view of such a
//! problem.

use hookean_nonlinear::{
    Newton, NewtonMethod, NewtonOptions, NonlinearError, NonlinearSystem, PcgSolver,
};
use hookean_problem::SecondOrderProblem;
use hookean_sparse::{AnyPreconditioner, Constraints, SymBlockMatrix};

use super::linearized::LinearizedNewton;
use super::{JacobianSource, StageFailure, StageInfo, System, account, imex_failure};
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::stats::Stats;

/// The reduced velocity form of one stage as a nonlinear system in `V`:
/// `G(V) = P [M (V - psi_v) - gh f(tau, psi_x + gh V, V)]` (`P` removes the
/// constrained components), Jacobian `M - gh df/dv - gh^2 df/dx`.
pub(crate) struct ReducedStage<'a, P> {
    pub problem: &'a P,
    pub tau: f64,
    pub gh: f64,
    pub psi_x: &'a [f64],
    pub psi_v: &'a [f64],
    pub x: &'a mut [f64],
    pub force: &'a mut [f64],
    /// `df/dx` and `df/dv`: evaluated with the Newton matrix at the iterate
    /// ([`JacobianSource::Evaluate`]), or the caller's ([`JacobianSource::Kept`]).
    pub dfdx: &'a mut SymBlockMatrix,
    pub dfdv: &'a mut SymBlockMatrix,
    pub source: JacobianSource,
    pub constraints: &'a Constraints,
    /// Filter every evaluated Newton matrix by the constraints
    /// ([`SolverOptions::filter_matrix`]).
    pub filter_matrix: bool,
}

impl<P: SecondOrderProblem> ReducedStage<'_, P> {
    pub(crate) fn positions(&mut self, v: &[f64]) {
        for i in 0..v.len() {
            self.x[i] = self.psi_x[i] + self.gh * v[i];
        }
    }

    /// `A = M - gh df/dv - gh^2 df/dx` from the `df/dx`, `df/dv` at hand.
    pub(crate) fn assemble(&self, a: &mut SymBlockMatrix) -> Result<(), NonlinearError> {
        let gh = self.gh;
        a.assign_diagonal_plus_combination(
            self.problem.mass(),
            -gh * gh,
            self.dfdx,
            -gh,
            self.dfdv,
        )?;
        Ok(())
    }
}

impl<P: SecondOrderProblem> NonlinearSystem for ReducedStage<'_, P> {
    type Jacobian = SymBlockMatrix;

    fn dim(&self) -> usize {
        self.psi_v.len()
    }

    fn residual(&mut self, v: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.positions(v);
        self.problem.force(self.tau, self.x, v, self.force);
        let mass = self.problem.mass();
        for i in 0..g.len() {
            g[i] = mass[i] * (v[i] - self.psi_v[i]) - self.gh * self.force[i];
        }
        if !self.constraints.is_empty() {
            self.constraints.project(g);
        }
        Ok(())
    }

    /// `A = M - gh df/dv - gh^2 df/dx` at `V`, in one sweep where the
    /// problem has one ([`SecondOrderProblem::step_matrix`]); from the kept
    /// `df/dx`, `df/dv` with [`JacobianSource::Kept`].
    fn jacobian(&mut self, v: &[f64], a: &mut SymBlockMatrix) -> Result<(), NonlinearError> {
        if self.source == JacobianSource::Kept {
            return self.assemble(a);
        }
        self.positions(v);
        let gh = self.gh;
        self.problem
            .step_matrix(self.tau, self.x, v, -gh * gh, -gh, self.dfdx, self.dfdv, a)?;
        if self.filter_matrix {
            self.constraints.filter_matrix(a);
        }
        Ok(())
    }

    fn approximate_jacobian(
        &mut self,
        _v: &[f64],
        a: &mut SymBlockMatrix,
    ) -> Result<bool, NonlinearError> {
        if !self.problem.linearization_is_newton_matrix()
            || !self.problem.linearized_jacobians(self.dfdx, self.dfdv)
        {
            return Ok(false);
        }
        self.assemble(a)?;
        Ok(true)
    }
}

/// Second-order problems in the reduced velocity form (docs/ARCHITECTURE.md): the
/// state is `[x; v]`; the stage `K = [X; V]` satisfies `X = psi_x + gh V`
/// and `G(V) = M (V - psi_v) - gh f(tau, psi_x + gh V, V) = 0`, solved by
/// `hookean-nonlinear`'s Newton with the SPD matrix
/// `A = M - gh df/dv - gh^2 df/dx` and (filtered) PCG.
pub(crate) struct SecondSys<P> {
    pub problem: P,
    pub(super) n: usize,
    pub constraints: Constraints,
    pub(super) dfdx: SymBlockMatrix,
    pub(super) dfdv: SymBlockMatrix,
    pub(super) newton: Newton<SymBlockMatrix, PcgSolver<AnyPreconditioner>>,
    pub(super) last_gh: f64,
    pub(super) force: Vec<f64>,
    pub(super) xs: Vec<f64>,
    /// `V - psi_v` of the last solved stage and its `gh` (NaN: none), the
    /// warm start of the next stage's first linear solve.
    pub(super) last_delta: Vec<f64>,
    pub(super) last_delta_gh: f64,
    /// The mean particle mass.
    pub(super) mean_mass: f64,
    /// The IMEX scheme's matrices and factor (built at its first step).
    pub(super) imex: Option<Box<crate::imex::Imex>>,
    /// Inexact simplified Newton's eq. 50 path (built at its first stage;
    /// `Err(())` once the problem was found to have none).
    pub(super) linearized: Option<Result<Box<LinearizedNewton>, ()>>,
    /// The material revision the kept Jacobian of `newton` belongs to.
    pub(super) revision: u64,
}

/// The velocity form's residual `M (V - psi_v) - gh f` is a momentum: its
/// absolute tolerance is the user's `atol` (a velocity) times the mean mass,
/// so that the same `k/m` converges alike in any mass unit.
pub(super) fn momentum_options(user: &NewtonOptions, mean_mass: f64) -> NewtonOptions {
    NewtonOptions {
        atol: user.atol * mean_mass,
        ..*user
    }
}

impl<P: SecondOrderProblem> SecondSys<P> {
    pub fn new(problem: P, opts: &SolverOptions) -> Result<Self, OdeError> {
        let n = problem.dim();
        if n == 0 {
            return Err(OdeError::InvalidParameter {
                name: "problem.dim()",
                value: 0.0,
                reason: "the problem has no unknowns: there is nothing to integrate",
            });
        }
        let pattern = problem.jacobian_pattern();
        if pattern.dim() != n {
            return Err(OdeError::DimensionMismatch {
                what: "jacobian pattern (3 x blocks)",
                expected: n,
                found: pattern.dim(),
            });
        }
        let linear = PcgSolver::from_options(&opts.linear)?;
        let mass = problem.mass();
        let mean_mass = mass.iter().sum::<f64>() / mass.len().max(1) as f64;
        let mut newton = Newton::new(
            momentum_options(&opts.newton, mean_mass),
            SymBlockMatrix::new(pattern.clone()),
            linear,
        )?;
        // A cloth's Newton iterations take milliseconds: clock their phases.
        newton.time_phases(true);
        Ok(Self {
            n,
            mean_mass,
            constraints: Constraints::new(n / 3),
            dfdx: SymBlockMatrix::new(pattern.clone()),
            dfdv: SymBlockMatrix::new(pattern),
            newton,
            last_gh: f64::NAN,
            force: vec![0.0; n],
            xs: vec![0.0; n],
            last_delta: vec![0.0; n],
            last_delta_gh: f64::NAN,
            imex: None,
            linearized: None,
            revision: problem.material_revision(),
            problem,
        })
    }
}

/// Before the Newton solve of a reduced stage (either Jacobian): one copy of
/// the step's constraints into the linear solver per stage (they change
/// between steps; none is made while both sets are empty), `kv` projected
/// onto them, and with `last_delta` the warm start: the first correction
/// `V_1 - V_0` guessed so that `V_1 - psi_v` repeats the last stage's
/// `V - psi_v`.
pub(crate) fn begin_stage(
    linear: &mut PcgSolver<AnyPreconditioner>,
    constraints: &Constraints,
    kv: &mut [f64],
    psi_v: &[f64],
    last_delta: Option<&Vec<f64>>,
) {
    let solver_has_some = linear.constraints_mut().is_some_and(|c| !c.is_empty());
    if !constraints.is_empty() || solver_has_some {
        linear.copy_constraints(constraints);
    }
    if !constraints.is_empty() {
        constraints.impose(kv);
    }
    if let Some(last) = last_delta {
        let guess = linear.arm_guess(kv.len());
        for (g, ((l, k), p)) in guess.iter_mut().zip(last.iter().zip(kv.iter()).zip(psi_v)) {
            *g = l - (k - p);
        }
    }
}

/// After a converged reduced stage: `kx = psi_x + gh kv` and the warm start's
/// `V - psi_v` for the next stage.
pub(super) fn end_stage(
    kx: &mut [f64],
    kv: &[f64],
    psi_x: &[f64],
    psi_v: &[f64],
    gh: f64,
    last_delta: &mut [f64],
) {
    for i in 0..kv.len() {
        kx[i] = psi_x[i] + gh * kv[i];
        last_delta[i] = kv[i] - psi_v[i];
    }
}

impl<P: SecondOrderProblem> System for SecondSys<P> {
    type Problem = P;

    fn problem(&self) -> &P {
        &self.problem
    }

    fn problem_mut(&mut self) -> &mut P {
        &mut self.problem
    }

    fn constraints(&self) -> Option<&Constraints> {
        Some(&self.constraints)
    }

    fn state_len(&self) -> usize {
        2 * self.n
    }

    fn is_second_order(&self) -> bool {
        true
    }

    fn derivative(&mut self, t: f64, s: &[f64], ds: &mut [f64], stats: &mut Stats) {
        let n = self.n;
        let (x, v) = s.split_at(n);
        let (dx, dv) = ds.split_at_mut(n);
        dx.copy_from_slice(v);
        self.problem.force(t, x, v, dv);
        stats.num_rhs_evals += 1;
        for (a, m) in dv.iter_mut().zip(self.problem.mass()) {
            *a /= m;
        }
        // Constrained directions do not accelerate: their velocities keep
        // the prescribed values.
        if !self.constraints.is_empty() {
            self.constraints.project(dv);
        }
    }

    fn begin_step(&mut self, t: f64, s: &mut [f64]) {
        let (x, v) = s.split_at_mut(self.n);
        self.constraints.clear();
        self.problem.begin_step(t, x, v, &mut self.constraints);
    }

    fn end_step(&mut self, t: f64, h: f64, start: &[f64], s: &mut [f64]) -> bool {
        let (x, v) = s.split_at_mut(self.n);
        self.problem.end_step(t, h, &start[..self.n], x, v)
    }

    fn impose(&self, s: &mut [f64]) {
        if !self.constraints.is_empty() {
            self.constraints.impose(&mut s[self.n..]);
        }
    }

    fn acceleration(
        &mut self,
        t: f64,
        x: &[f64],
        v: &[f64],
        acc: &mut [f64],
        stats: &mut Stats,
    ) -> bool {
        self.problem.force(t, x, v, acc);
        stats.num_rhs_evals += 1;
        for (a, m) in acc.iter_mut().zip(self.problem.mass()) {
            *a /= m;
        }
        if !self.constraints.is_empty() {
            self.constraints.project(acc);
        }
        true
    }

    fn imex_step(
        &mut self,
        t: f64,
        h: f64,
        s: &mut [f64],
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure> {
        use crate::imex::{Imex, ImexFailure};
        if self.imex.is_none() {
            let imex = Imex::new(&self.problem).ok_or(ImexFailure::NoLinearPart);
            self.imex = Some(Box::new(imex.map_err(imex_failure)?));
        }
        let Some(imex) = self.imex.as_mut() else {
            return Err(imex_failure(ImexFailure::NoLinearPart));
        };
        let (x, v) = s.split_at_mut(self.n);
        imex.step(
            &self.problem,
            &self.constraints,
            t,
            h,
            x,
            v,
            &mut self.force,
            stats,
        )
        .map_err(imex_failure)?;
        Ok(StageInfo::default())
    }

    fn save_state(&self, r: &mut crate::StateRecord) -> Result<(), OdeError> {
        self.save_checkpoint(r)
    }

    fn restore_state(
        &mut self,
        r: &crate::StateRecord,
        opts: &SolverOptions,
    ) -> Result<(), OdeError> {
        self.restore_checkpoint(r, opts)
    }

    /// The Newton iterations' PCG; not inexact simplified Newton, whose
    /// eq. 50 path has its own solver on another matrix type.
    fn record_linear_solves(
        &mut self,
        recorder: Option<hookean_nonlinear::SharedRecorder>,
    ) -> bool {
        if matches!(
            self.newton.options().method,
            NewtonMethod::InexactSimplified(_)
        ) {
            return false;
        }
        self.newton.linear_solver_mut().set_recorder(recorder);
        true
    }

    fn solve_stage(
        &mut self,
        tau: f64,
        gh: f64,
        psi: &[f64],
        k: &mut [f64],
        opts: &SolverOptions,
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure> {
        if matches!(opts.newton.method, NewtonMethod::InexactSimplified(_))
            && let Some(result) = self.solve_stage_linearized(tau, gh, psi, k, opts, stats)
        {
            return result;
        }
        let n = self.n;
        // A kept Jacobian (simplified variants) is only valid for this gh
        // and this material.
        let revision = self.problem.material_revision();
        if gh != self.last_gh || revision != self.revision {
            self.newton.invalidate_jacobian();
            self.last_gh = gh;
            self.revision = revision;
        }
        let (psi_x, psi_v) = psi.split_at(n);
        let (kx, kv) = k.split_at_mut(n);
        begin_stage(
            self.newton.linear_solver_mut(),
            &self.constraints,
            kv,
            psi_v,
            (opts.warm_start && self.last_delta_gh == gh).then_some(&self.last_delta),
        );
        let mut stage = ReducedStage {
            problem: &self.problem,
            tau,
            gh,
            psi_x,
            psi_v,
            x: &mut self.xs,
            force: &mut self.force,
            dfdx: &mut self.dfdx,
            dfdv: &mut self.dfdv,
            source: JacobianSource::Evaluate,
            constraints: &self.constraints,
            filter_matrix: opts.filter_matrix
                && matches!(
                    opts.newton.method,
                    NewtonMethod::Exact | NewtonMethod::Inexact(_)
                ),
        };
        let result = self.newton.solve(&mut stage, kv);
        self.newton.linear_solver_mut().disarm_guess();
        let info = account(result, 0, stats)?;
        end_stage(kx, kv, psi_x, psi_v, gh, &mut self.last_delta);
        self.last_delta_gh = gh;
        Ok(info)
    }
}
