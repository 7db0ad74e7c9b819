//! The multigrid hierarchy: set-up (symbolic once, numeric at every
//! refill), the smoothers, the coarsest-level solve and the V-cycle.

use std::sync::Mutex;

use super::aggregate::{NO_AGGREGATE, aggregate, strong_connections, tentative_prolongator};
use super::bsr::{
    Blk, Bsr, Entry, SBlk, determinant, frobenius2, load, mul_mat_add, mul_vec, product_pattern,
    product_values, product_values_symmetric, smul_add, spd_inverse, store, szero, zero,
};
use super::ic0::BlockIc0;
use super::par;
use super::{AmgLevelStats, AmgOptions, AmgSmoother};
use crate::error::SparseError;
use crate::operator::MatrixFree;
use crate::power::{PowerParams, power_iterate};
use crate::vecops::dot;

mod dense;
mod prolong;

use self::dense::DenseCholesky;
use self::prolong::{refill_prolongator, smooth_prolongator};

/// The coarsest level is solved directly (dense Cholesky) when it has at
/// most this many unknowns, even if coarsening stalled above the
/// requested `coarse_size` below the finest level; a larger stalled level,
/// and a finest level whose aggregation stalls, is only smoothed.
const DIRECT_LIMIT: usize = 3000;

/// Coarsening is given up when the aggregates would keep more than this
/// fraction of the nodes.
const MIN_COARSENING: f64 = 0.8;

/// The transfer from one level to the next and what its numbers are computed from.
#[derive(Debug, Clone)]
struct Transfer<const B: usize, const K: usize, S: Entry> {
    /// Strong off-diagonal slots of `a`. The filtered matrix `A_F` of
    /// prolongator smoothing is never stored: its rows are the strong blocks
    /// of `A` and, on the diagonal, `A_ii` plus the weak blocks of row `i`
    /// (so `A_F` keeps the row sums of `A`, and with them the near-nullspace
    /// of translations).
    strong: Vec<bool>,
    /// Whether every off-diagonal block is strong (`A_F = A`, `D_F = D`):
    /// then `rho(D_F^-1 A_F)` is the smoother's `rho(D^-1 A)`, estimated once.
    unfiltered: bool,
    /// For every slot of `a` in `A_F` (strong or diagonal) whose column is
    /// aggregated: the slot of `p` its product with `T` adds to (`u32::MAX`
    /// otherwise).
    z_slot: Vec<u32>,
    /// `D_F^-1`, the inverted diagonal blocks of `A_F` (of `a` where those
    /// are not positive definite).
    df_inv: Vec<Blk<B>>,
    /// Tentative prolongator (at most one `B x K` block per row) and where
    /// each of its blocks sits in the pattern of `p`.
    t: Bsr<B, f64, K>,
    t_in_p: Vec<usize>,
    /// Smoothed prolongator `P = (I - omega D_F^-1 A_F) T` and `R = P^T`.
    p: Bsr<B, S, K>,
    r: Bsr<K, S, B>,
    r_map: Vec<u32>,
    /// `A P`, the intermediate of the Galerkin product `R (A P)`.
    ap: Bsr<B, S, K>,
    /// For every slot of the next level's operator `R (A P)` (structurally
    /// symmetric), the slot of its transposed block.
    galerkin_mirror: Vec<u32>,
    /// `omega = prolongation_weight / rho(D_F^-1 A_F)`.
    omega: f64,
    /// The power method's eigenvector estimate of `D_F^-1 A_F`.
    eigenvector: Vec<f64>,
}

/// One level (`B` unknowns per node): its operator, the smoother's data
/// and the transfer to the next level (`K` unknowns per node; `None` on
/// the coarsest).
#[derive(Debug, Clone)]
struct Level<const B: usize, const K: usize, S: Entry> {
    a: Bsr<B, S>,
    diag: Vec<usize>,
    /// The inverted (symmetrised) diagonal blocks of `a`.
    dinv: Vec<SBlk<S, B>>,
    /// Damped-Jacobi weight `jacobi_weight / rho(D^-1 A)`.
    omega: f64,
    /// The power method's eigenvector estimate of `D^-1 A` (warm start of refills).
    eigenvector: Vec<f64>,
    transfer: Option<Transfer<B, K, S>>,
    /// The block IC(0) factor of `a`, for [`AmgSmoother::BlockIc0`].
    ic0: Option<BlockIc0<B>>,
}

/// Per-level scratch of the V-cycle: `t` (this level's residual), and the
/// next level's right-hand side `bc` and correction `xc`; `t` is also the
/// power method's scratch during set-up.
#[derive(Debug, Clone)]
struct Work {
    t: Vec<f64>,
    bc: Vec<f64>,
    xc: Vec<f64>,
}

impl Work {
    fn new(rows: usize, coarse_rows: usize) -> Self {
        Self {
            t: vec![0.0; rows],
            bc: vec![0.0; coarse_rows],
            xc: vec![0.0; coarse_rows],
        }
    }
}

