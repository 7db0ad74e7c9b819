//! Forces and Jacobians: the hot loops, and the
//! [`SecondOrderProblem`] implementation.
//!
//! Spring `(i, j, l0, k, d)`, `u = (x_j - x_i) / l`, `l = |x_j - x_i|`,
//! `dv = v_j - v_i` (docs/ARCHITECTURE.md):
//!
//! - force on `i`: `f_i = k (l - l0) u + d (dv . u) u` (projected damping)
//!   or `+ d dv` (incorrect damping); `f_j = -f_i`;
//! - stiffness block `K_ij = df_i/dx_j = k [ a (I - u u^T) + u u^T ]`,
//!   `a = 1 - l0/l` (exact) or `max(0, 1 - l0/l)` (clamped),
//!   `df_i/dx_i = -sum_j K_ij`;
//! - damping blocks `df_i/dv_j = d u u^T` (projected) or `d I` (incorrect);
//! - projected damping's position derivative
//!   `G = d/l [ (u . dv)(I - u u^T) + u w^T ]`, `w = (I - u u^T) dv`, which
//!   enters `df_i/dx_j` and `df_j/dx_i` alike (not transposed): see
//!   [`DampingInDfdx`] and [`MassSpringModel::dfdx_exact`].

use std::sync::Arc;

use hookean_problem::SecondOrderProblem;
use hookean_sparse::block::{self, Block3};
use hookean_sparse::{BlockPattern, Constraints, IsoBlockMatrix, Slot, SymBlockMatrix};
use nalgebra::Vector3;

use crate::error::MassSpringError;
use crate::model::{DampingInDfdx, MassSpringModel, Spring, SpringDamping, point};

/// `k [ a I + (1 - a) u u^T ]` = `k [ a (I - u u^T) + u u^T ]`.
#[inline(always)]
fn stiffness_block(k: f64, a: f64, u: &Vector3<f64>) -> Block3 {
    let b = k * (1.0 - a);
    let c = k * a;
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for s in 0..3 {
            m[r][s] = b * u[r] * u[s];
        }
        m[r][r] += c;
    }
    m
}

/// `G = d/l [ (u . dv)(I - u u^T) + u w^T ]`, `w = dv - (u . dv) u`.
#[inline(always)]
fn damping_position_block(d: f64, l: f64, u: &Vector3<f64>, dv: &Vector3<f64>) -> Block3 {
    let s = d / l;
    let ud = u.dot(dv);
    let w = dv - u * ud;
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let delta = if r == c { 1.0 } else { 0.0 };
            m[r][c] = s * (ud * (delta - u[r] * u[c]) + u[r] * w[c]);
        }
    }
    m
}

#[inline(always)]
fn matmul(a: &Block3, b: &Block3) -> Block3 {
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c];
        }
    }
    m
}

#[inline(always)]
fn neg(a: &Block3) -> Block3 {
    block::scale(a, -1.0)
}

/// The 6 unique entries of a symmetric block.
#[inline(always)]
fn sym6(b: &Block3) -> [f64; 6] {
    [b[0][0], b[0][1], b[0][2], b[1][1], b[1][2], b[2][2]]
}

/// The symmetric block of 6 unique entries.
#[inline(always)]
fn unsym6(a: &[f64]) -> Block3 {
    [[a[0], a[1], a[2]], [a[1], a[3], a[4]], [a[2], a[4], a[5]]]
}

/// Writes a spring's symmetric block `b` (`df_i/dx_j`, before projection,
/// given by its 6 unique entries `b6`):
/// the off-diagonal block is assigned (first spring of its pair) or added,
/// and `-b` (projected: `-P_i b P_i`, `-P_j b P_j`) is accumulated into the
/// diagonal accumulators at offset `at` (0: `df/dx`, 6: `df/dv`): `loc` of
/// the row's particle `min(i, j)`, `acc_c` of the other one.
#[inline(always)]
fn scatter_sym(
    vals: &mut [Block3],
    base: usize,
    loc: &mut [f64; 12],
    acc_c: &mut [f64; 12],
    at: usize,
    h: &HotSpring,
    constrained: bool,
    proj: &[Block3],
    b6: &[f64; 6],
) {
    let (i, j) = (h.i as usize, h.j as usize);
    let (off, di, dj) = if constrained {
        let b = &unsym6(b6);
        let (pi, pj) = (&proj[i], &proj[j]);
        let pb = matmul(pi, b);
        let off = matmul(&pb, pj);
        (
            off,
            sym6(&matmul(&pb, pi)),
            sym6(&matmul(&matmul(pj, b), pj)),
        )
    } else {
        (unsym6(b6), *b6, *b6)
    };
    if h.first {
        vals[h.upper as usize - base] = off;
    } else {
        let t = &mut vals[h.upper as usize - base];
        for r in 0..3 {
            for c in 0..3 {
                t[r][c] += off[r][c];
            }
        }
    }
    // The row's own particle is i < j.
    let (dr, dc) = (di, dj);
    for t in 0..6 {
        loc[at + t] -= dr[t];
        acc_c[at + t] -= dc[t];
    }
}

/// A spring's damping block `df_i/dv_j` by its 6 unique entries: `d u u^T`
/// (projected damping, from `u u^T` in `uu`), `d I` (the incorrect law) or 0.
#[inline(always)]
fn damping_block6<const DAMP: u8>(d: f64, uu: &[f64; 6]) -> [f64; 6] {
    match DAMP {
        DAMP_PROJECTED => uu.map(|w| d * w),
        DAMP_INCORRECT => [d, 0.0, 0.0, d, 0.0, d],
        _ => [0.0; 6],
    }
}

/// Springs per chunk of [`ChunkGeometry`].
pub(crate) const CHUNK: usize = 8;

/// The geometry of a chunk of springs in structure-of-arrays form: the
/// square roots and divisions of a chunk are independent and vectorise
/// (`sqrtpd` / `divpd`) instead of serialising the spring loop.
struct ChunkGeometry {
    e: [[f64; CHUNK]; 3],
    l: [f64; CHUNK],
    inv_l: [f64; CHUNK],
}

impl ChunkGeometry {
    fn new() -> Self {
        Self {
            e: [[1.0; CHUNK]; 3],
            l: [1.0; CHUNK],
            inv_l: [1.0; CHUNK],
        }
    }

    /// `e = x_j - x_i`, `l = |e|`, `1 / l` for every spring of `chunk`.
    #[inline(always)]
    fn compute(&mut self, x: &[[f64; 3]], chunk: &[HotSpring]) {
        for (k, h) in chunk.iter().enumerate() {
            let (xi, xj) = (&x[h.i as usize], &x[h.j as usize]);
            for r in 0..3 {
                self.e[r][k] = xj[r] - xi[r];
            }
        }
        for k in 0..CHUNK {
            let l2 = self.e[0][k] * self.e[0][k]
                + self.e[1][k] * self.e[1][k]
                + self.e[2][k] * self.e[2][k];
            self.l[k] = l2.sqrt();
            self.inv_l[k] = 1.0 / self.l[k];
        }
    }

    #[inline(always)]
    fn get(&self, k: usize) -> (Vector3<f64>, f64, f64) {
        (
            Vector3::new(self.e[0][k], self.e[1][k], self.e[2][k]),
            self.l[k],
            self.inv_l[k],
        )
    }
}

/// Diagonal accumulator of one particle: the 6 unique entries of the
/// symmetric diagonal block of `df/dx`, then of `df/dv`.
pub(crate) type Acc = [f64; 12];

/// [`SpringDamping`] as a const generic parameter.
const DAMP_NONE: u8 = 0;
const DAMP_PROJECTED: u8 = 1;
const DAMP_INCORRECT: u8 = 2;

const fn damp_code(d: SpringDamping) -> u8 {
    match d {
        SpringDamping::None => DAMP_NONE,
        SpringDamping::Projected => DAMP_PROJECTED,
        SpringDamping::Incorrect => DAMP_INCORRECT,
    }
}

/// The outputs of one assembly sweep over block rows `rows` (empty slices
/// for parts not computed): `f` and `acc` hold exactly those rows, `vx` and
/// `vv` their stored blocks (value index `base` first). Contributions to
/// particles past the rows go to `halo` (particle `rows.end + k` at `k`).
struct Outputs<'a> {
    f: &'a mut [f64],
    vx: &'a mut [Block3],
    vv: &'a mut [Block3],
    acc: &'a mut [Acc],
    rows: std::ops::Range<usize>,
    base: usize,
    halo: &'a mut [Halo],
}

