//! An independent triangle-triangle intersection test for checking
//! self-collision: written from orientation predicates (signed volumes), not
//! from `hookean-geometry`'s closest points or continuous detection, so that
//! a bug there cannot hide itself here.

type P = [f64; 3];

fn sub(a: &P, b: &P) -> P {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Six times the signed volume of the tetrahedron `(a, b, c, d)`: positive
/// when `d` is on the side of `(a, b, c)` its counter-clockwise normal
/// points to.
pub fn orient3d(a: &P, b: &P, c: &P, d: &P) -> f64 {
    let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0])
}

/// True when the segment `pq` passes through the interior of triangle `t`
/// (strictly: its end points on opposite sides of the triangle's plane, and
/// the line through it on the same side of all three edges).
fn segment_crosses(p: &P, q: &P, t: &[P; 3]) -> bool {
    let (sp, sq) = (
        orient3d(&t[0], &t[1], &t[2], p),
        orient3d(&t[0], &t[1], &t[2], q),
    );
    if !((sp > 0.0 && sq < 0.0) || (sp < 0.0 && sq > 0.0)) {
        return false;
    }
    let e = [
        orient3d(p, q, &t[0], &t[1]),
        orient3d(p, q, &t[1], &t[2]),
        orient3d(p, q, &t[2], &t[0]),
    ];
    (e[0] > 0.0 && e[1] > 0.0 && e[2] > 0.0) || (e[0] < 0.0 && e[1] < 0.0 && e[2] < 0.0)
}