/// The parameters of the numeric set-up and of the cycle.
#[derive(Debug, Clone, Copy)]
struct Numeric {
    smoother: AmgSmoother,
    sweeps: usize,
    jacobi_weight: f64,
    prolongation_weight: f64,
    power_iterations: usize,
    refill_power_iterations: usize,
    keep_prolongators: bool,
}

/// A smoothed-aggregation hierarchy with `B x B` blocks on the finest
/// level and `K x K` blocks on every coarser one (`K` near-nullspace
/// vectors: every coarse node carries one unknown per vector), their
/// entries stored as `S`. Both block sizes are constants, so every kernel
/// of every level is compiled for its block size.
#[derive(Debug)]
pub(crate) struct Hierarchy<const B: usize, const K: usize, S: Entry> {
    /// The finest level; its transfer (if any) goes to `coarse[0]`.
    fine: Level<B, K, S>,
    /// The coarser levels, finest first.
    coarse: Vec<Level<K, K, S>>,
    /// Factor of the coarsest operator, when it is solved directly.
    direct: Option<DenseCholesky>,
    numeric: Numeric,
    /// The V-cycle's vectors; `apply` takes `&self`, so they sit behind a
    /// lock that is taken once per cycle (uncontended, no allocation).
    work: Mutex<Vec<Work>>,
}

impl<const B: usize, const K: usize, S: Entry> Clone for Hierarchy<B, K, S> {
    fn clone(&self) -> Self {
        let work = self.work.lock().unwrap_or_else(|e| e.into_inner()).clone();
        Self {
            fine: self.fine.clone(),
            coarse: self.coarse.clone(),
            direct: self.direct.clone(),
            numeric: self.numeric,
            work: Mutex::new(work),
        }
    }
}

/// Gershgorin's bound `max_i sum_j |D_i^-1 A_ij|_inf >= rho(D^-1 A)`, or
/// the power method's estimate after `power_iterations` steps, started from
/// the eigenvector estimate in `v` if `warm` (`w` is scratch). The operator
/// is given by rows: `row(i, x)` is `sum_j A_ij x_j`, `abs_row(i)` the
/// absolute row sums of `D_i^-1 A_ij` (Gershgorin). Generic in the three
/// (static dispatch: the rows are inlined into the power method's product).
#[allow(clippy::too_many_arguments)]
fn spectral_radius<const B: usize>(
    nrows: usize,
    row: impl Fn(usize, &[[f64; B]]) -> [f64; B] + Sync,
    abs_row: impl Fn(usize) -> [f64; B],
    dinv: impl Fn(usize) -> Blk<B> + Sync,
    power_iterations: usize,
    warm: bool,
    v: &mut [f64],
    w: &mut [f64],
) -> Result<f64, SparseError> {
    if power_iterations == 0 {
        let mut rho = 0.0_f64;
        for i in 0..nrows {
            rho = abs_row(i).iter().fold(rho, |m, &s| m.max(s));
        }
        return Ok(rho);
    }
    let op = MatrixFree::new(B * nrows, |x: &[f64], y: &mut [f64]| {
        let (x3, _) = x.as_chunks::<B>();
        let (y3, _) = y.as_chunks_mut::<B>();
        par::rows(y3, &|i, yi: &mut [f64; B]| {
            *yi = mul_vec(&dinv(i), &row(i, x3));
        });
    });
    let params = PowerParams {
        rtol: 1e-3,
        max_iter: power_iterations,
        seed: 1,
        ..Default::default()
    };
    Ok(power_iterate(&op, &params, None, warm, v, w)?.0.abs())
}

/// Gershgorin's absolute row sums of `D_i^-1 A_ij` over the blocks `blocks` of row `i`.
fn gershgorin_row<const B: usize>(dinv: &Blk<B>, blocks: impl Iterator<Item = Blk<B>>) -> [f64; B] {
    let mut sums = [0.0; B];
    for b in blocks {
        let mut m = zero::<B, B>();
        mul_mat_add(dinv, &b, &mut m);
        for r in 0..B {
            sums[r] += m[r].iter().map(|v| v.abs()).sum::<f64>();
        }
    }
    sums
}

/// Inverts the (symmetrised) diagonal blocks of `a`. The error names the
/// first block that is not positive definite: [`SparseError::SingularBlock`]
/// when it is (numerically) singular on the finest level, else
/// [`SparseError::AmgNotPositiveDefinite`].
fn invert_diagonal<const B: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    dinv: &mut [SBlk<S, B>],
    level: usize,
) -> Result<(), SparseError> {
    // Rows split across threads; a failure is reported for the first row
    // that fails (searched again serially, so the error does not depend on
    // the schedule).
    let failed = std::sync::atomic::AtomicBool::new(false);
    par::rows(
        dinv,
        &|i, inv: &mut SBlk<S, B>| match spd_inverse(&load(&a.val[diag[i]])) {
            Some(m) => *inv = store(&m),
            None => failed.store(true, std::sync::atomic::Ordering::Relaxed),
        },
    );
    if !failed.into_inner() {
        return Ok(());
    }
    for (i, &d) in diag.iter().enumerate() {
        let ad = load(&a.val[d]);
        spd_inverse(&ad).ok_or_else(|| {
            let determinant = determinant(&ad);
            let scale = frobenius2(&ad).sqrt().powi(B as i32);
            if level == 0 && determinant.abs() <= 1e-14 * scale {
                SparseError::SingularBlock {
                    block: i,
                    determinant,
                }
            } else {
                SparseError::AmgNotPositiveDefinite {
                    level,
                    row: B * i,
                    what: "diagonal block",
                }
            }
        })?;
    }
    Ok(())
}

