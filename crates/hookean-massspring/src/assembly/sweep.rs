//! The assembly sweep: one pass over the springs, row by row, that writes
//! the force, `df/dx`, `df/dv` or the fused step matrix `A = M + a df/dx +
//! b df/dv`, compiled per SIMD level (pulp) and split over rayon parts with
//! halos (the layout of parts and halos: `plan.rs`).

use hookean_sparse::SymBlockMatrix;
use hookean_sparse::block::{self, Block3};
use nalgebra::Vector3;

use std::marker::PhantomData;

use crate::model::{DampingInDfdx, MassSpringModel, SpringDamping};

use super::*;

/// A spring's damping block `df_i/dv_j` by its 6 unique entries: `d u u^T`
/// (projected damping, from `u u^T` in `uu`), `d I` (the incorrect law) or 0.
#[inline(always)]
fn damping_block6<D: DampingLaw>(d: f64, uu: &[f64; 6]) -> [f64; 6] {
    match D::LAW {
        SpringDamping::Projected => uu.map(|w| d * w),
        SpringDamping::Incorrect => [d, 0.0, 0.0, d, 0.0, d],
        SpringDamping::None => [0.0; 6],
    }
}

/// Springs per chunk of [`ChunkGeometry`].
pub(crate) const CHUNK: usize = 8;

/// The geometry of a chunk of springs in structure-of-arrays form: the
/// square roots and divisions of a chunk are independent and vectorise
/// (`sqrtpd` / `divpd`) instead of serialising the spring loop.
pub(crate) struct ChunkGeometry {
    e: [[f64; CHUNK]; 3],
    pub(crate) l: [f64; CHUNK],
    inv_l: [f64; CHUNK],
}

impl ChunkGeometry {
    pub(crate) fn new() -> Self {
        Self {
            e: [[1.0; CHUNK]; 3],
            l: [1.0; CHUNK],
            inv_l: [1.0; CHUNK],
        }
    }

    /// `e = x_j - x_i`, `l = |e|`, `1 / l` for every spring of `chunk`.
    #[inline(always)]
    fn compute(&mut self, x: &[[f64; 3]], chunk: &[HotSpring]) {
        self.compute_lengths(x, chunk);
        for k in 0..CHUNK {
            self.inv_l[k] = 1.0 / self.l[k];
        }
    }

