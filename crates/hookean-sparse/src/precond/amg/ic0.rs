//! Block IC(0) (the symmetric block ILU(0)) of one multigrid level, the
//! smoother [`AmgSmoother::BlockIc0`](super::AmgSmoother::BlockIc0).
//!
//! `A ~ M = (D + W)^T D^-1 (D + W)` with `D` block diagonal and `W` strictly
//! upper on the block pattern of `A` (no fill), by the right-looking
//! elimination `X_ij -= W_ki^T D_k^-1 W_kj` restricted to stored blocks
//! `(i, j)` (Meijerink, van der Vorst 1977, in block form as Concus, Golub,
//! Meurant 1985). The same factorisation as
//! [`IncompleteCholesky`](crate::IncompleteCholesky) on a
//! [`SymBlockMatrix`](crate::SymBlockMatrix), here on the full block CSR
//! storage of a level and for any block size (the coarse levels of scalar
//! and 2-dof systems). `D_k^-1` is the inverse of the symmetrised block, so
//! `M` is symmetric and the V-cycle with it stays symmetric.

use super::bsr::{
    Blk, Bsr, Entry, load, mul_add, mul_mat_add, mul_vec, spd_inverse, transpose, zero,
};
use crate::error::SparseError;

/// One update of the elimination of row `k`: `X_ij -= W_ki^T (D_k^-1 W_kj)`,
/// as slots of the level's block array (`ij` is the diagonal slot when `i == j`).
#[derive(Debug, Clone, Copy)]
struct Update {
    ki: u32,
    kj: u32,
    ij: u32,
}

/// The factor in the layout of the level's block array: the diagonal slot
/// of row `i` holds `D_i^-1`, the slots right of it `W_ij`, the slots left
/// of it `W_ji^T` (so both triangular solves run row by row, gathering).
#[derive(Debug, Clone)]
pub(crate) struct BlockIc0<const B: usize> {
    values: Vec<Blk<B>>,
    /// For every slot left of a diagonal, `(lower slot, its mirror right of the diagonal)`.
    mirror: Vec<(u32, u32)>,
    /// Updates of row `k`: `updates[update_ptr[k]..update_ptr[k + 1]]`.
    update_ptr: Vec<usize>,
    updates: Vec<Update>,
    /// `D_k^-1 W_kj` of the row being eliminated (longest upper row).
    scratch: Vec<Blk<B>>,
}

impl<const B: usize> BlockIc0<B> {
    /// The symbolic factorisation: every update that keeps to the pattern.
    pub fn new<S: Entry>(a: &Bsr<B, S>, diag: &[usize]) -> Self {
        let mut update_ptr = Vec::with_capacity(a.nrows + 1);
        let mut updates = Vec::new();
        let mut longest = 0;
        update_ptr.push(0);
        for k in 0..a.nrows {
            let upper = diag[k] + 1..a.row_ptr[k + 1];
            longest = longest.max(upper.len());
            for p in upper.clone() {
                let i = a.col[p] as usize;
                let row_i = &a.col[diag[i]..a.row_ptr[i + 1]];
                for q in p..upper.end {
                    if let Ok(s) = row_i.binary_search(&a.col[q]) {
                        updates.push(Update {
                            ki: p as u32,
                            kj: q as u32,
                            ij: (diag[i] + s) as u32,
                        });
                    }
                }
            }
            update_ptr.push(updates.len());
        }
        let mut mirror = Vec::with_capacity(a.nnz_blocks() / 2);
        for i in 0..a.nrows {
            for p in a.row_ptr[i]..diag[i] {
                let k = a.col[p] as usize;
                let upper = &a.col[diag[k]..a.row_ptr[k + 1]];
                let s = upper
                    .binary_search(&(i as u32))
                    .expect("a full-storage pattern is symmetric");
                mirror.push((p as u32, (diag[k] + s) as u32));
            }
        }
        Self {
            values: vec![zero::<B, B>(); a.nnz_blocks()],
            mirror,
            update_ptr,
            updates,
            scratch: vec![zero::<B, B>(); longest],
        }
    }

    /// The numeric factorisation of `a` (no allocation).
    ///
    /// # Errors
    /// [`SparseError::AmgNotPositiveDefinite`] at the first pivot block
    /// whose symmetric part is not positive definite.
    pub fn factor<S: Entry>(
        &mut self,
        a: &Bsr<B, S>,
        diag: &[usize],
        level: usize,
    ) -> Result<(), SparseError> {
        for (v, s) in self.values.iter_mut().zip(&a.val) {
            *v = load(s);
        }
        for k in 0..a.nrows {
            let d = diag[k];
            let inv = spd_inverse(&self.values[d]).ok_or(SparseError::AmgNotPositiveDefinite {
                level,
                row: B * k,
                what: "block IC(0) pivot",
            })?;
            self.values[d] = inv;
            let end = a.row_ptr[k + 1];
            for (s, w) in self.scratch.iter_mut().zip(&self.values[d + 1..end]) {
                *s = zero::<B, B>();
                mul_mat_add(&inv, w, s);
            }
            for u in &self.updates[self.update_ptr[k]..self.update_ptr[k + 1]] {
                let wt = transpose(&self.values[u.ki as usize]);
                let mut prod = zero::<B, B>();
                mul_mat_add(&wt, &self.scratch[u.kj as usize - d - 1], &mut prod);
                let x = &mut self.values[u.ij as usize];
                for r in 0..B {
                    for c in 0..B {
                        x[r][c] -= prod[r][c];
                    }
                }
            }
        }
        for &(lower, upper) in &self.mirror {
            self.values[lower as usize] = transpose(&self.values[upper as usize]);
        }
        Ok(())
    }

    /// `z = M^-1 z` in place: the forward solve with `(D + W)^T`
    /// (`z_i = D_i^-1 (z_i - sum_{k < i} W_ki^T z_k)`), then the backward
    /// solve with `D^-1 (D + W)` (`z_i -= D_i^-1 sum_{j > i} W_ij z_j`).
    pub fn solve_in_place<S: Entry>(&self, a: &Bsr<B, S>, diag: &[usize], z: &mut [f64]) {
        let (z3, _) = z.as_chunks_mut::<B>();
        let v = &self.values;
        for i in 0..a.nrows {
            let d = diag[i];
            let mut s = z3[i];
            for (&k, w) in a.col[a.row_ptr[i]..d].iter().zip(&v[a.row_ptr[i]..d]) {
                let zk = z3[k as usize];
                for r in 0..B {
                    for c in 0..B {
                        s[r] -= w[r][c] * zk[c];
                    }
                }
            }
            z3[i] = mul_vec(&v[d], &s);
        }
        for i in (0..a.nrows).rev() {
            let d = diag[i];
            let end = a.row_ptr[i + 1];
            let mut acc = [0.0; B];
            for (&j, w) in a.col[d + 1..end].iter().zip(&v[d + 1..end]) {
                mul_add(w, &z3[j as usize], &mut acc);
            }
            let y = mul_vec(&v[d], &acc);
            for c in 0..B {
                z3[i][c] -= y[c];
            }
        }
    }
}
