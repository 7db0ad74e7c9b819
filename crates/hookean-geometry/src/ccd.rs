//! Continuous collision detection for vertices moving linearly over a time
//! step (Bridson, Fedkiw and Anderson 2002, section 6; Provot 1997): a
//! vertex and a triangle, or two edges, can only meet at a time `t` in
//! `[0, 1]` when their four points are coplanar, a cubic equation in `t`;
//! at each root (in increasing order) the distance between the two
//! features, and whether they close in on each other along the contact
//! normal, decide whether they meet.
//!
//! ```
//! use hookean_geometry::ccd::vertex_face;
//! use nalgebra::Vector3;
//!
//! // A vertex falling through a triangle in the plane z = 0.
//! let tri = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 1.0, 0.0)];
//! let x0 = [Vector3::new(0.2, 0.2, 0.5), tri[0], tri[1], tri[2]];
//! let x1 = [Vector3::new(0.2, 0.2, -0.5), tri[0], tri[1], tri[2]];
//! let hit = vertex_face(&x0, &x1, 1e-6).expect("the vertex crosses the face");
//! assert!((hit.t - 0.5).abs() < 1e-12);
//! assert!((hit.normal.z - 1.0).abs() < 1e-12); // pointing to where the vertex came from
//! ```

use nalgebra::Vector3;

use crate::closest::{
    closest_point_triangle, closest_points_segments, point_triangle_farther_than,
    segments_farther_than,
};

type V3 = Vector3<f64>;

/// Where and how two features meet during the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impact {
    /// The fraction of the step, in `[0, 1]`, of the first contact.
    pub t: f64,
    /// Weights `w` of the four points: `sum_i w_i x_i` is the vector from
    /// the second feature's contact point to the first's (vertex-face:
    /// `(1, -u, -v, -w)` with the barycentric coordinates of the contact
    /// point; edge-edge: `(1 - s, s, -(1 - r), -r)`).
    pub weights: [f64; 4],
    /// The unit contact normal, oriented so that the first feature was on
    /// its positive side at the start of the step: the features approach
    /// while `n . sum_i w_i v_i < 0`.
    pub normal: V3,
}

/// The cubic `f(t) = ((x1 - x0) x (x2 - x0)) . (x3 - x0)` (six times the
/// signed volume of the tetrahedron) of four points moving linearly,
/// `x_i(t) = a_i + t d_i`, as coefficients `[c0, c1, c2, c3]`.
fn coplanarity_cubic(x0: &[V3; 4], x1: &[V3; 4], order: [usize; 4]) -> [f64; 4] {
    let p = |k: usize| x0[order[k]];
    let d = |k: usize| x1[order[k]] - x0[order[k]];
    // Edges from point 0, each A + t B.
    let (a1, b1) = (p(1) - p(0), d(1) - d(0));
    let (a2, b2) = (p(2) - p(0), d(2) - d(0));
    let (a3, b3) = (p(3) - p(0), d(3) - d(0));
    let n0 = a1.cross(&a2);
    let n1 = a1.cross(&b2) + b1.cross(&a2);
    let n2 = b1.cross(&b2);
    [
        n0.dot(&a3),
        n0.dot(&b3) + n1.dot(&a3),
        n1.dot(&b3) + n2.dot(&a3),
        n2.dot(&b3),
    ]
}

#[inline]
fn eval(c: &[f64; 4], t: f64) -> f64 {
    ((c[3] * t + c[2]) * t + c[1]) * t + c[0]
}