/// Strength, aggregates, tentative prolongator and the patterns of
/// `P = A_F T` (with where every block of `A_F` lands), `R` and `A P`;
/// `None` when the level does not coarsen.
#[allow(clippy::type_complexity)]
fn symbolic_transfer<const B: usize, const K: usize, S: Entry>(
    a: &Bsr<B, S>,
    diag: &[usize],
    nullspace: &[Blk<B, K>],
    theta: f64,
) -> Result<Option<(Transfer<B, K, S>, Vec<Blk<K>>)>, SparseError> {
    let n = a.nrows;
    let strong = strong_connections(a, diag, theta);
    // Aggregates of at least K / B nodes, so that their unknowns can carry the K vectors.
    let (agg, n_agg) = aggregate(a, &strong, K.div_ceil(B));
    if n_agg == 0 || n_agg as f64 > MIN_COARSENING * n as f64 {
        return Ok(None);
    }
    let (t, coarse_nullspace) = tentative_prolongator(&agg, n_agg, nullspace)?;
    // The pattern of A_F (diagonal and strong blocks), for the pattern of A_F T.
    let mut af = Bsr::<B>::empty(n, n);
    af.row_ptr.clear();
    af.row_ptr.push(0);
    for i in 0..n {
        for k in a.row(i) {
            if k == diag[i] || strong[k] {
                af.col.push(a.col[k]);
            }
        }
        af.row_ptr.push(af.col.len());
    }
    let p: Bsr<B, S, K> = product_pattern(&af, &t);
    drop(af);
    // Row by row, the slot of every column of `P`'s row (`slot[c]`, valid
    // for the row's columns only), for where each block of `A_F T` lands.
    let mut slot = vec![0u32; p.ncols];
    let mut z_slot = vec![u32::MAX; a.col.len()];
    let mut t_in_p = vec![usize::MAX; n];
    for i in 0..n {
        for s in p.row(i) {
            slot[p.col[s] as usize] = s as u32;
        }
        for k in a.row(i) {
            if let Some(q) = t.row(a.col[k] as usize).next()
                && (k == diag[i] || strong[k])
            {
                z_slot[k] = slot[t.col[q] as usize];
                debug_assert_eq!(p.col[z_slot[k] as usize], t.col[q], "A_F T is in P");
            }
        }
        if let Some(q) = t.row(i).next() {
            t_in_p[i] = slot[t.col[q] as usize] as usize;
            debug_assert_eq!(p.col[t_in_p[i]], t.col[q], "T is in P");
        }
    }
    drop(slot);
    debug_assert!(
        agg.iter()
            .all(|&g| g == NO_AGGREGATE || (g as usize) < n_agg)
    );
    let (r, r_map) = p.transpose_pattern();
    let ap = product_pattern(a, &p);
    let unfiltered = (0..n).all(|i| a.row(i).all(|k| k == diag[i] || strong[k]));
    Ok(Some((
        Transfer {
            strong,
            unfiltered,
            z_slot,
            df_inv: vec![zero::<B, B>(); n],
            t,
            t_in_p,
            p,
            r,
            r_map,
            ap,
            galerkin_mirror: Vec::new(),
            omega: 0.0,
            eigenvector: vec![0.0; B * n],
        },
        coarse_nullspace,
    )))
}

