//! The mass-spring model: particles, springs, damping, permanent particle
//! constraints, colliders, and the sparsity pattern of its Jacobians.

use std::sync::Arc;

use hookean_sparse::block::{self, Block3};
use hookean_sparse::{BlockPattern, Slot, SymBlockMatrix};
use nalgebra::Vector3;

use crate::collide::Collider;
use crate::error::MassSpringError;

/// A spring between particles `i` and `j` (docs/ARCHITECTURE.md, "the reference drape"):
/// force on `i` is `f_i = k (l - l0) u + damping term`, `u = (x_j - x_i) / l`,
/// and `f_j = -f_i`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spring {
    /// First particle.
    pub i: usize,
    /// Second particle.
    pub j: usize,
    /// Rest length `l0` (m), positive.
    pub rest_length: f64,
    /// Stiffness `k` (N/m), non-negative.
    pub stiffness: f64,
    /// Damping `d` (N s/m), non-negative.
    pub damping: f64,
}

impl Spring {
    /// A spring `(i, j, l0, k, d)`.
    pub fn new(i: usize, j: usize, rest_length: f64, stiffness: f64, damping: f64) -> Self {
        Self {
            i,
            j,
            rest_length,
            stiffness,
            damping,
        }
    }
}

/// How the spring damping coefficient `d` acts (one choice per model).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SpringDamping {
    /// Projected damping along the spring (the default):
    /// `f_i = d ((v_j - v_i) . u) u`. Central, so it conserves angular
    /// momentum and does not damp rigid rotation. `df_i/dv_j = d u u^T`.
    #[default]
    Projected,
    /// The "incorrect" spring damping the filtering paper discusses,
    /// `f_i = d (v_j - v_i)`: not central, it damps rigid rotation.
    /// `df_i/dv_j = d I`.
    Incorrect,
    /// No spring damping (`d` is ignored).
    None,
}

/// What the symmetric `df/dx` of [`SecondOrderProblem::force_jacobians`](hookean_problem::SecondOrderProblem::force_jacobians)
/// does with the position derivative of projected damping,
/// `G = d/l [ (u . dv)(I - u u^T) + u dv^T (I - u u^T) ]` (`dv = v_j - v_i`),
/// which is not symmetric and cannot be stored in a symmetric block matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DampingInDfdx {
    /// Drop it (Baraff-Witkin; the default): `df/dx` is then the stiffness
    /// Jacobian only, exact when `v_j = v_i` along every damped spring.
    #[default]
    Drop,
    /// Store its symmetric part `(G + G^T) / 2`.
    Symmetrize,
}

/// Model-wide options. Defaults: projected damping, no air friction,
/// gravity `(0, 0, -9.81)`, clamped stiffness, damping dropped from `df/dx`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelOptions {
    /// The spring damping model. Default [`SpringDamping::Projected`].
    pub damping: SpringDamping,
    /// Air (fluid) friction `c` (N s/m) in `f_p = -c v_p`. Default `0`.
    pub air_friction: f64,
    /// Gravitational acceleration (m/s^2). Default `(0, 0, -9.81)`.
    pub gravity: [f64; 3],
    /// Replace `1 - l0/l` by `max(0, 1 - l0/l)` in the stiffness blocks so
    /// that `df/dx` is negative semidefinite and `M - h df/dv - h^2 df/dx`
    /// is SPD (docs/ARCHITECTURE.md). Default `true`.
    pub clamp_stiffness: bool,
    /// See [`DampingInDfdx`]. Default [`DampingInDfdx::Drop`].
    pub damping_in_dfdx: DampingInDfdx,
}

impl Default for ModelOptions {
    fn default() -> Self {
        Self {
            damping: SpringDamping::Projected,
            air_friction: 0.0,
            gravity: [0.0, 0.0, -9.81],
            clamp_stiffness: true,
            damping_in_dfdx: DampingInDfdx::Drop,
        }
    }
}

/// The constraint state of a particle (tutorial section 4.2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ParticleConstraint {
    /// Moves freely.
    Free,
    /// Nailed to a position.
    Pinned {
        /// Where it is held.
        position: [f64; 3],
    },
    /// Its motion along one or two orthonormal directions is prescribed
    /// (one direction: it slides in a plane; two: along a line).
    Sliding {
        /// Number of constrained directions (1 or 2).
        count: usize,
        /// The orthonormal directions (the first `count` are used).
        directions: [[f64; 3]; 2],
        /// The prescribed coordinates `d_k . x_p`.
        values: [f64; 2],
    },
}

