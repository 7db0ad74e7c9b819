//! IC(0) on 3x3 blocks: the factorisation behind
//! [`IncompleteCholesky`](super::IncompleteCholesky) for
//! [`SymBlockMatrix`] input.
//!
//! `A ~ (D + W)^T D^-1 (D + W)` with `D` block diagonal and `W` strictly
//! upper on the block pattern of `A`, i.e. `A ~ U^T D U` with the unit upper
//! factor `U = I + D^-1 W`. On a pattern whose blocks are dense this is the
//! same preconditioner as scalar IC(0) on the expanded pattern (fill between
//! two particles is kept exactly when their block is stored, whatever the
//! elimination order inside a block), but every product is a 3x3 block
//! kernel on the matrix's own layout: the factor is a copy of `A`'s value
//! array, refilled in place, and one application streams it twice (forward,
//! backward), about the work of one symmetric SpMV.
//!
//! With a relaxation `omega > 0` it is MIC(0), Gustafsson's modified
//! incomplete Cholesky: the fill that IC(0) drops is not thrown away but
//! (its symmetric part, times `omega`) subtracted from the two diagonal
//! blocks it would have coupled, so that `M` and `A` agree on the block row
//! sums (`omega = 1`): on the slowly varying vectors that the loads of a
//! cloth excite most (rigid translations lie in the null space of the
//! stiffness), `M^-1 A` is then close to the identity.

use std::ops::Range;
use std::sync::Arc;

use super::two_domain::TwoDomains;
use crate::block::{self, Block3};
use crate::matrix::{BlockPattern, SymBlockMatrix};

/// One fill-keeping update of the right-looking factorisation: when row `k`
/// is final, `W_ij -= W_ki^T D_k^-1 W_kj` for two stored blocks `(k, i)`,
/// `(k, j)` of row `k` with `i < j` whose block `(i, j)` is stored too.
#[derive(Debug, Clone, Copy)]
struct Update {
    ki: u32,
    kj: u32,
    ij: u32,
}

/// Fill dropped by IC(0) in row `k`: the positions (0 = first block after
/// the diagonal) of two blocks `(k, i)`, `(k, j)` of row `k` whose block
/// `(i, j)` is not stored (MIC(0) compensates on the diagonals of `i` and `j`).
#[derive(Debug, Clone, Copy)]
struct Dropped {
    a: u32,
    b: u32,
}

/// The block factor: `values` has the layout of the factor's pattern's
/// value array (the matrix's, or that of `P A P^T` in the two-domain order,
/// [`TwoDomains`]); the diagonal slot of row `i` holds `D_i^-1`, the other
/// slots `W_ij`.
#[derive(Debug, Clone)]
pub(crate) struct BlockFactor {
    /// The matrix's pattern.
    source: Arc<BlockPattern>,
    /// The factor's pattern: `source`, or `P A P^T`'s when `split` is set.
    pattern: Arc<BlockPattern>,
    split: Option<TwoDomains>,
    /// `P A P^T`'s values (with `split`), gathered by [`Self::load`].
    permuted: Vec<Block3>,
    values: Vec<Block3>,
    /// Updates of row `k`: `updates[update_ptr[k]..update_ptr[k + 1]]`.
    update_ptr: Vec<usize>,
    updates: Vec<Update>,
    /// Dropped fill of row `k`: `dropped[dropped_ptr[k]..dropped_ptr[k + 1]]`.
    dropped_ptr: Vec<usize>,
    dropped: Vec<Dropped>,
    /// `T_kj = D_k^-1 W_kj` of the row being eliminated (longest row).
    row_scratch: Vec<Block3>,
    /// MIC(0): `T_ki + omega sum T_kj` over the dropped partners `j` of `i`.
    row_sums: Vec<Block3>,
}

/// `a^T b`.
#[inline]
fn mul_tn(a: &Block3, b: &Block3) -> Block3 {
    let mut c = block::ZERO;
    for r in 0..3 {
        for col in 0..3 {
            c[r][col] = a[0][r] * b[0][col] + a[1][r] * b[1][col] + a[2][r] * b[2][col];
        }
    }
    c
}