impl<'a> Outputs<'a> {
    /// Splits at block row `r` (inside `rows`) and at part `k` of the halo
    /// parts of `bw` entries each.
    fn split(self, r: usize, starts: (usize, usize), k: usize, bw: usize) -> (Self, Self) {
        let s = self.rows.start;
        let f_at = if self.f.is_empty() { 0 } else { 3 * (r - s) };
        let (f0, f1) = self.f.split_at_mut(f_at);
        let v_at = starts.1 - starts.0;
        let (x0, x1) = self
            .vx
            .split_at_mut(if self.vx.is_empty() { 0 } else { v_at });
        let (v0, v1) = self
            .vv
            .split_at_mut(if self.vv.is_empty() { 0 } else { v_at });
        let (a0, a1) = self
            .acc
            .split_at_mut(if self.acc.is_empty() { 0 } else { r - s });
        let (h0, h1) = self.halo.split_at_mut(k * bw);
        (
            Outputs {
                f: f0,
                vx: x0,
                vv: v0,
                acc: a0,
                rows: s..r,
                base: self.base,
                halo: h0,
            },
            Outputs {
                f: f1,
                vx: x1,
                vv: v1,
                acc: a1,
                rows: r..self.rows.end,
                base: starts.1,
                halo: h1,
            },
        )
    }
}

/// What a part of the threaded sweep adds to a particle of a later part:
/// its diagonal accumulator and force.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Halo {
    acc: Acc,
    f: [f64; 3],
}

/// One assembly sweep as a [`pulp::WithSimd`] operation, so that it can be
/// compiled for the instruction set the CPU offers (checked at run time by
/// `pulp::Arch::dispatch`) without `unsafe` here.
struct Sweep<
    'm,
    'o,
    const F: bool,
    const DV: bool,
    const DAMP: u8,
    const DDX: bool,
    const JAC: bool = true,
    const FUSED: bool = false,
> {
    model: &'m MassSpringModel,
    x: &'m [f64],
    v: &'m [f64],
    out: Outputs<'o>,
    clamp_floor: f64,
    fast: bool,
    comb: Combination<'m>,
}

/// The one-sweep Newton matrix `A = M + a df/dx + b df/dv` (a sweep with
/// `FUSED` writes it into `vx`; otherwise unused).
#[derive(Debug, Clone, Copy)]
struct Combination<'m> {
    a: f64,
    b: f64,
    mass: &'m [f64],
}

impl Combination<'_> {
    const NONE: Combination<'static> = Combination {
        a: 0.0,
        b: 0.0,
        mass: &[],
    };
}

impl<
    const F: bool,
    const DV: bool,
    const DAMP: u8,
    const DDX: bool,
    const JAC: bool,
    const FUSED: bool,
> pulp::WithSimd for Sweep<'_, '_, F, DV, DAMP, DDX, JAC, FUSED>
{
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        self.model.sweep::<F, DV, DAMP, DDX, JAC, FUSED>(
            self.x,
            self.v,
            self.out,
            self.clamp_floor,
            self.fast,
            self.comb,
        );
    }
}

/// Runs `op` compiled for the best instruction set of this CPU (AVX2 on
/// x86-64 when present; about 5% faster than the SSE2 baseline on the
/// 128 x 128 cloth, see docs/perf/hookean-massspring.md).
#[inline(always)]
fn run_sweep<W: pulp::WithSimd<Output = ()>>(op: W) {
    pulp::Arch::new().dispatch(op)
}

/// Which parts a private assembly call computes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct AssemblyMode {
    pub(crate) clamp: bool,
    pub(crate) damping_in_dfdx: DampingInDfdx,
}
/// The cached storage slots of one spring's three blocks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SpringSlots {
    pub(crate) ii: Slot,
    pub(crate) jj: Slot,
    pub(crate) ij: Slot,
}

/// A spring prepared for the hot loops: springs are kept in the storage
/// order of their upper block, so that assembly writes the off-diagonal
/// blocks sequentially. Oriented `i < j` (the force law and the symmetric
/// Jacobian blocks do not depend on the orientation); 40 bytes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct HotSpring {
    pub(crate) i: u32,
    pub(crate) j: u32,
    /// Index of the stored upper block `(min, max)` in the value array.
    pub(crate) upper: u32,
    pub(crate) rest_length: f64,
    pub(crate) stiffness: f64,
    pub(crate) damping: f64,
    /// Whether this spring is the first (in storage order) of its block:
    /// it assigns the block, later springs of the same pair add to it.
    pub(crate) first: bool,
}

/// Per-particle diagonal accumulators of assembly (the 6 unique entries of
/// the symmetric diagonal block of `df/dx`, then of `df/dv`), kept contiguous so that the
/// scatter to the second endpoint of a spring hits a compact array. All
/// zeros between calls (each row zeroes its entry when it writes its
/// diagonal blocks). Behind a mutex because the `SecondOrderProblem` methods
/// take `&self`; a concurrent second caller (or any caller after a panic
/// poisoned the mutex) falls back to a temporary zeroed buffer.
/// The second vector holds the halos of the threaded sweep (all zeros
/// between calls too), grown on the first threaded call.
#[derive(Debug, Default)]
pub(crate) struct DiagScratch(pub(crate) std::sync::Mutex<(Vec<Acc>, Vec<Halo>)>);

impl Clone for DiagScratch {
    fn clone(&self) -> Self {
        let n = self.0.lock().map(|v| v.0.len()).unwrap_or(0);
        DiagScratch(std::sync::Mutex::new((vec![[0.0; 12]; n], Vec::new())))
    }
}

/// Where the assembly sweep writes each spring's blocks: the Jacobian
/// pattern of a spring set and the positions of its blocks in the value
/// array, built once from `hookean-sparse`'s public slot API (the storage
/// layout is that crate's business), plus the per-row fast-path flags that
/// the step's constraints switch.
#[derive(Debug, Clone)]
pub(crate) struct AssemblyPlan {
    pub(crate) pattern: Arc<BlockPattern>,
    pub(crate) slots: Vec<SpringSlots>,
    pub(crate) diag_slots: Vec<Slot>,
    /// The springs in storage order of their upper block.
    pub(crate) hot: Vec<HotSpring>,
    /// `hot[hot_row_ptr[r]..hot_row_ptr[r + 1]]` are the springs whose
    /// upper block lies in block row `r = min(i, j)`.
    pub(crate) hot_row_ptr: Vec<usize>,
    /// Value index of each diagonal block.
    pub(crate) diag_index: Vec<usize>,
    /// Whether block row `r` takes the fast assembly path: no spring of the
    /// row, nor its diagonal, touches a constrained particle (kept up to
    /// date through [`mark_rows_of`](Self::mark_rows_of)).
    pub(crate) row_fast: Vec<bool>,
    /// `touch_rows[touch_ptr[p]..touch_ptr[p + 1]]` are the block rows whose
    /// springs or diagonal touch particle `p` (`p` itself and the rows
    /// `min(i, j)` of its springs).
    pub(crate) touch_ptr: Vec<usize>,
    /// See `touch_ptr`.
    pub(crate) touch_rows: Vec<u32>,
    /// `max (j - i)` over the stored blocks: how far past its rows a part
    /// of the threaded sweep scatters.
    pub(crate) bandwidth: usize,
    pub(crate) diag_acc: DiagScratch,
}