/// Up to three orthonormal directions with prescribed coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Dirs {
    pub(crate) count: usize,
    pub(crate) dirs: [[f64; 3]; 3],
    pub(crate) values: [f64; 3],
}

impl Dirs {
    pub(crate) const EMPTY: Dirs = Dirs {
        count: 0,
        dirs: [[0.0; 3]; 3],
        values: [0.0; 3],
    };

    /// Adds direction `d` (orthonormalised against the others) with
    /// coordinate `value` of the current point; returns false when `d` is
    /// degenerate (zero, dependent, or a fourth direction).
    pub(crate) fn push(&mut self, d: [f64; 3], value: f64) -> bool {
        if self.count == 3 {
            return false;
        }
        let scale = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let mut w = d;
        let mut c = value;
        for k in 0..self.count {
            let e = self.dirs[k];
            let p = w[0] * e[0] + w[1] * e[1] + w[2] * e[2];
            for r in 0..3 {
                w[r] -= p * e[r];
            }
            c -= p * self.values[k];
        }
        let len = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        if !(scale > 0.0 && len > 1e-9 * scale) {
            return false;
        }
        self.dirs[self.count] = [w[0] / len, w[1] / len, w[2] / len];
        self.values[self.count] = c / len;
        self.count += 1;
        true
    }

