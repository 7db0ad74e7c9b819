//! The multigrid hierarchy: set-up (symbolic once, numeric at every
//! refill), the smoothers, the coarsest-level solve and the V-cycle.

use std::sync::Mutex;

use super::aggregate::{NO_AGGREGATE, aggregate, strong_connections, tentative_prolongator};
use super::bsr::{
    Blk, Bsr, determinant, frobenius2, mul_add, mul_mat_add, mul_vec, product_pattern,
    product_values, product_values_symmetric, spd_inverse, zero,
};
use super::ic0::BlockIc0;
use super::par;
use super::{AmgLevelStats, AmgOptions, AmgSmoother};
use crate::error::SparseError;
use crate::operator::MatrixFree;
use crate::power::{PowerParams, power_iterate};

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
struct Transfer<const B: usize> {
    /// The filtered matrix `A_F`: the strong blocks of `A`, and on the
    /// diagonal `A_ii` plus the weak blocks of row `i` (so `A_F` keeps the
    /// row sums of `A`, and with them the near-nullspace of translations).
    af: Bsr<B>,
    /// For every slot of `af`: the slot of `a` it copies (`u32::MAX` on the diagonal).
    af_src: Vec<u32>,
    af_diag: Vec<usize>,
    /// Strong off-diagonal slots of `a`.
    strong: Vec<bool>,
    /// `D_F^-1`, the inverted diagonal blocks of `af` (of `a` where those
    /// are not positive definite).
    df_inv: Vec<Blk<B>>,
    /// Tentative prolongator (at most one block per row) and where each
    /// of its blocks sits in the pattern of `p`.
    t: Bsr<B>,
    t_in_p: Vec<usize>,
    /// Smoothed prolongator `P = (I - omega D_F^-1 A_F) T` and `R = P^T`.
    p: Bsr<B>,
    r: Bsr<B>,
    r_map: Vec<u32>,
    /// `A P`, the intermediate of the Galerkin product `R (A P)`.
    ap: Bsr<B>,
    /// For every slot of the next level's operator `R (A P)` (structurally
    /// symmetric), the slot of its transposed block.
    galerkin_mirror: Vec<u32>,
    /// `omega = prolongation_weight / rho(D_F^-1 A_F)`.
    omega: f64,
    /// The power method's eigenvector estimate of `D_F^-1 A_F`.
    eigenvector: Vec<f64>,
}

/// One level: its operator, the smoother's data and the transfer to the
/// next level (`None` on the coarsest).
#[derive(Debug, Clone)]
struct Level<const B: usize> {
    a: Bsr<B>,
    diag: Vec<usize>,
    /// The inverted (symmetrised) diagonal blocks of `a`.
    dinv: Vec<Blk<B>>,
    /// Damped-Jacobi weight `jacobi_weight / rho(D^-1 A)`.
    omega: f64,
    /// The power method's eigenvector estimate of `D^-1 A` (warm start of refills).
    eigenvector: Vec<f64>,
    transfer: Option<Transfer<B>>,
    /// The block IC(0) factor of `a`, for [`AmgSmoother::BlockIc0`].
    ic0: Option<BlockIc0<B>>,
}

/// The dense Cholesky factor `L` (row-major, lower triangle) of the coarsest operator.
#[derive(Debug, Clone)]
struct DenseCholesky {
    n: usize,
    l: Vec<f64>,
}

impl DenseCholesky {
    fn new(n: usize) -> Self {
        Self {
            n,
            l: vec![0.0; n * n],
        }
    }

