//! The BDF corrector of a first-order problem `y' = f(t, y)`: the stage
//! equation of `stage/first_order.rs` for the correction to the predictor,
//! `G(d) = d + psi - c f(t, y^(0) + d)`, on the Newton matrix `I - c J`
//! with `J` kept across steps, solved by simplified Newton with faer's dense
//! LU, faer's sparse LU on the problem's pattern, or matrix-free GMRES
//! (CVODE's choices).

use hookean_nonlinear::{DenseLu, GmresSolver, LinearSolver, Newton, SparseLu};
use hookean_problem::FirstOrderProblem;
use hookean_sparse::vecops::negate_into;
use hookean_sparse::{GmresParams, PrecondKind};

use super::corrector::{Attempt, Corrector, CorrectorStep, Rescaled, account, newton_options};
use crate::bdf_config::{BdfConfig, BdfLinearSolver};
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::stage::{
    FirstStage, FirstSys, JacobianSource, SparseFirstStage, diagonal_positions,
    forward_difference_jacobian,
};
use crate::stats::Stats;

/// GMRES stops at this fraction of the Newton tolerance (CVODE's `eplifac`).
const KRYLOV_TOL_FACTOR: f64 = 0.05;

/// The Newton solver and the kept Jacobian of a first-order BDF corrector.
pub(crate) struct FirstCorrector {
    matrices: Matrices,
    /// `-psi` (the stage's constant relative to the predictor), the point
    /// `y^(0) + d`, `f` there, scratch.
    neg_psi: Vec<f64>,
    y: Vec<f64>,
    f: Vec<f64>,
    tmp: Vec<f64>,
    col: Vec<f64>,
    /// The mapped tolerances, for the increments of difference-quotient Jacobians.
    atol: Vec<f64>,
    rtol: f64,
    /// The values of the previous Jacobian evaluation, and whether the
    /// last one repeated them.
    previous: Vec<f64>,
    constant: bool,
}

/// The Newton matrix `I - c J` and its solver.
enum Matrices {
    /// faer's dense LU; `jac` is `J`, row-major.
    Dense {
        newton: Box<Newton<faer::Mat<f64>, Rescaled<DenseLu>>>,
        jac: Vec<f64>,
    },
    /// faer's sparse LU on the problem's pattern.
    Sparse {
        newton: Box<Newton<sprs::CsMat<f64>, Rescaled<SparseLu>>>,
        jac: sprs::CsMat<f64>,
        diag: Vec<usize>,
    },
    /// Matrix-free GMRES; `jac` is the pattern's `J` for the
    /// preconditioner, or empty without one.
    Krylov {
        newton: Box<Newton<sprs::CsMat<f64>, GmresSolver>>,
        jac: sprs::CsMat<f64>,
        diag: Vec<usize>,
        y_pert: Vec<f64>,
        f_pert: Vec<f64>,
    },
}

/// Refills the sparse Jacobian `jac` (of `nnz` entries) at `(t, y)`.
fn sparse_jacobian<P: FirstOrderProblem>(
    problem: &P,
    t: f64,
    y: &[f64],
    jac: &mut sprs::CsMat<f64>,
    nnz: usize,
) -> Result<(), OdeError> {
    if !problem.jacobian_sparse(t, y, jac) {
        return Err(OdeError::InvalidParameter {
            name: "jacobian_sparse",
            value: t,
            reason: "the problem gave a sparse Jacobian pattern but no values",
        });
    }
    if jac.nnz() != nnz {
        return Err(OdeError::DimensionMismatch {
            what: "sparse Jacobian entries (jacobian_sparse changed the pattern)",
            expected: nnz,
            found: jac.nnz(),
        });
    }
    Ok(())
}

impl<P: FirstOrderProblem> Corrector for FirstSys<P> {
    type Data = FirstCorrector;

