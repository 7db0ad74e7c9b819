//! Forces and Jacobians: the hot loops, and the
//! [`SecondOrderProblem`] implementation.
//!
//! Spring `(i, j, l0, k, d)`, `u = (x_j - x_i) / l`, `l = |x_j - x_i|`,
//! `dv = v_j - v_i` (DESIGN.md):
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

use hookean_ode::SecondOrderProblem;
use hookean_sparse::block::{self, Block3};
use hookean_sparse::{BlockPattern, Constraints, SymBlockMatrix};
use nalgebra::Vector3;

use crate::error::MassSpringError;
use crate::model::{DampingInDfdx, MassSpringModel, SpringDamping, SpringSlots, point};

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
    loc: &mut [f64; 12],
    acc_c: &mut [f64; 12],
    at: usize,
    h: &crate::model::HotSpring,
    constrained: bool,
    proj: &[Block3],
    b6: &[f64; 6],
) {
    let (i, j) = (h.i, h.j);
    let (off, di, dj) = if constrained {
        let b = &unsym6(b6);
        let (pi, pj) = (&proj[i], &proj[j]);
        let pb = matmul(pi, b);
        let mut off = matmul(&pb, pj);
        if h.transposed {
            off = block::transpose(&off);
        }
        (
            off,
            sym6(&matmul(&pb, pi)),
            sym6(&matmul(&matmul(pj, b), pj)),
        )
    } else {
        (unsym6(b6), *b6, *b6)
    };
    if h.first {
        vals[h.upper] = off;
    } else {
        let t = &mut vals[h.upper];
        for r in 0..3 {
            for c in 0..3 {
                t[r][c] += off[r][c];
            }
        }
    }
    // The row's own particle is min(i, j).
    let (dr, dc) = if h.transposed { (dj, di) } else { (di, dj) };
    for t in 0..6 {
        loc[at + t] -= dr[t];
        acc_c[at + t] -= dc[t];
    }
}

