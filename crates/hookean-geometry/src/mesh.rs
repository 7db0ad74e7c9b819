//! A validated static triangle mesh as a contact surface: closest feature,
//! signed distance through angle-weighted pseudo-normals (Baerentzen and
//! Aanaes 2005: the sign of `(p - q) . n` with the pseudo-normal `n` of the
//! closest feature is the inside/outside of a closed, consistently oriented
//! mesh), and the first crossing of a segment with the surface.

use nalgebra::Vector3;

use crate::aabb::Aabb;
use crate::bvh::Bvh;
use crate::closest::{Feature, TrianglePoint, closest_point_triangle};
use crate::error::GeometryError;

type V3 = Vector3<f64>;

/// The closest point of a mesh to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    /// The closest surface point.
    pub point: V3,
    /// Signed distance: positive outside (on the side the normals point
    /// to), negative inside or behind.
    pub distance: f64,
    /// The unit outward normal of the contact: from the surface point
    /// towards the query point when it is outside, away from it inside; the
    /// closest feature's pseudo-normal when the point is on the surface.
    pub normal: V3,
    /// The triangle of the closest point.
    pub triangle: usize,
    /// The feature of that triangle.
    pub feature: Feature,
}

/// A triangle mesh checked to be a contact surface: finite vertices, no
/// degenerate triangle, every edge on at most two triangles (manifold), and
/// neighbouring triangles oriented alike (counter-clockwise seen from
/// outside). It may be open (a sheet, a terrain: "inside" is then "behind")
/// or closed (a solid).
///
/// ```
/// use hookean_geometry::TriMesh;
/// use nalgebra::Vector3;
///
/// // A unit tetrahedron, outward counter-clockwise faces.
/// let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
/// let t = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
/// let mesh = TriMesh::new(v, t)?;
/// assert!(mesh.is_closed());
/// let out = mesh.closest(&Vector3::new(0.2, 0.2, -0.5));
/// assert!((out.distance - 0.5).abs() < 1e-15);
/// let inside = mesh.closest(&Vector3::new(0.1, 0.1, 0.1));
/// assert!(inside.distance < 0.0);
/// # Ok::<(), hookean_geometry::GeometryError>(())
/// ```
#[derive(Debug, Clone)]
pub struct TriMesh {
    vertices: Vec<V3>,
    triangles: Vec<[usize; 3]>,
    face_normals: Vec<V3>,
    vertex_normals: Vec<V3>,
    /// Per triangle, the pseudo-normal of its edge `k` (vertex `k` to `k + 1`).
    edge_normals: Vec<[V3; 3]>,
    bvh: Bvh,
    closed: bool,
}

