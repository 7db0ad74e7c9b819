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
//!
//! With more than one rayon thread the product splits the rows into one part
//! per thread as the block matrix does ([`par`](crate::par)): a part writes
//! only its own rows, scattering the transposed entries only to rows inside
//! it, and gathers what earlier rows add to its rows through the transposed
//! index ([`LowerIndex`]). Every `y_j` sums the same terms in the same order
//! as the serial product, so `y` has the serial bits for every thread count;
//! `x . y` is summed per part and added in a fixed tree.

use crate::error::SparseError;
use crate::operator::LinearOperator;
use crate::par::LowerIndex;

/// A symmetric `n x n` matrix as its diagonal and strict upper triangle
/// in CSR (`u32` column indices, increasing in each row).
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
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SymCsrMatrix {
    /// `a_ii` (zero where the input stores none).
    pub(crate) diag: Vec<f64>,
    /// Row `i`'s entries right of the diagonal: `row_ptr[i]..row_ptr[i + 1]`
    /// (`u32`, as the columns: 4 bytes a row less to stream).
    pub(crate) row_ptr: Vec<u32>,
    pub(crate) col: Vec<u32>,
    pub(crate) val: Vec<f64>,
    /// The transposed index of the upper triangle, for the threaded
    /// product (built by [`from_csr`](Self::from_csr); empty in the copies
    /// SSOR refills, whose products are not used).
    pub(crate) lower: LowerIndex,
    /// `reach[s]`: one past the farthest column stored in the rows before
    /// `s` (at least `s`), so rows `s..reach[s]` are the only rows that rows
    /// before `s` add to.
    pub(crate) reach: Vec<u32>,
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
    /// `u32::MAX` rows or entries above the diagonal.
    pub fn from_csr(a: &sprs::CsMat<f64>) -> Result<Self, SparseError> {
        crate::precond::square_dim(a)?;
        crate::matrix::check_csr_symmetric(a)?;
        let mut s = Self::default();
        s.refill_upper(a)?;
        s.lower = LowerIndex::of_upper(&s.row_ptr, &s.col, 0);
        let mut far = 0u32;
        let reach = std::iter::once(0)
            .chain((0..s.dim()).map(|i| {
                let (cols, _) = s.upper_row(i);
                far = far.max(cols.last().map_or(0, |&j| j + 1));
                far.max(i as u32 + 1)
            }))
            .collect();
        s.reach = reach;
        Ok(s)
    }

    /// Refills `self` with the diagonal and upper triangle of `a`, reusing
    /// the storage (no allocation once it is large enough). Symmetry is the
    /// caller's to check: the lower triangle is not read.
    ///
    /// # Errors
    /// [`SparseError::NotSquare`], [`SparseError::InvalidParameter`] above
    /// `u32::MAX` rows or entries above the diagonal.
    pub(crate) fn refill_upper(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let n = crate::precond::square_dim(a)?;
        if n > u32::MAX as usize {
            return Err(SparseError::InvalidParameter {
                name: "matrix",
                message: format!("{n} rows exceed the u32 index range"),
            });
        }
        let csr = crate::precond::as_csr(a);
        let indptr = csr.proper_indptr();
        let (indices, data) = (csr.indices(), csr.data());
        self.diag.clear();
        self.row_ptr.clear();
        self.col.clear();
        self.val.clear();
        self.row_ptr.push(0);
        for (i, w) in indptr.windows(2).enumerate() {
            let (cols, vals) = (&indices[w[0]..w[1]], &data[w[0]..w[1]]);
            let mut diag = 0.0;
            for (&j, &v) in cols.iter().zip(vals) {
                if j == i {
                    diag = v;
                } else if j > i {
                    self.col.push(j as u32);
                    self.val.push(v);
                }
            }
            self.diag.push(diag);
            self.row_ptr
                .push(u32::try_from(self.col.len()).map_err(|_| {
                    SparseError::InvalidParameter {
                        name: "matrix",
                        message: format!(
                            "more than {} entries above the diagonal exceed the u32 index range",
                            u32::MAX
                        ),
                    }
                })?);
        }
        Ok(())
    }

    /// The dimension `n`.
    pub fn dim(&self) -> usize {
        self.diag.len()
    }

    /// Entries stored (the diagonal and the upper triangle).
    pub fn stored(&self) -> usize {
        self.diag.len() + self.val.len()
    }

    /// Row `i`'s columns and values right of the diagonal.
    #[inline(always)]
    pub(crate) fn upper_row(&self, i: usize) -> (&[u32], &[f64]) {
        let (s, e) = (self.row_ptr[i] as usize, self.row_ptr[i + 1] as usize);
        (&self.col[s..e], &self.val[s..e])
    }
}

