//! Linear solvers for the Newton correction `J s = -G` (step (4) of the
//! tutorial's Algorithms 1-3): PCG with any hookean-sparse preconditioner,
//! faer's dense partial-pivoting LU and faer's sparse LU.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use hookean_sparse::{
    CgParams, CgWorkspace, Constraints, InitialGuess, LinearOperator, PreconditionerSetup,
    SparseError, filtered_pcg, pcg,
};

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

    /// Whether [`solve`](Self::solve) is exact up to rounding (direct
    /// solvers). Newton then does not spend forcing terms on it.
    fn is_direct(&self) -> bool {
        false
    }
}

/// Preconditioned conjugate gradients ([`hookean_sparse::pcg`]) for
/// symmetric positive definite Jacobians, e.g. the cloth matrix
/// `M - h df/dv - h^2 df/dx` (the tutorial's section 4).
///
/// Works for every Jacobian type `A` that is a [`LinearOperator`] and that
/// the preconditioner `P` can be set up from
/// ([`SymBlockMatrix`](hookean_sparse::SymBlockMatrix) and `sprs::CsMat<f64>`
/// with every hookean-sparse preconditioner; any operator with
/// [`Identity`](hookean_sparse::Identity)).
///
/// With [`constraints`](Self::with_constraints), the filtered PCG of
/// Baraff-Witkin (the tutorial's Algorithm 4) is used: the values the
/// constraints prescribe are imposed on every Newton *correction*, so they
/// should normally be zero (the initial iterate already satisfies the
/// constraints, and corrections must not move it off them). The residual
/// `G` of such a system should then be filtered too (`G <- P G`), so that
/// Newton's convergence test sees only the free directions.
#[derive(Debug, Clone)]
pub struct PcgSolver<P> {
    precond: P,
    /// Iteration limit per solve; `None` means `2 n`. Default `None`.
    pub max_iter: Option<usize>,
    constraints: Option<Constraints>,
    workspace: CgWorkspace,
}

impl<P> PcgSolver<P> {
    /// A PCG solver with the given (not yet set up) preconditioner.
    pub fn new(precond: P) -> Self {
        Self {
            precond,
            max_iter: None,
            constraints: None,
            workspace: CgWorkspace::default(),
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

    /// The constraints, for refilling them in place between steps.
    pub fn constraints_mut(&mut self) -> Option<&mut Constraints> {
        self.constraints.as_mut()
    }

    /// The preconditioner.
    pub fn preconditioner(&self) -> &P {
        &self.precond
    }
}

impl<A, P> LinearSolver<A> for PcgSolver<P>
where
    A: LinearOperator + ?Sized,
    P: PreconditionerSetup<A>,
{
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
            return Err(invalid("rtol", format!("must be >= 0, got {rtol}")));
        }
        let params = CgParams {
            rtol,
            atol: 0.0,
            max_iter: self.max_iter,
            initial_guess: InitialGuess::Zero,
            record_history: false,
        };
        let info = match &self.constraints {
            Some(c) => filtered_pcg(
                jac,
                &self.precond,
                rhs,
                x,
                c,
                &params,
                &mut self.workspace,
                None,
            )?,
            None => pcg(
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
