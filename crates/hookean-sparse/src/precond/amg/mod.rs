//! Smoothed-aggregation algebraic multigrid: [`Amg`] (its documentation
//! describes the algorithm and the re-use of the hierarchy).

use crate::NonExhaustive;
mod aggregate;
mod bsr;
mod checkpoint;
mod hierarchy;
mod ic0;
mod levels;
mod nullspace;
mod par;

use std::sync::Arc;
use std::time::Instant;

use self::bsr::{Bsr, Entry, SBlk, szero, transpose, zero};
use self::levels::{Levels, SUPPORTED, with_block_sizes};
use self::nullspace::nullspace_blocks;
pub use self::nullspace::rigid_body_modes;
use super::{Preconditioner, PreconditionerSetup, as_csr, square_dim};
use crate::error::SparseError;
use crate::matrix::{BlockPattern, SymBlockMatrix};

/// The smoother of every level but the coarsest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AmgSmoother {
    /// Block damped Jacobi `x += omega D^-1 (b - A x)` with
    /// `omega = jacobi_weight / rho(D^-1 A)`; every row independent.
    #[default]
    BlockJacobi,
    /// Forward block Gauss-Seidel before the coarse correction, backward after.
    SymmetricGaussSeidel,
    /// Block IC(0) (block ILU(0) of a symmetric matrix) `x += M^-1 (b - A x)`
    /// with `M = (D + W)^T D^-1 (D + W)` on each level's block pattern:
    /// the strongest smoother per step, sequential (triangular solves).
    BlockIc0,
}

/// What [`PreconditionerSetup::setup`] does when the matrix has the sparsity
/// pattern of the current hierarchy and only its values changed (every
/// Newton iteration and every time step of a simulation). A new pattern,
/// block size or near-nullspace length always gets a full set-up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AmgReuse {
    /// A full set-up every time: new strength graph, aggregates and patterns.
    Rebuild,
    /// Refill the numbers (smoothers, `omega`, `P` unless
    /// [`AmgOptions::keep_prolongators`], Galerkin operators, coarsest
    /// factor), keeping aggregates and every pattern. No allocation.
    #[default]
    Refill,
    /// Keep the whole hierarchy (a lagged preconditioner: still symmetric
    /// positive definite, so PCG stays valid, at the price of more
    /// iterations when the values drift) for `updates` calls of `setup`;
    /// the call after them refills. `Keep { updates: 0 }` is `Refill`.
    Keep {
        /// Calls of `setup` that leave the hierarchy as it is.
        updates: usize,
    },
}

/// How the hierarchy stores its matrices (every level's operator, the
/// prolongators, restrictions, `A P` and the smoothers' inverted diagonal
/// blocks); the arithmetic is `f64` either way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AmgPrecision {
    /// `f32` entries: half the memory, and half the bytes a V-cycle
    /// streams (the cycle is bound by memory bandwidth). The V-cycle stays
    /// a symmetric positive definite operator: each level uses the same
    /// rounded matrix in its smoothing and residuals.
    #[default]
    Single,
    /// `f64` entries (the hierarchy before issue 25).
    Double,
}

/// The largest [`AmgOptions::sweeps`], [`AmgOptions::power_iterations`]
/// and [`AmgOptions::refill_power_iterations`] (each pass costs a sweep
/// over a level; more never pays and a huge count would not end).
pub const AMG_MAX_SWEEPS: usize = 100;

/// The shapes of a near-nullspace the multigrid takes
/// ([`AmgOptions::near_nullspace`]), in words for messages: `k` vectors on
/// nodes of `b` unknowns, as [`amg_takes_near_nullspace`] checks them.
pub const AMG_NEAR_NULLSPACE_SHAPES: &str = SUPPORTED;

/// Whether the multigrid takes `vectors` near-nullspace vectors on nodes of
/// `block_size` unknowns ([`AMG_NEAR_NULLSPACE_SHAPES`]).
///
/// ```
/// use hookean_sparse::amg_takes_near_nullspace;
/// assert!(amg_takes_near_nullspace(3, 6) && amg_takes_near_nullspace(1, 1));
/// assert!(!amg_takes_near_nullspace(1, 4) && !amg_takes_near_nullspace(3, 0));
/// ```
pub fn amg_takes_near_nullspace(block_size: usize, vectors: usize) -> bool {
    with_block_sizes!(block_size, vectors, B, K => { let _ = (B, K); true }, _ => false)
}
/// The largest [`AmgOptions::coarse_size`]: the coarsest level is a dense
/// Cholesky factor of `coarse_size^2` numbers.
pub const AMG_MAX_COARSE_SIZE: usize = 4096;
/// The largest [`AmgOptions::max_levels`] (each level coarsens by a
/// factor; 64 is far beyond any matrix that fits in memory).
pub const AMG_MAX_LEVELS: usize = 64;

