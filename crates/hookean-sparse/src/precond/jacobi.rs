//! The identity, diagonal (Jacobi, eq. 53) and 3x3 block-diagonal preconditioners.

use super::{Preconditioner, PreconditionerSetup, square_dim};
use crate::block::{self, Block3};
use crate::error::SparseError;
use crate::matrix::SymBlockMatrix;

/// No preconditioning: `z = r`.
#[derive(Debug, Clone, Copy, Default)]
pub struct Identity;

impl Preconditioner for Identity {
    fn dim(&self) -> Option<usize> {
        None
    }
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        z.copy_from_slice(r);
    }
}

impl<A: ?Sized> PreconditionerSetup<A> for Identity {
    fn setup(&mut self, _a: &A) -> Result<(), SparseError> {
        Ok(())
    }
}

/// Diagonal scaling `M = diag(A)` (the tutorial's eq. 53; Baraff-Witkin's choice).
#[derive(Debug, Clone, Default)]
pub struct Jacobi {
    inv_diag: Vec<f64>,
}

impl Jacobi {
    /// An empty preconditioner; call [`setup`](PreconditionerSetup::setup) before use.
    pub fn new() -> Self {
        Self::default()
    }

    fn store(&mut self, n: usize, diag: impl Fn(usize) -> f64) -> Result<(), SparseError> {
        self.inv_diag.resize(n, 0.0);
        for i in 0..n {
            let d = diag(i);
            if !(d > 0.0 && d.is_finite()) {
                return Err(SparseError::NonPositiveDiagonal {
                    preconditioner: "Jacobi",
                    row: i,
                    value: d,
                });
            }
            self.inv_diag[i] = 1.0 / d;
        }
        Ok(())
    }
}

impl Preconditioner for Jacobi {
    fn dim(&self) -> Option<usize> {
        Some(self.inv_diag.len())
    }
    #[inline]
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        for ((z, r), d) in z.iter_mut().zip(r).zip(&self.inv_diag) {
            *z = r * d;
        }
    }
    #[inline]
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        let mut acc = 0.0;
        for ((z, r), d) in z.iter_mut().zip(r).zip(&self.inv_diag) {
            *z = r * d;
            acc += r * *z;
        }
        acc
    }
    #[inline]
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        // Long vectors: fixed leaves on the rayon pool, sums in a fixed tree.
        crate::par::tree_sum2_mut(r, z, &|at, r, z| {
            let end = at + r.len();
            jacobi_update(alpha, &q[at..end], &self.inv_diag[at..end], r, z)
        })
    }
}

/// Jacobi's fused CG pass on one range: `r -= alpha q`, `z = D^-1 r`;
/// returns `(r . r, r . z)`.
#[inline]
fn jacobi_update(
    alpha: f64,
    q: &[f64],
    inv_diag: &[f64],
    r: &mut [f64],
    z: &mut [f64],
) -> (f64, f64) {
    // Four independent partial sums keep the two reductions from
    // serialising the pass on floating-point add latency.
    let n = r.len();
    let (r4, _) = r.as_chunks_mut::<4>();
    let (z4, _) = z.as_chunks_mut::<4>();
    let (q4, _) = q.as_chunks::<4>();
    let (d4, _) = inv_diag.as_chunks::<4>();
    let mut rr = [0.0; 4];
    let mut rz = [0.0; 4];
    for (((r, z), q), d) in r4.iter_mut().zip(z4.iter_mut()).zip(q4).zip(d4) {
        for l in 0..4 {
            let ri = r[l] - alpha * q[l];
            r[l] = ri;
            let zi = ri * d[l];
            z[l] = zi;
            rr[l] += ri * ri;
            rz[l] += ri * zi;
        }
    }
    let (mut rr, mut rz) = (
        (rr[0] + rr[1]) + (rr[2] + rr[3]),
        (rz[0] + rz[1]) + (rz[2] + rz[3]),
    );
    for i in n - n % 4..n {
        let ri = r[i] - alpha * q[i];
        r[i] = ri;
        let zi = ri * inv_diag[i];
        z[i] = zi;
        rr += ri * ri;
        rz += ri * zi;
    }
    (rr, rz)
}

impl PreconditionerSetup<SymBlockMatrix> for Jacobi {
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        self.store(a.dim(), |i| a.diagonal_block(i / 3)[i % 3][i % 3])
    }
}

impl PreconditionerSetup<sprs::CsMat<f64>> for Jacobi {
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let n = square_dim(a)?;
        self.store(n, |i| a.get(i, i).copied().unwrap_or(0.0))
    }
}

/// Block-diagonal preconditioner: the 3x3 diagonal blocks of `A`, inverted
/// (one block per particle: it couples x, y and z, which Jacobi does not).
#[derive(Debug, Clone, Default)]
pub struct BlockJacobi {
    inv_blocks: Vec<Block3>,
}