/// One level of the full set-up from its operator `a` (values filled) and
/// near-nullspace: the symbolic transfer (unless the level is the last
/// one), the patterns of `P`, `R`, `A P` and the next operator, and every
/// number. Returns the level, the next operator with its near-nullspace
/// (`None` on the coarsest level), and whether the level stopped because
/// its aggregation stalled; pushes the level's work vectors onto `work`.
#[allow(clippy::type_complexity)]
fn build_level<const B: usize, const K: usize, S: Entry>(
    a: Bsr<B, S>,
    nullspace: &[Blk<B, K>],
    l: usize,
    theta: f64,
    options: &AmgOptions,
    numeric: &Numeric,
    work: &mut Vec<Work>,
) -> Result<(Level<B, K, S>, Option<(Bsr<K, S>, Vec<Blk<K>>)>, bool), SparseError> {
    let diag = a.diagonal_slots().map_err(|i| {
        if l == 0 {
            SparseError::SingularBlock {
                block: i,
                determinant: 0.0,
            }
        } else {
            SparseError::AmgNotPositiveDefinite {
                level: l,
                row: B * i,
                what: "diagonal block",
            }
        }
    })?;
    let n = a.nrows;
    let last = B * n <= options.coarse_size || l + 1 >= options.max_levels;
    let symbolic = if last {
        None
    } else {
        // Strength needs the diagonal blocks' values only.
        symbolic_transfer(&a, &diag, nullspace, theta)?
    };
    let stalled = !last && symbolic.is_none();
    let (mut transfer, coarse_nullspace) = match symbolic {
        Some((t, ns)) => (Some(t), Some(ns)),
        None => (None, None),
    };
    let mut next = transfer.as_mut().map(|t| {
        let c: Bsr<K, S> = product_pattern(&t.r, &t.ap);
        let (ct, mirror) = c.transpose_pattern();
        debug_assert!(
            ct.row_ptr == c.row_ptr && ct.col == c.col,
            "R A P is symmetric"
        );
        t.galerkin_mirror = mirror;
        c
    });
    let mut w = Work::new(B * n, next.as_ref().map_or(0, |c| K * c.nrows));
    let mut level = Level {
        dinv: vec![szero::<S, B, B>(); n],
        omega: 0.0,
        eigenvector: vec![0.0; B * n],
        ic0: (options.smoother == AmgSmoother::BlockIc0).then(|| BlockIc0::new(&a, &diag)),
        a,
        diag,
        transfer,
    };
    compute_level(&mut level, next.as_mut(), l, numeric, false, &mut w)?;
    work.push(w);
    Ok((level, next.zip(coarse_nullspace), stalled))
}

impl<const B: usize, const K: usize, S: Entry> Hierarchy<B, K, S> {
    /// The full set-up from the finest operator `a` (values filled) and its
    /// near-nullspace (one `B x K` block per node: column `c` of the blocks
    /// is vector `c`). Each level is computed numerically before the next
    /// one is aggregated (strength needs the Galerkin operator's values).
    pub fn new(
        a: Bsr<B, S>,
        nullspace: Vec<Blk<B, K>>,
        options: &AmgOptions,
    ) -> Result<Self, SparseError> {
        par::install(|| Self::build(a, nullspace, options))
    }

    fn build(
        a: Bsr<B, S>,
        nullspace: Vec<Blk<B, K>>,
        options: &AmgOptions,
    ) -> Result<Self, SparseError> {
        let numeric = Numeric {
            smoother: options.smoother,
            sweeps: options.sweeps,
            jacobi_weight: options.jacobi_weight,
            prolongation_weight: options.prolongation_weight,
            power_iterations: options.power_iterations,
            refill_power_iterations: options.refill_power_iterations,
            keep_prolongators: options.keep_prolongators,
        };
        let mut work: Vec<Work> = Vec::new();
        let mut theta = options.strength_threshold;
        let (fine, mut next, finest_stalled) =
            build_level(a, &nullspace, 0, theta, options, &numeric, &mut work)?;
        drop(nullspace);
        let mut coarse: Vec<Level<K, K, S>> = Vec::new();
        while let Some((a, nullspace)) = next {
            theta *= 0.5;
            let level;
            (level, next, _) = build_level(
                a,
                &nullspace,
                coarse.len() + 1,
                theta,
                options,
                &numeric,
                &mut work,
            )?;
            coarse.push(level);
        }
        let coarsest = coarse.last().map_or(B * fine.a.nrows, |l| K * l.a.nrows);
        // A finest level whose aggregation stalls has few strong connections
        // (a mass-dominated system: a soft cloth, a small step, where no
        // block is strong): the smoother nearly solves it, and a dense
        // factor of the whole matrix at every refill would cost n^3 / 3
        // (1.5e8 flops for 768 unknowns, against 3e4 nonzeros).
        let direct = coarsest <= DIRECT_LIMIT && !finest_stalled;
        let mut h = Self {
            fine,
            coarse,
            direct: direct.then(|| DenseCholesky::new(coarsest)),
            numeric,
            work: Mutex::new(work),
        };
        h.factor_coarsest()?;
        Ok(h)
    }

    /// Mutable access to the finest operator's values, for a refill.
    pub fn finest_mut(&mut self) -> &mut Bsr<B, S> {
        &mut self.fine.a
    }

    /// Recomputes every number of the hierarchy from the finest operator's
    /// values: smoothers, `A_F`, `omega`, `P`, `R`, the Galerkin operators
    /// and the coarsest factor. Allocates nothing.
    pub fn compute(&mut self) -> Result<(), SparseError> {
        par::install(|| {
            let work = self.work.get_mut().unwrap_or_else(|e| e.into_inner());
            let next = self.coarse.first_mut().map(|n| &mut n.a);
            compute_level(&mut self.fine, next, 0, &self.numeric, true, &mut work[0])?;
            for l in 0..self.coarse.len() {
                let (head, tail) = self.coarse.split_at_mut(l + 1);
                let next = tail.first_mut().map(|n| &mut n.a);
                let w = &mut work[l + 1];
                compute_level(&mut head[l], next, l + 1, &self.numeric, true, w)?;
            }
            self.factor_coarsest()
        })
    }

