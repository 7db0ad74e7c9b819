//! The two problem kinds seen by the integrator core as "a state vector
//! and a stage equation": first-order `y' = f(t, y)` (Newton with a dense
//! LU) and second-order `M x'' = f(t, x, v)` (the reduced velocity form
//! with PCG). Both stage equations are solved by `hookean-nonlinear`'s
//! [`Newton`]. Private except for [`FirstOrderForm`].

use std::cell::RefCell;

use hookean_nonlinear::{
    DenseLu, Newton, NewtonMethod, NewtonOptions, NewtonStats, NonlinearError, NonlinearSystem,
    PcgSolver, SparseLu,
};
use hookean_sparse::{AnyPreconditioner, Constraints, IsoBlockMatrix, SparseError, SymBlockMatrix};

use crate::error::OdeError;
use crate::options::{SolverOptions, Stats};
use hookean_problem::{FirstOrderProblem, SecondOrderProblem};

/// Why one attempt at solving a stage equation failed.
#[derive(Debug)]
pub(crate) enum StageFailure {
    /// No convergence within the iteration limit, or divergence.
    NoConvergence { iterations: usize, update_norm: f64 },
    /// The linear solver failed (did not converge, or a `hookean-sparse` error).
    Linear(NonlinearError),
    /// The dense Newton matrix is singular.
    Singular { pivot: usize },
    /// Any other error of the Newton solver (not worth a retry).
    Other(NonlinearError),
}

/// Newton statistics of one successful stage solve.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct StageInfo {
    pub iterations: usize,
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
    /// Lets the model correct the state after an accepted step from `t`
    /// of size `h` that started at `start`; true if it changed `s`.
    fn end_step(&mut self, t: f64, h: f64, start: &[f64], s: &mut [f64]) -> bool;
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
        opts: &SolverOptions,
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
    /// One step of the IMEX scheme ([`crate::imex`]) on the state `s`
    /// (second-order systems with a linear part only; the integrator
    /// checks that at construction).
    fn imex_step(
        &mut self,
        t: f64,
        h: f64,
        s: &mut [f64],
        stats: &mut Stats,
    ) -> Result<StageInfo, StageFailure>;
}

/// The failure of an IMEX step as a stage failure (a linear-solver failure:
/// the step is retried with substeps).
fn imex_failure(e: crate::imex::ImexFailure) -> StageFailure {
    use crate::imex::ImexFailure;
    match e {
        ImexFailure::Sparse(e) => StageFailure::Linear(NonlinearError::Linear(e)),
        ImexFailure::NotConverged {
            iterations,
            relative_residual,
        } => StageFailure::Linear(NonlinearError::LinearNotConverged {
            iterations,
            tolerance: 1e-10,
            relative_residual,
            stats: Box::default(),
        }),
        ImexFailure::NoLinearPart => {
            StageFailure::Other(NonlinearError::Linear(SparseError::InvalidParameter {
                name: "method",
                message: "imex needs the problem's linear part (eq. 50)".into(),
            }))
        }
    }
}

/// Books a Newton run (successful or not) into the counters and maps the result.
fn account(
    result: Result<NewtonStats, NonlinearError>,
    extra_f_evals: usize,
    stats: &mut Stats,
) -> Result<StageInfo, StageFailure> {
    let ns = match &result {
        Ok(s) => Some(s),
        Err(e) => e.stats(),
    };
    stats.f_evals += extra_f_evals;
    if let Some(ns) = ns {
        stats.f_evals += ns.residual_evaluations;
        stats.jacobian_evals += ns.jacobian_evaluations;
        stats.newton_iterations += ns.iterations;
        stats.linear_iterations += ns.linear_iterations;
        stats.linear_setups += ns.linear_setups;
        stats
            .phases
            .add_seconds(ns.jacobian_seconds, ns.setup_seconds, ns.solve_seconds);
    }
    match result {
        Ok(ns) => Ok(StageInfo {
            iterations: ns.iterations,
        }),
        Err(e @ (NonlinearError::LinearNotConverged { .. } | NonlinearError::Linear(_))) => {
            Err(StageFailure::Linear(e))
        }
        Err(NonlinearError::SingularJacobian { pivot, .. }) => {
            Err(StageFailure::Singular { pivot })
        }
        Err(e) if e.is_step_failure() => {
            let (iterations, update_norm) = e.stats().map_or((0, f64::NAN), |s| {
                (
                    s.iterations,
                    s.step_norms.last().copied().unwrap_or(f64::NAN),
                )
            });
            Err(StageFailure::NoConvergence {
                iterations,
                update_norm,
            })
        }
        Err(e) => Err(StageFailure::Other(e)),
    }
}

