//! Preconditioners for CG (the tutorial's section 4.1).
//!
//! A preconditioner `M ~ A` is set up from a matrix once per refill
//! ([`PreconditionerSetup::setup`]; symbolic work is reused while the
//! sparsity pattern stays the same) and then applied as `z = M^-1 r` in
//! every CG iteration ([`Preconditioner::apply`], which never allocates).
//!
//! | type | `M` | setup | apply |
//! |---|---|---|---|
//! | [`Identity`] | `I` | nothing | copy |
//! | [`Jacobi`] | `diag(A)` (eq. 53) | one pass | `n` multiplications |
//! | [`BlockJacobi`] | diagonal blocks of `A`, one per node of `B` unknowns | `B x B` inverses | `B n` |
//! | [`Ssor`] | `(D + wL) D^-1 (D + wL^T) / (w (2 - w))` (eq. 54) | copy of `A` | two triangular sweeps |
//! | [`IncompleteCholesky`] | `L L^T`, `L` on the pattern of `A` | IC(0) factorisation | two triangular solves (3x3 blocks from 2 048 block rows: two domains side by side) |
//! | [`Amg`] | smoothed-aggregation V-cycle | aggregates, `P`, Galerkin `P^T A P` per level | one V-cycle |
//!
//! Every preconditioner is implemented for [`SymBlockMatrix`](crate::SymBlockMatrix)
//! and for scalar `sprs::CsMat<f64>`; [`AnyPreconditioner`] picks one by name.

mod amg;
mod any;
mod block_ic0;
mod ic0;
mod jacobi;
mod ssor;
mod two_domain;

pub use amg::{
    AMG_MAX_COARSE_SIZE, AMG_MAX_LEVELS, AMG_MAX_SWEEPS, AMG_NEAR_NULLSPACE_SHAPES, Amg,
    AmgLevelStats, AmgOptions, AmgPrecision, AmgReuse, AmgSmoother, AmgStats,
    amg_takes_near_nullspace, rigid_body_modes,
};
pub use any::{AnyPreconditioner, PrecondKind, PreconditionerOptions};
pub use ic0::IncompleteCholesky;
pub use jacobi::{BlockJacobi, Identity, Jacobi};
pub use ssor::Ssor;

use crate::error::SparseError;
use crate::vecops::dot;

/// Applies `z = M^-1 r` for a symmetric positive definite `M ~ A`.
pub trait Preconditioner {
    /// The dimension this preconditioner was set up for, or `None` if it
    /// works for any dimension (the identity).
    fn dim(&self) -> Option<usize>;

    /// Computes `z = M^-1 r`, overwriting `z`. Never allocates.
    ///
    /// # Panics
    /// May panic if `r` or `z` does not have length [`dim`](Self::dim) or if
    /// the preconditioner was never set up; CG checks both before calling.
    fn apply(&self, r: &[f64], z: &mut [f64]);

    /// Computes `z = M^-1 r` and returns `r . z`; pointwise preconditioners
    /// fuse the two.
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        self.apply(r, z);
        dot(r, z)
    }

    /// CG's residual update fused with the preconditioner: `r -= alpha q`,
    /// `z = M^-1 r`; returns `(r . r, r . z)` of the new `r`. Pointwise
    /// preconditioners (Jacobi) do it in one pass.
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        let rr = crate::vecops::update_residual(alpha, q, r);
        (rr, self.apply_dot(r, z))
    }

    /// Whether one application costs several products with `A` (multigrid),
    /// so that CG should, in an iteration predicted to be its last, update
    /// `r` and test `|r|` before applying the preconditioner instead of
    /// calling the fused [`update_and_apply`](Self::update_and_apply): one
    /// more pass over `r` and `q` against an application saved per solve.
    /// Default `false` (cheap preconditioners keep the fused pass and their bits).
    fn costly(&self) -> bool {
        false
    }
}

/// Builds (or rebuilds) a preconditioner from a matrix of type `A`.
pub trait PreconditionerSetup<A: ?Sized>: Preconditioner {
    /// Computes the preconditioner of `a`. Calling it again after the values
    /// of `a` changed (same pattern) reuses the symbolic work and allocates
    /// nothing.
    ///
    /// # Errors
    /// A typed [`SparseError`] when `a` is unfit for this preconditioner
    /// (not square, non-positive diagonal, singular block, ...).
    fn setup(&mut self, a: &A) -> Result<(), SparseError>;
}

impl<P: Preconditioner + ?Sized> Preconditioner for &P {
    fn dim(&self) -> Option<usize> {
        (**self).dim()
    }
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        (**self).apply(r, z)
    }
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        (**self).apply_dot(r, z)
    }
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        (**self).update_and_apply(alpha, q, r, z)
    }
    fn costly(&self) -> bool {
        (**self).costly()
    }
}

/// Checks that a `sprs` matrix is square and returns its dimension.
pub(crate) fn square_dim(a: &sprs::CsMat<f64>) -> Result<usize, SparseError> {
    let (rows, cols) = a.shape();
    if rows != cols {
        return Err(SparseError::NotSquare { rows, cols });
    }
    crate::error::non_empty("matrix", rows)
}

/// `a` in CSR form: itself, or a converted copy of a CSC matrix.
pub(crate) fn as_csr(a: &sprs::CsMat<f64>) -> std::borrow::Cow<'_, sprs::CsMat<f64>> {
    if a.is_csr() {
        std::borrow::Cow::Borrowed(a)
    } else {
        std::borrow::Cow::Owned(a.to_csr())
    }
}

