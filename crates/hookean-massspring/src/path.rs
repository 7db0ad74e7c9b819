//! Keyframed rigid paths: a translation and a rotation given at key times,
//! interpolated linearly or smoothly, held before the first key and after
//! the last. The targets of pin groups ([`crate::PinGroup`]) move along one.
//!
//! A point at `X` at rest is at `c(t) + R(theta(t)) (X - c0)` at time `t`,
//! with `c(t) = c0 + T(t)` the moved pivot, `T(t)` the interpolated
//! translation and `theta(t)` the interpolated rotation vector (`R(w)` the
//! rotation by `|w|` radians about `w`, as [`crate::RigidMotion`]). Between
//! keys `k` and `k + 1` both are `a_k + s(u) (a_{k+1} - a_k)` with `u = (t -
//! t_k) / (t_{k+1} - t_k)` and `s(u) = u` (linear) or `s(u) = 3u^2 - 2u^3`
//! (smooth: zero velocity at every key).
//!
//! ```
//! use hookean_massspring::{Interpolation, Keyframe, KeyframedPath};
//!
//! let path = KeyframedPath::new(
//!     vec![
//!         Keyframe { t: 0.0, translation: [0.0; 3], rotation: [0.0; 3] },
//!         Keyframe { t: 2.0, translation: [1.0, 0.0, 0.0], rotation: [0.0; 3] },
//!     ],
//!     Interpolation::Linear,
//!     [0.0; 3],
//! )?;
//! assert_eq!(path.point_at(1.0, [0.0, 0.0, 1.0]), [0.5, 0.0, 1.0]);
//! assert_eq!(path.velocity_at(1.0, [0.0, 0.0, 1.0]), [0.5, 0.0, 0.0]);
//! # Ok::<(), hookean_massspring::MassSpringError>(())
//! ```

use nalgebra::{Rotation3, Vector3};

use crate::error::MassSpringError;

/// How a [`KeyframedPath`] goes from one key to the next.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Interpolation {
    /// `s(u) = u`: constant velocity between keys.
    #[default]
    Linear,
    /// `s(u) = 3 u^2 - 2 u^3`: eases in and out, at rest at every key.
    Smooth,
}

/// One key of a [`KeyframedPath`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyframe {
    /// Time (s).
    pub t: f64,
    /// Translation of the pivot (m).
    pub translation: [f64; 3],
    /// Rotation vector about the pivot (rad: the axis scaled by the angle).
    pub rotation: [f64; 3],
}

/// A rigid motion through keyframes (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct KeyframedPath {
    keys: Vec<Keyframe>,
    interpolation: Interpolation,
    pivot: [f64; 3],
}

