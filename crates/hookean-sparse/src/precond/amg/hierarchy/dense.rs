//! The coarsest level's direct solve: a dense Cholesky factor of its
//! operator, refactored at every refill.

use super::super::bsr::{Bsr, Entry};

/// The dense Cholesky factor `L` (row-major, lower triangle) of the coarsest operator.
#[derive(Debug, Clone)]
pub(super) struct DenseCholesky {
    n: usize,
    l: Vec<f64>,
}

impl DenseCholesky {
    pub fn new(n: usize) -> Self {
        Self {
            n,
            l: vec![0.0; n * n],
        }
    }

    /// Factors the symmetric part of `a`; `Err(row)` at the first pivot that
    /// is not positive (relative to the row's diagonal entry).
    pub fn factor<const B: usize, S: Entry>(&mut self, a: &Bsr<B, S>) -> Result<(), usize> {
        let n = self.n;
        let m = &mut self.l;
        m.fill(0.0);
        for i in 0..a.nrows {
            for k in a.row(i) {
                let j = a.col[k] as usize;
                for r in 0..B {
                    for c in 0..B {
                        m[(B * i + r) * n + B * j + c] += a.val[k][r][c].load();
                    }
                }
            }
        }
        for i in 0..n {
            for j in 0..i {
                let s = 0.5 * (m[i * n + j] + m[j * n + i]);
                m[i * n + j] = s;
            }
        }
        // Row-oriented (left-looking) Cholesky: every entry is a dot product
        // of two rows' prefixes, contiguous in row-major storage.
        for j in 0..n {
            let diag0 = m[j * n + j];
            let (before, rest) = m.split_at_mut(j * n);
            let row_j = &mut rest[..n];
            let d = diag0 - dot4(&row_j[..j], &row_j[..j]);
            if !(d > 1e-14 * diag0.abs() && d.is_finite()) {
                return Err(j);
            }
            let ljj = d.sqrt();
            row_j[j] = ljj;
            let _ = before;
            for i in j + 1..n {
                let (upper, lower) = m.split_at_mut(i * n);
                let row_j = &upper[j * n..j * n + j];
                let row_i = &mut lower[..n];
                let s = row_i[j] - dot4(&row_i[..j], row_j);
                row_i[j] = s / ljj;
            }
        }
        Ok(())
    }

    /// `x = (L L^T)^-1 b`.
    pub fn solve(&self, b: &[f64], x: &mut [f64]) {
        let n = self.n;
        let l = &self.l;
        for i in 0..n {
            let s = dot4(&l[i * n..i * n + i], &x[..i]);
            x[i] = (b[i] - s) / l[i * n + i];
        }
        for i in (0..n).rev() {
            let xi = x[i] / l[i * n + i];
            x[i] = xi;
            // Column i of L^T is row i of L: subtract it from the rows above.
            for (xk, lik) in x[..i].iter_mut().zip(&l[i * n..i * n + i]) {
                *xk -= lik * xi;
            }
        }
    }
}

/// `sum_k a_k b_k` with four independent partial sums (a fixed order, so
/// the result does not depend on anything but the inputs).
#[inline]
fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let mut s = [0.0; 4];
    let (a4, a_rest) = a.as_chunks::<4>();
    let (b4, b_rest) = b.as_chunks::<4>();
    for (x, y) in a4.iter().zip(b4) {
        for q in 0..4 {
            s[q] += x[q] * y[q];
        }
    }
    for (x, y) in a_rest.iter().zip(b_rest) {
        s[0] += x * y;
    }
    (s[0] + s[1]) + (s[2] + s[3])
}
