//! The symmetric 3x3 block-sparse matrix ([`SymBlockMatrix`]) and its
//! sparsity pattern ([`BlockPattern`]).
//!
//! Storage is block compressed sparse rows (BSR) of the upper triangle: each
//! block row holds its diagonal block first, then the blocks right of the
//! diagonal in increasing column order. The pattern is built once per
//! topology and shared behind an [`Arc`]; values are zeroed and refilled in
//! place every step, so assembly allocates nothing. A symmetric SpMV reads
//! every stored block once and applies it twice (`B x_j` to row `i`, `B^T x_i`
//! to row `j`), moving about half the bytes of full block storage and a third
//! of scalar CSR.

use std::sync::Arc;

use crate::block::{self, Block3};
use crate::error::{SparseError, check_len};
use crate::par::LowerIndex;

mod csr;
pub use csr::{check_csr_symmetric, detect_block_size, is_block_pattern};

/// The sparsity pattern of a [`SymBlockMatrix`]: which 3x3 blocks are stored.
///
/// Built once from a list of block pairs `(i, j)`; the diagonal blocks are
/// always present. `(i, j)` and `(j, i)` name the same stored block.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BlockPattern {
    n: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<u32>,
    /// The transpose's index, for the threaded SpMV: column `j`'s stored
    /// upper blocks `(i, j)`, `i < j`.
    lower: LowerIndex,
}

/// `Ok` when two matrices share their pattern (the same `Arc`, or equal
/// patterns), as element-wise operations on their value arrays need.
pub(crate) fn check_same_pattern(
    a: &Arc<BlockPattern>,
    b: &Arc<BlockPattern>,
) -> Result<(), SparseError> {
    if Arc::ptr_eq(a, b) || a == b {
        Ok(())
    } else {
        Err(SparseError::InvalidParameter {
            name: "other",
            message: "matrices have different sparsity patterns".into(),
        })
    }
}

/// `Ok` when `n` block rows fit the patterns' `u32` column indices.
fn check_block_rows(n: usize) -> Result<(), SparseError> {
    if n > u32::MAX as usize {
        return Err(SparseError::InvalidParameter {
            name: "n",
            message: format!("{n} block rows exceed the u32 index range"),
        });
    }
    Ok(())
}

/// Where a block lives in the value array, found once by
/// [`SymBlockMatrix::slot`] and reused every refill to skip the search.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    index: usize,
    transposed: bool,
}

impl Slot {
    /// Position of the stored block in [`SymBlockMatrix::values`] (the
    /// same position in every matrix on this pattern). Assembly code that
    /// writes the value array directly takes its positions from here; the
    /// storage order is this crate's business.
    pub fn index(&self) -> usize {
        self.index
    }

    /// Whether the requested block `(i, j)` is the transpose of the stored
    /// one (`i > j`: the lower triangle is not stored).
    pub fn is_transposed(&self) -> bool {
        self.transposed
    }
}