    /// The projector `P = I - sum_k d_k d_k^T` onto admissible motions.
    pub(crate) fn projector(&self) -> Block3 {
        let mut p = block::IDENTITY;
        for d in &self.dirs[..self.count] {
            for r in 0..3 {
                for c in 0..3 {
                    p[r][c] -= d[r] * d[c];
                }
            }
        }
        p
    }
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
#[derive(Debug, Default)]
pub(crate) struct DiagScratch(pub(crate) std::sync::Mutex<Vec<crate::assembly::Acc>>);

impl Clone for DiagScratch {
    fn clone(&self) -> Self {
        let n = self.0.lock().map(|v| v.len()).unwrap_or(0);
        DiagScratch(std::sync::Mutex::new(vec![[0.0; 12]; n]))
    }
}

/// A mass-spring system `M x'' = f(x, v)` (the tutorial's section 1.1, the
/// filtering paper's eq. 1) with lumped masses, springs, gravity, external
/// forces, air friction, pinned / sliding particles and colliders.
///
/// It implements [`hookean_problem::SecondOrderProblem`]: forces and both
/// Jacobians are assembled into 3x3 block matrices whose pattern (one block
/// per spring plus the diagonal) is built once in [`new`](Self::new); each
/// spring's block slots are cached, so refills do no search and no
/// allocation.
///
/// **Constraints.** A particle with constrained directions (pinned: all
/// three; sliding: one or two; in contact with a collider: the surface
/// normal, for the current step) is held by a support whose reaction
/// cancels the force along those directions: [`force`](hookean_problem::SecondOrderProblem::force)
/// returns `P_p f_p` with `P_p = I - sum_k d_k d_k^T`, and the Jacobian blocks
/// are `P_i (df_i/dx_j) P_j`, exact on admissible motions. Hence explicit
/// integrators (which see only `force`) keep pinned particles fixed, and the
/// implicit matrix `M - h df/dv - h^2 df/dx` restricted to a constrained
/// direction is just the mass: even an unfiltered solve gives `d . dv_p = 0`.
/// Implicit integrators also get the directions as [`hookean_sparse::Constraints`]
/// from `begin_step`: each active direction `d` of particle `p` is passed
/// with value 0, meaning `d . dv_p = 0` for the unknown `dv` (the velocity
/// change of the reduced velocity form); `begin_step` has already zeroed
/// the constrained velocity components (`v_p = 0` for a pinned particle,
/// the inward normal velocity removed for a contact), so they stay zero.
#[derive(Debug, Clone)]
pub struct MassSpringModel {
    pub(crate) particle_mass: Vec<f64>,
    pub(crate) mass: Vec<f64>,
    pub(crate) springs: Vec<Spring>,
    pub(crate) options: ModelOptions,
    pub(crate) external: Vec<f64>,
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
    /// row, nor its diagonal, touches a constrained particle. Kept up to date by [`activate`](Self::activate) and
    /// [`refresh_permanent`](Self::refresh_permanent).
    pub(crate) row_fast: Vec<bool>,
    /// `touch_rows[touch_ptr[p]..touch_ptr[p + 1]]` are the block rows whose
    /// springs or diagonal touch particle `p` (`p` itself and the rows
    /// `min(i, j)` of its springs).
    pub(crate) touch_ptr: Vec<usize>,
    /// See `touch_ptr`.
    pub(crate) touch_rows: Vec<u32>,
    pub(crate) diag_acc: DiagScratch,
    /// Permanent constraints (pins, sliding), per particle.
    pub(crate) fixes: Vec<Dirs>,
    /// Active constraint directions of the current step (permanent + contacts).
    pub(crate) active: Vec<Dirs>,
    /// `P_p` of the active directions (identity for free particles).
    pub(crate) proj: Vec<Block3>,
    /// Whether particle `p` has active constraints.
    pub(crate) constrained: Vec<bool>,
    /// The particles with active constraints.
    pub(crate) constrained_list: Vec<usize>,
    pub(crate) colliders: Vec<Collider>,
    pub(crate) contact_count: usize,
    pub(crate) scratch: Vec<f64>,
    pub(crate) faces: Vec<[usize; 3]>,
    pub(crate) revision: u64,
}

impl MassSpringModel {
    /// A model of `masses.len()` particles (lumped masses in kg) joined by
    /// `springs`, with [`ModelOptions`]. Builds the Jacobian pattern and the
    /// per-spring slots once.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidMass`] for a zero, negative or non-finite
    /// mass; [`MassSpringError::ParticleOutOfRange`], [`MassSpringError::SelfSpring`],
    /// [`MassSpringError::ZeroLengthSpring`] (rest length 0) and
    /// [`MassSpringError::InvalidSpring`] for bad springs;
    /// [`MassSpringError::InvalidParameter`] / [`MassSpringError::NonFinite`]
    /// for bad options.
    pub fn new(
        masses: Vec<f64>,
        springs: Vec<Spring>,
        options: ModelOptions,
    ) -> Result<Self, MassSpringError> {
        let n = masses.len();
        for (p, &m) in masses.iter().enumerate() {
            if !(m > 0.0 && m.is_finite()) {
                return Err(MassSpringError::InvalidMass {
                    particle: p,
                    mass: m,
                });
            }
        }
        for (s, sp) in springs.iter().enumerate() {
            for particle in [sp.i, sp.j] {
                if particle >= n {
                    return Err(MassSpringError::ParticleOutOfRange {
                        spring: s,
                        particle,
                        n_particles: n,
                    });
                }
            }
            if sp.i == sp.j {
                return Err(MassSpringError::SelfSpring {
                    spring: s,
                    particle: sp.i,
                });
            }
            if sp.rest_length == 0.0 {
                return Err(MassSpringError::ZeroLengthSpring {
                    spring: s,
                    i: sp.i,
                    j: sp.j,
                });
            }
            for (parameter, value) in [
                ("rest length", sp.rest_length),
                ("stiffness", sp.stiffness),
                ("damping", sp.damping),
            ] {
                if !(value >= 0.0 && value.is_finite()) {
                    return Err(MassSpringError::InvalidSpring {
                        spring: s,
                        parameter,
                        value,
                    });
                }
            }
        }
        check_options(&options)?;
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
        let mass = masses.iter().flat_map(|&m| [m, m, m]).collect();
        // The pattern's column indices are u32, so particle indices fit;
        // storage positions (from the pattern's slots) are checked.
        let to_u32 = |k: usize| {
            u32::try_from(k).map_err(|_| MassSpringError::InvalidParameter {
                name: "springs",
                message: format!("index {k} does not fit the 32-bit assembly tables"),
            })
        };
        let mut hot: Vec<HotSpring> = Vec::with_capacity(springs.len());
        for s in &springs {
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
            particle_mass: masses,
            mass,
            springs,
            options,
            external: vec![0.0; 3 * n],
            pattern,
            slots,
            diag_slots,
            hot,
            hot_row_ptr,
            diag_index,
            row_fast: vec![true; n],
            touch_ptr,
            touch_rows,
            diag_acc: DiagScratch(std::sync::Mutex::new(vec![[0.0; 12]; n])),
            fixes: vec![Dirs::EMPTY; n],
            active: vec![Dirs::EMPTY; n],
            proj: vec![block::IDENTITY; n],
            constrained: vec![false; n],
            constrained_list: Vec::with_capacity(n),
            colliders: Vec::new(),
            contact_count: 0,
            scratch: vec![0.0; 3 * n],
            faces: Vec::new(),
            revision: 0,
        })
    }

    /// Number of particles.
    pub fn n_particles(&self) -> usize {
        self.particle_mass.len()
    }

    /// The particle masses (kg), one per particle.
    pub fn particle_masses(&self) -> &[f64] {
        &self.particle_mass
    }