/// Options of [`Amg`].
#[derive(Debug, Clone, PartialEq)]
pub struct AmgOptions {
    /// Strength threshold `theta` on the finest level, halved on every
    /// coarser one (as AMGCL). In [0, 1). Default `0.08`.
    pub strength_threshold: f64,
    /// Stop coarsening at this many unknowns (then a dense Cholesky solve). Default `500`.
    pub coarse_size: usize,
    /// At most this many levels. Default `10`.
    pub max_levels: usize,
    /// The smoother. Default block damped Jacobi.
    pub smoother: AmgSmoother,
    /// Pre- and post-smoothing steps per level. Default `1`.
    pub sweeps: usize,
    /// Block-Jacobi weight times `rho(D^-1 A)`, in (0, 2). Default `4/3`.
    pub jacobi_weight: f64,
    /// Prolongator-smoothing weight times `rho(D_F^-1 A_F)`, in (0, 2). Default `4/3`.
    pub prolongation_weight: f64,
    /// Power-method steps estimating the spectral radii `rho(D^-1 A)`
    /// (allocation-free, on the V-cycle's vectors). Default `5` (on the cloth
    /// systems 4 and 10 steps give the same PCG iteration counts). `0` uses
    /// Gershgorin's bound `max_i sum_j |D_i^-1 A_ij|_inf` instead: an upper
    /// bound (the smoother then surely converges), but loose for 3x3 blocks
    /// whose conditioning is poor (cloth: a tiny out-of-plane stiffness),
    /// which damps far too much.
    pub power_iterations: usize,
    /// Power-method steps at a refill, started from the previous set-up's
    /// eigenvector estimates (which fit the new values if they changed
    /// little). Default `0`: a refill keeps the last estimates (and with
    /// them the weights `omega`), the cheapest refill: on the 128² drape
    /// (1 s, 123 set-ups) the same 637-638 CG iterations as with 3 steps
    /// per refill, in 12% less time (docs/PERFORMANCE.md). For the
    /// Laplacian-like cloth matrices `rho(D^-1 A)` stays near 2 however the
    /// values move, so a kept estimate stays safe (`omega rho < 2`). (Ignored
    /// when `power_iterations = 0`.)
    pub refill_power_iterations: usize,
    /// At a refill, keep every prolongator of the last full set-up and
    /// recompute only the smoothers, the Galerkin operators `P^T A P` and
    /// the coarsest factor (still a symmetric positive definite V-cycle:
    /// any full-rank `P` gives SPD coarse operators). Cheaper, and fit for
    /// values that change slowly (time steps); default `false` (`P` is
    /// smoothed again with the new values).
    pub keep_prolongators: bool,
    /// What a `setup` with the same pattern does: rebuild, refill (default)
    /// or keep the hierarchy for some updates.
    pub reuse: AmgReuse,
    /// Near-nullspace vectors of length `dim` (e.g. the rigid-body modes of
    /// [`rigid_body_modes`]), `k` of them on nodes of `B` unknowns
    /// (`B` = 3 for block matrices, [`block_size`](Self::block_size) for CSR
    /// ones): `k = B`, or `k = 3` on `B = 2` (2D rigid-body modes), or
    /// `k = 6` on `B = 3` (3D). Every coarse node carries `k` unknowns (the
    /// coarse operators have `k x k` blocks). Empty (default): the `B`
    /// translations (for a scalar matrix, the constant).
    pub near_nullspace: Vec<Vec<f64>>,
    /// Unknowns per node of a CSR matrix (node `i` owns rows
    /// `block_size * i ..`, e.g. 2 for 2D elasticity): 1 (default), 2 or 3.
    /// [`SymBlockMatrix`] input always has 3. Block Jacobi's nodes through
    /// [`PreconditionerOptions`](crate::PreconditionerOptions) too.
    pub block_size: usize,
    /// Storage precision of the hierarchy. Default [`AmgPrecision::Single`].
    pub precision: AmgPrecision,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for AmgOptions {
    fn default() -> Self {
        Self {
            strength_threshold: 0.08,
            coarse_size: 500,
            max_levels: 10,
            smoother: AmgSmoother::BlockJacobi,
            sweeps: 1,
            jacobi_weight: 4.0 / 3.0,
            prolongation_weight: 4.0 / 3.0,
            power_iterations: 5,
            refill_power_iterations: 0,
            keep_prolongators: false,
            reuse: AmgReuse::Refill,
            near_nullspace: Vec::new(),
            block_size: 1,
            precision: AmgPrecision::Single,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// Statistics of one level.
#[derive(Debug, Clone, PartialEq)]
pub struct AmgLevelStats {
    /// Scalar unknowns.
    pub rows: usize,
    /// Scalar nonzeros of the operator (every stored block counted dense).
    pub nonzeros: usize,
    /// Damped-Jacobi weight `omega` (0 for Gauss-Seidel and IC(0)).
    pub smoother_weight: f64,
    /// Prolongator-smoothing weight (0 on the coarsest level).
    pub prolongation_weight: f64,
}

/// Statistics of an [`Amg`] hierarchy.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AmgStats {
    /// Finest first.
    pub levels: Vec<AmgLevelStats>,
    /// `sum_l nnz(A_l) / nnz(A_0)`.
    pub operator_complexity: f64,
    /// `sum_l rows(A_l) / rows(A_0)`.
    pub grid_complexity: f64,
    /// Wall time of the last full set-up (s).
    pub setup_seconds: f64,
    /// Wall time of the last refill (s), 0 if there was none.
    pub refill_seconds: f64,
    /// Full set-ups so far.
    pub setups: usize,
    /// Refills so far.
    pub refills: usize,
    /// Calls of `setup` that kept the hierarchy ([`AmgReuse::Keep`]).
    pub kept: usize,
    /// Whether the coarsest level is solved by a dense Cholesky factor;
    /// `false` when it is only smoothed (a level that stalled above 3000
    /// unknowns, or a finest level above `coarse_size` whose aggregation
    /// stalls).
    pub coarsest_direct: bool,
}

/// Where the finest level's values come from.
pub(super) enum Source<'a> {
    /// The blocks of a [`SymBlockMatrix`], slot by slot of the full storage
    /// (`(stored block, transposed)`, from [`full_pattern`]); 3x3 blocks only.
    Blocks(&'a [(u32, bool)], &'a SymBlockMatrix),
    /// The entries of a CSR matrix and where each goes (block slot, row, column).
    Csr(&'a [EntrySlot], &'a [f64]),
}

/// Writes the values of `source` into the finest level `a`: the blocks of
/// a [`SymBlockMatrix`] with rows split across threads (a non-finite entry
/// is reported by its first slot, searched again serially, independent of
/// the schedule), or CSR entries serially (not the hot path of a simulation).
pub(super) fn fill<const B: usize, S: Entry>(
    a: &mut Bsr<B, S>,
    source: &Source<'_>,
) -> Result<(), SparseError> {
    match *source {
        Source::Blocks(map, src) => {
            assert_eq!(B, 3, "symmetric block matrices have 3x3 blocks");
            let v = src.values();
            let non_finite = std::sync::atomic::AtomicBool::new(false);
            let row_ptr = &a.row_ptr;
            par::row_slices(row_ptr, &mut a.val, &|i, row: &mut [SBlk<S, B>]| {
                for (dst, &(s, t)) in row.iter_mut().zip(&map[row_ptr[i]..]) {
                    let b = &v[s as usize];
                    if b.iter().flatten().any(|x| !x.is_finite()) {
                        non_finite.store(true, std::sync::atomic::Ordering::Relaxed);
                    }
                    let b = if t { transpose(b) } else { *b };
                    for (d, x) in dst.as_flattened_mut().iter_mut().zip(b.as_flattened()) {
                        *d = S::store(*x);
                    }
                }
            });
            if !non_finite.into_inner() {
                return Ok(());
            }
            match map
                .iter()
                .position(|&(s, _)| v[s as usize].iter().flatten().any(|x| !x.is_finite()))
            {
                Some(k) => Err(SparseError::NonFinite {
                    what: "matrix",
                    index: Some(k),
                }),
                None => Ok(()),
            }
        }
        Source::Csr(map, data) => {
            a.val.fill(szero::<S, B, B>());
            for (&(slot, r, c), &v) in map.iter().zip(data) {
                a.val[slot as usize][r as usize][c as usize] = S::store(v);
            }
            Ok(())
        }
    }
}

/// The finest level's storage and where its blocks come from.
#[derive(Debug, Clone)]
enum Inner {
    Empty,
    /// From a [`SymBlockMatrix`]: every full-storage slot copies a stored
    /// block, transposed when it lies below the diagonal.
    Block {
        source: Arc<BlockPattern>,
        map: Vec<(u32, bool)>,
        h: Levels,
    },
    /// From a CSR matrix, with 1, 2 or 3 unknowns per node.
    Csr(CsrLevels),
}

/// Where a CSR entry goes in block storage: `(block slot, row, column)`.
type EntrySlot = (u32, u8, u8);

/// A hierarchy set up from a scalar CSR matrix grouped into `B x B` blocks
/// (node `i` owns rows `B i .. B i + B`, `B = block_size`), with the CSR
/// pattern it came from and where every CSR entry goes: `(block slot, row,
/// column)`.
#[derive(Debug, Clone)]
struct CsrLevels {
    block_size: usize,
    indptr: Vec<usize>,
    indices: Vec<usize>,
    map: Vec<EntrySlot>,
    h: Levels,
}

impl CsrLevels {
    fn same_pattern(&self, a: &sprs::CsMat<f64>, block_size: usize) -> bool {
        self.block_size == block_size
            && self.indptr.as_slice() == &*a.proper_indptr()
            && self.indices.as_slice() == a.indices()
    }

    /// The block pattern of a CSR matrix (CSR storage order) and the map of
    /// its entries.
    fn blocks<const B: usize>(
        a: &sprs::CsMat<f64>,
    ) -> Result<(Bsr<B>, Vec<EntrySlot>), SparseError> {
        let dim = a.rows();
        if !dim.is_multiple_of(B) {
            return Err(SparseError::InvalidParameter {
                name: "block_size",
                message: format!("the dimension {dim} is not a multiple of the block size {B}"),
            });
        }
        let n = dim / B;
        let indptr = a.proper_indptr();
        let sorted = |r: std::ops::Range<usize>| a.indices()[r].is_sorted_by(|x, y| x < y);
        if B == 1 && (0..n).all(|i| sorted(indptr[i]..indptr[i + 1])) {
            // One unknown per node, columns sorted and distinct: the CSR
            // pattern is the block pattern, entry `k` its slot `k`.
            let bsr = Bsr {
                nrows: n,
                ncols: n,
                row_ptr: indptr.to_vec(),
                col: a.indices().iter().map(|&j| j as u32).collect(),
                val: vec![zero::<B, B>(); a.nnz()],
            };
            let map = (0..a.nnz()).map(|k| (k as u32, 0, 0)).collect();
            return Ok((bsr, map));
        }
        let mut marker = vec![usize::MAX; n];
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col: Vec<u32> = Vec::new();
        row_ptr.push(0);
        for i in 0..n {
            let start = col.len();
            for &j in &a.indices()[indptr[B * i]..indptr[B * i + B]] {
                if marker[j / B] != i {
                    marker[j / B] = i;
                    col.push((j / B) as u32);
                }
            }
            col[start..].sort_unstable();
            row_ptr.push(col.len());
        }
        let mut map = Vec::with_capacity(a.nnz());
        for row in 0..dim {
            let i = row / B;
            let cols = &col[row_ptr[i]..row_ptr[i + 1]];
            for &j in &a.indices()[indptr[row]..indptr[row + 1]] {
                let k = cols
                    .binary_search(&((j / B) as u32))
                    .expect("every entry's block is in the pattern");
                map.push(((row_ptr[i] + k) as u32, (row % B) as u8, (j % B) as u8));
            }
        }
        let nnz = col.len();
        let bsr = Bsr {
            nrows: n,
            ncols: n,
            row_ptr,
            col,
            val: vec![zero::<B, B>(); nnz],
        };
        Ok((bsr, map))
    }

    /// The full set-up of `a` with `B` unknowns per node and `K`
    /// near-nullspace vectors.
    fn new<const B: usize, const K: usize>(
        a: &sprs::CsMat<f64>,
        options: &AmgOptions,
    ) -> Result<Self, SparseError>
    where
        hierarchy::Hierarchy<B, K, f32>: Into<Levels>,
        hierarchy::Hierarchy<B, K, f64>: Into<Levels>,
    {
        let (fine, map) = Self::blocks::<B>(a)?;
        let nullspace = nullspace_blocks::<B, K>(&options.near_nullspace, fine.nrows)?;
        let h = Levels::new(&fine, &Source::Csr(&map, a.data()), nullspace, options)?;
        Ok(Self {
            block_size: B,
            indptr: a.proper_indptr().into_owned(),
            indices: a.indices().to_vec(),
            h,
            map,
        })
    }

    fn refill(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        self.h.refill(&Source::Csr(&self.map, a.data()))
    }
}

/// Smoothed-aggregation algebraic multigrid (Vaněk, Mandel, Brezina 1996)
/// on the 3x3 blocks of a [`SymBlockMatrix`], and on CSR matrices grouped
/// into blocks of 1, 2 or 3 unknowns per node ([`AmgOptions::block_size`]).
/// Every level is stored as full block CSR: `B x B` blocks on the finest
/// level, `k x k` on the coarser ones (`k` near-nullspace vectors), so all
/// kernels of the cycle run row by row (ready to be split across threads),
/// compiled for their block size.
///
/// Set-up, per level `l` (`A_0 = A`):
/// 1. strength of connection on blocks: `A_ij` is strong when
///    `|A_ij|_F^2 > theta_l^2 |A_ii|_F |A_jj|_F` (`theta_l` halves per level);
/// 2. aggregation of the strong graph (three greedy passes);
/// 3. the tentative prolongator `T` from the near-nullspace `N_l`, by a thin
///    QR on every aggregate (`N_l = T N_{l+1}`): the three translations per
///    particle by default (the constant for scalar matrices), or the `k`
///    vectors of [`AmgOptions::near_nullspace`] (the rigid-body modes of
///    [`rigid_body_modes`]: `k = 3` on 2D nodes of 2 unknowns, 6 on 3D
///    nodes of 3), so that every coarse node carries `k` unknowns;
/// 4. the smoothed prolongator `P = (I - omega D_F^-1 A_F) T`, `A_F` the
///    filtered matrix (weak blocks lumped onto the diagonal) and
///    `omega = 4/3 / rho(D_F^-1 A_F)`;
/// 5. the Galerkin operator `A_{l+1} = P^T A_l P`, in block storage;
///
/// until a level has at most `coarse_size` unknowns, which is solved by a
/// dense Cholesky factorisation (a matrix that small from the start is just
/// that direct solve; a level whose aggregation stalls becomes the coarsest,
/// factored if it has at most 3000 unknowns, else only smoothed). Nodes
/// without strong neighbours join no aggregate and are left to the smoother. [`Amg::apply`](crate::Preconditioner::apply)
/// is one V-cycle from a zero guess with block damped-Jacobi (or symmetric
/// block Gauss-Seidel, or block IC(0)) smoothing; the post-smoother is the
/// adjoint of the pre-smoother, so the V-cycle is a symmetric positive
/// definite operator and PCG and filtered PCG stay valid. The kernels of
/// every level run row-parallel on rayon's pool (the Gauss-Seidel and IC(0)
/// sweeps excepted), with results independent of the thread count.
///
/// # Re-use
/// [`PreconditionerSetup::setup`] with a matrix of the same sparsity pattern
/// as the last one (the same `Arc<BlockPattern>`, or equal CSR index arrays)
/// does what [`AmgOptions::reuse`] says ([`AmgReuse`]):
/// - `Refill` (default): strength, aggregates, the tentative prolongator and
///   every pattern are kept, and only the numbers (smoothers, `omega`, `P`,
///   the Galerkin products, the coarsest factor) are recomputed, without
///   allocating; the spectral radius estimates are kept (by default) or
///   continue the power method from the last eigenvectors for
///   `refill_power_iterations` steps. With
///   [`AmgOptions::keep_prolongators`] a refill keeps the prolongators too
///   and recomputes only the smoothers, the Galerkin operators and the
///   coarsest factor.
/// - `Keep { updates }`: the next `updates` calls leave the whole hierarchy
///   as it is (a lagged preconditioner, still SPD, so CG stays valid); the
///   call after them refills.
/// - `Rebuild`: a full set-up every time.
///
/// A full set-up is redone whenever the pattern (or the block size)
/// changes, when the last set-up failed, on [`Amg::rebuild`] (e.g. when
/// the values changed so much that the old aggregates no longer fit), and
/// with `Rebuild`. The measured costs of each choice are in
/// docs/PERFORMANCE.md (`cargo bench -p hookean-sparse --bench amg`).
///
/// # Example
/// ```
/// use hookean_sparse::{Amg, CgParams, CgWorkspace, PreconditionerSetup, pcg};
/// use std::sync::Arc;
/// use hookean_sparse::{BlockPattern, SymBlockMatrix, block};
/// // A chain of 2000 particles joined by springs, plus a small mass.
/// let n = 2000;
/// let pattern = Arc::new(BlockPattern::new(n, (1..n).map(|i| (i - 1, i)))?);
/// let mut a = SymBlockMatrix::new(pattern);
/// for i in 1..n {
///     a.add_to_block(i - 1, i - 1, &block::IDENTITY)?;
///     a.add_to_block(i, i, &block::IDENTITY)?;
///     a.add_to_block(i - 1, i, &block::scale(&block::IDENTITY, -1.0))?;
/// }
/// a.add_to_diagonal(&vec![1e-4; 3 * n])?;
/// let mut amg = Amg::new();
/// amg.setup(&a)?;
/// assert!(amg.stats().levels.len() > 1);
/// let b = vec![1.0; 3 * n];
/// let mut x = vec![0.0; 3 * n];
/// let info = pcg(&a, &amg, &b, &mut x, &CgParams::default(), &mut CgWorkspace::new(3 * n), None)?;
/// assert!(info.converged && info.iterations < 30);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Clone)]
pub struct Amg {
    options: AmgOptions,
    inner: Inner,
    stats: AmgStats,
    /// Calls of `setup` kept since the last set-up or refill.
    kept_in_a_row: usize,
    /// The matrix of the last full set-up from a [`SymBlockMatrix`], kept
    /// (unless [`AmgReuse::Rebuild`]) because a refill reuses what was built
    /// from it: [`built_from`](Amg::built_from).
    built_from: Option<SymBlockMatrix>,
    /// Whether the last set-up that changed the hierarchy was a refill
    /// (not a full set-up): [`last_setup_refilled`](Amg::last_setup_refilled).
    last_refilled: bool,
    /// With [`AmgReuse::Keep`], the matrix of the last refill, whose
    /// hierarchy the kept set-ups go on using: [`refilled_from`](Amg::refilled_from).
    refilled_from: Option<SymBlockMatrix>,
}

impl Default for Amg {
    fn default() -> Self {
        Self::new()
    }
}

impl Amg {
    /// An empty preconditioner with default options; call
    /// [`setup`](PreconditionerSetup::setup) before use.
    pub fn new() -> Self {
        Self {
            options: AmgOptions::default(),
            inner: Inner::Empty,
            stats: AmgStats::default(),
            kept_in_a_row: 0,
            built_from: None,
            last_refilled: false,
            refilled_from: None,
        }
    }

    /// An empty preconditioner with the given options.
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] for an option out of range.
    pub fn with_options(options: AmgOptions) -> Result<Self, SparseError> {
        let bad = |name: &'static str, message: String| {
            Err(SparseError::InvalidParameter { name, message })
        };
        let o = &options;
        if !(0.0..1.0).contains(&o.strength_threshold) {
            return bad(
                "strength_threshold",
                format!("{} is outside [0, 1)", o.strength_threshold),
            );
        }
        for (name, value, lo, hi) in [
            ("sweeps", o.sweeps, 1, AMG_MAX_SWEEPS),
            ("coarse_size", o.coarse_size, 1, AMG_MAX_COARSE_SIZE),
            ("max_levels", o.max_levels, 1, AMG_MAX_LEVELS),
            ("power_iterations", o.power_iterations, 0, AMG_MAX_SWEEPS),
            (
                "refill_power_iterations",
                o.refill_power_iterations,
                0,
                AMG_MAX_SWEEPS,
            ),
        ] {
            if !(lo..=hi).contains(&value) {
                return bad(name, format!("{value} is outside {lo} to {hi}"));
            }
        }
        if !(1..=3).contains(&o.block_size) {
            return bad("block_size", format!("{} is not 1, 2 or 3", o.block_size));
        }
        for (name, w) in [
            ("jacobi_weight", o.jacobi_weight),
            ("prolongation_weight", o.prolongation_weight),
        ] {
            if !(w > 0.0 && w < 2.0) {
                return bad(name, format!("{w} is outside (0, 2)"));
            }
        }
        Ok(Self {
            options,
            inner: Inner::Empty,
            stats: AmgStats::default(),
            kept_in_a_row: 0,
            built_from: None,
            last_refilled: false,
            refilled_from: None,
        })
    }

