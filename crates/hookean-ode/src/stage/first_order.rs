//! First-order problems `y' = f(t, y)`: the stage equation
//! `K = psi + gh f(tau, K)` as a nonlinear system on a dense or a sparse
//! Newton matrix `I - gh df/dy`, and [`FirstSys`], the integrators' view of
//! such a problem.

use hookean_nonlinear::{DenseLu, Newton, NonlinearError, NonlinearSystem, SparseLu};
use hookean_problem::FirstOrderProblem;

use super::{JacobianSource, StageFailure, StageInfo, System, account, imex_failure};
use crate::error::OdeError;
use crate::options::SolverOptions;
use crate::stats::Stats;

/// Where the unknown `u` of a first-order stage sits: the stage value
/// itself (`K = u`), or its correction to a base point `b` (`K = b + u`,
/// with `b + u` formed in the scratch vector).
pub(crate) type Offset<'a> = Option<(&'a [f64], &'a mut [f64])>;

/// The point `K` of the unknown `u`: `u` itself, or `b + u` (see [`Offset`]).
#[allow(clippy::needless_range_loop)]
fn stage_point<'s>(offset: &'s mut Offset<'_>, u: &'s [f64]) -> &'s [f64] {
    match offset {
        None => u,
        Some((b, y)) => {
            // Indexed on slices cut to `n`: no bounds checks left, and no
            // zip chain, whose set-up outweighs the sums at a few unknowns.
            let n = u.len();
            let (b, y) = (&b[..n], &mut y[..n]);
            for i in 0..n {
                y[i] = b[i] + u[i];
            }
            y
        }
    }
}

/// The stage equation of a first-order problem as a nonlinear system:
/// `G(K) = K - psi - gh f(tau, K)`, Jacobian `I - gh df/dy` (dense). With an
/// [`Offset`] `b` the unknown is the correction `u = K - b` and
/// `G(u) = u - (psi - b) - gh f(tau, b + u)` (`psi` then holds `psi - b`):
/// the variable-order BDF solves for the correction to its predictor, so
/// that the residual loses nothing to the cancellation `K - psi` when the
/// correction is far below the state (CVODE's form of the corrector).
pub(crate) struct FirstStage<'a, P> {
    pub problem: &'a P,
    pub tau: f64,
    pub gh: f64,
    pub psi: &'a [f64],
    pub offset: Offset<'a>,
    /// `df/dy`, row-major `n x n`: evaluated at the iterate Newton asks for
    /// ([`JacobianSource::Evaluate`], analytic or by forward differences),
    /// or the caller's ([`JacobianSource::Kept`]).
    pub jac: &'a mut [f64],
    pub source: JacobianSource,
    /// `f` at the iterate of the last residual.
    pub f: &'a mut [f64],
    pub tmp: &'a mut [f64],
    pub col: &'a mut [f64],
    /// Evaluations of `f` for difference-quotient Jacobians.
    pub fd_evals: usize,
}

/// The stage residual `G(u) = u - psi - gh f(tau, K)`, `K = u` or `b + u`,
/// shared by the dense and sparse first-order stages.
#[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
#[inline]
fn first_order_stage_residual<P: FirstOrderProblem>(
    problem: &P,
    tau: f64,
    gh: f64,
    psi: &[f64],
    f: &mut [f64],
    offset: &mut Offset<'_>,
    u: &[f64],
    g: &mut [f64],
) {
    problem.rhs(tau, stage_point(offset, u), f);
    let n = u.len();
    let (g, psi, f) = (&mut g[..n], &psi[..n], &f[..n]);
    for i in 0..n {
        g[i] = u[i] - psi[i] - gh * f[i];
    }
}

