//! The smoothed prolongator `P = (I - omega D_F^-1 A_F) T` of smoothed
//! aggregation (Vaněk, Mandel, Brezina 1996), with the filtered
//! matrix `A_F` read from `A` row by row (its strong blocks, the weak ones
//! lumped onto the diagonal) and never stored.

use super::super::bsr::{
    Blk, Bsr, Entry, SBlk, load, mul_add, mul_mat_add, smul_add, spd_inverse, store, szero, zero,
};
use super::super::par;
use super::{Transfer, Work, gershgorin_row, spectral_radius};
use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::SparseError;

/// The diagonal block of row `i` of `A_F`: `A_ii` plus the weak blocks of the row.
#[inline(always)]
fn lumped_diagonal<const B: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    strong: &[bool],
    i: usize,
) -> Blk<B> {
    let mut d = load(&a.val[diag[i]]);
    for k in a.row(i) {
        if k != diag[i] && !strong[k] {
            let w = load(&a.val[k]);
            for r in 0..B {
                for c in 0..B {
                    d[r][c] += w[r][c];
                }
            }
        }
    }
    d
}

/// `sum_j (A_F)_ij x_j` from the rows of `A` (`d` the lumped diagonal block of row `i`).
#[inline(always)]
fn filtered_row_times<const B: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    strong: &[bool],
    d: &Blk<B>,
    i: usize,
    x: &[[f64; B]],
) -> [f64; B] {
    let mut acc = [0.0; B];
    for k in a.row(i) {
        if k == diag[i] {
            mul_add(d, &x[i], &mut acc);
        } else if strong[k] {
            smul_add(&a.val[k], &x[a.col[k] as usize], &mut acc);
        }
    }
    acc
}

/// `D_F^-1`, `omega` (from `unfiltered_rho` when given: the smoother's
/// estimate of `rho(D^-1 A)` on a level without weak blocks) and
/// `P = (I - omega D_F^-1 A_F) T`, `R = P^T`, with
/// `A_F` read from `A` row by row (its strong blocks, and the weak ones
/// lumped onto the diagonal).
#[allow(clippy::too_many_arguments)]
pub(super) fn smooth_prolongator<const B: usize, const K: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    a_dinv: &[SBlk<S, B>],
    tr: &mut Transfer<B, K, S>,
    prolongation_weight: f64,
    iterations: Option<usize>,
    unfiltered_rho: Option<f64>,
    refill: bool,
    work: &mut Work,
) -> Result<(), SparseError> {
    // D_F^-1; where lumping made a diagonal block indefinite (a matrix that
    // is not an M-matrix, e.g. a scalar elasticity operator with positive
    // off-diagonal entries), D^-1 of A instead: any SPD scaling smooths T.
    let strong = &tr.strong;
    par::rows(&mut tr.df_inv, &|i, inv: &mut Blk<B>| {
        *inv =
            spd_inverse(&lumped_diagonal(a, diag, strong, i)).unwrap_or_else(|| load(&a_dinv[i]));
    });
    if let Some(iterations) = iterations {
        let df_inv = &tr.df_inv;
        // Without weak blocks `D_F^-1 A_F` is the smoother's `D^-1 A`
        // (its `D^-1` only rounded to the storage): its estimate serves.
        let rho = if let Some(rho) = unfiltered_rho {
            rho
        } else {
            spectral_radius(
                a.nrows,
                |i, x| {
                    filtered_row_times(a, diag, strong, &lumped_diagonal(a, diag, strong, i), i, x)
                },
                |i| {
                    let d = lumped_diagonal(a, diag, strong, i);
                    let blocks = a.row(i).filter_map(|k| {
                        if k == diag[i] {
                            Some(d)
                        } else {
                            strong[k].then(|| load(&a.val[k]))
                        }
                    });
                    gershgorin_row(&df_inv[i], blocks)
                },
                |i| df_inv[i],
                iterations,
                refill,
                &mut tr.eigenvector,
                &mut work.t,
            )?
        };
        tr.omega = prolongation_weight / rho;
    }
    // P = T - omega D_F^-1 (A_F T), row by row (its values taken out of
    // `tr` while they are written: no allocation).
    let mut p_val = std::mem::take(&mut tr.p.val);
    let rows = Rows { a, diag, tr };
    par::row_slices_with(
        &tr.p.row_ptr,
        &mut p_val,
        &p_row_buffer,
        &|i, vals: &mut [SBlk<S, B, K>], acc| {
            let d = lumped_diagonal(a, diag, &tr.strong, i);
            rows.prolongator_row(i, &d, &tr.df_inv[i], tr.omega, vals, acc);
        },
    );
    tr.p.val = p_val;
    tr.p.fill_transpose(&mut tr.r, &tr.r_map);
    Ok(())
}

/// Rows of `P` up to this many blocks are accumulated in `f64` on the stack
/// (longer ones in their storage).
const MAX_P_ROW: usize = 32;