impl AssemblyPlan {
    /// The plan of `springs` (already checked) on `n` particles.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] when a storage position does not
    /// fit the 32-bit tables; the pattern's errors.
    pub(crate) fn new(n: usize, springs: &[Spring]) -> Result<Self, MassSpringError> {
        let pattern = Arc::new(BlockPattern::new(n, springs.iter().map(|s| (s.i, s.j)))?);
        let probe = SymBlockMatrix::new(pattern.clone());
        let slots = springs
            .iter()
            .map(|s| {
                Ok(SpringSlots {
                    ii: probe.slot(s.i, s.i)?,
                    jj: probe.slot(s.j, s.j)?,
                    ij: probe.slot(s.i, s.j)?,
                })
            })
            .collect::<Result<Vec<_>, hookean_sparse::SparseError>>()?;
        let diag_slots = (0..n)
            .map(|p| probe.slot(p, p))
            .collect::<Result<Vec<_>, _>>()?;
        // The pattern's column indices are u32, so particle indices fit;
        // storage positions (from the pattern's slots) are checked.
        let to_u32 = |k: usize| {
            u32::try_from(k).map_err(|_| MassSpringError::InvalidParameter {
                name: "springs",
                message: format!("index {k} does not fit the 32-bit assembly tables"),
            })
        };
        let mut hot: Vec<HotSpring> = Vec::with_capacity(springs.len());
        for s in springs {
            let (r, c) = (s.i.min(s.j), s.i.max(s.j));
            let upper = pattern
                .find(r, c)
                .ok_or(hookean_sparse::SparseError::NotInPattern { row: r, col: c })?;
            hot.push(HotSpring {
                i: to_u32(r)?,
                j: to_u32(c)?,
                rest_length: s.rest_length,
                stiffness: s.stiffness,
                damping: s.damping,
                upper: to_u32(upper.index())?,
                first: false,
            });
        }
        hot.sort_by_key(|h| h.upper);
        for k in 0..hot.len() {
            hot[k].first = k == 0 || hot[k - 1].upper != hot[k].upper;
        }
        let diag_index = diag_slots.iter().map(Slot::index).collect();
        let bandwidth = (0..n)
            .map(|r| pattern.col_idx()[pattern.row_ptr()[r + 1] - 1] as usize - r)
            .max()
            .unwrap_or(0);
        let mut hot_row_ptr = vec![0usize; n + 1];
        for h in &hot {
            hot_row_ptr[h.i as usize + 1] += 1;
        }
        for r in 0..n {
            hot_row_ptr[r + 1] += hot_row_ptr[r];
        }
        let mut touch_ptr = vec![1usize; n + 1];
        touch_ptr[0] = 0;
        for h in &hot {
            touch_ptr[h.j as usize + 1] += 1;
        }
        for p in 0..n {
            touch_ptr[p + 1] += touch_ptr[p];
        }
        let mut touch_rows = vec![0u32; touch_ptr[n]];
        let mut fill = touch_ptr.clone();
        for p in 0..n {
            touch_rows[fill[p]] = to_u32(p)?;
            fill[p] += 1;
        }
        for h in &hot {
            let hi = h.j as usize;
            touch_rows[fill[hi]] = h.i;
            fill[hi] += 1;
        }
        Ok(Self {
            pattern,
            slots,
            diag_slots,
            hot,
            hot_row_ptr,
            diag_index,
            row_fast: vec![true; n],
            touch_ptr,
            touch_rows,
            bandwidth,
            diag_acc: DiagScratch(std::sync::Mutex::new((vec![[0.0; 12]; n], Vec::new()))),
        })
    }

    /// Sets the fast-path flag of every block row that touches particle `p`.
    pub(crate) fn mark_rows_of(&mut self, p: usize, fast: bool) {
        for &r in &self.touch_rows[self.touch_ptr[p]..self.touch_ptr[p + 1]] {
            self.row_fast[r as usize] = fast;
        }
    }
}

impl MassSpringModel {
    /// Gravity, external forces and air friction: the per-particle part of `f`.
    fn init_force(&self, v: &[f64], f: &mut [f64]) {
        let g = self.options.gravity;
        let c = self.options.air_friction;
        for (p, &m) in self.particle_mass.iter().enumerate() {
            for r in 0..3 {
                f[3 * p + r] = m * g[r] + self.external[3 * p + r] - c * v[3 * p + r];
            }
        }
    }

    /// `f(x, v)` into `f`: gravity, external forces, air friction, springs,
    /// then `f_p <- P_p f_p` for constrained particles. No allocation
    /// (unless another thread evaluates the same model concurrently).
    ///
    /// The springs go through the assembly's sweep without its Jacobian
    /// half, so the force has the fused sweep's bits for every thread count
    /// (threaded: the SpMV's row parts and their halos, added in part order).
    pub(crate) fn eval_force(&self, x: &[f64], v: &[f64], f: &mut [f64]) {
        let n = self.n_particles();
        assert!(
            x.len() == 3 * n && v.len() == 3 * n && f.len() == 3 * n,
            "force: x, v and f must have length 3 n = {}",
            3 * n
        );
        self.init_force(v, f);
        let parts = hookean_sparse::par::parts_for(n);
        let bw = self.plan.bandwidth;
        let mut guard = self.plan.diag_acc.0.try_lock();
        let mut local: Vec<Halo> = Vec::new();
        let halo_buf = match guard.as_deref_mut() {
            Ok(buf) => &mut buf.1,
            Err(_) => &mut local,
        };
        if parts > 1 && halo_buf.len() < parts * bw {
            halo_buf.resize(parts * bw, Halo::default());
        }
        let out = Outputs {
            f: &mut f[..],
            vx: &mut [],
            vv: &mut [],
            acc: &mut [],
            rows: 0..n,
            base: 0,
            halo: if parts > 1 {
                &mut halo_buf[..parts * bw]
            } else {
                &mut []
            },
        };
        macro_rules! force_sweep {
            ($dm:ident) => {
                Self::sweep_parts(
                    Sweep::<'_, '_, true, false, { damp_code(SpringDamping::$dm) }, false, false> {
                        model: self,
                        x,
                        v,
                        out,
                        clamp_floor: 0.0,
                        fast: true,
                        comb: Combination::NONE,
                    },
                    0,
                    parts.max(1),
                    parts,
                )
            };
        }
        match self.options.damping {
            SpringDamping::Projected => force_sweep!(Projected),
            SpringDamping::Incorrect => force_sweep!(Incorrect),
            SpringDamping::None => force_sweep!(None),
        }
        if parts > 1 {
            // The halos' forces, added in part order, and zeroed.
            let f3 = f.as_chunks_mut::<3>().0;
            for t in 0..parts {
                let e = self.plan.pattern.part_start(t + 1, parts);
                for (k, h) in halo_buf[t * bw..(t + 1) * bw].iter_mut().enumerate() {
                    let j = e + k;
                    if j >= n {
                        break;
                    }
                    for q in 0..3 {
                        f3[j][q] += h.f[q];
                    }
                    *h = Halo::default();
                }
            }
        }
        self.add_contact_forces(x, v, f);
        self.project_rows(f);
    }

    /// `f_p <- P_p f_p` for the constrained particles.
    pub(crate) fn project_rows(&self, f: &mut [f64]) {
        for &p in &self.active_set.list {
            let fp = [f[3 * p], f[3 * p + 1], f[3 * p + 2]];
            let q = block::mul_vec(&self.active_set.proj[p], &fp);
            f[3 * p..3 * p + 3].copy_from_slice(&q);
        }
    }

    /// Refills `dfdx` and (if given) `dfdv` at `(x, v)`, and (if given) the
    /// force `f` in the same sweep over the springs. No allocation (unless
    /// another thread assembles the same model concurrently).
    ///
    /// Every stored block is overwritten: off-diagonal blocks are assigned
    /// (in storage order) by the first spring of their pair, and the
    /// diagonal blocks are accumulated in a contiguous scratch array and
    /// written once their row is done, so the matrices need no zeroing pass.
    pub(crate) fn assemble(
        &self,
        x: &[f64],
        v: &[f64],
        f: Option<&mut [f64]>,
        dfdx: &mut SymBlockMatrix,
        dfdv: Option<&mut SymBlockMatrix>,
        mode: AssemblyMode,
    ) {
        self.assemble_paths(x, v, f, dfdx, dfdv, mode, true, None);
    }

    /// The Newton matrix `A = M + a df/dx + b df/dv` at `(x, v)` in one
    /// sweep over the springs, straight into `out` (each spring's two
    /// blocks combined, projected once and scattered once; no `df/dx` or
    /// `df/dv` is formed). Equal to the separate Jacobians combined by
    /// [`SymBlockMatrix::assign_diagonal_plus_combination`] up to round-off
    /// (the terms are added in another order). No allocation.
    ///
    /// # Panics
    /// If a slice length or the pattern of `out` does not match the model.
    pub(crate) fn assemble_step_matrix(
        &self,
        x: &[f64],
        v: &[f64],
        a: f64,
        b: f64,
        out: &mut SymBlockMatrix,
        mode: AssemblyMode,
    ) {
        self.assemble_paths(x, v, None, out, None, mode, true, Some((a, b)));
    }