    /// The options.
    pub fn options(&self) -> &AmgOptions {
        &self.options
    }

    /// Statistics of the current hierarchy (empty before the first set-up).
    pub fn stats(&self) -> &AmgStats {
        &self.stats
    }

    /// A full set-up of `a`, even if its pattern is the one of the last
    /// set-up (new strength graph and aggregates for the new values).
    ///
    /// # Errors
    /// As [`setup`](PreconditionerSetup::setup).
    pub fn rebuild<A: ?Sized>(&mut self, a: &A) -> Result<(), SparseError>
    where
        Self: PreconditionerSetup<A>,
    {
        self.inner = Inner::Empty;
        self.setup(a)
    }

    /// What `setup` does for a matrix whose pattern is (`same`) or is not
    /// the hierarchy's: `None` keeps the hierarchy, `Some(true)` refills,
    /// `Some(false)` builds it afresh.
    fn plan(&mut self, same: bool) -> Option<bool> {
        if !same {
            return Some(false);
        }
        match self.options.reuse {
            AmgReuse::Rebuild => Some(false),
            AmgReuse::Keep { updates } if self.kept_in_a_row < updates => {
                self.kept_in_a_row += 1;
                self.stats.kept += 1;
                None
            }
            AmgReuse::Refill | AmgReuse::Keep { .. } => Some(true),
        }
    }