impl<P: FirstOrderProblem> NonlinearSystem for FirstStage<'_, P> {
    type Jacobian = faer::Mat<f64>;

    fn dim(&self) -> usize {
        self.psi.len()
    }

    fn residual(&mut self, u: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        first_order_stage_residual(
            self.problem,
            self.tau,
            self.gh,
            self.psi,
            self.f,
            &mut self.offset,
            u,
            g,
        );
        Ok(())
    }

    fn jacobian(&mut self, u: &[f64], jac: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
        let n = u.len();
        let y = stage_point(&mut self.offset, u);
        if self.source == JacobianSource::Evaluate && !self.problem.jacobian(self.tau, y, self.jac)
        {
            self.problem.rhs(self.tau, y, self.f);
            forward_difference_jacobian(
                self.problem,
                self.tau,
                y,
                self.f,
                |_, yj| f64::EPSILON.sqrt() * yj.abs().max(1.0),
                self.tmp,
                self.col,
                self.jac,
            );
            self.fd_evals += n + 1;
        }
        for i in 0..n {
            for j in 0..n {
                let id = if i == j { 1.0 } else { 0.0 };
                jac[(i, j)] = id - self.gh * self.jac[i * n + j];
            }
        }
        Ok(())
    }
}

/// The dense Jacobian `df/dy` at `(t, y)` by forward differences (one
/// evaluation of `f` per column): `J[:, j] = (f(y + eps_j e_j) - f0) / eps_j`
/// with `f0 = f(t, y)` given and `eps_j = increment(j, y_j)`; `jac` is
/// row-major `n x n`, `tmp` and `col` are work vectors of length `n`.
pub(crate) fn forward_difference_jacobian<P: FirstOrderProblem>(
    problem: &P,
    t: f64,
    y: &[f64],
    f0: &[f64],
    increment: impl Fn(usize, f64) -> f64,
    tmp: &mut [f64],
    col: &mut [f64],
    jac: &mut [f64],
) {
    let n = y.len();
    tmp.copy_from_slice(y);
    for j in 0..n {
        let eps = increment(j, y[j]);
        tmp[j] = y[j] + eps;
        problem.rhs(t, tmp, col);
        for i in 0..n {
            jac[i * n + j] = (col[i] - f0[i]) / eps;
        }
        tmp[j] = y[j];
    }
}

/// The stage equation of a first-order problem with a sparse Jacobian:
/// the Newton matrix `I - gh df/dy` on the problem's pattern, and its
/// products `(I - gh df/dy) v` by difference quotients of `f` for
/// matrix-free solvers.
pub(crate) struct SparseFirstStage<'a, P> {
    pub problem: &'a P,
    pub tau: f64,
    pub gh: f64,
    pub psi: &'a [f64],
    /// As [`FirstStage::offset`].
    pub offset: Offset<'a>,
    /// `f` at the iterate of the last residual.
    pub f: &'a mut [f64],
    /// `df/dy` on the pattern (empty for an unpreconditioned matrix-free
    /// solve), evaluated here or kept by the caller.
    pub jsp: &'a mut sprs::CsMat<f64>,
    pub source: JacobianSource,
    pub diag: &'a [usize],
    /// The weights of the products' difference increments and their
    /// scratch `(w, y + s v, f(y + s v))`; `None` without products.
    pub product: Option<(&'a [f64], &'a mut [f64], &'a mut [f64])>,
}