/// 2D: do the segments `ab` and `cd` cross at interior points?
fn cross2(a: &[f64; 2], b: &[f64; 2], c: &[f64; 2], d: &[f64; 2]) -> bool {
    let o = |p: &[f64; 2], q: &[f64; 2], r: &[f64; 2]| {
        (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    };
    let (d1, d2, d3, d4) = (o(c, d, a), o(c, d, b), o(a, b, c), o(a, b, d));
    d1 * d2 < 0.0 && d3 * d4 < 0.0
}

/// 2D: is `p` strictly inside triangle `t`?
fn inside2(p: &[f64; 2], t: &[[f64; 2]; 3]) -> bool {
    let o =
        |a: &[f64; 2], b: &[f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    let s = [o(&t[0], &t[1]), o(&t[1], &t[2]), o(&t[2], &t[0])];
    (s[0] > 0.0 && s[1] > 0.0 && s[2] > 0.0) || (s[0] < 0.0 && s[1] < 0.0 && s[2] < 0.0)
}

/// True when triangles `a` and `b` share interior points: an edge of one
/// passes through the other, or, for triangles in one plane, their
/// projections overlap. Touching along boundaries does not count.
pub fn triangles_intersect(a: &[P; 3], b: &[P; 3]) -> bool {
    for k in 0..3 {
        if segment_crosses(&a[k], &a[(k + 1) % 3], b) || segment_crosses(&b[k], &b[(k + 1) % 3], a)
        {
            return true;
        }
    }
    // Coplanar triangles: every vertex of one in the other's plane.
    let coplanar = (0..3).all(|k| orient3d(&a[0], &a[1], &a[2], &b[k]) == 0.0);
    if !coplanar {
        return false;
    }
    let n = {
        let (u, v) = (sub(&a[1], &a[0]), sub(&a[2], &a[0]));
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let drop = (0..3)
        .max_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
        .unwrap_or(2);
    let proj = |p: &P| {
        let mut q = [0.0; 2];
        let mut k = 0;
        for c in 0..3 {
            if c != drop {
                q[k] = p[c];
                k += 1;
            }
        }
        q
    };
    let (pa, pb) = (a.map(|p| proj(&p)), b.map(|p| proj(&p)));
    for i in 0..3 {
        for j in 0..3 {
            if cross2(&pa[i], &pa[(i + 1) % 3], &pb[j], &pb[(j + 1) % 3]) {
                return true;
            }
        }
    }
    pa.iter().any(|p| inside2(p, &pb)) || pb.iter().any(|p| inside2(p, &pa))
}

/// Every pair `(i, j)`, `i < j`, of triangles of `faces` on the positions
/// `x` (3 per vertex) that share no vertex and intersect. Brute force over
/// the pairs whose boxes overlap (sweep along x).
pub fn self_intersections(x: &[f64], faces: &[[usize; 3]]) -> Vec<(usize, usize)> {
    let tri = |f: &[usize; 3]| f.map(|i| [x[3 * i], x[3 * i + 1], x[3 * i + 2]]);
    let boxes: Vec<(P, P)> = faces
        .iter()
        .map(|f| {
            let t = tri(f);
            let mut lo = t[0];
            let mut hi = t[0];
            for p in &t[1..] {
                for c in 0..3 {
                    lo[c] = lo[c].min(p[c]);
                    hi[c] = hi[c].max(p[c]);
                }
            }
            (lo, hi)
        })
        .collect();
    let mut order: Vec<usize> = (0..faces.len()).collect();
    order.sort_by(|&i, &j| boxes[i].0[0].total_cmp(&boxes[j].0[0]));
    let mut out = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if boxes[j].0[0] > boxes[i].1[0] {
                break;
            }
            let overlap =
                (1..3).all(|c| boxes[i].0[c] <= boxes[j].1[c] && boxes[j].0[c] <= boxes[i].1[c]);
            if !overlap || faces[i].iter().any(|v| faces[j].contains(v)) {
                continue;
            }
            if triangles_intersect(&tri(&faces[i]), &tri(&faces[j])) {
                out.push((i.min(j), i.max(j)));
            }
        }
    }
    out.sort_unstable();
    out
}

/// True when `p` lies strictly inside the closed triangle mesh
/// (`vertices`, `triangles`), by the parity of the crossings of a ray from
/// `p` in a fixed direction of irrational slopes (so that it passes through
/// no edge or vertex of a mesh with rational coordinates) with the
/// triangles: a test independent of signed distances and pseudo-normals.
pub fn inside_closed_mesh(p: &P, vertices: &[P], triangles: &[[usize; 3]]) -> bool {
    let d = [
        0.301_511_344_577_763_6,
        0.527_644_853_011_086_3,
        0.794_200_883_813_283_7,
    ];
    let far = [p[0] + 1e6 * d[0], p[1] + 1e6 * d[1], p[2] + 1e6 * d[2]];
    let mut crossings = 0;
    for t in triangles {
        let tri = t.map(|i| vertices[i]);
        if segment_crosses(p, &far, &tri) {
            crossings += 1;
        }
    }
    crossings % 2 == 1
}

/// The closed box `[lo, hi]` as 8 vertices and 12 triangles,
/// counter-clockwise seen from outside.
pub fn box_triangles(lo: P, hi: P) -> (Vec<P>, Vec<[usize; 3]>) {
    let v = (0..8)
        .map(|i| [0, 1, 2].map(|c| if (i >> c) & 1 == 0 { lo[c] } else { hi[c] }))
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let t = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    (v, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_touching_and_separate_triangles() {
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        // A triangle piercing a's interior.
        let b = [[0.2, 0.2, -0.5], [0.3, 0.2, 0.5], [0.2, 0.3, 0.5]];
        assert!(triangles_intersect(&a, &b));
        assert!(triangles_intersect(&b, &a));
        // Lifted above a: no intersection.
        let c = b.map(|p| [p[0], p[1], p[2] + 0.6]);
        assert!(!triangles_intersect(&a, &c));
        // Edge-edge: a's edge (0,0,0)-(1,0,0) through a vertical triangle.
        let d = [[0.5, -0.5, -0.5], [0.5, 0.5, -0.5], [0.5, 0.0, 0.5]];
        assert!(triangles_intersect(&a, &d));
        // Coplanar and overlapping; coplanar and disjoint.
        let e = [[0.1, 0.1, 0.0], [0.6, 0.1, 0.0], [0.1, 0.6, 0.0]];
        assert!(triangles_intersect(&a, &e));
        let f = [[2.0, 2.0, 0.0], [3.0, 2.0, 0.0], [2.0, 3.0, 0.0]];
        assert!(!triangles_intersect(&a, &f));
        // Sharing an edge and folded: boundary contact only.
        let g = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.3]];
        assert!(!triangles_intersect(&a, &g));
    }

    #[test]
    fn ray_parity_finds_the_inside_of_a_box() {
        let (v, t) = box_triangles([0.0; 3], [1.0; 3]);
        assert!(inside_closed_mesh(&[0.5, 0.5, 0.5], &v, &t));
        assert!(inside_closed_mesh(&[0.01, 0.99, 0.02], &v, &t));
        assert!(!inside_closed_mesh(&[1.5, 0.5, 0.5], &v, &t));
        assert!(!inside_closed_mesh(&[0.5, 0.5, 1.001], &v, &t));
    }
}