    /// [`assemble`](Self::assemble); `fast = false` sends every row through
    /// the constrained-capable path (for tests comparing the two). With
    /// `comb = Some((a, b))` (no `f`, no `dfdv`): `M + a df/dx + b df/dv`
    /// into `dfdx` ([`assemble_step_matrix`](Self::assemble_step_matrix)).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn assemble_paths(
        &self,
        x: &[f64],
        v: &[f64],
        mut f: Option<&mut [f64]>,
        dfdx: &mut SymBlockMatrix,
        dfdv: Option<&mut SymBlockMatrix>,
        mode: AssemblyMode,
        fast: bool,
        comb: Option<(f64, f64)>,
    ) {
        let n = self.n_particles();
        assert!(
            x.len() == 3 * n && v.len() == 3 * n && f.as_ref().is_none_or(|f| f.len() == 3 * n),
            "force_jacobians: x, v (and f) must have length 3 n = {}",
            3 * n
        );
        assert!(
            dfdx.n_blocks() == n
                && dfdx.values().len() == self.plan.pattern.stored_blocks()
                && dfdv
                    .as_ref()
                    .is_none_or(|m| m.values().len() == self.plan.pattern.stored_blocks()),
            "force_jacobians: matrices must be on the model's pattern (use jacobian_pattern())"
        );
        if let Some(f) = f.as_deref_mut() {
            self.init_force(v, f);
        }
        // The scratch is all zeros between calls: every row takes (and
        // zeroes) its accumulator when it writes its diagonal blocks.
        let mut guard = self.plan.diag_acc.0.try_lock();
        let mut local: (Vec<Acc>, Vec<Halo>) = (Vec::new(), Vec::new());
        let (acc, halo_buf) = match guard.as_deref_mut() {
            Ok(buf) if buf.0.len() == n => (&mut buf.0, &mut buf.1),
            _ => {
                local.0.resize(n, [0.0; 12]);
                (&mut local.0, &mut local.1)
            }
        };
        // Threaded: one part of the rows per thread (the SpMV's split),
        // each with a halo of `bandwidth` particles past its rows.
        let parts = hookean_sparse::par::parts_for(n);
        let bw = self.plan.bandwidth;
        if parts > 1 && halo_buf.len() < parts * bw {
            halo_buf.resize(parts * bw, Halo::default());
        }
        let damping = self.options.damping;
        let damping_dx = damping == SpringDamping::Projected
            && mode.damping_in_dfdx == DampingInDfdx::Symmetrize;
        let has_f = f.is_some();
        let has_dv = dfdv.is_some();
        let mut dfdv = dfdv;
        let out = Outputs {
            f: f.as_deref_mut().unwrap_or_default(),
            vx: dfdx.values_mut(),
            vv: dfdv.as_deref_mut().map_or(&mut [], |m| m.values_mut()),
            acc: &mut acc[..],
            rows: 0..n,
            base: 0,
            halo: if parts > 1 {
                &mut halo_buf[..parts * bw]
            } else {
                &mut []
            },
        };
        let clamp_floor = if mode.clamp { 0.0 } else { f64::NEG_INFINITY };
        // The loop invariants become const generics: the spring loop carries
        // no branch on them.
        macro_rules! dispatch {
            ($($fl:literal, $dv:literal, $dm:ident, $dd:literal;)*) => {
                match (has_f, has_dv, damping, damping_dx) {
                    $(($fl, $dv, $dm, $dd) => {
                        Self::sweep_parts(
                            Sweep::<'_, '_, $fl, $dv, { damp_code($dm) }, $dd, true> {
                                model: self, x, v, out, clamp_floor, fast,
                                comb: Combination::NONE,
                            },
                            0,
                            parts.max(1),
                            parts,
                        )
                    })*
                    _ => unreachable!("damping_dx implies projected damping"),
                }
            };
        }
        use SpringDamping::{Incorrect as I, None as N, Projected as P};
        if let Some((a, b)) = comb {
            assert!(
                !has_f && !has_dv,
                "the one-sweep matrix takes no f or df/dv"
            );
            let comb = Combination {
                a,
                b,
                mass: &self.mass,
            };
            macro_rules! fused {
                ($($dm:ident, $dd:literal;)*) => {
                    match (damping, damping_dx) {
                        $(($dm, $dd) => Self::sweep_parts(
                            Sweep::<'_, '_, false, false, { damp_code($dm) }, $dd, true, true> {
                                model: self, x, v, out, clamp_floor, fast, comb,
                            },
                            0,
                            parts.max(1),
                            parts,
                        ),)*
                        _ => unreachable!("damping_dx implies projected damping"),
                    }
                };
            }
            fused! { P, false; P, true; I, false; N, false; }
        } else {
            dispatch! {
            true, true, P, false; true, true, P, true; true, true, I, false; true, true, N, false;
            true, false, P, false; true, false, P, true; true, false, I, false; true, false, N, false;
            false, true, P, false; false, true, P, true; false, true, I, false; false, true, N, false;
            false, false, P, false; false, false, P, true; false, false, I, false; false, false, N, false;
            }
        }
        // The contact forces' diagonal blocks (nothing without contact).
        if let Some((a, b)) = comb {
            self.add_contact_jacobians(x, a, b, dfdx);
        } else {
            self.add_contact_jacobians(x, 1.0, 0.0, dfdx);
            if let Some(m) = dfdv.as_deref_mut() {
                self.add_contact_jacobians(x, 0.0, 1.0, m);
            }
        }
        if parts > 1 {
            // The halos, added in part order (the same bits every run), and
            // zeroed for the next call.
            let vx = dfdx.values_mut();
            let mut vv = dfdv.map(|m| m.values_mut());
            let mut f3 = f.as_deref_mut().map(|f| f.as_chunks_mut::<3>().0);
            for t in 0..parts {
                let e = self.plan.pattern.part_start(t + 1, parts);
                for (k, h) in halo_buf[t * bw..(t + 1) * bw].iter_mut().enumerate() {
                    let j = e + k;
                    if j >= n {
                        break;
                    }
                    let d = self.plan.diag_index[j];
                    vx[d] = block::add(&vx[d], &unsym6(&h.acc[..6]));
                    if let Some(vv) = vv.as_deref_mut() {
                        vv[d] = block::add(&vv[d], &unsym6(&h.acc[6..]));
                    }
                    if let Some(f3) = f3.as_deref_mut() {
                        for q in 0..3 {
                            f3[j][q] += h.f[q];
                        }
                    }
                    *h = Halo::default();
                }
            }
        }
        if let Some(f) = f {
            self.add_contact_forces(x, v, f);
            self.project_rows(f);
        }
    }

    /// The sweep `op` over parts `p0..p1` of `parts` (the rows of
    /// `op.out`): halves under [`rayon::join`], each part a
    /// [`sweep`](Self::sweep) compiled for the CPU's instruction set
    /// ([`run_sweep`]).
    fn sweep_parts<
        const F: bool,
        const DV: bool,
        const DAMP: u8,
        const DDX: bool,
        const JAC: bool,
        const FUSED: bool,
    >(
        op: Sweep<'_, '_, F, DV, DAMP, DDX, JAC, FUSED>,
        p0: usize,
        p1: usize,
        parts: usize,
    ) {
        if p1 - p0 <= 1 {
            run_sweep(op);
            return;
        }
        let Sweep {
            model,
            x,
            v,
            out,
            clamp_floor,
            fast,
            comb,
        } = op;
        let mid = (p0 + p1) / 2;
        let r = model.plan.pattern.part_start(mid, parts);
        let rp = model.plan.pattern.row_ptr();
        let starts = (rp[out.rows.start], rp[r]);
        let (a, b) = out.split(r, starts, mid - p0, model.plan.bandwidth);
        let half = |out| Sweep::<'_, '_, F, DV, DAMP, DDX, JAC, FUSED> {
            model,
            x,
            v,
            out,
            clamp_floor,
            fast,
            comb,
        };
        let (a, b) = (half(a), half(b));
        rayon::join(
            || Self::sweep_parts(a, p0, mid, parts),
            || Self::sweep_parts(b, mid, p1, parts),
        );
    }

    /// One assembly sweep, row by row (`r = min(i, j)`): the diagonal
    /// contributions to `r` stay in a local accumulator, those to the other
    /// endpoint go to `acc`; when the row is done its diagonal block is final
    /// and written. Springs go in chunks: the square roots and divisions of
    /// a chunk are independent, so they overlap instead of serialising the
    /// loop. Rows flagged fast (no constrained particle) skip the
    /// projections and their look-ups.
    ///
    /// Threaded, `out` holds the rows of one part; what its springs add to
    /// particles past those rows goes to its halo, added after all parts.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn sweep<
        const F: bool,
        const DV: bool,
        const DAMP: u8,
        const DDX: bool,
        const JAC: bool,
        const FUSED: bool,
    >(
        &self,
        x: &[f64],
        v: &[f64],
        out: Outputs<'_>,
        clamp_floor: f64,
        fast: bool,
        comb: Combination<'_>,
    ) {
        let need_dv = DDX || (F && DAMP != DAMP_NONE);
        let Outputs {
            f,
            vx,
            vv,
            acc,
            rows,
            base,
            halo,
        } = out;
        let (s, end) = (rows.start, rows.end);
        let f = f.as_chunks_mut::<3>().0;
        let (x3, v3) = (x.as_chunks::<3>().0, v.as_chunks::<3>().0);
        let c_air = self.options.air_friction;
        let mut geo = ChunkGeometry::new();
        for r in s..end {
            let row_fast = fast && self.plan.row_fast[r];
            let mut loc = if JAC {
                std::mem::replace(&mut acc[r - s], [0.0; 12])
            } else {
                [0.0; 12]
            };
            // The force on the row's own particle, in registers.
            let mut floc = [0.0; 3];
            let row = &self.plan.hot[self.plan.hot_row_ptr[r]..self.plan.hot_row_ptr[r + 1]];
            for chunk in row.chunks(CHUNK) {
                geo.compute(x3, chunk);
                for (k, h) in chunk.iter().enumerate() {
                    let (e, l, inv_l) = geo.get(k);
                    let (i, j) = (h.i as usize, h.j as usize);
                    if l <= 0.0 || l.is_nan() {
                        // Coincident endpoints: no direction, no force, no Jacobian.
                        if JAC && h.first {
                            vx[h.upper as usize - base] = block::ZERO;
                            if DV {
                                vv[h.upper as usize - base] = block::ZERO;
                            }
                        }
                        continue;
                    }
                    let u = e * inv_l;
                    let dv = if need_dv {
                        Vector3::from(v3[j]) - Vector3::from(v3[i])
                    } else {
                        Vector3::zeros()
                    };
                    if F {
                        let mut fi = u * (h.stiffness * (l - h.rest_length));
                        match DAMP {
                            DAMP_PROJECTED => fi += u * (h.damping * dv.dot(&u)),
                            DAMP_INCORRECT => fi += dv * h.damping,
                            _ => {}
                        }
                        let fj = if j < end {
                            &mut f[j - s]
                        } else {
                            &mut halo[j - end].f
                        };
                        for q in 0..3 {
                            floc[q] += fi[q];
                            fj[q] -= fi[q];
                        }
                    }
                    if !JAC {
                        continue;
                    }
                    // Branch-free clamp (the sign of 1 - l0/l is random in a deformed cloth).
                    let a = (1.0 - h.rest_length * inv_l).max(clamp_floor);
                    // u u^T once (6 unique entries), shared by both blocks.
                    let uu = [
                        u.x * u.x,
                        u.x * u.y,
                        u.x * u.z,
                        u.y * u.y,
                        u.y * u.z,
                        u.z * u.z,
                    ];
                    // k [ a I + (1 - a) u u^T ].
                    let (beta, gamma) = (h.stiffness * (1.0 - a), h.stiffness * a);
                    let mut k6 = uu.map(|w| beta * w);
                    k6[0] += gamma;
                    k6[3] += gamma;
                    k6[5] += gamma;
                    if DDX && h.damping != 0.0 {
                        let g = damping_position_block(h.damping, l, &u, &dv);
                        let gs = sym6(&block::add(&g, &block::transpose(&g)));
                        for t in 0..6 {
                            k6[t] += 0.5 * gs[t];
                        }
                    }
                    let constrained = !row_fast
                        && (self.active_set.constrained[i] || self.active_set.constrained[j]);
                    let acc_c = if j < end {
                        &mut acc[j - s]
                    } else {
                        &mut halo[j - end].acc
                    };
                    // df_i/dx_j, or with FUSED a df_i/dx_j + b df_i/dv_j (projected once).
                    let b6 = if FUSED {
                        let d6 = damping_block6::<DAMP>(h.damping, &uu);
                        std::array::from_fn(|t| comb.a * k6[t] + comb.b * d6[t])
                    } else {
                        k6
                    };
                    scatter_sym(
                        vx,
                        base,
                        &mut loc,
                        acc_c,
                        0,
                        h,
                        constrained,
                        &self.active_set.proj,
                        &b6,
                    );
                    if DV && !FUSED {
                        let d6 = damping_block6::<DAMP>(h.damping, &uu);
                        scatter_sym(
                            vv,
                            base,
                            &mut loc,
                            acc_c,
                            6,
                            h,
                            constrained,
                            &self.active_set.proj,
                            &d6,
                        );
                    }
                }
            }
            let idx = self.plan.diag_index[r] - base;
            if JAC && FUSED {
                // M + a (df/dx)_rr + b (df/dv)_rr, the latter with air friction.
                let mut d = unsym6(&loc[..6]);
                if c_air != 0.0 {
                    let air = block::scale(&self.active_set.proj[r], -c_air * comb.b);
                    d = block::add(&d, &air);
                }
                for q in 0..3 {
                    d[q][q] += comb.mass[3 * r + q];
                }
                vx[idx] = d;
            } else if JAC {
                vx[idx] = unsym6(&loc[..6]);
            }
            if JAC && DV {
                let mut d = unsym6(&loc[6..]);
                if c_air != 0.0 {
                    d = block::add(&d, &block::scale(&self.active_set.proj[r], -c_air));
                }
                vv[idx] = d;
            }
            if F {
                for q in 0..3 {
                    f[r - s][q] += floc[q];
                }
            }
        }
    }

    /// Refills `dfdx` and (if given) `dfdv` at `(x, v)`. No allocation.
    pub(crate) fn assemble_jacobians(
        &self,
        x: &[f64],
        v: &[f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: Option<&mut SymBlockMatrix>,
        mode: AssemblyMode,
    ) {
        self.assemble(x, v, None, dfdx, dfdv, mode);
    }

    /// `f(x, v)`, `df/dx` and `df/dv` in one sweep over the springs (the
    /// geometry of each spring is computed once): what an implicit step
    /// needs at the start of a Newton iteration. Same results as
    /// [`force`](SecondOrderProblem::force) followed by
    /// [`force_jacobians`](SecondOrderProblem::force_jacobians). No allocation.
    ///
    /// # Panics
    /// If a slice length or matrix pattern does not match the model.
    pub fn force_and_jacobians(
        &self,
        x: &[f64],
        v: &[f64],
        f: &mut [f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    ) {
        self.assemble(
            x,
            v,
            Some(f),
            dfdx,
            Some(dfdv),
            AssemblyMode {
                clamp: self.options.clamp_stiffness,
                damping_in_dfdx: self.options.damping_in_dfdx,
            },
        );
    }

    /// The exact, generally non-symmetric `df/dx` at `(x, v)` as a CSR
    /// matrix: unclamped stiffness blocks plus the full position derivative
    /// `G` of projected damping, projected for constrained particles
    /// (`P_i J_ij P_j`). For tests and for Newton variants where exactness
    /// matters; it allocates.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state).
    pub fn dfdx_exact(&self, x: &[f64], v: &[f64]) -> Result<sprs::CsMat<f64>, MassSpringError> {
        self.check_state(x, v)?;
        let n = self.n_particles();
        let mut tri = sprs::TriMat::new((3 * n, 3 * n));
        let mut put = |bi: usize, bj: usize, b: &Block3| {
            for r in 0..3 {
                for c in 0..3 {
                    if b[r][c] != 0.0 {
                        tri.add_triplet(3 * bi + r, 3 * bj + c, b[r][c]);
                    }
                }
            }
        };
        for s in &self.springs {
            let (i, j) = (s.i, s.j);
            let e = point(x, j) - point(x, i);
            let l = e.norm();
            let inv_l = 1.0 / l;
            let u = e * inv_l;
            let mut b = stiffness_block(s.stiffness, 1.0 - s.rest_length / l, &u);
            if self.options.damping == SpringDamping::Projected {
                let dv = point(v, j) - point(v, i);
                b = block::add(&b, &damping_position_block(s.damping, l, &u, &dv));
            }
            let (pi, pj) = (&self.active_set.proj[i], &self.active_set.proj[j]);
            put(i, j, &matmul(&matmul(pi, &b), pj));
            put(j, i, &matmul(&matmul(pj, &b), pi));
            put(i, i, &neg(&matmul(&matmul(pi, &b), pi)));
            put(j, j, &neg(&matmul(&matmul(pj, &b), pj)));
        }
        Ok(tri.to_csr())
    }

    /// Writes the tutorial's constant linearised Jacobians (eq. 50): per
    /// spring an isotropic block `k I` in `df/dx` (`-k I` on the diagonals)
    /// and `d I` in `df/dv` (for projected or incorrect damping; none for
    /// [`SpringDamping::None`]), plus `-c I` for air friction. They depend on
    /// the material only (not on the state, nor on contacts); permanent
    /// constraints (pins, sliding) are applied as `P_i B P_j`. The paper's
    /// `k_ij / l_ij^2` is our `k` (N/m).
    pub fn assemble_linearized(&self, dfdx: &mut SymBlockMatrix, dfdv: &mut SymBlockMatrix) {
        dfdx.set_zero();
        dfdv.set_zero();
        for (s, sl) in self.springs.iter().zip(&self.plan.slots) {
            let (i, j) = (s.i, s.j);
            let kb = block::scale(&block::IDENTITY, s.stiffness);
            let d = match self.options.damping {
                SpringDamping::None => 0.0,
                _ => s.damping,
            };
            let db = block::scale(&block::IDENTITY, d);
            self.scatter_permanent(dfdx, sl, i, j, &kb);
            if d != 0.0 {
                self.scatter_permanent(dfdv, sl, i, j, &db);
            }
        }
        let c = self.options.air_friction;
        if c != 0.0 {
            for p in 0..self.n_particles() {
                let pp = self.fixes[p].projector();
                dfdv.add_to_slot(self.plan.diag_slots[p], &block::scale(&pp, -c));
            }
        }
    }

    /// The tutorial's eq. 50 in isotropic storage, one scalar per block:
    /// `k` per spring in `df/dx` (`-k` on the diagonals), `d` in `df/dv`
    /// (none for [`SpringDamping::None`]), `-c` on the diagonal for air
    /// friction. Permanent constraints are *not* applied (they would make
    /// the blocks anisotropic): the integrators filter the constrained
    /// directions (filtered PCG, or the eliminated pins of the IMEX
    /// factorisation). Allocates nothing; panics if the matrices are not on
    /// the model's pattern.
    pub fn assemble_linearized_iso(&self, dfdx: &mut IsoBlockMatrix, dfdv: &mut IsoBlockMatrix) {
        dfdx.set_zero();
        dfdv.set_zero();
        let damped = self.options.damping != SpringDamping::None;
        for s in &self.springs {
            let (i, j) = (s.i, s.j);
            let slots = (dfdx.slot(i, j), dfdx.slot(i, i), dfdx.slot(j, j));
            let (Ok(ij), Ok(ii), Ok(jj)) = slots else {
                panic!("linearised Jacobian not on the model's pattern");
            };
            dfdx.add_to_slot(ij, s.stiffness);
            dfdx.add_to_slot(ii, -s.stiffness);
            dfdx.add_to_slot(jj, -s.stiffness);
            if damped && s.damping != 0.0 {
                dfdv.add_to_slot(ij, s.damping);
                dfdv.add_to_slot(ii, -s.damping);
                dfdv.add_to_slot(jj, -s.damping);
            }
        }
        let c = self.options.air_friction;
        if c != 0.0 {
            for p in 0..self.n_particles() {
                if let Ok(pp) = dfdv.slot(p, p) {
                    dfdv.add_to_slot(pp, -c);
                }
            }
        }
    }

    fn scatter_permanent(
        &self,
        m: &mut SymBlockMatrix,
        sl: &SpringSlots,
        i: usize,
        j: usize,
        b: &Block3,
    ) {
        if self.fixes[i].count > 0 || self.fixes[j].count > 0 {
            let pi = self.fixes[i].projector();
            let pj = self.fixes[j].projector();
            m.add_to_slot(sl.ij, &matmul(&matmul(&pi, b), &pj));
            m.add_to_slot(sl.ii, &neg(&matmul(&matmul(&pi, b), &pi)));
            m.add_to_slot(sl.jj, &neg(&matmul(&matmul(&pj, b), &pj)));
        } else {
            let nb = neg(b);
            m.add_to_slot(sl.ij, b);
            m.add_to_slot(sl.ii, &nb);
            m.add_to_slot(sl.jj, &nb);
        }
    }

    /// A pair of zero matrices on the Jacobian pattern, for `df/dx` and `df/dv`.
    pub fn new_jacobians(&self) -> (SymBlockMatrix, SymBlockMatrix) {
        (
            SymBlockMatrix::new(self.plan.pattern.clone()),
            SymBlockMatrix::new(self.plan.pattern.clone()),
        )
    }

    /// Checked force evaluation: validates the state, then `f(x, v)`.
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state), and
    /// [`MassSpringError::DimensionMismatch`] for `f`.
    pub fn force_checked(
        &self,
        x: &[f64],
        v: &[f64],
        f: &mut [f64],
    ) -> Result<(), MassSpringError> {
        self.check_state(x, v)?;
        if f.len() != x.len() {
            return Err(MassSpringError::DimensionMismatch {
                what: "f",
                expected: x.len(),
                found: f.len(),
            });
        }
        self.eval_force(x, v, f);
        Ok(())
    }

    /// Checked Jacobian assembly with explicit clamping, for callers that
    /// want the exact (`clamp = false`) symmetric `df/dx` regardless of
    /// [`ModelOptions::clamp_stiffness`](crate::ModelOptions::clamp_stiffness).
    ///
    /// # Errors
    /// As [`check_state`](Self::check_state); [`MassSpringError::InvalidParameter`]
    /// if a matrix is not on this model's pattern.
    pub fn jacobians_checked(
        &self,
        x: &[f64],
        v: &[f64],
        clamp: bool,
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    ) -> Result<(), MassSpringError> {
        self.check_state(x, v)?;
        for m in [&*dfdx, &*dfdv] {
            if !Arc::ptr_eq(m.pattern(), &self.plan.pattern) && **m.pattern() != *self.plan.pattern
            {
                return Err(MassSpringError::InvalidParameter {
                    name: "matrix",
                    message: "not on the model's Jacobian pattern".into(),
                });
            }
        }
        self.assemble_jacobians(
            x,
            v,
            dfdx,
            Some(dfdv),
            AssemblyMode {
                clamp,
                damping_in_dfdx: self.options.damping_in_dfdx,
            },
        );
        Ok(())
    }
}

