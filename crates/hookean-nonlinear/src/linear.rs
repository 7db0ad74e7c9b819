//! Linear solvers for the Newton correction `J s = -G` (step (4) of the
//! tutorial's Algorithms 1-3): PCG with any hookean-sparse preconditioner,
//! faer's dense partial-pivoting LU and faer's sparse LU.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use std::any::Any;

use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, Constraints, InitialGuess, LinearOperator,
    NegativeCurvature, PreconditionerSetup, SparseError, filtered_pcg, pcg,
};

use crate::NewtonOptions;
use crate::error::{NonlinearError, check_len, invalid};

/// What one linear solve did; summed into [`NewtonStats`](crate::NewtonStats).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinearSolveStats {
    /// Iterations of an iterative solver (matrix-vector products); 0 for a direct solver.
    pub iterations: usize,
    /// `|J x - rhs|` at exit as the solver knows it (the recursively updated
    /// CG residual; 0 for direct solvers, which do not compute it).
    pub residual_norm: f64,
    /// `|J x - rhs| / |rhs|` at exit (0 for direct solvers).
    pub relative_residual: f64,
    /// Whether the requested tolerance was met (always `true` for direct solvers).
    pub converged: bool,
    /// Whether an iterative solve stopped early on a direction of
    /// non-positive curvature and returned its iterate so far (a descent
    /// direction; [`NewtonOptions::negative_curvature`]). Newton takes it as
    /// its correction.
    pub truncated: bool,
}

/// A solver for `J x = rhs` with the Jacobian type `J`.
///
/// [`setup`](Self::setup) is called after every Jacobian evaluation
/// (factorise, or set up a preconditioner); [`solve`](Self::solve) once per
/// Newton iteration, with the same Jacobian and a relative tolerance: an
/// iterative solver must return `x` with `|J x - rhs| <= rtol |rhs|` (the
/// inexact-Newton condition of the tutorial's Algorithm 2 with
/// `rtol = eta_k`), or report `converged = false`; a direct solver ignores it.
pub trait LinearSolver<J: ?Sized> {
    /// Prepares for solves with `jac` (factorisation, preconditioner setup).
    ///
    /// # Errors
    /// Singular or non-finite matrices, preconditioner failures, wrong sizes.
    fn setup(&mut self, jac: &J) -> Result<(), NonlinearError>;

    /// Solves `jac x = rhs` to relative residual `rtol`; `x` is overwritten
    /// (iterative solvers start from `x = 0`).
    ///
    /// # Errors
    /// Wrong sizes, NaN, breakdown (e.g. PCG on an indefinite matrix), or
    /// [`NonlinearError::NotReady`] before a successful [`setup`](Self::setup).
    fn solve(
        &mut self,
        jac: &J,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError>;

    /// Takes the linear-solver settings of the Newton options (called by
    /// [`Newton::new`](crate::Newton::new) and
    /// [`Newton::set_options`](crate::Newton::set_options)). Default: nothing.
    ///
    /// # Errors
    /// Invalid settings for this solver.
    fn configure(&mut self, _options: &NewtonOptions) -> Result<(), NonlinearError> {
        Ok(())
    }

    /// Whether [`solve`](Self::solve) is exact up to rounding (direct
    /// solvers). Newton then does not spend forcing terms on it.
    fn is_direct(&self) -> bool {
        false
    }
}

/// Preconditioned conjugate gradients ([`hookean_sparse::pcg`]) for
/// symmetric positive definite Jacobians, e.g. the cloth matrix
/// `M - h df/dv - h^2 df/dx` (the tutorial's section 4): the one Krylov
/// adapter of the workspace (the integrators of `hookean-ode` use it too).
///
/// Works for every Jacobian type `A` that is a [`LinearOperator`] and that
/// the preconditioner `P` can be set up from
/// ([`SymBlockMatrix`](hookean_sparse::SymBlockMatrix) and `sprs::CsMat<f64>`
/// with every hookean-sparse preconditioner; any operator with
/// [`Identity`](hookean_sparse::Identity)). With `P =`
/// [`AnyPreconditioner`] the preconditioner follows
/// [`NewtonOptions::preconditioner`]; the iteration limit always follows
/// [`NewtonOptions::linear_max_iter`].
///
/// **Constraints.** With [`constraints`](Self::with_constraints), the
/// filtered PCG of Baraff-Witkin (the tutorial's Algorithm 4) solves for
/// Newton *corrections* that keep the constrained components unchanged:
/// with `z` the prescribed values, `A s' = rhs + A z` is solved with `s'`
/// taking the values `z`, and `s = s' - z` has zero constrained components
/// (for homogeneous constraints such as pins `z = 0` and no product is
/// needed). The initial iterate should satisfy the constraints, and the
/// residual `G` of such a system should be filtered (`G <- P G`) so that
/// Newton's convergence test sees only the free directions.
///
/// **Warm start.** Every solve starts from zero unless a guess was armed
/// with [`arm_guess`](Self::arm_guess) (used by the next solve only), e.g.
/// the previous time step's correction.
#[derive(Debug, Clone)]
pub struct PcgSolver<P> {
    precond: P,
    /// Iteration limit per solve; `None` means `2 n`. Set from
    /// [`NewtonOptions::linear_max_iter`] by [`Newton`](crate::Newton).
    max_iter: Option<usize>,
    /// From [`NewtonOptions::negative_curvature`].
    negative_curvature: NegativeCurvature,
    constraints: Option<Constraints>,
    workspace: CgWorkspace,
    /// The prescribed values `z` and the shifted right-hand side `rhs + A z`.
    z: Vec<f64>,
    shifted_rhs: Vec<f64>,
    /// The starting guess of the next solve, if armed.
    guess: Vec<f64>,
    use_guess: bool,
}

impl<P> PcgSolver<P> {
    /// A PCG solver with the given (not yet set up) preconditioner.
    pub fn new(precond: P) -> Self {
        Self {
            precond,
            max_iter: None,
            negative_curvature: NegativeCurvature::Error,
            constraints: None,
            workspace: CgWorkspace::default(),
            z: Vec::new(),
            shifted_rhs: Vec::new(),
            guess: Vec::new(),
            use_guess: false,
        }
    }