impl<P: FirstOrderProblem> NonlinearSystem for SparseFirstStage<'_, P> {
    type Jacobian = sprs::CsMat<f64>;

    fn dim(&self) -> usize {
        self.psi.len()
    }

    fn residual(&mut self, u: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        first_order_stage_residual(
            self.problem,
            self.tau,
            self.gh,
            self.psi,
            self.f,
            &mut self.offset,
            u,
            g,
        );
        Ok(())
    }

    fn jacobian(&mut self, u: &[f64], a: &mut sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        if self.source == JacobianSource::Evaluate
            && !self
                .problem
                .jacobian_sparse(self.tau, stage_point(&mut self.offset, u), self.jsp)
        {
            return Err(NonlinearError::System {
                message: "the problem gave a sparse Jacobian pattern but no jacobian_sparse values"
                    .into(),
            });
        }
        if self.jsp.nnz() != a.nnz() {
            return Err(NonlinearError::System {
                message: "jacobian_sparse changed the sparsity pattern".into(),
            });
        }
        let gh = self.gh;
        for (dst, src) in a.data_mut().iter_mut().zip(self.jsp.data()) {
            *dst = -gh * src;
        }
        for &k in self.diag {
            a.data_mut()[k] += 1.0;
        }
        Ok(())
    }

    /// `(I - gh J) v` with `J v = (f(y + s v) - f(y)) / s`, `s = 1 / ||v||`
    /// in the weighted RMS norm (CVODE's difference-quotient `jtimes`: the
    /// increment is one weight unit along `v`), `f(y)` from the last residual.
    fn jacobian_product(
        &mut self,
        u: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) -> Result<bool, NonlinearError> {
        let y = stage_point(&mut self.offset, u);
        let Some((w, y_pert, f_pert)) = self.product.as_mut() else {
            return Ok(false);
        };
        let norm = hookean_nonlinear::weighted_rms(v, w);
        if norm == 0.0 {
            out.fill(0.0);
            return Ok(true);
        }
        let sigma = 1.0 / norm;
        for ((yp, yi), vi) in y_pert.iter_mut().zip(y).zip(v) {
            *yp = yi + sigma * vi;
        }
        self.problem.rhs(self.tau, y_pert, f_pert);
        for (((o, vi), fp), fi) in out.iter_mut().zip(v).zip(f_pert.iter()).zip(self.f.iter()) {
            *o = vi - self.gh * (fp - fi) / sigma;
        }
        Ok(true)
    }
}

/// The positions in `pattern.data()` of the diagonal entries of an `n x n`
/// sparse Jacobian pattern (CSR or CSC), to add the identity of `I - gh df/dy`.
///
/// # Errors
/// [`OdeError::DimensionMismatch`] for another shape,
/// [`OdeError::InvalidParameter`] if a diagonal entry is missing.
pub(crate) fn diagonal_positions(
    pattern: &sprs::CsMat<f64>,
    n: usize,
) -> Result<Vec<usize>, OdeError> {
    if pattern.shape() != (n, n) {
        return Err(OdeError::DimensionMismatch {
            what: "sparse Jacobian pattern (rows)",
            expected: n,
            found: pattern.rows(),
        });
    }
    let mut diag = vec![usize::MAX; pattern.outer_dims()];
    let mut k = 0;
    for (outer, vec) in pattern.outer_iterator().enumerate() {
        for (inner, _) in vec.iter() {
            if inner == outer {
                diag[outer] = k;
            }
            k += 1;
        }
    }
    if let Some(i) = diag.iter().position(|&d| d == usize::MAX) {
        return Err(OdeError::InvalidParameter {
            name: "sparse Jacobian pattern",
            value: i as f64,
            reason: "must contain the diagonal (missing at the row given as value)",
        });
    }
    Ok(diag)
}

/// Newton for first-order stages: dense LU, or sparse LU on the problem's pattern.
enum FirstNewton {
    Dense(Option<Box<Newton<faer::Mat<f64>, DenseLu>>>),
    Sparse(Box<SparseNewton>),
}

/// The sparse branch of [`FirstNewton`].
struct SparseNewton {
    newton: Newton<sprs::CsMat<f64>, SparseLu>,
    jsp: sprs::CsMat<f64>,
    diag: Vec<usize>,
}

/// First-order problems: `hookean-nonlinear`'s Newton with a dense LU, or a
/// sparse LU when the problem has a sparse Jacobian pattern.
pub(crate) struct FirstSys<P> {
    pub problem: P,
    n: usize,
    newton: FirstNewton,
    last_gh: f64,
    jac: Vec<f64>,
    f: Vec<f64>,
    tmp: Vec<f64>,
    col: Vec<f64>,
}