    /// The near-nullspace vectors the hierarchy takes: `K` of them on nodes
    /// of `block_size` unknowns (the translations when none are given).
    fn vectors(&self, block_size: usize) -> usize {
        match self.options.near_nullspace.len() {
            0 => block_size,
            k => k,
        }
    }

    fn record(&mut self, h: &Levels, seconds: f64, refill: bool) {
        if refill {
            self.stats.refill_seconds = seconds;
            self.stats.refills += 1;
            h.update_weights(&mut self.stats.levels);
            return;
        }
        let levels: Vec<AmgLevelStats> = h.level_stats();
        let (rows0, nnz0) = (levels[0].rows as f64, levels[0].nonzeros as f64);
        self.stats.operator_complexity =
            levels.iter().map(|l| l.nonzeros as f64).sum::<f64>() / nnz0;
        self.stats.grid_complexity = levels.iter().map(|l| l.rows as f64).sum::<f64>() / rows0;
        self.stats.levels = levels;
        self.stats.coarsest_direct = h.coarsest_direct();
        self.stats.setup_seconds = seconds;
        self.stats.setups += 1;
    }

    /// Runs `f` on the hierarchy, dropping it when `f` fails (so the next
    /// set-up starts afresh).
    fn finish(&mut self, start: Instant, refill: bool) {
        self.kept_in_a_row = 0;
        self.last_refilled = refill;
        let seconds = start.elapsed().as_secs_f64();
        match std::mem::replace(&mut self.inner, Inner::Empty) {
            Inner::Block { source, map, h } => {
                self.record(&h, seconds, refill);
                self.inner = Inner::Block { source, map, h };
            }
            Inner::Csr(c) => {
                self.record(&c.h, seconds, refill);
                self.inner = Inner::Csr(c);
            }
            Inner::Empty => {}
        }
    }
}

