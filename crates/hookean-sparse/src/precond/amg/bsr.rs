//! The storage of every multigrid level: full (both triangles) block CSR
//! with `B x B` blocks, generic in the block size (3 for particles, 1 for
//! scalar matrices) and in the precision of the stored entries
//! ([`Entry`]: `f64`, or `f32` for half the bytes), and the small dense
//! block kernels on it. Every kernel loads the entries into `f64` and
//! computes in `f64`.
//!
//! Full storage (rather than the symmetric storage of
//! [`SymBlockMatrix`](crate::SymBlockMatrix)) makes every kernel of the
//! V-cycle a loop over rows that only writes its own row: smoothing,
//! residual, restriction (with `R = P^T` stored explicitly) and
//! prolongation are split by row ranges across threads ([`super::par`]).

use super::par;
use crate::transpose::{column_pointers, scatter_transpose};

/// A dense `B x B` block, row-major.
pub(crate) type Blk<const R: usize, const C: usize = R> = [[f64; C]; R];

/// The type of a stored block entry: `f64`, or `f32` (single-precision
/// levels: half the memory traffic of the V-cycle; the arithmetic stays in
/// `f64`, so a level's kernels are the same linear maps, only their stored
/// coefficients rounded).
pub(crate) trait Entry:
    Copy + Default + PartialEq + Send + Sync + std::fmt::Debug + 'static
{
    /// Whether entries are stored exactly as computed (`f64`): products of
    /// stored matrices (`A P`) then equal the product of their factors.
    const EXACT: bool;
    /// The entry as `f64`.
    fn load(self) -> f64;
    /// The nearest entry to `v`.
    fn store(v: f64) -> Self;
}

impl Entry for f64 {
    const EXACT: bool = true;
    #[inline(always)]
    fn load(self) -> f64 {
        self
    }
    #[inline(always)]
    fn store(v: f64) -> Self {
        v
    }
}

impl Entry for f32 {
    const EXACT: bool = false;
    #[inline(always)]
    fn load(self) -> f64 {
        f64::from(self)
    }
    #[inline(always)]
    fn store(v: f64) -> Self {
        v as f32
    }
}

/// A stored `B x B` block.
pub(crate) type SBlk<S, const R: usize, const C: usize = R> = [[S; C]; R];

/// A stored block in `f64`.
#[inline(always)]
pub(crate) fn load<S: Entry, const R: usize, const C: usize>(m: &SBlk<S, R, C>) -> Blk<R, C> {
    let mut out = [[0.0; C]; R];
    for r in 0..R {
        for c in 0..C {
            out[r][c] = m[r][c].load();
        }
    }
    out
}

/// A block rounded to the storage type.
#[inline(always)]
pub(crate) fn store<S: Entry, const R: usize, const C: usize>(m: &Blk<R, C>) -> SBlk<S, R, C> {
    let mut out = [[S::default(); C]; R];
    for r in 0..R {
        for c in 0..C {
            out[r][c] = S::store(m[r][c]);
        }
    }
    out
}

/// The zero stored block.
#[inline(always)]
pub(crate) fn szero<S: Entry, const R: usize, const C: usize>() -> SBlk<S, R, C> {
    [[S::default(); C]; R]
}

/// `y += m x` for a stored block.
#[inline(always)]
pub(crate) fn smul_add<S: Entry, const R: usize, const C: usize>(
    m: &SBlk<S, R, C>,
    x: &[f64; C],
    y: &mut [f64; R],
) {
    for r in 0..R {
        let mut s = 0.0;
        for c in 0..C {
            s += m[r][c].load() * x[c];
        }
        y[r] += s;
    }
}

/// `c += a b` with `c` stored (rounded once after the block product).
#[inline(always)]
pub(crate) fn smul_mat_add<
    S: Entry,
    T: Entry,
    U: Entry,
    const R: usize,
    const M: usize,
    const C: usize,
>(
    a: &SBlk<S, R, M>,
    b: &SBlk<T, M, C>,
    c: &mut SBlk<U, R, C>,
) {
    let mut acc = load(c);
    for r in 0..R {
        for k in 0..M {
            let ark = a[r][k].load();
            for col in 0..C {
                acc[r][col] += ark * b[k][col].load();
            }
        }
    }
    *c = store(&acc);
}

/// The transpose of a stored block.
#[inline(always)]
pub(crate) fn stranspose<S: Entry, const R: usize, const C: usize>(
    m: &SBlk<S, R, C>,
) -> SBlk<S, C, R> {
    let mut t = [[S::default(); R]; C];
    for r in 0..R {
        for c in 0..C {
            t[c][r] = m[r][c];
        }
    }
    t
}

/// The zero block.
#[inline(always)]
pub(crate) fn zero<const R: usize, const C: usize>() -> Blk<R, C> {
    [[0.0; C]; R]
}

/// `y += m x`.
#[inline(always)]
pub(crate) fn mul_add<const R: usize, const C: usize>(
    m: &Blk<R, C>,
    x: &[f64; C],
    y: &mut [f64; R],
) {
    for r in 0..R {
        let mut s = 0.0;
        for c in 0..C {
            s += m[r][c] * x[c];
        }
        y[r] += s;
    }
}

/// `m x`.
#[inline(always)]
pub(crate) fn mul_vec<const B: usize>(m: &Blk<B>, x: &[f64; B]) -> [f64; B] {
    let mut y = [0.0; B];
    mul_add(m, x, &mut y);
    y
}

