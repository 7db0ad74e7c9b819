//! Eq. 50's path of the reduced velocity form: inexact simplified Newton
//! (the tutorial's Algorithm 3) on the isotropic linearised Newton matrix
//! `A = M - gh D - gh^2 K`, kept until `gh` or the material changes.

use hookean_nonlinear::{Newton, NewtonOptions, NonlinearError, NonlinearSystem, PcgSolver};
use hookean_problem::SecondOrderProblem;
use hookean_sparse::{AnyPreconditioner, IsoBlockMatrix, SparseError};

use super::second_order::{SecondSys, end_stage, momentum_options};
use super::{
    JacobianSource, NewtonRecord, ReducedStage, StageFailure, StageInfo, account, begin_stage,
    save_newton,
};
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::snapshot::StateRecord;
use crate::stats::Stats;

/// The stage equation of [`ReducedStage`] with the tutorial's linearised
/// Jacobian (eq. 50) as its Newton matrix, stored isotropically (one
/// scalar per 3x3 block): `A = M - gh D - gh^2 K` with the constant `K`
/// and `D` of [`SecondOrderProblem::linearized_jacobians_iso`]. Inexact
/// simplified Newton (algorithm 3) keeps `A` until `gh` or the material
/// changes, so a Newton iteration costs a force evaluation and CG
/// iterations on a third of the nonzeros, and no assembly.
struct ReducedStageIso<'a, 'b, P> {
    stage: ReducedStage<'a, P>,
    k: &'b IsoBlockMatrix,
    d: &'b IsoBlockMatrix,
    /// The particles' masses (one per particle: isotropic).
    particle_mass: &'b [f64],
}

impl<P: SecondOrderProblem> NonlinearSystem for ReducedStageIso<'_, '_, P> {
    type Jacobian = IsoBlockMatrix;

    fn dim(&self) -> usize {
        self.stage.dim()
    }

    fn residual(&mut self, v: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        self.stage.residual(v, g)
    }

    /// The linearised matrix is the only one this form has.
    fn jacobian(&mut self, v: &[f64], a: &mut IsoBlockMatrix) -> Result<(), NonlinearError> {
        self.approximate_jacobian(v, a).map(|_| ())
    }

    fn approximate_jacobian(
        &mut self,
        _v: &[f64],
        a: &mut IsoBlockMatrix,
    ) -> Result<bool, NonlinearError> {
        linearized_matrix(a, self.k, self.d, self.particle_mass, self.stage.gh)?;
        Ok(true)
    }
}

/// Eq. 50's Newton matrix `A = M - gh D - gh^2 K` (isotropic), into `a`.
fn linearized_matrix(
    a: &mut IsoBlockMatrix,
    k: &IsoBlockMatrix,
    d: &IsoBlockMatrix,
    particle_mass: &[f64],
    gh: f64,
) -> Result<(), SparseError> {
    a.set_zero();
    a.add_scaled(-gh * gh, k)?;
    a.add_scaled(-gh, d)?;
    a.add_to_diagonal(particle_mass)
}

/// Eq. 50's path of [`SecondSys`]: its own Newton on isotropic storage,
/// the constant `K`, `D` and the material revision they belong to.
pub(super) struct LinearizedNewton {
    newton: Newton<IsoBlockMatrix, PcgSolver<AnyPreconditioner>>,
    k: IsoBlockMatrix,
    d: IsoBlockMatrix,
    particle_mass: Vec<f64>,
    revision: u64,
    last_gh: f64,
}

impl LinearizedNewton {
    /// `None` if the problem has no isotropic linearisation or its masses
    /// differ between the coordinates of a particle.
    fn new<P: SecondOrderProblem>(
        problem: &P,
        options: NewtonOptions,
        linear: PcgSolver<AnyPreconditioner>,
    ) -> Result<Option<Self>, NonlinearError> {
        let pattern = problem.jacobian_pattern();
        let mut k = IsoBlockMatrix::new(pattern.clone());
        let mut d = IsoBlockMatrix::new(pattern.clone());
        if !problem.linearized_jacobians_iso(&mut k, &mut d) {
            return Ok(None);
        }
        let mass = problem.mass();
        let (m3, _) = mass.as_chunks::<3>();
        if m3.iter().any(|m| m[0] != m[1] || m[1] != m[2]) {
            return Ok(None);
        }
        let particle_mass = m3.iter().map(|m| m[0]).collect();
        let mut newton = Newton::new(options, IsoBlockMatrix::new(pattern), linear)?;
        newton.time_phases(true);
        Ok(Some(Self {
            newton,
            k,
            d,
            particle_mass,
            revision: problem.material_revision(),
            last_gh: f64::NAN,
        }))
    }
}