impl BlockPattern {
    /// Builds the pattern of an `n x n` block matrix from block pairs.
    ///
    /// Pairs may repeat and come in any order or orientation; diagonal pairs
    /// are accepted and ignored (every diagonal block is stored).
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`] if a pair names a block outside
    /// the matrix; [`SparseError::InvalidParameter`] if `n` exceeds `u32::MAX`;
    /// [`SparseError::TooLarge`] if the allocator cannot give the pattern's
    /// row pointers and column indices (about `12 n` bytes, checked before
    /// they are filled).
    pub fn new(
        n: usize,
        pairs: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, SparseError> {
        check_block_rows(n)?;
        let mut upper: Vec<(u32, u32)> = Vec::new();
        for (i, j) in pairs {
            if i >= n || j >= n {
                return Err(SparseError::BlockIndexOutOfRange { row: i, col: j, n });
            }
            if i != j {
                upper.push((i.min(j) as u32, i.max(j) as u32));
            }
        }
        upper.sort_unstable();
        upper.dedup();
        let mut row_ptr = Vec::new();
        crate::error::try_grow("block pattern row pointers", &mut row_ptr, n + 1)?;
        let mut col_idx = Vec::new();
        crate::error::try_grow("block pattern columns", &mut col_idx, n + upper.len())?;
        row_ptr.push(0);
        let mut k = 0;
        for i in 0..n {
            col_idx.push(i as u32);
            while k < upper.len() && upper[k].0 as usize == i {
                col_idx.push(upper[k].1);
                k += 1;
            }
            row_ptr.push(col_idx.len());
        }
        Ok(Self::from_rows(n, row_ptr, col_idx))
    }

    /// The pattern of rows written in order (`row_ptr`, and per row the
    /// diagonal then the columns right of it, ascending), with the index
    /// of its transpose.
    fn from_rows(n: usize, row_ptr: Vec<usize>, col_idx: Vec<u32>) -> Self {
        let lower = LowerIndex::of_upper(&row_ptr, &col_idx, 1);
        Self {
            n,
            row_ptr,
            col_idx,
            lower,
        }
    }

    /// The pattern of the `3 x 3` blocks of the square CSR matrix `a`
    /// (dimension `3 n`, rows sorted) that hold an entry on or right of the
    /// block diagonal: block row `I`'s columns are the block columns `c / 3
    /// > I` of its three scalar rows, merged in order. One pass over the
    /// indices, no sort of all pairs (the rows come in order, so the
    /// pattern is written row by row as [`new`](Self::new) would leave it).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if `n` exceeds `u32::MAX`;
    /// [`SparseError::TooLarge`] if the row pointers or columns cannot be
    /// allocated.
    pub(crate) fn of_scalar_upper(n: usize, a: &sprs::CsMat<f64>) -> Result<Self, SparseError> {
        debug_assert!(a.is_csr() && a.rows() == 3 * n && a.cols() == 3 * n);
        check_block_rows(n)?;
        let (indptr, indices) = (a.indptr(), a.indices());
        let mut row_ptr = Vec::new();
        crate::error::try_grow("block pattern row pointers", &mut row_ptr, n + 1)?;
        let mut col_idx: Vec<u32> = Vec::new();
        crate::error::try_grow("block pattern columns", &mut col_idx, n)?;
        // `last[J] == I + 1`: block column `J` is already in block row `I`.
        let mut last = Vec::new();
        crate::error::try_grow("block pattern marks", &mut last, n)?;
        last.resize(n, 0usize);
        row_ptr.push(0);
        for bi in 0..n {
            col_idx.push(bi as u32);
            let start = col_idx.len();
            for r in 3 * bi..3 * bi + 3 {
                let cols = &indices[indptr.index(r)..indptr.index(r + 1)];
                // Columns are sorted: skip those left of the diagonal block.
                let first = cols.partition_point(|&c| c < 3 * bi + 3);
                for &c in &cols[first..] {
                    let bj = c / 3;
                    if last[bj] != bi + 1 {
                        last[bj] = bi + 1;
                        if col_idx.len() == col_idx.capacity() {
                            let more = col_idx.len();
                            crate::error::try_grow("block pattern columns", &mut col_idx, more)?;
                        }
                        col_idx.push(bj as u32);
                    }
                }
            }
            // The three rows' block columns, each sorted: merged by a sort of
            // this row's few (13 on a 27-point grid).
            col_idx[start..].sort_unstable();
            row_ptr.push(col_idx.len());
        }
        Ok(Self::from_rows(n, row_ptr, col_idx))
    }

    /// First block row of part `t` of `parts` parts with about equal numbers
    /// of stored blocks (`t = parts` gives `n`). A fixed function of the
    /// pattern and `parts`, so threaded kernels split the same way every call.
    pub fn part_start(&self, t: usize, parts: usize) -> usize {
        crate::par::part_start(&self.row_ptr, t, parts)
    }

    /// Number of block rows (and block columns).
    pub fn n_blocks(&self) -> usize {
        self.n
    }

    /// Scalar dimension, `3 * n_blocks()`.
    pub fn dim(&self) -> usize {
        3 * self.n
    }

    /// Number of stored blocks (diagonal plus upper triangle).
    pub fn stored_blocks(&self) -> usize {
        self.col_idx.len()
    }

    /// Number of scalar nonzeros of the full (both triangles) matrix, counting
    /// every stored block as dense: `9 * (2 * stored - n)`.
    pub fn full_nnz(&self) -> usize {
        9 * (2 * self.col_idx.len() - self.n)
    }

    /// Row pointers: block row `i` occupies slots `row_ptr[i]..row_ptr[i + 1]`,
    /// the first of which is the diagonal.
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Block column of every slot; within a row, sorted ascending after the diagonal.
    pub fn col_idx(&self) -> &[u32] {
        &self.col_idx
    }

