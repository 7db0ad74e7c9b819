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

/// `s u u^T`.
#[inline(always)]
fn outer_scaled(s: f64, u: &Vector3<f64>) -> Block3 {
    let mut m = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = s * u[r] * u[c];
        }
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

/// Which parts a private assembly call computes.
#[derive(Clone, Copy)]
pub(crate) struct AssemblyMode {
    pub(crate) clamp: bool,
    pub(crate) damping_in_dfdx: DampingInDfdx,
}

impl MassSpringModel {
    /// `f(x, v)` into `f`: gravity, external forces, air friction, springs,
    /// then `f_p <- P_p f_p` for constrained particles. No allocation.
    pub(crate) fn eval_force(&self, x: &[f64], v: &[f64], f: &mut [f64]) {
        let n = self.n_particles();
        assert!(
            x.len() == 3 * n && v.len() == 3 * n && f.len() == 3 * n,
            "force: x, v and f must have length 3 n = {}",
            3 * n
        );
        let g = self.options.gravity;
        let c = self.options.air_friction;
        for p in 0..n {
            let m = self.particle_mass[p];
            for r in 0..3 {
                f[3 * p + r] = m * g[r] + self.external[3 * p + r] - c * v[3 * p + r];
            }
        }
        let damping = self.options.damping;
        for s in &self.springs {
            let (i, j) = (s.i, s.j);
            let e = point(x, j) - point(x, i);
            let l = e.norm();
            if l <= 0.0 {
                continue; // coincident endpoints: no direction, no force
            }
            let u = e / l;
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

    /// Adds a spring block `b` (off-diagonal `b`, diagonals `-b`), projected
    /// for constrained endpoints.
    #[inline(always)]
    fn scatter(&self, m: &mut SymBlockMatrix, sl: &SpringSlots, i: usize, j: usize, b: &Block3) {
        if self.constrained[i] || self.constrained[j] {
            let (pi, pj) = (&self.proj[i], &self.proj[j]);
            m.add_to_slot(sl.ij, &matmul(&matmul(pi, b), pj));
            m.add_to_slot(sl.ii, &neg(&matmul(&matmul(pi, b), pi)));
            m.add_to_slot(sl.jj, &neg(&matmul(&matmul(pj, b), pj)));
        } else {
            let nb = neg(b);
            m.add_to_slot(sl.ij, b);
            m.add_to_slot(sl.ii, &nb);
            m.add_to_slot(sl.jj, &nb);
        }
    }

    /// Refills `dfdx` and (if given) `dfdv` at `(x, v)`. No allocation.
    pub(crate) fn assemble_jacobians(
        &self,
        x: &[f64],
        v: &[f64],
        dfdx: &mut SymBlockMatrix,
        mut dfdv: Option<&mut SymBlockMatrix>,
        mode: AssemblyMode,
    ) {
        let n = self.n_particles();
        assert!(
            x.len() == 3 * n && v.len() == 3 * n,
            "force_jacobians: x and v must have length 3 n = {}",
            3 * n
        );
        assert!(
            dfdx.n_blocks() == n && dfdv.as_ref().is_none_or(|m| m.n_blocks() == n),
            "force_jacobians: matrices must have {n} block rows (use jacobian_pattern())"
        );
        dfdx.set_zero();
        if let Some(m) = dfdv.as_deref_mut() {
            m.set_zero();
        }
        let damping = self.options.damping;
        let damping_dx = damping == SpringDamping::Projected
            && mode.damping_in_dfdx == DampingInDfdx::Symmetrize;
        for (s, sl) in self.springs.iter().zip(&self.slots) {
            let (i, j) = (s.i, s.j);
            let e = point(x, j) - point(x, i);
            let l = e.norm();
            if l <= 0.0 {
                continue;
            }
            let u = e / l;
            let mut a = 1.0 - s.rest_length / l;
            if mode.clamp && a < 0.0 {
                a = 0.0;
            }
            let mut kb = stiffness_block(s.stiffness, a, &u);
            if damping_dx && s.damping != 0.0 {
                let dv = point(v, j) - point(v, i);
                let g = damping_position_block(s.damping, l, &u, &dv);
                for r in 0..3 {
                    for c in 0..3 {
                        kb[r][c] += 0.5 * (g[r][c] + g[c][r]);
                    }
                }
            }
            self.scatter(dfdx, sl, i, j, &kb);
            if let Some(m) = dfdv.as_deref_mut() {
                match damping {
                    SpringDamping::Projected => {
                        self.scatter(m, sl, i, j, &outer_scaled(s.damping, &u));
                    }
                    SpringDamping::Incorrect => {
                        self.scatter(m, sl, i, j, &block::scale(&block::IDENTITY, s.damping));
                    }
                    SpringDamping::None => {}
                }
            }
        }
        let c = self.options.air_friction;
        if c != 0.0
            && let Some(m) = dfdv
        {
            for p in 0..n {
                m.add_to_slot(self.diag_slots[p], &block::scale(&self.proj[p], -c));
            }
        }
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
            let u = e / l;
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