    /// Factors the symmetric part of `a`; `Err(row)` at the first pivot that
    /// is not positive (relative to the row's diagonal entry).
    fn factor<const B: usize>(&mut self, a: &Bsr<B>) -> Result<(), usize> {
        let n = self.n;
        let m = &mut self.l;
        m.fill(0.0);
        for i in 0..a.nrows {
            for k in a.row(i) {
                let j = a.col[k] as usize;
                for r in 0..B {
                    for c in 0..B {
                        m[(B * i + r) * n + B * j + c] += a.val[k][r][c];
                    }
                }
            }
        }
        for i in 0..n {
            for j in 0..i {
                let s = 0.5 * (m[i * n + j] + m[j * n + i]);
                m[i * n + j] = s;
            }
        }
        for j in 0..n {
            let diag0 = m[j * n + j];
            let mut d = diag0;
            for k in 0..j {
                d -= m[j * n + k] * m[j * n + k];
            }
            if !(d > 1e-14 * diag0.abs() && d.is_finite()) {
                return Err(j);
            }
            let ljj = d.sqrt();
            m[j * n + j] = ljj;
            for i in j + 1..n {
                let mut s = m[i * n + j];
                for k in 0..j {
                    s -= m[i * n + k] * m[j * n + k];
                }
                m[i * n + j] = s / ljj;
            }
        }
        Ok(())
    }