    fn factor_coarsest(&mut self) -> Result<(), SparseError> {
        if let Some(chol) = self.direct.as_mut() {
            let level = self.coarse.len();
            let factored = match self.coarse.last() {
                Some(c) => chol.factor(&c.a),
                None => chol.factor(&self.fine.a),
            };
            factored.map_err(|row| SparseError::AmgNotPositiveDefinite {
                level,
                row,
                what: "coarsest operator",
            })?;
        }
        Ok(())
    }

    /// Whether the coarsest level is solved directly (else only smoothed).
    pub fn coarsest_direct(&self) -> bool {
        self.direct.is_some()
    }

    /// Per-level statistics.
    pub fn level_stats(&self) -> impl Iterator<Item = AmgLevelStats> + '_ {
        std::iter::once(self.fine.stats()).chain(self.coarse.iter().map(Level::stats))
    }

    /// Scalar dimension of the finest level.
    pub fn dim(&self) -> usize {
        B * self.fine.a.nrows
    }

    /// One V-cycle from a zero initial guess: `z = M^-1 r`.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let work: &mut [Work] = &mut guard;
        par::install(|| self.cycle(0, r, z, work));
    }

    /// Whether the finest level's passes can carry CG's vector updates and
    /// sums (block Jacobi, one sweep, at least two levels).
    fn fusable(&self) -> bool {
        self.numeric.smoother == AmgSmoother::BlockJacobi
            && self.numeric.sweeps == 1
            && self.fine.transfer.is_some()
    }

    /// CG's residual update and preconditioner in one: `r -= alpha q`,
    /// `z = M^-1 r` by one V-cycle; returns `(r . r, r . z)`. With block
    /// Jacobi (one sweep) the update and `r . r` share the finest
    /// pre-smoothing pass and `r . z` the post-smoothing pass (threaded,
    /// partial sums in a fixed tree); otherwise they are separate passes.
    pub fn update_and_apply(
        &self,
        alpha: f64,
        q: &[f64],
        r: &mut [f64],
        z: &mut [f64],
    ) -> (f64, f64) {
        if !self.fusable() {
            for (ri, qi) in r.iter_mut().zip(q) {
                *ri -= alpha * qi;
            }
            self.apply(r, z);
            return (dot(r, r), dot(r, z));
        }
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let work: &mut [Work] = &mut guard;
        let level = &self.fine;
        let omega = level.omega;
        par::install(|| {
            // r -= alpha q; r . r; x = omega D^-1 r.
            let (rr, _) = crate::par::tree_sum2_mut(r, z, &|at, r, x| {
                let (r3, _) = r.as_chunks_mut::<B>();
                let (x3, _) = x.as_chunks_mut::<B>();
                let mut rr = 0.0;
                for (k, (ri, xi)) in r3.iter_mut().zip(x3.iter_mut()).enumerate() {
                    for c in 0..B {
                        ri[c] -= alpha * q[at + B * k + c];
                        rr += ri[c] * ri[c];
                    }
                    *xi = [0.0; B];
                    mul_add_scaled(&level.dinv[at / B + k], omega, ri, xi);
                }
                (rr, 0.0)
            });
            (rr, self.fused_rest(r, z, work))
        })
    }

    /// One V-cycle `z = M^-1 r` and `r . z`, the sum fused with the last
    /// pass (see [`update_and_apply`](Self::update_and_apply)).
    pub fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        if !self.fusable() {
            self.apply(r, z);
            return dot(r, z);
        }
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let work: &mut [Work] = &mut guard;
        let level = &self.fine;
        let omega = level.omega;
        par::install(|| {
            // x = omega D^-1 r.
            let (r3, _) = r.as_chunks::<B>();
            let (x3, _) = z.as_chunks_mut::<B>();
            par::rows(x3, &|i, xi: &mut [f64; B]| {
                *xi = [0.0; B];
                mul_add_scaled(&level.dinv[i], omega, &r3[i], xi);
            });
            self.fused_rest(r, z, work)
        })
    }

    /// The finest level after the fused pre-smoothing pass: the coarse-grid
    /// correction, then `x += omega D^-1 t` with `b . x`, which it returns.
    fn fused_rest(&self, b: &[f64], x: &mut [f64], work: &mut [Work]) -> f64 {
        let level = &self.fine;
        let tr = level.transfer.as_ref().expect("fusable: a transfer");
        let (w, rest) = work.split_first_mut().expect("one work entry per level");
        self.correct(0, level, tr, b, x, w, rest);
        let omega = level.omega;
        let (bx, _) = crate::par::tree_sum2_mut(x, &mut w.t, &|at, x, t| {
            let (x3, _) = x.as_chunks_mut::<B>();
            let (t3, _) = t.as_chunks::<B>();
            let mut bx = 0.0;
            for (k, (xi, ti)) in x3.iter_mut().zip(t3).enumerate() {
                mul_add_scaled(&level.dinv[at / B + k], omega, ti, xi);
                for c in 0..B {
                    bx += b[at + B * k + c] * xi[c];
                }
            }
            (bx, 0.0)
        });
        bx
    }

    /// The V-cycle on level `l` for `A_l x = b` from `x = 0`: pre-smoothing,
    /// coarse-grid correction `x += P V_{l+1}(R (b - A x))`, post-smoothing
    /// (the adjoint of the pre-smoother, so the cycle is symmetric).
    fn cycle(&self, l: usize, b: &[f64], x: &mut [f64], work: &mut [Work]) {
        match l {
            0 => self.cycle_on(&self.fine, 0, b, x, work),
            _ => self.cycle_on(&self.coarse[l - 1], l, b, x, work),
        }
    }

    /// [`cycle`](Self::cycle) on `level`, level `l` of the hierarchy.
    fn cycle_on<const M: usize, const N: usize>(
        &self,
        level: &Level<M, N, S>,
        l: usize,
        b: &[f64],
        x: &mut [f64],
        work: &mut [Work],
    ) {
        let (w, rest) = work.split_first_mut().expect("one work entry per level");
        match &level.transfer {
            None => match &self.direct {
                Some(chol) => chol.solve(b, x),
                None => {
                    self.pre_smooth(level, b, x, &mut w.t);
                    level.a.residual(b, x, &mut w.t);
                    self.post_smooth(level, b, x, &mut w.t);
                }
            },
            Some(tr) => {
                self.pre_smooth(level, b, x, &mut w.t);
                self.correct(l, level, tr, b, x, w, rest);
                if self.numeric.smoother == AmgSmoother::BlockJacobi {
                    let omega = level.omega;
                    let (x3, _) = x.as_chunks_mut::<M>();
                    let (t3, _) = w.t.as_chunks::<M>();
                    par::rows(x3, &|i, xi: &mut [f64; M]| {
                        mul_add_scaled(&level.dinv[i], omega, &t3[i], xi);
                    });
                    for _ in 1..self.numeric.sweeps {
                        jacobi_step(level, b, x, &mut w.t);
                    }
                } else {
                    self.post_smooth(level, b, x, &mut w.t);
                }
            }
        }
    }

    /// The coarse-grid correction of level `l` after pre-smoothing:
    /// `t = b - A x`, `x += P V_{l+1}(R t)`, and `t` the residual of the
    /// new `x`, for post-smoothing.
    ///
    /// With `f64` storage the new residual is `t - (A P) x_c`, with `A P`
    /// kept from the Galerkin product: cheaper than `A` again (fewer blocks
    /// per row). With `f32` storage the stored `A P` is rounded and no
    /// longer equals `A P` of the rounded factors, so the residual is
    /// `b - A x` anew: the cycle stays exactly symmetric.
    #[allow(clippy::too_many_arguments)]
    fn correct<const M: usize, const N: usize>(
        &self,
        l: usize,
        level: &Level<M, N, S>,
        tr: &Transfer<M, N, S>,
        b: &[f64],
        x: &mut [f64],
        w: &mut Work,
        rest: &mut [Work],
    ) {
        level.a.residual(b, x, &mut w.t);
        tr.r.spmv(&w.t, &mut w.bc);
        self.cycle(l + 1, &w.bc, &mut w.xc, rest);
        {
            let (x3, _) = x.as_chunks_mut::<M>();
            let (xc3, _) = w.xc.as_chunks::<N>();
            par::rows(x3, &|i, xi: &mut [f64; M]| {
                let px = tr.p.row_times(i, xc3);
                for c in 0..M {
                    xi[c] += px[c];
                }
            });
        }
        if S::EXACT {
            let (t3, _) = w.t.as_chunks_mut::<M>();
            let (xc3, _) = w.xc.as_chunks::<N>();
            par::rows(t3, &|i, ti: &mut [f64; M]| {
                let apx = tr.ap.row_times(i, xc3);
                for c in 0..M {
                    ti[c] -= apx[c];
                }
            });
        } else {
            level.a.residual(b, x, &mut w.t);
        }
    }

    /// `sweeps` smoothing steps from `x = 0`.
    fn pre_smooth<const M: usize, const N: usize>(
        &self,
        level: &Level<M, N, S>,
        b: &[f64],
        x: &mut [f64],
        t: &mut [f64],
    ) {
        match self.numeric.smoother {
            AmgSmoother::BlockJacobi => {
                // The first step from zero: x = omega D^-1 b.
                let (b3, _) = b.as_chunks::<M>();
                let (x3, _) = x.as_chunks_mut::<M>();
                let omega = level.omega;
                par::rows(x3, &|i, xi: &mut [f64; M]| {
                    *xi = [0.0; M];
                    mul_add_scaled(&level.dinv[i], omega, &b3[i], xi);
                });
                for _ in 1..self.numeric.sweeps {
                    jacobi_step(level, b, x, t);
                }
            }
            AmgSmoother::SymmetricGaussSeidel => {
                x.fill(0.0);
                for _ in 0..self.numeric.sweeps {
                    gauss_seidel(level, b, x, false);
                }
            }
            AmgSmoother::BlockIc0 => {
                // The first step from zero: x = M^-1 b.
                x.copy_from_slice(b);
                level.ic0_solve(x);
                for _ in 1..self.numeric.sweeps {
                    level.a.residual(b, x, t);
                    level.ic0_solve(t);
                    add_assign(x, t);
                }
            }
        }
    }

    /// `sweeps` smoothing steps, the adjoint of [`pre_smooth`](Self::pre_smooth),
    /// given the residual `t = b - A x` of the current `x`.
    fn post_smooth<const M: usize, const N: usize>(
        &self,
        level: &Level<M, N, S>,
        b: &[f64],
        x: &mut [f64],
        t: &mut [f64],
    ) {
        for s in 0..self.numeric.sweeps {
            match self.numeric.smoother {
                AmgSmoother::BlockJacobi => {
                    if s > 0 {
                        level.a.residual(b, x, t);
                    }
                    let (t3, _) = t.as_chunks::<M>();
                    let (x3, _) = x.as_chunks_mut::<M>();
                    par::rows(x3, &|i, xi: &mut [f64; M]| {
                        mul_add_scaled(&level.dinv[i], level.omega, &t3[i], xi);
                    });
                }
                AmgSmoother::SymmetricGaussSeidel => gauss_seidel(level, b, x, true),
                AmgSmoother::BlockIc0 => {
                    if s > 0 {
                        level.a.residual(b, x, t);
                    }
                    level.ic0_solve(t);
                    add_assign(x, t);
                }
            }
        }
    }
}

