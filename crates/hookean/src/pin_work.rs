//! The work of pins driven along a path (`PinGroup::path`,
//! hookean-massspring's `handles.rs`): what the energy guard of a
//! [`Simulation`](crate::Simulation) adds to the energy a run may have
//! (docs/CONTACT.md, "Energy").
//!
//! - **Hard pins** (`weight = 1`) prescribe the motion `y_i(t)` of their
//!   particles; the constraint's reaction at particle `i` is
//!   `R_i = m_i a_i - f_i(x, v)` (`f_i` every other force there: springs, damping, gravity,
//!   external forces, air friction, contact, wind, before the constraint's
//!   projection, [`MassSpringModel::free_force`]), and its power is `R_i .
//!   v_i`. Over a step from `t_n` to `t_{n+1}` the inertial part integrates
//!   exactly, `int m_i a_i . v_i dt = m_i (|v_i^{n+1}|^2 - |v_i^n|^2) / 2`
//!   (also across the velocity jump at a key of a linear path), and the
//!   force part by the trapezoid rule along the path, exact for a straight
//!   motion under a force that varies linearly:
//!
//!   `W += sum_i [ m_i (|v_i^{n+1}|^2 - |v_i^n|^2) / 2 - (f_i^n + f_i^{n+1}) . (x_i^{n+1} - x_i^n) / 2 ]`
//!
//!   over the particles of the groups that hold at `t_n` (a group stops
//!   doing work from the first step that starts at or after its release,
//!   as the model lets it go then).
//! - **Soft pins** (`weight < 1`) are springs `w k |x_i - y_i|^2 / 2` to the
//!   target, counted in the spring term of
//!   [`MassSpringModel::energies`]; the model holds the target of a step's
//!   start over the step, so the target moves in jumps at the step starts,
//!   `x` held. The work of a jump is exactly the change of the stored
//!   energy, `w k (|x_i^n - y_i(t_n)|^2 - |x_i^n - y_i(t_{n-1})|^2) / 2 = w
//!   k ((y_i(t_n) + y_i(t_{n-1})) / 2 - x_i^n) . (y_i(t_n) - y_i(t_{n-1}))`,
//!   the midpoint rule of `int w k (y_i - x_i) . y_i' dt`
//!   ([`MassSpringModel::soft_pin_energy_at`]). The step-held target is
//!   the model's, so is this energy: a target moving at `u` jumps `u h`
//!   ahead of a particle that follows it and stores `w k (u h)^2 / 2` per
//!   step more than the continuous pull would give (`w k u^2 h T / 2` over
//!   `T`, vanishing with `h`), which the budget counts as the model holds
//!   it. A step that the integrator
//!   retries internally in substeps moves the targets at the substeps too;
//!   those jumps are counted at the next step's start, where the model's
//!   targets and the counted ones agree again.
//! - Pins without a path do no work (not counted: nothing to add).
//!
//! Costs one force evaluation per step for models with driven hard pins
//! (into a buffer allocated at the baseline), a pass over the soft pins for
//! models with driven soft pins; nothing for other models.

use hookean_massspring::MassSpringModel;

/// A driven hard pin's particle at the last counted state.
#[derive(Debug, Clone, Copy, Default)]
struct Sample {
    x: [f64; 3],
    v: [f64; 3],
    f: [f64; 3],
}

/// What a redo of the step restarts from.
#[derive(Debug, Clone, Default)]
struct Checkpoint {
    work: f64,
    soft_t: Option<f64>,
    last: Vec<Sample>,
}

/// The driven pins' work since the energy guard's baseline (module docs).
#[derive(Debug, Clone, Default)]
pub(crate) struct PinWork {
    /// Whether the model has a pin group on a path (else nothing is counted).
    driven: bool,
    /// `W` (J).
    work: f64,
    /// The start time of the step whose soft targets `work` counts (`None`:
    /// the model's targets at the baseline).
    soft_t: Option<f64>,
    /// The driven hard pins' particles, group by group, at the last state.
    last: Vec<Sample>,
    /// `f(x, v)` before projection (`3 n`).
    force: Vec<f64>,
    /// The state at the start of the current step.
    start: Checkpoint,
}

impl PinWork {
    /// Starts counting from `(x, v)` at the guard's baseline: `W = 0`.
    pub(crate) fn reset(&mut self, model: &MassSpringModel, x: &[f64], v: &[f64]) {
        self.driven = model
            .pin_groups()
            .any(|g| g.path.is_some() && g.weight > 0.0);
        self.work = 0.0;
        self.soft_t = None;
        self.last.clear();
        if !self.driven {
            return;
        }
        let n_hard: usize = model
            .pin_groups()
            .filter(|g| g.is_driven_hard())
            .map(|g| g.particles.len())
            .sum();
        self.last.resize(n_hard, Sample::default());
        if n_hard > 0 {
            self.force.resize(x.len(), 0.0);
            model.free_force(x, v, &mut self.force);
            self.sample(model, x, v, None);
        }
    }