/// `a b`.
#[inline]
fn mul_nn(a: &Block3, b: &Block3) -> Block3 {
    let mut c = block::ZERO;
    for r in 0..3 {
        for col in 0..3 {
            c[r][col] = a[r][0] * b[0][col] + a[r][1] * b[1][col] + a[r][2] * b[2][col];
        }
    }
    c
}

/// `a += s b`.
#[inline]
fn add_scaled_assign(a: &mut Block3, s: f64, b: &Block3) {
    for r in 0..3 {
        for c in 0..3 {
            a[r][c] += s * b[r][c];
        }
    }
}

#[inline]
fn sub_assign(a: &mut Block3, b: &Block3) {
    for r in 0..3 {
        for c in 0..3 {
            a[r][c] -= b[r][c];
        }
    }
}

/// The inverse of a symmetric 3x3 block if it is positive definite (its
/// leading minors are positive), else `None`.
fn spd_inverse(d: &Block3) -> Option<Block3> {
    let m1 = d[0][0];
    let m2 = d[0][0] * d[1][1] - d[0][1] * d[1][0];
    let m3 = block::determinant(d);
    if !(m1 > 0.0 && m2 > 0.0 && m3 > 0.0 && m3.is_finite()) {
        return None;
    }
    block::inverse(d)
}

impl BlockFactor {
    /// The symbolic factorisation of `source` (in the two-domain order when
    /// [`TwoDomains::of`] splits it): the fill-keeping updates.
    pub fn new(source: &Arc<BlockPattern>) -> Self {
        let split = TwoDomains::of(source);
        let pattern = split.as_ref().map_or(source, |s| s.pattern()).clone();
        let n = pattern.n_blocks();
        let row_ptr = pattern.row_ptr();
        let cols = pattern.col_idx();
        let mut update_ptr = Vec::with_capacity(n + 1);
        let mut updates = Vec::new();
        let mut longest = 0;
        update_ptr.push(0);
        let mut dropped_ptr = Vec::with_capacity(n + 1);
        let mut dropped = Vec::new();
        dropped_ptr.push(0);
        for k in 0..n {
            let row = row_ptr[k] + 1..row_ptr[k + 1];
            longest = longest.max(row.len());
            for a in row.clone() {
                let i = cols[a] as usize;
                for b in a + 1..row.end {
                    // Columns are sorted within a row, so i < j.
                    let j = cols[b] as usize;
                    let (s, e) = (row_ptr[i] + 1, row_ptr[i + 1]);
                    match cols[s..e].binary_search(&(j as u32)) {
                        Ok(p) => updates.push(Update {
                            ki: a as u32,
                            kj: b as u32,
                            ij: (s + p) as u32,
                        }),
                        Err(_) => dropped.push(Dropped {
                            a: (a - row.start) as u32,
                            b: (b - row.start) as u32,
                        }),
                    }
                }
            }
            update_ptr.push(updates.len());
            dropped_ptr.push(dropped.len());
        }
        Self {
            source: source.clone(),
            values: vec![block::ZERO; pattern.stored_blocks()],
            pattern,
            split,
            permuted: Vec::new(),
            update_ptr,
            updates,
            dropped_ptr,
            dropped,
            row_scratch: vec![block::ZERO; longest],
            row_sums: vec![block::ZERO; longest],
        }
    }

    /// True when this factor was built for `pattern`.
    pub fn is_for(&self, pattern: &Arc<BlockPattern>) -> bool {
        Arc::ptr_eq(&self.source, pattern)
    }

    /// The two-domain order, if the factor uses it: the factor's row `k` is
    /// the matrix's row `order[k]`.
    #[cfg(test)]
    pub fn order(&self) -> Option<Vec<usize>> {
        let split = self.split.as_ref()?;
        Some((0..self.n_blocks()).map(|k| split.old_row(k)).collect())
    }

    /// Block rows.
    pub fn n_blocks(&self) -> usize {
        self.pattern.n_blocks()
    }

