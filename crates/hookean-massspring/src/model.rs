//! The mass-spring model: particles, springs, damping, permanent particle
//! constraints and colliders (the physics), with its assembly plan
//! (`assembly::AssemblyPlan`) and the constraints of the current step
//! ([`ActiveSet`]) as separate parts.

use crate::NonExhaustive;
use hookean_sparse::block::{self, Block3};
use nalgebra::Vector3;

use crate::assembly::AssemblyPlan;
use crate::collide::Collider;
use crate::contact::ContactState;
use crate::error::MassSpringError;
use crate::self_contact::{SelfCollision, SelfContact};

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
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for ModelOptions {
    fn default() -> Self {
        Self {
            damping: SpringDamping::Projected,
            air_friction: 0.0,
            gravity: [0.0, 0.0, -9.81],
            clamp_stiffness: true,
            damping_in_dfdx: DampingInDfdx::Drop,
            non_exhaustive: NonExhaustive(()),
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

    /// A pin at `position`: the three coordinate axes.
    pub(crate) fn pin(position: [f64; 3]) -> Dirs {
        let mut d = Dirs::EMPTY;
        for (c, &value) in position.iter().enumerate() {
            let mut e = [0.0; 3];
            e[c] = 1.0;
            d.push(e, value);
        }
        d
    }

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

/// The constraints of the current step: the active directions of each
/// particle (its permanent ones plus contacts), their projectors `P_p`, and
/// the list of constrained particles. Reset by `refresh_permanent` at the
/// start of every step, extended by `activate`.
#[derive(Debug, Clone)]
pub(crate) struct ActiveSet {
    /// Active constraint directions per particle.
    pub(crate) dirs: Vec<Dirs>,
    /// `P_p` of the active directions (identity for free particles).
    pub(crate) proj: Vec<Block3>,
    /// Whether particle `p` has active constraints.
    pub(crate) constrained: Vec<bool>,
    /// The particles with active constraints.
    pub(crate) list: Vec<usize>,
    /// Contacts found by the last collision pass.
    pub(crate) contact_count: usize,
    /// The velocity the constrained directions of a particle move with
    /// (zero for pins and static colliders; a moving collider's surface
    /// velocity): the prescribed value of direction `d` is `d . vel[p]`.
    pub(crate) vel: Vec<[f64; 3]>,
}

impl ActiveSet {
    fn new(n: usize) -> Self {
        Self {
            dirs: vec![Dirs::EMPTY; n],
            proj: vec![block::IDENTITY; n],
            constrained: vec![false; n],
            list: Vec::with_capacity(n),
            contact_count: 0,
            vel: vec![[0.0; 3]; n],
        }
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
    /// Where assembly writes each spring's blocks (built once).
    pub(crate) plan: AssemblyPlan,
    /// Permanent constraints (pins, sliding), per particle.
    pub(crate) fixes: Vec<Dirs>,
    /// The constraints of the current step (permanent + contacts).
    pub(crate) active_set: ActiveSet,
    pub(crate) colliders: Vec<Collider>,
    /// The contact state of the current step (friction, self-contact).
    pub(crate) contact: ContactState,
    pub(crate) scratch: Vec<f64>,
    pub(crate) faces: Vec<[usize; 3]>,
    pub(crate) revision: u64,
    /// Pin groups (`handles.rs`).
    pub(crate) handles: Vec<crate::handles::Handle>,
    /// The soft pins of the current step.
    pub(crate) soft_pins: Vec<crate::handles::SoftPin>,
    /// The wind on the triangles (`wind.rs`), if on.
    pub(crate) wind: Option<Box<crate::wind::WindState>>,
}

impl MassSpringModel {
    /// A model of `masses.len()` particles (lumped masses in kg) joined by
    /// `springs`, with [`ModelOptions`]. Builds its assembly plan (the Jacobian
    /// pattern and the positions of every spring's blocks) once.
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
        if n == 0 {
            return Err(MassSpringError::InvalidParameter {
                name: "masses",
                message: "a model needs at least one particle".into(),
            });
        }
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
        let plan = AssemblyPlan::new(n, &springs)?;
        let mass = masses.iter().flat_map(|&m| [m, m, m]).collect();
        Ok(Self {
            particle_mass: masses,
            mass,
            springs,
            options,
            external: vec![0.0; 3 * n],
            plan,
            fixes: vec![Dirs::EMPTY; n],
            active_set: ActiveSet::new(n),
            colliders: Vec::new(),
            contact: ContactState::default(),
            scratch: vec![0.0; 3 * n],
            faces: Vec::new(),
            revision: 0,
            handles: Vec::new(),
            soft_pins: Vec::new(),
            wind: None,
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

    /// The constant external forces (N), three per particle (zero where
    /// none was set).
    pub fn external_forces(&self) -> &[f64] {
        &self.external
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
        self.fixes[particle] = Dirs::pin(position);
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
        self.active_set.dirs.get(particle).map_or(0, |d| d.count)
    }

    /// Adds a collider (plane, sphere or mesh), handled in every
    /// `begin_step` (and, for meshes, `end_step`).
    pub fn add_collider(&mut self, collider: Collider) {
        self.colliders.push(collider);
    }

    /// Turns cloth self-collision on (`Some`) or off (`None`) on the
    /// model's triangles ([`set_faces`](Self::set_faces) first): proximity
    /// repulsion inside the implicit step and the continuous pass after it
    /// (docs/CONTACT.md).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a non-positive thickness, a
    /// negative stiffness, or a model without triangles.
    pub fn set_self_collision(
        &mut self,
        options: Option<SelfCollision>,
    ) -> Result<(), MassSpringError> {
        self.contact.self_contact = match options {
            Some(o) => Some(Box::new(SelfContact::new(
                self.n_particles(),
                &self.faces,
                o,
            )?)),
            None => None,
        };
        Ok(())
    }

    /// The largest self-collision thickness `h_th` the model's triangles at
    /// positions `x` admit: the smallest altitude of a triangle (a cloth
    /// grid's spacing `s` gives `s / sqrt 2`, the distance of a vertex from
    /// the diagonal of its square). Non-adjacent features of a flat mesh
    /// are about this far apart, so a thicker `h_th` makes the cloth at
    /// rest repel itself (docs/CONTACT.md). Infinite without triangles.
    pub fn self_thickness_limit(&self, x: &[f64]) -> f64 {
        self.faces
            .iter()
            .filter(|t| t.iter().all(|&i| 3 * i + 3 <= x.len()))
            .map(|t| {
                let [a, b, c] = t.map(|i| point(x, i));
                let area2 = (b - a).cross(&(c - a)).norm();
                let longest = (b - a).norm().max((c - b).norm()).max((a - c).norm());
                area2 / longest
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Refuses a self-collision thickness the model's triangles at `x` do
    /// not admit ([`self_thickness_limit`](Self::self_thickness_limit)).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `self_thickness`, with
    /// the range.
    pub fn check_self_thickness(&self, x: &[f64]) -> Result<(), MassSpringError> {
        let Some(o) = self.self_collision() else {
            return Ok(());
        };
        let limit = self.self_thickness_limit(x);
        if o.thickness < limit {
            return Ok(());
        }
        Err(MassSpringError::InvalidParameter {
            name: "self_thickness",
            message: format!(
                "{:?} m is outside (0, {limit:.6}) m: it must be below the smallest altitude of the model's triangles at the start (a cloth grid: 0.707 of its spacing), or the flat cloth repels itself",
                o.thickness
            ),
        })
    }

    /// The self-collision options, if it is on.
    pub fn self_collision(&self) -> Option<SelfCollision> {
        self.contact.self_contact.as_ref().map(|s| s.options())
    }

    /// The colliders.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// Number of particle-collider contacts constrained by the last `begin_step`.
    pub fn contact_count(&self) -> usize {
        self.active_set.contact_count
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
        for &p in &self.active_set.list {
            self.active_set.constrained[p] = false;
            self.active_set.dirs[p] = Dirs::EMPTY;
            self.active_set.proj[p] = block::IDENTITY;
            self.active_set.vel[p] = [0.0; 3];
            self.plan.mark_rows_of(p, true);
        }
        self.active_set.list.clear();
        for p in 0..self.fixes.len() {
            if self.fixes[p].count > 0 {
                self.activate(p, self.fixes[p]);
            }
        }
        self.active_set.contact_count = 0;
    }

    pub(crate) fn activate(&mut self, p: usize, dirs: Dirs) {
        if !self.active_set.constrained[p] {
            self.active_set.constrained[p] = true;
            self.active_set.list.push(p);
            self.plan.mark_rows_of(p, false);
        }
        self.active_set.dirs[p] = dirs;
        self.active_set.proj[p] = dirs.projector();
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
