//! Proximity of two features at one instant: a vertex within a distance of
//! the interior of a triangle, two edges within a distance of each other
//! at interior points (the pairs that Bridson, Fedkiw and Anderson 2002,
//! section 7.2, repel to keep a cloth's thickness).

use nalgebra::Vector3;

use crate::closest::{Feature, closest_point_triangle, closest_points_segments};

type V3 = Vector3<f64>;

/// Two features closer than a given distance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proximity {
    /// Their distance.
    pub distance: f64,
    /// Weights `w` of the four points: `sum_i w_i x_i` is the vector from
    /// the second feature's closest point to the first's (see
    /// [`Impact::weights`](crate::ccd::Impact::weights)).
    pub weights: [f64; 4],
    /// The unit direction of that vector (for features touching, the
    /// triangle's normal or the edges' common normal).
    pub normal: V3,
}

/// Vertex `x[0]` within `radius` of the interior of triangle `(x[1], x[2],
/// x[3])` (its closest point on the face, not on an edge or vertex: those
/// contacts are edge-edge ones).
pub fn vertex_face_proximity(x: &[V3; 4], radius: f64) -> Option<Proximity> {
    let q = closest_point_triangle(&x[0], &x[1], &x[2], &x[3]);
    if q.feature != Feature::Face {
        return None;
    }
    let d = x[0] - q.point;
    let distance = d.norm();
    if !(distance < radius) {
        return None;
    }
    let normal = if distance > 0.0 {
        d / distance
    } else {
        (x[2] - x[1]).cross(&(x[3] - x[1])).normalize()
    };
    Some(Proximity {
        distance,
        weights: [1.0, -q.bary[0], -q.bary[1], -q.bary[2]],
        normal,
    })
}

/// Edges `(x[0], x[1])` and `(x[2], x[3])` within `radius` of each other
/// at points inside both (end points are vertex contacts).
pub fn edge_edge_proximity(x: &[V3; 4], radius: f64) -> Option<Proximity> {
    let (s, r, c1, c2) = closest_points_segments(&x[0], &x[1], &x[2], &x[3]);
    if !(s > 0.0 && s < 1.0 && r > 0.0 && r < 1.0) {
        return None;
    }
    let d = c1 - c2;
    let distance = d.norm();
    if !(distance < radius) {
        return None;
    }
    let normal = if distance > 0.0 {
        d / distance
    } else {
        (x[1] - x[0]).cross(&(x[3] - x[2])).try_normalize(0.0)?
    };
    Some(Proximity {
        distance,
        weights: [1.0 - s, s, -(1.0 - r), -r],
        normal,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proximity_reports_distance_weights_and_normal() {
        let x = [
            V3::new(0.25, 0.25, 0.01),
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ];
        let p = vertex_face_proximity(&x, 0.02).unwrap();
        assert!((p.distance - 0.01).abs() < 1e-15);
        let gap: V3 = (0..4).map(|i| x[i] * p.weights[i]).sum();
        assert!((gap - p.normal * p.distance).norm() < 1e-15);
        assert!(vertex_face_proximity(&x, 0.005).is_none());
        // Over a vertex of the triangle: not a face contact.
        let mut y = x;
        y[0] = V3::new(-0.001, -0.001, 0.001);
        assert!(vertex_face_proximity(&y, 0.02).is_none());
        let e = [
            V3::new(-1.0, 0.5, 0.003),
            V3::new(1.0, 0.5, 0.003),
            V3::new(0.2, -1.0, 0.0),
            V3::new(0.2, 1.0, 0.0),
        ];
        let p = edge_edge_proximity(&e, 0.01).unwrap();
        assert!((p.distance - 0.003).abs() < 1e-15);
        assert!((p.normal - V3::z()).norm() < 1e-12);
        assert!((p.weights[0] - 0.4).abs() < 1e-12 && (p.weights[3] + 0.75).abs() < 1e-12);
    }
}