    /// Number of scalar entries of the lower factor (9 per stored
    /// off-diagonal block, 6 per diagonal block), as in the scalar version.
    pub fn nnz(&self) -> usize {
        let n = self.n_blocks();
        9 * (self.pattern.stored_blocks() - n) + 6 * n
    }

    /// `a`'s values for the attempts of a shift search
    /// ([`Loaded::factor`]): in the two-domain order `P A P^T`, gathered here
    /// once per matrix rather than at every attempt.
    pub fn load<'a>(&'a mut self, a: &'a SymBlockMatrix) -> Loaded<'a> {
        if let Some(split) = &self.split {
            split.gather(a.values(), &mut self.permuted);
        }
        Loaded { factor: self, a }
    }

    /// [`Loaded::factor`] of the values `src` on the factor's pattern;
    /// `Err(row)` in the factor's numbering.
    fn factor_values(&mut self, src: &[Block3], shift: f64, omega: f64) -> Result<(), usize> {
        let n = self.n_blocks();
        let row_ptr = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        // Rows are copied from `a` (and shifted) just ahead of the first
        // row whose elimination touches them, inside this pass rather than
        // in a separate copy of the whole matrix.
        let mut copied = 0;
        for k in 0..n {
            let (start, end) = (row_ptr[k], row_ptr[k + 1]);
            let reach = if end > start + 1 {
                cols[end - 1] as usize + 1
            } else {
                k + 1
            };
            if reach > copied {
                let (from, to) = (row_ptr[copied], row_ptr[reach]);
                self.values[from..to].copy_from_slice(&src[from..to]);
                if shift != 0.0 {
                    for i in copied..reach {
                        let d = &mut self.values[row_ptr[i]];
                        for c in 0..3 {
                            let s = if d[c][c] > 0.0 { d[c][c] } else { 1.0 };
                            d[c][c] += shift * s;
                        }
                    }
                }
                copied = reach;
            }
            let dinv = spd_inverse(&self.values[start]).ok_or(k)?;
            self.values[start] = dinv;
            let m = end - start - 1;
            // T_kj = D_k^-1 W_kj.
            for (t, w) in self.row_scratch[..m]
                .iter_mut()
                .zip(&self.values[start + 1..end])
            {
                *t = mul_nn(&dinv, w);
            }
            // Diagonal updates D_j -= W_kj^T T_kj (symmetric). MIC(0) adds
            // the dropped fill W_ki^T T_kj at (i, j) and its transpose at
            // (j, i) to both diagonals, times omega, symmetrised; by
            // linearity one product per block: D_i -= sym(W_ki^T S_i),
            // S_i = T_ki + omega sum_{j dropped with i} T_kj.
            let sums = if omega != 0.0 {
                let sums = &mut self.row_sums[..m];
                sums.copy_from_slice(&self.row_scratch[..m]);
                for d in &self.dropped[self.dropped_ptr[k]..self.dropped_ptr[k + 1]] {
                    let (a, b) = (d.a as usize, d.b as usize);
                    add_scaled_assign(&mut sums[a], omega, &self.row_scratch[b]);
                    add_scaled_assign(&mut sums[b], omega, &self.row_scratch[a]);
                }
                &self.row_sums[..m]
            } else {
                &self.row_scratch[..m]
            };
            for (a, p) in (start + 1..end).enumerate() {
                let u = mul_tn(&self.values[p], &sums[a]);
                let d = &mut self.values[row_ptr[cols[p] as usize]];
                for r in 0..3 {
                    for c in 0..3 {
                        d[r][c] -= 0.5 * (u[r][c] + u[c][r]);
                    }
                }
            }
            // Fill that IC(0) keeps: W_ij -= W_ki^T T_kj.
            for up in &self.updates[self.update_ptr[k]..self.update_ptr[k + 1]] {
                let (ki, kj) = (up.ki as usize, up.kj as usize);
                let u = mul_tn(&self.values[ki], &self.row_scratch[kj - start - 1]);
                sub_assign(&mut self.values[up.ij as usize], &u);
            }
        }
        Ok(())
    }