/// The stage equation of a first-order problem as a nonlinear system:
/// `G(K) = K - psi - gh f(tau, K)`, Jacobian `I - gh df/dy`.
struct FirstStage<'a, P> {
    problem: &'a P,
    tau: f64,
    gh: f64,
    psi: &'a [f64],
    jac: &'a mut [f64],
    f: &'a mut [f64],
    tmp: &'a mut [f64],
    col: &'a mut [f64],
    fd_evals: usize,
}

/// The stage residual `G(y) = y - psi - gh f(tau, y)` shared by the dense and
/// sparse first-order stages.
fn first_order_stage_residual<P: FirstOrderProblem>(
    problem: &P,
    tau: f64,
    gh: f64,
    psi: &[f64],
    f: &mut [f64],
    y: &[f64],
    g: &mut [f64],
) {
    problem.rhs(tau, y, f);
    for i in 0..g.len() {
        g[i] = y[i] - psi[i] - gh * f[i];
    }
}

impl<P: FirstOrderProblem> NonlinearSystem for FirstStage<'_, P> {
    type Jacobian = faer::Mat<f64>;

    fn dim(&self) -> usize {
        self.psi.len()
    }

    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        first_order_stage_residual(self.problem, self.tau, self.gh, self.psi, self.f, y, g);
        Ok(())
    }

    fn jacobian(&mut self, y: &[f64], jac: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
        let n = y.len();
        if !self.problem.jacobian(self.tau, y, self.jac) {
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
/// the Newton matrix `I - gh df/dy` on the problem's pattern.
struct SparseFirstStage<'a, P> {
    problem: &'a P,
    tau: f64,
    gh: f64,
    psi: &'a [f64],
    f: &'a mut [f64],
    jsp: &'a mut sprs::CsMat<f64>,
    diag: &'a [usize],
}

impl<P: FirstOrderProblem> NonlinearSystem for SparseFirstStage<'_, P> {
    type Jacobian = sprs::CsMat<f64>;

    fn dim(&self) -> usize {
        self.psi.len()
    }

    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        first_order_stage_residual(self.problem, self.tau, self.gh, self.psi, self.f, y, g);
        Ok(())
    }

    fn jacobian(&mut self, y: &[f64], a: &mut sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        if !self.problem.jacobian_sparse(self.tau, y, self.jsp) {
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
        let newton = match problem.sparse_jacobian_pattern() {
            None => FirstNewton::Dense(None),
            Some(pattern) => {
                let diag = diagonal_positions(&pattern, n)?;
                FirstNewton::Sparse(Box::new(SparseNewton {
                    newton: Newton::new(opts.newton.clone(), pattern.clone(), SparseLu::new())?,
                    jsp: pattern,
                    diag,
                }))
            }
        };
        Ok(Self {
            problem,
            n,
            newton,
            last_gh: f64::NAN,
            jac: vec![0.0; n * n],
            f: vec![0.0; n],
            tmp: vec![0.0; n],
            col: vec![0.0; n],
        })
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
        let nopts = &opts.newton;
        let gh_changed = gh != self.last_gh;
        self.last_gh = gh;
        match &mut self.newton {
            FirstNewton::Dense(slot) => {
                let newton = match slot {
                    Some(nw) => {
                        if nw.options() != nopts {
                            nw.set_options(nopts.clone()).map_err(StageFailure::Other)?;
                        }
                        nw
                    }
                    None => slot.insert(Box::new(
                        Newton::new(
                            nopts.clone(),
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
                    jac: &mut self.jac,
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
                if newton.options() != nopts {
                    newton
                        .set_options(nopts.clone())
                        .map_err(StageFailure::Other)?;
                }
                if gh_changed {
                    newton.invalidate_jacobian();
                }
                let mut stage = SparseFirstStage {
                    problem: &self.problem,
                    tau,
                    gh,
                    psi,
                    f: &mut self.f,
                    jsp,
                    diag,
                };
                account(newton.solve(&mut stage, k), 0, stats)
            }
        }
    }
}

/// The reduced velocity form of one stage as a nonlinear system in `V`:
/// `G(V) = P [M (V - psi_v) - gh f(tau, psi_x + gh V, V)]` (`P` removes the
/// constrained components), Jacobian `M - gh df/dv - gh^2 df/dx`.
struct ReducedStage<'a, P> {
    problem: &'a P,
    tau: f64,
    gh: f64,
    psi_x: &'a [f64],
    psi_v: &'a [f64],
    x: &'a mut [f64],
    force: &'a mut [f64],
    dfdx: &'a mut SymBlockMatrix,
    dfdv: &'a mut SymBlockMatrix,
    constraints: &'a Constraints,
}

impl<P: SecondOrderProblem> ReducedStage<'_, P> {
    fn positions(&mut self, v: &[f64]) {
        for i in 0..v.len() {
            self.x[i] = self.psi_x[i] + self.gh * v[i];
        }
    }

    fn assemble(&self, a: &mut SymBlockMatrix) -> Result<(), NonlinearError> {
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
    /// problem has one ([`SecondOrderProblem::step_matrix`]).
    fn jacobian(&mut self, v: &[f64], a: &mut SymBlockMatrix) -> Result<(), NonlinearError> {
        self.positions(v);
        let gh = self.gh;
        self.problem
            .step_matrix(self.tau, self.x, v, -gh * gh, -gh, self.dfdx, self.dfdv, a)?;
        Ok(())
    }

    fn approximate_jacobian(
        &mut self,
        _v: &[f64],
        a: &mut SymBlockMatrix,
    ) -> Result<bool, NonlinearError> {
        if !self.problem.linearized_jacobians(self.dfdx, self.dfdv) {
            return Ok(false);
        }
        self.assemble(a)?;
        Ok(true)
    }
}

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
        let gh = self.stage.gh;
        a.set_zero();
        a.add_scaled(-gh * gh, self.k)?;
        a.add_scaled(-gh, self.d)?;
        a.add_to_diagonal(self.particle_mass)?;
        Ok(true)
    }
}

/// Eq. 50's path of [`SecondSys`]: its own Newton on isotropic storage,
/// the constant `K`, `D` and the material revision they belong to.
struct LinearizedNewton {
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
        Ok(Some(Self {
            newton: Newton::new(options, IsoBlockMatrix::new(pattern), linear)?,
            k,
            d,
            particle_mass,
            revision: problem.material_revision(),
            last_gh: f64::NAN,
        }))
    }
}

