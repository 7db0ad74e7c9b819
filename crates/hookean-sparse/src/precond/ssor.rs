//! Symmetric successive over-relaxation (the tutorial's eq. 54, with relaxation).

use std::sync::Arc;

use super::{Preconditioner, PreconditionerSetup};
use crate::error::SparseError;
use crate::matrix::SymBlockMatrix;
use crate::symcsr::{SymCsrMatrix, row_dot};

/// SSOR with relaxation `omega` in (0, 2):
///
/// `M = (D + w L) D^-1 (D + w L^T) / (w (2 - w))`, with `A = L + D + L^T`,
/// `D` the scalar diagonal and `L` the strictly lower triangle. `w = 1` is
/// symmetric Gauss-Seidel, the tutorial's eq. (54). Applying `M^-1` is a
/// forward and a backward triangular sweep over the stored matrix, in place.
#[derive(Debug, Clone)]
pub struct Ssor {
    omega: f64,
    inv_diag: Vec<f64>,
    diag: Vec<f64>,
    storage: Storage,
}

#[derive(Debug, Clone)]
enum Storage {
    Empty,
    Block(SymBlockMatrix),
    /// A scalar matrix's diagonal and upper triangle (the lower one is its
    /// transpose).
    Csr(SymCsrMatrix),
}

impl Ssor {
    /// SSOR with relaxation `omega`.
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] unless `0 < omega < 2`.
    pub fn new(omega: f64) -> Result<Self, SparseError> {
        if !(omega > 0.0 && omega < 2.0) {
            return Err(SparseError::InvalidParameter {
                name: "omega",
                message: format!("SSOR relaxation must lie in (0, 2), got {omega:?}"),
            });
        }
        Ok(Self {
            omega,
            inv_diag: Vec::new(),
            diag: Vec::new(),
            storage: Storage::Empty,
        })
    }

    /// The relaxation parameter.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    fn store_diag(&mut self, n: usize, d: impl Fn(usize) -> f64) -> Result<(), SparseError> {
        self.diag.resize(n, 0.0);
        self.inv_diag.resize(n, 0.0);
        for i in 0..n {
            let v = d(i);
            if !(v > 0.0 && v.is_finite()) {
                return Err(SparseError::NonPositiveDiagonal {
                    preconditioner: "SSOR",
                    row: i,
                    value: v,
                });
            }
            self.diag[i] = v;
            self.inv_diag[i] = 1.0 / v;
        }
        Ok(())
    }

    fn apply_block(&self, a: &SymBlockMatrix, r: &[f64], z: &mut [f64]) {
        let w = self.omega;
        let c = w * (2.0 - w);
        let n = a.n_blocks();
        let row_ptr = a.pattern().row_ptr();
        let cols = a.pattern().col_idx();
        let vals = a.values();
        let inv = &self.inv_diag;
        let (z3, _) = z.as_chunks_mut::<3>();
        let (r3, _) = r.as_chunks::<3>();
        z3.copy_from_slice(&r3[..n]);
        // Forward: (D + wL) y = r, pushing each finished y_i into later rows.
        for i in 0..n {
            let start = row_ptr[i];
            let d = &vals[start];
            let mut y = z3[i];
            y[0] *= inv[3 * i];
            y[1] = (y[1] - w * d[1][0] * y[0]) * inv[3 * i + 1];
            y[2] = (y[2] - w * (d[2][0] * y[0] + d[2][1] * y[1])) * inv[3 * i + 2];
            z3[i] = y;
            for k in start + 1..row_ptr[i + 1] {
                let j = cols[k] as usize;
                let t = crate::block::mul_transpose_vec(&vals[k], &y);
                let zj = &mut z3[j];
                zj[0] -= w * t[0];
                zj[1] -= w * t[1];
                zj[2] -= w * t[2];
            }
        }
        // Backward: (D + wL^T) z = w(2 - w) D y, pulling finished z_j, j > i.
        for i in (0..n).rev() {
            let start = row_ptr[i];
            let d = &vals[start];
            let y = z3[i];
            let mut acc = [
                c * self.diag[3 * i] * y[0],
                c * self.diag[3 * i + 1] * y[1],
                c * self.diag[3 * i + 2] * y[2],
            ];
            for k in start + 1..row_ptr[i + 1] {
                let j = cols[k] as usize;
                let t = crate::block::mul_vec(&vals[k], &z3[j]);
                acc[0] -= w * t[0];
                acc[1] -= w * t[1];
                acc[2] -= w * t[2];
            }
            let z2 = acc[2] * inv[3 * i + 2];
            let z1 = (acc[1] - w * d[1][2] * z2) * inv[3 * i + 1];
            let z0 = (acc[0] - w * (d[0][1] * z1 + d[0][2] * z2)) * inv[3 * i];
            z3[i] = [z0, z1, z2];
        }
    }

    /// The forward sweep on scalar storage, in place: `(D + wL) y = z`.
    /// `L = U^T` is read by columns: each finished `y_i` is pushed into the
    /// later rows `j` of its upper row.
    fn forward_csr(&self, a: &SymCsrMatrix, z: &mut [f64]) {
        let w = self.omega;
        let n = a.dim();
        let (z, inv) = (&mut z[..n], &self.inv_diag[..n]);
        for i in 0..n {
            let yi = z[i] * inv[i];
            z[i] = yi;
            let wy = w * yi;
            let (cols, vals) = a.upper_row(i);
            for (&j, &v) in cols.iter().zip(vals) {
                z[j as usize] -= v * wy;
            }
        }
    }

    /// The backward sweep on scalar storage, in place: `(D + wU) z = w (2 -
    /// w) D y`, pulling the finished `z_j`, `j > i`; returns `r . z`.
    fn backward_csr(&self, a: &SymCsrMatrix, r: &[f64], z: &mut [f64]) -> f64 {
        let w = self.omega;
        let c = w * (2.0 - w);
        let n = a.dim();
        let (r, z, inv) = (&r[..n], &mut z[..n], &self.inv_diag[..n]);
        let mut rz = 0.0;
        for i in (0..n).rev() {
            let (cols, vals) = a.upper_row(i);
            let s = row_dot(cols, vals, z);
            let zi = (c * a.diag[i] * z[i] - w * s) * inv[i];
            z[i] = zi;
            rz += r[i] * zi;
        }
        rz
    }
}

