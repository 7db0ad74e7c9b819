//! Axis-aligned bounding boxes.

use nalgebra::Vector3;

/// An axis-aligned box `[min, max]`; [`Aabb::EMPTY`] contains nothing and is
/// the identity of [`Aabb::union`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f64; 3],
    /// Upper corner.
    pub max: [f64; 3],
}

impl Aabb {
    /// The empty box (`min = +inf`, `max = -inf`).
    pub const EMPTY: Aabb = Aabb {
        min: [f64::INFINITY; 3],
        max: [f64::NEG_INFINITY; 3],
    };

    /// The box of one point.
    pub fn point(p: &Vector3<f64>) -> Self {
        Self {
            min: [p.x, p.y, p.z],
            max: [p.x, p.y, p.z],
        }
    }

    /// Grows the box to contain `p`.
    #[inline]
    pub fn add_point(&mut self, p: &Vector3<f64>) {
        for k in 0..3 {
            self.min[k] = self.min[k].min(p[k]);
            self.max[k] = self.max[k].max(p[k]);
        }
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        let mut b = *self;
        for k in 0..3 {
            b.min[k] = b.min[k].min(o.min[k]);
            b.max[k] = b.max[k].max(o.max[k]);
        }
        b
    }

    /// The box grown by `r` on every side.
    #[inline]
    pub fn inflated(&self, r: f64) -> Aabb {
        let mut b = *self;
        for k in 0..3 {
            b.min[k] -= r;
            b.max[k] += r;
        }
        b
    }

    /// True when the boxes share a point (closed boxes).
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        (0..3).all(|k| self.min[k] <= o.max[k] && o.min[k] <= self.max[k])
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    pub fn distance_squared(&self, p: &Vector3<f64>) -> f64 {
        let mut d2 = 0.0;
        for k in 0..3 {
            let e = (self.min[k] - p[k]).max(p[k] - self.max[k]).max(0.0);
            d2 += e * e;
        }
        d2
    }

    /// The centre.
    pub fn center(&self) -> Vector3<f64> {
        Vector3::new(
            0.5 * (self.min[0] + self.max[0]),
            0.5 * (self.min[1] + self.max[1]),
            0.5 * (self.min[2] + self.max[2]),
        )
    }

    /// The edge lengths (negative for the empty box).
    pub fn extent(&self) -> Vector3<f64> {
        Vector3::new(
            self.max[0] - self.min[0],
            self.max[1] - self.min[1],
            self.max[2] - self.min[2],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn union_overlap_and_distance_follow_the_definitions() {
        let a = Aabb::point(&Vector3::new(0.0, 0.0, 0.0))
            .union(&Aabb::point(&Vector3::new(1.0, 1.0, 1.0)));
        let b = Aabb::point(&Vector3::new(1.0, 2.0, 0.5));
        assert!(!a.overlaps(&b));
        assert!(a.inflated(1.0).overlaps(&b));
        assert_eq!(a.distance_squared(&Vector3::new(1.0, 2.0, 0.5)), 1.0);
        assert_eq!(a.distance_squared(&Vector3::new(0.5, 0.5, 0.5)), 0.0);
        assert_eq!(Aabb::EMPTY.union(&a), a);
        assert!(!Aabb::EMPTY.overlaps(&a));
    }
}