    /// The springs.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }

    /// A counter that changes whenever the material or the permanent
    /// constraints change ([`set_options`](Self::set_options),
    /// [`pin`](Self::pin), [`constrain_direction`](Self::constrain_direction),
    /// [`release`](Self::release)): the tutorial's constant linearised
    /// Jacobian (eq. 50) needs rebuilding only when this (or the step size)
    /// changes.
    pub fn material_revision(&self) -> u64 {
        self.revision
    }

    /// The model options.
    pub fn options(&self) -> &ModelOptions {
        &self.options
    }

    /// Replaces the options (damping model, air friction, gravity, clamping).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a negative air friction,
    /// [`MassSpringError::NonFinite`] for a non-finite gravity.
    pub fn set_options(&mut self, options: ModelOptions) -> Result<(), MassSpringError> {
        check_options(&options)?;
        self.options = options;
        self.revision += 1;
        Ok(())
    }

    /// Sets a constant external force (N) on `particle`, added to gravity.
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`], [`MassSpringError::NonFinite`].
    pub fn set_external_force(
        &mut self,
        particle: usize,
        force: [f64; 3],
    ) -> Result<(), MassSpringError> {
        self.check_particle(particle)?;
        if let Some(c) = force.iter().position(|v| !v.is_finite()) {
            return Err(MassSpringError::NonFinite {
                what: "external force",
                index: 3 * particle + c,
            });
        }
        self.external[3 * particle..3 * particle + 3].copy_from_slice(&force);
        Ok(())
    }

    /// Pins `particle` at `position`: from the next
    /// [`begin_step`](hookean_problem::SecondOrderProblem::begin_step) on, it is
    /// held there with zero velocity.
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`], [`MassSpringError::NonFinite`].
    pub fn pin(&mut self, particle: usize, position: [f64; 3]) -> Result<(), MassSpringError> {
        self.check_particle(particle)?;
        if let Some(c) = position.iter().position(|v| !v.is_finite()) {
            return Err(MassSpringError::NonFinite {
                what: "pin position",
                index: c,
            });
        }
        let mut d = Dirs::EMPTY;
        for (c, &value) in position.iter().enumerate() {
            let mut e = [0.0; 3];
            e[c] = 1.0;
            d.push(e, value);
        }
        self.fixes[particle] = d;
        self.refresh_permanent();
        self.revision += 1;
        Ok(())
    }

    /// Constrains `particle` so that `direction . x_p` stays at its value for
    /// `position` (the particle slides in the plane through `position`
    /// orthogonal to `direction`; a second call adds a second direction: it
    /// slides along a line).
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`], [`MassSpringError::NonFinite`],
    /// [`MassSpringError::InvalidParameter`] for a zero direction, one
    /// dependent on the particle's earlier ones, or a third direction (use
    /// [`pin`](Self::pin)).
    pub fn constrain_direction(
        &mut self,
        particle: usize,
        direction: [f64; 3],
        position: [f64; 3],
    ) -> Result<(), MassSpringError> {
        self.check_particle(particle)?;
        if let Some(c) = direction
            .iter()
            .chain(position.iter())
            .position(|v| !v.is_finite())
        {
            return Err(MassSpringError::NonFinite {
                what: "constraint direction or position",
                index: c,
            });
        }
        let mut d = self.fixes[particle];
        let value =
            direction[0] * position[0] + direction[1] * position[1] + direction[2] * position[2];
        if d.count >= 2 || !d.push(direction, value) {
            return Err(MassSpringError::InvalidParameter {
                name: "direction",
                message: format!(
                    "direction {direction:?} is zero, dependent on the earlier ones, or a third direction of particle {particle}"
                ),
            });
        }
        self.fixes[particle] = d;
        self.refresh_permanent();
        self.revision += 1;
        Ok(())
    }

    /// Removes every permanent constraint of `particle`.
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`].
    pub fn release(&mut self, particle: usize) -> Result<(), MassSpringError> {
        self.check_particle(particle)?;
        self.fixes[particle] = Dirs::EMPTY;
        self.refresh_permanent();
        self.revision += 1;
        Ok(())
    }

    /// The permanent constraint state of `particle` (contacts not included).
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`].
    pub fn constraint(&self, particle: usize) -> Result<ParticleConstraint, MassSpringError> {
        self.check_particle(particle)?;
        let d = &self.fixes[particle];
        Ok(match d.count {
            0 => ParticleConstraint::Free,
            3 => {
                // Pins are stored along the coordinate axes.
                ParticleConstraint::Pinned { position: d.values }
            }
            count => ParticleConstraint::Sliding {
                count,
                directions: [d.dirs[0], d.dirs[1]],
                values: [d.values[0], d.values[1]],
            },
        })
    }

    /// Number of constrained directions of `particle` in the current step
    /// (permanent constraints and contacts found by the last `begin_step`).
    pub fn active_constraint_count(&self, particle: usize) -> usize {
        self.active.get(particle).map_or(0, |d| d.count)
    }

    /// Adds a collider (plane or sphere), handled in every `begin_step`.
    pub fn add_collider(&mut self, collider: Collider) {
        self.colliders.push(collider);
    }

    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// Number of particle-collider contacts constrained by the last `begin_step`.
    pub fn contact_count(&self) -> usize {
        self.contact_count
    }

    /// Sets the triangles used by OBJ export (vertex indices are particles).
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`] for an index out of range.
    pub fn set_faces(&mut self, faces: Vec<[usize; 3]>) -> Result<(), MassSpringError> {
        for f in &faces {
            for &p in f {
                self.check_particle(p)?;
            }
        }
        self.faces = faces;
        Ok(())
    }

    /// The triangles for OBJ export (empty for ropes and point sets).
    pub fn faces(&self) -> &[[usize; 3]] {
        &self.faces
    }

    /// Checks a state: lengths `3 n`, finite entries, and no spring whose
    /// endpoints coincide (its direction would be undefined).
    ///
    /// The [`SecondOrderProblem`](hookean_problem::SecondOrderProblem) methods
    /// are the unchecked hot path; call this once on states from outside.
    ///
    /// # Errors
    /// [`MassSpringError::DimensionMismatch`], [`MassSpringError::NonFinite`],
    /// [`MassSpringError::ZeroLengthSpring`].
    pub fn check_state(&self, x: &[f64], v: &[f64]) -> Result<(), MassSpringError> {
        let dim = 3 * self.n_particles();
        crate::error::check_vec("x", x, dim)?;
        crate::error::check_vec("v", v, dim)?;
        for (s, sp) in self.springs.iter().enumerate() {
            if (point(x, sp.j) - point(x, sp.i)).norm() == 0.0 {
                return Err(MassSpringError::ZeroLengthSpring {
                    spring: s,
                    i: sp.i,
                    j: sp.j,
                });
            }
        }
        Ok(())
    }

    pub(crate) fn check_particle(&self, particle: usize) -> Result<(), MassSpringError> {
        if particle < self.n_particles() {
            Ok(())
        } else {
            Err(MassSpringError::NoSuchParticle {
                particle,
                n_particles: self.n_particles(),
            })
        }
    }

    /// Resets the active constraints to the permanent ones (drops contacts).
    pub(crate) fn refresh_permanent(&mut self) {
        for &p in &self.constrained_list {
            self.constrained[p] = false;
            self.active[p] = Dirs::EMPTY;
            self.proj[p] = block::IDENTITY;
            for &r in &self.touch_rows[self.touch_ptr[p]..self.touch_ptr[p + 1]] {
                self.row_fast[r as usize] = true;
            }
        }
        self.constrained_list.clear();
        for p in 0..self.fixes.len() {
            if self.fixes[p].count > 0 {
                self.activate(p, self.fixes[p]);
            }
        }
        self.contact_count = 0;
    }

    pub(crate) fn activate(&mut self, p: usize, dirs: Dirs) {
        if !self.constrained[p] {
            self.constrained[p] = true;
            self.constrained_list.push(p);
            for &r in &self.touch_rows[self.touch_ptr[p]..self.touch_ptr[p + 1]] {
                self.row_fast[r as usize] = false;
            }
        }
        self.active[p] = dirs;
        self.proj[p] = dirs.projector();
    }
}

fn check_options(o: &ModelOptions) -> Result<(), MassSpringError> {
    if !(o.air_friction >= 0.0 && o.air_friction.is_finite()) {
        return Err(MassSpringError::InvalidParameter {
            name: "air_friction",
            message: format!("{} must be non-negative and finite", o.air_friction),
        });
    }
    if let Some(index) = o.gravity.iter().position(|g| !g.is_finite()) {
        return Err(MassSpringError::NonFinite {
            what: "gravity",
            index,
        });
    }
    Ok(())
}

/// Particle `p` of a flat xyz-interleaved vector.
#[inline(always)]
pub(crate) fn point(x: &[f64], p: usize) -> Vector3<f64> {
    Vector3::new(x[3 * p], x[3 * p + 1], x[3 * p + 2])
}