impl SecondOrderProblem for MassSpringModel {
    fn dim(&self) -> usize {
        3 * self.n_particles()
    }

    fn mass(&self) -> &[f64] {
        &self.mass
    }

    /// `f(x, v)`; constrained directions are projected out (see
    /// [`MassSpringModel`]). No allocation.
    ///
    /// # Panics
    /// If a slice length is not `3 n` (the trait cannot return errors; use
    /// [`MassSpringModel::force_checked`] on untrusted input).
    fn force(&self, _t: f64, x: &[f64], v: &[f64], f: &mut [f64]) {
        self.eval_force(x, v, f);
    }

    fn jacobian_pattern(&self) -> Arc<BlockPattern> {
        self.plan.pattern.clone()
    }

    /// Refills `df/dx` (clamped per [`ModelOptions::clamp_stiffness`](crate::ModelOptions::clamp_stiffness),
    /// damping term per [`DampingInDfdx`]) and `df/dv` (exact). No allocation.
    ///
    /// # Panics
    /// If a slice length or matrix size does not match the model.
    fn force_jacobians(
        &self,
        _t: f64,
        x: &[f64],
        v: &[f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    ) {
        self.assemble_jacobians(
            x,
            v,
            dfdx,
            Some(dfdv),
            AssemblyMode {
                clamp: self.options.clamp_stiffness,
                damping_in_dfdx: self.options.damping_in_dfdx,
            },
        );
    }

    /// `A = M + a df/dx + b df/dv` in one sweep over the springs
    /// ([`MassSpringModel::assemble_step_matrix`]); `dfdx` and `dfdv` are
    /// left as they are.
    fn step_matrix(
        &self,
        _t: f64,
        x: &[f64],
        v: &[f64],
        a: f64,
        b: f64,
        _dfdx: &mut SymBlockMatrix,
        _dfdv: &mut SymBlockMatrix,
        out: &mut SymBlockMatrix,
    ) -> Result<(), hookean_sparse::SparseError> {
        if out.values().len() != self.plan.pattern.stored_blocks()
            || out.n_blocks() != self.n_particles()
        {
            return Err(hookean_sparse::SparseError::InvalidParameter {
                name: "step_matrix",
                message: "the matrix is not on the model's Jacobian pattern".into(),
            });
        }
        self.assemble_step_matrix(
            x,
            v,
            a,
            b,
            out,
            AssemblyMode {
                clamp: self.options.clamp_stiffness,
                damping_in_dfdx: self.options.damping_in_dfdx,
            },
        );
        Ok(())
    }

    /// The tutorial's eq. 50 (see [`MassSpringModel::assemble_linearized`]).
    fn linearized_jacobians(&self, dfdx: &mut SymBlockMatrix, dfdv: &mut SymBlockMatrix) -> bool {
        self.assemble_linearized(dfdx, dfdv);
        true
    }

    /// The tutorial's eq. 50 in isotropic storage (see
    /// [`MassSpringModel::assemble_linearized_iso`]).
    fn linearized_jacobians_iso(
        &self,
        dfdx: &mut IsoBlockMatrix,
        dfdv: &mut IsoBlockMatrix,
    ) -> bool {
        self.assemble_linearized_iso(dfdx, dfdv);
        true
    }

    fn material_revision(&self) -> u64 {
        MassSpringModel::material_revision(self)
    }

    /// Pins, sliding constraints and collisions (tutorial section 4.2).
    ///
    /// 1. Permanent constraints: each constrained coordinate of `x_p` is reset
    ///    to its prescribed value and the constrained components of `v_p` are
    ///    zeroed (a pinned particle gets `x_p` = its pin, `v_p = 0`).
    /// 2. Contact (`contact.rs`, docs/CONTACT.md): self-contact pairs are
    ///    found; a particle with signed distance `phi <= margin` to a
    ///    collider (a mesh: its thickness) is in contact. If `phi < 0` (a
    ///    mesh: below the thickness) it is projected back; an inward normal
    ///    velocity relative to the surface is removed. The normal is then
    ///    constrained for this step unless the particle separates or the
    ///    force pulls it away (`f . n > 0`); with friction, a sticking
    ///    particle is constrained in all three directions, a sliding one gets
    ///    the kinetic friction force.
    /// 3. `constraints` is cleared (recreated if sized for another model) and
    ///    filled with every active direction `d` of particle `p` with the
    ///    value `d . w_p`, `w_p` the velocity the constraint moves with (zero
    ///    for pins and static colliders, a moving collider's surface
    ///    velocity): the integrator imposes it on the new velocity, and its
    ///    Newton corrections keep it (the velocity components were already
    ///    set to it here).
    ///
    /// The active directions also project `force` and the Jacobians until the
    /// next `begin_step`.
    fn begin_step(&mut self, t: f64, x: &mut [f64], v: &mut [f64], constraints: &mut Constraints) {
        self.apply_constraints_and_contacts(t, x, v);
        let n = self.n_particles();
        if constraints.n_particles() != n {
            *constraints = Constraints::new(n);
        } else {
            constraints.clear();
        }
        for &p in &self.active_set.list {
            let d = &self.active_set.dirs[p];
            // The prescribed velocity: zero, or a moving collider's.
            let w = self.active_set.vel[p];
            if d.count == 3 {
                // Orthonormal and complete: equivalent to a pin of V_p.
                constraints.pin(p, w).expect("particle index is in range");
            } else {
                for k in 0..d.count {
                    let e = d.dirs[k];
                    let value = e[0] * w[0] + e[1] * w[1] + e[2] * w[2];
                    constraints
                        .constrain(p, e, value)
                        .expect("directions are orthonormal and finite");
                }
            }
        }
    }

    /// The continuous contact passes (`contact.rs`): cloth self-collision
    /// and mesh colliders; nothing (and `false`) for a model without them.
    fn end_step(&mut self, t: f64, h: f64, x_start: &[f64], x: &mut [f64], v: &mut [f64]) -> bool {
        self.end_contact_step(t, h, x_start, x, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ClothParams, ModelOptions, Spring, cloth};
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// A 7 x 6 cloth, its bottom-left corner pinned, its top-right corner
    /// sliding along a line, particle 12 in the plane `z = const`, one
    /// spring duplicated (with other material), compressed by 10% and
    /// shaken, with random velocities.
    fn scene(options: ModelOptions) -> (MassSpringModel, Vec<f64>, Vec<f64>) {
        scene_sized(options, 7, 6)
    }

    /// [`scene`] on an `nu x nv` cloth.
    fn scene_sized(
        options: ModelOptions,
        nu: usize,
        nv: usize,
    ) -> (MassSpringModel, Vec<f64>, Vec<f64>) {
        let (base, state) = cloth(&ClothParams {
            nu,
            nv,
            ..Default::default()
        })
        .unwrap();
        let mut springs = base.springs().to_vec();
        let s0 = springs[5];
        springs.push(Spring::new(s0.j, s0.i, 0.8 * s0.rest_length, 3e3, 0.3));
        let mut model =
            MassSpringModel::new(base.particle_masses().to_vec(), springs, options).unwrap();
        let n = model.n_particles();
        let mut rng = SmallRng::seed_from_u64(0x2545_F491_4F6C_DD1D);
        let x: Vec<f64> = (state.x.iter())
            .map(|&c| 0.9 * c + 0.02 * rng.random_range(-0.5..0.5))
            .collect();
        let v: Vec<f64> = (0..3 * n).map(|_| rng.random_range(-0.5..0.5)).collect();
        model.pin(0, [x[0], x[1], x[2]]).unwrap();
        let p = n - 1;
        let at = [x[3 * p], x[3 * p + 1], x[3 * p + 2]];
        model.constrain_direction(p, [1.0, 0.0, 0.0], at).unwrap();
        model.constrain_direction(p, [0.0, 1.0, 1.0], at).unwrap();
        model
            .constrain_direction(12, [0.0, 0.0, 1.0], [x[36], x[37], x[38]])
            .unwrap();
        (model, x, v)
    }

    /// Assembles `(f, df/dx, df/dv)` into garbage-filled outputs.
    fn run(
        model: &MassSpringModel,
        x: &[f64],
        v: &[f64],
        mode: AssemblyMode,
        fast: bool,
    ) -> (Vec<f64>, SymBlockMatrix, SymBlockMatrix) {
        let (mut dx, mut dv) = model.new_jacobians();
        let mut f = vec![f64::NAN; x.len()];
        // Start from garbage: every block must be overwritten.
        dx.values_mut().fill([[7.0; 3]; 3]);
        dv.values_mut().fill([[7.0; 3]; 3]);
        model.assemble_paths(x, v, Some(&mut f), &mut dx, Some(&mut dv), mode, fast, None);
        (f, dx, dv)
    }

    /// The row flags are consistent with the constraints: skipping the
    /// constrained look-ups on fast rows changes nothing (against every row
    /// checked, on a fresh copy of the model); a repeated call on the same
    /// scratch gives the same bits (the scratch is left zeroed).
    fn assert_paths_agree(model: &MassSpringModel, x: &[f64], v: &[f64], mode: AssemblyMode) {
        let first = run(model, x, v, mode, true);
        let (fa, xa, va) = run(model, x, v, mode, true);
        assert_eq!(first.0, fa);
        assert_eq!(first.1.values(), xa.values());
        assert_eq!(first.2.values(), va.values());
        let checked = run(&model.clone(), x, v, mode, false);
        assert_round_off(&(fa, xa, va), &checked, &format!("{mode:?}"));
    }

    /// Two assemblies `(f, df/dx, df/dv)` agree to round-off: `1e-12`
    /// relative for `f`, `1e-12` of the largest `df/dx` entry for the blocks.
    fn assert_round_off(
        a: &(Vec<f64>, SymBlockMatrix, SymBlockMatrix),
        b: &(Vec<f64>, SymBlockMatrix, SymBlockMatrix),
        what: &str,
    ) {
        let scale = (b.1.values().iter().flatten().flatten()).fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 1e3);
        for (u, w) in a.0.iter().zip(&b.0) {
            assert!(
                (u - w).abs() <= 1e-12 * (1.0 + w.abs()),
                "{what}: f {u} vs {w}"
            );
        }
        for (ma, mb) in [(&a.1, &b.1), (&a.2, &b.2)] {
            let pairs = (ma.values().iter().flatten().flatten())
                .zip(mb.values().iter().flatten().flatten());
            for (u, w) in pairs {
                assert!((u - w).abs() <= 1e-12 * scale, "{what}: {u} vs {w}");
            }
        }
    }

    /// The threaded sweep (row parts, halos added afterwards in part order)
    /// sums the same terms as the serial one in another order: equal to
    /// round-off, and bitwise repeatable for a given thread count.
    #[test]
    fn threaded_assembly_agrees_with_the_serial_sweep_and_repeats_its_bits() {
        let (model, x, v) = scene_sized(ModelOptions::default(), 50, 48);
        assert!(model.n_particles() >= hookean_sparse::par::MIN_PARALLEL_BLOCKS);
        let pool = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
        };
        for mode in [
            AssemblyMode {
                clamp: true,
                damping_in_dfdx: DampingInDfdx::Drop,
            },
            AssemblyMode {
                clamp: false,
                damping_in_dfdx: DampingInDfdx::Symmetrize,
            },
        ] {
            let serial = pool(1).install(|| run(&model, &x, &v, mode, true));
            for threads in [2, 3] {
                let p = pool(threads);
                let (fa, xa, va) = p.install(|| run(&model, &x, &v, mode, true));
                let again = p.install(|| run(&model, &x, &v, mode, true));
                assert_eq!(
                    (&fa, xa.values(), va.values()),
                    (&again.0, again.1.values(), again.2.values())
                );
                assert_round_off(&(fa, xa, va), &serial, &format!("{threads} threads"));
            }
        }
    }

