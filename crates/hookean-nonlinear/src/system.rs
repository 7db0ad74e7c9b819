//! The nonlinear-system trait: `G(Y) = 0` (the tutorial's eqs. 46-48).

use crate::error::NonlinearError;

/// A square nonlinear system `G(Y) = 0` of dimension [`dim`](Self::dim).
///
/// Implicit integrators reduce a step to such a system (the tutorial's
/// eqs. 46-48; for cloth the reduced velocity form
/// `G(dv) = M dv - h f(x + h (v + dv), v + dv)`). The Jacobian is whatever
/// the chosen [`LinearSolver`](crate::LinearSolver) can set up: a
/// [`SymBlockMatrix`](hookean_sparse::SymBlockMatrix) for PCG, a dense
/// `faer::Mat<f64>` for [`DenseLu`](crate::DenseLu), a `sprs::CsMat<f64>`
/// for [`SparseLu`](crate::SparseLu) or PCG, or any type implementing
/// [`LinearOperator`](hookean_sparse::LinearOperator) for a matrix-free PCG.
/// Its storage is owned by the [`Newton`](crate::Newton) solver and refilled
/// in place by [`jacobian`](Self::jacobian).
pub trait NonlinearSystem {
    /// The Jacobian's storage type.
    type Jacobian;

    /// Number of unknowns (and of equations).
    fn dim(&self) -> usize;

    /// Writes `G(y)` into `g` (both of length [`dim`](Self::dim)).
    /// Should not allocate: it runs once per Newton iteration.
    ///
    /// # Errors
    /// Whatever the system cannot evaluate; NaN or infinite values may also
    /// simply be written to `g` (Newton reports [`NonlinearError::NonFinite`]).
    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError>;

    /// Refills `jac` with the Jacobian `dG/dY` at `y` (the tutorial's
    /// `J^(k)` of Algorithms 1 and 2).
    ///
    /// # Errors
    /// Whatever the system cannot evaluate (e.g. a sparsity-pattern error,
    /// converted from [`SparseError`](hookean_sparse::SparseError) by `?`).
    fn jacobian(&mut self, y: &[f64], jac: &mut Self::Jacobian) -> Result<(), NonlinearError>;

    /// Refills `jac` with a cheap approximation of the Jacobian and returns
    /// `true`, or returns `false` (the default) if the system has none.
    ///
    /// Used by [`NewtonMethod::InexactSimplified`](crate::NewtonMethod::InexactSimplified)
    /// (the tutorial's Algorithm 3); for cloth it is the constant linearised
    /// Jacobian of eq. (50), which changes only when `h` or the material
    /// changes. Without it the exact Jacobian at the first iterate is used.
    ///
    /// # Errors
    /// As [`jacobian`](Self::jacobian).
    fn approximate_jacobian(
        &mut self,
        y: &[f64],
        jac: &mut Self::Jacobian,
    ) -> Result<bool, NonlinearError> {
        let _ = (y, jac);
        Ok(false)
    }

    /// Writes the product `out = J(y) v` of the Jacobian at `y` with `v`
    /// without the matrix, and returns `true`; `false` (the default) if the
    /// system has no such product. Matrix-free linear solvers
    /// ([`GmresSolver::matrix_free`](crate::GmresSolver::matrix_free)) use
    /// it, with `y` the iterate of the last [`residual`](Self::residual)
    /// call (a system may reuse what that call computed, such as `f(y)`
    /// for a difference quotient).
    ///
    /// # Errors
    /// Whatever the system cannot evaluate.
    fn jacobian_product(
        &mut self,
        y: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) -> Result<bool, NonlinearError> {
        let _ = (y, v, out);
        Ok(false)
    }
}

impl<S: NonlinearSystem + ?Sized> NonlinearSystem for &mut S {
    type Jacobian = S::Jacobian;
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
        (**self).residual(y, g)
    }
    fn jacobian(&mut self, y: &[f64], jac: &mut Self::Jacobian) -> Result<(), NonlinearError> {
        (**self).jacobian(y, jac)
    }
    fn approximate_jacobian(
        &mut self,
        y: &[f64],
        jac: &mut Self::Jacobian,
    ) -> Result<bool, NonlinearError> {
        (**self).approximate_jacobian(y, jac)
    }
    fn jacobian_product(
        &mut self,
        y: &[f64],
        v: &[f64],
        out: &mut [f64],
    ) -> Result<bool, NonlinearError> {
        (**self).jacobian_product(y, v, out)
    }
}