/// `Ok` unless the CSR pattern (`indptr`, `indices`) stores off-diagonal
/// entries in one triangle only: the symmetric preconditioners (SSOR, IC(0),
/// multigrid) read both triangles, and a matrix stored as its upper half would
/// silently be a different matrix to them. Checked when a pattern is first
/// seen (O(nnz)), not at every refill.
///
/// # Errors
/// [`SparseError::OneTriangle`] naming `who` and the stored triangle.
pub(crate) fn check_both_triangles(
    indptr: &[usize],
    indices: &[usize],
    who: &'static str,
) -> Result<(), SparseError> {
    let (mut upper, mut lower) = (false, false);
    for (row, w) in indptr.windows(2).enumerate() {
        for &col in &indices[w[0]..w[1]] {
            upper |= col > row;
            lower |= col < row;
        }
        if upper && lower {
            return Ok(());
        }
    }
    let stored = match (upper, lower) {
        (true, false) => "upper",
        (false, true) => "lower",
        _ => return Ok(()), // diagonal, or both
    };
    Err(SparseError::OneTriangle {
        preconditioner: who,
        stored,
    })
}

#[cfg(test)]
pub(crate) mod testutil {
    //! Dense references for preconditioner tests.
    use std::sync::Arc;

    use crate::{BlockPattern, SymBlockMatrix};

    /// The couplings of a 2D grid of `nx x ny` particles: right, up and one
    /// diagonal (so the other diagonal is fill that IC(0) drops).
    pub fn grid_pairs(nx: usize, ny: usize) -> Vec<(usize, usize)> {
        let id = |x: usize, y: usize| y * nx + x;
        let mut pairs = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                if x + 1 < nx {
                    pairs.push((id(x, y), id(x + 1, y)));
                }
                if y + 1 < ny {
                    pairs.push((id(x, y), id(x, y + 1)));
                }
                if x + 1 < nx && y + 1 < ny {
                    pairs.push((id(x, y), id(x + 1, y + 1)));
                }
            }
        }
        pairs
    }

    /// A small SPD block matrix with dense, non-symmetric-looking blocks on
    /// the [`grid_pairs`] of an `nx x ny` grid.
    pub fn spd_block_matrix(nx: usize, ny: usize) -> SymBlockMatrix {
        let n = nx * ny;
        let pairs = grid_pairs(nx, ny);
        let pattern = Arc::new(BlockPattern::new(n, pairs.iter().copied()).unwrap());
        let mut a = SymBlockMatrix::new(pattern);
        // A graph Laplacian of spring blocks k u u^T + 0.3 k (I - u u^T), plus mass.
        for (e, &(i, j)) in pairs.iter().enumerate() {
            let t = e as f64 * 0.37;
            let u = [t.cos() * 0.8, t.sin() * 0.8, 0.6];
            let k = 1.0 + (e % 5) as f64;
            let mut b = [[0.0; 3]; 3];
            for r in 0..3 {
                for c in 0..3 {
                    let id = if r == c { 1.0 } else { 0.0 };
                    b[r][c] = k * (u[r] * u[c] + 0.3 * (id - u[r] * u[c]));
                }
            }
            a.add_to_block(i, i, &b).unwrap();
            a.add_to_block(j, j, &b).unwrap();
            let neg = crate::block::scale(&b, -1.0);
            a.add_to_block(i, j, &neg).unwrap();
        }
        let mass: Vec<f64> = (0..3 * n).map(|i| 0.05 + 0.01 * (i % 7) as f64).collect();
        a.add_to_diagonal(&mass).unwrap();
        a
    }

    /// Row-major dense copy.
    pub fn dense(a: &SymBlockMatrix) -> Vec<Vec<f64>> {
        let n = a.dim();
        let csr = a.to_csr();
        let mut d = vec![vec![0.0; n]; n];
        for (&v, (r, c)) in csr.iter() {
            d[r][c] = v;
        }
        d
    }

    /// Solves `m x = b` by Gaussian elimination with partial pivoting.
    pub fn dense_solve(m: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
        let n = b.len();
        let mut a: Vec<Vec<f64>> = m.to_vec();
        let mut x = b.to_vec();
        for k in 0..n {
            let p = (k..n)
                .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
                .unwrap();
            a.swap(k, p);
            x.swap(k, p);
            for i in k + 1..n {
                let f = a[i][k] / a[k][k];
                for j in k..n {
                    a[i][j] -= f * a[k][j];
                }
                x[i] -= f * x[k];
            }
        }
        for k in (0..n).rev() {
            let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
            x[k] = (x[k] - s) / a[k][k];
        }
        x
    }

    /// `a * b` for dense matrices.
    pub fn matmul(a: &[Vec<f64>], b: &[Vec<f64>]) -> Vec<Vec<f64>> {
        let n = a.len();
        let m = b[0].len();
        let mut c = vec![vec![0.0; m]; n];
        for i in 0..n {
            for k in 0..b.len() {
                if a[i][k] != 0.0 {
                    for j in 0..m {
                        c[i][j] += a[i][k] * b[k][j];
                    }
                }
            }
        }
        c
    }

    /// A test vector.
    pub fn rhs(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| ((i * 7 + 3) as f64 * 0.31).sin() + 0.1)
            .collect()
    }

    /// `max |a - b| / max |b|`.
    pub fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
        let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        a.iter()
            .zip(b)
            .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
            / scale
    }
}