    /// The one-sweep Newton matrix is `M + a df/dx + b df/dv` formed from
    /// the separately assembled Jacobians, to round-off, for every damping
    /// law, damping-in-`df/dx` choice, clamp, thread count, with
    /// constraints (pins, directions) and air friction; and a second call
    /// gives the same bits (the scratch is left zeroed).
    #[test]
    fn one_sweep_step_matrix_is_the_combination_of_the_jacobians() {
        let (gh_a, gh_b) = (-1e-4, -1e-2);
        for damping in [
            SpringDamping::Projected,
            SpringDamping::Incorrect,
            SpringDamping::None,
        ] {
            for damping_in_dfdx in [DampingInDfdx::Drop, DampingInDfdx::Symmetrize] {
                if damping_in_dfdx == DampingInDfdx::Symmetrize
                    && damping != SpringDamping::Projected
                {
                    continue;
                }
                for clamp in [true, false] {
                    let options = ModelOptions {
                        damping,
                        air_friction: 0.3,
                        ..ModelOptions::default()
                    };
                    let (model, x, v) = scene_sized(options, 50, 48);
                    let mode = AssemblyMode {
                        clamp,
                        damping_in_dfdx,
                    };
                    for threads in [1, 2] {
                        let pool = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .unwrap();
                        pool.install(|| {
                            let (_, dx, dv) = run(&model, &x, &v, mode, true);
                            let mut expected = SymBlockMatrix::new(dx.pattern().clone());
                            expected
                                .assign_diagonal_plus_combination(&model.mass, gh_a, &dx, gh_b, &dv)
                                .unwrap();
                            let mut fused = SymBlockMatrix::new(dx.pattern().clone());
                            fused.values_mut().fill([[7.0; 3]; 3]);
                            model.assemble_step_matrix(&x, &v, gh_a, gh_b, &mut fused, mode);
                            let scale = expected
                                .values()
                                .iter()
                                .flatten()
                                .flatten()
                                .fold(0.0f64, |m, w| m.max(w.abs()));
                            let pairs = (fused.values().iter().flatten().flatten())
                                .zip(expected.values().iter().flatten().flatten());
                            for (u, w) in pairs {
                                assert!(
                                    (u - w).abs() <= 1e-13 * scale,
                                    "{damping:?} {damping_in_dfdx:?} clamp {clamp}, {threads} threads: {u} vs {w}"
                                );
                            }
                            let mut again = SymBlockMatrix::new(dx.pattern().clone());
                            model.assemble_step_matrix(&x, &v, gh_a, gh_b, &mut again, mode);
                            assert_eq!(again.values(), fused.values());
                        });
                    }
                }
            }
        }
    }

