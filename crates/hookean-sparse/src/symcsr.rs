//! A symmetric scalar matrix stored as its upper triangle ([`SymCsrMatrix`]):
//! the scalar counterpart of [`SymBlockMatrix`](crate::SymBlockMatrix) for
//! PCG's products.
//!
//! CG spends most of its time in `q = A p`, which streams the matrix once
//! per iteration: the memory bandwidth bounds it. Full CSR with `usize`
//! indices (`sprs::CsMat<f64>`) moves 16 bytes per stored entry; the upper
//! triangle with `u32` column indices moves 12 bytes per entry of half the
//! entries (plus the diagonal), and applies each off-diagonal entry twice
//! (`a_ij p_j` to row `i`, `a_ij p_i` to row `j`), as Eigen's self-adjoint
//! product does with one triangle.

use crate::error::SparseError;
use crate::operator::LinearOperator;

/// A symmetric `n x n` matrix as the upper triangle of CSR: each row holds
/// its diagonal entry first (zero when the input has none), then the
/// entries right of the diagonal in increasing column order.
///
/// ```
/// use hookean_sparse::{LinearOperator, SymCsrMatrix, sprs};
/// // [[4, 1], [1, 3]], both triangles stored as sprs holds them.
/// let a = sprs::CsMat::new((2, 2), vec![0, 2, 4], vec![0, 1, 0, 1], vec![4.0, 1.0, 1.0, 3.0]);
/// let s = SymCsrMatrix::from_csr(&a)?;
/// let mut y = [0.0; 2];
/// s.apply(&[1.0, 2.0], &mut y);
/// assert_eq!(y, [6.0, 7.0]);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SymCsrMatrix {
    n: usize,
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<f64>,
}

impl SymCsrMatrix {
    /// The upper triangle of a square, symmetric `sprs` matrix (CSR or
    /// CSC, both triangles stored).
    ///
    /// # Errors
    /// [`SparseError::NotSquare`], [`SparseError::NonFinite`],
    /// [`SparseError::NotSymmetric`] (an entry differs from its transpose by
    /// more than `1e-12` of the largest entry: a matrix stored as one
    /// triangle is such a matrix), [`SparseError::InvalidParameter`] above
    /// `u32::MAX` rows.
    pub fn from_csr(a: &sprs::CsMat<f64>) -> Result<Self, SparseError> {
        let n = crate::precond::square_dim(a)?;
        if n > u32::MAX as usize {
            return Err(SparseError::InvalidParameter {
                name: "matrix",
                message: format!("{n} rows exceed the u32 index range"),
            });
        }
        crate::matrix::check_csr_symmetric(a)?;
        let csr = crate::precond::as_csr(a);
        let indptr = csr.proper_indptr();
        let (indices, data) = (csr.indices(), csr.data());
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col = Vec::new();
        let mut val = Vec::new();
        row_ptr.push(0);
        for i in 0..n {
            let (s, e) = (indptr[i], indptr[i + 1]);
            let diag = (s..e).find(|&k| indices[k] == i).map_or(0.0, |k| data[k]);
            col.push(i as u32);
            val.push(diag);
            for k in s..e {
                if indices[k] > i {
                    col.push(indices[k] as u32);
                    val.push(data[k]);
                }
            }
            row_ptr.push(col.len());
        }
        Ok(Self {
            n,
            row_ptr,
            col,
            val,
        })
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Entries stored (the diagonal and the upper triangle).
    pub fn stored(&self) -> usize {
        self.val.len()
    }

    /// Row `i`'s `(p_i after the update, y_i from the upper triangle, the
    /// off-diagonal part of p . A p)`, adding `a_ij p_i` to the `y_j` of the
    /// rows right of the diagonal. Rows are visited in decreasing order, so
    /// `p_j` (j > i) is already updated and `y_j` already assigned.
    #[inline]
    fn row(&self, i: usize, pi: f64, p: &[f64], y: &mut [f64]) -> (f64, f64) {
        let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
        let mut yi = self.val[s] * pi;
        let mut off = 0.0;
        for (&j, &a) in self.col[s + 1..e].iter().zip(&self.val[s + 1..e]) {
            let j = j as usize;
            let pj = p[j];
            yi += a * pj;
            off += a * pj;
            y[j] += a * pi;
        }
        (yi, off)
    }
}

impl LinearOperator for SymCsrMatrix {
    fn nrows(&self) -> usize {
        self.n
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.apply_dot(x, y);
    }

