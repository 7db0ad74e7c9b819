//! The checked public entry points (force, Jacobians) and the
//! [`SecondOrderProblem`] implementation of [`MassSpringModel`].
use std::sync::Arc;

use hookean_problem::SecondOrderProblem;
use hookean_sparse::{BlockPattern, Constraints, IsoBlockMatrix, SymBlockMatrix};

use crate::error::MassSpringError;
use crate::model::MassSpringModel;

use super::*;

impl MassSpringModel {
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
    /// damping term per [`DampingInDfdx`](crate::DampingInDfdx)) and `df/dv` (exact). No allocation.
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
    /// (`MassSpringModel::assemble_step_matrix`); `dfdx` and `dfdv` are
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

    /// Not with wind (see [`MassSpringModel::has_constant_linearization`]).
    fn linearization_is_newton_matrix(&self) -> bool {
        self.has_constant_linearization()
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
        self.begin_wind(t, x);
        self.begin_handles(t);
        self.apply_constraints_and_contacts(t, x, v);
        self.move_hard_pins(t, v);
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
    /// and mesh colliders, then the hard pins of pin groups set exactly on
    /// their paths (`handles.rs`); nothing (and `false`) for a model
    /// without them.
    fn end_step(&mut self, t: f64, h: f64, x_start: &[f64], x: &mut [f64], v: &mut [f64]) -> bool {
        let contact = self.end_contact_step(t, h, x_start, x, v);
        let pins = self.end_handles(t + h, x, v);
        contact || pins
    }
}