    /// Uses filtered PCG with these constraints (see the type's docs).
    pub fn with_constraints(mut self, constraints: Constraints) -> Self {
        self.constraints = Some(constraints);
        self
    }

    /// Replaces (or removes) the constraints.
    pub fn set_constraints(&mut self, constraints: Option<Constraints>) {
        self.constraints = constraints;
    }

    /// Copies `constraints` into the solver's own (reusing its storage),
    /// e.g. the constraints of a new time step.
    pub fn copy_constraints(&mut self, constraints: &Constraints) {
        match &mut self.constraints {
            Some(c) => c.clone_from(constraints),
            None => self.constraints = Some(constraints.clone()),
        }
    }

    /// The constraints, for refilling them in place between steps.
    pub fn constraints_mut(&mut self) -> Option<&mut Constraints> {
        self.constraints.as_mut()
    }

    /// The preconditioner.
    pub fn preconditioner(&self) -> &P {
        &self.precond
    }

    /// Arms a starting guess for the next solve only and returns its
    /// storage (length `n`, to be filled by the caller).
    pub fn arm_guess(&mut self, n: usize) -> &mut [f64] {
        self.guess.resize(n, 0.0);
        self.use_guess = true;
        &mut self.guess
    }

    /// Drops an armed guess that the next solve has not used.
    pub fn disarm_guess(&mut self) {
        self.use_guess = false;
    }
}

impl PcgSolver<AnyPreconditioner> {
    /// A PCG solver with the preconditioner and iteration limit of `options`.
    ///
    /// # Errors
    /// [`NonlinearError::Linear`] for an invalid preconditioner parameter.
    pub fn from_options(options: &NewtonOptions) -> Result<Self, NonlinearError> {
        let mut solver = Self::new(AnyPreconditioner::with_amg_options(
            options.preconditioner,
            &options.amg,
        )?);
        solver.max_iter = options.linear_max_iter;
        solver.negative_curvature = options.negative_curvature;
        Ok(solver)
    }
}

impl<A, P> LinearSolver<A> for PcgSolver<P>
where
    A: LinearOperator + ?Sized,
    P: PreconditionerSetup<A> + 'static,
{
    fn configure(&mut self, options: &NewtonOptions) -> Result<(), NonlinearError> {
        self.max_iter = options.linear_max_iter;
        self.negative_curvature = options.negative_curvature;
        let precond: &mut dyn Any = &mut self.precond;
        if let Some(any) = precond.downcast_mut::<AnyPreconditioner>()
            && (any.kind() != options.preconditioner
                || matches!(any, AnyPreconditioner::Amg(amg) if *amg.options() != options.amg))
        {
            *any = AnyPreconditioner::with_amg_options(options.preconditioner, &options.amg)?;
        }
        Ok(())
    }

    fn setup(&mut self, jac: &A) -> Result<(), NonlinearError> {
        self.precond.setup(jac)?;
        Ok(())
    }

    fn solve(
        &mut self,
        jac: &A,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let n = jac.nrows();
        check_len("right-hand side", rhs, n)?;
        check_len("solution", x, n)?;
        if !(rtol >= 0.0) {
            return Err(invalid("rtol", format!("must be >= 0, got {rtol:?}")));
        }
        let initial_guess = if std::mem::take(&mut self.use_guess) {
            check_len("armed guess", &self.guess, n)?;
            x.copy_from_slice(&self.guess);
            InitialGuess::Given
        } else {
            InitialGuess::Zero
        };
        let params = CgParams {
            rtol,
            atol: 0.0,
            max_iter: self.max_iter,
            initial_guess,
            record_history: false,
            negative_curvature: self.negative_curvature,
        };
        let info = match &self.constraints {
            Some(c) if !c.is_empty() => {
                self.z.resize(n, 0.0);
                self.shifted_rhs.resize(n, 0.0);
                self.z.fill(0.0);
                c.impose(&mut self.z);
                if self.z.iter().all(|&v| v == 0.0) {
                    // Homogeneous constraints (pins): A z = 0, no product needed.
                    self.shifted_rhs.copy_from_slice(rhs);
                } else {
                    jac.apply(&self.z, &mut self.shifted_rhs);
                    for i in 0..n {
                        self.shifted_rhs[i] += rhs[i];
                    }
                }
                // A given start needs no shift by z: filtered PCG imposes the
                // prescribed components on it.
                let info = filtered_pcg(
                    jac,
                    &self.precond,
                    &self.shifted_rhs,
                    x,
                    c,
                    &params,
                    &mut self.workspace,
                    None,
                )?;
                for i in 0..n {
                    x[i] -= self.z[i];
                }
                info
            }
            _ => pcg(
                jac,
                &self.precond,
                rhs,
                x,
                &params,
                &mut self.workspace,
                None,
            )?,
        };
        Ok(LinearSolveStats {
            iterations: info.iterations,
            residual_norm: info.residual_norm,
            relative_residual: info.relative_residual,
            converged: info.converged,
            truncated: info.truncated,
        })
    }
}

/// Dense LU with partial pivoting (faer), for small general Jacobians
/// (`faer::Mat<f64>`): the tutorial's scalar examples, first-order systems
/// with a handful of unknowns.
///
/// A pivot `|u_kk| <= n eps max |u_ij|` is reported as
/// [`NonlinearError::SingularJacobian`].
#[derive(Debug, Default)]
pub struct DenseLu {
    lu: Option<faer::linalg::solvers::PartialPivLu<f64>>,
    n: usize,
}

impl DenseLu {
    /// An empty solver.
    pub fn new() -> Self {
        Self::default()
    }
}

impl LinearSolver<faer::Mat<f64>> for DenseLu {
    fn setup(&mut self, jac: &faer::Mat<f64>) -> Result<(), NonlinearError> {
        self.lu = None;
        let (r, c) = (jac.nrows(), jac.ncols());
        if r != c {
            return Err(SparseError::NotSquare { rows: r, cols: c }.into());
        }
        for j in 0..c {
            for i in 0..r {
                if !jac[(i, j)].is_finite() {
                    return Err(SparseError::NonFinite {
                        what: "Jacobian",
                        index: Some(j * r + i),
                    }
                    .into());
                }
            }
        }
        let lu = jac.partial_piv_lu();
        let u = lu.U();
        let mut umax = 0.0f64;
        for j in 0..c {
            for i in 0..=j {
                umax = umax.max(u[(i, j)].abs());
            }
        }
        let tiny = r as f64 * f64::EPSILON * umax;
        for k in 0..r {
            let p = u[(k, k)];
            if !(p.abs() > tiny) {
                return Err(NonlinearError::SingularJacobian { pivot: k, value: p });
            }
        }
        self.lu = Some(lu);
        self.n = r;
        Ok(())
    }

