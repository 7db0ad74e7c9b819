//! Closest points: a point and a triangle (by the Voronoi regions of the
//! triangle's vertices, edges and face), and two segments.

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// The feature of a triangle `(a, b, c)` a closest point lies on. Edge `k`
/// joins vertex `k` and vertex `(k + 1) % 3`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Feature {
    /// Vertex 0, 1 or 2.
    Vertex(u8),
    /// Edge 0 (a-b), 1 (b-c) or 2 (c-a).
    Edge(u8),
    /// The interior of the face.
    Face,
}

/// The closest point of a triangle to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrianglePoint {
    /// The point.
    pub point: V3,
    /// Its barycentric coordinates `(u, v, w)`: `point = u a + v b + w c`.
    pub bary: [f64; 3],
    /// The feature it lies on.
    pub feature: Feature,
}

/// The point of triangle `(a, b, c)` closest to `p`, classified by the
/// Voronoi region of `p` (the vertex regions, then the edge regions, then
/// the face), from the signs of the dot products `d1..d6` of the edges with
/// the vectors to `p` (Ericson, *Real-Time Collision Detection*, 5.1.5). A
/// degenerate triangle (zero area) falls back to its closest edge.
pub fn closest_point_triangle(p: &V3, a: &V3, b: &V3, c: &V3) -> TrianglePoint {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let vertex = |k: u8, q: &V3| {
        let mut bary = [0.0; 3];
        bary[k as usize] = 1.0;
        TrianglePoint {
            point: *q,
            bary,
            feature: Feature::Vertex(k),
        }
    };
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return vertex(0, a);
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return vertex(1, b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return TrianglePoint {
            point: a + ab * v,
            bary: [1.0 - v, v, 0.0],
            feature: Feature::Edge(0),
        };
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return vertex(2, c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return TrianglePoint {
            point: a + ac * w,
            bary: [1.0 - w, 0.0, w],
            feature: Feature::Edge(2),
        };
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return TrianglePoint {
            point: b + (c - b) * w,
            bary: [0.0, 1.0 - w, w],
            feature: Feature::Edge(1),
        };
    }
    let sum = va + vb + vc;
    if !(sum > 0.0) || !sum.is_finite() {
        return closest_on_edges(p, a, b, c);
    }
    let v = vb / sum;
    let w = vc / sum;
    TrianglePoint {
        point: a + ab * v + ac * w,
        bary: [1.0 - v - w, v, w],
        feature: Feature::Face,
    }
}

/// The closest point on the three edges (degenerate triangles).
fn closest_on_edges(p: &V3, a: &V3, b: &V3, c: &V3) -> TrianglePoint {
    let corners = [a, b, c];
    let mut best: Option<(f64, TrianglePoint)> = None;
    for k in 0..3u8 {
        let (s, e) = (corners[k as usize], corners[(k as usize + 1) % 3]);
        let d = e - s;
        let len2 = d.norm_squared();
        let t = if len2 > 0.0 {
            ((p - s).dot(&d) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = s + d * t;
        let dist = (p - q).norm_squared();
        if best.as_ref().is_none_or(|(bd, _)| dist < *bd) {
            let mut bary = [0.0; 3];
            bary[k as usize] = 1.0 - t;
            bary[(k as usize + 1) % 3] = t;
            best = Some((
                dist,
                TrianglePoint {
                    point: q,
                    bary,
                    feature: Feature::Edge(k),
                },
            ));
        }
    }
    best.map_or(
        TrianglePoint {
            point: *a,
            bary: [1.0, 0.0, 0.0],
            feature: Feature::Vertex(0),
        },
        |(_, t)| t,
    )
}

/// The closest points `p1 + s (q1 - p1)` and `p2 + t (q2 - p2)` of two
/// segments, `s, t` in `[0, 1]` (Ericson 5.1.9: the unconstrained minimum
/// of the squared distance, clamped to the square and re-projected).
/// Degenerate (point) segments and parallel ones are handled.
pub fn closest_points_segments(p1: &V3, q1: &V3, p2: &V3, q2: &V3) -> (f64, f64, V3, V3) {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = d1.norm_squared();
    let e = d2.norm_squared();
    let f = d2.dot(&r);
    // Relative size below which a segment counts as a point.
    let tiny = f64::EPSILON * (a + e).max(f64::MIN_POSITIVE);
    let (s, t) = if a <= tiny && e <= tiny {
        (0.0, 0.0)
    } else if a <= tiny {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e <= tiny {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > f64::EPSILON * a * e {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0 // parallel: any s; take the start
            };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (s, t, p1 + d1 * s, p2 + d2 * t)
}

/// Relative margin of the separating-axis tests below: they answer `true`
/// only when the bound beats `r` by this much, far more than round-off.
const AXIS_MARGIN: f64 = 1e-9;

/// True when segments `p1 q1` and `p2 q2` are provably farther apart than
/// `r > 0`: their projections on the line through their midpoints (a
/// separating axis; projection does not lengthen distances) are more than
/// `r` apart. No square root or division, so much cheaper than
/// [`closest_points_segments`]; exact for side-by-side and end-to-end
/// segments (a cloth's common near pairs), `false` when unsure.
#[inline]
pub fn segments_farther_than(p1: &V3, q1: &V3, p2: &V3, q2: &V3, r: f64) -> bool {
    let m = (p2 + q2 - p1 - q1) * 0.5;
    let len2 = m.norm_squared();
    // gap * |m| = |m|^2 - (|e1 . m| + |e2 . m|) / 2.
    let g = len2 - 0.5 * ((q1 - p1).dot(&m).abs() + (q2 - p2).dot(&m).abs());
    g > 0.0 && g * g > r * r * len2 * (1.0 + AXIS_MARGIN)
}

/// True when `p` is provably farther than `r > 0` from triangle `(a, b,
/// c)`: the triangle's projection on the line from `p` to its centroid
/// starts more than `r` beyond `p` (a separating axis). Cheap; `false` when
/// unsure.
#[inline]
pub fn point_triangle_farther_than(p: &V3, a: &V3, b: &V3, c: &V3, r: f64) -> bool {
    let (da, db, dc) = (a - p, b - p, c - p);
    let m = da + db + dc; // 3 (centroid - p)
    let near = da.dot(&m).min(db.dot(&m)).min(dc.dot(&m));
    near > 0.0 && near * near > r * r * m.norm_squared() * (1.0 + AXIS_MARGIN)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    fn rv(rng: &mut SmallRng) -> V3 {
        V3::new(
            rng.random::<f64>() * 2.0 - 1.0,
            rng.random::<f64>() * 2.0 - 1.0,
            rng.random::<f64>() * 2.0 - 1.0,
        )
    }

    /// The closest point beats a dense sample of the triangle, and its
    /// barycentric coordinates reproduce it.
    #[test]
    fn triangle_closest_point_is_no_farther_than_any_sample() {
        let mut rng = SmallRng::seed_from_u64(3);
        for _ in 0..300 {
            let (a, b, c, p) = (rv(&mut rng), rv(&mut rng), rv(&mut rng), rv(&mut rng) * 2.0);
            let q = closest_point_triangle(&p, &a, &b, &c);
            let from_bary = a * q.bary[0] + b * q.bary[1] + c * q.bary[2];
            assert!((from_bary - q.point).norm() < 1e-12);
            assert!(q.bary.iter().all(|&w| w >= -1e-12));
            let d = (p - q.point).norm();
            assert!(!point_triangle_farther_than(&p, &a, &b, &c, d));
            let n = 60;
            for i in 0..=n {
                for j in 0..=n - i {
                    let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                    let s = a + (b - a) * u + (c - a) * v;
                    assert!(d <= (p - s).norm() + 1e-12);
                }
            }
            if q.feature == Feature::Face {
                let nrm = (b - a).cross(&(c - a));
                assert!((p - q.point).cross(&nrm).norm() <= 1e-9 * nrm.norm() * (1.0 + d));
            }
        }
    }

    #[test]
    fn segment_closest_points_are_no_farther_than_any_sample() {
        let mut rng = SmallRng::seed_from_u64(5);
        for k in 0..300 {
            let (p1, q1, p2) = (rv(&mut rng), rv(&mut rng), rv(&mut rng));
            // Every tenth pair parallel, every 30th a point.
            let q2 = match k % 30 {
                0 => p2,
                x if x % 10 == 0 => p2 + (q1 - p1) * 0.7,
                _ => rv(&mut rng),
            };
            let (s, t, c1, c2) = closest_points_segments(&p1, &q1, &p2, &q2);
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t));
            let d = (c1 - c2).norm();
            assert!(!segments_farther_than(&p1, &q1, &p2, &q2, d), "case {k}");
            for i in 0..=50 {
                for j in 0..=50 {
                    let a = p1 + (q1 - p1) * (i as f64 / 50.0);
                    let b = p2 + (q2 - p2) * (j as f64 / 50.0);
                    assert!(d <= (a - b).norm() + 1e-12, "case {k}");
                }
            }
        }
    }

    /// The separating-axis tests are exact where a cloth's near pairs are:
    /// parallel segments side by side or end to end, a point facing a
    /// triangle's vertex in its plane; and never claim more than the truth.
    #[test]
    fn separating_axis_tests_are_tight_on_side_by_side_features() {
        let (p1, q1) = (V3::new(0.0, 0.0, 0.0), V3::new(1.0, 1.0, 0.0));
        let off = V3::new(0.3, -0.3, 0.0); // distance 0.3 sqrt(2)
        let d = off.norm();
        let (p2, q2) = (p1 + off, q1 + off);
        assert!(segments_farther_than(&p1, &q1, &p2, &q2, 0.999 * d));
        assert!(!segments_farther_than(&p1, &q1, &p2, &q2, d));
        // End to end along a line: the gap between the ends, 0.5 |q1|.
        let (p3, q3) = (q1 * 1.5, q1 * 2.0);
        let d = 0.5 * q1.norm();
        assert!(segments_farther_than(&p1, &q1, &p3, &q3, 0.999 * d));
        assert!(!segments_farther_than(&p1, &q1, &p3, &q3, d));
        // A point in the plane on the line from the centroid through
        // vertex a: its distance sqrt(2) to a.
        let (a, b, c) = (
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        );
        let p = V3::new(-1.0, -1.0, 0.0);
        let d = (p - closest_point_triangle(&p, &a, &b, &c).point).norm();
        assert_eq!(d, 2f64.sqrt());
        assert!(point_triangle_farther_than(&p, &a, &b, &c, 0.999 * d));
        assert!(!point_triangle_farther_than(&p, &a, &b, &c, d));
        // Crossing segments and a point over the face: no claim.
        let (p4, q4) = (V3::new(0.0, 1.0, 0.0), V3::new(1.0, 0.0, 0.0));
        assert!(!segments_farther_than(&p1, &q1, &p4, &q4, 1e-9));
        let over = V3::new(0.2, 0.2, 0.5);
        assert!(!point_triangle_farther_than(&over, &a, &b, &c, 0.4));
    }
}