    /// `z = M^-1 r`.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let (r3, _) = r.as_chunks::<3>();
        self.sweeps(&r3[..self.n_blocks()], z);
    }

    /// `r <- r - alpha q`, then `z = M^-1 r`; returns `(r . r, r . z)`.
    pub fn update_and_apply(
        &self,
        alpha: f64,
        q: &[f64],
        r: &mut [f64],
        z: &mut [f64],
    ) -> (f64, f64) {
        let n = self.n_blocks();
        let (q3, _) = q.as_chunks::<3>();
        let (r3, _) = r.as_chunks_mut::<3>();
        let q = &q3[..n];
        let r = &mut r3[..n];
        self.sweeps(Downdate { alpha, q, r }, z)
    }

    /// `z = M^-1 r` and `(r . r, r . z)` for the right side `rhs`: the
    /// forward and backward sweeps over the whole factor, or, in the
    /// two-domain order, over `A` and `B` side by side (two threads when the
    /// pool has them) and `S` alone. The sums are taken per domain and the
    /// domains' sums added in a fixed order.
    fn sweeps(&self, rhs: impl Rhs, z: &mut [f64]) -> (f64, f64) {
        let n = self.n_blocks();
        let (z3, _) = z.as_chunks_mut::<3>();
        let z3 = &mut z3[..n];
        let Some(split) = &self.split else {
            let mut rhs = rhs;
            let rr = self.forward::<false>(0..n, n, z3, &mut rhs);
            let rz = self.backward::<false>(0..n, n, z3, &[], &rhs);
            return (rr, rz);
        };
        // The matrix's numbering holds A | S | B, the factor's A | B
        // reversed | S: B's pieces of r and z are read backwards.
        let (m, w, b) = (split.m(), split.w(), split.b());
        let sep = m + b;
        let (za, zs, zb) = three(z3, m, w);
        let (mut ra, mut rs, mut rb) = rhs.three(m, w);
        let threaded = crate::par::parts_for(n) > 1;
        let (rra, rrb) = join(
            threaded,
            || self.forward::<false>(0..m, sep, za, &mut ra),
            || self.forward::<true>(m..sep, sep, zb, &mut rb),
        );
        let rrs = self.forward_separator(sep..n, za, zb, zs, &mut rs);
        let rzs = self.backward::<false>(sep..n, n, zs, &[], &rs);
        let (rza, rzb) = join(
            threaded,
            || self.backward::<false>(0..m, sep, za, zs, &ra),
            || self.backward::<true>(m..sep, sep, zb, zs, &rb),
        );
        (rra + rrb + rrs, rzs + rza + rzb)
    }

    /// The forward sweep `(D + W^T) y = r` over the factor's rows `rows`,
    /// leaving `t = D y` in `own` (row `i` at `own[at(i)]`, `at(i) = i -
    /// rows.start`, or counted from the end with `REV`), with `r_i` from
    /// `rhs` (row `at(i)`); returns `sum r_i . r_i`. Each row scatters `W_ij^T y_i` into the
    /// later rows `j` it couples to (`own[j]` first accumulates
    /// `sum_{i<j} W_ij^T y_i`, then becomes `t_j = r_j - own[j]`), except to
    /// rows `j >= sep` (the separator, which gathers them itself).
    #[inline(always)]
    fn forward<const REV: bool>(
        &self,
        rows: Range<usize>,
        sep: usize,
        own: &mut [[f64; 3]],
        rhs: &mut impl Rhs,
    ) -> f64 {
        let row_ptr = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        let vals = &self.values;
        let at = local::<REV>(rows.clone());
        own.fill([0.0; 3]);
        let mut sum = 0.0;
        for i in rows {
            let (start, end) = (row_ptr[i], row_ptr[i + 1]);
            let (ri, s2) = rhs.take(at(i));
            sum += s2;
            let s = own[at(i)];
            let t = [ri[0] - s[0], ri[1] - s[1], ri[2] - s[2]];
            own[at(i)] = t;
            let y = block::mul_vec(&vals[start], &t);
            for (&j, w) in cols[start + 1..end].iter().zip(&vals[start + 1..end]) {
                let j = j as usize;
                if j >= sep {
                    break;
                }
                let u = block::mul_transpose_vec(w, &y);
                let zj = &mut own[at(j)];
                zj[0] += u[0];
                zj[1] += u[1];
                zj[2] += u[2];
            }
        }
        sum
    }

    /// The forward sweep over the separator's rows `rows` (the factor's last
    /// rows), each gathering `sum_{k<j} W_kj^T y_k` through the transposed
    /// index, in increasing `k` as [`Self::forward`] scatters them, with
    /// `y_k = D_k^-1 t_k` from the domains' `t` (`za`: rows `0..`, `zb`:
    /// the rows after, backwards, `zs`: the separator).
    fn forward_separator(
        &self,
        rows: Range<usize>,
        za: &[[f64; 3]],
        zb: &[[f64; 3]],
        zs: &mut [[f64; 3]],
        rhs: &mut impl Rhs,
    ) -> f64 {
        let row_ptr = self.pattern.row_ptr();
        let lower = self.pattern.lower();
        let vals = &self.values;
        let (m, sep) = (za.len(), rows.start);
        let mut sum = 0.0;
        for j in rows {
            let mut acc = [0.0; 3];
            for p in lower.ptr[j]..lower.ptr[j + 1] {
                let k = lower.row[p] as usize;
                let tk = if k < m {
                    za[k]
                } else if k < sep {
                    zb[sep - 1 - k]
                } else {
                    zs[k - sep]
                };
                let y = block::mul_vec(&vals[row_ptr[k]], &tk);
                let u = block::mul_transpose_vec(&vals[lower.slot[p]], &y);
                acc[0] += u[0];
                acc[1] += u[1];
                acc[2] += u[2];
            }
            let (rj, s2) = rhs.take(j - sep);
            sum += s2;
            zs[j - sep] = [rj[0] - acc[0], rj[1] - acc[1], rj[2] - acc[2]];
        }
        sum
    }

    /// The backward sweep `(D + W) z = t` over the factor's rows `rows`, in
    /// decreasing order, `t` and then `z` in `own` (row `i` at `own[at(i)]`,
    /// as in [`Self::forward`]); rows `j >= sep` are read from
    /// `separator[j - sep]`. Returns `sum_i r_i . z_i`.
    #[inline(always)]
    fn backward<const REV: bool>(
        &self,
        rows: Range<usize>,
        sep: usize,
        own: &mut [[f64; 3]],
        separator: &[[f64; 3]],
        rhs: &impl Rhs,
    ) -> f64 {
        let row_ptr = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        let vals = &self.values;
        let at = local::<REV>(rows.clone());
        let mut rz = 0.0;
        for i in rows.rev() {
            let (start, end) = (row_ptr[i], row_ptr[i + 1]);
            let mut acc = own[at(i)];
            for (&j, w) in cols[start + 1..end].iter().zip(&vals[start + 1..end]) {
                let j = j as usize;
                let zj = if j >= sep {
                    &separator[j - sep]
                } else {
                    &own[at(j)]
                };
                let u = block::mul_vec(w, zj);
                acc[0] -= u[0];
                acc[1] -= u[1];
                acc[2] -= u[2];
            }
            let zi = block::mul_vec(&vals[start], &acc);
            own[at(i)] = zi;
            let ri = rhs.get(at(i));
            rz += ri[0] * zi[0] + ri[1] * zi[1] + ri[2] * zi[2];
        }
        rz
    }
}