    /// `x = (L L^T)^-1 b`.
    fn solve(&self, b: &[f64], x: &mut [f64]) {
        let n = self.n;
        let l = &self.l;
        for i in 0..n {
            let row = &l[i * n..i * n + i];
            let s: f64 = row.iter().zip(&x[..i]).map(|(a, b)| a * b).sum();
            x[i] = (b[i] - s) / l[i * n + i];
        }
        for i in (0..n).rev() {
            let mut s = x[i];
            for k in i + 1..n {
                s -= l[k * n + i] * x[k];
            }
            x[i] = s / l[i * n + i];
        }
    }
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

/// A smoothed-aggregation hierarchy with `B x B` blocks on every level.
#[derive(Debug)]
pub(crate) struct Hierarchy<const B: usize> {
    levels: Vec<Level<B>>,
    /// Factor of the coarsest operator, when it is solved directly.
    coarse: Option<DenseCholesky>,
    numeric: Numeric,
    /// The V-cycle's vectors; `apply` takes `&self`, so they sit behind a
    /// lock that is taken once per cycle (uncontended, no allocation).
    work: Mutex<Vec<Work>>,
}

impl<const B: usize> Clone for Hierarchy<B> {
    fn clone(&self) -> Self {
        let work = self.work.lock().unwrap_or_else(|e| e.into_inner()).clone();
        Self {
            levels: self.levels.clone(),
            coarse: self.coarse.clone(),
            numeric: self.numeric,
            work: Mutex::new(work),
        }
    }
}

/// Gershgorin's bound `max_i sum_j |D_i^-1 A_ij|_inf >= rho(D^-1 A)`, or
/// the power method's estimate after `power_iterations` steps, started from
/// the eigenvector estimate in `v` if `warm` (`w` is scratch).
fn spectral_radius<const B: usize>(
    a: &Bsr<B>,
    dinv: &[Blk<B>],
    power_iterations: usize,
    warm: bool,
    v: &mut [f64],
    w: &mut [f64],
) -> Result<f64, SparseError> {
    if power_iterations == 0 {
        let mut rho = 0.0_f64;
        for i in 0..a.nrows {
            let mut sums = [0.0; B];
            for k in a.row(i) {
                let mut m = zero::<B>();
                mul_mat_add(&dinv[i], &a.val[k], &mut m);
                for r in 0..B {
                    sums[r] += m[r].iter().map(|v| v.abs()).sum::<f64>();
                }
            }
            rho = sums.iter().fold(rho, |m, &s| m.max(s));
        }
        return Ok(rho);
    }
    let op = MatrixFree::new(B * a.nrows, |x: &[f64], y: &mut [f64]| {
        let (x3, _) = x.as_chunks::<B>();
        let (y3, _) = y.as_chunks_mut::<B>();
        par::rows(y3, &|i, yi: &mut [f64; B]| {
            *yi = mul_vec(&dinv[i], &a.row_times(i, x3));
        });
    });
    let params = PowerParams {
        rtol: 1e-3,
        max_iter: power_iterations,
        seed: 1,
    };
    Ok(power_iterate(&op, &params, None, warm, v, w)?.0.abs())
}

/// Inverts the (symmetrised) diagonal blocks of `a`. The error names the
/// first block that is not positive definite: [`SparseError::SingularBlock`]
/// when it is (numerically) singular on the finest level, else
/// [`SparseError::AmgNotPositiveDefinite`].
fn invert_diagonal<const B: usize>(
    a: &Bsr<B>,
    diag: &[usize],
    dinv: &mut [Blk<B>],
    level: usize,
) -> Result<(), SparseError> {
    // Rows split across threads; a failure is reported for the first row
    // that fails (searched again serially, so the error does not depend on
    // the schedule).
    let failed = std::sync::atomic::AtomicBool::new(false);
    par::rows(
        dinv,
        &|i, inv: &mut Blk<B>| match spd_inverse(&a.val[diag[i]]) {
            Some(m) => *inv = m,
            None => failed.store(true, std::sync::atomic::Ordering::Relaxed),
        },
    );
    if !failed.into_inner() {
        return Ok(());
    }
    for (i, &d) in diag.iter().enumerate() {
        spd_inverse(&a.val[d]).ok_or_else(|| {
            let determinant = determinant(&a.val[d]);
            let scale = frobenius2(&a.val[d]).sqrt().powi(B as i32);
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

impl<const B: usize> Hierarchy<B> {
    /// The full set-up from the finest operator `a` (values filled) and its
    /// near-nullspace (one `B x B` block per node: column `c` of the blocks
    /// is vector `c`). Each level is computed numerically before the next
    /// one is aggregated (strength needs the Galerkin operator's values).
    pub fn new(
        a: Bsr<B>,
        nullspace: Vec<Blk<B>>,
        options: &AmgOptions,
    ) -> Result<Self, SparseError> {
        par::install(|| Self::build(a, nullspace, options))
    }

    fn build(a: Bsr<B>, nullspace: Vec<Blk<B>>, options: &AmgOptions) -> Result<Self, SparseError> {
        let numeric = Numeric {
            smoother: options.smoother,
            sweeps: options.sweeps,
            jacobi_weight: options.jacobi_weight,
            prolongation_weight: options.prolongation_weight,
            power_iterations: options.power_iterations,
            refill_power_iterations: options.refill_power_iterations,
            keep_prolongators: options.keep_prolongators,
        };
        let mut levels: Vec<Level<B>> = Vec::new();
        let mut work: Vec<Work> = Vec::new();
        let mut a = a;
        let mut nullspace = nullspace;
        let mut theta = options.strength_threshold;
        // Whether the finest level stopped because its aggregation stalled
        // (not because it was small enough or the level count was reached).
        let mut finest_stalled = false;
        loop {
            let l = levels.len();
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
                Self::symbolic_transfer(&a, &diag, &nullspace, theta)?
            };
            if l == 0 {
                finest_stalled = !last && symbolic.is_none();
            }
            let (transfer, coarse_nullspace) = match symbolic {
                Some((t, ns)) => (Some(t), Some(ns)),
                None => (None, None),
            };
            let mut transfer = transfer;
            let mut next = transfer.as_mut().map(|t| {
                let c = product_pattern(&t.r, &t.ap);
                let (ct, mirror) = c.transpose_pattern();
                debug_assert!(
                    ct.row_ptr == c.row_ptr && ct.col == c.col,
                    "R A P is symmetric"
                );
                t.galerkin_mirror = mirror;
                c
            });
            let mut w = Work::new(B * n, next.as_ref().map_or(0, |c| B * c.nrows));
            let mut level = Level {
                dinv: vec![zero::<B>(); n],
                omega: 0.0,
                eigenvector: vec![0.0; B * n],
                ic0: (options.smoother == AmgSmoother::BlockIc0).then(|| BlockIc0::new(&a, &diag)),
                a,
                diag,
                transfer,
            };
            compute_level(&mut level, next.as_mut(), l, &numeric, false, &mut w)?;
            levels.push(level);
            work.push(w);
            match (next, coarse_nullspace) {
                (Some(c), Some(ns)) => {
                    a = c;
                    nullspace = ns;
                    theta *= 0.5;
                }
                _ => break,
            }
        }
        let coarsest = B * levels.last().map_or(0, |l| l.a.nrows);
        // A finest level whose aggregation stalls has few strong connections
        // (a mass-dominated system: a soft cloth, a small step, where no
        // block is strong): the smoother nearly solves it, and a dense
        // factor of the whole matrix at every refill would cost n^3 / 3
        // (1.5e8 flops for 768 unknowns, against 3e4 nonzeros).
        let direct = coarsest <= DIRECT_LIMIT && !finest_stalled;
        let mut h = Self {
            levels,
            coarse: direct.then(|| DenseCholesky::new(coarsest)),
            numeric,
            work: Mutex::new(work),
        };
        h.factor_coarsest()?;
        Ok(h)
    }

    /// Strength, aggregates, tentative prolongator and the patterns of
    /// `A_F`, `P`, `R` and `A P`; `None` when the level does not coarsen.
    #[allow(clippy::type_complexity)]
    fn symbolic_transfer(
        a: &Bsr<B>,
        diag: &[usize],
        nullspace: &[Blk<B>],
        theta: f64,
    ) -> Result<Option<(Transfer<B>, Vec<Blk<B>>)>, SparseError> {
        let n = a.nrows;
        let strong = strong_connections(a, diag, theta);
        let (agg, n_agg) = aggregate(a, &strong);
        if n_agg == 0 || n_agg as f64 > MIN_COARSENING * n as f64 {
            return Ok(None);
        }
        let (t, coarse_nullspace) = tentative_prolongator(&agg, n_agg, nullspace)?;
        // A_F: diagonal and strong blocks.
        let mut af = Bsr::<B>::empty(n, n);
        af.row_ptr.clear();
        af.row_ptr.push(0);
        let mut af_src = Vec::new();
        let mut af_diag = Vec::with_capacity(n);
        for i in 0..n {
            for k in a.row(i) {
                if k == diag[i] {
                    af_diag.push(af.col.len());
                    af_src.push(u32::MAX);
                    af.col.push(i as u32);
                } else if strong[k] {
                    af_src.push(k as u32);
                    af.col.push(a.col[k]);
                }
            }
            af.row_ptr.push(af.col.len());
        }
        af.val = vec![zero::<B>(); af.col.len()];
        let p = product_pattern(&af, &t);
        let t_in_p = (0..n)
            .map(|i| match t.row(i).next() {
                Some(k) => {
                    let c = t.col[k];
                    let row = p.row(i);
                    row.start
                        + p.col[row]
                            .binary_search(&c)
                            .expect("the diagonal of A_F keeps T's block in P")
                }
                None => usize::MAX,
            })
            .collect();
        debug_assert!(
            agg.iter()
                .all(|&g| g == NO_AGGREGATE || (g as usize) < n_agg)
        );
        let (r, r_map) = p.transpose_pattern();
        let ap = product_pattern(a, &p);
        Ok(Some((
            Transfer {
                af,
                af_src,
                af_diag,
                strong,
                df_inv: vec![zero::<B>(); n],
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

    /// Mutable access to the finest operator's values, for a refill.
    pub fn finest_mut(&mut self) -> &mut Bsr<B> {
        &mut self.levels[0].a
    }

    /// Recomputes every number of the hierarchy from the finest operator's
    /// values: smoothers, `A_F`, `omega`, `P`, `R`, the Galerkin operators
    /// and the coarsest factor. Allocates nothing.
    pub fn compute(&mut self) -> Result<(), SparseError> {
        par::install(|| {
            let work = self.work.get_mut().unwrap_or_else(|e| e.into_inner());
            for l in 0..self.levels.len() {
                let (head, tail) = self.levels.split_at_mut(l + 1);
                let next = tail.first_mut().map(|n| &mut n.a);
                compute_level(&mut head[l], next, l, &self.numeric, true, &mut work[l])?;
            }
            self.factor_coarsest()
        })
    }

    fn factor_coarsest(&mut self) -> Result<(), SparseError> {
        if let Some(chol) = self.coarse.as_mut() {
            let level = self.levels.len() - 1;
            chol.factor(&self.levels[level].a).map_err(|row| {
                SparseError::AmgNotPositiveDefinite {
                    level,
                    row,
                    what: "coarsest operator",
                }
            })?;
        }
        Ok(())
    }

    /// Whether the coarsest level is solved directly (else only smoothed).
    pub fn coarsest_direct(&self) -> bool {
        self.coarse.is_some()
    }

    /// Per-level statistics.
    pub fn level_stats(&self) -> impl Iterator<Item = AmgLevelStats> + '_ {
        self.levels.iter().map(|l| AmgLevelStats {
            rows: B * l.a.nrows,
            nonzeros: B * B * l.a.nnz_blocks(),
            smoother_weight: l.omega,
            prolongation_weight: l.transfer.as_ref().map_or(0.0, |t| t.omega),
        })
    }

    /// Scalar dimension of the finest level.
    pub fn dim(&self) -> usize {
        B * self.levels[0].a.nrows
    }

    /// One V-cycle from a zero initial guess: `z = M^-1 r`.
    pub fn apply(&self, r: &[f64], z: &mut [f64]) {
        let mut guard = self.work.lock().unwrap_or_else(|e| e.into_inner());
        let work: &mut [Work] = &mut guard;
        par::install(|| self.cycle(0, r, z, work));
    }

    /// The V-cycle on level `l` for `A_l x = b` from `x = 0`: pre-smoothing,
    /// coarse-grid correction `x += P V_{l+1}(R (b - A x))`, post-smoothing
    /// (the adjoint of the pre-smoother, so the cycle is symmetric).
    ///
    /// The residual after the correction is `t - (A P) x_c`, with `t` the
    /// residual before it and `A P` kept from the Galerkin product: cheaper
    /// than `A` again (fewer blocks per row), and fused with the
    /// prolongation and the first post-smoothing step into one pass.
    fn cycle(&self, l: usize, b: &[f64], x: &mut [f64], work: &mut [Work]) {
        let level = &self.levels[l];
        let (w, rest) = work.split_first_mut().expect("one work entry per level");
        match &level.transfer {
            None => match &self.coarse {
                Some(chol) => chol.solve(b, x),
                None => {
                    self.pre_smooth(level, b, x, &mut w.t);
                    level.a.residual(b, x, &mut w.t);
                    self.post_smooth(level, b, x, &mut w.t);
                }
            },
            Some(tr) => {
                self.pre_smooth(level, b, x, &mut w.t);
                level.a.residual(b, x, &mut w.t);
                tr.r.spmv(&w.t, &mut w.bc);
                self.cycle(l + 1, &w.bc, &mut w.xc, rest);
                let smoother = self.numeric.smoother;
                let (x3, _) = x.as_chunks_mut::<B>();
                let (t3, _) = w.t.as_chunks_mut::<B>();
                let (xc3, _) = w.xc.as_chunks::<B>();
                // x += P x_c; t -= (A P) x_c; and for Jacobi x += omega D^-1 t.
                par::rows(x3, &|i, xi: &mut [f64; B]| {
                    let px = tr.p.row_times(i, xc3);
                    for c in 0..B {
                        xi[c] += px[c];
                    }
                });
                let jacobi = smoother == AmgSmoother::BlockJacobi;
                let omega = level.omega;
                par::rows(t3, &|i, ti: &mut [f64; B]| {
                    let apx = tr.ap.row_times(i, xc3);
                    for c in 0..B {
                        ti[c] -= apx[c];
                    }
                });
                if jacobi {
                    let (t3, _) = w.t.as_chunks::<B>();
                    par::rows(x3, &|i, xi: &mut [f64; B]| {
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

    /// `sweeps` smoothing steps from `x = 0`.
    fn pre_smooth(&self, level: &Level<B>, b: &[f64], x: &mut [f64], t: &mut [f64]) {
        match self.numeric.smoother {
            AmgSmoother::BlockJacobi => {
                // The first step from zero: x = omega D^-1 b.
                let (b3, _) = b.as_chunks::<B>();
                let (x3, _) = x.as_chunks_mut::<B>();
                let omega = level.omega;
                par::rows(x3, &|i, xi: &mut [f64; B]| {
                    *xi = [0.0; B];
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
    fn post_smooth(&self, level: &Level<B>, b: &[f64], x: &mut [f64], t: &mut [f64]) {
        for s in 0..self.numeric.sweeps {
            match self.numeric.smoother {
                AmgSmoother::BlockJacobi => {
                    if s > 0 {
                        level.a.residual(b, x, t);
                    }
                    let (t3, _) = t.as_chunks::<B>();
                    let (x3, _) = x.as_chunks_mut::<B>();
                    par::rows(x3, &|i, xi: &mut [f64; B]| {
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

impl<const B: usize> Level<B> {
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
fn mul_add_scaled<const B: usize>(m: &Blk<B>, omega: f64, x: &[f64; B], y: &mut [f64; B]) {
    let mx = mul_vec(m, x);
    for c in 0..B {
        y[c] += omega * mx[c];
    }
}

/// The numbers of level `l`: the smoother's inverted diagonal and weight
/// and, with a transfer, `A_F`, `omega`, `P = (I - omega D_F^-1 A_F) T`,
/// `R = P^T`, `A P` and the next level's operator `R (A P)` into `next`.
///
/// A refill starts the power method from the previous eigenvector
/// estimates and runs `refill_power_iterations` steps only.
fn compute_level<const B: usize>(
    level: &mut Level<B>,
    next: Option<&mut Bsr<B>>,
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
    invert_diagonal(&level.a, &level.diag, &mut level.dinv, l)?;
    if let Some(ic0) = level.ic0.as_mut() {
        ic0.factor(&level.a, &level.diag, l)?;
    }
    if num.smoother == AmgSmoother::BlockJacobi && estimate {
        let rho = spectral_radius(
            &level.a,
            &level.dinv,
            iterations,
            refill,
            &mut level.eigenvector,
            &mut work.t,
        )?;
        level.omega = num.jacobi_weight / rho;
    }
    let (Some(tr), Some(next)) = (level.transfer.as_mut(), next) else {
        return Ok(());
    };
    if !(refill && num.keep_prolongators) {
        smooth_prolongator(
            &level.a,
            &level.diag,
            &level.dinv,
            tr,
            num.prolongation_weight,
            estimate.then_some(iterations),
            refill,
            work,
        )?;
    }
    product_values(&level.a, &tr.p, &mut tr.ap);
    product_values_symmetric(&tr.r, &tr.ap, next, &tr.galerkin_mirror);
    Ok(())
}

/// `A_F`, `D_F^-1`, `omega` and `P = (I - omega D_F^-1 A_F) T`, `R = P^T`.
#[allow(clippy::too_many_arguments)]
fn smooth_prolongator<const B: usize>(
    a: &Bsr<B>,
    diag: &[usize],
    a_dinv: &[Blk<B>],
    tr: &mut Transfer<B>,
    prolongation_weight: f64,
    iterations: Option<usize>,
    refill: bool,
    work: &mut Work,
) -> Result<(), SparseError> {
    // A_F: strong blocks copied, weak ones lumped onto the diagonal (rows
    // split across threads).
    let (af_src, af_diag, strong) = (&tr.af_src, &tr.af_diag, &tr.strong);
    let af_ptr = &tr.af.row_ptr;
    par::row_slices(af_ptr, &mut tr.af.val, &|i, vals: &mut [Blk<B>]| {
        let row = af_ptr[i];
        for (slot, v) in (row..).zip(vals.iter_mut()) {
            let s = af_src[slot];
            if s != u32::MAX {
                *v = a.val[s as usize];
            }
        }
        let mut d = a.val[diag[i]];
        for k in a.row(i) {
            if k != diag[i] && !strong[k] {
                for r in 0..B {
                    for c in 0..B {
                        d[r][c] += a.val[k][r][c];
                    }
                }
            }
        }
        vals[af_diag[i] - row] = d;
    });
    // D_F^-1; where lumping made a diagonal block indefinite (a matrix that
    // is not an M-matrix, e.g. a scalar elasticity operator with positive
    // off-diagonal entries), D^-1 of A instead: any SPD scaling smooths T.
    let af = &tr.af;
    par::rows(&mut tr.df_inv, &|i, inv: &mut Blk<B>| {
        *inv = spd_inverse(&af.val[af_diag[i]]).unwrap_or(a_dinv[i]);
    });
    if let Some(iterations) = iterations {
        let rho = spectral_radius(
            &tr.af,
            &tr.df_inv,
            iterations,
            refill,
            &mut tr.eigenvector,
            &mut work.t,
        )?;
        tr.omega = prolongation_weight / rho;
    }
    // P = T - omega D_F^-1 (A_F T).
    product_values(&tr.af, &tr.t, &mut tr.p);
    let (df_inv, t, t_in_p, omega) = (&tr.df_inv, &tr.t, &tr.t_in_p, tr.omega);
    let p_ptr = &tr.p.row_ptr;
    par::row_slices(p_ptr, &mut tr.p.val, &|i, vals: &mut [Blk<B>]| {
        let dinv = &df_inv[i];
        for v in vals.iter_mut() {
            let mut m = zero::<B>();
            mul_mat_add(dinv, v, &mut m);
            for row in m.iter_mut() {
                for x in row.iter_mut() {
                    *x *= -omega;
                }
            }
            *v = m;
        }
        if let Some(k) = t.row(i).next() {
            let s = t_in_p[i] - p_ptr[i];
            for r in 0..B {
                for c in 0..B {
                    vals[s][r][c] += t.val[k][r][c];
                }
            }
        }
    });
    tr.p.fill_transpose(&mut tr.r, &tr.r_map);
    Ok(())
}

/// One damped block-Jacobi step `x += omega D^-1 (b - A x)`.
fn jacobi_step<const B: usize>(level: &Level<B>, b: &[f64], x: &mut [f64], t: &mut [f64]) {
    level.a.residual(b, x, t);
    let (t3, _) = t.as_chunks::<B>();
    let (x3, _) = x.as_chunks_mut::<B>();
    par::rows(x3, &|i, xi: &mut [f64; B]| {
        mul_add_scaled(&level.dinv[i], level.omega, &t3[i], xi);
    });
}

/// One block Gauss-Seidel sweep `x_i += D_i^-1 (b_i - sum_j A_ij x_j)`,
/// rows in increasing order (`backward = false`) or decreasing order.
fn gauss_seidel<const B: usize>(level: &Level<B>, b: &[f64], x: &mut [f64], backward: bool) {
    let a = &level.a;
    let (b3, _) = b.as_chunks::<B>();
    let (x3, _) = x.as_chunks_mut::<B>();
    let mut row = |i: usize| {
        let ax = a.row_times(i, x3);
        let mut s = b3[i];
        for c in 0..B {
            s[c] -= ax[c];
        }
        mul_add(&level.dinv[i], &s, &mut x3[i]);
    };
    if backward {
        (0..a.nrows).rev().for_each(&mut row);
    } else {
        (0..a.nrows).for_each(&mut row);
    }
}

#[cfg(test)]
impl<const B: usize> Hierarchy<B> {
    /// Test access: level `l`'s operator, prolongator and tentative prolongator.
    pub fn level_matrices(&self, l: usize) -> (&Bsr<B>, Option<(&Bsr<B>, &Bsr<B>)>) {
        let level = &self.levels[l];
        (&level.a, level.transfer.as_ref().map(|t| (&t.p, &t.t)))
    }

    pub fn n_levels(&self) -> usize {
        self.levels.len()
    }
}