impl<const B: usize, const K: usize, S: Entry> Level<B, K, S> {
    fn stats(&self) -> AmgLevelStats {
        AmgLevelStats {
            rows: B * self.a.nrows,
            nonzeros: B * B * self.a.nnz_blocks(),
            smoother_weight: self.omega,
            prolongation_weight: self.transfer.as_ref().map_or(0.0, |t| t.omega),
        }
    }

    /// `z = M^-1 z` with the block IC(0) factor.
    fn ic0_solve(&self, z: &mut [f64]) {
        let ic0 = self
            .ic0
            .as_ref()
            .expect("the IC(0) smoother has its factor");
        ic0.solve_in_place(&self.a, &self.diag, z);
    }
}

/// `x += t` (rows split across threads).
fn add_assign(x: &mut [f64], t: &[f64]) {
    par::rows(x, &|i, xi: &mut f64| *xi += t[i]);
}

/// `y += omega m x`.
#[inline(always)]
fn mul_add_scaled<const B: usize, S: Entry>(
    m: &SBlk<S, B>,
    omega: f64,
    x: &[f64; B],
    y: &mut [f64; B],
) {
    let mut mx = [0.0; B];
    smul_add(m, x, &mut mx);
    for c in 0..B {
        y[c] += omega * mx[c];
    }
}