impl Preconditioner for Ssor {
    fn dim(&self) -> Option<usize> {
        Some(match &self.storage {
            Storage::Empty => 0,
            Storage::Block(a) => a.dim(),
            Storage::Csr(a) => a.dim(),
        })
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) {
        match &self.storage {
            Storage::Empty => panic!("SSOR preconditioner used before setup"),
            Storage::Block(a) => self.apply_block(a, r, z),
            Storage::Csr(a) => {
                z.copy_from_slice(r);
                self.forward_csr(a, z);
                self.backward_csr(a, r, z);
            }
        }
    }

    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        match &self.storage {
            Storage::Csr(a) => {
                z.copy_from_slice(r);
                self.forward_csr(a, z);
                self.backward_csr(a, r, z)
            }
            _ => {
                self.apply(r, z);
                crate::vecops::dot(r, z)
            }
        }
    }

    /// On scalar storage: `r -= alpha q` and `z = r` in one pass, then the
    /// two sweeps, the backward one forming `r . z`.
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        let Storage::Csr(a) = &self.storage else {
            let rr = crate::vecops::update_residual(alpha, q, r);
            return (rr, self.apply_dot(r, z));
        };
        let mut rr = 0.0;
        for ((ri, qi), zi) in r.iter_mut().zip(q).zip(z.iter_mut()) {
            *ri -= alpha * qi;
            rr += *ri * *ri;
            *zi = *ri;
        }
        self.forward_csr(a, z);
        (rr, self.backward_csr(a, r, z))
    }
}

impl PreconditionerSetup<SymBlockMatrix> for Ssor {
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        let reuse =
            matches!(&self.storage, Storage::Block(m) if Arc::ptr_eq(m.pattern(), a.pattern()));
        if reuse {
            if let Storage::Block(m) = &mut self.storage {
                m.values_mut().copy_from_slice(a.values());
            }
        } else {
            self.storage = Storage::Block(a.clone());
        }
        let result = self.store_diag(a.dim(), |i| a.diagonal_block(i / 3)[i % 3][i % 3]);
        if result.is_err() {
            self.storage = Storage::Empty;
        }
        result
    }
}

impl PreconditionerSetup<sprs::CsMat<f64>> for Ssor {
    /// Keeps the diagonal and the upper triangle of `a` (`u32` indices):
    /// `a` must be symmetric (PCG's matrices are); its lower triangle is
    /// taken to be the transpose of the upper one.
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let mut csr = match std::mem::replace(&mut self.storage, Storage::Empty) {
            Storage::Csr(c) => c,
            _ => SymCsrMatrix::default(),
        };
        {
            let a = super::as_csr(a);
            super::check_both_triangles(&a.proper_indptr(), a.indices(), "SSOR")?;
        }
        csr.refill_upper(a)?;
        if let Some(k) = csr.val.iter().position(|v| !v.is_finite()) {
            return Err(SparseError::NonFinite {
                what: "matrix",
                index: Some(k),
            });
        }
        self.store_diag(csr.dim(), |i| csr.diag[i])?;
        self.storage = Storage::Csr(csr);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::testutil::*;
    use super::*;

