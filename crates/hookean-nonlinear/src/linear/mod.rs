//! Linear solvers for the Newton correction `J s = -G` (step (4) of the
//! tutorial's Algorithms 1-3): PCG with any hookean-sparse preconditioner
//! ([`PcgSolver`], which owns its [`PcgOptions`]), matrix-free GMRES
//! ([`GmresSolver`]), faer's dense partial-pivoting LU ([`DenseLu`]) and
//! faer's sparse LU ([`SparseLu`]). Each solver owns its settings; Newton
//! only hands it a relative tolerance per solve.

mod dense_lu;
mod gmres;
mod pcg;
mod record;
mod sparse_lu;

pub use dense_lu::DenseLu;
pub use gmres::{GmresCounters, GmresSolver};
pub use pcg::{PcgOptions, PcgSolver};
pub use record::{RecordedSolve, SharedRecorder, SolveRecorder};
pub use sparse_lu::SparseLu;

use crate::error::NonlinearError;

/// What one linear solve did; summed into [`NewtonStats`](crate::NewtonStats).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LinearSolveStats {
    /// Iterations of an iterative solver (matrix-vector products); 0 for a direct solver.
    pub iterations: usize,
    /// `|J x - rhs|` at exit as the solver knows it (the recursively updated
    /// CG residual, the forcing terms' `|G + J s|`; GMRES's true residual; 0
    /// for direct solvers, which do not compute it).
    pub residual_norm: f64,
    /// The true `|J x - rhs| / |rhs|` at exit (0 for direct solvers).
    pub relative_residual: f64,
    /// Whether the requested tolerance was met by the true residual (always
    /// `true` for direct solvers; for GMRES, see its CVODE rule).
    pub converged: bool,
    /// Whether an iterative solve stopped early on a direction of
    /// non-positive curvature and returned its iterate so far (a descent
    /// direction; [`PcgOptions::negative_curvature`]). Newton takes it as
    /// its correction.
    pub truncated: bool,
}

/// The product `out = J v` of the current Newton Jacobian with a vector,
/// as the system computes it without the matrix
/// ([`NonlinearSystem::jacobian_product`](crate::NonlinearSystem::jacobian_product)),
/// handed to matrix-free solvers.
pub type JacobianProduct<'a> = dyn FnMut(&[f64], &mut [f64]) -> Result<(), NonlinearError> + 'a;

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

    /// As [`solve`](Self::solve), with `product` computing `J v` at the
    /// current iterate without the matrix (the system's
    /// [`jacobian_product`](crate::NonlinearSystem::jacobian_product)).
    /// [`Newton`](crate::Newton) calls it instead of `solve` for solvers that
    /// are [`is_matrix_free`](Self::is_matrix_free); the default ignores
    /// `product`.
    ///
    /// # Errors
    /// As [`solve`](Self::solve), and the errors of `product`.
    fn solve_with_product(
        &mut self,
        jac: &J,
        product: &mut JacobianProduct<'_>,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let _ = product;
        self.solve(jac, rhs, x, rtol)
    }

    /// Whether [`solve`](Self::solve) is exact up to rounding (direct
    /// solvers). Newton then does not spend forcing terms on it.
    fn is_direct(&self) -> bool {
        false
    }

    /// Whether the solver multiplies by the Jacobian through the system's
    /// products ([`solve_with_product`](Self::solve_with_product)) rather
    /// than through the stored `jac`.
    fn is_matrix_free(&self) -> bool {
        false
    }
}
