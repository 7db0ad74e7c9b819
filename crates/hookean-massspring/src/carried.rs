//! What a [`MassSpringModel`] carries from one step to the next, for
//! checkpoints and for a step redone from its start: the size of the last
//! accepted step (the friction impulse of the next contact pass reads it),
//! with cloth self-collision its candidate list and the shape of its tree
//! (`self_contact/carry.rs`, `SelfCarried`), which pin groups were released,
//! and the material revision. Everything else a step reads is either the
//! model's construction (springs, masses, colliders, paths, the wind's
//! seeded modes) or a function of the time and the state (the colliders'
//! and pins' poses at `t`, the contacts and proximity pairs found at the
//! step's start).

use crate::error::MassSpringError;
use crate::model::{Dirs, MassSpringModel};
use crate::self_contact::SelfCarried;

/// The contact state a step starts from and changes: the last step's
/// size and the self-collision state (`SelfCarried`). Kept before a step
/// with [`MassSpringModel::keep_contact_carry`] and put back with
/// [`MassSpringModel::restore_contact_carry`], a step redone from its
/// start (the facade's energy budget) starts from exactly the state the
/// first attempt started from.
#[derive(Debug, Clone, Default)]
pub struct ContactCarry {
    h_last: f64,
    self_contact: Option<SelfCarried>,
}

impl MassSpringModel {
    /// The carried state: `[h_last, revision, released_0, released_1, ...]`
    /// (one flag per pin group), then with cloth self-collision its state
    /// (`SelfCarried`: the candidate list's radius, the last step's
    /// motion, the reference positions, the candidates, the tree's leaf
    /// order).
    ///
    /// # Errors
    /// None at present (the `Result` is kept for states a checkpoint does
    /// not cover).
    pub fn carried_state(&self) -> Result<Vec<f64>, MassSpringError> {
        let mut s = vec![self.contact.h_last, self.revision as f64];
        s.extend(self.handles.iter().map(|h| f64::from(u8::from(h.released))));
        if let Some(sc) = &self.contact.self_contact {
            let mut kept = SelfCarried::default();
            sc.keep_carried(&mut kept);
            kept.write(&mut s);
        }
        Ok(s)
    }

    /// Restores [`carried_state`](Self::carried_state) into a model built
    /// alike (the same pin groups, the same self-collision): released
    /// groups lose their fixes, as their release did.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `checkpoint` for a state
    /// of another length, with a flag that is not 0 or 1, or a
    /// self-collision state that does not fit the model.
    pub fn restore_carried_state(&mut self, s: &[f64]) -> Result<(), MassSpringError> {
        let bad = |message: String| MassSpringError::InvalidParameter {
            name: "checkpoint",
            message,
        };
        let fixed = 2 + self.handles.len();
        let self_contact = match &self.contact.self_contact {
            Some(sc) => {
                let (kept, used) = SelfCarried::read(
                    s.get(fixed..).unwrap_or(&[]),
                    self.n_particles(),
                    sc.n_triangles(),
                )
                .map_err(bad)?;
                Some((kept, used))
            }
            None => None,
        };
        let len = fixed + self_contact.as_ref().map_or(0, |(_, used)| *used);
        if s.len() != len {
            return Err(bad(format!(
                "the model's carried state has {} numbers, this model's {len} (2 + one per pin group{})",
                s.len(),
                if self_contact.is_some() {
                    " + its self-collision state"
                } else {
                    ""
                }
            )));
        }
        if s[2..fixed].iter().any(|&f| f != 0.0 && f != 1.0) {
            return Err(bad("a pin group's release flag is not 0 or 1".into()));
        }
        if !(s[1] >= 0.0 && s[1].fract() == 0.0) {
            return Err(bad(format!("revision {} is not a count", s[1])));
        }
        if let (Some(sc), Some((kept, _))) = (self.contact.self_contact.as_mut(), &self_contact) {
            sc.restore_carried(kept).map_err(bad)?;
        }
        self.contact.h_last = s[0];
        self.revision = s[1] as u64;
        for (h, &f) in self.handles.iter_mut().zip(&s[2..fixed]) {
            h.released = f == 1.0;
            // Only hard pins are released (soft ones follow `held_at(t)`).
            if h.released {
                for &p in &h.group.particles {
                    self.fixes[p] = Dirs::EMPTY;
                }
            }
        }
        Ok(())
    }

    /// Copies the contact state the next step starts from into `into`
    /// ([`ContactCarry`]; storage reused, no allocation once grown).
    pub fn keep_contact_carry(&self, into: &mut ContactCarry) {
        into.h_last = self.contact.h_last;
        match (&self.contact.self_contact, &mut into.self_contact) {
            (Some(sc), Some(kept)) => sc.keep_carried(kept),
            (Some(sc), slot) => {
                let mut kept = SelfCarried::default();
                sc.keep_carried(&mut kept);
                *slot = Some(kept);
            }
            (None, slot) => *slot = None,
        }
    }

    /// Puts back a [`keep_contact_carry`](Self::keep_contact_carry) of this
    /// model: the next step starts from the contact state it was kept from.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `self_collision` for a
    /// carry of a model with another number of triangles (nothing is
    /// changed then).
    pub fn restore_contact_carry(&mut self, from: &ContactCarry) -> Result<(), MassSpringError> {
        match (self.contact.self_contact.as_mut(), &from.self_contact) {
            (Some(sc), Some(kept)) => {
                sc.restore_carried(kept)
                    .map_err(|message| MassSpringError::InvalidParameter {
                        name: "self_collision",
                        message,
                    })?;
            }
            (None, None) => {}
            _ => {
                return Err(MassSpringError::InvalidParameter {
                    name: "self_collision",
                    message: "the contact state was kept from a model with other self-collision"
                        .into(),
                });
            }
        }
        self.contact.h_last = from.h_last;
        Ok(())
    }
}