    /// The value positions of block rows `rows` (`rows.end <= n`): the
    /// stored blocks of row `r` are `rows_value_range(r..r + 1)`, the
    /// diagonal first; threaded kernels split their value arrays at
    /// `rows_value_range(s..r)`'s ends.
    pub fn rows_value_range(&self, rows: std::ops::Range<usize>) -> std::ops::Range<usize> {
        self.row_ptr[rows.start]..self.row_ptr[rows.end]
    }

    /// The block bandwidth `max_r max { j - r : (r, j) stored, j >= r }`: how
    /// far past its own row the stored blocks of a row reach (0 for a
    /// diagonal pattern or `n = 0`).
    pub fn bandwidth(&self) -> usize {
        // Columns ascend within a row, so a row's last stored block is its farthest.
        (0..self.n)
            .map(|r| self.col_idx[self.row_ptr[r + 1] - 1] as usize - r)
            .max()
            .unwrap_or(0)
    }

    /// The transpose's index: column `j`'s stored upper blocks `(i, j)`,
    /// `i < j`, rows ascending.
    pub(crate) fn lower(&self) -> &LowerIndex {
        &self.lower
    }

    /// The slot holding block `(i, j)`, if it is in the pattern.
    pub fn find(&self, i: usize, j: usize) -> Option<Slot> {
        if i >= self.n || j >= self.n {
            return None;
        }
        let (r, c, transposed) = if i <= j { (i, j, false) } else { (j, i, true) };
        let start = self.row_ptr[r];
        let end = self.row_ptr[r + 1];
        if r == c {
            return Some(Slot {
                index: start,
                transposed: false,
            });
        }
        self.col_idx[start + 1..end]
            .binary_search(&(c as u32))
            .ok()
            .map(|k| Slot {
                index: start + 1 + k,
                transposed,
            })
    }
}

/// A symmetric matrix of 3x3 blocks, stored as its diagonal and upper blocks.
///
/// ```
/// use std::sync::Arc;
/// use hookean_sparse::{BlockPattern, SymBlockMatrix, LinearOperator};
///
/// // Two particles joined by one spring: blocks (0,0), (0,1), (1,1).
/// let pattern = Arc::new(BlockPattern::new(2, [(0, 1)])?);
/// let mut a = SymBlockMatrix::new(pattern);
/// let k = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]];
/// let minus_k = [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]];
/// a.add_to_block(0, 0, &k)?;
/// a.add_to_block(1, 1, &k)?;
/// a.add_to_block(1, 0, &minus_k)?; // stored once as (0, 1)
/// let x = [1.0, 0.0, 0.0, 1.0, 0.0, 0.0];
/// let mut y = [0.0; 6];
/// a.apply(&x, &mut y);
/// assert_eq!(y, [1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SymBlockMatrix {
    pattern: Arc<BlockPattern>,
    values: Vec<Block3>,
}

impl SymBlockMatrix {
    /// A zero matrix with the given pattern.
    ///
    /// # Panics
    /// If the allocator cannot give the `72` bytes per stored block (as
    /// `Vec` does); [`try_new`](Self::try_new) returns an error instead.
    pub fn new(pattern: Arc<BlockPattern>) -> Self {
        let values = vec![block::ZERO; pattern.stored_blocks()];
        Self { pattern, values }
    }

    /// A zero matrix with the given pattern, or an error where
    /// [`new`](Self::new) panics.
    ///
    /// # Errors
    /// [`SparseError::TooLarge`] if the values cannot be allocated.
    pub fn try_new(pattern: Arc<BlockPattern>) -> Result<Self, SparseError> {
        let values =
            crate::error::try_filled("block matrix values", pattern.stored_blocks(), block::ZERO)?;
        Ok(Self { pattern, values })
    }

    /// The shared sparsity pattern. Preconditioners compare it with
    /// [`Arc::ptr_eq`] to reuse their symbolic setup across refills.
    pub fn pattern(&self) -> &Arc<BlockPattern> {
        &self.pattern
    }

    /// Number of block rows.
    pub fn n_blocks(&self) -> usize {
        self.pattern.n
    }

    /// Scalar dimension `3 * n_blocks()`.
    pub fn dim(&self) -> usize {
        3 * self.pattern.n
    }

    /// The stored blocks, slot by slot (see [`BlockPattern::row_ptr`]).
    pub fn values(&self) -> &[Block3] {
        &self.values
    }

