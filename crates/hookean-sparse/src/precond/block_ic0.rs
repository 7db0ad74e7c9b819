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

use std::sync::Arc;

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

/// The block factor: `values` has the layout of the matrix's value array;
/// the diagonal slot of row `i` holds `D_i^-1`, the other slots `W_ij`.
#[derive(Debug, Clone)]
pub(crate) struct BlockFactor {
    pattern: Arc<BlockPattern>,
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
    /// The symbolic factorisation of `pattern`: the fill-keeping updates.
    pub fn new(pattern: &Arc<BlockPattern>) -> Self {
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
            pattern: pattern.clone(),
            values: vec![block::ZERO; pattern.stored_blocks()],
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
        Arc::ptr_eq(&self.pattern, pattern)
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

    /// The numeric factorisation of `a + shift diag(a)` (the `shift` scales
    /// each scalar diagonal entry; a non-positive entry counts as 1, as in
    /// the unit-diagonal scaling of the scalar version), with the dropped
    /// fill compensated on the diagonal with weight `omega` (0: IC(0)).
    /// `Err(row)` at the first block pivot that is not positive definite.
    pub fn factor(&mut self, a: &SymBlockMatrix, shift: f64, omega: f64) -> Result<(), usize> {
        let n = self.n_blocks();
        let row_ptr = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        let src = a.values();
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
        self.forward(z, |i| r3[i]);
        self.backward(z, |_, _| {});
    }

    /// `r <- r - alpha q`, then `z = M^-1 r`; returns `(r . r, r . z)`.
    pub fn update_and_apply(
        &self,
        alpha: f64,
        q: &[f64],
        r: &mut [f64],
        z: &mut [f64],
    ) -> (f64, f64) {
        let (q3, _) = q.as_chunks::<3>();
        let (r3, _) = r.as_chunks_mut::<3>();
        let mut rr = 0.0;
        let mut rz = 0.0;
        self.forward(z, |i| {
            let ri = &mut r3[i];
            let qi = &q3[i];
            ri[0] -= alpha * qi[0];
            ri[1] -= alpha * qi[1];
            ri[2] -= alpha * qi[2];
            rr += ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2];
            *ri
        });
        self.backward(z, |i, zi| {
            let ri = &r3[i];
            rz += ri[0] * zi[0] + ri[1] * zi[1] + ri[2] * zi[2];
        });
        (rr, rz)
    }

    /// The forward sweep `(D + W^T) y = r`, with `r_i` supplied row by row
    /// by `residual(i)`, leaving `t = D y` in `z`: `z_j` first accumulates
    /// `sum_{k<j} W_kj^T y_k` (zeroed just ahead of the rows that scatter
    /// into it), then becomes `t_j = r_j - z_j`.
    #[inline(always)]
    fn forward(&self, z: &mut [f64], mut residual: impl FnMut(usize) -> [f64; 3]) {
        let n = self.n_blocks();
        let row_ptr = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        let vals = &self.values;
        let (z3, _) = z.as_chunks_mut::<3>();
        let z3 = &mut z3[..n];
        let mut zeroed = 0;
        for i in 0..n {
            let (start, end) = (row_ptr[i], row_ptr[i + 1]);
            let reach = if end > start + 1 {
                (cols[end - 1] as usize).max(i) + 1
            } else {
                i + 1
            };
            if reach > zeroed {
                z3[zeroed..reach].fill([0.0; 3]);
                zeroed = reach;
            }
            let ri = residual(i);
            let s = z3[i];
            let t = [ri[0] - s[0], ri[1] - s[1], ri[2] - s[2]];
            z3[i] = t;
            let y = block::mul_vec(&vals[start], &t);
            for (&j, w) in cols[start + 1..end].iter().zip(&vals[start + 1..end]) {
                let u = block::mul_transpose_vec(w, &y);
                let zj = &mut z3[j as usize];
                zj[0] += u[0];
                zj[1] += u[1];
                zj[2] += u[2];
            }
        }
    }

    /// The backward sweep `(D + W) z = t` (`t` in `z`), reporting each
    /// finished `z_i` to `done(i, z_i)`, in decreasing `i`.
    #[inline(always)]
    fn backward(&self, z: &mut [f64], mut done: impl FnMut(usize, [f64; 3])) {
        let n = self.n_blocks();
        let row_ptr = self.pattern.row_ptr();
        let cols = self.pattern.col_idx();
        let vals = &self.values;
        let (z3, _) = z.as_chunks_mut::<3>();
        let z3 = &mut z3[..n];
        for i in (0..n).rev() {
            let (start, end) = (row_ptr[i], row_ptr[i + 1]);
            let mut acc = z3[i];
            for (&j, w) in cols[start + 1..end].iter().zip(&vals[start + 1..end]) {
                let u = block::mul_vec(w, &z3[j as usize]);
                acc[0] -= u[0];
                acc[1] -= u[1];
                acc[2] -= u[2];
            }
            let zi = block::mul_vec(&vals[start], &acc);
            z3[i] = zi;
            done(i, zi);
        }
    }
}