/// The error for `k` near-nullspace vectors on nodes of `b` unknowns.
fn unsupported(b: usize, k: usize) -> SparseError {
    SparseError::InvalidParameter {
        name: "near_nullspace",
        message: format!(
            "{k} vectors on nodes of {b} unknowns; the multigrid takes {SUPPORTED} (the coarse nodes carry one unknown per vector)"
        ),
    }
}

/// The full-storage pattern of a symmetric block matrix and, for every slot,
/// the stored block it copies (`true`: transposed, the slot is below the diagonal).
fn full_pattern(p: &BlockPattern) -> (Bsr<3>, Vec<(u32, bool)>) {
    let n = p.n_blocks();
    let (row_ptr, cols) = (p.row_ptr(), p.col_idx());
    let mut lower = vec![0usize; n];
    for &j in cols {
        lower[j as usize] += 1;
    }
    // `lower` counted the diagonal once per row too.
    let mut full_ptr = vec![0usize; n + 1];
    for i in 0..n {
        full_ptr[i + 1] = full_ptr[i] + (lower[i] - 1) + (row_ptr[i + 1] - row_ptr[i]);
    }
    let nnz = full_ptr[n];
    let mut col = vec![0u32; nnz];
    let mut map = vec![(0u32, false); nnz];
    let mut next_lower: Vec<usize> = full_ptr[..n].to_vec();
    for i in 0..n {
        // Diagonal and upper blocks go after the row's lower blocks.
        let first = full_ptr[i] + lower[i] - 1;
        for (p, s) in (first..).zip(row_ptr[i]..row_ptr[i + 1]) {
            let j = cols[s] as usize;
            col[p] = j as u32;
            map[p] = (s as u32, false);
            if j != i {
                // Block (j, i) = stored (i, j)^T, in row j, where rows i
                // arrive in increasing order: sorted.
                let q = next_lower[j];
                next_lower[j] += 1;
                col[q] = i as u32;
                map[q] = (s as u32, true);
            }
        }
    }
    let a = Bsr {
        nrows: n,
        ncols: n,
        row_ptr: full_ptr,
        col,
        val: vec![zero::<3, 3>(); nnz],
    };
    (a, map)
}

