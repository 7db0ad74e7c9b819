//! Symmetric block matrices whose every 3x3 block is a scalar times the
//! identity: the storage for the tutorial's linearised Jacobian (eq. 50),
//! whose spring blocks are `k I` and `d I`.
//!
//! One scalar per block instead of nine: the product touches a third of
//! the bytes of [`SymBlockMatrix`] (the tutorial's "an iteration of the
//! linear solver only requires a third of the original time").

use std::sync::Arc;

use crate::block;
use crate::error::{SparseError, check_len};
use crate::matrix::{BlockPattern, SymBlockMatrix, check_same_pattern};
use crate::operator::LinearOperator;
use crate::precond::{Amg, BlockJacobi, IncompleteCholesky, Jacobi, PreconditionerSetup, Ssor};

/// Where a block's scalar lives, found once by [`IsoBlockMatrix::slot`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IsoSlot(usize);

/// A symmetric matrix of `n x n` blocks `a_ij I3` on a [`BlockPattern`]
/// (diagonal + upper blocks stored, one scalar each).
#[derive(Debug, Clone, PartialEq)]
pub struct IsoBlockMatrix {
    pattern: Arc<BlockPattern>,
    values: Vec<f64>,
}

impl IsoBlockMatrix {
    /// A zero matrix on `pattern`.
    ///
    /// # Panics
    /// If the allocator cannot give the `8` bytes per stored block (as
    /// `Vec` does); [`try_new`](Self::try_new) returns an error instead.
    pub fn new(pattern: Arc<BlockPattern>) -> Self {
        let values = vec![0.0; pattern.stored_blocks()];
        Self { pattern, values }
    }

    /// A zero matrix on `pattern`, or an error where [`new`](Self::new) panics.
    ///
    /// # Errors
    /// [`SparseError::TooLarge`] if the values cannot be allocated.
    pub fn try_new(pattern: Arc<BlockPattern>) -> Result<Self, SparseError> {
        let values = crate::error::try_filled(
            "isotropic block matrix values",
            pattern.stored_blocks(),
            0.0,
        )?;
        Ok(Self { pattern, values })
    }

    /// The sparsity pattern.
    pub fn pattern(&self) -> &Arc<BlockPattern> {
        &self.pattern
    }

    /// Number of block rows.
    pub fn n_blocks(&self) -> usize {
        self.pattern.n_blocks()
    }

    /// Scalar dimension `3 n`.
    pub fn dim(&self) -> usize {
        3 * self.n_blocks()
    }

    /// The stored scalars, in the pattern's order (diagonal first in each block row).
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Calls `visit(i, j, a_ij)` for every stored block, `i <= j`, row by row
    /// (diagonal first, columns ascending): the upper triangle only, so a
    /// full-matrix consumer adds `(j, i)` itself when `i != j`.
    pub fn for_each_stored(&self, mut visit: impl FnMut(usize, usize, f64)) {
        for i in 0..self.n_blocks() {
            for k in self.pattern.rows_value_range(i..i + 1) {
                visit(i, self.pattern.col_idx()[k] as usize, self.values[k]);
            }
        }
    }

    /// Sets every value to zero (the pattern stays).
    pub fn set_zero(&mut self) {
        self.values.fill(0.0);
    }