/// Springs per chunk of [`ChunkGeometry`].
const CHUNK: usize = 8;

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
    fn compute(&mut self, x: &[f64], chunk: &[crate::model::HotSpring]) {
        for (k, h) in chunk.iter().enumerate() {
            for r in 0..3 {
                self.e[r][k] = x[3 * h.j + r] - x[3 * h.i + r];
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

/// Which parts a private assembly call computes.
#[derive(Clone, Copy)]
pub(crate) struct AssemblyMode {
    pub(crate) clamp: bool,
    pub(crate) damping_in_dfdx: DampingInDfdx,
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
    /// then `f_p <- P_p f_p` for constrained particles. No allocation.
    pub(crate) fn eval_force(&self, x: &[f64], v: &[f64], f: &mut [f64]) {
        let n = self.n_particles();
        assert!(
            x.len() == 3 * n && v.len() == 3 * n && f.len() == 3 * n,
            "force: x, v and f must have length 3 n = {}",
            3 * n
        );
        self.init_force(v, f);
        let damping = self.options.damping;
        let mut geo = ChunkGeometry::new();
        for chunk in self.hot.chunks(CHUNK) {
            geo.compute(x, chunk);
            for (k, s) in chunk.iter().enumerate() {
                let (e, l, inv_l) = geo.get(k);
                if l <= 0.0 || l.is_nan() {
                    continue; // coincident endpoints: no direction, no force
                }
                let (i, j) = (s.i, s.j);
                let u = e * inv_l;
                let mut fi = u * (s.stiffness * (l - s.rest_length));
                match damping {
                    SpringDamping::Projected => {
                        let dv = point(v, j) - point(v, i);
                        fi += u * (s.damping * dv.dot(&u));
                    }
                    SpringDamping::Incorrect => {
                        let dv = point(v, j) - point(v, i);
                        fi += dv * s.damping;
                    }
                    SpringDamping::None => {}
                }
                for r in 0..3 {
                    f[3 * i + r] += fi[r];
                    f[3 * j + r] -= fi[r];
                }
            }
        }
        self.project_rows(f);
    }

    /// `f_p <- P_p f_p` for the constrained particles.
    pub(crate) fn project_rows(&self, f: &mut [f64]) {
        for &p in &self.constrained_list {
            let fp = [f[3 * p], f[3 * p + 1], f[3 * p + 2]];
            let q = block::mul_vec(&self.proj[p], &fp);
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
    /// written at the end, so the matrices need no zeroing pass.
    pub(crate) fn assemble(
        &self,
        x: &[f64],
        v: &[f64],
        mut f: Option<&mut [f64]>,
        dfdx: &mut SymBlockMatrix,
        dfdv: Option<&mut SymBlockMatrix>,
        mode: AssemblyMode,
    ) {
        let n = self.n_particles();
        assert!(
            x.len() == 3 * n && v.len() == 3 * n && f.as_ref().is_none_or(|f| f.len() == 3 * n),
            "force_jacobians: x, v (and f) must have length 3 n = {}",
            3 * n
        );
        assert!(
            dfdx.n_blocks() == n
                && dfdx.values().len() == self.pattern.stored_blocks()
                && dfdv
                    .as_ref()
                    .is_none_or(|m| m.values().len() == self.pattern.stored_blocks()),
            "force_jacobians: matrices must be on the model's pattern (use jacobian_pattern())"
        );
        if let Some(f) = f.as_deref_mut() {
            self.init_force(v, f);
        }
        let mut guard = self.diag_acc.0.try_lock();
        let mut local: Vec<[f64; 12]> = Vec::new();
        let acc: &mut [[f64; 12]] = match guard.as_deref_mut() {
            Ok(buf) if buf.len() == n => buf,
            _ => {
                local.resize(n, [0.0; 12]);
                &mut local
            }
        };
        acc.fill([0.0; 12]);
        let damping = self.options.damping;
        let damping_dx = damping == SpringDamping::Projected
            && mode.damping_in_dfdx == DampingInDfdx::Symmetrize;
        let need_dv = damping_dx || (f.is_some() && damping != SpringDamping::None);
        let vx = dfdx.values_mut();
        let mut vv: Option<&mut [Block3]> = dfdv.map(|m| m.values_mut());
        // Row by row (r = min(i, j)): the diagonal contributions to r stay in
        // a local accumulator, those to the other endpoint go to `acc`; when
        // the row is done its diagonal block is final and written. Springs go
        // in chunks: the square roots and divisions of a chunk are
        // independent, so they overlap instead of serialising the loop.
        let clamp_floor = if mode.clamp { 0.0 } else { f64::NEG_INFINITY };
        let c_air = self.options.air_friction;
        let mut geo = ChunkGeometry::new();
        for r in 0..n {
            let mut loc = acc[r];
            let row = &self.hot[self.hot_row_ptr[r]..self.hot_row_ptr[r + 1]];
            for chunk in row.chunks(CHUNK) {
                geo.compute(x, chunk);
                for (k, h) in chunk.iter().enumerate() {
                    let (e, l, inv_l) = geo.get(k);
                    let (i, j) = (h.i, h.j);
                    if l <= 0.0 || l.is_nan() {
                        // Coincident endpoints: no direction, no force, no Jacobian.
                        if h.first {
                            vx[h.upper] = block::ZERO;
                            if let Some(vv) = vv.as_deref_mut() {
                                vv[h.upper] = block::ZERO;
                            }
                        }
                        continue;
                    }
                    let u = e * inv_l;
                    let dv = if need_dv {
                        point(v, j) - point(v, i)
                    } else {
                        Vector3::zeros()
                    };
                    if let Some(f) = f.as_deref_mut() {
                        let mut fi = u * (h.stiffness * (l - h.rest_length));
                        match damping {
                            SpringDamping::Projected => fi += u * (h.damping * dv.dot(&u)),
                            SpringDamping::Incorrect => fi += dv * h.damping,
                            SpringDamping::None => {}
                        }
                        for q in 0..3 {
                            f[3 * i + q] += fi[q];
                            f[3 * j + q] -= fi[q];
                        }
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
                    if damping_dx && h.damping != 0.0 {
                        let g = damping_position_block(h.damping, l, &u, &dv);
                        let gs = sym6(&block::add(&g, &block::transpose(&g)));
                        for t in 0..6 {
                            k6[t] += 0.5 * gs[t];
                        }
                    }
                    let constrained = self.constrained[i] || self.constrained[j];
                    let other = i.max(j);
                    let acc_c = &mut acc[other];
                    scatter_sym(vx, &mut loc, acc_c, 0, h, constrained, &self.proj, &k6);
                    if let Some(vv) = vv.as_deref_mut() {
                        let d = h.damping;
                        let d6 = match damping {
                            SpringDamping::Projected => uu.map(|w| d * w),
                            SpringDamping::Incorrect => [d, 0.0, 0.0, d, 0.0, d],
                            SpringDamping::None => [0.0; 6],
                        };
                        scatter_sym(vv, &mut loc, acc_c, 6, h, constrained, &self.proj, &d6);
                    }
                }
            }
            let idx = self.diag_index[r];
            vx[idx] = unsym6(&loc[..6]);
            if let Some(vv) = vv.as_deref_mut() {
                let mut d = unsym6(&loc[6..]);
                if c_air != 0.0 {
                    d = block::add(&d, &block::scale(&self.proj[r], -c_air));
                }
                vv[idx] = d;
            }
        }
        if let Some(f) = f {
            self.project_rows(f);
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
            let (pi, pj) = (&self.proj[i], &self.proj[j]);
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
        for (s, sl) in self.springs.iter().zip(&self.slots) {
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
                dfdv.add_to_slot(self.diag_slots[p], &block::scale(&pp, -c));
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
            SymBlockMatrix::new(self.pattern.clone()),
            SymBlockMatrix::new(self.pattern.clone()),
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
            if !Arc::ptr_eq(m.pattern(), &self.pattern) && **m.pattern() != *self.pattern {
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
        self.pattern.clone()
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

    /// The tutorial's eq. 50 (see [`MassSpringModel::assemble_linearized`]).
    fn linearized_jacobians(&self, dfdx: &mut SymBlockMatrix, dfdv: &mut SymBlockMatrix) -> bool {
        self.assemble_linearized(dfdx, dfdv);
        true
    }

    /// Pins, sliding constraints and collisions (tutorial section 4.2).
    ///
    /// 1. Permanent constraints: each constrained coordinate of `x_p` is reset
    ///    to its prescribed value and the constrained components of `v_p` are
    ///    zeroed (a pinned particle gets `x_p` = its pin, `v_p = 0`).
    /// 2. Colliders: a particle with signed distance `phi <= margin` to a
    ///    collider is in contact. If `phi < 0` it is projected back onto the
    ///    surface; an inward normal velocity (`v . n < 0`) is removed. The
    ///    normal is then constrained for this step unless the particle
    ///    separates (`v . n > 0`) or the force pulls it away (`f . n > 0`).
    /// 3. `constraints` is cleared (recreated if sized for another model) and
    ///    filled with every active direction `d` of particle `p` with value 0:
    ///    **the unknown is the velocity change `dv` of the reduced velocity
    ///    form, and `d . dv_p = 0`** keeps the already-zeroed constrained
    ///    velocity components at zero during the step.
    ///
    /// The active directions also project `force` and the Jacobians until the
    /// next `begin_step`.
    fn begin_step(&mut self, _t: f64, x: &mut [f64], v: &mut [f64], constraints: &mut Constraints) {
        self.apply_constraints_and_contacts(x, v);
        let n = self.n_particles();
        if constraints.n_particles() != n {
            *constraints = Constraints::new(n);
        } else {
            constraints.clear();
        }
        for &p in &self.constrained_list {
            let d = &self.active[p];
            if d.count == 3 {
                // Orthonormal and complete: equivalent to a pin at dv = 0.
                constraints
                    .pin(p, [0.0; 3])
                    .expect("particle index is in range");
            } else {
                for k in 0..d.count {
                    constraints
                        .constrain(p, d.dirs[k], 0.0)
                        .expect("directions are orthonormal and finite");
                }
            }
        }
    }
}