/// A factor with a matrix's values taken ([`BlockFactor::load`]), ready
/// for the numeric factorisation at any shift.
pub(crate) struct Loaded<'a> {
    factor: &'a mut BlockFactor,
    a: &'a SymBlockMatrix,
}

impl Loaded<'_> {
    /// The numeric factorisation of `a + shift diag(a)` (the `shift` scales
    /// each scalar diagonal entry; a non-positive entry counts as 1, as in
    /// the unit-diagonal scaling of the scalar version), with the dropped
    /// fill compensated on the diagonal with weight `omega` (0: IC(0)).
    /// `Err(row)` at the first block pivot that is not positive definite
    /// (the matrix's row number).
    pub fn factor(&mut self, shift: f64, omega: f64) -> Result<(), usize> {
        let f = &mut *self.factor;
        let permuted = std::mem::take(&mut f.permuted);
        let src = match &f.split {
            Some(_) => &permuted[..],
            None => self.a.values(),
        };
        let result = f.factor_values(src, shift, omega);
        f.permuted = permuted;
        result.map_err(|row| f.split.as_ref().map_or(row, |s| s.old_row(row)))
    }
}

/// The right side of the sweeps, row by row: `r` itself
/// ([`BlockFactor::apply`]) or `r - alpha q`, updated in place
/// ([`BlockFactor::update_and_apply`]).
trait Rhs: Send + Sync + Sized {
    /// This right side cut into rows `..m`, `m..m + w` and the rest.
    fn three(self, m: usize, w: usize) -> (Self, Self, Self);
    /// `r_i` for the forward sweep, and `r_i . r_i`.
    fn take(&mut self, i: usize) -> ([f64; 3], f64);
    /// `r_i` (after [`Rhs::take`]).
    fn get(&self, i: usize) -> [f64; 3];
}