/// The numbers of level `l`: the smoother's inverted diagonal and weight
/// and, with a transfer, `omega`, `P = (I - omega D_F^-1 A_F) T`,
/// `R = P^T`, `A P` and the next level's operator `R (A P)` into `next`.
///
/// A refill starts the power method from the previous eigenvector
/// estimates and runs `refill_power_iterations` steps only.
fn compute_level<const B: usize, const K: usize, S: Entry>(
    level: &mut Level<B, K, S>,
    next: Option<&mut Bsr<K, S>>,
    l: usize,
    num: &Numeric,
    refill: bool,
    work: &mut Work,
) -> Result<(), SparseError> {
    let iterations = if refill && num.power_iterations > 0 {
        num.refill_power_iterations
    } else {
        num.power_iterations
    };
    // A refill with no power steps keeps the last estimates of rho.
    let estimate = !(refill && num.power_iterations > 0 && iterations == 0);
    // A refill that keeps every omega: the smoother's diagonal, D_F^-1 and P
    // in one pass over the rows of A.
    let fused = !estimate && !num.keep_prolongators && next.is_some();
    match level.transfer.as_mut() {
        Some(tr) if fused => {
            if !refill_prolongator(&level.a, &level.diag, &mut level.dinv, tr) {
                // Reports the first diagonal block that is not positive definite.
                invert_diagonal(&level.a, &level.diag, &mut level.dinv, l)?;
            }
        }
        _ => invert_diagonal(&level.a, &level.diag, &mut level.dinv, l)?,
    }
    if let Some(ic0) = level.ic0.as_mut() {
        ic0.factor(&level.a, &level.diag, l)?;
    }
    // The smoother's power-method estimate of rho(D^-1 A), if it made one.
    let mut smoother_rho = None;
    if num.smoother == AmgSmoother::BlockJacobi && estimate {
        let (a, dinv) = (&level.a, &level.dinv);
        let rho = spectral_radius(
            a.nrows,
            |i, x| a.row_times(i, x),
            |i| gershgorin_row(&load(&dinv[i]), a.row(i).map(|k| load(&a.val[k]))),
            |i| load(&dinv[i]),
            iterations,
            refill,
            &mut level.eigenvector,
            &mut work.t,
        )?;
        level.omega = num.jacobi_weight / rho;
        smoother_rho = (iterations > 0).then_some(rho);
    }
    let (Some(tr), Some(next)) = (level.transfer.as_mut(), next) else {
        return Ok(());
    };
    if !(fused || (refill && num.keep_prolongators)) {
        smooth_prolongator(
            &level.a,
            &level.diag,
            &level.dinv,
            tr,
            num.prolongation_weight,
            estimate.then_some(iterations),
            smoother_rho.filter(|_| tr.unfiltered),
            refill,
            work,
        )?;
    }
    product_values(&level.a, &tr.p, &mut tr.ap);
    product_values_symmetric(&tr.r, &tr.ap, next, &tr.galerkin_mirror);
    Ok(())
}