/// `sum_j a_ij p_j` over one row's upper entries, adding `a_ij p_i` to
/// `y_j` (the transposed entry's share of row `j`), with `BELOW` only for
/// `j < e` (a part's last rows, whose entries reach rows of later parts).
/// `p` and `y` hold entries `s..`: a row `i >= s` reads no column before
/// `s`, and slices of one length share their bounds check. Two partial sums, so the adds do not wait on
/// each other's latency.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn row_gather_scatter<const BELOW: bool>(
    cols: &[u32],
    vals: &[f64],
    pi: f64,
    p: &[f64],
    y: &mut [f64],
    s: usize,
    e: usize,
) -> f64 {
    let (c2, c1) = cols.as_chunks::<2>();
    let (v2, v1) = vals.as_chunks::<2>();
    let (mut s0, mut s1) = (0.0, 0.0);
    for (c, v) in c2.iter().zip(v2) {
        let (j0, j1) = (c[0] as usize, c[1] as usize);
        s0 += v[0] * p[j0 - s];
        if !BELOW || j0 < e {
            y[j0 - s] += v[0] * pi;
        }
        s1 += v[1] * p[j1 - s];
        if !BELOW || j1 < e {
            y[j1 - s] += v[1] * pi;
        }
    }
    for (&j, &v) in c1.iter().zip(v1) {
        let j = j as usize;
        s0 += v * p[j - s];
        if !BELOW || j < e {
            y[j - s] += v * pi;
        }
    }
    s0 + s1
}

/// `sum_j a_ij z_j` over one row's upper entries, in two partial sums.
#[inline(always)]
pub(crate) fn row_dot(cols: &[u32], vals: &[f64], z: &[f64]) -> f64 {
    let (c2, c1) = cols.as_chunks::<2>();
    let (v2, v1) = vals.as_chunks::<2>();
    let (mut s0, mut s1) = (0.0, 0.0);
    for (c, v) in c2.iter().zip(v2) {
        s0 += v[0] * z[c[0] as usize];
        s1 += v[1] * z[c[1] as usize];
    }
    for (&j, &v) in c1.iter().zip(v1) {
        s0 += v * z[j as usize];
    }
    s0 + s1
}

impl SymCsrMatrix {
    /// The number of parts the product splits into: one per thread of the
    /// current pool for a large matrix with its transposed index, else 1.
    fn parts(&self) -> usize {
        if self.lower.ptr.is_empty() {
            1
        } else {
            crate::par::parts_for(self.dim() / 3)
        }
    }

    /// Rows `s..s + y.len()` of `y = A x`, writing only those rows; returns
    /// their share of `x . A x`, `sum_i x_i (a_ii x_i + 2 sum_{j>i} a_ij
    /// x_j)`, from the stored entries.
    ///
    /// Rows go in decreasing order: row `i` assigns `y_i` from its own
    /// entries after the rows `j > i` of the part, then adds `a_ij x_i` to
    /// the part's `y_j`; last, the rows before `s` add theirs, gathered
    /// through the transposed index in decreasing row order. That is the
    /// serial product's order of the terms of every `y_j`. Inlined, so the
    /// serial call (`s = 0`, `y` as long as `x`) compiles to the plain loop.
    #[inline(always)]
    fn product_rows(&self, x: &[f64], y: &mut [f64], s: usize) -> f64 {
        let (e, n) = (s + y.len(), x.len());
        // x from row s on: to the part's end for rows that reach no later
        // part (the length of y), to n for the others.
        let (x_part, x_on) = (&x[s..e], &x[s..]);
        let mut dot = 0.0;
        for i in (s..e).rev() {
            let (cols, vals) = self.upper_row(i);
            let (xi, d) = (x[i], self.diag[i]);
            let off = if e == n || cols.last().is_none_or(|&j| (j as usize) < e) {
                row_gather_scatter::<false>(cols, vals, xi, x_part, y, s, e)
            } else {
                row_gather_scatter::<true>(cols, vals, xi, x_on, y, s, e)
            };
            y[i - s] = d * xi + off;
            dot += xi * (d * xi + 2.0 * off);
        }
        if s > 0 {
            let l = &self.lower;
            for j in s..(self.reach[s] as usize).min(e) {
                let (k0, k1) = (l.ptr[j], l.ptr[j + 1]);
                let before = l.row[k0..k1].partition_point(|&i| (i as usize) < s);
                let mut yj = y[j - s];
                for k in (k0..k0 + before).rev() {
                    yj += self.val[l.slot[k]] * x[l.row[k] as usize];
                }
                y[j - s] = yj;
            }
        }
        dot
    }
}