    /// `y = A x` and `x . A x` in one pass: `sum a_ii x_i^2 + 2 sum_{i<j}
    /// a_ij x_i x_j` from the stored entries.
    fn apply_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let mut dot = 0.0;
        for i in (0..self.n).rev() {
            let xi = x[i];
            let (yi, off) = self.row(i, xi, x, y);
            y[i] = yi;
            dot += self.val[self.row_ptr[i]] * xi * xi + 2.0 * xi * off;
        }
        dot
    }

    /// CG's `x += alpha p`, `p = z + beta p`, `q = A p` and `p . q` in one
    /// pass over the matrix and the vectors.
    fn update_and_apply_dot(
        &self,
        z: &[f64],
        beta: f64,
        alpha: f64,
        x: &mut [f64],
        p: &mut [f64],
        q: &mut [f64],
    ) -> f64 {
        let mut dot = 0.0;
        for i in (0..self.n).rev() {
            x[i] += alpha * p[i];
            let pi = z[i] + beta * p[i];
            p[i] = pi;
            let (qi, off) = self.row(i, pi, p, q);
            q[i] = qi;
            dot += self.val[self.row_ptr[i]] * pi * pi + 2.0 * pi * off;
        }
        dot
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A random symmetric matrix with both triangles and some rows without
    /// a diagonal entry, as triplets.
    fn random_symmetric(n: usize, seed: u64) -> sprs::CsMat<f64> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut t = sprs::TriMat::new((n, n));
        for i in 0..n {
            if i % 5 != 3 {
                t.add_triplet(i, i, 4.0 + next());
            }
            for _ in 0..3 {
                let j = (next() * n as f64) as usize % n;
                if j != i {
                    let v = next() - 0.5;
                    t.add_triplet(i, j, v);
                    t.add_triplet(j, i, v);
                }
            }
        }
        t.to_csr()
    }

    /// The product and the fused CG update against sprs's full CSR product
    /// and plain loops.
    #[test]
    fn products_match_the_full_matrix() {
        let a = random_symmetric(57, 7);
        let s = SymCsrMatrix::from_csr(&a).unwrap();
        assert_eq!(
            s.stored(),
            57 + (a.nnz() - (0..57).filter(|i| i % 5 != 3).count()) / 2
        );
        let x: Vec<f64> = (0..57).map(|i| (i as f64 * 0.37).sin()).collect();
        let (mut y, mut y_ref) = (vec![9.0; 57], vec![0.0; 57]);
        let dot = s.apply_dot(&x, &mut y);
        a.apply(&x, &mut y_ref);
        for (u, v) in y.iter().zip(&y_ref) {
            assert!((u - v).abs() < 1e-13, "{u} {v}");
        }
        let dot_ref: f64 = x.iter().zip(&y_ref).map(|(a, b)| a * b).sum();
        assert!((dot - dot_ref).abs() < 1e-12 * dot_ref.abs().max(1.0));

        let z: Vec<f64> = (0..57).map(|i| (i as f64 * 0.11).cos()).collect();
        let (alpha, beta) = (0.3, 0.7);
        let (mut x1, mut p1, mut q1) = (x.clone(), z.clone(), vec![0.0; 57]);
        let (mut x2, mut p2, mut q2) = (x.clone(), z.clone(), vec![0.0; 57]);
        let d1 = s.update_and_apply_dot(&z, beta, alpha, &mut x1, &mut p1, &mut q1);
        for i in 0..57 {
            x2[i] += alpha * p2[i];
            p2[i] = z[i] + beta * p2[i];
        }
        a.apply(&p2, &mut q2);
        let d2: f64 = p2.iter().zip(&q2).map(|(a, b)| a * b).sum();
        assert_eq!(x1, x2);
        assert_eq!(p1, p2);
        for (u, v) in q1.iter().zip(&q2) {
            assert!((u - v).abs() < 1e-13);
        }
        assert!((d1 - d2).abs() < 1e-12 * d2.abs().max(1.0));
    }

    #[test]
    fn one_triangle_and_non_square_matrices_are_refused() {
        let a = random_symmetric(10, 3);
        let mut t = sprs::TriMat::new((10, 10));
        for (&v, (r, c)) in a.iter() {
            if c >= r {
                t.add_triplet(r, c, v);
            }
        }
        assert!(matches!(
            SymCsrMatrix::from_csr(&t.to_csr()),
            Err(SparseError::NotSymmetric { .. })
        ));
        let rect = sprs::CsMat::new((1, 2), vec![0, 1], vec![0], vec![1.0]);
        assert!(matches!(
            SymCsrMatrix::from_csr(&rect),
            Err(SparseError::NotSquare { .. })
        ));
    }
}