    /// `e = x_j - x_i` and `l = |e|` for every spring of `chunk` (not `1 /
    /// l`: the energy needs no direction, and a division per spring costs
    /// as much as its square root).
    #[inline(always)]
    pub(crate) fn compute_lengths(&mut self, x: &[[f64; 3]], chunk: &[HotSpring]) {
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

/// The spring damping law of a sweep, fixed at compile time: the model's
/// [`SpringDamping`], and for projected damping whether the symmetric part
/// of its position derivative goes into `df/dx` ([`DampingInDfdx`]).
trait DampingLaw {
    /// The law of the damping force and of `df/dv`.
    const LAW: SpringDamping;
    /// `df/dx` holds `(G + G^T) / 2` of the projected damping force.
    const IN_DFDX: bool;
}

/// Projected damping `d ((v_j - v_i) . u) u`, dropped from `df/dx`.
struct Projected;
/// Projected damping with the symmetric part of its position derivative
/// in `df/dx` ([`DampingInDfdx::Symmetrize`]).
struct ProjectedSymmetrized;
/// The "incorrect" damping `d (v_j - v_i)`.
struct Incorrect;
/// No spring damping.
struct Undamped;

impl DampingLaw for Projected {
    const LAW: SpringDamping = SpringDamping::Projected;
    const IN_DFDX: bool = false;
}
impl DampingLaw for ProjectedSymmetrized {
    const LAW: SpringDamping = SpringDamping::Projected;
    const IN_DFDX: bool = true;
}
impl DampingLaw for Incorrect {
    const LAW: SpringDamping = SpringDamping::Incorrect;
    const IN_DFDX: bool = false;
}
impl DampingLaw for Undamped {
    const LAW: SpringDamping = SpringDamping::None;
    const IN_DFDX: bool = false;
}

/// What a sweep writes, fixed at compile time: its loop invariants become
/// constants, so the spring loop carries no branch on them (static
/// dispatch; one compiled sweep per mode and damping law).
trait SweepMode {
    /// The damping law.
    type Damping: DampingLaw;
    /// Writes the force `f`.
    const FORCE: bool;
    /// Writes the Jacobian half: `df/dx` (or the step matrix) into `vx`.
    const JACOBIANS: bool;
    /// Writes `df/dv` into `vv` as well.
    const DFDV: bool;
    /// Writes the step matrix `A = M + a df/dx + b df/dv` into `vx`
    /// instead of `df/dx` (no `df/dv` is formed).
    const STEP_MATRIX: bool;
    /// [`DampingLaw::LAW`] of the mode's damping.
    const DAMPING: SpringDamping = <Self::Damping as DampingLaw>::LAW;
    /// [`DampingLaw::IN_DFDX`] of the mode's damping.
    const DAMPING_IN_DFDX: bool = <Self::Damping as DampingLaw>::IN_DFDX;
}

/// The force alone ([`MassSpringModel::eval_force`]).
struct ForceOnly<D>(PhantomData<D>);
/// `df/dx` alone.
struct Dfdx<D>(PhantomData<D>);
/// `df/dx` and `df/dv`.
struct DfdxDfdv<D>(PhantomData<D>);
/// The force and `df/dx`.
struct ForceDfdx<D>(PhantomData<D>);
/// The force, `df/dx` and `df/dv`.
struct ForceDfdxDfdv<D>(PhantomData<D>);
/// The step matrix `A = M + a df/dx + b df/dv` in one sweep.
struct StepMatrix<D>(PhantomData<D>);

macro_rules! sweep_modes {
    ($($mode:ident: $force:literal, $jac:literal, $dv:literal, $step:literal;)*) => {$(
        impl<D: DampingLaw> SweepMode for $mode<D> {
            type Damping = D;
            const FORCE: bool = $force;
            const JACOBIANS: bool = $jac;
            const DFDV: bool = $dv;
            const STEP_MATRIX: bool = $step;
        }
    )*};
}
sweep_modes! {
    //             FORCE, JACOBIANS, DFDV, STEP_MATRIX
    ForceOnly:     true,  false,     false, false;
    Dfdx:          false, true,      false, false;
    DfdxDfdv:      false, true,      true,  false;
    ForceDfdx:     true,  true,      false, false;
    ForceDfdxDfdv: true,  true,      true,  false;
    StepMatrix:    false, true,      false, true;
}

/// Runs `$body` with the type `$d` set to the [`DampingLaw`] of `damping`
/// and `in_dfdx` (whether projected damping's position derivative goes
/// into `df/dx`).
macro_rules! with_damping_law {
    ($damping:expr, $in_dfdx:expr, $d:ident => $body:expr) => {
        match ($damping, $in_dfdx) {
            (SpringDamping::Projected, false) => {
                type $d = Projected;
                $body
            }
            (SpringDamping::Projected, true) => {
                type $d = ProjectedSymmetrized;
                $body
            }
            (SpringDamping::Incorrect, _) => {
                type $d = Incorrect;
                $body
            }
            (SpringDamping::None, _) => {
                type $d = Undamped;
                $body
            }
        }
    };
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

/// One assembly sweep in mode `M` as a [`pulp::WithSimd`] operation, so
/// that it can be compiled for the instruction set the CPU offers (checked
/// at run time by `pulp::Arch::dispatch`) without `unsafe` here.
struct Sweep<'m, 'o, M: SweepMode> {
    model: &'m MassSpringModel,
    x: &'m [f64],
    v: &'m [f64],
    out: Outputs<'o>,
    clamp_floor: f64,
    fast: bool,
    comb: Combination<'m>,
    mode: PhantomData<fn() -> M>,
}

/// The one-sweep Newton matrix `A = M + a df/dx + b df/dv` (a
/// [`StepMatrix`] sweep writes it into `vx`; otherwise unused).
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

impl<M: SweepMode> pulp::WithSimd for Sweep<'_, '_, M> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        self.model.sweep::<M>(
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

impl MassSpringModel {
    /// Gravity, external forces and air friction: the per-particle part of `f`.
    pub(super) fn init_force(&self, v: &[f64], f: &mut [f64]) {
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
        self.free_force(x, v, f);
        self.project_rows(f);
    }

    /// The force before the rows of constrained particles are projected:
    /// gravity, external forces, air friction, springs and their damping,
    /// the step's contact forces (kinetic friction, self-contact, soft pins)
    /// and wind, `f_i(x, v)` at every particle, pinned or not. At a hard pin
    /// the constraint's reaction is `R_i = m_i a_i - f_i` (the energy
    /// guard's work of driven pins, `hookean::Simulation`). No allocation
    /// (as [`force`](hookean_problem::SecondOrderProblem::force)).
    ///
    /// # Panics
    /// If a slice length is not `3 n`.
    pub fn free_force(&self, x: &[f64], v: &[f64], f: &mut [f64]) {
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
        with_damping_law!(self.options.damping, false, D => Self::sweep_parts(
            Sweep {
                model: self,
                x,
                v,
                out,
                clamp_floor: 0.0,
                fast: true,
                comb: Combination::NONE,
                mode: PhantomData::<fn() -> ForceOnly<D>>,
            },
            0,
            parts.max(1),
            parts,
        ));
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
        self.add_wind_forces(v, f);
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
        // The loop invariants become a mode type (what the sweep writes, the
        // damping law): the spring loop carries no branch on them.
        macro_rules! sweep {
            ($mode:ty, $comb:expr) => {
                Self::sweep_parts(
                    Sweep {
                        model: self,
                        x,
                        v,
                        out,
                        clamp_floor,
                        fast,
                        comb: $comb,
                        mode: PhantomData::<fn() -> $mode>,
                    },
                    0,
                    parts.max(1),
                    parts,
                )
            };
        }
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
            with_damping_law!(damping, damping_dx, D => sweep!(StepMatrix<D>, comb));
        } else {
            with_damping_law!(damping, damping_dx, D => match (has_f, has_dv) {
                (true, true) => sweep!(ForceDfdxDfdv<D>, Combination::NONE),
                (true, false) => sweep!(ForceDfdx<D>, Combination::NONE),
                (false, true) => sweep!(DfdxDfdv<D>, Combination::NONE),
                (false, false) => sweep!(Dfdx<D>, Combination::NONE),
            });
        }
        // The contact forces' diagonal blocks (nothing without contact).
        if let Some((a, b)) = comb {
            self.add_contact_jacobians(x, a, b, dfdx);
            self.add_wind_jacobians(v, b, dfdx);
        } else {
            self.add_contact_jacobians(x, 1.0, 0.0, dfdx);
            if let Some(m) = dfdv.as_deref_mut() {
                self.add_contact_jacobians(x, 0.0, 1.0, m);
                self.add_wind_jacobians(v, 1.0, m);
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
            self.add_wind_forces(v, f);
            self.project_rows(f);
        }
    }

    /// The sweep `op` over parts `p0..p1` of `parts` (the rows of
    /// `op.out`): halves under [`rayon::join`], each part a
    /// [`sweep`](Self::sweep) compiled for the CPU's instruction set
    /// ([`run_sweep`]).
    fn sweep_parts<M: SweepMode>(op: Sweep<'_, '_, M>, p0: usize, p1: usize, parts: usize) {
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
            mode,
        } = op;
        let mid = (p0 + p1) / 2;
        let r = model.plan.pattern.part_start(mid, parts);
        let values = model.plan.pattern.rows_value_range(out.rows.start..r);
        let starts = (values.start, values.end);
        let (a, b) = out.split(r, starts, mid - p0, model.plan.bandwidth);
        let half = |out| Sweep {
            model,
            x,
            v,
            out,
            clamp_floor,
            fast,
            comb,
            mode,
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
    fn sweep<M: SweepMode>(
        &self,
        x: &[f64],
        v: &[f64],
        out: Outputs<'_>,
        clamp_floor: f64,
        fast: bool,
        comb: Combination<'_>,
    ) {
        let need_dv = M::DAMPING_IN_DFDX || (M::FORCE && M::DAMPING != SpringDamping::None);
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
            let mut loc = if M::JACOBIANS {
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
                        if M::JACOBIANS && h.first {
                            vx[h.upper as usize - base] = block::ZERO;
                            if M::DFDV {
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
                    if M::FORCE {
                        let mut fi = u * (h.stiffness * (l - h.rest_length));
                        match M::DAMPING {
                            SpringDamping::Projected => fi += u * (h.damping * dv.dot(&u)),
                            SpringDamping::Incorrect => fi += dv * h.damping,
                            SpringDamping::None => {}
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
                    if !M::JACOBIANS {
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
                    if M::DAMPING_IN_DFDX && h.damping != 0.0 {
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
                    // df_i/dx_j, or in a step-matrix sweep a df_i/dx_j + b df_i/dv_j (projected once).
                    let b6 = if M::STEP_MATRIX {
                        let d6 = damping_block6::<M::Damping>(h.damping, &uu);
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
                    if M::DFDV && !M::STEP_MATRIX {
                        let d6 = damping_block6::<M::Damping>(h.damping, &uu);
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
            if M::JACOBIANS && M::STEP_MATRIX {
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
            } else if M::JACOBIANS {
                vx[idx] = unsym6(&loc[..6]);
            }
            if M::JACOBIANS && M::DFDV {
                let mut d = unsym6(&loc[6..]);
                if c_air != 0.0 {
                    d = block::add(&d, &block::scale(&self.active_set.proj[r], -c_air));
                }
                vv[idx] = d;
            }
            if M::FORCE {
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
    /// [`force`](hookean_problem::SecondOrderProblem::force) followed by
    /// [`force_jacobians`](hookean_problem::SecondOrderProblem::force_jacobians). No allocation.
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
}
