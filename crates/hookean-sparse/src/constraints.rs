//! Per-particle constraints for the filtered CG of Baraff and Witkin
//! (the tutorial's section 4.2, eqs. 55-57).

use crate::error::SparseError;

const NONE: usize = usize::MAX;

/// Constraints on the unknown `x` (3 entries per particle): for a
/// constrained particle `p`, up to three orthonormal directions `d_k` with
/// prescribed values `d_k . x_p = c_k`.
///
/// The filter `P = I - sum_k d_k d_k^T` ([`project`](Self::project)) removes
/// the constrained components; filtered CG solves `P A P x = P b` with
/// `(I - P) x` fixed to the prescribed values.
///
/// Re-filled every step as collisions come and go: [`clear`](Self::clear)
/// keeps the storage, so refilling allocates nothing once warmed up.
///
/// ```
/// use hookean_sparse::Constraints;
/// let mut c = Constraints::new(3);
/// c.pin(0, [0.0, 0.0, 0.0])?;                 // particle 0 does not move
/// c.constrain(2, [0.0, 0.0, 2.0], 0.0)?;      // particle 2 slides in the z = const plane
/// let mut v = vec![1.0; 9];
/// c.project(&mut v);
/// assert_eq!(v, [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct Constraints {
    slot: Vec<usize>,
    entries: Vec<Entry>,
}

#[derive(Debug, Clone, Copy)]
struct Entry {
    particle: usize,
    count: usize,
    dirs: [[f64; 3]; 3],
    values: [f64; 3],
}

impl Constraints {
    /// No constraints on `n_particles` particles.
    pub fn new(n_particles: usize) -> Self {
        Self {
            slot: vec![NONE; n_particles],
            entries: Vec::new(),
        }
    }

    /// Number of particles (the unknown has `3 * n_particles` entries).
    pub fn n_particles(&self) -> usize {
        self.slot.len()
    }

    /// Number of constrained particles.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when no particle is constrained.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Removes every constraint, keeping the storage.
    pub fn clear(&mut self) {
        for e in &self.entries {
            self.slot[e.particle] = NONE;
        }
        self.entries.clear();
    }

    /// The constrained particles and their numbers of constrained
    /// directions (1 to 3), in the order they were constrained.
    pub fn counts(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.entries.iter().map(|e| (e.particle, e.count))
    }

    /// Number of constrained directions of `particle` (0 to 3).
    pub fn count(&self, particle: usize) -> usize {
        match self.slot.get(particle) {
            Some(&s) if s != NONE => self.entries[s].count,
            _ => 0,
        }
    }

    /// Adds the constraint `direction . x_particle = value`. The direction
    /// need not be unit length nor orthogonal to the particle's earlier
    /// directions: it is orthonormalised against them (Gram-Schmidt) and the
    /// value transformed to match.
    ///
    /// # Errors
    /// [`SparseError::BlockIndexOutOfRange`] for a particle out of range,
    /// [`SparseError::NonFinite`] for NaN input, and
    /// [`SparseError::DegenerateConstraint`] for a zero direction, one in the
    /// span of earlier ones, or a fourth direction.
    pub fn constrain(
        &mut self,
        particle: usize,
        direction: [f64; 3],
        value: f64,
    ) -> Result<(), SparseError> {
        let n = self.slot.len();
        if particle >= n {
            return Err(SparseError::BlockIndexOutOfRange {
                row: particle,
                col: particle,
                n,
            });
        }
        if direction.iter().any(|v| !v.is_finite()) || !value.is_finite() {
            return Err(SparseError::NonFinite {
                what: "constraint",
                index: Some(particle),
            });
        }
        let s = self.slot[particle];
        let mut entry = if s == NONE {
            Entry {
                particle,
                count: 0,
                dirs: [[0.0; 3]; 3],
                values: [0.0; 3],
            }
        } else {
            self.entries[s]
        };
        if entry.count == 3 {
            return Err(SparseError::DegenerateConstraint { particle });
        }
        let scale = norm3(&direction);
        let mut d = direction;
        let mut v = value;
        for k in 0..entry.count {
            let proj = dot3(&d, &entry.dirs[k]);
            for c in 0..3 {
                d[c] -= proj * entry.dirs[k][c];
            }
            v -= proj * entry.values[k];
        }
        let len = norm3(&d);
        if !(len > 1e-10 * scale) || scale == 0.0 {
            return Err(SparseError::DegenerateConstraint { particle });
        }
        entry.dirs[entry.count] = [d[0] / len, d[1] / len, d[2] / len];
        entry.values[entry.count] = v / len;
        entry.count += 1;
        if s == NONE {
            self.slot[particle] = self.entries.len();
            self.entries.push(entry);
        } else {
            self.entries[s] = entry;
        }
        Ok(())
    }