/// Second-order problems in the reduced velocity form (docs/ARCHITECTURE.md): the
/// state is `[x; v]`; the stage `K = [X; V]` satisfies `X = psi_x + gh V`
/// and `G(V) = M (V - psi_v) - gh f(tau, psi_x + gh V, V) = 0`, solved by
/// `hookean-nonlinear`'s Newton with the SPD matrix
/// `A = M - gh df/dv - gh^2 df/dx` and (filtered) PCG.
pub(crate) struct SecondSys<P> {
    pub problem: P,
    n: usize,
    pub constraints: Constraints,
    dfdx: SymBlockMatrix,
    dfdv: SymBlockMatrix,
    newton: Newton<SymBlockMatrix, PcgSolver<AnyPreconditioner>>,
    last_gh: f64,
    force: Vec<f64>,
    xs: Vec<f64>,
    /// `V - psi_v` of the last solved stage and its `gh` (NaN: none), the
    /// warm start of the next stage's first linear solve.
    last_delta: Vec<f64>,
    last_delta_gh: f64,
    /// The Newton options as the user gave them (`newton` holds them with
    /// the absolute tolerance in momentum units, see [`momentum_options`]).
    user_newton: NewtonOptions,
    /// The mean particle mass.
    mean_mass: f64,
    /// The IMEX scheme's matrices and factor (built at its first step).
    imex: Option<Box<crate::imex::Imex>>,
    /// Inexact simplified Newton's eq. 50 path (built at its first stage;
    /// `Err(())` once the problem was found to have none).
    linearized: Option<Result<Box<LinearizedNewton>, ()>>,
    /// The material revision the kept Jacobian of `newton` belongs to.
    revision: u64,
}