impl<P: SecondOrderProblem> SecondSys<P> {
    /// [`System::solve_stage`](super::System::solve_stage) by inexact simplified Newton on eq. 50's
    /// isotropic matrix ([`ReducedStageIso`]), kept until `gh` or the
    /// material revision changes; `None` if the problem has no isotropic
    /// linearisation or it is no Newton matrix
    /// ([`SecondOrderProblem::linearization_is_newton_matrix`]; then the full-block path runs, with
    /// [`SecondOrderProblem::linearized_jacobians`] if it has that).
    pub(super) fn solve_stage_linearized(
        &mut self,
        tau: f64,
        gh: f64,
        psi: &[f64],
        k: &mut [f64],
        opts: &SolverOptions,
        stats: &mut Stats,
    ) -> Option<Result<StageInfo, StageFailure>> {
        if !self.problem.linearization_is_newton_matrix() {
            return None;
        }
        let nopts = momentum_options(&opts.newton, self.mean_mass);
        if self.linearized.is_none() {
            let built = PcgSolver::from_options(&opts.linear)
                .and_then(|linear| LinearizedNewton::new(&self.problem, nopts, linear));
            self.linearized = Some(match built {
                Ok(Some(l)) => Ok(Box::new(l)),
                Ok(None) => Err(()),
                Err(e) => return Some(Err(StageFailure::Other(e))),
            });
        }
        let Some(Ok(lin)) = self.linearized.as_mut() else {
            return None;
        };
        let lin = &mut **lin;
        let revision = self.problem.material_revision();
        if revision != lin.revision {
            if !self
                .problem
                .linearized_jacobians_iso(&mut lin.k, &mut lin.d)
            {
                self.linearized = Some(Err(()));
                return None;
            }
            lin.revision = revision;
            lin.newton.invalidate_jacobian();
        }
        if gh != lin.last_gh {
            lin.newton.invalidate_jacobian();
            lin.last_gh = gh;
        }
        let n = self.n;
        let (psi_x, psi_v) = psi.split_at(n);
        let (kx, kv) = k.split_at_mut(n);
        begin_stage(
            lin.newton.linear_solver_mut(),
            &self.constraints,
            kv,
            psi_v,
            (opts.warm_start && self.last_delta_gh == gh).then_some(&self.last_delta),
        );
        let mut stage = ReducedStageIso {
            stage: ReducedStage {
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
                filter_matrix: false,
            },
            k: &lin.k,
            d: &lin.d,
            particle_mass: &lin.particle_mass,
        };
        let result = lin.newton.solve(&mut stage, kv);
        lin.newton.linear_solver_mut().disarm_guess();
        let info = match account(result, 0, stats) {
            Ok(info) => info,
            Err(e) => return Some(Err(e)),
        };
        end_stage(kx, kv, psi_x, psi_v, gh, &mut self.last_delta);
        self.last_delta_gh = gh;
        Some(Ok(info))
    }
}

impl<P: SecondOrderProblem> SecondSys<P> {
    /// Eq. 50's path in a checkpoint: `sys.lin` is empty (not built yet),
    /// `[0]` (the problem has none) or `[1, gh, revision]`, with its
    /// Newton solver's carried state under `sys.lin`
    /// ([`save_newton`]). Its kept matrix is not saved: `K`, `D` are the
    /// model's constants at its material revision, so `M - gh D - gh^2 K`
    /// is rebuilt bit for bit from `gh`.
    pub(super) fn save_linearized(&self, r: &mut StateRecord) -> Result<(), OdeError> {
        match &self.linearized {
            None => r.put("sys.lin", &[]),
            Some(Err(())) => r.put("sys.lin", &[0.0]),
            Some(Ok(lin)) => {
                r.put("sys.lin", &[1.0, lin.last_gh, lin.revision as f64]);
                save_newton(&lin.newton, "sys.lin", r)?;
            }
        }
        Ok(())
    }

    /// Eq. 50's path as [`save_linearized`](Self::save_linearized) saved
    /// it, built again from the (restored) problem and `opts`, its kept
    /// matrix rebuilt from the saved `gh`.
    pub(super) fn restored_linearized(
        &self,
        r: &StateRecord,
        opts: &SolverOptions,
    ) -> Result<Option<Result<Box<LinearizedNewton>, ()>>, OdeError> {
        let (gh, revision) = match r.get("sys.lin")? {
            [] => return Ok(None),
            [0.0] => return Ok(Some(Err(()))),
            &[1.0, gh, revision] if revision >= 0.0 && revision.fract() == 0.0 => (gh, revision),
            _ => {
                return Err(OdeError::Checkpoint {
                    reason: "entry `sys.lin` is malformed".into(),
                });
            }
        };
        let nopts = momentum_options(&opts.newton, self.mean_mass);
        let linear = PcgSolver::from_options(&opts.linear)?;
        let Some(mut lin) = LinearizedNewton::new(&self.problem, nopts, linear)? else {
            return Err(OdeError::Checkpoint {
                reason: "it has eq. 50's linearised Newton matrix, this problem has none".into(),
            });
        };
        let record = NewtonRecord::read(
            r,
            "sys.lin",
            lin.newton.jacobian().pattern(),
            lin.newton.linear_solver(),
        )?;
        lin.last_gh = gh;
        lin.revision = revision as u64;
        let (k, d, mass) = (&lin.k, &lin.d, &lin.particle_mass);
        let mut failed = None;
        record.restore(&mut lin.newton, self.n, |a| {
            failed = linearized_matrix(a, k, d, mass, gh).err();
        })?;
        if let Some(e) = failed {
            return Err(e.into());
        }
        Ok(Some(Ok(Box::new(lin))))
    }
}
