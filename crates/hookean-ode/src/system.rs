//! The two problem kinds seen by the integrator core as "a state vector
//! and a stage equation": first-order `y' = f(t, y)` (Newton with a dense
//! LU) and second-order `M x'' = f(t, x, v)` (the reduced velocity form
//! with PCG). Private except for [`FirstOrderForm`].

use std::cell::RefCell;

use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, Constraints, InitialGuess, PreconditionerSetup,
    SparseError, SymBlockMatrix, filtered_pcg, pcg,
};

use crate::linalg::DenseLu;
use crate::options::{NewtonOptions, Stats};
use crate::problem::{FirstOrderProblem, SecondOrderProblem};

/// Why one attempt at solving a stage equation failed.
#[derive(Debug)]
pub(crate) enum StageFailure {
    /// No convergence within the iteration limit, or divergence.
    NoConvergence { iterations: usize, update_norm: f64 },
    /// The linear solver failed.
    Linear(SparseError),
    /// The dense Newton matrix is singular.
    Singular { pivot: usize },
}

/// Newton statistics of one successful stage solve.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct StageInfo {
    pub iterations: usize,
    pub linear_iterations: usize,
}

/// The integrator core's view of a problem.
pub(crate) trait System {
    /// Length of the state vector (`y`, or `[x; v]`).
    fn state_len(&self) -> usize;
    /// True for second-order problems (state `[x; v]`).
    fn is_second_order(&self) -> bool;
    /// Time derivative of the state: `f(t, y)`, or `[v; M^{-1} f(t, x, v)]`.
    fn derivative(&mut self, t: f64, s: &[f64], ds: &mut [f64], stats: &mut Stats);
    /// Lets the model adjust the state and set constraints before a step.
    fn begin_step(&mut self, t: f64, s: &mut [f64]);
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
        opts: &NewtonOptions,
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
}

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |m, x| m.max(x.abs()))
}

fn converged(delta: f64, k: &[f64], opts: &NewtonOptions) -> bool {
    delta <= opts.atol + opts.rtol * inf_norm(k)
}

/// First-order problems: Newton on `G(K) = K - psi - gh f(tau, K)` with
/// the dense matrix `I - gh df/dy` factored by LU.
pub(crate) struct FirstSys<P> {
    pub problem: P,
    n: usize,
    jac: Vec<f64>,
    lu: DenseLu,
    f: Vec<f64>,
    g: Vec<f64>,
    tmp: Vec<f64>,
    col: Vec<f64>,
}

impl<P: FirstOrderProblem> FirstSys<P> {
    pub fn new(problem: P) -> Self {
        let n = problem.dim();
        Self {
            problem,
            n,
            jac: vec![0.0; n * n],
            lu: DenseLu::new(n),
            f: vec![0.0; n],
            g: vec![0.0; n],
            tmp: vec![0.0; n],
            col: vec![0.0; n],
        }
    }

    /// `df/dy` at `(t, y)` into `self.jac`: analytic, or forward differences.
    fn jacobian(&mut self, t: f64, y: &[f64], f_at_y: &[f64], stats: &mut Stats) {
        stats.jacobian_evals += 1;
        if self.problem.jacobian(t, y, &mut self.jac) {
            return;
        }
        let n = self.n;
        self.tmp.copy_from_slice(y);
        for j in 0..n {
            let eps = f64::EPSILON.sqrt() * y[j].abs().max(1.0);
            self.tmp[j] = y[j] + eps;
            self.problem.rhs(t, &self.tmp, &mut self.col);
            stats.f_evals += 1;
            for i in 0..n {
                self.jac[i * n + j] = (self.col[i] - f_at_y[i]) / eps;
            }
            self.tmp[j] = y[j];
        }
    }
}

impl<P: FirstOrderProblem> System for FirstSys<P> {
    fn state_len(&self) -> usize {
        self.n
    }

    fn is_second_order(&self) -> bool {
        false
    }

    fn derivative(&mut self, t: f64, s: &[f64], ds: &mut [f64], stats: &mut Stats) {
        stats.f_evals += 1;
        self.problem.rhs(t, s, ds);
    }

    fn begin_step(&mut self, _t: f64, _s: &mut [f64]) {}

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