    /// The force-only evaluation is the fused sweep without its Jacobian
    /// half: for every damping law and thread count (1: serial; 2, 3: row
    /// parts and halos) its `f` has the fused sweep's bits, and a coincident
    /// pair of particles gives no force and no NaN.
    #[test]
    fn force_only_sweep_has_the_fused_sweeps_bits_for_every_thread_count() {
        for damping in [
            SpringDamping::Projected,
            SpringDamping::Incorrect,
            SpringDamping::None,
        ] {
            let options = ModelOptions {
                damping,
                ..ModelOptions::default()
            };
            let (model, mut x, v) = scene_sized(options, 50, 48);
            // Particles 1 and 2 at the same place.
            let (a, b) = x.split_at_mut(6);
            b[..3].copy_from_slice(&a[3..6]);
            let mode = AssemblyMode {
                clamp: true,
                damping_in_dfdx: DampingInDfdx::Drop,
            };
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let (fused, only) = pool.install(|| {
                    let (fused, _, _) = run(&model, &x, &v, mode, true);
                    let mut only = vec![f64::NAN; x.len()];
                    model.eval_force(&x, &v, &mut only);
                    (fused, only)
                });
                assert!(only.iter().all(|f| f.is_finite()), "{damping:?}, {threads}");
                assert_eq!(fused, only, "{damping:?}, {threads} threads");
            }
        }
    }

    #[test]
    fn fast_rows_equal_checked_rows_with_constraints_duplicates_and_compression() {
        for damping in [
            SpringDamping::Projected,
            SpringDamping::Incorrect,
            SpringDamping::None,
        ] {
            for damping_in_dfdx in [DampingInDfdx::Drop, DampingInDfdx::Symmetrize] {
                for clamp in [true, false] {
                    let options = ModelOptions {
                        damping,
                        damping_in_dfdx,
                        clamp_stiffness: clamp,
                        air_friction: 0.3,
                        ..Default::default()
                    };
                    let (model, x, v) = scene(options);
                    let rows = model.plan.row_fast.iter().filter(|&&b| b).count();
                    assert!(rows > 10 && rows < model.n_particles());
                    // Compressed springs: the clamp is active somewhere.
                    let compressed = model
                        .springs()
                        .iter()
                        .filter(|s| (point(&x, s.j) - point(&x, s.i)).norm() < s.rest_length)
                        .count();
                    assert!(compressed > 10);
                    let mode = AssemblyMode {
                        clamp,
                        damping_in_dfdx,
                    };
                    assert_paths_agree(&model, &x, &v, mode);
                }
            }
        }
    }

    #[test]
    fn row_flags_follow_pins_releases_and_contacts() {
        let (mut model, mut x, mut v) = scene(ModelOptions::default());
        let mode = AssemblyMode {
            clamp: true,
            damping_in_dfdx: DampingInDfdx::Drop,
        };
        let slow = |m: &MassSpringModel| m.plan.row_fast.iter().filter(|&&b| !b).count();
        let before = slow(&model);
        // Releasing the sliding particle 12 frees its rows.
        model.release(12).unwrap();
        assert!(model.plan.row_fast[12] && model.plan.row_fast[11]);
        assert!(slow(&model) < before);
        assert_paths_agree(&model, &x, &v, mode);
        // Pinning an interior particle flags its row and the rows of its
        // lower neighbours.
        assert!(model.plan.row_fast[20] && model.plan.row_fast[19] && model.plan.row_fast[13]);
        model.pin(20, [x[60], x[61], x[62]]).unwrap();
        assert!(!model.plan.row_fast[20] && !model.plan.row_fast[19] && !model.plan.row_fast[13]);
        assert_paths_agree(&model, &x, &v, mode);
        // A collider: contacts of begin_step flag rows, the next step with
        // no contact unflags them.
        let z = (0..model.n_particles())
            .map(|p| x[3 * p + 2])
            .fold(f64::INFINITY, f64::min);
        model.add_collider(
            crate::Collider::plane([0.0, 0.0, z + 0.01], [0.0, 0.0, 1.0], 0.0).unwrap(),
        );
        let mut c = hookean_sparse::Constraints::new(model.n_particles());
        model.begin_step(0.0, &mut x, &mut v, &mut c);
        assert!(model.contact_count() > 0);
        assert_paths_agree(&model, &x, &v, mode);
    }
}
