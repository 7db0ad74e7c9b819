//! The linear-operator trait (`y = A x`) and its implementations: the block
//! matrix, `sprs` matrices and closures (matrix-free operators).

use crate::matrix::SymBlockMatrix;
use crate::vecops::dot;

/// A square linear operator `y = A x` on flat `f64` slices.
///
/// Solvers check vector lengths against [`nrows`](Self::nrows) once at entry,
/// so implementations may assume `x.len() == y.len() == nrows()`.
pub trait LinearOperator {
    /// Dimension of the (square) operator.
    fn nrows(&self) -> usize;

    /// Computes `y = A x`, overwriting `y`.
    ///
    /// # Panics
    /// May panic if `x` or `y` is not of length [`nrows`](Self::nrows); the
    /// solvers of this crate check lengths before calling.
    fn apply(&self, x: &[f64], y: &mut [f64]);

    /// Computes `y = A x` and returns `x . y` (CG's curvature `p^T A p`).
    /// Implementations may fuse the dot product into the product's pass.
    fn apply_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        self.apply(x, y);
        dot(x, y)
    }

    /// CG's updates fused with the product: `x <- x + alpha p` (the previous
    /// iteration's step, with the old `p`), then `p <- z + beta p`, `q = A p`;
    /// returns `p . q`. The block matrix does all of it in one pass.
    fn update_and_apply_dot(
        &self,
        z: &[f64],
        beta: f64,
        alpha: f64,
        x: &mut [f64],
        p: &mut [f64],
        q: &mut [f64],
    ) -> f64 {
        crate::vecops::update_x_p(z, beta, alpha, x, p);
        self.apply_dot(p, q)
    }

    /// A copy of the operator's entries as CSR (both triangles), when it is
    /// a stored matrix; `None` (the default) for a matrix-free operator. It
    /// allocates: for recording the systems a solver saw
    /// (`hookean_nonlinear::SolveRecorder`), never for a solve.
    fn stored_matrix(&self) -> Option<sprs::CsMat<f64>> {
        None
    }
}

impl<T: LinearOperator + ?Sized> LinearOperator for &T {
    fn nrows(&self) -> usize {
        (**self).nrows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (**self).apply(x, y)
    }
    fn apply_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        (**self).apply_dot(x, y)
    }
    fn update_and_apply_dot(
        &self,
        z: &[f64],
        beta: f64,
        alpha: f64,
        x: &mut [f64],
        p: &mut [f64],
        q: &mut [f64],
    ) -> f64 {
        (**self).update_and_apply_dot(z, beta, alpha, x, p, q)
    }
    fn stored_matrix(&self) -> Option<sprs::CsMat<f64>> {
        (**self).stored_matrix()
    }
}

impl LinearOperator for SymBlockMatrix {
    fn nrows(&self) -> usize {
        self.dim()
    }
    #[inline]
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.spmv_dot(x, y);
    }
    #[inline]
    fn apply_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        self.spmv_dot(x, y)
    }
    #[inline]
    fn update_and_apply_dot(
        &self,
        z: &[f64],
        beta: f64,
        alpha: f64,
        x: &mut [f64],
        p: &mut [f64],
        q: &mut [f64],
    ) -> f64 {
        self.update_spmv_dot(z, beta, alpha, x, p, q)
    }
    /// Every stored block and its transpose ([`SymBlockMatrix::to_csr`]).
    fn stored_matrix(&self) -> Option<sprs::CsMat<f64>> {
        Some(self.to_csr())
    }
}

/// A `sprs` matrix in CSR or CSC storage. It must be square; the solvers
/// check that before use.
///
/// The product is of the matrix *as stored*: a symmetric matrix must store
/// both triangles (a Matrix Market file marked `symmetric` is expanded by
/// [`read_matrix_market`](crate::read_matrix_market)). The symmetric
/// preconditioners refuse a one-triangle matrix
/// ([`SparseError::OneTriangle`](crate::SparseError::OneTriangle)); Jacobi
/// reads only the diagonal and accepts any storage.
impl LinearOperator for sprs::CsMat<f64> {
    fn nrows(&self) -> usize {
        self.rows()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let indptr = self.indptr();
        let indptr = indptr.raw_storage();
        let offset = indptr[0];
        let indices = self.indices();
        let data = self.data();
        if self.is_csr() {
            for (i, yi) in y.iter_mut().enumerate() {
                let (s, e) = (indptr[i] - offset, indptr[i + 1] - offset);
                let mut acc = 0.0;
                for k in s..e {
                    acc += data[k] * x[indices[k]];
                }
                *yi = acc;
            }
        } else {
            y.fill(0.0);
            for (j, &xj) in x.iter().enumerate() {
                let (s, e) = (indptr[j] - offset, indptr[j + 1] - offset);
                for k in s..e {
                    y[indices[k]] += data[k] * xj;
                }
            }
        }
    }
    fn stored_matrix(&self) -> Option<sprs::CsMat<f64>> {
        Some(self.to_csr())
    }
}

/// A matrix-free operator: any closure `f(x, y)` that writes `y = A x`.
///
/// ```
/// use hookean_sparse::{LinearOperator, MatrixFree};
/// // The 1D Laplacian with Dirichlet ends, never stored.
/// let n = 4;
/// let laplace = MatrixFree::new(n, |x: &[f64], y: &mut [f64]| {
///     for i in 0..x.len() {
///         let left = if i > 0 { x[i - 1] } else { 0.0 };
///         let right = if i + 1 < x.len() { x[i + 1] } else { 0.0 };
///         y[i] = 2.0 * x[i] - left - right;
///     }
/// });
/// let mut y = vec![0.0; n];
/// laplace.apply(&[1.0; 4], &mut y);
/// assert_eq!(y, [1.0, 0.0, 0.0, 1.0]);
/// ```
#[derive(Debug, Clone)]
pub struct MatrixFree<F> {
    n: usize,
    f: F,
}

impl<F: Fn(&[f64], &mut [f64])> MatrixFree<F> {
    /// Wraps `f` as an `n x n` operator.
    pub fn new(n: usize, f: F) -> Self {
        Self { n, f }
    }
}

impl<F: Fn(&[f64], &mut [f64])> LinearOperator for MatrixFree<F> {
    fn nrows(&self) -> usize {
        self.n
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        (self.f)(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csr_and_csc_products_agree() {
        let mut t = sprs::TriMat::new((3, 3));
        for (r, c, v) in [
            (0, 0, 2.0),
            (0, 2, -1.0),
            (1, 1, 3.0),
            (2, 0, 4.0),
            (2, 2, 1.0),
        ] {
            t.add_triplet(r, c, v);
        }
        let x = [1.0, 2.0, 3.0];
        let mut y1 = [0.0; 3];
        let mut y2 = [0.0; 3];
        t.to_csr::<usize>().apply(&x, &mut y1);
        t.to_csc::<usize>().apply(&x, &mut y2);
        assert_eq!(y1, [-1.0, 6.0, 7.0]);
        assert_eq!(y1, y2);
    }
}