impl PreconditionerSetup<SymBlockMatrix> for Amg {
    fn setup(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        let start = Instant::now();
        let same = matches!(&self.inner, Inner::Block { source, .. }
            if Arc::ptr_eq(source, a.pattern()) || **source == **a.pattern());
        let Some(refill) = self.plan(same) else {
            return Ok(());
        };
        let result = match &mut self.inner {
            Inner::Block { map, h, .. } if refill => h.refill(&Source::Blocks(map, a)),
            _ => {
                let (fine, map) = full_pattern(a.pattern());
                let source = Source::Blocks(&map, a);
                let (o, n) = (&self.options, a.n_blocks());
                let built = match self.vectors(3) {
                    3 => nullspace_blocks::<3, 3>(&o.near_nullspace, n)
                        .and_then(|ns| Levels::new(&fine, &source, ns, o)),
                    6 => nullspace_blocks::<3, 6>(&o.near_nullspace, n)
                        .and_then(|ns| Levels::new(&fine, &source, ns, o)),
                    k => Err(unsupported(3, k)),
                };
                built.map(|h| {
                    self.inner = Inner::Block {
                        source: a.pattern().clone(),
                        map,
                        h,
                    };
                    // Kept only when a refill reuses it (a full set-up
                    // allocates anyway; a refill copies nothing).
                    if self.options.reuse != AmgReuse::Rebuild {
                        match &mut self.built_from {
                            Some(b) if Arc::ptr_eq(b.pattern(), a.pattern()) => {
                                b.values_mut().copy_from_slice(a.values());
                            }
                            b => *b = Some(a.clone()),
                        }
                    }
                })
            }
        };
        if let Err(e) = result {
            self.inner = Inner::Empty;
            return Err(e);
        }
        if refill {
            self.keep_refill_matrix(a);
        }
        self.finish(start, refill);
        Ok(())
    }
}