    fn solve(
        &mut self,
        _jac: &faer::Mat<f64>,
        rhs: &[f64],
        x: &mut [f64],
        _rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let lu = self.lu.as_ref().ok_or(NonlinearError::NotReady(
            "DenseLu::solve before a successful setup",
        ))?;
        check_len("right-hand side", rhs, self.n)?;
        check_len("solution", x, self.n)?;
        x.copy_from_slice(rhs);
        lu.solve_in_place(faer::ColMut::from_slice_mut(x));
        Ok(LinearSolveStats {
            converged: true,
            ..Default::default()
        })
    }

    fn is_direct(&self) -> bool {
        true
    }
}

/// Sparse LU with partial pivoting (faer, COLAMD ordering) for general
/// sparse Jacobians stored as `sprs::CsMat<f64>` (CSR or CSC).
///
/// The symbolic analysis is kept while the sparsity pattern is unchanged,
/// so a setup after a refill redoes only the numeric factorisation.
#[derive(Debug, Default)]
pub struct SparseLu {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    symbolic: Option<SymbolicLu<usize>>,
    lu: Option<Lu<usize, f64>>,
    n: usize,
}

impl SparseLu {
    /// An empty solver.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether a symbolic analysis is cached (it is reused by the next
    /// [`setup`](LinearSolver::setup) if the pattern is unchanged).
    pub fn has_symbolic(&self) -> bool {
        self.symbolic.is_some()
    }
}

impl LinearSolver<sprs::CsMat<f64>> for SparseLu {
    fn setup(&mut self, jac: &sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        self.lu = None;
        let (r, c) = jac.shape();
        if r != c {
            return Err(SparseError::NotSquare { rows: r, cols: c }.into());
        }
        let csc_owned;
        let csc = if jac.is_csc() {
            jac
        } else {
            csc_owned = jac.to_other_storage();
            &csc_owned
        };
        let same_pattern = self.symbolic.is_some()
            && self.n == r
            && self.col_ptr.as_slice() == csc.indptr().raw_storage()
            && self.row_idx.as_slice() == csc.indices();
        if !same_pattern {
            self.col_ptr.clear();
            self.col_ptr.extend_from_slice(csc.indptr().raw_storage());
            self.row_idx.clear();
            self.row_idx.extend_from_slice(csc.indices());
            let sym =
                SymbolicSparseColMatRef::new_checked(r, r, &self.col_ptr, None, &self.row_idx);
            let symbolic = SymbolicLu::try_new(sym).map_err(|e| {
                invalid(
                    "Jacobian",
                    format!("sparse LU symbolic analysis failed: {e:?}"),
                )
            })?;
            self.symbolic = Some(symbolic);
        }
        self.values.clear();
        self.values.extend_from_slice(csc.data());
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            return Err(SparseError::NonFinite {
                what: "Jacobian",
                index: Some(i),
            }
            .into());
        }
        let sym = SymbolicSparseColMatRef::new_checked(r, r, &self.col_ptr, None, &self.row_idx);
        let mat = SparseColMatRef::new(sym, &self.values);
        let symbolic = self.symbolic.clone().expect("symbolic analysis set above");
        let lu = Lu::try_new_with_symbolic(symbolic, mat).map_err(|e| match e {
            LuError::SymbolicSingular { index } => NonlinearError::SingularJacobian {
                pivot: index,
                value: 0.0,
            },
            LuError::Generic(g) => invalid("Jacobian", format!("sparse LU failed: {g:?}")),
        })?;
        self.lu = Some(lu);
        self.n = r;
        Ok(())
    }