    fn corrector(
        &self,
        _opts: &SolverOptions,
        config: &BdfConfig,
        newton_tol: f64,
        atol: &[f64],
        rtol: f64,
    ) -> Result<FirstCorrector, OdeError> {
        let problem = &self.problem;
        let n = problem.dim();
        let pattern = problem.sparse_jacobian_pattern();
        let options = newton_options(newton_tol, config.max_newton_iterations, 0.0);
        let matrices = match (&config.linear_solver, pattern) {
            (
                BdfLinearSolver::Gmres {
                    krylov_dim,
                    restarts,
                    preconditioner,
                },
                pattern,
            ) => {
                let (jac, diag) = match (preconditioner.kind, pattern) {
                    (PrecondKind::None, _) => (sprs::CsMat::zero((n, n)), Vec::new()),
                    (_, None) => {
                        return Err(OdeError::InvalidParameter {
                            name: "linear_solver",
                            value: f64::NAN,
                            reason: "a GMRES preconditioner needs the problem's sparse Jacobian pattern",
                        });
                    }
                    (_, Some(pattern)) => {
                        let diag = diagonal_positions(&pattern, n)?;
                        (pattern, diag)
                    }
                };
                let params = GmresParams {
                    krylov_dim: *krylov_dim,
                    restarts: *restarts,
                    rtol: 0.0,
                    atol: KRYLOV_TOL_FACTOR * newton_tol * (n as f64).sqrt(),
                    ..Default::default()
                };
                let gmres = GmresSolver::new(params, preconditioner)?.matrix_free();
                Matrices::Krylov {
                    newton: Box::new(Newton::new(options, jac.clone(), gmres)?),
                    jac,
                    diag,
                    y_pert: vec![0.0; n],
                    f_pert: vec![0.0; n],
                }
            }
            (BdfLinearSolver::Direct, None) => Matrices::Dense {
                newton: Box::new(Newton::new(
                    options,
                    faer::Mat::zeros(n, n),
                    Rescaled {
                        inner: DenseLu::new(),
                        scale: 1.0,
                    },
                )?),
                jac: vec![0.0; n * n],
            },
            (BdfLinearSolver::Direct, Some(pattern)) => {
                let diag = diagonal_positions(&pattern, n)?;
                Matrices::Sparse {
                    newton: Box::new(Newton::new(
                        options,
                        pattern.clone(),
                        Rescaled {
                            inner: SparseLu::new(),
                            scale: 1.0,
                        },
                    )?),
                    jac: pattern,
                    diag,
                }
            }
        };
        Ok(FirstCorrector {
            matrices,
            neg_psi: vec![0.0; n],
            y: vec![0.0; n],
            f: vec![0.0; n],
            tmp: vec![0.0; n],
            col: vec![0.0; n],
            atol: atol.to_vec(),
            rtol,
            previous: Vec::new(),
            constant: false,
        })
    }

    fn evaluate_jacobian(
        &mut self,
        data: &mut FirstCorrector,
        t: f64,
        y: &[f64],
        stats: &mut Stats,
    ) -> Result<bool, OdeError> {
        let problem = &self.problem;
        let n = y.len();
        let values: &[f64] = match &mut data.matrices {
            Matrices::Krylov { jac, .. } if jac.nnz() == 0 => return Ok(true),
            Matrices::Dense { jac, .. } => {
                stats.num_jac_evals += 1;
                if !problem.jacobian(t, y, jac) {
                    problem.rhs(t, y, &mut data.f);
                    let (atol, rtol) = (&data.atol, data.rtol);
                    forward_difference_jacobian(
                        problem,
                        t,
                        y,
                        &data.f,
                        |j, yj| {
                            let inc = f64::EPSILON.sqrt() * yj.abs().max(atol[j] / rtol);
                            if inc > 0.0 { inc } else { f64::EPSILON.sqrt() }
                        },
                        &mut data.tmp,
                        &mut data.col,
                        jac,
                    );
                    stats.num_lin_rhs_evals += n + 1;
                }
                jac
            }
            Matrices::Sparse { jac, .. } | Matrices::Krylov { jac, .. } => {
                stats.num_jac_evals += 1;
                let nnz = jac.nnz();
                sparse_jacobian(problem, t, y, jac, nnz)?;
                jac.data()
            }
        };
        let finite = values.iter().all(|v| v.is_finite());
        data.constant = finite && data.previous.as_slice() == values;
        data.previous.clear();
        data.previous.extend_from_slice(values);
        Ok(finite)
    }