    fn solve_stage(
        &mut self,
        tau: f64,
        gh: f64,
        psi: &[f64],
        k: &mut [f64],
        opts: &NewtonOptions,
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure> {
        let n = self.n;
        let mut info = StageInfo::default();
        let mut prev = f64::INFINITY;
        for it in 0..opts.max_iter {
            self.problem.rhs(tau, k, &mut self.f);
            stats.f_evals += 1;
            for i in 0..n {
                self.g[i] = -(k[i] - psi[i] - gh * self.f[i]);
            }
            if it == 0 || !opts.simplified {
                let f = std::mem::take(&mut self.f);
                self.jacobian(tau, k, &f, stats);
                self.f = f;
                let m = self.lu.matrix_mut();
                for i in 0..n {
                    for j in 0..n {
                        let id = if i == j { 1.0 } else { 0.0 };
                        m[i * n + j] = id - gh * self.jac[i * n + j];
                    }
                }
                stats.linear_setups += 1;
                self.lu
                    .factor()
                    .map_err(|pivot| StageFailure::Singular { pivot })?;
            }
            self.lu.solve(&mut self.g);
            let delta = inf_norm(&self.g);
            for i in 0..n {
                k[i] += self.g[i];
            }
            stats.newton_iterations += 1;
            info.iterations = it + 1;
            if !delta.is_finite() || k.iter().any(|v| !v.is_finite()) {
                return Err(StageFailure::NoConvergence {
                    iterations: it + 1,
                    update_norm: f64::NAN,
                });
            }
            if converged(delta, k, opts) {
                return Ok(info);
            }
            if it >= 1 && delta > 2.0 * prev {
                return Err(StageFailure::NoConvergence {
                    iterations: it + 1,
                    update_norm: delta,
                });
            }
            prev = delta;
        }
        Err(StageFailure::NoConvergence {
            iterations: opts.max_iter,
            update_norm: prev,
        })
    }
}

/// Second-order problems in the reduced velocity form (DESIGN.md): the
/// state is `[x; v]`; the stage `K = [X; V]` satisfies `X = psi_x + gh V`
/// and `G(V) = M (V - psi_v) - gh f(tau, psi_x + gh V, V) = 0`, solved by
/// Newton with the SPD matrix `A = M - gh df/dv - gh^2 df/dx` and (filtered) PCG.
pub(crate) struct SecondSys<P> {
    pub problem: P,
    n: usize,
    pub constraints: Constraints,
    dfdx: SymBlockMatrix,
    dfdv: SymBlockMatrix,
    a: SymBlockMatrix,
    precond: AnyPreconditioner,
    precond_kind: hookean_sparse::PrecondKind,
    ws: CgWorkspace,
    force: Vec<f64>,
    g: Vec<f64>,
    b: Vec<f64>,
    vnew: Vec<f64>,
}

impl<P: SecondOrderProblem> SecondSys<P> {
    pub fn new(problem: P, opts: &NewtonOptions) -> Result<Self, SparseError> {
        let n = problem.dim();
        let pattern = problem.jacobian_pattern();
        if pattern.dim() != n {
            return Err(SparseError::DimensionMismatch {
                what: "jacobian pattern (3 x blocks)",
                expected: n,
                found: pattern.dim(),
            });
        }
        Ok(Self {
            n,
            constraints: Constraints::new(n / 3),
            dfdx: SymBlockMatrix::new(pattern.clone()),
            dfdv: SymBlockMatrix::new(pattern.clone()),
            a: SymBlockMatrix::new(pattern),
            precond: AnyPreconditioner::new(opts.preconditioner)?,
            precond_kind: opts.preconditioner,
            ws: CgWorkspace::new(n),
            force: vec![0.0; n],
            g: vec![0.0; n],
            b: vec![0.0; n],
            vnew: vec![0.0; n],
            problem,
        })
    }
}

impl<P: SecondOrderProblem> System for SecondSys<P> {
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
        stats.f_evals += 1;
        for (a, m) in dv.iter_mut().zip(self.problem.mass()) {
            *a /= m;
        }
    }

    fn begin_step(&mut self, t: f64, s: &mut [f64]) {
        let (x, v) = s.split_at_mut(self.n);
        self.constraints.clear();
        self.problem.begin_step(t, x, v, &mut self.constraints);
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
        stats.f_evals += 1;
        for (a, m) in acc.iter_mut().zip(self.problem.mass()) {
            *a /= m;
        }
        true
    }