/// `c += a b`.
#[inline(always)]
pub(crate) fn mul_mat_add<const R: usize, const M: usize, const C: usize>(
    a: &Blk<R, M>,
    b: &Blk<M, C>,
    c: &mut Blk<R, C>,
) {
    for r in 0..R {
        for k in 0..M {
            let ark = a[r][k];
            for col in 0..C {
                c[r][col] += ark * b[k][col];
            }
        }
    }
}

/// `m^T`.
#[inline(always)]
pub(crate) fn transpose<const B: usize>(m: &Blk<B>) -> Blk<B> {
    let mut t = zero::<B, B>();
    for r in 0..B {
        for c in 0..B {
            t[c][r] = m[r][c];
        }
    }
    t
}

/// The squared Frobenius norm.
#[inline(always)]
pub(crate) fn frobenius2<const R: usize, const C: usize>(m: &Blk<R, C>) -> f64 {
    m.iter().flatten().map(|v| v * v).sum()
}

/// The inverse of the symmetric part `(m + m^T) / 2` of a block by its
/// Cholesky factorisation, or `None` when that part is not positive
/// definite (a pivot `<= 1e-14` of the largest diagonal entry, or not
/// finite). The result is symmetric, so a smoother built from it is too.
pub(crate) fn spd_inverse<const B: usize>(m: &Blk<B>) -> Option<Blk<B>> {
    if B == 3 {
        let mut out = zero::<B, B>();
        let done = spd_inverse3(m.as_flattened(), out.as_flattened_mut());
        return done.then_some(out);
    }
    let mut l = zero::<B, B>();
    let scale = (0..B).fold(0.0_f64, |s, i| s.max(m[i][i].abs()));
    for j in 0..B {
        let mut d = m[j][j];
        for k in 0..j {
            d -= l[j][k] * l[j][k];
        }
        if !(d > 1e-14 * scale && d.is_finite()) {
            return None;
        }
        let ljj = d.sqrt();
        l[j][j] = ljj;
        for i in j + 1..B {
            let mut s = 0.5 * (m[i][j] + m[j][i]);
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            l[i][j] = s / ljj;
        }
    }
    // Columns of the inverse: solve L L^T x = e_c.
    let mut inv = zero::<B, B>();
    for c in 0..B {
        let mut y = [0.0; B];
        for i in 0..B {
            let mut s = if i == c { 1.0 } else { 0.0 };
            for k in 0..i {
                s -= l[i][k] * y[k];
            }
            y[i] = s / l[i][i];
        }
        for i in (0..B).rev() {
            let mut s = y[i];
            for k in i + 1..B {
                s -= l[k][i] * y[k];
            }
            y[i] = s / l[i][i];
        }
        for i in 0..B {
            inv[i][c] = y[i];
        }
    }
    // Exactly symmetric.
    for r in 0..B {
        for c in r + 1..B {
            let s = 0.5 * (inv[r][c] + inv[c][r]);
            inv[r][c] = s;
            inv[c][r] = s;
        }
    }
    Some(inv)
}

/// [`spd_inverse`] of a 3x3 block (row-major in `m`, into `inv`) by its
/// adjugate: the same positive-definiteness test (the Cholesky pivots
/// `a`, `(a d - b^2) / a` and `det / (a d - b^2)` above `1e-14` of the
/// largest diagonal entry), without square roots and with one division.
#[inline(always)]
fn spd_inverse3(m: &[f64], inv: &mut [f64]) -> bool {
    let (a, d, f) = (m[0], m[4], m[8]);
    let b = 0.5 * (m[1] + m[3]);
    let c = 0.5 * (m[2] + m[6]);
    let e = 0.5 * (m[5] + m[7]);
    let tol = 1e-14 * a.abs().max(d.abs()).max(f.abs());
    // Cofactors of the symmetric part.
    let c00 = d * f - e * e;
    let c01 = c * e - b * f;
    let c02 = b * e - c * d;
    let c11 = a * f - c * c;
    let c12 = b * c - a * e;
    let minor2 = a * d - b * b;
    let det = a * c00 + b * c01 + c * c02;
    let definite = a > tol && minor2 > tol * a && det > tol * minor2 && det.is_finite();
    if !definite {
        return false;
    }
    let s = 1.0 / det;
    let (i00, i01, i02, i11, i12, i22) = (c00 * s, c01 * s, c02 * s, c11 * s, c12 * s, minor2 * s);
    inv.copy_from_slice(&[i00, i01, i02, i01, i11, i12, i02, i12, i22]);
    true
}

/// The determinant of a block (for error messages), by Gaussian elimination
/// with partial pivoting.
pub(crate) fn determinant<const B: usize>(m: &Blk<B>) -> f64 {
    let mut a = *m;
    let mut det = 1.0;
    for k in 0..B {
        let p = (k..B)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .unwrap_or(k);
        if a[p][k] == 0.0 {
            return 0.0;
        }
        if p != k {
            a.swap(p, k);
            det = -det;
        }
        det *= a[k][k];
        for i in k + 1..B {
            let f = a[i][k] / a[k][k];
            for j in k..B {
                a[i][j] -= f * a[k][j];
            }
        }
    }
    det
}