/// One damped block-Jacobi step `x += omega D^-1 (b - A x)`.
fn jacobi_step<const B: usize, const K: usize, S: Entry>(
    level: &Level<B, K, S>,
    b: &[f64],
    x: &mut [f64],
    t: &mut [f64],
) {
    level.a.residual(b, x, t);
    let (t3, _) = t.as_chunks::<B>();
    let (x3, _) = x.as_chunks_mut::<B>();
    par::rows(x3, &|i, xi: &mut [f64; B]| {
        mul_add_scaled(&level.dinv[i], level.omega, &t3[i], xi);
    });
}

/// One block Gauss-Seidel sweep `x_i += D_i^-1 (b_i - sum_j A_ij x_j)`,
/// rows in increasing order (`backward = false`) or decreasing order.
fn gauss_seidel<const B: usize, const K: usize, S: Entry>(
    level: &Level<B, K, S>,
    b: &[f64],
    x: &mut [f64],
    backward: bool,
) {
    let a = &level.a;
    let (b3, _) = b.as_chunks::<B>();
    let (x3, _) = x.as_chunks_mut::<B>();
    let mut row = |i: usize| {
        let ax = a.row_times(i, x3);
        let mut s = b3[i];
        for c in 0..B {
            s[c] -= ax[c];
        }
        smul_add(&level.dinv[i], &s, &mut x3[i]);
    };
    if backward {
        (0..a.nrows).rev().for_each(&mut row);
    } else {
        (0..a.nrows).for_each(&mut row);
    }
}

/// A level's matrices as dense rows: `(A, Some((P, T)))`, `P` and `T`
/// with `K` columns per coarse node.
#[cfg(test)]
pub(crate) type DenseLevel = (Vec<Vec<f64>>, Option<(Vec<Vec<f64>>, Vec<Vec<f64>>)>);

#[cfg(test)]
impl<const B: usize, const K: usize, S: Entry> Hierarchy<B, K, S> {
    /// Test access: every level's operator, prolongator and tentative
    /// prolongator, dense, finest first.
    pub fn dense_levels(&self) -> Vec<DenseLevel> {
        fn dense<const R: usize, const C: usize, T: Entry>(m: &Bsr<R, T, C>) -> Vec<Vec<f64>> {
            let mut d = vec![vec![0.0; C * m.ncols]; R * m.nrows];
            for i in 0..m.nrows {
                for k in m.row(i) {
                    for r in 0..R {
                        for c in 0..C {
                            d[R * i + r][C * m.col[k] as usize + c] = m.val[k][r][c].load();
                        }
                    }
                }
            }
            d
        }
        fn level<const R: usize, const C: usize, T: Entry>(l: &Level<R, C, T>) -> DenseLevel {
            (
                dense(&l.a),
                l.transfer.as_ref().map(|t| (dense(&t.p), dense(&t.t))),
            )
        }
        std::iter::once(level(&self.fine))
            .chain(self.coarse.iter().map(level))
            .collect()
    }

    pub fn n_levels(&self) -> usize {
        1 + self.coarse.len()
    }
}

#[cfg(test)]
impl<const B: usize, S: Entry> Hierarchy<B, B, S> {
    /// Test access: level `l`'s operator, prolongator and tentative prolongator.
    #[allow(clippy::type_complexity)]
    pub fn level_matrices(&self, l: usize) -> (&Bsr<B, S>, Option<(&Bsr<B, S>, &Bsr<B>)>) {
        let level = if l == 0 {
            &self.fine
        } else {
            &self.coarse[l - 1]
        };
        (&level.a, level.transfer.as_ref().map(|t| (&t.p, &t.t)))
    }
}