impl<P: FirstOrderProblem> FirstSys<P> {
    pub fn new(problem: P, opts: &SolverOptions) -> Result<Self, OdeError> {
        let n = problem.dim();
        if n == 0 {
            return Err(OdeError::InvalidParameter {
                name: "problem.dim()",
                value: 0.0,
                reason: "the problem has no unknowns: there is nothing to integrate",
            });
        }
        let (newton, jac) = match problem.sparse_jacobian_pattern() {
            None => (FirstNewton::Dense(None), vec![0.0; n * n]),
            Some(pattern) => {
                let diag = diagonal_positions(&pattern, n)?;
                let sparse = SparseNewton {
                    newton: Newton::new(opts.newton, pattern.clone(), SparseLu::new())?,
                    jsp: pattern,
                    diag,
                };
                (FirstNewton::Sparse(Box::new(sparse)), Vec::new())
            }
        };
        Ok(Self {
            problem,
            n,
            newton,
            last_gh: f64::NAN,
            jac,
            f: vec![0.0; n],
            tmp: vec![0.0; n],
            col: vec![0.0; n],
        })
    }
}

impl<P: FirstOrderProblem> System for FirstSys<P> {
    type Problem = P;

    fn problem(&self) -> &P {
        &self.problem
    }

    fn problem_mut(&mut self) -> &mut P {
        &mut self.problem
    }

    fn state_len(&self) -> usize {
        self.n
    }

    fn is_second_order(&self) -> bool {
        false
    }

    fn derivative(&mut self, t: f64, s: &[f64], ds: &mut [f64], stats: &mut Stats) {
        stats.num_rhs_evals += 1;
        self.problem.rhs(t, s, ds);
    }

    fn begin_step(&mut self, _t: f64, _s: &mut [f64]) {}

    fn end_step(&mut self, _t: f64, _h: f64, _start: &[f64], _s: &mut [f64]) -> bool {
        false
    }

    fn impose(&self, _s: &mut [f64]) {}

    fn acceleration(
        &mut self,
        _t: f64,
        _x: &[f64],
        _v: &[f64],
        _acc: &mut [f64],
        _stats: &mut Stats,
    ) -> bool {
        false
    }

    fn imex_step(
        &mut self,
        _t: f64,
        _h: f64,
        _s: &mut [f64],
        _stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure> {
        // Core::new refuses second-order-only methods on first-order problems.
        Err(imex_failure(crate::imex::ImexFailure::NoLinearPart))
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
        let gh_changed = gh != self.last_gh;
        self.last_gh = gh;
        match &mut self.newton {
            FirstNewton::Dense(slot) => {
                let newton = match slot {
                    Some(nw) => nw,
                    None => slot.insert(Box::new(
                        Newton::new(
                            opts.newton,
                            faer::Mat::zeros(self.n, self.n),
                            DenseLu::new(),
                        )
                        .map_err(StageFailure::Other)?,
                    )),
                };
                // The Newton matrix depends on gh: a kept Jacobian (simplified
                // variants) is only valid for the same gh.
                if gh_changed {
                    newton.invalidate_jacobian();
                }
                let mut stage = FirstStage {
                    problem: &self.problem,
                    tau,
                    gh,
                    psi,
                    offset: None,
                    jac: &mut self.jac,
                    source: JacobianSource::Evaluate,
                    f: &mut self.f,
                    tmp: &mut self.tmp,
                    col: &mut self.col,
                    fd_evals: 0,
                };
                let result = newton.solve(&mut stage, k);
                let fd = stage.fd_evals;
                account(result, fd, stats)
            }
            FirstNewton::Sparse(sp) => {
                let SparseNewton { newton, jsp, diag } = &mut **sp;
                if gh_changed {
                    newton.invalidate_jacobian();
                }
                let mut stage = SparseFirstStage {
                    problem: &self.problem,
                    tau,
                    gh,
                    psi,
                    offset: None,
                    f: &mut self.f,
                    jsp,
                    source: JacobianSource::Evaluate,
                    diag,
                    product: None,
                };
                account(newton.solve(&mut stage, k), 0, stats)
            }
        }
    }
}