/// A sparse matrix of `B x C` blocks (square, `C = B`, for operators) in
/// block CSR, both triangles stored, columns sorted within each row,
/// entries stored as `S`. Rectangular (in blocks and in block rows) for
/// prolongators: `B` unknowns per fine node, `C` per coarse node.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Bsr<const B: usize, S: Entry = f64, const C: usize = B> {
    pub nrows: usize,
    pub ncols: usize,
    pub row_ptr: Vec<usize>,
    pub col: Vec<u32>,
    pub val: Vec<SBlk<S, B, C>>,
}

impl<const B: usize, S: Entry, const C: usize> Bsr<B, S, C> {
    /// An empty `nrows x ncols` matrix (no stored blocks).
    pub fn empty(nrows: usize, ncols: usize) -> Self {
        Self {
            nrows,
            ncols,
            row_ptr: vec![0; nrows + 1],
            col: Vec::new(),
            val: Vec::new(),
        }
    }

    /// Stored blocks.
    pub fn nnz_blocks(&self) -> usize {
        self.col.len()
    }

    /// The slots of row `i`.
    #[inline(always)]
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.row_ptr[i]..self.row_ptr[i + 1]
    }

    /// The slot of the diagonal block of every row, or the first row without one.
    pub fn diagonal_slots(&self) -> Result<Vec<usize>, usize> {
        (0..self.nrows)
            .map(|i| {
                let row = self.row(i);
                self.col[row.clone()]
                    .binary_search(&(i as u32))
                    .map(|k| row.start + k)
                    .map_err(|_| i)
            })
            .collect()
    }

    /// `sum_j A_ij x_j` for row `i` (`x` as blocks).
    #[inline(always)]
    pub fn row_times(&self, i: usize, x: &[[f64; C]]) -> [f64; B] {
        let r = self.row(i);
        // The B C products m_rc x_c of all blocks of the row summed term by
        // term (independent sums, no reduction per block), then each output
        // entry as the sum of its C partial sums.
        let mut acc = [[0.0; C]; B];
        for (&c, v) in self.col[r.clone()].iter().zip(&self.val[r]) {
            let xc = &x[c as usize];
            for rr in 0..B {
                for cc in 0..C {
                    acc[rr][cc] += v[rr][cc].load() * xc[cc];
                }
            }
        }
        let mut y = [0.0; B];
        for rr in 0..B {
            y[rr] = acc[rr].iter().sum();
        }
        y
    }

    /// `y = A x` (rows split across threads, compiled for the CPU's
    /// instruction set: [`par::kernel_rows`]).
    pub fn spmv(&self, x: &[f64], y: &mut [f64]) {
        let (x3, _) = x.as_chunks::<C>();
        let (y3, _) = y.as_chunks_mut::<B>();
        let kernel = Residual {
            a: self,
            b3: None,
            x3,
        };
        par::kernel_rows(&mut y3[..self.nrows], &kernel);
    }

    /// `r = b - A x` (rows split across threads, compiled for the CPU's
    /// instruction set: [`par::kernel_rows`]).
    pub fn residual(&self, b: &[f64], x: &[f64], r: &mut [f64]) {
        let (x3, _) = x.as_chunks::<C>();
        let (b3, _) = b.as_chunks::<B>();
        let (r3, _) = r.as_chunks_mut::<B>();
        let kernel = Residual {
            a: self,
            b3: Some(b3),
            x3,
        };
        par::kernel_rows(&mut r3[..self.nrows], &kernel);
    }

    /// The same pattern with the entries stored as `T` (values zero).
    pub fn pattern_as<T: Entry>(&self) -> Bsr<B, T, C> {
        Bsr {
            nrows: self.nrows,
            ncols: self.ncols,
            row_ptr: self.row_ptr.clone(),
            col: self.col.clone(),
            val: vec![szero::<T, B, C>(); self.col.len()],
        }
    }

    /// The pattern of `A^T` (values zero) and, for every slot of it, the
    /// slot of `A` it transposes.
    pub fn transpose_pattern(&self) -> (Bsr<C, S, B>, Vec<u32>) {
        let row_ptr = column_pointers(self.ncols, &self.row_ptr, &self.col, 0);
        let nnz = self.col.len();
        let mut col = vec![0u32; nnz];
        let mut map = vec![0u32; nnz];
        scatter_transpose(
            &self.row_ptr,
            &self.col,
            0,
            &mut row_ptr.clone(),
            &mut col,
            |p, k| map[p] = k as u32,
        );
        let t = Bsr {
            nrows: self.ncols,
            ncols: self.nrows,
            row_ptr,
            col,
            val: vec![szero::<S, C, B>(); nnz],
        };
        (t, map)
    }

    /// Refills `t` (built by [`transpose_pattern`](Self::transpose_pattern))
    /// with the transposed values of `self`.
    pub fn fill_transpose(&self, t: &mut Bsr<C, S, B>, map: &[u32]) {
        par::row_slices(&t.row_ptr, &mut t.val, &|i, vals: &mut [SBlk<S, C, B>]| {
            for (v, &k) in vals.iter_mut().zip(&map[t.row_ptr[i]..]) {
                *v = stranspose(&self.val[k as usize]);
            }
        });
    }
}

/// Row `i` of `b - A x` ([`Bsr::residual`]), or of `A x` without `b`
/// ([`Bsr::spmv`]).
struct Residual<'a, const B: usize, S: Entry, const C: usize> {
    a: &'a Bsr<B, S, C>,
    b3: Option<&'a [[f64; B]]>,
    x3: &'a [[f64; C]],
}