impl PreconditionerSetup<sprs::CsMat<f64>> for Amg {
    /// AMG on a symmetric positive definite CSR or CSC matrix (CSC is
    /// converted, which allocates), with [`AmgOptions::block_size`]
    /// unknowns per node.
    fn setup(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let start = Instant::now();
        square_dim(a)?;
        let a = &*as_csr(a);
        if let Some(k) = a.data().iter().position(|v| !v.is_finite()) {
            return Err(SparseError::NonFinite {
                what: "matrix",
                index: Some(k),
            });
        }
        let same = match &self.inner {
            Inner::Csr(c) => c.same_pattern(a, self.options.block_size),
            _ => false,
        };
        if !same {
            super::check_both_triangles(&a.proper_indptr(), a.indices(), "AMG")?;
        }
        let Some(refill) = self.plan(same) else {
            return Ok(());
        };
        let refill = match &mut self.inner {
            Inner::Csr(c) if refill => Some(c.refill(a)),
            _ => None,
        };
        let refilled = refill.is_some();
        let result = match refill {
            Some(r) => r,
            None => {
                let (b, k) = (
                    self.options.block_size,
                    self.vectors(self.options.block_size),
                );
                with_block_sizes!(b, k, B, K => CsrLevels::new::<B, K>(a, &self.options),
                    _ => Err(unsupported(b, k)))
                .map(|c| {
                    self.inner = Inner::Csr(c);
                    self.built_from = None;
                })
            }
        };
        if let Err(e) = result {
            self.inner = Inner::Empty;
            return Err(e);
        }
        self.finish(start, refilled);
        Ok(())
    }
}