impl TriMesh {
    /// Checks and indexes a mesh.
    ///
    /// # Errors
    /// [`GeometryError::Empty`], [`GeometryError::NonFinite`],
    /// [`GeometryError::IndexOutOfRange`], [`GeometryError::Degenerate`],
    /// [`GeometryError::NonManifoldEdge`], [`GeometryError::Orientation`],
    /// naming the first offending vertex or triangle.
    pub fn new(vertices: Vec<[f64; 3]>, triangles: Vec<[usize; 3]>) -> Result<Self, GeometryError> {
        if vertices.is_empty() {
            return Err(GeometryError::Empty { what: "vertices" });
        }
        if triangles.is_empty() {
            return Err(GeometryError::Empty { what: "triangles" });
        }
        if let Some(vertex) = vertices
            .iter()
            .position(|v| v.iter().any(|c| !c.is_finite()))
        {
            return Err(GeometryError::NonFinite { vertex });
        }
        let vertices: Vec<V3> = vertices.into_iter().map(V3::from).collect();
        let n = vertices.len();
        let mut face_normals = Vec::with_capacity(triangles.len());
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i >= n) {
                return Err(GeometryError::IndexOutOfRange {
                    triangle,
                    index,
                    n_vertices: n,
                });
            }
            let [a, b, c] = t.map(|i| vertices[i]);
            let cross = (b - a).cross(&(c - a));
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || !(cross.norm() > 0.0) {
                return Err(GeometryError::Degenerate { triangle });
            }
            face_normals.push(cross.normalize());
        }
        // Edges: (min, max, triangle, k, forward), sorted: manifold and
        // orientation checks in one scan, in a fixed order.
        let mut edges: Vec<(usize, usize, usize, u8, bool)> =
            Vec::with_capacity(3 * triangles.len());
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                edges.push((a.min(b), a.max(b), ti, k as u8, a < b));
            }
        }
        edges.sort_unstable();
        let mut edge_normals = vec![[V3::zeros(); 3]; triangles.len()];
        let mut closed = true;
        let mut s = 0;
        while s < edges.len() {
            let mut e = s + 1;
            while e < edges.len() && edges[e].0 == edges[s].0 && edges[e].1 == edges[s].1 {
                e += 1;
            }
            let (a, b) = (edges[s].0, edges[s].1);
            match e - s {
                1 => closed = false,
                2 => {
                    if edges[s].4 == edges[s + 1].4 {
                        return Err(GeometryError::Orientation {
                            triangle: edges[s + 1].2,
                            a,
                            b,
                        });
                    }
                }
                count => {
                    return Err(GeometryError::NonManifoldEdge {
                        triangle: edges[s + 2].2,
                        a,
                        b,
                        count,
                    });
                }
            }
            let sum: V3 = edges[s..e].iter().map(|x| face_normals[x.2]).sum();
            let normal = sum.try_normalize(0.0).unwrap_or(face_normals[edges[s].2]);
            for x in &edges[s..e] {
                edge_normals[x.2][x.3 as usize] = normal;
            }
            s = e;
        }
        // Angle-weighted vertex pseudo-normals.
        let mut vertex_normals = vec![V3::zeros(); n];
        for (ti, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let p = vertices[t[k]];
                let u = (vertices[t[(k + 1) % 3]] - p).normalize();
                let w = (vertices[t[(k + 2) % 3]] - p).normalize();
                let angle = u.dot(&w).clamp(-1.0, 1.0).acos();
                vertex_normals[t[k]] += face_normals[ti] * angle;
            }
        }
        for nv in &mut vertex_normals {
            *nv = nv.try_normalize(0.0).unwrap_or_else(V3::z);
        }
        let boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| triangle_box(&vertices, t))
            .collect();
        let bvh = Bvh::build(&boxes);
        Ok(Self {
            vertices,
            triangles,
            face_normals,
            vertex_normals,
            edge_normals,
            bvh,
            closed,
        })
    }

    /// The vertices.
    pub fn vertices(&self) -> &[V3] {
        &self.vertices
    }

    /// The triangles (vertex indices, counter-clockwise from outside).
    pub fn triangles(&self) -> &[[usize; 3]] {
        &self.triangles
    }

    /// True when every edge has two triangles (the mesh bounds a solid).
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// The bounding box.
    pub fn aabb(&self) -> Aabb {
        self.bvh.root_aabb()
    }

    /// The unit normal of triangle `t`.
    pub fn face_normal(&self, t: usize) -> V3 {
        self.face_normals[t]
    }

    fn corners(&self, t: usize) -> [V3; 3] {
        self.triangles[t].map(|i| self.vertices[i])
    }

    /// The closest surface point to `p`, its signed distance and the
    /// contact normal (branch and bound over the tree; no allocation). A
    /// point with a NaN or infinite coordinate, or so far away that its
    /// squared distance overflows (beyond about 1e154 m), has no closest
    /// point: every field is NaN (triangle 0), and the distance tests of
    /// callers fail.
    pub fn closest(&self, p: &V3) -> Closest {
        // The nearest triangle's point, kept as the search finds it: the
        // search takes a triangle exactly when its squared distance is
        // below the best so far (from infinity), so the same rule here
        // keeps the winner's point.
        let mut best: (f64, Option<TrianglePoint>) = (f64::INFINITY, None);
        let nearest = self.bvh.nearest(p, |t| {
            let [a, b, c] = self.corners(t);
            let q = closest_point_triangle(p, &a, &b, &c);
            let d2 = (p - q.point).norm_squared();
            if d2 < best.0 {
                best = (d2, Some(q));
            }
            d2
        });
        // A validated mesh has triangles, so only a `p` whose every squared
        // distance is NaN or infinite finds none.
        let (Some((triangle, _)), Some(q)) = (nearest, best.1) else {
            let nan = V3::repeat(f64::NAN);
            return Closest {
                point: nan,
                distance: f64::NAN,
                normal: nan,
                triangle: 0,
                feature: Feature::Face,
            };
        };
        let pseudo = match q.feature {
            Feature::Face => self.face_normals[triangle],
            Feature::Edge(k) => self.edge_normals[triangle][k as usize],
            Feature::Vertex(k) => self.vertex_normals[self.triangles[triangle][k as usize]],
        };
        let d = p - q.point;
        let len = d.norm();
        let side = d.dot(&pseudo);
        let inside = side < 0.0;
        let normal = if len > 1e-12 * (1.0 + p.amax()) {
            if inside { -d / len } else { d / len }
        } else {
            pseudo
        };
        Closest {
            point: q.point,
            distance: if inside { -len } else { len },
            normal,
            triangle,
            feature: q.feature,
        }
    }

    /// The first point where the segment from `a` to `b` meets the surface:
    /// its parameter `s` in `[0, 1]` (the point is `a + s (b - a)`) and the
    /// triangle; `None` if it meets none. Edges and vertices count as part
    /// of their triangles.
    pub fn first_hit(&self, a: &V3, b: &V3) -> Option<(f64, usize)> {
        let mut query = Aabb::point(a);
        query.add_point(b);
        let d = b - a;
        let mut best: Option<(f64, usize)> = None;
        self.bvh.for_each_overlap(&query, |t| {
            let [p, q, r] = self.corners(t);
            if let Some(s) = segment_triangle(a, &d, &p, &q, &r)
                && best.is_none_or(|(bs, bt)| s < bs || (s == bs && t < bt))
            {
                best = Some((s, t));
            }
        });
        best
    }
}