    fn solve_stage(
        &mut self,
        tau: f64,
        gh: f64,
        psi: &[f64],
        k: &mut [f64],
        opts: &NewtonOptions,
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure> {
        let n = self.n;
        if opts.preconditioner != self.precond_kind {
            self.precond =
                AnyPreconditioner::new(opts.preconditioner).map_err(StageFailure::Linear)?;
            self.precond_kind = opts.preconditioner;
        }
        let (psi_x, psi_v) = psi.split_at(n);
        let (kx, kv) = k.split_at_mut(n);
        let filtered = !self.constraints.is_empty();
        if filtered {
            self.constraints.impose(kv);
        }
        let cg = CgParams {
            rtol: opts.linear_rtol,
            atol: 0.0,
            max_iter: opts.linear_max_iter,
            initial_guess: InitialGuess::Given,
            record_history: false,
        };
        let mut info = StageInfo::default();
        let mut prev = f64::INFINITY;
        for it in 0..opts.max_iter {
            for i in 0..n {
                kx[i] = psi_x[i] + gh * kv[i];
            }
            self.problem.force(tau, kx, kv, &mut self.force);
            stats.f_evals += 1;
            let mass = self.problem.mass();
            for i in 0..n {
                self.g[i] = mass[i] * (kv[i] - psi_v[i]) - gh * self.force[i];
            }
            if it == 0 || !opts.simplified {
                self.problem
                    .force_jacobians(tau, kx, kv, &mut self.dfdx, &mut self.dfdv);
                stats.jacobian_evals += 1;
                self.a.set_zero();
                self.a
                    .add_scaled(-gh * gh, &self.dfdx)
                    .map_err(StageFailure::Linear)?;
                self.a
                    .add_scaled(-gh, &self.dfdv)
                    .map_err(StageFailure::Linear)?;
                self.a.add_to_diagonal(mass).map_err(StageFailure::Linear)?;
                self.precond.setup(&self.a).map_err(StageFailure::Linear)?;
                stats.linear_setups += 1;
            }
            // Newton for V directly: A V_new = A V - G(V), so that filtered
            // PCG can impose the prescribed velocities on V_new.
            self.a
                .mul_vec(kv, &mut self.b)
                .map_err(StageFailure::Linear)?;
            for i in 0..n {
                self.b[i] -= self.g[i];
            }
            self.vnew.copy_from_slice(kv);
            let res = if filtered {
                filtered_pcg(
                    &self.a,
                    &self.precond,
                    &self.b,
                    &mut self.vnew,
                    &self.constraints,
                    &cg,
                    &mut self.ws,
                    None,
                )
            } else {
                pcg(
                    &self.a,
                    &self.precond,
                    &self.b,
                    &mut self.vnew,
                    &cg,
                    &mut self.ws,
                    None,
                )
            };
            let cg_info = res.map_err(StageFailure::Linear)?;
            stats.linear_iterations += cg_info.iterations;
            info.linear_iterations += cg_info.iterations;
            if !cg_info.converged {
                return Err(StageFailure::Linear(SparseError::NotConverged {
                    method: "PCG",
                    iterations: cg_info.iterations,
                    relative_residual: cg_info.relative_residual,
                }));
            }
            let mut delta = 0.0_f64;
            for i in 0..n {
                delta = delta.max((self.vnew[i] - kv[i]).abs());
            }
            kv.copy_from_slice(&self.vnew);
            stats.newton_iterations += 1;
            info.iterations = it + 1;
            if !delta.is_finite() {
                return Err(StageFailure::NoConvergence {
                    iterations: it + 1,
                    update_norm: f64::NAN,
                });
            }
            if converged(delta, kv, opts) {
                for i in 0..n {
                    kx[i] = psi_x[i] + gh * kv[i];
                }
                return Ok(info);
            }
            if it >= 1 && delta > 2.0 * prev {
                return Err(StageFailure::NoConvergence {
                    iterations: it + 1,
                    update_norm: delta,
                });
            }
            prev = delta;
        }
        Err(StageFailure::NoConvergence {
            iterations: opts.max_iter,
            update_norm: prev,
        })
    }
}

/// A second-order problem `M x'' = f(t, x, v)` seen as the first-order
/// system (6) of size `2 dim`: `y = [x; v]`, `y' = [v; M^{-1} f]`, with the
/// dense Jacobian `[[0, I], [M^{-1} df/dx, M^{-1} df/dv]]`. For comparisons
/// and small problems (it allocates in `jacobian`); the integrators solve
/// second-order problems in the reduced form instead.
pub struct FirstOrderForm<P> {
    problem: P,
    scratch: RefCell<(SymBlockMatrix, SymBlockMatrix, Vec<f64>)>,
}

impl<P: SecondOrderProblem> FirstOrderForm<P> {
    /// Wraps `problem`.
    pub fn new(problem: P) -> Self {
        let pattern = problem.jacobian_pattern();
        let n = problem.dim();
        Self {
            scratch: RefCell::new((
                SymBlockMatrix::new(pattern.clone()),
                SymBlockMatrix::new(pattern),
                vec![0.0; n],
            )),
            problem,
        }
    }

    /// The wrapped problem.
    pub fn inner(&self) -> &P {
        &self.problem
    }
}

impl<P: SecondOrderProblem> FirstOrderProblem for FirstOrderForm<P> {
    fn dim(&self) -> usize {
        2 * self.problem.dim()
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let n = self.problem.dim();
        let (x, v) = y.split_at(n);
        let (dx, dv) = dy.split_at_mut(n);
        dx.copy_from_slice(v);
        self.problem.force(t, x, v, dv);
        for (a, m) in dv.iter_mut().zip(self.problem.mass()) {
            *a /= m;
        }
    }

    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> bool {
        let n = self.problem.dim();
        let n2 = 2 * n;
        let (x, v) = y.split_at(n);
        let mut s = self.scratch.borrow_mut();
        let (dfdx, dfdv, _) = &mut *s;
        self.problem.force_jacobians(t, x, v, dfdx, dfdv);
        jac.fill(0.0);
        for i in 0..n {
            jac[i * n2 + n + i] = 1.0;
        }
        let mass = self.problem.mass();
        for (mat, off) in [(&*dfdx, 0), (&*dfdv, n)] {
            let csr = mat.to_csr();
            for (&val, (r, c)) in csr.iter() {
                jac[(n + r) * n2 + off + c] += val / mass[r];
            }
        }
        true
    }
}