    fn solve(
        &mut self,
        _jac: &sprs::CsMat<f64>,
        rhs: &[f64],
        x: &mut [f64],
        _rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let lu = self.lu.as_ref().ok_or(NonlinearError::NotReady(
            "SparseLu::solve before a successful setup",
        ))?;
        check_len("right-hand side", rhs, self.n)?;
        check_len("solution", x, self.n)?;
        x.copy_from_slice(rhs);
        lu.solve_in_place(faer::ColMut::from_slice_mut(x));
        // A numerically zero pivot shows up as inf/NaN in the solution.
        if x.iter().any(|v| !v.is_finite()) && rhs.iter().all(|v| v.is_finite()) {
            return Err(NonlinearError::SingularJacobian {
                pivot: 0,
                value: 0.0,
            });
        }
        Ok(LinearSolveStats {
            converged: true,
            ..Default::default()
        })
    }

    fn is_direct(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hookean_sparse::{IncompleteCholesky, Jacobi};
    use hookean_testkit::dense::{rel_diff, solve as dense_solve, to_dense};

    /// A nonsymmetric sparse matrix (convection-diffusion-like), diagonally dominant.
    fn nonsymmetric(n: usize) -> sprs::CsMat<f64> {
        let mut t = sprs::TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 4.0 + (i % 3) as f64);
            if i > 0 {
                t.add_triplet(i, i - 1, -1.5);
            }
            if i + 1 < n {
                t.add_triplet(i, i + 1, -0.5);
            }
            if i + 7 < n {
                t.add_triplet(i, i + 7, 0.25);
            }
        }
        t.to_csr()
    }

    #[test]
    fn sparse_lu_solves_nonsymmetric_systems_and_reuses_the_analysis() {
        let a = nonsymmetric(40);
        let b: Vec<f64> = (0..40).map(|i| (i as f64).cos()).collect();
        let exact = dense_solve(&to_dense(&a), &b);
        let mut lu = SparseLu::new();
        let mut x = vec![0.0; 40];
        assert!(matches!(
            lu.solve(&a, &b, &mut x, 0.0),
            Err(NonlinearError::NotReady(_))
        ));
        lu.setup(&a).unwrap();
        let st = lu.solve(&a, &b, &mut x, 0.0).unwrap();
        assert!(st.converged && st.iterations == 0);
        assert!(rel_diff(&x, &exact) < 1e-13);
        // Refill (same pattern, new values) and solve again: CSC input too.
        let mut a2 = a.to_other_storage();
        for v in a2.data_mut() {
            *v *= 2.0;
        }
        lu.setup(&a2).unwrap();
        assert!(lu.has_symbolic());
        lu.solve(&a2, &b, &mut x, 0.0).unwrap();
        let half: Vec<f64> = exact.iter().map(|v| v / 2.0).collect();
        assert!(rel_diff(&x, &half) < 1e-13);
        // Structurally singular (an empty column) and non-square are errors.
        let mut t = sprs::TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 0, 1.0);
        assert!(matches!(
            lu.setup(&t.to_csr()),
            Err(NonlinearError::SingularJacobian { .. })
        ));
        let rect = sprs::CsMat::<f64>::zero((2, 3));
        assert!(lu.setup(&rect).is_err());
    }

    #[test]
    fn dense_lu_solves_and_detects_singularity() {
        let a = faer::mat![[0.0, 2.0, 1.0], [1.0, 1.0, 0.0], [3.0, 0.0, 1.0]];
        let mut lu = DenseLu::new();
        lu.setup(&a).unwrap();
        let mut x = [0.0; 3];
        lu.solve(&a, &[3.0, 2.0, 4.0], &mut x, 0.0).unwrap();
        // Solution (1, 1, 1) by inspection.
        for v in x {
            approx::assert_abs_diff_eq!(v, 1.0, epsilon = 1e-14);
        }
        let s = faer::mat![[1.0, 2.0], [2.0, 4.0]];
        assert!(matches!(
            lu.setup(&s),
            Err(NonlinearError::SingularJacobian { pivot: 1, .. })
        ));
        assert!(lu.solve(&s, &[1.0, 1.0], &mut [0.0; 2], 0.0).is_err());
        let nan = faer::mat![[f64::NAN]];
        assert!(lu.setup(&nan).is_err());
        assert!(lu.setup(&faer::Mat::<f64>::zeros(2, 3)).is_err());
    }

    #[test]
    fn pcg_solver_meets_the_requested_relative_residual() {
        let a = hookean_testkit::random::random_spd(200, 5, 1.05, 3);
        let b: Vec<f64> = (0..200).map(|i| ((i * 7) % 11) as f64 - 5.0).collect();
        for rtol in [0.5, 0.02, 1e-10] {
            let mut s = PcgSolver::new(Jacobi::new());
            s.setup(&a).unwrap();
            let mut x = vec![0.0; 200];
            let st = s.solve(&a, &b, &mut x, rtol).unwrap();
            assert!(st.converged);
            // The true residual, computed independently.
            let mut ax = vec![0.0; 200];
            a.apply(&x, &mut ax);
            let r: f64 = ax
                .iter()
                .zip(&b)
                .map(|(p, q)| (p - q) * (p - q))
                .sum::<f64>()
                .sqrt();
            let bn: f64 = b.iter().map(|q| q * q).sum::<f64>().sqrt();
            assert!(r <= 1.01 * rtol * bn, "rtol {rtol}: {}", r / bn);
        }
        let mut s = PcgSolver::new(IncompleteCholesky::new());
        s.setup(&a).unwrap();
        let mut x = vec![0.0; 200];
        let loose = s.solve(&a, &b, &mut x, 0.5).unwrap().iterations;
        let tight = s.solve(&a, &b, &mut x, 1e-10).unwrap().iterations;
        assert!(loose < tight);
        assert!(s.solve(&a, &b, &mut x, -1.0).is_err());
        assert!(s.solve(&a, &b[..10], &mut x, 0.1).is_err());
    }
}