impl Rhs for &[[f64; 3]] {
    fn three(self, m: usize, w: usize) -> (Self, Self, Self) {
        (&self[..m], &self[m..m + w], &self[m + w..])
    }

    #[inline(always)]
    fn take(&mut self, i: usize) -> ([f64; 3], f64) {
        // The sums of `apply` are not used.
        (self[i], 0.0)
    }

    #[inline(always)]
    fn get(&self, i: usize) -> [f64; 3] {
        self[i]
    }
}

/// `r <- r - alpha q`, row by row as the forward sweep reaches it.
struct Downdate<'a> {
    alpha: f64,
    q: &'a [[f64; 3]],
    r: &'a mut [[f64; 3]],
}

impl Rhs for Downdate<'_> {
    fn three(self, m: usize, w: usize) -> (Self, Self, Self) {
        let alpha = self.alpha;
        let (qa, qs, qb) = (&self.q[..m], &self.q[m..m + w], &self.q[m + w..]);
        let (ra, rs, rb) = three(self.r, m, w);
        (
            Downdate {
                alpha,
                q: qa,
                r: ra,
            },
            Downdate {
                alpha,
                q: qs,
                r: rs,
            },
            Downdate {
                alpha,
                q: qb,
                r: rb,
            },
        )
    }

    #[inline(always)]
    fn take(&mut self, i: usize) -> ([f64; 3], f64) {
        let ri = &mut self.r[i];
        let qi = &self.q[i];
        ri[0] -= self.alpha * qi[0];
        ri[1] -= self.alpha * qi[1];
        ri[2] -= self.alpha * qi[2];
        (*ri, ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2])
    }

    #[inline(always)]
    fn get(&self, i: usize) -> [f64; 3] {
        self.r[i]
    }
}

/// The position of the factor's row `i` in a domain's pieces of `r` and
/// `z`: `i - rows.start`, or `rows.end - 1 - i` with `REV`.
#[inline(always)]
fn local<const REV: bool>(rows: Range<usize>) -> impl Fn(usize) -> usize + Copy {
    let (start, end) = (rows.start, rows.end);
    move |i| if REV { end - 1 - i } else { i - start }
}

/// `x` cut into `..m`, `m..m + w` and the rest.
fn three<T>(x: &mut [T], m: usize, w: usize) -> (&mut [T], &mut [T], &mut [T]) {
    let (a, rest) = x.split_at_mut(m);
    let (s, b) = rest.split_at_mut(w);
    (a, s, b)
}

/// `(f(), g())`, on two threads when `threaded`.
fn join<A: Send, B: Send>(
    threaded: bool,
    f: impl FnOnce() -> A + Send,
    g: impl FnOnce() -> B + Send,
) -> (A, B) {
    if threaded {
        rayon::join(f, g)
    } else {
        (f(), g())
    }
}