    /// The slot of block `(i, j)` (either orientation).
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`], [`SparseError::NotInPattern`].
    pub fn slot(&self, i: usize, j: usize) -> Result<IsoSlot, SparseError> {
        let n = self.n_blocks();
        if i >= n || j >= n {
            return Err(SparseError::BlockIndexOutOfRange { row: i, col: j, n });
        }
        let (r, c) = (i.min(j), i.max(j));
        let rp = self.pattern.row_ptr();
        let cols = &self.pattern.col_idx()[rp[r]..rp[r + 1]];
        if r == c {
            return Ok(IsoSlot(rp[r]));
        }
        cols[1..]
            .binary_search(&(c as u32))
            .map(|k| IsoSlot(rp[r] + 1 + k))
            .map_err(|_| SparseError::NotInPattern { row: i, col: j })
    }

    /// Adds `a` to block `(i, j)` (the block is `a I3`; by symmetry also `(j, i)`).
    ///
    /// # Errors
    /// As [`slot`](Self::slot).
    pub fn add_to_block(&mut self, i: usize, j: usize, a: f64) -> Result<(), SparseError> {
        let s = self.slot(i, j)?;
        self.add_to_slot(s, a);
        Ok(())
    }

    /// Adds `a` at a cached slot (no search).
    #[inline]
    pub fn add_to_slot(&mut self, slot: IsoSlot, a: f64) {
        self.values[slot.0] += a;
    }

    /// The scalar of diagonal block `i`.
    ///
    /// # Panics
    /// If `i >= n_blocks()`.
    pub fn diagonal(&self, i: usize) -> f64 {
        self.values[self.pattern.row_ptr()[i]]
    }

    /// Adds `d[i] I3` to diagonal block `i` (e.g. a lumped mass per particle).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `d.len() != n_blocks()`.
    pub fn add_to_diagonal(&mut self, d: &[f64]) -> Result<(), SparseError> {
        check_len("diagonal (one per block)", d, self.n_blocks())?;
        let rp = self.pattern.row_ptr();
        for (i, di) in d.iter().enumerate() {
            self.values[rp[i]] += di;
        }
        Ok(())
    }

    /// `self += s * other` (same pattern).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if the patterns differ.
    pub fn add_scaled(&mut self, s: f64, other: &IsoBlockMatrix) -> Result<(), SparseError> {
        check_same_pattern(&self.pattern, &other.pattern)?;
        for (a, b) in self.values.iter_mut().zip(&other.values) {
            *a += s * b;
        }
        Ok(())
    }

    /// The same matrix with full 3x3 blocks.
    pub fn to_block(&self) -> SymBlockMatrix {
        let mut m = SymBlockMatrix::new(self.pattern.clone());
        for (b, a) in m.values_mut().iter_mut().zip(&self.values) {
            *b = block::scale(&block::IDENTITY, *a);
        }
        m
    }

    /// Structural scalar nonzeros of the full (both triangles) matrix: 3 per block.
    pub fn full_nnz(&self) -> usize {
        3 * (2 * self.values.len() - self.n_blocks())
    }

    fn spmv_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let n = self.n_blocks();
        let (x3, _) = x.as_chunks::<3>();
        let (y3, _) = y.as_chunks_mut::<3>();
        let x3 = &x3[..n];
        let y3 = &mut y3[..n];
        y3.fill([0.0; 3]);
        let rp = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        let vals = &self.values;
        let mut dot = 0.0;
        for i in 0..n {
            let (start, end) = (rp[i], rp[i + 1]);
            let xi = x3[i];
            let d = vals[start];
            let mut yi = [d * xi[0], d * xi[1], d * xi[2]];
            for k in start + 1..end {
                let j = cols[k] as usize;
                let a = vals[k];
                let xj = &x3[j];
                yi[0] += a * xj[0];
                yi[1] += a * xj[1];
                yi[2] += a * xj[2];
                let yj = &mut y3[j];
                yj[0] += a * xi[0];
                yj[1] += a * xi[1];
                yj[2] += a * xi[2];
            }
            let out = &mut y3[i];
            out[0] += yi[0];
            out[1] += yi[1];
            out[2] += yi[2];
            dot += xi[0] * out[0] + xi[1] * out[1] + xi[2] * out[2];
        }
        dot
    }
}

impl LinearOperator for IsoBlockMatrix {
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
}

/// The diagonal of an isotropic matrix as a scalar `sprs` matrix (every
/// diagonal entry of block `i` is `a_ii`), the input both Jacobi variants read.
fn diagonal_csr(a: &IsoBlockMatrix) -> sprs::CsMat<f64> {
    let n = a.dim();
    let data: Vec<f64> = (0..n).map(|k| a.diagonal(k / 3)).collect();
    sprs::CsMat::new((n, n), (0..=n).collect(), (0..n).collect(), data)
}

/// Jacobi on an isotropic matrix. Its setup builds the `3n` diagonal in a
/// temporary (one allocation per setup; the linearised Jacobian is set up
/// only when `h` or the material changes).
impl PreconditionerSetup<IsoBlockMatrix> for Jacobi {
    fn setup(&mut self, a: &IsoBlockMatrix) -> Result<(), SparseError> {
        <Jacobi as PreconditionerSetup<sprs::CsMat<f64>>>::setup(self, &diagonal_csr(a))
    }
}

/// Block-Jacobi on an isotropic matrix: its diagonal blocks are `a_ii I3`,
/// so it equals Jacobi. Setup as for [`Jacobi`].
impl PreconditionerSetup<IsoBlockMatrix> for BlockJacobi {
    fn setup(&mut self, a: &IsoBlockMatrix) -> Result<(), SparseError> {
        self.setup_three_from_csr(&diagonal_csr(a))
    }
}

/// SSOR, IC(0) / MIC(0) and multigrid on an isotropic matrix: set up from
/// the same matrix with full 3x3 blocks ([`IsoBlockMatrix::to_block`], one
/// copy per setup: the linearised Jacobian is set up only when `h` or the
/// material changes). Their application costs what it costs on the full
/// matrix; only the matrix product of a CG iteration is cheaper.
macro_rules! setup_from_blocks {
    ($($t:ty),*) => {$(
        impl PreconditionerSetup<IsoBlockMatrix> for $t {
            fn setup(&mut self, a: &IsoBlockMatrix) -> Result<(), SparseError> {
                <$t as PreconditionerSetup<SymBlockMatrix>>::setup(self, &a.to_block())
            }
        }
    )*};
}
setup_from_blocks!(Ssor, IncompleteCholesky, Amg);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cg::{CgParams, CgWorkspace, pcg};
    use crate::precond::Preconditioner;

    /// `for_each_stored` visits each written block once, upper triangle,
    /// with the sum of what was added to it (either orientation), on a
    /// matrix from [`IsoBlockMatrix::try_new`].
    #[test]
    fn for_each_stored_visits_the_upper_blocks_with_their_sums() {
        let adds = [
            (0, 0, 2.0),
            (2, 0, -1.0),
            (0, 2, -0.5),
            (1, 1, 3.0),
            (3, 1, 4.0),
        ];
        let pattern = BlockPattern::new(4, adds.iter().map(|&(i, j, _)| (i, j))).unwrap();
        // try_new: a zero matrix on the pattern, as new (the sums below start at 0).
        let mut a = IsoBlockMatrix::try_new(Arc::new(pattern)).unwrap();
        let mut expected = std::collections::BTreeMap::new();
        for i in 0..4 {
            expected.insert((i, i), 0.0);
        }
        for &(i, j, v) in &adds {
            a.add_to_block(i, j, v).unwrap();
            *expected.entry((i.min(j), i.max(j))).or_insert(0.0) += v;
        }
        let mut seen = Vec::new();
        a.for_each_stored(|i, j, v| seen.push(((i, j), v)));
        let expected: Vec<_> = expected.into_iter().collect();
        assert_eq!(seen, expected);
    }

    fn chain(n: usize) -> IsoBlockMatrix {
        let pattern = Arc::new(BlockPattern::new(n, (0..n - 1).map(|i| (i, i + 1))).unwrap());
        let mut a = IsoBlockMatrix::new(pattern);
        for i in 0..n - 1 {
            a.add_to_block(i + 1, i, -1.0).unwrap();
            a.add_to_block(i, i, 1.0).unwrap();
            a.add_to_block(i + 1, i + 1, 1.0).unwrap();
        }
        a.add_to_diagonal(&vec![0.5; n]).unwrap();
        a
    }

    #[test]
    fn product_matches_the_full_block_matrix() {
        let a = chain(7);
        let full = a.to_block();
        let x: Vec<f64> = (0..21).map(|i| (i as f64 * 0.7).sin()).collect();
        let (mut y1, mut y2) = (vec![0.0; 21], vec![0.0; 21]);
        let d1 = a.apply_dot(&x, &mut y1);
        let d2 = full.apply_dot(&x, &mut y2);
        for (p, q) in y1.iter().zip(&y2) {
            approx::assert_abs_diff_eq!(p, q, epsilon = 1e-14);
        }
        approx::assert_abs_diff_eq!(d1, d2, epsilon = 1e-12);
        // 7 diagonal + 2 x 6 off-diagonal blocks, 3 scalars each.
        assert_eq!(a.full_nnz(), 3 * (7 + 12));
        assert_eq!(
            full.to_csr().iter().filter(|(v, _)| **v != 0.0).count(),
            a.full_nnz()
        );
    }

    #[test]
    fn pcg_with_jacobi_solves_isotropic_systems() {
        let a = chain(30);
        let b: Vec<f64> = (0..90).map(|i| ((i % 5) as f64) - 2.0).collect();
        for mut p in [
            Box::new(Jacobi::new()) as Box<dyn JacobiLike>,
            Box::new(BlockJacobi::new()),
        ] {
            p.setup_iso(&a).unwrap();
            let mut x = vec![0.0; 90];
            let info = pcg(
                &a,
                p.as_precond(),
                &b,
                &mut x,
                &CgParams::default(),
                &mut CgWorkspace::new(90),
                None,
            )
            .unwrap();
            assert!(info.converged);
            let mut ax = vec![0.0; 90];
            a.to_block().apply(&x, &mut ax);
            let r: f64 = ax
                .iter()
                .zip(&b)
                .map(|(p, q)| (p - q).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(r < 1e-7);
        }
        assert!(matches!(
            a.slot(0, 5),
            Err(SparseError::NotInPattern { .. })
        ));
        assert!(matches!(
            a.slot(0, 99),
            Err(SparseError::BlockIndexOutOfRange { .. })
        ));
        assert!(
            IsoBlockMatrix::new(a.pattern().clone())
                .add_to_diagonal(&[1.0])
                .is_err()
        );
    }

    /// Every preconditioner set up from the isotropic matrix applies as the
    /// same one set up from its full-block copy.
    #[test]
    fn every_preconditioner_sets_up_from_an_isotropic_matrix() {
        use crate::precond::{AnyPreconditioner, PrecondKind};
        let a = chain(40);
        let r: Vec<f64> = (0..120).map(|i| (i as f64 * 0.37).cos()).collect();
        for kind in PrecondKind::all(1.2) {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            let mut q = AnyPreconditioner::new(kind).unwrap();
            p.setup(&a).unwrap();
            q.setup(&a.to_block()).unwrap();
            let (mut z1, mut z2) = (vec![0.0; 120], vec![0.0; 120]);
            p.apply(&r, &mut z1);
            q.apply(&r, &mut z2);
            assert!(z1.iter().any(|v| *v != 0.0), "{kind:?}");
            for (u, w) in z1.iter().zip(&z2) {
                approx::assert_abs_diff_eq!(u, w, epsilon = 1e-14);
            }
        }
    }

    trait JacobiLike {
        fn setup_iso(&mut self, a: &IsoBlockMatrix) -> Result<(), SparseError>;
        fn as_precond(&self) -> &dyn Preconditioner;
    }
    impl<T: PreconditionerSetup<IsoBlockMatrix> + 'static> JacobiLike for T {
        fn setup_iso(&mut self, a: &IsoBlockMatrix) -> Result<(), SparseError> {
            self.setup(a)
        }
        fn as_precond(&self) -> &dyn Preconditioner {
            self
        }
    }
}
