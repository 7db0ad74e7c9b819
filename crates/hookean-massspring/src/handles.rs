//! Pin groups as handles: a set of particles whose targets (their rest
//! positions) move rigidly along a [`KeyframedPath`], held hard or soft,
//! and released at a time.
//!
//! - **Hard** (`weight = 1`): the particles are pinned (the model's
//!   permanent constraints, prescribed motion in the filtered PCG): at the
//!   start of every step at their targets `y_p(t)` with the path's velocity
//!   as the prescribed velocity, and after the step set to `y_p(t + h)` with
//!   velocity `y_p'(t + h)`, so they lie exactly on the path at every step.
//! - **Soft** (`weight < 1`): a zero-rest-length spring to the target,
//!   `f_p = -w k (x_p - y_p)` with `w` the weight and `k` the stiffness
//!   (Blender's pin stiffness scaled by the pin weight), `df_p/dx_p = -w k I`
//!   in the implicit Jacobian; the target is the one at the start of the
//!   step. Its elastic energy `w k |x_p - y_p|^2 / 2` counts as spring
//!   energy.
//!
//! From `release` on (s of simulated time) a group holds nothing.

use crate::error::MassSpringError;
use crate::model::MassSpringModel;
use crate::path::KeyframedPath;

/// A pin group (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PinGroup {
    /// The particles.
    pub particles: Vec<usize>,
    /// 1: hard pins; in `[0, 1)`: soft pins of stiffness `weight * stiffness`.
    pub weight: f64,
    /// Soft pins' stiffness at weight 1 (N/m), non-negative.
    pub stiffness: f64,
    /// The targets' path (`None`: they stay at the rest positions).
    pub path: Option<KeyframedPath>,
    /// The time the group lets go (s); `None`: never.
    pub release: Option<f64>,
}

/// A pin group with its particles' rest positions (the targets at rest).
#[derive(Debug, Clone)]
pub(crate) struct Handle {
    pub(crate) group: PinGroup,
    pub(crate) rest: Vec<[f64; 3]>,
    /// Whether the group was released (a hard group: its fixes cleared).
    pub(crate) released: bool,
}

/// A soft pin of the current step: particle, stiffness `w k`, target.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SoftPin {
    pub(crate) p: usize,
    pub(crate) k: f64,
    pub(crate) target: [f64; 3],
}

impl PinGroup {
    /// Whether the group holds its particles at `t` (before its release).
    pub fn holds_at(&self, t: f64) -> bool {
        self.release.is_none_or(|r| t < r)
    }

    /// Hard pins (`weight = 1`) moved along a path: the groups whose
    /// reaction forces do work on the model.
    pub fn is_driven_hard(&self) -> bool {
        self.weight == 1.0 && self.path.is_some()
    }
}

impl SoftPin {
    /// `w k |x_p - y_p|^2 / 2`.
    fn energy(&self, x: &[f64]) -> f64 {
        let d2: f64 = (0..3)
            .map(|r| (x[3 * self.p + r] - self.target[r]).powi(2))
            .sum();
        0.5 * self.k * d2
    }
}

/// The soft pins of a step starting at `t`: particle, `w k` and the target
/// `y_p(t)`, in the order of the groups.
fn soft_pins_at(handles: &[Handle], t: f64) -> impl Iterator<Item = SoftPin> + '_ {
    handles
        .iter()
        .filter(move |h| !h.is_hard() && h.held_at(t) && h.group.weight > 0.0)
        .flat_map(move |h| {
            let k = h.group.weight * h.group.stiffness;
            (h.group.particles.iter().enumerate()).map(move |(i, &p)| SoftPin {
                p,
                k,
                target: h.target(i, t),
            })
        })
}

impl Handle {
    fn held_at(&self, t: f64) -> bool {
        self.group.holds_at(t)
    }

    fn target(&self, k: usize, t: f64) -> [f64; 3] {
        match &self.group.path {
            Some(path) => path.point_at(t, self.rest[k]),
            None => self.rest[k],
        }
    }