    /// Pins `particle`: all three components are prescribed, `x_particle = value`.
    ///
    /// # Errors
    /// As [`constrain`](Self::constrain); a particle that already has
    /// constraints is re-pinned from scratch.
    pub fn pin(&mut self, particle: usize, value: [f64; 3]) -> Result<(), SparseError> {
        if let Some(&s) = self.slot.get(particle)
            && s != NONE
        {
            self.entries[s].count = 0;
        }
        for (c, &v) in value.iter().enumerate() {
            let mut e = [0.0; 3];
            e[c] = 1.0;
            self.constrain(particle, e, v)?;
        }
        Ok(())
    }

    /// Applies the filter `v <- P v`, removing constrained components.
    #[inline]
    pub fn project(&self, v: &mut [f64]) {
        for e in &self.entries {
            let vp = &mut v[3 * e.particle..3 * e.particle + 3];
            for d in &e.dirs[..e.count] {
                let s = d[0] * vp[0] + d[1] * vp[1] + d[2] * vp[2];
                vp[0] -= s * d[0];
                vp[1] -= s * d[1];
                vp[2] -= s * d[2];
            }
        }
    }

    /// Sets the constrained components of `x` to their prescribed values:
    /// `x <- P x + sum_k c_k d_k`.
    pub fn impose(&self, x: &mut [f64]) {
        self.project(x);
        for e in &self.entries {
            for k in 0..e.count {
                for c in 0..3 {
                    x[3 * e.particle + c] += e.values[k] * e.dirs[k][c];
                }
            }
        }
    }

    /// The largest violation `max |d_k . x_p - c_k|` over all constraints.
    pub fn violation(&self, x: &[f64]) -> f64 {
        let mut worst = 0.0_f64;
        for e in &self.entries {
            let xp = &x[3 * e.particle..3 * e.particle + 3];
            for k in 0..e.count {
                let d = &e.dirs[k];
                worst = worst.max((d[0] * xp[0] + d[1] * xp[1] + d[2] * xp[2] - e.values[k]).abs());
            }
        }
        worst
    }
}

fn dot3(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm3(a: &[f64; 3]) -> f64 {
    dot3(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn oblique_directions_are_orthonormalised_with_their_values() {
        let mut c = Constraints::new(1);
        c.constrain(0, [1.0, 0.0, 0.0], 2.0).unwrap();
        c.constrain(0, [1.0, 1.0, 0.0], 5.0).unwrap(); // x + y = 5 with x = 2: y = 3
        let mut x = vec![7.0, -1.0, 4.0];
        c.impose(&mut x);
        approx::assert_abs_diff_eq!(x[0], 2.0, epsilon = 1e-15);
        approx::assert_abs_diff_eq!(x[1], 3.0, epsilon = 1e-15);
        assert_eq!(x[2], 4.0);
        assert!(c.violation(&x) < 1e-15);
    }

    #[test]
    fn dependent_zero_and_fourth_directions_are_errors() {
        let mut c = Constraints::new(2);
        assert_eq!(
            c.constrain(0, [0.0; 3], 1.0),
            Err(SparseError::DegenerateConstraint { particle: 0 })
        );
        c.constrain(0, [1.0, 0.0, 0.0], 0.0).unwrap();
        assert_eq!(
            c.constrain(0, [2.0, 0.0, 0.0], 0.0),
            Err(SparseError::DegenerateConstraint { particle: 0 })
        );
        c.pin(1, [0.0; 3]).unwrap();
        assert_eq!(
            c.constrain(1, [0.0, 0.0, 1.0], 0.0),
            Err(SparseError::DegenerateConstraint { particle: 1 })
        );
        assert!(matches!(
            c.constrain(5, [1.0, 0.0, 0.0], 0.0),
            Err(SparseError::BlockIndexOutOfRange { .. })
        ));
        assert!(matches!(
            c.constrain(0, [0.0, f64::NAN, 0.0], 0.0),
            Err(SparseError::NonFinite { .. })
        ));
    }

    #[test]
    fn clear_forgets_everything() {
        let mut c = Constraints::new(2);
        c.pin(1, [1.0, 2.0, 3.0]).unwrap();
        assert_eq!(c.count(1), 3);
        c.clear();
        assert!(c.is_empty());
        assert_eq!(c.count(1), 0);
        let mut v = vec![1.0; 6];
        c.project(&mut v);
        assert_eq!(v, vec![1.0; 6]);
    }
}