    /// What the count carries from step to step, for a checkpoint:
    /// `[driven, W, has soft_t, soft_t, then x, v, f of each driven hard
    /// pin's particle]`.
    pub(crate) fn carried(&self) -> Vec<f64> {
        let flag = |b: bool| f64::from(u8::from(b));
        let mut c = vec![
            flag(self.driven),
            self.work,
            flag(self.soft_t.is_some()),
            self.soft_t.unwrap_or(0.0),
        ];
        for s in &self.last {
            c.extend(s.x.iter().chain(&s.v).chain(&s.f));
        }
        c
    }

    /// Restores [`carried`](Self::carried); `None` for a malformed one.
    pub(crate) fn restore_carried(&mut self, c: &[f64], dim: usize) -> Option<()> {
        if c.len() < 4 || !(c.len() - 4).is_multiple_of(9) {
            return None;
        }
        self.driven = c[0] == 1.0;
        self.work = c[1];
        self.soft_t = (c[2] == 1.0).then_some(c[3]);
        self.last.clear();
        self.last.extend(c[4..].chunks_exact(9).map(|s| Sample {
            x: [s[0], s[1], s[2]],
            v: [s[3], s[4], s[5]],
            f: [s[6], s[7], s[8]],
        }));
        if !self.last.is_empty() {
            self.force.resize(dim, 0.0);
        }
        Some(())
    }

    /// `W` (J): zero without driven pins.
    pub(crate) fn work(&self) -> f64 {
        self.work
    }

    /// Keeps the count at the start of a step, for a redo.
    pub(crate) fn checkpoint(&mut self) {
        if self.driven {
            self.start.work = self.work;
            self.start.soft_t = self.soft_t;
            self.start.last.clear();
            self.start.last.extend_from_slice(&self.last);
        }
    }

    /// Back to the count of [`checkpoint`](Self::checkpoint).
    pub(crate) fn restore(&mut self) {
        if self.driven {
            self.work = self.start.work;
            self.soft_t = self.start.soft_t;
            self.last.clear();
            self.last.extend_from_slice(&self.start.last);
        }
    }

    /// Before a (sub)step from `t` at positions `x`: the soft targets' jump
    /// from those counted to `y(t)`.
    pub(crate) fn begin(&mut self, model: &MassSpringModel, t: f64, x: &[f64]) {
        if !self.driven || self.soft_t == Some(t) {
            return;
        }
        let before = match self.soft_t {
            Some(s) => model.soft_pin_energy_at(s, x),
            None => model.soft_pin_energy(x),
        };
        self.work += model.soft_pin_energy_at(t, x) - before;
        self.soft_t = Some(t);
    }

    /// After a (sub)step from `t_start` that ended at `(x, v)`: the hard
    /// pins' work over it.
    pub(crate) fn end(&mut self, model: &MassSpringModel, t_start: f64, x: &[f64], v: &[f64]) {
        if self.last.is_empty() {
            return;
        }
        model.free_force(x, v, &mut self.force);
        self.sample(model, x, v, Some(t_start));
    }

    /// Records the driven hard pins' particles at `(x, v)` with the force
    /// in `self.force`, adding the step's work first if it started at `t`.
    fn sample(&mut self, model: &MassSpringModel, x: &[f64], v: &[f64], t: Option<f64>) {
        let mass = model.particle_masses();
        let mut k = 0;
        for g in model.pin_groups().filter(|g| g.is_driven_hard()) {
            let held = t.is_some_and(|t| g.holds_at(t));
            for &p in &g.particles {
                let at = |a: &[f64]| [a[3 * p], a[3 * p + 1], a[3 * p + 2]];
                let now = Sample {
                    x: at(x),
                    v: at(v),
                    f: at(&self.force),
                };
                if held {
                    let last = &self.last[k];
                    let mut w = 0.0;
                    for c in 0..3 {
                        w += 0.5 * mass[p] * (now.v[c] * now.v[c] - last.v[c] * last.v[c])
                            - 0.5 * (now.f[c] + last.f[c]) * (now.x[c] - last.x[c]);
                    }
                    self.work += w;
                }
                self.last[k] = now;
                k += 1;
            }
        }
    }
}