impl LinearOperator for SymCsrMatrix {
    fn nrows(&self) -> usize {
        self.dim()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.apply_dot(x, y);
    }

    /// `y = A x` and `x . A x` in one pass over the matrix, threaded for a
    /// large matrix (see `product_rows`).
    fn apply_dot(&self, x: &[f64], y: &mut [f64]) -> f64 {
        let n = self.dim();
        let (x, y) = (&x[..n], &mut y[..n]);
        match self.parts() {
            1 => self.product_rows(x, y, 0),
            parts => {
                let start = |t| crate::par::part_start(&self.row_ptr, t, parts);
                crate::par::join_parts(
                    y,
                    parts,
                    &start,
                    &|t, y| self.product_rows(x, y, start(t)),
                    &|a, b| a + b,
                )
            }
        }
    }

    /// CG's `x += alpha p`, `p = z + beta p`, `q = A p` and `p . q` in one
    /// pass over the matrix and the vectors, rows in decreasing order:
    /// row `i`'s neighbours `j > i` hold their new `p_j` already. Threaded,
    /// the updates and the product are two passes (a part's rows need the
    /// new `p` of later parts), with the same `x`, `p` and `q`.
    fn update_and_apply_dot(
        &self,
        z: &[f64],
        beta: f64,
        alpha: f64,
        x: &mut [f64],
        p: &mut [f64],
        q: &mut [f64],
    ) -> f64 {
        let n = self.dim();
        let (z, x, p, q) = (&z[..n], &mut x[..n], &mut p[..n], &mut q[..n]);
        if self.parts() > 1 {
            crate::vecops::update_x_p(z, beta, alpha, x, p);
            return self.apply_dot(p, q);
        }
        let mut dot = 0.0;
        for i in (0..n).rev() {
            let (cols, vals) = self.upper_row(i);
            x[i] += alpha * p[i];
            let pi = z[i] + beta * p[i];
            p[i] = pi;
            let d = self.diag[i];
            let off = row_gather_scatter::<false>(cols, vals, pi, p, q, 0, n);
            q[i] = d * pi + off;
            dot += pi * (d * pi + 2.0 * off);
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

    /// Threaded, the product and the fused update give the serial bits of
    /// `y` (and of `x`, `p`) for 2 and 3 threads, and `x . y` to round-off;
    /// the random columns reach across every part boundary.
    #[test]
    fn threaded_products_give_the_serial_bits() {
        let n = 3 * crate::par::MIN_PARALLEL_BLOCKS * 2 + 11;
        let a = random_symmetric(n, 5);
        let s = SymCsrMatrix::from_csr(&a).unwrap();
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin()).collect();
        let z: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let run = |threads: usize| {
            crate::par::in_pool(threads, || {
                let mut y = vec![f64::NAN; n];
                let dot = s.apply_dot(&x, &mut y);
                let (mut x1, mut p1, mut q1) = (x.clone(), z.clone(), vec![f64::NAN; n]);
                let pq = s.update_and_apply_dot(&z, 0.7, 0.3, &mut x1, &mut p1, &mut q1);
                (y, dot, x1, p1, q1, pq)
            })
        };
        let serial = run(1);
        let mut y_ref = vec![0.0; n];
        a.apply(&x, &mut y_ref);
        for (u, v) in serial.0.iter().zip(&y_ref) {
            assert!((u - v).abs() < 1e-12, "{u} {v}");
        }
        for threads in [2, 3] {
            let t = run(threads);
            assert_eq!(t.0, serial.0, "{threads} threads");
            assert!((t.1 - serial.1).abs() < 1e-10 * serial.1.abs());
            assert_eq!((&t.2, &t.3, &t.4), (&serial.2, &serial.3, &serial.4));
            assert!((t.5 - serial.5).abs() < 1e-10 * serial.5.abs());
            assert_eq!(t.1.to_bits(), run(threads).1.to_bits());
        }
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