impl<const B: usize, S: Entry, const C: usize> par::RowKernel<[f64; B]> for Residual<'_, B, S, C> {
    #[inline(always)]
    fn row(&self, i: usize, out: &mut [f64; B]) {
        let ax = self.a.row_times(i, self.x3);
        match self.b3 {
            Some(b3) => {
                for c in 0..B {
                    out[c] = b3[i][c] - ax[c];
                }
            }
            None => *out = ax,
        }
    }
}

/// The pattern of the product `C = X Y` (values zero), columns sorted,
/// without a sort: Gustavson's symbolic product (row `i` of `C` is the
/// union of the rows of `Y` that row `i` of `X` selects, found with one
/// marker per column) leaves every row's columns in the order they were
/// found; two counting-sort transposes, `C -> C^T -> C`, put them in order
/// in `O(nnz(C) + n)` (Gustavson 1978, "Two fast algorithms for sparse
/// matrices: multiplication and permuted transposition").
pub(crate) fn product_pattern<
    const B: usize,
    const M: usize,
    const C: usize,
    S: Entry,
    T: Entry,
    U: Entry,
>(
    x: &Bsr<B, S, M>,
    y: &Bsr<M, T, C>,
) -> Bsr<B, U, C> {
    // Row `i` marks column `j` with `i + 1` (0: no row yet).
    let mut marker = vec![0u32; y.ncols];
    let mut row_ptr = Vec::with_capacity(x.nrows + 1);
    let mut col: Vec<u32> = Vec::with_capacity(x.col.len());
    row_ptr.push(0);
    for i in 0..x.nrows {
        let mark = i as u32 + 1;
        for k in x.row(i) {
            for &j in &y.col[y.row(x.col[k] as usize)] {
                if marker[j as usize] != mark {
                    marker[j as usize] = mark;
                    col.push(j);
                }
            }
        }
        row_ptr.push(col.len());
    }
    drop(marker);
    let t_ptr = column_pointers(y.ncols, &row_ptr, &col, 0);
    let mut t_col = vec![0u32; col.len()];
    scatter_transpose(&row_ptr, &col, 0, &mut t_ptr.clone(), &mut t_col, |_, _| {});
    scatter_transpose(&t_ptr, &t_col, 0, &mut row_ptr.clone(), &mut col, |_, _| {});
    let nnz = col.len();
    Bsr {
        nrows: x.nrows,
        ncols: y.ncols,
        row_ptr,
        col,
        val: vec![szero::<U, B, C>(); nnz],
    }
}

/// The numbers of `C = X Y` on the pattern from [`product_pattern`]
/// (Gustavson's row-by-row product, rows split across threads). The slot
/// of every product term in row `i` of `C` is read from a table of the
/// row's columns when they span at most [`SLOT_WINDOW`] columns, else
/// found by a forward scan of the row's sorted columns (the columns of a
/// row of `Y` are sorted too); either way rows are independent and the
/// terms are added in the same order.
pub(crate) fn product_values<
    const B: usize,
    const M: usize,
    const C: usize,
    S: Entry,
    T: Entry,
    U: Entry,
>(
    x: &Bsr<B, S, M>,
    y: &Bsr<M, T, C>,
    c: &mut Bsr<B, U, C>,
) {
    let kernel = Product {
        x,
        y,
        row_ptr: &c.row_ptr,
        col: &c.col,
    };
    par::kernel_row_slices_with(&c.row_ptr, &mut c.val, &RowScratch::new, &kernel);
}

/// Row `i` of `C = X Y` on `C`'s pattern (`row_ptr`, `col`), as a kernel of
/// [`par::kernel_row_slices_with`]: [`product_values`] without its
/// symmetry, [`product_values_symmetric`] with it.
struct Product<'a, const B: usize, const M: usize, const C: usize, S: Entry, T: Entry> {
    x: &'a Bsr<B, S, M>,
    y: &'a Bsr<M, T, C>,
    row_ptr: &'a [usize],
    col: &'a [u32],
}

impl<const B: usize, const M: usize, const C: usize, S: Entry, T: Entry, U: Entry>
    par::RowSliceKernel<SBlk<U, B, C>, RowScratch<B, C>> for Product<'_, B, M, C, S, T>
{
    #[inline(always)]
    fn row(&self, i: usize, vals: &mut [SBlk<U, B, C>], scratch: &mut RowScratch<B, C>) {
        let cols = &self.col[self.row_ptr[i]..self.row_ptr[i + 1]];
        product_row(self.x, self.y, i, cols, 0, vals, scratch, |_| true);
    }
}

/// Row `i` of the upper triangle of the symmetric `C = X Y`
/// ([`product_values_symmetric`]), its diagonal block made exactly symmetric.
struct SymmetricProduct<'a, const B: usize, const M: usize, S: Entry, T: Entry>(
    Product<'a, B, M, B, S, T>,
);