/// Candidate times in `[0, 1]`, ascending, written to `out` (at most 7):
/// every sign change of the cubic located by bisection to round-off, and
/// every end or turning point of its monotone pieces where `|f|` is within
/// `tol` of zero (grazing contact, and coplanar motion where `f` vanishes
/// identically). Returns the number written.
fn candidate_times(c: &[f64; 4], tol: f64, out: &mut [f64; 8]) -> usize {
    // Breakpoints: 0, the turning points of f in (0, 1), 1.
    let mut bp = [0.0; 4];
    let mut nb = 0;
    bp[nb] = 0.0;
    nb += 1;
    let (qa, qb, qc) = (3.0 * c[3], 2.0 * c[2], c[1]);
    let mut turns = [f64::NAN; 2];
    if qa != 0.0 {
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 {
            // The numerically stable pair of quadratic roots.
            let q = -0.5 * (qb + qb.signum() * disc.sqrt());
            turns = [q / qa, if q != 0.0 { qc / q } else { f64::NAN }];
        }
    } else if qb != 0.0 {
        turns[0] = -qc / qb;
    }
    if turns[0] > turns[1] {
        turns.swap(0, 1);
    }
    for t in turns {
        if t > 0.0 && t < 1.0 {
            bp[nb] = t;
            nb += 1;
        }
    }
    bp[nb] = 1.0;
    nb += 1;
    let mut n = 0;
    let mut push = |t: f64, out: &mut [f64; 8]| {
        if n == 0 || out[n - 1] < t {
            out[n] = t;
            n += 1;
        }
    };
    for k in 0..nb {
        let t = bp[k];
        let ft = eval(c, t);
        if ft.abs() <= tol {
            push(t, out);
        }
        if k + 1 < nb {
            let (mut lo, mut hi) = (t, bp[k + 1]);
            let (flo, fhi) = (ft, eval(c, hi));
            if flo.abs() > tol && fhi.abs() > tol && (flo < 0.0) != (fhi < 0.0) {
                // Monotone piece with a sign change: bisection to round-off.
                for _ in 0..100 {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        break;
                    }
                    if (eval(c, mid) < 0.0) == (flo < 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                push(0.5 * (lo + hi), out);
            }
        }
    }
    n
}

/// The tolerance on the cubic below which a breakpoint counts as a root:
/// round-off of the coefficients, relative to the size of the
/// configuration (`f` is a volume, `size^3`).
fn cubic_tolerance(x0: &[V3; 4], x1: &[V3; 4]) -> f64 {
    let mut lo = x0[0];
    let mut hi = x0[0];
    for p in x0.iter().chain(x1.iter()) {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let size = (hi - lo).amax().max(f64::MIN_POSITIVE);
    1e-12 * size * size * size
}

/// True when the features close along `n` over the step:
/// `n . sum_i w_i (x1_i - x0_i) < 0`.
fn closing(n: &V3, w: &[f64; 4], x0: &[V3; 4], x1: &[V3; 4]) -> bool {
    let c: f64 = (0..4).map(|i| w[i] * n.dot(&(x1[i] - x0[i]))).sum();
    c < 0.0
}

/// How far the distance between the features `0..split` and `split..4`
/// can shrink over the step: `max_{i < split} |d_i - c| + max_{i >= split}
/// |d_i - c|` with `d_i = x1_i - x0_i` and `c` their mean. Moving all four
/// points by the common `t c` keeps every distance between them, so the
/// features meet on the paths `x0 + t d` exactly when they meet on
/// `x0 + t (d - c)`, where each point moves by `|d_i - c|`; distance is
/// 1-Lipschitz in each point. A pair carried along together (a flapping
/// flag's neighbouring features) moves little relative to itself.
fn relative_motion(x0: &[V3; 4], x1: &[V3; 4], split: usize) -> f64 {
    let d: [V3; 4] = std::array::from_fn(|i| x1[i] - x0[i]);
    let c = (d[0] + d[1] + d[2] + d[3]) * 0.25;
    let reach = |range: std::ops::Range<usize>| {
        range
            .map(|i| (d[i] - c).norm_squared())
            .fold(0.0, f64::max)
            .sqrt()
    };
    reach(0..split) + reach(split..4)
}

/// Orients `n` so that the first feature starts on its positive side:
/// `n . sum_i w_i x_i(0) >= 0`, or, for features touching at the start,
/// so that they approach along it.
fn orient(n: V3, w: &[f64; 4], x0: &[V3; 4], x1: &[V3; 4]) -> V3 {
    let gap0: f64 = (0..4).map(|i| w[i] * n.dot(&x0[i])).sum();
    if gap0 > 0.0 {
        return n;
    }
    if gap0 < 0.0 {
        return -n;
    }
    let closing: f64 = (0..4).map(|i| w[i] * n.dot(&(x1[i] - x0[i]))).sum();
    if closing <= 0.0 { n } else { -n }
}

/// The impact at time `t` with weights `w` along `normal` (oriented by
/// [`orient`]) if the features close in along it, else `None`.
fn impact_if_closing(
    t: f64,
    w: [f64; 4],
    normal: V3,
    x0: &[V3; 4],
    x1: &[V3; 4],
) -> Option<Impact> {
    let normal = orient(normal, &w, x0, x1);
    closing(&normal, &w, x0, x1).then_some(Impact {
        t,
        weights: w,
        normal,
    })
}

/// The first time in the step at which vertex `x[0]` comes within `eta`
/// of triangle `(x[1], x[2], x[3])` while closing in on it (features that
/// touch but move apart or slide along each other are no impact), all four
/// moving linearly from `x0` to `x1`; `None` if it never does.
pub fn vertex_face(x0: &[V3; 4], x1: &[V3; 4], eta: f64) -> Option<Impact> {
    // Features farther apart at the start than their motions relative to
    // each other can close do not meet ([`relative_motion`]).
    // (The separating-axis test first: cheaper, and enough for most pairs.)
    let motion = relative_motion(x0, x1, 1);
    if point_triangle_farther_than(&x0[0], &x0[1], &x0[2], &x0[3], motion + eta) {
        return None;
    }
    let d0 = (x0[0] - closest_point_triangle(&x0[0], &x0[1], &x0[2], &x0[3]).point).norm();
    if d0 - motion > eta {
        return None;
    }
    let c = coplanarity_cubic(x0, x1, [1, 2, 3, 0]);
    let mut times = [0.0; 8];
    let n = candidate_times(&c, cubic_tolerance(x0, x1), &mut times);
    for &t in &times[..n] {
        let at = |k: usize| x0[k] + (x1[k] - x0[k]) * t;
        let (p, a, b, cc) = (at(0), at(1), at(2), at(3));
        let q = closest_point_triangle(&p, &a, &b, &cc);
        let d = p - q.point;
        if d.norm() <= eta {
            let w = [1.0, -q.bary[0], -q.bary[1], -q.bary[2]];
            let face = (b - a).cross(&(cc - a));
            let normal = if face.norm() > 0.0 {
                face.normalize()
            } else if d.norm() > 0.0 {
                d.normalize()
            } else {
                V3::z()
            };
            if let Some(impact) = impact_if_closing(t, w, normal, x0, x1) {
                return Some(impact);
            }
        }
    }
    None
}

/// The first time in the step at which edge `(x[0], x[1])` comes within
/// `eta` of edge `(x[2], x[3])` while closing in on it, all four moving
/// linearly from `x0` to `x1`; `None` if it never does.
pub fn edge_edge(x0: &[V3; 4], x1: &[V3; 4], eta: f64) -> Option<Impact> {
    let motion = relative_motion(x0, x1, 2);
    if segments_farther_than(&x0[0], &x0[1], &x0[2], &x0[3], motion + eta) {
        return None;
    }
    let (_, _, c1, c2) = closest_points_segments(&x0[0], &x0[1], &x0[2], &x0[3]);
    if (c1 - c2).norm() - motion > eta {
        return None;
    }
    let c = coplanarity_cubic(x0, x1, [0, 1, 2, 3]);
    let mut times = [0.0; 8];
    let n = candidate_times(&c, cubic_tolerance(x0, x1), &mut times);
    for &t in &times[..n] {
        let at = |k: usize| x0[k] + (x1[k] - x0[k]) * t;
        let (p1, q1, p2, q2) = (at(0), at(1), at(2), at(3));
        let (s, r, c1, c2) = closest_points_segments(&p1, &q1, &p2, &q2);
        let d = c1 - c2;
        if d.norm() <= eta {
            let w = [1.0 - s, s, -(1.0 - r), -r];
            let cross = (q1 - p1).cross(&(q2 - p2));
            let normal = if cross.norm() > 1e-12 * (q1 - p1).norm() * (q2 - p2).norm() {
                cross.normalize()
            } else if d.norm() > 0.0 {
                d.normalize()
            } else {
                // Parallel and touching: any direction across both edges.
                let e = q1 - p1;
                let trial = if e.x.abs() < e.y.abs() {
                    V3::x()
                } else {
                    V3::y()
                };
                e.cross(&trial).normalize()
            };
            if let Some(impact) = impact_if_closing(t, w, normal, x0, x1) {
                return Some(impact);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    #[test]
    fn candidate_times_find_every_simple_root_of_a_known_cubic() {
        // (t - 0.2)(t - 0.5)(t - 0.9)
        let (r1, r2, r3) = (0.2, 0.5, 0.9);
        let c = [
            -r1 * r2 * r3,
            r1 * r2 + r1 * r3 + r2 * r3,
            -(r1 + r2 + r3),
            1.0,
        ];
        let mut out = [0.0; 8];
        let n = candidate_times(&c, 1e-15, &mut out);
        assert_eq!(n, 3);
        for (got, want) in out[..n].iter().zip([r1, r2, r3]) {
            assert!((got - want).abs() < 1e-14, "{got} vs {want}");
        }
        // A double root (tangency) is a turning point with f = 0.
        let c = [0.25, -1.0, 1.0, 0.0]; // (t - 0.5)^2
        let n = candidate_times(&c, 1e-15, &mut out);
        assert_eq!(&out[..n], &[0.5]);
    }

    /// A moving edge crossing another: the time from the geometry.
    #[test]
    fn edge_edge_crossing_time_and_normal_are_exact() {
        // Edge 1 along x at height z = 1 - 2t, edge 2 along y at z = 0.
        let x0 = [
            V3::new(-1.0, 0.0, 1.0),
            V3::new(1.0, 0.0, 1.0),
            V3::new(0.3, -1.0, 0.0),
            V3::new(0.3, 1.0, 0.0),
        ];
        let mut x1 = x0;
        x1[0].z = -1.0;
        x1[1].z = -1.0;
        let hit = edge_edge(&x0, &x1, 1e-9).unwrap();
        assert!((hit.t - 0.5).abs() < 1e-14);
        assert!((hit.normal - V3::z()).norm() < 1e-12);
        assert!((hit.weights[0] - 0.35).abs() < 1e-12 && (hit.weights[1] - 0.65).abs() < 1e-12);
        // Passing beside the other edge (x > 1.2): no impact.
        let shift = V3::new(1.5, 0.0, 0.0);
        let (y0, y1) = (
            [x0[0] + shift, x0[1] + shift, x0[2], x0[3]],
            [x1[0] + shift, x1[1] + shift, x1[2], x1[3]],
        );
        assert!(edge_edge(&y0, &y1, 1e-9).is_none());
    }

    /// Moving all four points by one more displacement changes no distance
    /// between them at any time, so it changes no impact: the culls use the
    /// motion relative to the pair's mean, and a pair carried fast as a
    /// whole is tested as one at rest.
    #[test]
    fn a_common_motion_changes_no_impact() {
        let mut rng = SmallRng::seed_from_u64(5);
        let mut hits = 0;
        for k in 0..4000 {
            let mut r = || V3::new(rng.random(), rng.random(), rng.random::<f64>() - 0.5);
            let x0 = [r(), r(), r(), r()];
            let mut x1 = x0;
            for p in &mut x1 {
                *p += r() * 0.6 - V3::new(0.3, 0.3, 0.0);
            }
            let carry = V3::new(3.0, -2.0, 5.0);
            let carried = x1.map(|p| p + carry);
            let test = if k % 2 == 0 { vertex_face } else { edge_edge };
            let (a, b) = (test(&x0, &x1, 1e-3), test(&x0, &carried, 1e-3));
            // The carried paths are longer: the carried copy must still be
            // tested, and the two see the same first contact.
            let (a, b) = (a.map(|h| h.t), b.map(|h| h.t));
            match (a, b) {
                (Some(ta), Some(tb)) => {
                    hits += 1;
                    assert!((ta - tb).abs() < 1e-6, "case {k}: t {ta} against {tb}");
                }
                (None, None) => {}
                _ => panic!("case {k}: {a:?} at rest, {b:?} carried"),
            }
        }
        assert!(hits > 100, "{hits} impacts sampled");
    }

    /// Random linear motions: a crossing found by dense sampling of the
    /// signed volume (a vertex passing from one side of the triangle to the
    /// other inside it) is always reported, never later than it happens.
    #[test]
    fn vertex_face_never_misses_a_sampled_crossing() {
        let mut rng = SmallRng::seed_from_u64(11);
        let mut crossings = 0;
        for _ in 0..2000 {
            let mut r = || V3::new(rng.random(), rng.random(), rng.random::<f64>() - 0.5);
            let tri0 = [r(), r(), r()];
            let tri1 = [
                tri0[0] + r() * 0.2,
                tri0[1] + r() * 0.2,
                tri0[2] + r() * 0.2,
            ];
            let p0 = (tri0[0] + tri0[1] + tri0[2]) / 3.0 + V3::new(0.0, 0.0, 0.4) + r() * 0.1;
            let p1 = (tri1[0] + tri1[1] + tri1[2]) / 3.0 - V3::new(0.0, 0.0, 0.4) + r() * 0.3;
            let x0 = [p0, tri0[0], tri0[1], tri0[2]];
            let x1 = [p1, tri1[0], tri1[1], tri1[2]];
            // Sampled first crossing of the face's interior.
            let mut first = None;
            let steps = 2000;
            let side = |t: f64| {
                let at = |k: usize| x0[k] + (x1[k] - x0[k]) * t;
                let (p, a, b, c) = (at(0), at(1), at(2), at(3));
                let nrm = (b - a).cross(&(c - a));
                ((p - a).dot(&nrm), closest_point_triangle(&p, &a, &b, &c))
            };
            let mut prev = side(0.0).0;
            for k in 1..=steps {
                let t = k as f64 / steps as f64;
                let (s, q) = side(t);
                if (s < 0.0) != (prev < 0.0) && q.bary.iter().all(|&w| w > 0.05) {
                    first = Some(t);
                    break;
                }
                prev = s;
            }
            let hit = vertex_face(&x0, &x1, 1e-9);
            if let Some(t) = first {
                crossings += 1;
                let hit = hit.expect("sampled crossing missed");
                assert!(hit.t <= t + 1e-12);
            }
        }
        assert!(crossings > 200, "{crossings} crossings sampled");
    }
}