    fn jacobian_is_constant(data: &FirstCorrector) -> bool {
        data.constant
    }

    fn solve_corrector(
        &mut self,
        data: &mut FirstCorrector,
        step: &CorrectorStep<'_>,
        dcor: &mut [f64],
        stats: &mut Stats,
    ) -> Result<Attempt, OdeError> {
        let FirstCorrector {
            matrices,
            neg_psi,
            y,
            f,
            tmp,
            col,
            ..
        } = data;
        negate_into(step.psi, neg_psi);
        dcor.fill(0.0);
        let k = dcor;
        let problem = &self.problem;
        let (t, c, psi) = (step.t, step.c, &*neg_psi);
        let offset = Some((step.y_pred, &mut y[..]));
        let result = match matrices {
            Matrices::Dense { newton, jac } => {
                arm(newton, step, k.len());
                let mut stage = FirstStage {
                    problem,
                    tau: t,
                    gh: c,
                    psi,
                    offset,
                    jac,
                    source: JacobianSource::Kept,
                    f,
                    tmp,
                    col,
                    fd_evals: 0,
                };
                let result = newton.solve(&mut stage, k);
                account(newton_stats(&result), stats);
                result
            }
            Matrices::Sparse { newton, jac, diag } => {
                arm(newton, step, k.len());
                let mut stage = SparseFirstStage {
                    problem,
                    tau: t,
                    gh: c,
                    psi,
                    offset,
                    f,
                    jsp: jac,
                    source: JacobianSource::Kept,
                    diag,
                    product: None,
                };
                let result = newton.solve(&mut stage, k);
                account(newton_stats(&result), stats);
                result
            }
            Matrices::Krylov {
                newton,
                jac,
                diag,
                y_pert,
                f_pert,
            } => {
                newton.weights_mut(k.len()).copy_from_slice(step.weights);
                newton.linear_solver_mut().set_weights(step.weights);
                let before = newton.linear_solver().counters();
                if step.refactor {
                    newton.invalidate_jacobian();
                }
                newton.set_known_rate(step.known_rate);
                let mut stage = SparseFirstStage {
                    problem,
                    tau: t,
                    gh: c,
                    psi,
                    offset,
                    f,
                    jsp: jac,
                    source: JacobianSource::Kept,
                    diag,
                    product: Some((step.weights, y_pert, f_pert)),
                };
                let result = newton.solve(&mut stage, k);
                account(newton_stats(&result), stats);
                let gmres = newton.linear_solver();
                let after = gmres.counters();
                let products = after.products - before.products;
                stats.num_jtimes_evals += products;
                stats.num_lin_rhs_evals += products;
                stats.num_lin_conv_fails +=
                    after.convergence_failures - before.convergence_failures;
                stats.num_prec_evals += after.preconditioner_setups - before.preconditioner_setups;
                stats.num_prec_solves += after.preconditioner_solves - before.preconditioner_solves;
                result
            }
        };
        Attempt::from_newton(result, |ns| ns.iterations, t)
    }
}

/// The statistics a Newton result carries.
fn newton_stats(
    result: &Result<hookean_nonlinear::NewtonStats, hookean_nonlinear::NonlinearError>,
) -> Option<&hookean_nonlinear::NewtonStats> {
    match result {
        Ok(s) => Some(s),
        Err(e) => e.stats(),
    }
}

/// Readies a direct corrector's Newton for one step: the error weights of
/// the rate test, a refactorisation when the step asks for one, the known
/// contraction rate of a linear problem, and CVODE's stale-`gamma` scale.
fn arm<J, L: LinearSolver<J>>(
    newton: &mut Newton<J, Rescaled<L>>,
    step: &CorrectorStep<'_>,
    n: usize,
) {
    newton.weights_mut(n).copy_from_slice(step.weights);
    if step.refactor {
        newton.invalidate_jacobian();
    }
    newton.set_known_rate(step.known_rate);
    newton.linear_solver_mut().scale = step.scale;
}