    fn velocity(&self, k: usize, t: f64) -> [f64; 3] {
        match &self.group.path {
            Some(path) => path.velocity_at(t, self.rest[k]),
            None => [0.0; 3],
        }
    }

    fn is_hard(&self) -> bool {
        self.group.weight == 1.0
    }
}

impl MassSpringModel {
    /// Adds a pin group whose targets at rest are the particles' positions
    /// in `x` (usually the initial state).
    ///
    /// # Errors
    /// [`MassSpringError::NoSuchParticle`] for an index past the model;
    /// [`MassSpringError::InvalidParameter`] for a weight outside `[0, 1]`,
    /// a negative or non-finite stiffness, a release time that is not
    /// finite; [`MassSpringError::DimensionMismatch`] for `x`.
    pub fn add_pin_group(&mut self, group: PinGroup, x: &[f64]) -> Result<(), MassSpringError> {
        let n = self.n_particles();
        if x.len() != 3 * n {
            return Err(MassSpringError::DimensionMismatch {
                what: "x",
                expected: 3 * n,
                found: x.len(),
            });
        }
        for &p in &group.particles {
            self.check_particle(p)?;
        }
        if !(0.0..=1.0).contains(&group.weight) {
            return Err(MassSpringError::InvalidParameter {
                name: "weight",
                message: format!("{} must lie in [0, 1]", group.weight),
            });
        }
        if !(group.stiffness >= 0.0 && group.stiffness.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "stiffness",
                message: format!("{} must be non-negative and finite", group.stiffness),
            });
        }
        if group.release.is_some_and(|r| !r.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "release",
                message: "must be finite".into(),
            });
        }
        let rest = group
            .particles
            .iter()
            .map(|&p| [x[3 * p], x[3 * p + 1], x[3 * p + 2]])
            .collect();
        self.handles.push(Handle {
            group,
            rest,
            released: false,
        });
        self.revision += 1;
        Ok(())
    }

    /// The pin groups, in the order added.
    pub fn pin_groups(&self) -> impl Iterator<Item = &PinGroup> {
        self.handles.iter().map(|h| &h.group)
    }

    /// `begin_step` at `t`, before the permanent constraints are applied:
    /// hard pins to their targets at `t` (or released), the soft pins'
    /// targets of the step.
    pub(crate) fn begin_handles(&mut self, t: f64) {
        if self.handles.is_empty() {
            return;
        }
        self.soft_pins.clear();
        let mut changed = false;
        for h in &mut self.handles {
            let held = h.held_at(t);
            if !held && !h.released {
                // A release changes the material: the hard pins' fixes go,
                // a soft group's `-w k I` leaves eq. 50's constant `df/dx`.
                if h.is_hard() {
                    for &p in &h.group.particles {
                        self.fixes[p] = crate::model::Dirs::EMPTY;
                    }
                }
                h.released = true;
                changed = true;
            }
            if held && h.is_hard() {
                for (k, &p) in h.group.particles.iter().enumerate() {
                    self.fixes[p] = crate::model::Dirs::pin(h.target(k, t));
                }
            }
        }
        self.soft_pins.extend(soft_pins_at(&self.handles, t));
        if changed {
            self.revision += 1;
        }
    }

    /// `begin_step` at `t`, after the permanent constraints were applied
    /// (which zeroed the pinned velocities): the hard pins move with their
    /// path, `v_p = y_p'(t)`, prescribed for the step.
    pub(crate) fn move_hard_pins(&mut self, t: f64, v: &mut [f64]) {
        for h in &self.handles {
            if !(h.is_hard() && h.held_at(t)) {
                continue;
            }
            for (k, &p) in h.group.particles.iter().enumerate() {
                let w = h.velocity(k, t);
                v[3 * p..3 * p + 3].copy_from_slice(&w);
                self.active_set.vel[p] = w;
            }
        }
    }

    /// `end_step` to `t1 = t + h`: hard pins exactly at `y_p(t1)` with
    /// velocity `y_p'(t1)`. True if a coordinate changed.
    pub(crate) fn end_handles(&self, t1: f64, x: &mut [f64], v: &mut [f64]) -> bool {
        let mut changed = false;
        for h in &self.handles {
            if !(h.is_hard() && h.held_at(t1)) || h.released {
                continue;
            }
            for (k, &p) in h.group.particles.iter().enumerate() {
                let (y, w) = (h.target(k, t1), h.velocity(k, t1));
                for r in 0..3 {
                    changed |= x[3 * p + r] != y[r] || v[3 * p + r] != w[r];
                    x[3 * p + r] = y[r];
                    v[3 * p + r] = w[r];
                }
            }
        }
        changed
    }

    /// Adds the soft pins' forces `-w k (x_p - y_p)` to `f`.
    pub(crate) fn add_soft_pin_forces(&self, x: &[f64], f: &mut [f64]) {
        for s in &self.soft_pins {
            for r in 0..3 {
                f[3 * s.p + r] -= s.k * (x[3 * s.p + r] - s.target[r]);
            }
        }
    }

    /// The soft pins' elastic energy `sum w k |x_p - y_p|^2 / 2` with the
    /// targets of the current step (those of its start; the spring term of
    /// [`energies`](Self::energies) holds it). No allocation.
    ///
    /// # Panics
    /// If `x` is shorter than `3 n`.
    pub fn soft_pin_energy(&self, x: &[f64]) -> f64 {
        self.soft_pins.iter().map(|s| s.energy(x)).sum()
    }

    /// The soft pins' elastic energy with the targets of a step starting at
    /// `t`, `y_p(t)` (released groups hold nothing): what
    /// [`soft_pin_energy`](Self::soft_pin_energy) gives once a step from
    /// `t` has begun. A step's start moves the targets with `x` held, so
    /// the moving targets' work there is the difference of the two
    /// (`hookean::Simulation`'s energy guard). No allocation.
    ///
    /// # Panics
    /// If `x` is shorter than `3 n`.
    pub fn soft_pin_energy_at(&self, t: f64, x: &[f64]) -> f64 {
        soft_pins_at(&self.handles, t).map(|s| s.energy(x)).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ModelOptions;
    use hookean_problem::SecondOrderProblem;
    use hookean_sparse::Constraints;

    /// One particle on a soft pin: `f = m g - w k (x - y)` and `df/dx = -w k I`.
    #[test]
    fn a_soft_pin_is_a_spring_to_its_target_with_its_jacobian() {
        let (m, w, k) = (0.3, 0.25, 80.0);
        let g = [0.0, 0.0, -9.81];
        let options = ModelOptions {
            gravity: g,
            ..Default::default()
        };
        let mut model = MassSpringModel::new(vec![m], vec![], options).unwrap();
        let y = [1.0, 2.0, 3.0];
        let group = PinGroup {
            particles: vec![0],
            weight: w,
            stiffness: k,
            path: None,
            release: None,
        };
        model.add_pin_group(group, &y).unwrap();
        let mut x = vec![1.1, 1.9, 2.5];
        let mut v = vec![0.0; 3];
        let mut c = Constraints::new(1);
        model.begin_step(0.0, &mut x, &mut v, &mut c);
        let mut f = vec![0.0; 3];
        model.force(0.0, &x, &v, &mut f);
        for r in 0..3 {
            let expected = m * g[r] - w * k * (x[r] - y[r]);
            assert!((f[r] - expected).abs() < 1e-12, "{f:?}");
        }
        let (mut dfdx, mut dfdv) = model.new_jacobians();
        model.force_jacobians(0.0, &x, &v, &mut dfdx, &mut dfdv);
        let d = dfdx.diagonal_block(0);
        for r in 0..3 {
            for s in 0..3 {
                let expected = if r == s { -w * k } else { 0.0 };
                assert_eq!(d[r][s], expected);
            }
        }
        // Released: nothing left.
        model.handles[0].group.release = Some(1.0);
        model.begin_step(1.0, &mut x, &mut v, &mut c);
        model.force(1.0, &x, &v, &mut f);
        assert_eq!(f, vec![0.0, 0.0, m * g[2]]);
    }
}
