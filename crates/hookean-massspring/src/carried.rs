//! What a [`MassSpringModel`] carries from one step to the next, for
//! checkpoints: the size of the last accepted step (the friction impulse
//! of the next contact pass reads it), which pin groups were released, and
//! the material revision. Everything else a step reads is either the
//! model's construction (springs, masses, colliders, paths, the wind's
//! seeded modes) or a function of the time and the state (the colliders'
//! and pins' poses at `t`, the contacts found at the step's start).

use crate::error::MassSpringError;
use crate::model::{Dirs, MassSpringModel};

impl MassSpringModel {
    /// The carried state: `[h_last, revision, released_0, released_1, ...]`
    /// (one flag per pin group).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `self_collision` for a
    /// model with cloth self-collision, whose bounding-volume tree and
    /// candidate lists carry over from step to step and are not covered.
    pub fn carried_state(&self) -> Result<Vec<f64>, MassSpringError> {
        if self.contact.self_contact.is_some() {
            return Err(MassSpringError::InvalidParameter {
                name: "self_collision",
                message: "checkpoints do not cover cloth self-collision (its bounding-volume \
                          tree and candidate lists carry over from step to step)"
                    .into(),
            });
        }
        let mut s = vec![self.contact.h_last, self.revision as f64];
        s.extend(self.handles.iter().map(|h| f64::from(u8::from(h.released))));
        Ok(s)
    }

    /// Restores [`carried_state`](Self::carried_state) into a model built
    /// alike (the same pin groups): released groups lose their fixes, as
    /// their release did.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `checkpoint` for a state
    /// of another length or with a flag that is not 0 or 1; as
    /// [`carried_state`](Self::carried_state) for self-collision.
    pub fn restore_carried_state(&mut self, s: &[f64]) -> Result<(), MassSpringError> {
        self.carried_state()?;
        let bad = |message: String| MassSpringError::InvalidParameter {
            name: "checkpoint",
            message,
        };
        if s.len() != 2 + self.handles.len() {
            return Err(bad(format!(
                "the model's carried state has {} numbers, this model's {} (2 + one per pin group)",
                s.len(),
                2 + self.handles.len()
            )));
        }
        if s[2..].iter().any(|&f| f != 0.0 && f != 1.0) {
            return Err(bad("a pin group's release flag is not 0 or 1".into()));
        }
        if !(s[1] >= 0.0 && s[1].fract() == 0.0) {
            return Err(bad(format!("revision {} is not a count", s[1])));
        }
        self.contact.h_last = s[0];
        self.revision = s[1] as u64;
        for (h, &f) in self.handles.iter_mut().zip(&s[2..]) {
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
}