impl<const B: usize, const M: usize, S: Entry, T: Entry, U: Entry>
    par::RowSliceKernel<SBlk<U, B>, RowScratch<B, B>> for SymmetricProduct<'_, B, M, S, T>
{
    #[inline(always)]
    fn row(&self, i: usize, vals: &mut [SBlk<U, B>], scratch: &mut RowScratch<B, B>) {
        let p = &self.0;
        let cols = &p.col[p.row_ptr[i]..p.row_ptr[i + 1]];
        let first = cols.partition_point(|&j| (j as usize) < i);
        product_row(p.x, p.y, i, cols, first, vals, scratch, |j| j as usize >= i);
        // The diagonal block, symmetric in exact arithmetic, made exactly
        // symmetric (its rounding would otherwise differ across the diagonal).
        if cols.get(first) == Some(&(i as u32)) {
            let d = load(&vals[first]);
            let mut sym = d;
            for r in 0..B {
                for c in 0..B {
                    sym[r][c] = 0.5 * (d[r][c] + d[c][r]);
                }
            }
            vals[first] = store(&sym);
        }
    }
}

/// Row `i` of `C = X Y` into `vals` (the slots of `cols[first..]`), for
/// the product terms whose column passes `keep`: accumulated in place when
/// `C` stores `f64`, else in `f64` in the task's scratch for rows up to
/// [`ROW_BUFFER`] blocks and then rounded once.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn product_row<const B: usize, const M: usize, const C: usize, S: Entry, T: Entry, U: Entry>(
    x: &Bsr<B, S, M>,
    y: &Bsr<M, T, C>,
    i: usize,
    cols: &[u32],
    first: usize,
    vals: &mut [SBlk<U, B, C>],
    scratch: &mut RowScratch<B, C>,
    keep: impl Fn(u32) -> bool,
) {
    let n = cols.len() - first;
    let RowScratch { acc, slots } = scratch;
    let table = SlotTable::new(cols, first, slots);
    if !U::EXACT && n <= ROW_BUFFER {
        acc[..n].fill(zero::<B, C>());
        product_terms(x, y, i, &table, keep, load, |xk, yq, p| {
            mul_mat_add(xk, &load(yq), &mut acc[p - first]);
        });
        for (v, a) in vals[first..].iter_mut().zip(&acc[..n]) {
            *v = store(a);
        }
    } else {
        vals[first..].fill(szero::<U, B, C>());
        product_terms(
            x,
            y,
            i,
            &table,
            keep,
            |b| *b,
            |xk, yq, p| {
                smul_mat_add(xk, yq, &mut vals[p]);
            },
        );
    }
}

/// Where the column `j` of a product term sits in a row's sorted columns
/// `cols[first..]`: `slots[j - cols[first]]` when the columns span at most
/// [`SLOT_WINDOW`] (the table filled for the row: one write per column),
/// else a forward scan from `first` (restarted for every block of `X`).
struct SlotTable<'a> {
    cols: &'a [u32],
    first: usize,
    window: Option<(u32, &'a [u32; SLOT_WINDOW])>,
}

impl<'a> SlotTable<'a> {
    #[inline(always)]
    fn new(cols: &'a [u32], first: usize, slots: &'a mut [u32; SLOT_WINDOW]) -> Self {
        let window = match (cols.get(first), cols.last()) {
            (Some(&lo), Some(&hi)) if ((hi - lo) as usize) < SLOT_WINDOW => {
                for (p, &j) in cols.iter().enumerate().skip(first) {
                    slots[(j - lo) as usize] = p as u32;
                }
                Some((lo, &*slots))
            }
            _ => None,
        };
        Self {
            cols,
            first,
            window,
        }
    }
}

/// Every term `X_ik Y_kj` of row `i` of `X Y` whose column `j` is kept:
/// `add(prepare(X_ik), Y_kj, p)` with `p` the slot of `j` in the row's
/// columns (`table`; `prepare` runs once per block of `X`).
#[inline(always)]
fn product_terms<const B: usize, const M: usize, const C: usize, S: Entry, T: Entry, P>(
    x: &Bsr<B, S, M>,
    y: &Bsr<M, T, C>,
    i: usize,
    table: &SlotTable<'_>,
    keep: impl Fn(u32) -> bool,
    prepare: impl Fn(&SBlk<S, B, M>) -> P,
    mut add: impl FnMut(&P, &SBlk<T, M, C>, usize),
) {
    for k in x.row(i) {
        let xk = prepare(&x.val[k]);
        let m = x.col[k] as usize;
        let row = y.row(m);
        let terms = y.col[row.clone()].iter().zip(&y.val[row]);
        match table.window {
            Some((lo, slots)) => {
                for (&j, yq) in terms {
                    if keep(j) {
                        add(&xk, yq, slots[(j - lo) as usize] as usize);
                    }
                }
            }
            None => {
                let mut p = table.first;
                for (&j, yq) in terms {
                    if !keep(j) {
                        continue;
                    }
                    while table.cols[p] != j {
                        p += 1;
                    }
                    add(&xk, yq, p);
                }
            }
        }
    }
}

/// Product rows up to this many blocks are accumulated on the stack in
/// `f64` (rows of `A P` and `R A P` of a cloth have 8-12).
const ROW_BUFFER: usize = 16;

/// Product rows whose columns span at most this many get a slot table.
const SLOT_WINDOW: usize = 2048;

/// The scratch of [`product_row`], made once per task of rows (not zeroed
/// whole for every row: only a row's own part is written): the `f64`
/// accumulator of a row and the slot table of [`SlotTable`].
struct RowScratch<const B: usize, const C: usize> {
    acc: [Blk<B, C>; ROW_BUFFER],
    slots: [u32; SLOT_WINDOW],
}

impl<const B: usize, const C: usize> RowScratch<B, C> {
    fn new() -> Self {
        Self {
            acc: [zero::<B, C>(); ROW_BUFFER],
            slots: [0; SLOT_WINDOW],
        }
    }
}