impl Preconditioner for Amg {
    /// A V-cycle costs about three products with `A`: CG does not apply it
    /// in the iteration it predicts to be its last.
    fn costly(&self) -> bool {
        true
    }

    fn dim(&self) -> Option<usize> {
        Some(match &self.inner {
            Inner::Empty => 0,
            Inner::Block { h, .. } => h.dim(),
            Inner::Csr(c) => c.h.dim(),
        })
    }

    fn apply(&self, r: &[f64], z: &mut [f64]) {
        match &self.inner {
            Inner::Empty => z.copy_from_slice(r),
            Inner::Block { h, .. } => h.apply(r, z),
            Inner::Csr(c) => c.h.apply(r, z),
        }
    }

    /// One V-cycle and `r . z`, fused with the cycle's last pass.
    fn apply_dot(&self, r: &[f64], z: &mut [f64]) -> f64 {
        match &self.inner {
            Inner::Empty => {
                z.copy_from_slice(r);
                crate::vecops::dot(r, z)
            }
            Inner::Block { h, .. } => h.apply_dot(r, z),
            Inner::Csr(c) => c.h.apply_dot(r, z),
        }
    }

    /// CG's `r -= alpha q`, `z = M^-1 r`, `(r . r, r . z)`: the update and
    /// the sums fused with the V-cycle's finest passes.
    fn update_and_apply(&self, alpha: f64, q: &[f64], r: &mut [f64], z: &mut [f64]) -> (f64, f64) {
        match &self.inner {
            Inner::Empty => {
                for (ri, qi) in r.iter_mut().zip(q) {
                    *ri -= alpha * qi;
                }
                z.copy_from_slice(r);
                let rr = crate::vecops::dot(r, r);
                (rr, rr)
            }
            Inner::Block { h, .. } => h.update_and_apply(alpha, q, r, z),
            Inner::Csr(c) => c.h.update_and_apply(alpha, q, r, z),
        }
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod nullspace_tests;