    /// `M = (D + wL) D^-1 (D + wL^T) / (w (2 - w))`, densely.
    fn ssor_matrix(a: &[Vec<f64>], w: f64) -> Vec<Vec<f64>> {
        let n = a.len();
        let mut lower = vec![vec![0.0; n]; n];
        let mut dinv_upper = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..n {
                if j < i {
                    lower[i][j] = w * a[i][j];
                } else if j == i {
                    lower[i][j] = a[i][i];
                }
                if j > i {
                    dinv_upper[i][j] = w * a[i][j] / a[i][i];
                } else if j == i {
                    dinv_upper[i][j] = 1.0;
                }
            }
        }
        let mut m = matmul(&lower, &dinv_upper);
        for row in &mut m {
            for v in row {
                *v /= w * (2.0 - w);
            }
        }
        m
    }

    #[test]
    fn ssor_apply_is_the_inverse_of_its_formula() {
        let a = spd_block_matrix(3, 3);
        let d = dense(&a);
        let r = rhs(a.dim());
        for w in [0.6, 1.0, 1.5] {
            let expected = dense_solve(&ssor_matrix(&d, w), &r);
            let mut p = Ssor::new(w).unwrap();
            let mut z = vec![0.0; r.len()];
            p.setup(&a).unwrap();
            p.apply(&r, &mut z);
            assert!(rel_diff(&z, &expected) < 1e-12, "block, omega {w}");
            p.setup(&a.to_csr()).unwrap();
            p.apply(&r, &mut z);
            assert!(rel_diff(&z, &expected) < 1e-12, "csr, omega {w}");
        }
    }

    /// The fused pass of scalar storage (`r -= alpha q`, the sweeps, `r . r`
    /// and `r . z`) against the updated residual and the dense formula.
    #[test]
    fn csr_residual_update_and_sweeps_match_the_formula() {
        let a = spd_block_matrix(3, 3);
        let d = dense(&a);
        let n = a.dim();
        let q = rhs(n);
        let mut r: Vec<f64> = q.iter().map(|v| (3.0 * v).cos()).collect();
        let alpha = 0.4;
        let r_new: Vec<f64> = r.iter().zip(&q).map(|(r, q)| r - alpha * q).collect();
        let w = 1.3;
        let expected = dense_solve(&ssor_matrix(&d, w), &r_new);
        let mut p = Ssor::new(w).unwrap();
        p.setup(&a.to_csr()).unwrap();
        let mut z = vec![f64::NAN; n];
        let (rr, rz) = p.update_and_apply(alpha, &q, &mut r, &mut z);
        assert_eq!(r, r_new);
        assert!(rel_diff(&z, &expected) < 1e-12);
        let rr_ref: f64 = r_new.iter().map(|v| v * v).sum();
        let rz_ref: f64 = r_new.iter().zip(&expected).map(|(a, b)| a * b).sum();
        approx::assert_relative_eq!(rr, rr_ref, max_relative = 1e-12);
        approx::assert_relative_eq!(rz, rz_ref, max_relative = 1e-10);
        let mut z2 = vec![f64::NAN; n];
        let rz2 = p.apply_dot(&r_new, &mut z2);
        assert_eq!(z, z2);
        assert_eq!(rz, rz2);
    }

    #[test]
    fn refill_with_new_values_reuses_the_pattern() {
        let mut a = spd_block_matrix(2, 2);
        let mut p = Ssor::new(1.2).unwrap();
        p.setup(&a).unwrap();
        a.scale(2.0);
        p.setup(&a).unwrap();
        let r = rhs(a.dim());
        let expected = dense_solve(&ssor_matrix(&dense(&a), 1.2), &r);
        let mut z = vec![0.0; r.len()];
        p.apply(&r, &mut z);
        assert!(rel_diff(&z, &expected) < 1e-12);
    }

    #[test]
    fn omega_outside_zero_two_is_an_error() {
        for w in [0.0, 2.0, -1.0, f64::NAN] {
            assert!(matches!(
                Ssor::new(w),
                Err(SparseError::InvalidParameter { name: "omega", .. })
            ));
        }
    }

    #[test]
    fn missing_diagonal_is_an_error() {
        let mut t = sprs::TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(0, 1, 0.5);
        t.add_triplet(1, 0, 0.5);
        let mut p = Ssor::new(1.0).unwrap();
        assert!(matches!(
            p.setup(&t.to_csr()),
            Err(SparseError::NonPositiveDiagonal { row: 1, .. })
        ));
    }
}
