//! Plane and sphere colliders and the per-step contact handling of the
//! tutorial's section 4.2 (constraints for collision response).

use nalgebra::Vector3;

use crate::error::MassSpringError;
use crate::model::{Dirs, MassSpringModel, point};

/// A static obstacle: particles stay on its outer side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Collider {
    /// The half-space above a plane: signed distance `(x - point) . normal`.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// The unit outward normal.
        normal: [f64; 3],
        /// Contact margin (thickness) `>= 0`: particles closer than this count as touching.
        margin: f64,
    },
    /// The outside of a ball: signed distance `|x - center| - radius`.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius `> 0`.
        radius: f64,
        /// Contact margin (thickness) `>= 0`.
        margin: f64,
    },
}

impl Collider {
    /// The plane through `point` with outward `normal` (normalised here).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a zero or non-finite normal,
    /// non-finite point, or a negative / non-finite margin.
    pub fn plane(point: [f64; 3], normal: [f64; 3], margin: f64) -> Result<Self, MassSpringError> {
        let n = Vector3::from(normal);
        let len = n.norm();
        if !(len > 0.0 && len.is_finite()) || point.iter().any(|p| !p.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "plane",
                message: format!(
                    "point {point:?} and normal {normal:?} must be finite, normal non-zero"
                ),
            });
        }
        check_margin(margin)?;
        let n = n / len;
        Ok(Collider::Plane {
            point,
            normal: [n.x, n.y, n.z],
            margin,
        })
    }

    /// The ball of `radius` around `center`.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a non-positive radius, a
    /// non-finite centre, or a negative / non-finite margin.
    pub fn sphere(center: [f64; 3], radius: f64, margin: f64) -> Result<Self, MassSpringError> {
        if !(radius > 0.0 && radius.is_finite()) || center.iter().any(|p| !p.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "sphere",
                message: format!("center {center:?} must be finite, radius {radius:?} positive"),
            });
        }
        check_margin(margin)?;
        Ok(Collider::Sphere {
            center,
            radius,
            margin,
        })
    }

    /// Signed distance of `x` to the surface (negative inside) and the unit
    /// outward normal at the closest surface point.
    pub fn signed_distance(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>) {
        match *self {
            Collider::Plane { point, normal, .. } => {
                let n = Vector3::from(normal);
                ((x - Vector3::from(point)).dot(&n), n)
            }
            Collider::Sphere { center, radius, .. } => {
                let r = x - Vector3::from(center);
                let len = r.norm();
                // At the centre every direction is a normal: take +z.
                let n = if len > 0.0 { r / len } else { Vector3::z() };
                (len - radius, n)
            }
        }
    }

    /// The contact margin.
    pub fn margin(&self) -> f64 {
        match *self {
            Collider::Plane { margin, .. } | Collider::Sphere { margin, .. } => margin,
        }
    }
}

fn check_margin(margin: f64) -> Result<(), MassSpringError> {
    if margin >= 0.0 && margin.is_finite() {
        Ok(())
    } else {
        Err(MassSpringError::InvalidParameter {
            name: "margin",
            message: format!("{margin:?} must be non-negative and finite"),
        })
    }
}

impl MassSpringModel {
    /// Steps 1 and 2 of `begin_step`: permanent constraints, then contacts.
    /// No allocation.
    pub(crate) fn apply_constraints_and_contacts(&mut self, x: &mut [f64], v: &mut [f64]) {
        self.refresh_permanent();
        let n = self.n_particles();
        for p in 0..n {
            let d = self.fixes[p];
            for k in 0..d.count {
                let e = d.dirs[k];
                let xe: f64 = (0..3).map(|r| e[r] * x[3 * p + r]).sum();
                let ve: f64 = (0..3).map(|r| e[r] * v[3 * p + r]).sum();
                for r in 0..3 {
                    x[3 * p + r] -= (xe - d.values[k]) * e[r];
                    v[3 * p + r] -= ve * e[r];
                }
            }
        }
        if self.colliders.is_empty() {
            return;
        }
        // The force with permanent constraints only, to release contacts
        // that the force pulls away from the surface.
        let mut f = std::mem::take(&mut self.scratch);
        self.eval_force(x, v, &mut f);
        for p in 0..n {
            if self.fixes[p].count == 3 {
                continue;
            }
            for c in 0..self.colliders.len() {
                let collider = self.colliders[c];
                let xp = point(x, p);
                let (phi, normal) = collider.signed_distance(&xp);
                if phi.is_nan() || phi > collider.margin() {
                    continue;
                }
                if phi < 0.0 {
                    let y = xp - normal * phi;
                    x[3 * p..3 * p + 3].copy_from_slice(y.as_slice());
                }
                let vp = point(v, p);
                let vn = vp.dot(&normal);
                if vn < 0.0 {
                    let w = vp - normal * vn;
                    v[3 * p..3 * p + 3].copy_from_slice(w.as_slice());
                }
                if vn > 0.0 || point(&f, p).dot(&normal) > 0.0 {
                    continue; // separating: no constraint this step
                }
                let mut dirs: Dirs = self.active_set.dirs[p];
                if dirs.push([normal.x, normal.y, normal.z], 0.0) {
                    self.activate(p, dirs);
                    self.active_set.contact_count += 1;
                }
            }
        }
        self.scratch = f;
    }
}