/// The velocity form's residual `M (V - psi_v) - gh f` is a momentum: its
/// absolute tolerance is the user's `atol` (a velocity) times the mean mass,
/// so that the same `k/m` converges alike in any mass unit.
fn momentum_options(user: &NewtonOptions, mean_mass: f64) -> NewtonOptions {
    NewtonOptions {
        atol: user.atol * mean_mass,
        ..user.clone()
    }
}

impl<P: SecondOrderProblem> SecondSys<P> {
    pub fn new(problem: P, opts: &SolverOptions) -> Result<Self, OdeError> {
        let n = problem.dim();
        let pattern = problem.jacobian_pattern();
        if pattern.dim() != n {
            return Err(OdeError::DimensionMismatch {
                what: "jacobian pattern (3 x blocks)",
                expected: n,
                found: pattern.dim(),
            });
        }
        let linear = PcgSolver::from_options(&opts.newton)?;
        let mass = problem.mass();
        let mean_mass = mass.iter().sum::<f64>() / mass.len().max(1) as f64;
        let newton = Newton::new(
            momentum_options(&opts.newton, mean_mass),
            SymBlockMatrix::new(pattern.clone()),
            linear,
        )?;
        Ok(Self {
            n,
            user_newton: opts.newton.clone(),
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

impl<P: SecondOrderProblem> SecondSys<P> {
    /// [`System::solve_stage`] by inexact simplified Newton on eq. 50's
    /// isotropic matrix ([`ReducedStageIso`]), kept until `gh` or the
    /// material revision changes; `None` if the problem has no isotropic
    /// linearisation (then the full-block path runs, with
    /// [`SecondOrderProblem::linearized_jacobians`] if it has that).
    fn solve_stage_linearized(
        &mut self,
        tau: f64,
        gh: f64,
        psi: &[f64],
        k: &mut [f64],
        opts: &SolverOptions,
        stats: &mut Stats,
    ) -> Option<Result<StageInfo, StageFailure>> {
        let nopts = momentum_options(&opts.newton, self.mean_mass);
        if self.linearized.is_none() {
            let built = PcgSolver::from_options(&opts.newton)
                .and_then(|linear| LinearizedNewton::new(&self.problem, nopts.clone(), linear));
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
        if *lin.newton.options() != nopts
            && let Err(e) = lin.newton.set_options(nopts)
        {
            return Some(Err(StageFailure::Other(e)));
        }
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
                constraints: &self.constraints,
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

/// Before the Newton solve of a reduced stage (either Jacobian): one copy of
/// the step's constraints into the linear solver per stage (they change
/// between steps; none is made while both sets are empty), `kv` projected
/// onto them, and with `last_delta` the warm start: the first correction
/// `V_1 - V_0` guessed so that `V_1 - psi_v` repeats the last stage's
/// `V - psi_v`.
fn begin_stage(
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
fn end_stage(
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
        stats.f_evals += 1;
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
        if self.user_newton != opts.newton {
            self.newton
                .set_options(momentum_options(&opts.newton, self.mean_mass))
                .map_err(StageFailure::Other)?;
            self.user_newton = opts.newton.clone();
        }
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
            constraints: &self.constraints,
        };
        let result = self.newton.solve(&mut stage, kv);
        self.newton.linear_solver_mut().disarm_guess();
        let info = account(result, 0, stats)?;
        end_stage(kx, kv, psi_x, psi_v, gh, &mut self.last_delta);
        self.last_delta_gh = gh;
        Ok(info)
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