    /// Mutable stored blocks, for assembly kernels that keep their own slot map.
    /// Writing a non-symmetric diagonal block makes the matrix non-symmetric.
    pub fn values_mut(&mut self) -> &mut [Block3] {
        &mut self.values
    }

    /// Sets every stored value to zero, keeping the pattern (no allocation).
    pub fn set_zero(&mut self) {
        self.values.fill(block::ZERO);
    }

    /// The slot of block `(i, j)`, to be cached by assembly code.
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`] or [`SparseError::NotInPattern`].
    pub fn slot(&self, i: usize, j: usize) -> Result<Slot, SparseError> {
        let n = self.pattern.n;
        if i >= n || j >= n {
            return Err(SparseError::BlockIndexOutOfRange { row: i, col: j, n });
        }
        self.pattern
            .find(i, j)
            .ok_or(SparseError::NotInPattern { row: i, col: j })
    }

    /// Adds `m` to block `(i, j)` (and, by symmetry, `m^T` to block `(j, i)`).
    ///
    /// # Errors
    /// As [`slot`](Self::slot).
    pub fn add_to_block(&mut self, i: usize, j: usize, m: &Block3) -> Result<(), SparseError> {
        let slot = self.slot(i, j)?;
        self.add_to_slot(slot, m);
        Ok(())
    }

    /// Adds `m` to the block at a cached slot: the search-free path for hot loops.
    #[inline]
    pub fn add_to_slot(&mut self, slot: Slot, m: &Block3) {
        let b = &mut self.values[slot.index];
        if slot.transposed {
            for r in 0..3 {
                for c in 0..3 {
                    b[r][c] += m[c][r];
                }
            }
        } else {
            for r in 0..3 {
                for c in 0..3 {
                    b[r][c] += m[r][c];
                }
            }
        }
    }

    /// Block `(i, j)`: stored, transposed from storage, or zero if absent.
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`].
    pub fn block(&self, i: usize, j: usize) -> Result<Block3, SparseError> {
        let n = self.pattern.n;
        if i >= n || j >= n {
            return Err(SparseError::BlockIndexOutOfRange { row: i, col: j, n });
        }
        Ok(match self.pattern.find(i, j) {
            None => block::ZERO,
            Some(s) if s.transposed => block::transpose(&self.values[s.index]),
            Some(s) => self.values[s.index],
        })
    }

    /// Diagonal block `i` (no search: it is the first slot of row `i`).
    ///
    /// # Panics
    /// If `i >= n_blocks()`.
    #[inline]
    pub fn diagonal_block(&self, i: usize) -> &Block3 {
        &self.values[self.pattern.row_ptr[i]]
    }

    /// Adds `d[k]` to scalar diagonal entry `k` (e.g. a lumped mass matrix).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `d.len() != dim()`.
    pub fn add_to_diagonal(&mut self, d: &[f64]) -> Result<(), SparseError> {
        check_len("diagonal", d, self.dim())?;
        for i in 0..self.pattern.n {
            let b = &mut self.values[self.pattern.row_ptr[i]];
            for c in 0..3 {
                b[c][c] += d[3 * i + c];
            }
        }
        Ok(())
    }

    /// `self = diag(d) + a X + b Y` for matrices on one pattern, in one pass
    /// over the values: the implicit-Euler matrix
    /// `A = M - h df/dv - h^2 df/dx` of the reduced velocity form
    /// (docs/ARCHITECTURE.md) with `d = M`, `a = -h^2`, `X = df/dx`,
    /// `b = -h`, `Y = df/dv`: how `SecondOrderProblem::step_matrix` forms
    /// it from separately assembled Jacobians by default (a model may form
    /// it in its own sweep instead, as the mass-spring model does).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if the patterns differ;
    /// [`SparseError::DimensionMismatch`] if `d.len() != dim()`.
    pub fn assign_diagonal_plus_combination(
        &mut self,
        d: &[f64],
        a: f64,
        x: &SymBlockMatrix,
        b: f64,
        y: &SymBlockMatrix,
    ) -> Result<(), SparseError> {
        check_same_pattern(&self.pattern, &x.pattern)?;
        check_same_pattern(&self.pattern, &y.pattern)?;
        check_len("diagonal", d, self.dim())?;
        // Element-wise, so threads (fixed chunks of blocks) give the serial bits.
        let combine = |o: &mut [Block3], xv: &[Block3], yv: &[Block3]| {
            for (o, (xv, yv)) in o.iter_mut().zip(xv.iter().zip(yv)) {
                for r in 0..3 {
                    for c in 0..3 {
                        o[r][c] = a * xv[r][c] + b * yv[r][c];
                    }
                }
            }
        };
        if crate::par::parts_for(self.pattern.n) > 1 {
            use rayon::prelude::*;
            const CHUNK: usize = 4096;
            self.values
                .par_chunks_mut(CHUNK)
                .zip(x.values.par_chunks(CHUNK).zip(y.values.par_chunks(CHUNK)))
                .for_each(|(o, (xv, yv))| combine(o, xv, yv));
        } else {
            combine(&mut self.values, &x.values, &y.values);
        }
        self.add_to_diagonal(d)
    }

    /// Multiplies every value by `s`.
    pub fn scale(&mut self, s: f64) {
        for b in &mut self.values {
            *b = block::scale(b, s);
        }
    }

    /// `self += s * other`, for matrices that share one pattern
    /// (e.g. `A = M - h D - h^2 K` from `D` and `K` assembled on one pattern).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if the patterns differ.
    pub fn add_scaled(&mut self, s: f64, other: &SymBlockMatrix) -> Result<(), SparseError> {
        check_same_pattern(&self.pattern, &other.pattern)?;
        for (a, b) in self.values.iter_mut().zip(&other.values) {
            for r in 0..3 {
                for c in 0..3 {
                    a[r][c] += s * b[r][c];
                }
            }
        }
        Ok(())
    }

    /// `y = A x`, checking lengths.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `x` or `y` is not of length `dim()`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        check_len("x", x, self.dim())?;
        check_len("y", y, self.dim())?;
        self.spmv(x, y);
        Ok(())
    }

    /// The symmetric SpMV kernel: `y = A x`, and returns `x . y`.
    ///
    /// Every stored off-diagonal block `B_ij` is read once and applied twice.
    /// With more than one rayon thread and a large matrix, the rows are
    /// split into one part per thread ([`par`](crate::par)): see
    /// [`spmv_rows`](Self::spmv_rows) for the conflict-free scheme.
    #[inline]
    pub(crate) fn spmv_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let parts = crate::par::parts_for(self.pattern.n);
        if parts > 1 {
            let n = self.pattern.n;
            let (x3, _) = x.as_chunks::<3>();
            let (y3, _) = y.as_chunks_mut::<3>();
            let start = |t| self.pattern.part_start(t, parts);
            return crate::par::join_parts(
                &mut y3[..n],
                parts,
                &start,
                &|t, y| self.spmv_rows(&x3[..n], y, start(t)),
                &|a, b| a + b,
            );
        }
        self.spmv_dot_serial(x, y)
    }

    /// Rows `s..s + y3.len()` of `y = A x`, writing only those rows; returns
    /// their part of `x . y`.
    ///
    /// The conflict-free scheme for upper-triangle storage: a row's own
    /// blocks scatter `B_ij^T x_i` only to rows `j` of this part; the
    /// contributions of rows before the part (`i < s`) are gathered first
    /// through the transposed index. Every `y_j` thus sums the same terms
    /// in the same order as the serial kernel (rows `i < j` ascending, then
    /// row `j`'s own sum), so `y` is bitwise the serial one for any split;
    /// only the dot product's summation order depends on the number of parts.
    fn spmv_rows(&self, x3: &[[f64; 3]], y3: &mut [[f64; 3]], s: usize) -> f64 {
        let e = s + y3.len();
        let p = &*self.pattern;
        let vals = &self.values;
        if s == 0 {
            // The first part (or the serial kernel): no earlier rows.
            y3.fill([0.0; 3]);
        } else {
            for (j, yj) in (s..e).zip(y3.iter_mut()) {
                let mut acc = [0.0; 3];
                for k in p.lower.ptr[j]..p.lower.ptr[j + 1] {
                    let i = p.lower.row[k] as usize;
                    if i >= s {
                        break;
                    }
                    let u = block::mul_transpose_vec(&vals[p.lower.slot[k]], &x3[i]);
                    acc[0] += u[0];
                    acc[1] += u[1];
                    acc[2] += u[2];
                }
                *yj = acc;
            }
        }
        let mut dot = 0.0;
        for i in s..e {
            let start = p.row_ptr[i];
            let end = p.row_ptr[i + 1];
            let xi = x3[i];
            let mut yi = block::mul_vec(&vals[start], &xi);
            for (&j, b) in p.col_idx[start + 1..end].iter().zip(&vals[start + 1..end]) {
                let j = j as usize;
                let t = block::mul_vec(b, &x3[j]);
                yi[0] += t[0];
                yi[1] += t[1];
                yi[2] += t[2];
                if j < e {
                    let u = block::mul_transpose_vec(b, &xi);
                    let yj = &mut y3[j - s];
                    yj[0] += u[0];
                    yj[1] += u[1];
                    yj[2] += u[2];
                }
            }
            let out = &mut y3[i - s];
            out[0] += yi[0];
            out[1] += yi[1];
            out[2] += yi[2];
            dot += xi[0] * out[0] + xi[1] * out[1] + xi[2] * out[2];
        }
        dot
    }

    /// The serial kernel of [`spmv_dot`](Self::spmv_dot): all rows as one part.
    #[inline]
    fn spmv_dot_serial(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let n = self.pattern.n;
        let (x3, _) = x.as_chunks::<3>();
        let (y3, _) = y.as_chunks_mut::<3>();
        self.spmv_rows(&x3[..n], &mut y3[..n], 0)
    }

    /// CG's fused updates and product, in one pass over the matrix:
    /// `x <- x + alpha p` (old `p`), `p <- z + beta p`, `q = A p`; returns
    /// `p . q`. Row `i` stores its new `p_i`; the upper neighbours `j > i`
    /// are not updated yet, so their new values `z_j + beta p_j` are formed
    /// on the fly.
    ///
    /// Threaded (as [`spmv_dot`](Self::spmv_dot)), the updates and the
    /// product are two passes: a part's rows need the new `p` of rows in
    /// other parts. `x`, `p` and `q` are bitwise those of the serial pass.
    #[inline]
    pub(crate) fn update_spmv_dot(
        &self,
        z: &[f64],
        beta: f64,
        alpha: f64,
        x: &mut [f64],
        p: &mut [f64],
        q: &mut [f64],
    ) -> f64 {
        let n = self.pattern.n;
        if crate::par::parts_for(n) > 1 {
            crate::vecops::update_x_p(z, beta, alpha, x, p);
            return self.spmv_dot(p, q);
        }
        let (z3, _) = z.as_chunks::<3>();
        let (x3, _) = x.as_chunks_mut::<3>();
        let (p3, _) = p.as_chunks_mut::<3>();
        let (q3, _) = q.as_chunks_mut::<3>();
        let (z3, x3, p3, q3) = (&z3[..n], &mut x3[..n], &mut p3[..n], &mut q3[..n]);
        let row_ptr = &self.pattern.row_ptr;
        let cols = &self.pattern.col_idx;
        let vals = &self.values;
        let mut dot = 0.0;
        // q is zeroed just ahead of the rows that scatter into it, in the
        // same pass, instead of in a separate sweep: entries up to the
        // largest column seen so far are zero or accumulating.
        let mut zeroed = 0;
        for i in 0..n {
            let start = row_ptr[i];
            let end = row_ptr[i + 1];
            let reach = (cols[end - 1] as usize).max(i) + 1;
            if reach > zeroed {
                q3[zeroed..reach].fill([0.0; 3]);
                zeroed = reach;
            }
            let (zi, pi_old) = (z3[i], p3[i]);
            let xi = &mut x3[i];
            xi[0] += alpha * pi_old[0];
            xi[1] += alpha * pi_old[1];
            xi[2] += alpha * pi_old[2];
            let pi = [
                zi[0] + beta * pi_old[0],
                zi[1] + beta * pi_old[1],
                zi[2] + beta * pi_old[2],
            ];
            p3[i] = pi;
            let mut yi = block::mul_vec(&vals[start], &pi);
            for (&j, b) in cols[start + 1..end].iter().zip(&vals[start + 1..end]) {
                let j = j as usize;
                let (zj, pj_old) = (&z3[j], &p3[j]);
                let pj = [
                    zj[0] + beta * pj_old[0],
                    zj[1] + beta * pj_old[1],
                    zj[2] + beta * pj_old[2],
                ];
                let t = block::mul_vec(b, &pj);
                yi[0] += t[0];
                yi[1] += t[1];
                yi[2] += t[2];
                let u = block::mul_transpose_vec(b, &pi);
                let qj = &mut q3[j];
                qj[0] += u[0];
                qj[1] += u[1];
                qj[2] += u[2];
            }
            let out = &mut q3[i];
            out[0] += yi[0];
            out[1] += yi[1];
            out[2] += yi[2];
            dot += pi[0] * out[0] + pi[1] * out[1] + pi[2] * out[2];
        }
        dot
    }

    #[inline]
    fn spmv(&self, x: &[f64], y: &mut [f64]) {
        self.spmv_dot(x, y);
    }

    /// The full matrix (both triangles) as a scalar CSR `sprs` matrix.
    /// Every stored block contributes its 9 entries, zeros included, so the
    /// pattern is the same at every refill.
    pub fn to_csr(&self) -> sprs::CsMat<f64> {
        let n = self.pattern.n;
        let dim = 3 * n;
        // For each block row, the list of (block column, slot, transposed).
        let mut lower: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
        for i in 0..n {
            for k in self.pattern.row_ptr[i] + 1..self.pattern.row_ptr[i + 1] {
                lower[self.pattern.col_idx[k] as usize].push((i, k));
            }
        }
        let mut indptr = Vec::with_capacity(dim + 1);
        let mut indices = Vec::with_capacity(self.pattern.full_nnz());
        let mut data = Vec::with_capacity(self.pattern.full_nnz());
        indptr.push(0);
        for i in 0..n {
            for r in 0..3 {
                // Blocks left of the diagonal: transposes of upper blocks (j, i), j < i.
                for &(j, k) in &lower[i] {
                    for c in 0..3 {
                        indices.push(3 * j + c);
                        data.push(self.values[k][c][r]);
                    }
                }
                for k in self.pattern.row_ptr[i]..self.pattern.row_ptr[i + 1] {
                    let j = self.pattern.col_idx[k] as usize;
                    for c in 0..3 {
                        indices.push(3 * j + c);
                        data.push(self.values[k][r][c]);
                    }
                }
                indptr.push(indices.len());
            }
        }
        sprs::CsMat::new((dim, dim), indptr, indices, data)
    }

    /// The upper triangle (diagonal included) as scalar CSR arrays
    /// `(indptr, indices, data)`; read as CSC, the same arrays are the lower
    /// triangle, which is what faer's sparse Cholesky takes.
    #[cfg(feature = "faer")]
    pub(crate) fn upper_csr_arrays(&self) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let n = self.pattern.n;
        let nnz = 6 * n + 9 * (self.pattern.stored_blocks() - n);
        let mut indptr = Vec::with_capacity(3 * n + 1);
        let mut indices = Vec::with_capacity(nnz);
        let mut data = Vec::with_capacity(nnz);
        indptr.push(0);
        for i in 0..n {
            let start = self.pattern.row_ptr[i];
            for r in 0..3 {
                for c in r..3 {
                    indices.push(3 * i + c);
                    data.push(self.values[start][r][c]);
                }
                for k in start + 1..self.pattern.row_ptr[i + 1] {
                    let j = self.pattern.col_idx[k] as usize;
                    for c in 0..3 {
                        indices.push(3 * j + c);
                        data.push(self.values[k][r][c]);
                    }
                }
                indptr.push(indices.len());
            }
        }
        (indptr, indices, data)
    }

    /// The full matrix as faer's sparse column matrix (for faer's own
    /// kernels and direct solvers; feature `faer`).
    #[cfg(feature = "faer")]
    pub fn to_faer(&self) -> faer::sparse::SparseColMat<usize, f64> {
        // The matrix is symmetric: its CSR arrays are also its CSC arrays.
        let csr = self.to_csr();
        let dim = self.dim();
        let (indptr, indices, data) = csr.into_raw_storage();
        let symbolic =
            faer::sparse::SymbolicSparseColMat::new_checked(dim, dim, indptr, None, indices);
        faer::sparse::SparseColMat::new(symbolic, data)
    }

    /// Builds an `n x n` block matrix from block triplets `(i, j, m)`:
    /// the pattern is the set of pairs named, and each triplet adds `m` to
    /// block `(i, j)` and, by symmetry, `m^T` to block `(j, i)`
    /// ([`add_to_block`](Self::add_to_block)); duplicates are summed. So a
    /// coupling between two particles is given once, in either orientation
    /// (giving `(i, j, m)` and `(j, i, m^T)` counts it twice).
    ///
    /// For matrices refilled every step, build the [`BlockPattern`] once and
    /// refill through [`slot`](Self::slot)s instead; this allocates.
    ///
    /// ```
    /// use hookean_sparse::{SymBlockMatrix, block};
    /// let k = block::scale(&block::IDENTITY, 2.0);
    /// let a = SymBlockMatrix::from_blocks(2, [
    ///     (0, 0, k), (1, 1, k), (0, 1, block::scale(&k, -0.5)), (1, 1, k),
    /// ])?;
    /// assert_eq!(a.block(1, 1)?[0][0], 4.0); // the two (1, 1) triplets summed
    /// assert_eq!(a.block(1, 0)?[2][2], -1.0); // (0, 1) seen from the other side
    /// # Ok::<(), hookean_sparse::SparseError>(())
    /// ```
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`] for a triplet outside the
    /// matrix, [`SparseError::NonFinite`] for a NaN or infinite entry, and
    /// [`SparseError::NotSymmetric`] if a diagonal block ends up asymmetric
    /// (by more than `1e-12` of its largest entry).
    pub fn from_blocks(
        n: usize,
        blocks: impl IntoIterator<Item = (usize, usize, Block3)>,
    ) -> Result<Self, SparseError> {
        let blocks: Vec<(usize, usize, Block3)> = blocks.into_iter().collect();
        for (k, (_, _, m)) in blocks.iter().enumerate() {
            if m.iter().flatten().any(|v| !v.is_finite()) {
                return Err(SparseError::NonFinite {
                    what: "block triplet",
                    index: Some(k),
                });
            }
        }
        let pattern = BlockPattern::new(n, blocks.iter().map(|&(i, j, _)| (i, j)))?;
        let mut a = SymBlockMatrix::new(Arc::new(pattern));
        for (i, j, m) in &blocks {
            a.add_to_block(*i, *j, m)?;
        }
        for i in 0..n {
            let d = a.diagonal_block(i);
            let tol = 1e-12 * d.iter().flatten().fold(0.0_f64, |s, v| s.max(v.abs()));
            for r in 0..3 {
                for c in r + 1..3 {
                    if (d[r][c] - d[c][r]).abs() > tol {
                        return Err(SparseError::NotSymmetric {
                            row: 3 * i + r,
                            col: 3 * i + c,
                        });
                    }
                }
            }
        }
        Ok(a)
    }

    /// Builds a block matrix from a scalar `sprs` matrix (CSR or CSC) whose
    /// dimension is a multiple of 3. Every 3x3 block with at least one stored
    /// entry enters the pattern.
    ///
    /// # Errors
    /// [`SparseError::NotSquare`], [`SparseError::NotBlockAligned`],
    /// [`SparseError::NonFinite`], and [`SparseError::NotSymmetric`] if an
    /// entry differs from its transpose by more than `1e-12` of the largest entry.
    pub fn from_csr(a: &sprs::CsMat<f64>) -> Result<Self, SparseError> {
        let (rows, cols) = a.shape();
        if rows != cols {
            return Err(SparseError::NotSquare { rows, cols });
        }
        if rows % 3 != 0 {
            return Err(SparseError::NotBlockAligned { dim: rows });
        }
        let n = rows / 3;
        check_csr_symmetric(a)?;
        if !a.is_csr() {
            return Self::from_csr(&a.to_csr());
        }
        let (indptr, indices, data) = (a.indptr(), a.indices(), a.data());
        let row = |r: usize| indptr.index(r)..indptr.index(r + 1);
        let mut m = SymBlockMatrix::try_new(Arc::new(BlockPattern::of_scalar_upper(n, a)?))?;
        // Each scalar row meets its block row's stored blocks in column
        // order: one cursor per row instead of a search per entry.
        for r in 0..rows {
            let bi = r / 3;
            let (start, end) = (m.pattern.row_ptr[bi], m.pattern.row_ptr[bi + 1]);
            let mut slot = start;
            for k in row(r) {
                let bj = indices[k] / 3;
                if bj < bi {
                    continue;
                }
                while slot < end && (m.pattern.col_idx[slot] as usize) < bj {
                    slot += 1;
                }
                debug_assert!(slot < end && m.pattern.col_idx[slot] as usize == bj);
                m.values[slot][r % 3][indices[k] % 3] = data[k];
            }
        }
        Ok(m)
    }
}

#[cfg(test)]
mod tests;