/// The accumulator of a row of `P`, made once per task of rows (zeroing
/// all of it for every row cost as much as the rest of the smoothing; only
/// the row's own part is zeroed).
fn p_row_buffer<const B: usize, const K: usize>() -> [Blk<B, K>; MAX_P_ROW] {
    [zero::<B, K>(); MAX_P_ROW]
}

/// What a row of `P` is computed from, besides its diagonal blocks: `A`
/// and the transfer's `T` and slot maps (its `P` values and `D_F^-1` taken
/// out while they are written).
struct Rows<'a, const B: usize, const K: usize, S: Entry> {
    a: &'a Bsr<B, S>,
    diag: &'a [usize],
    tr: &'a Transfer<B, K, S>,
}

impl<const B: usize, const K: usize, S: Entry> Rows<'_, B, K, S> {
    /// Row `i` of `P = T - omega D_F^-1 (A_F T)` into its slots `vals`:
    /// `A_F T` (with `d` the lumped diagonal block of row `i`), then scaled
    /// by `-omega D_F^-1` (`df_inv`, the row's block of `D_F^-1`), then `T` added.
    #[inline(always)]
    fn prolongator_row(
        &self,
        i: usize,
        d: &Blk<B>,
        df_inv: &Blk<B>,
        omega: f64,
        vals: &mut [SBlk<S, B, K>],
        acc: &mut [Blk<B, K>; MAX_P_ROW],
    ) {
        let (a, t) = (self.a, &self.tr.t);
        let start = self.tr.p.row_ptr[i];
        let wide = vals.len() > MAX_P_ROW;
        if wide {
            vals.fill(szero::<S, B, K>());
        } else {
            acc[..vals.len()].fill(zero::<B, K>());
        }
        for k in a.row(i) {
            let z = self.tr.z_slot[k];
            if z == u32::MAX {
                continue;
            }
            let q = t.row(a.col[k] as usize).start;
            let blk = if k == self.diag[i] {
                *d
            } else {
                load(&a.val[k])
            };
            let slot = z as usize - start;
            if wide {
                let mut m = load(&vals[slot]);
                mul_mat_add(&blk, &t.val[q], &mut m);
                vals[slot] = store(&m);
            } else {
                mul_mat_add(&blk, &t.val[q], &mut acc[slot]);
            }
        }
        for (s, v) in vals.iter_mut().enumerate() {
            let z = if wide { load(v) } else { acc[s] };
            let mut m = zero::<B, K>();
            mul_mat_add(df_inv, &z, &mut m);
            for row in m.iter_mut() {
                for x in row.iter_mut() {
                    *x *= -omega;
                }
            }
            if let Some(k) = t.row(i).next()
                && self.tr.t_in_p[i] - start == s
            {
                for r in 0..B {
                    for c in 0..K {
                        m[r][c] += t.val[k][r][c];
                    }
                }
            }
            *v = store(&m);
        }
    }
}

/// A refill that keeps `omega` (no spectral radius to estimate): the
/// smoother's `D^-1` (into `a_dinv`), `D_F^-1` and `P` in one pass over the
/// rows of `A` (each row read once, not three times), then `R = P^T`; the
/// same numbers as [`invert_diagonal`](super::invert_diagonal) followed by
/// [`smooth_prolongator`]. `false` when a diagonal block of `A` is not
/// positive definite (the caller reports which).
pub(super) fn refill_prolongator<const B: usize, const K: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    a_dinv: &mut [SBlk<S, B>],
    tr: &mut Transfer<B, K, S>,
) -> bool {
    let failed = AtomicBool::new(false);
    // `D_F^-1` and `P`'s values taken out of `tr` while they are written.
    let (mut df_inv, mut p_val) = (
        std::mem::take(&mut tr.df_inv),
        std::mem::take(&mut tr.p.val),
    );
    let rows = Rows { a, diag, tr };
    par::rows_and_slices_with(
        &tr.p.row_ptr,
        0,
        a_dinv,
        &mut df_inv,
        &mut p_val,
        &p_row_buffer,
        &|i, inv: &mut SBlk<S, B>, df: &mut Blk<B>, vals: &mut [SBlk<S, B, K>], acc| {
            match spd_inverse(&load(&a.val[diag[i]])) {
                Some(m) => *inv = store(&m),
                None => failed.store(true, Ordering::Relaxed),
            }
            let d = lumped_diagonal(a, diag, &tr.strong, i);
            *df = spd_inverse(&d).unwrap_or_else(|| load(inv));
            rows.prolongator_row(i, &d, df, tr.omega, vals, acc);
        },
    );
    (tr.df_inv, tr.p.val) = (df_inv, p_val);
    if failed.into_inner() {
        return false;
    }
    tr.p.fill_transpose(&mut tr.r, &tr.r_map);
    true
}