/// The box of triangle `t` of `vertices`.
pub(crate) fn triangle_box(vertices: &[V3], t: &[usize; 3]) -> Aabb {
    let mut b = Aabb::point(&vertices[t[0]]);
    b.add_point(&vertices[t[1]]);
    b.add_point(&vertices[t[2]]);
    b
}

/// Parameter `s` in `[0, 1]` where `a + s d` meets triangle `(p, q, r)`
/// (Moeller and Trumbore's solve of `a + s d = p + u (q - p) + v (r - p)`
/// by Cramer's rule), or `None`. Boundaries count, with a relative slack
/// of `1e-12`; a segment in the triangle's plane does not meet it.
fn segment_triangle(a: &V3, d: &V3, p: &V3, q: &V3, r: &V3) -> Option<f64> {
    const SLACK: f64 = 1e-12;
    let e1 = q - p;
    let e2 = r - p;
    let h = d.cross(&e2);
    let det = e1.dot(&h);
    if det.abs() <= f64::EPSILON * e1.norm() * e2.norm() * d.norm() {
        return None;
    }
    let inv = 1.0 / det;
    let s0 = a - p;
    let u = s0.dot(&h) * inv;
    if !(-SLACK..=1.0 + SLACK).contains(&u) {
        return None;
    }
    let qv = s0.cross(&e1);
    let v = d.dot(&qv) * inv;
    if v < -SLACK || u + v > 1.0 + SLACK {
        return None;
    }
    let s = e2.dot(&qv) * inv;
    (-SLACK..=1.0 + SLACK)
        .contains(&s)
        .then_some(s.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// The closed box [0, 1]^3 as 12 outward triangles.
    pub(crate) fn unit_box() -> TriMesh {
        let v: Vec<[f64; 3]> = (0..8)
            .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
            .collect();
        let quads = [
            [0, 2, 3, 1], // z = 0, normal -z
            [4, 5, 7, 6], // z = 1
            [0, 1, 5, 4], // y = 0
            [2, 6, 7, 3], // y = 1
            [0, 4, 6, 2], // x = 0
            [1, 3, 7, 5], // x = 1
        ];
        let mut t = Vec::new();
        for q in quads {
            t.push([q[0], q[1], q[2]]);
            t.push([q[0], q[2], q[3]]);
        }
        TriMesh::new(v, t).unwrap()
    }

    /// Signed distance to the box against its closed form, including the
    /// points closest to edges and corners, where the sign needs the
    /// pseudo-normals.
    #[test]
    fn a_point_with_a_nan_or_infinite_coordinate_has_no_closest_point() {
        let mesh = unit_box();
        for p in [
            V3::new(f64::NAN, 0.5, 0.5),
            V3::new(0.5, f64::INFINITY, 0.5),
            V3::new(f64::NEG_INFINITY, 0.0, 0.0),
        ] {
            let c = mesh.closest(&p);
            assert!(
                c.distance.is_nan() && c.point.x.is_nan() && c.normal.z.is_nan(),
                "{p:?}"
            );
        }
        // A finite point far away still finds its closest point; one whose
        // squared distance overflows does not.
        let c = mesh.closest(&V3::new(0.5, 0.5, 1e6));
        assert_eq!(c.point, V3::new(0.5, 0.5, 1.0));
        assert!(mesh.closest(&V3::new(0.5, 0.5, 1e300)).distance.is_nan());
    }

    #[test]
    fn signed_distance_to_a_box_matches_its_closed_form() {
        let mesh = unit_box();
        assert!(mesh.is_closed());
        let mut rng = SmallRng::seed_from_u64(1);
        for _ in 0..5000 {
            let p = V3::new(
                rng.random::<f64>() * 3.0 - 1.0,
                rng.random::<f64>() * 3.0 - 1.0,
                rng.random::<f64>() * 3.0 - 1.0,
            );
            let outside = V3::new(
                (p.x - 1.0).max(-p.x).max(0.0),
                (p.y - 1.0).max(-p.y).max(0.0),
                (p.z - 1.0).max(-p.z).max(0.0),
            );
            let want = if outside.norm() > 0.0 {
                outside.norm()
            } else {
                -[p.x, 1.0 - p.x, p.y, 1.0 - p.y, p.z, 1.0 - p.z]
                    .into_iter()
                    .fold(f64::INFINITY, f64::min)
            };
            let got = mesh.closest(&p);
            assert!(
                (got.distance - want).abs() < 1e-12,
                "{p:?}: {} vs {want}",
                got.distance
            );
            // The normal points from the surface point to p outside.
            if want > 1e-9 {
                assert!(((p - got.point) / want - got.normal).norm() < 1e-9);
            }
        }
    }

    #[test]
    fn segments_hit_the_first_face_they_cross() {
        let mesh = unit_box();
        let (a, b) = (V3::new(0.5, 0.5, 2.0), V3::new(0.5, 0.5, -1.0));
        let (s, t) = mesh.first_hit(&a, &b).unwrap();
        assert!((s - 1.0 / 3.0).abs() < 1e-14);
        assert!(mesh.face_normal(t).z > 0.99);
        assert!(
            mesh.first_hit(&V3::new(2.0, 0.5, 0.5), &V3::new(2.0, 0.5, -1.0))
                .is_none()
        );
        // Through an edge of the box (two triangles share it): still a hit.
        let (s, _) = mesh
            .first_hit(&V3::new(0.5, -1.0, -1.0), &V3::new(0.5, 1.0, 1.0))
            .unwrap();
        assert!((s - 0.5).abs() < 1e-12);
    }

    #[test]
    fn bad_meshes_are_refused_with_the_triangle_named() {
        let sq = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
        ];
        assert_eq!(
            TriMesh::new(sq.clone(), vec![]).unwrap_err(),
            GeometryError::Empty { what: "triangles" }
        );
        let mut nan = sq.clone();
        nan[2][1] = f64::NAN;
        assert_eq!(
            TriMesh::new(nan, vec![[0, 1, 2]]).unwrap_err(),
            GeometryError::NonFinite { vertex: 2 }
        );
        assert_eq!(
            TriMesh::new(sq.clone(), vec![[0, 1, 1]]).unwrap_err(),
            GeometryError::Degenerate { triangle: 0 }
        );
        // Three triangles on edge 0-1 (a fin).
        let mut fin = sq.clone();
        fin.push([0.5, 0.0, 1.0]);
        assert!(matches!(
            TriMesh::new(fin, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]).unwrap_err(),
            GeometryError::NonManifoldEdge {
                triangle: 2,
                a: 0,
                b: 1,
                count: 3
            }
        ));
        // Two neighbours both running 1 -> 2.
        assert_eq!(
            TriMesh::new(sq.clone(), vec![[0, 1, 2], [1, 2, 3]]).unwrap_err(),
            GeometryError::Orientation {
                triangle: 1,
                a: 1,
                b: 2
            }
        );
        assert_eq!(
            TriMesh::new(sq, vec![[0, 1, 9]]).unwrap_err(),
            GeometryError::IndexOutOfRange {
                triangle: 0,
                index: 9,
                n_vertices: 4
            }
        );
    }
}
