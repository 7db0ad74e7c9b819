//! A [`Simulation`]'s checkpoint: its whole state as a [`StateRecord`],
//! so that a run stopped between two steps continues bit for bit
//! ([`Simulation::save_state`], [`Simulation::restore_state`]).
//!
//! The record holds the integrator's state (positions, velocities, time,
//! step size, counters, the step controller's and multistep history, the
//! Newton solver's carried rate and kept Jacobian, the warm start of the
//! linear solves, the matrix the multigrid's aggregates were built from,
//! IMEX's and eq. 50's factor keys, the variable-order BDF's history:
//! [`Integrator::save_state`](hookean_ode::Integrator::save_state)), the
//! model's carried state ([`MassSpringModel::carried_state`]: the last
//! step size that friction reads, released pin groups, cloth
//! self-collision's candidate list and the shape of its tree), and the energy
//! check's baseline and pin work. Pins, colliders and wind are functions
//! of the time and are posed from the restored `t` at the next step.

use std::time::Duration;

use hookean_massspring::{Energies, MassSpringModel};
use hookean_ode::{OdeError, StateRecord};

use super::{Baseline, Simulation};
use crate::error::HookeanError;

/// The error for a record that does not fit.
fn misfit(reason: impl Into<String>) -> HookeanError {
    HookeanError::Ode(OdeError::Checkpoint {
        reason: reason.into(),
    })
}

impl Simulation {
    /// Adds the whole state the next step depends on to `record` (see
    /// the module docs), between steps.
    ///
    /// # Errors
    /// [`HookeanError::Ode`] with [`OdeError::NoCheckpoint`] for what a
    /// checkpoint does not cover: a multigrid that carries eigenvector
    /// estimates from refill to refill (`refill_power_iterations > 0`).
    /// Every method is covered: the one-step and
    /// fixed-step multistep methods, IMEX (its factor is rebuilt from the
    /// `h`, material revision and pinned particles it was made for), the
    /// variable-order BDF (its history, order, re-use counters and kept
    /// Jacobians and Newton matrix), the simplified Newton variants (the
    /// kept Newton matrix, or for eq. 50's what rebuilds it: `gh`), and the
    /// velocity filter around an explicit method; and the multigrid with
    /// `reuse = "refill"`, `"rebuild"` or `"keep"`; and cloth
    /// self-collision (its candidate list and tree shape, in the model's
    /// carried state).
    ///
    /// ```
    /// use hookean::prelude::*;
    /// use hookean::StateRecord;
    ///
    /// let new = || {
    ///     let (model, state) = cloth(&ClothParams { nu: 8, nv: 8, ..Default::default() })?;
    ///     Simulation::new(model, state, SimulationOptions::default())
    /// };
    /// let (mut a, mut b) = (new()?, new()?);
    /// a.run_until(0.05)?;
    /// let mut record = StateRecord::default();
    /// a.save_state(&mut record)?;
    /// b.restore_state(&record)?;
    /// a.run_until(0.1)?;
    /// b.run_until(0.1)?;
    /// assert_eq!(a.x(), b.x()); // bit for bit
    /// # Ok::<(), hookean::HookeanError>(())
    /// ```
    pub fn save_state(&self, record: &mut StateRecord) -> Result<(), HookeanError> {
        self.integrator.save_state(record)?;
        record.put("model.carried", &self.model().carried_state()?);
        let g = &self.guard;
        match &g.baseline {
            Some(b) => {
                let e = b.start;
                record.put(
                    "guard.baseline",
                    &[
                        b.t0,
                        e.kinetic,
                        e.gravitational,
                        e.spring,
                        e.external,
                        b.bound,
                        b.budget,
                        b.collider_power,
                    ],
                );
            }
            None => record.put("guard.baseline", &[]),
        }
        record.put("guard.x0", &g.x0);
        record.put("guard.pins", &g.pins.carried());
        record.put_scalar("sim.wall_ns", self.wall.as_nanos() as f64);
        Ok(())
    }

    /// Continues from a [`save_state`](Self::save_state) record of a
    /// simulation built alike (the same scene): after it, the next steps
    /// are those the saved simulation would have taken, bit for bit.
    ///
    /// # Errors
    /// As [`save_state`](Self::save_state), and
    /// [`OdeError::Checkpoint`] for a record that does not fit this
    /// simulation (another size, a missing entry).
    pub fn restore_state(&mut self, record: &StateRecord) -> Result<(), HookeanError> {
        let dim = self.x().len();
        let baseline = match record.get("guard.baseline")? {
            [] => None,
            &[
                t0,
                kinetic,
                gravitational,
                spring,
                external,
                bound,
                budget,
                collider_power,
            ] => Some(Baseline {
                t0,
                start: Energies {
                    kinetic,
                    gravitational,
                    spring,
                    external,
                },
                bound,
                budget,
                collider_power,
            }),
            other => {
                return Err(misfit(format!(
                    "entry `guard.baseline` has {} numbers, not 8",
                    other.len()
                )));
            }
        };
        let x0 = record.get("guard.x0")?;
        if !(x0.is_empty() || x0.len() == dim) {
            return Err(misfit(format!(
                "entry `guard.x0` has {} numbers, this model {dim}",
                x0.len()
            )));
        }
        let pins = record.get("guard.pins")?;
        let wall = record.count("sim.wall_ns")?;
        let carried = record.get("model.carried")?;
        // The model first (it checks its part), then the integrator.
        restore_model(self.integrator.problem_mut(), carried)?;
        self.integrator.restore_state(record)?;
        if self.guard.pins.restore_carried(pins, dim).is_none() {
            return Err(misfit("entry `guard.pins` is malformed"));
        }
        self.guard.baseline = baseline;
        self.guard.x0.clear();
        self.guard.x0.extend_from_slice(x0);
        self.wall = Duration::from_nanos(wall as u64);
        self.current = None;
        Ok(())
    }
}

/// [`MassSpringModel::restore_carried_state`] through the integrator's
/// `problem_mut` (which drops its cached forces, as a restore must).
fn restore_model(model: &mut MassSpringModel, carried: &[f64]) -> Result<(), HookeanError> {
    model.restore_carried_state(carried)?;
    Ok(())
}