/// The numbers of the symmetric product `C = X Y` (the Galerkin operator
/// `R (A P)` with `R = P^T`) on the pattern from [`product_pattern`], which
/// is then structurally symmetric: the blocks on and above the diagonal are
/// computed as in [`product_values`] (rows split across threads), those
/// below are the transposes of their mirror blocks (`mirror[s]`: the slot
/// of the transposed block of slot `s`, from [`Bsr::transpose_pattern`]).
/// Half the block products, and `C` exactly symmetric.
pub(crate) fn product_values_symmetric<
    const B: usize,
    const M: usize,
    S: Entry,
    T: Entry,
    U: Entry,
>(
    x: &Bsr<B, S, M>,
    y: &Bsr<M, T, B>,
    c: &mut Bsr<B, U>,
    mirror: &[u32],
) {
    let kernel = SymmetricProduct(Product {
        x,
        y,
        row_ptr: &c.row_ptr,
        col: &c.col,
    });
    par::kernel_row_slices_with(&c.row_ptr, &mut c.val, &RowScratch::new, &kernel);
    for i in 0..c.nrows {
        for s in c.row(i) {
            if (c.col[s] as usize) < i {
                c.val[s] = stranspose(&c.val[mirror[s] as usize]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spd_inverse_inverts_and_rejects_indefinite_blocks() {
        let m = [[4.0, 1.0, 0.5], [1.0, 3.0, -0.2], [0.5, -0.2, 2.0]];
        let inv = spd_inverse(&m).unwrap();
        let mut p = zero::<3, 3>();
        mul_mat_add(&m, &inv, &mut p);
        for r in 0..3 {
            for c in 0..3 {
                let e = if r == c { 1.0 } else { 0.0 };
                approx::assert_abs_diff_eq!(p[r][c], e, epsilon = 1e-14);
            }
        }
        assert!(spd_inverse(&[[1.0, 2.0], [2.0, 1.0]]).is_none());
        assert!(spd_inverse(&[[0.0]]).is_none());
        assert!(
            (determinant(&m) - (4.0 * (6.0 - 0.04) - (2.0 + 0.1) + 0.5 * (-0.2 - 1.5))).abs()
                < 1e-12
        );
    }

    /// A pattern (values zero) from a dense boolean matrix, each row's
    /// columns in increasing order, or decreasing when `reversed`.
    fn pattern_of(dense: &[Vec<bool>], ncols: usize, reversed: bool) -> Bsr<1> {
        let mut m = Bsr::<1>::empty(dense.len(), ncols);
        m.row_ptr.clear();
        m.row_ptr.push(0);
        for row in dense {
            let mut cols: Vec<u32> = (0..ncols as u32).filter(|&j| row[j as usize]).collect();
            if reversed {
                cols.reverse();
            }
            m.col.extend(cols);
            m.row_ptr.push(m.col.len());
        }
        m.val = vec![szero::<f64, 1, 1>(); m.col.len()];
        m
    }

    use proptest::prelude::*;

    proptest! {
        /// The sort-free symbolic product against the nonzero pattern of the
        /// dense boolean product `C_ij = OR_k X_ik Y_kj` (rows of `X` and
        /// `Y` given in any column order), and its transpose against the
        /// dense transpose.
        #[test]
        fn product_pattern_is_the_dense_products_pattern(
            (n, m, l, bits) in (1usize..12, 1usize..12, 1usize..12).prop_flat_map(|(n, m, l)| {
                (Just(n), Just(m), Just(l), proptest::collection::vec(0u8..4, n * m + m * l))
            }),
            reversed in any::<bool>(),
        ) {
            // About one entry in four is structurally nonzero.
            let xd: Vec<Vec<bool>> = (0..n).map(|i| (0..m).map(|k| bits[i * m + k] == 0).collect()).collect();
            let yd: Vec<Vec<bool>> = (0..m).map(|k| (0..l).map(|j| bits[n * m + k * l + j] == 0).collect()).collect();
            let x = pattern_of(&xd, m, reversed);
            let y = pattern_of(&yd, l, !reversed);
            let c: Bsr<1> = product_pattern(&x, &y);
            let cd: Vec<Vec<bool>> = (0..n)
                .map(|i| (0..l).map(|j| (0..m).any(|k| xd[i][k] && yd[k][j])).collect())
                .collect();
            let expected = pattern_of(&cd, l, false);
            prop_assert_eq!((c.nrows, c.ncols), (n, l));
            prop_assert_eq!(&c.row_ptr, &expected.row_ptr);
            prop_assert_eq!(&c.col, &expected.col);
            let (ct, map) = c.transpose_pattern();
            let ctd: Vec<Vec<bool>> = (0..l).map(|j| (0..n).map(|i| cd[i][j]).collect()).collect();
            let expected_t = pattern_of(&ctd, n, false);
            prop_assert_eq!(&ct.row_ptr, &expected_t.row_ptr);
            prop_assert_eq!(&ct.col, &expected_t.col);
            for j in 0..l {
                for p in ct.row(j) {
                    let k = map[p] as usize;
                    let i = c.row_ptr.partition_point(|&s| s <= k) - 1;
                    prop_assert_eq!((i as u32, c.col[k]), (ct.col[p], j as u32));
                }
            }
        }
    }

    /// Product rows whose columns span more than [`SLOT_WINDOW`] (the
    /// forward scan) and fewer (the slot table), in `f64` and in `f32`
    /// storage, against the dense product of the same entries.
    #[test]
    fn product_values_match_dense_products_on_wide_and_narrow_rows() {
        let n = SLOT_WINDOW + 1000;
        // Y: entry k + 1 at (k, k) and 1 / 2 at (k, k + 100 mod n).
        let mut y = Bsr::<1>::empty(n, n);
        y.row_ptr.clear();
        y.row_ptr.push(0);
        for k in 0..n {
            let mut row = [(k, (k + 1) as f64), ((k + 100) % n, 0.5)];
            row.sort_by_key(|e| e.0);
            for (j, v) in row {
                y.col.push(j as u32);
                y.val.push([[v]]);
            }
            y.row_ptr.push(y.col.len());
        }
        // X: row 0 spans the whole width (columns 0 and n - 1), row 1 is narrow.
        let x = Bsr::<1> {
            nrows: 2,
            ncols: n,
            row_ptr: vec![0, 2, 4],
            col: vec![0, n as u32 - 1, 5, 10],
            val: vec![[[2.0]], [[-3.0]], [[1.5]], [[4.0]]],
        };
        let dense = |i: usize, j: usize| -> f64 {
            let yv = |k: usize| {
                let r = y.row(k);
                y.col[r.clone()]
                    .iter()
                    .zip(&y.val[r])
                    .find(|(c, _)| **c as usize == j)
                    .map_or(0.0, |(_, v)| v[0][0])
            };
            let r = x.row(i);
            x.col[r.clone()]
                .iter()
                .zip(&x.val[r])
                .map(|(&k, v)| v[0][0] * yv(k as usize))
                .sum()
        };
        let mut c64: Bsr<1> = product_pattern(&x, &y);
        let mut c32: Bsr<1, f32> = product_pattern(&x, &y);
        let spans: Vec<u32> = (0..2)
            .map(|i| c64.col[c64.row_ptr[i + 1] - 1] - c64.col[c64.row_ptr[i]])
            .collect();
        assert!(spans[0] as usize >= SLOT_WINDOW && (spans[1] as usize) < SLOT_WINDOW);
        product_values(&x, &y, &mut c64);
        product_values(&x, &y, &mut c32);
        for i in 0..2 {
            for s in c64.row(i) {
                let e = dense(i, c64.col[s] as usize);
                assert!(e != 0.0);
                assert_eq!(c64.val[s][0][0], e, "row {i}, column {}", c64.col[s]);
                assert_eq!(c32.val[s][0][0], e as f32, "row {i}, column {}", c64.col[s]);
            }
        }
    }

    #[test]
    fn product_and_transpose_match_dense_products() {
        // X: 3x2 block rows/cols of 2x2 blocks, Y: 2x3.
        let x = Bsr::<2> {
            nrows: 3,
            ncols: 2,
            row_ptr: vec![0, 1, 3, 4],
            col: vec![0, 0, 1, 1],
            val: vec![
                [[1.0, 2.0], [3.0, 4.0]],
                [[0.5, 0.0], [1.0, -1.0]],
                [[2.0, 1.0], [0.0, 1.0]],
                [[-1.0, 0.0], [0.0, 3.0]],
            ],
        };
        let (mut xt, map) = x.transpose_pattern();
        x.fill_transpose(&mut xt, &map);
        let mut c = product_pattern(&xt, &x);
        product_values(&xt, &x, &mut c);
        let dense = |m: &Bsr<2>| {
            let mut d = vec![vec![0.0; 2 * m.ncols]; 2 * m.nrows];
            for i in 0..m.nrows {
                for k in m.row(i) {
                    for r in 0..2 {
                        for s in 0..2 {
                            d[2 * i + r][2 * m.col[k] as usize + s] = m.val[k][r][s];
                        }
                    }
                }
            }
            d
        };
        let (dx, dc) = (dense(&x), dense(&c));
        for r in 0..4 {
            for s in 0..4 {
                let e: f64 = (0..6).map(|k| dx[k][r] * dx[k][s]).sum();
                assert!((dc[r][s] - e).abs() < 1e-14, "({r},{s})");
            }
        }
    }

    /// Marsaglia's xorshift64 from `seed`: numbers in [-1, 1) times
    /// 10^[-decades, decades).
    fn xorshift(mut seed: u64, decades: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
            let e = ((seed >> 3) % (2 * decades)) as i32 - decades as i32;
            (2.0 * u - 1.0) * 10f64.powi(e)
        }
    }

    /// An `n x n` block matrix of band half-width `half`, entries from `next`.
    fn banded(n: usize, half: usize, next: &mut impl FnMut() -> f64) -> Bsr<3, f32> {
        let mut a = Bsr::<3, f32>::empty(n, n);
        a.row_ptr.clear();
        a.row_ptr.push(0);
        for i in 0..n {
            for j in i.saturating_sub(half)..(i + half + 1).min(n) {
                a.col.push(j as u32);
                let mut blk = szero::<f32, 3, 3>();
                for row in &mut blk {
                    for v in row.iter_mut() {
                        *v = next() as f32;
                    }
                }
                a.val.push(blk);
            }
            a.row_ptr.push(a.col.len());
        }
        a
    }

    /// The dispatched kernels ([`par::kernel_rows`]: AVX2 where the CPU has
    /// it) give the bits of the same rows computed by a plain loop, which
    /// this test binary compiles for the x86-64 baseline (SSE2), and
    /// `b - A x` within round-off of a dense sum in another order. 3 000
    /// block rows of 13 f32 blocks (three rayon tasks and more), entries
    /// over eight decades, on 1, 2 and 3 threads.
    #[test]
    fn dispatched_residual_has_the_baseline_bits_on_any_thread_count() {
        let (n, half) = (3000usize, 6usize);
        // In [-1, 1) times 10^[-4, 4).
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15, 4);
        let a = banded(n, half, &mut next);
        let x: Vec<f64> = (0..3 * n).map(|_| next()).collect();
        let b: Vec<f64> = (0..3 * n).map(|_| next()).collect();
        // The baseline's bits: the same row kernel in a plain loop.
        let (x3, _) = x.as_chunks::<3>();
        let mut base = vec![0.0; 3 * n];
        for i in 0..n {
            let ax = a.row_times(i, x3);
            for c in 0..3 {
                base[3 * i + c] = b[3 * i + c] - ax[c];
            }
        }
        // b - A x summed block by block, entry by entry (another order).
        for i in (0..n).step_by(97) {
            for r in 0..3 {
                let (mut sum, mut scale) = (0.0_f64, 0.0_f64);
                for k in a.row(i) {
                    for c in 0..3 {
                        let t = f64::from(a.val[k][r][c]) * x[3 * a.col[k] as usize + c];
                        sum += t;
                        scale += t.abs();
                    }
                }
                let e = b[3 * i + r] - sum;
                assert!((base[3 * i + r] - e).abs() <= 1e-14 * (scale + e.abs()));
            }
        }
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (r, ax) = pool.install(|| {
                let mut r = vec![0.0; 3 * n];
                let mut ax = vec![0.0; 3 * n];
                a.residual(&b, &x, &mut r);
                a.spmv(&x, &mut ax);
                (r, ax)
            });
            assert!(r == base, "residual, {threads} threads");
            let ax_base: Vec<f64> = b.iter().zip(&base).map(|(b, r)| b - r).collect();
            for (i, (&v, &w)) in ax.iter().zip(&ax_base).enumerate() {
                // b - (b - A x) need not be A x exactly; A x's own bits:
                let e = a.row_times(i / 3, x3)[i % 3];
                assert!(v == e, "A x, {threads} threads, entry {i}");
                assert!((v - w).abs() <= 1e-12 * (1.0 + w.abs()));
            }
        }
    }

    /// The dispatched Galerkin products ([`par::kernel_row_slices_with`])
    /// give the bits of the same row kernel in a plain loop compiled for the
    /// baseline, for `A A` and the upper triangle of the symmetric `A^T A`,
    /// on 1, 2 and 3 threads (a banded f32 matrix of 2 500 block rows with
    /// entries over six decades).
    #[test]
    fn dispatched_products_have_the_baseline_bits_on_any_thread_count() {
        type RowFn<'k> = &'k dyn Fn(usize, &mut [SBlk<f32, 3>], &mut RowScratch<3, 3>);
        let (n, half) = (2500usize, 4usize);
        // In [-1, 1) times 10^[-3, 3).
        let a = banded(n, half, &mut xorshift(0x2545_f491_4f6c_dd1d, 3));
        let (mut at, map) = a.transpose_pattern();
        a.fill_transpose(&mut at, &map);
        let plain = |c: &mut Bsr<3, f32>, kernel: RowFn<'_>| {
            let mut scratch = RowScratch::new();
            for i in 0..c.nrows {
                let r = c.row(i);
                kernel(i, &mut c.val[r], &mut scratch);
            }
        };
        let pattern: Bsr<3, f32> = product_pattern(&a, &a);
        let mut base = pattern.pattern_as::<f32>();
        let (ptr, col) = (base.row_ptr.clone(), base.col.clone());
        let k = Product {
            x: &a,
            y: &a,
            row_ptr: &ptr,
            col: &col,
        };
        plain(&mut base, &|i, v, w| par::RowSliceKernel::row(&k, i, v, w));
        let sym_pattern: Bsr<3, f32> = product_pattern(&at, &a);
        let mut sym_base = sym_pattern.pattern_as::<f32>();
        let (sptr, scol) = (sym_base.row_ptr.clone(), sym_base.col.clone());
        let ks = SymmetricProduct(Product {
            x: &at,
            y: &a,
            row_ptr: &sptr,
            col: &scol,
        });
        plain(&mut sym_base, &|i, v, w| {
            par::RowSliceKernel::row(&ks, i, v, w)
        });
        let (_, mirror) = sym_base.transpose_pattern();
        let upper = |m: &Bsr<3, f32>| -> Vec<SBlk<f32, 3>> {
            (0..m.nrows)
                .flat_map(|i| m.row(i).filter(move |&s| m.col[s] as usize >= i))
                .map(|s| m.val[s])
                .collect()
        };
        assert!(base.val.iter().any(|b| b[0][0] != 0.0));
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (c, s) = pool.install(|| {
                let mut c = pattern.pattern_as::<f32>();
                product_values(&a, &a, &mut c);
                let mut s = sym_pattern.pattern_as::<f32>();
                product_values_symmetric(&at, &a, &mut s, &mirror);
                (c, s)
            });
            assert!(c.val == base.val, "A A, {threads} threads");
            assert!(upper(&s) == upper(&sym_base), "A^T A, {threads} threads");
        }
    }
}