impl BlockJacobi {
    /// An empty preconditioner; call [`setup`](PreconditionerSetup::setup) before use.
    pub fn new() -> Self {
        Self::default()
    }

    fn store(&mut self, n: usize, blk: impl Fn(usize) -> Block3) -> Result<(), SparseError> {
        self.inv_blocks.resize(n, block::ZERO);
        for i in 0..n {
            let b = blk(i);
            self.inv_blocks[i] = block::inverse(&b).ok_or(SparseError::SingularBlock {
                block: i,
                determinant: block::determinant(&b),
            })?;
        }
        Ok(())
    }
}

impl Preconditioner for BlockJacobi {
    fn dim(&self) -> Option<usize> {
        Some(3 * self.inv_blocks.len())
    }
    #[inline]
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let (r3, _) = r.as_chunks::<3>();
        let (z3, _) = z.as_chunks_mut::<3>();
        for ((z, r), b) in z3.iter_mut().zip(r3).zip(&self.inv_blocks) {
            *z = block::mul_vec(b, r);
        }
    }
    #[inline]
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        let (r3, _) = r.as_chunks::<3>();
        let (z3, _) = z.as_chunks_mut::<3>();
        let mut acc = 0.0;
        for ((z, r), b) in z3.iter_mut().zip(r3).zip(&self.inv_blocks) {
            *z = block::mul_vec(b, r);
            acc += r[0] * z[0] + r[1] * z[1] + r[2] * z[2];
        }
        acc
    }
}

impl PreconditionerSetup<SymBlockMatrix> for BlockJacobi {
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        self.store(a.n_blocks(), |i| *a.diagonal_block(i))
    }
}

impl PreconditionerSetup<sprs::CsMat<f64>> for BlockJacobi {
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let n = square_dim(a)?;
        if n % 3 != 0 {
            return Err(SparseError::NotBlockAligned { dim: n });
        }
        self.store(n / 3, |i| {
            let mut b = block::ZERO;
            for r in 0..3 {
                for c in 0..3 {
                    b[r][c] = a.get(3 * i + r, 3 * i + c).copied().unwrap_or(0.0);
                }
            }
            b
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::testutil::*;
    use super::*;

    #[test]
    fn jacobi_divides_by_the_diagonal() {
        let a = spd_block_matrix(3, 2);
        let d = dense(&a);
        let r = rhs(a.dim());
        for csr in [false, true] {
            let mut p = Jacobi::new();
            if csr {
                p.setup(&a.to_csr()).unwrap();
            } else {
                p.setup(&a).unwrap();
            }
            let mut z = vec![0.0; r.len()];
            let rz = p.apply_dot(&r, &mut z);
            let mut expected_rz = 0.0;
            for i in 0..r.len() {
                approx::assert_abs_diff_eq!(z[i], r[i] / d[i][i], epsilon = 1e-15);
                expected_rz += r[i] * r[i] / d[i][i];
            }
            approx::assert_relative_eq!(rz, expected_rz, max_relative = 1e-12);
        }
    }

    #[test]
    fn block_jacobi_solves_each_diagonal_block() {
        let a = spd_block_matrix(2, 3);
        let d = dense(&a);
        let r = rhs(a.dim());
        for csr in [false, true] {
            let mut p = BlockJacobi::new();
            if csr {
                p.setup(&a.to_csr()).unwrap();
            } else {
                p.setup(&a).unwrap();
            }
            let mut z = vec![0.0; r.len()];
            p.apply(&r, &mut z);
            for i in 0..a.n_blocks() {
                let blk: Vec<Vec<f64>> = (0..3)
                    .map(|rr| (0..3).map(|c| d[3 * i + rr][3 * i + c]).collect())
                    .collect();
                let expected = dense_solve(&blk, &r[3 * i..3 * i + 3]);
                assert!(rel_diff(&z[3 * i..3 * i + 3], &expected) < 1e-13);
            }
        }
    }

    #[test]
    fn non_positive_diagonal_and_singular_block_are_errors() {
        let mut t = sprs::TriMat::new((3, 3));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, -2.0);
        t.add_triplet(2, 2, 1.0);
        let m = t.to_csr();
        assert_eq!(
            Jacobi::new().setup(&m),
            Err(SparseError::NonPositiveDiagonal {
                preconditioner: "Jacobi",
                row: 1,
                value: -2.0
            })
        );
        let mut t = sprs::TriMat::new((3, 3));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, 1.0);
        let m = t.to_csr();
        assert!(matches!(
            BlockJacobi::new().setup(&m),
            Err(SparseError::SingularBlock { block: 0, .. })
        ));
        let mut t = sprs::TriMat::new((4, 4));
        t.add_triplet(0, 0, 1.0);
        assert_eq!(
            BlockJacobi::new().setup(&t.to_csr()),
            Err(SparseError::NotBlockAligned { dim: 4 })
        );
    }
}