impl KeyframedPath {
    /// A path through `keys` (at least one, times strictly increasing).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for no keys, a value that is
    /// not finite (naming the key, from 1) or times that do not increase.
    pub fn new(
        keys: Vec<Keyframe>,
        interpolation: Interpolation,
        pivot: [f64; 3],
    ) -> Result<Self, MassSpringError> {
        let bad = |message: String| MassSpringError::InvalidParameter {
            name: "keys",
            message,
        };
        if keys.is_empty() {
            return Err(bad("a path needs at least one key".into()));
        }
        if pivot.iter().any(|c| !c.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "pivot",
                message: format!("{pivot:?} must be finite"),
            });
        }
        for (k, key) in keys.iter().enumerate() {
            let values = std::iter::once(key.t)
                .chain(key.translation)
                .chain(key.rotation);
            if values.into_iter().any(|c| !c.is_finite()) {
                return Err(bad(format!("key {}: every value must be finite", k + 1)));
            }
            if k > 0 && !(key.t > keys[k - 1].t) {
                return Err(bad(format!(
                    "key {}: t = {} does not come after the key before (t = {})",
                    k + 1,
                    hookean_sparse::Short(key.t),
                    hookean_sparse::Short(keys[k - 1].t)
                )));
            }
        }
        Ok(Self {
            keys,
            interpolation,
            pivot,
        })
    }

    /// The keys.
    pub fn keys(&self) -> &[Keyframe] {
        &self.keys
    }

    /// How the path goes between keys.
    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    /// The segment at `t` and `(s(u), ds/dt)` on it (held outside the keys).
    /// At a key the rates are those of the segment that starts there (the
    /// right derivative: a step from the first key's time moves with the
    /// path), after the last key zero.
    fn segment(&self, t: f64) -> (usize, f64, f64) {
        let last = self.keys.len() - 1;
        if last == 0 || t < self.keys[0].t {
            return (0, 0.0, 0.0);
        }
        if t >= self.keys[last].t {
            return (last - 1, 1.0, 0.0);
        }
        // The last key at or before t (keys are few: a linear scan).
        let k = self.keys[..last]
            .iter()
            .rposition(|key| key.t <= t)
            .unwrap_or(0);
        let span = self.keys[k + 1].t - self.keys[k].t;
        let u = (t - self.keys[k].t) / span;
        match self.interpolation {
            Interpolation::Linear => (k, u, 1.0 / span),
            Interpolation::Smooth => (k, u * u * (3.0 - 2.0 * u), 6.0 * u * (1.0 - u) / span),
        }
    }

    /// Translation, rotation vector and their time derivatives at `t`.
    fn state(&self, t: f64) -> [Vector3<f64>; 4] {
        let (k, s, ds) = self.segment(t);
        let a = &self.keys[k];
        let b = self.keys.get(k + 1).unwrap_or(a);
        let lerp = |p: [f64; 3], q: [f64; 3]| {
            let (p, q) = (Vector3::from(p), Vector3::from(q));
            (p + (q - p) * s, (q - p) * ds)
        };
        let (tr, dtr) = lerp(a.translation, b.translation);
        let (rot, drot) = lerp(a.rotation, b.rotation);
        [tr, dtr, rot, drot]
    }

    /// Where the point at `x_rest` at rest is at time `t`.
    pub fn point_at(&self, t: f64, x_rest: [f64; 3]) -> [f64; 3] {
        let [tr, _, rot, _] = self.state(t);
        let c0 = Vector3::from(self.pivot);
        let w = c0 + tr + Rotation3::from_scaled_axis(rot) * (Vector3::from(x_rest) - c0);
        [w.x, w.y, w.z]
    }

    /// The pose at time `t`: the rotation `R(theta(t))` and the moved pivot
    /// `c(t) = c0 + T(t)`.
    pub fn pose(&self, t: f64) -> (Rotation3<f64>, Vector3<f64>) {
        let [tr, _, rot, _] = self.state(t);
        (
            Rotation3::from_scaled_axis(rot),
            Vector3::from(self.pivot) + tr,
        )
    }

    /// The pivot at rest, `c0` (m).
    pub fn pivot(&self) -> [f64; 3] {
        self.pivot
    }

    /// The velocity at time `t` of the body point that is at the world
    /// point `x` then: `T'(t) + theta'(t) x (x - c(t))`, as
    /// [`velocity_at`](Self::velocity_at).
    pub fn velocity_of_world_point(&self, t: f64, x: &Vector3<f64>) -> Vector3<f64> {
        let [tr, dtr, _, drot] = self.state(t);
        let c = Vector3::from(self.pivot) + tr;
        dtr + drot.cross(&(x - c))
    }

    /// Bounds of the path's speeds over all time: the largest `|T'(t)|`
    /// (m/s) and `|theta'(t)|` (rad/s) (`s'(u)` peaks at `1.5 / span` for
    /// smooth interpolation), for the energy budget's bound of the work a
    /// body on the path can do.
    pub fn max_rates(&self) -> (f64, f64) {
        let peak = match self.interpolation {
            Interpolation::Linear => 1.0,
            Interpolation::Smooth => 1.5,
        };
        let mut rates = (0.0f64, 0.0f64);
        for w in self.keys.windows(2) {
            let span = w[1].t - w[0].t;
            let d = |a: [f64; 3], b: [f64; 3]| (Vector3::from(b) - Vector3::from(a)).norm();
            rates.0 = rates
                .0
                .max(peak * d(w[0].translation, w[1].translation) / span);
            rates.1 = rates.1.max(peak * d(w[0].rotation, w[1].rotation) / span);
        }
        rates
    }

    /// The velocity at time `t` of the point at `x_rest` at rest:
    /// `T'(t) + theta'(t) x (x(t) - c(t))` (exact for rotations about one
    /// axis within a segment, the paths keys of one axis give).
    pub fn velocity_at(&self, t: f64, x_rest: [f64; 3]) -> [f64; 3] {
        let [_, dtr, rot, drot] = self.state(t);
        let c0 = Vector3::from(self.pivot);
        let arm = Rotation3::from_scaled_axis(rot) * (Vector3::from(x_rest) - c0);
        let w = dtr + drot.cross(&arm);
        [w.x, w.y, w.z]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(t: f64, translation: [f64; 3], rotation: [f64; 3]) -> Keyframe {
        Keyframe {
            t,
            translation,
            rotation,
        }
    }

    #[test]
    fn a_quarter_turn_about_z_moves_x_to_y() {
        let path = KeyframedPath::new(
            vec![
                key(0.0, [0.0; 3], [0.0; 3]),
                key(1.0, [0.0; 3], [0.0, 0.0, std::f64::consts::FRAC_PI_2]),
            ],
            Interpolation::Linear,
            [0.0; 3],
        )
        .unwrap();
        let p = path.point_at(1.0, [1.0, 0.0, 0.0]);
        assert!((p[0]).abs() < 1e-15 && (p[1] - 1.0).abs() < 1e-15, "{p:?}");
        // Speed |omega| r = pi / 2 along +y at the start.
        let v = path.velocity_at(0.5, [1.0, 0.0, 0.0]);
        let r = path.point_at(0.5, [1.0, 0.0, 0.0]);
        let speed = (v[0] * v[0] + v[1] * v[1]).sqrt();
        assert!((speed - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((v[0] * r[0] + v[1] * r[1]).abs() < 1e-12, "tangent");
    }

    #[test]
    fn velocity_is_the_derivative_of_position() {
        let path = KeyframedPath::new(
            vec![
                key(0.0, [0.0; 3], [0.0; 3]),
                key(1.0, [1.0, 2.0, 0.0], [0.0, 0.3, 0.0]),
                key(3.0, [0.0, 0.0, 1.0], [0.0, -0.5, 0.0]),
            ],
            Interpolation::Smooth,
            [0.5, 0.0, 0.0],
        )
        .unwrap();
        let x = [1.0, 1.0, 1.0];
        for &t in &[0.2, 0.7, 1.5, 2.9] {
            let d = 1e-6;
            let (a, b) = (path.point_at(t - d, x), path.point_at(t + d, x));
            let v = path.velocity_at(t, x);
            for c in 0..3 {
                assert!(((b[c] - a[c]) / (2.0 * d) - v[c]).abs() < 1e-6, "t = {t}");
            }
        }
        // Held after the last key, at rest.
        assert_eq!(path.point_at(5.0, x), path.point_at(3.0, x));
        assert_eq!(path.velocity_at(5.0, x), [0.0; 3]);
    }

    #[test]
    fn bad_keys_are_named() {
        let e = KeyframedPath::new(
            vec![
                key(0.0, [0.0; 3], [0.0; 3]),
                key(1.0, [f64::NAN, 0.0, 0.0], [0.0; 3]),
            ],
            Interpolation::Linear,
            [0.0; 3],
        )
        .unwrap_err();
        assert!(e.to_string().contains("key 2"), "{e}");
        let e = KeyframedPath::new(
            vec![key(1.0, [0.0; 3], [0.0; 3]), key(1.0, [0.0; 3], [0.0; 3])],
            Interpolation::Linear,
            [0.0; 3],
        )
        .unwrap_err();
        assert!(e.to_string().contains("does not come after"), "{e}");
    }
}
