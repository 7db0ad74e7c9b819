//! A validated static triangle mesh as a contact surface: closest feature,
//! signed distance through angle-weighted pseudo-normals (Baerentzen and
//! Aanaes 2005: the sign of `(p - q) . n` with the pseudo-normal `n` of the
//! closest feature is the inside/outside of a closed, consistently oriented
//! mesh; an open mesh has a behind only where the closest point is interior
//! to it, so a point beside its boundary is outside), and the first crossing
//! of a segment with the surface.

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
    /// to), negative inside a closed mesh or behind an open one. A point
    /// whose closest point lies on an open mesh's boundary (an edge with
    /// one triangle, or a vertex of such an edge) is beside the mesh, not
    /// behind it: its distance is positive whatever the side.
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

/// A triangle mesh checked to be a contact surface: finite vertices of at
/// most [`TriMesh::MAX_COORDINATE`] in magnitude, no degenerate triangle,
/// every edge on at most two triangles (manifold), neighbouring triangles
/// oriented alike (counter-clockwise seen from outside), and every closed
/// part (a connected set of triangles whose edges all have two) of positive
/// signed volume (its normals point out, not in). It may be open (a sheet,
/// a terrain: "inside" is then "behind", the points whose closest surface
/// point is interior to the sheet and on the side its normals turn away
/// from) or closed (a solid).
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
    /// Per triangle, bit `k` set when its edge `k` is on no other triangle
    /// (the boundary of an open mesh).
    boundary_edges: Vec<u8>,
    /// Per vertex, true when it is on a boundary edge.
    boundary_vertices: Vec<bool>,
    /// Per triangle, the triangle across its edge `k` (`usize::MAX` on the
    /// boundary): the topology [`TriMesh::set_vertices`] keeps.
    neighbours: Vec<[usize; 3]>,
    bvh: Bvh,
    closed: bool,
}

impl TriMesh {
    /// The largest magnitude of a vertex coordinate (m): the normals and
    /// distances take products of up to four coordinates (a face normal is
    /// the norm of a cross product), which stay finite, with room for the
    /// particles' positions, below this.
    pub const MAX_COORDINATE: f64 = 1e60;

    /// Checks and indexes a mesh.
    ///
    /// # Errors
    /// [`GeometryError::Empty`], [`GeometryError::NonFinite`],
    /// [`GeometryError::TooLarge`], [`GeometryError::IndexOutOfRange`],
    /// [`GeometryError::Degenerate`], [`GeometryError::NonManifoldEdge`],
    /// [`GeometryError::Orientation`], [`GeometryError::InsideOut`], naming
    /// the first offending vertex or triangle.
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
        if let Some((vertex, &value)) = vertices.iter().enumerate().find_map(|(i, v)| {
            v.iter()
                .find(|c| c.abs() > Self::MAX_COORDINATE)
                .map(|c| (i, c))
        }) {
            return Err(GeometryError::TooLarge {
                vertex,
                value,
                max: Self::MAX_COORDINATE,
            });
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
        let mut boundary_edges = vec![0u8; triangles.len()];
        let mut boundary_vertices = vec![false; n];
        let mut neighbours = vec![[usize::MAX; 3]; triangles.len()];
        // The parts: vertices joined by the edges (union-find, the smaller
        // root kept, so the result does not depend on the scan's order).
        let mut part: Vec<usize> = (0..n).collect();
        let mut closed = true;
        let mut s = 0;
        while s < edges.len() {
            let mut e = s + 1;
            while e < edges.len() && edges[e].0 == edges[s].0 && edges[e].1 == edges[s].1 {
                e += 1;
            }
            let (a, b) = (edges[s].0, edges[s].1);
            let (ra, rb) = (find(&mut part, a), find(&mut part, b));
            part[ra.max(rb)] = ra.min(rb);
            match e - s {
                1 => {
                    closed = false;
                    boundary_edges[edges[s].2] |= 1 << edges[s].3;
                    boundary_vertices[a] = true;
                    boundary_vertices[b] = true;
                }
                2 => {
                    let (t0, k0, t1, k1) = (edges[s].2, edges[s].3, edges[s + 1].2, edges[s + 1].3);
                    neighbours[t0][k0 as usize] = t1;
                    neighbours[t1][k1 as usize] = t0;
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
        check_outward(&vertices, &triangles, &mut part, &boundary_vertices)?;
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
            boundary_edges,
            boundary_vertices,
            neighbours,
            bvh,
            closed,
        })
    }

    /// Moves the vertices to `vertices` (the same count and order), keeping
    /// the topology: the face, edge and vertex pseudo-normals are computed
    /// again as [`TriMesh::new`] does and the tree is refitted (its shape
    /// kept). For a deforming collider, one pose per time. No allocation.
    ///
    /// # Errors
    /// [`GeometryError::IndexOutOfRange`] for another vertex count (naming
    /// the count as `index`), [`GeometryError::NonFinite`] /
    /// [`GeometryError::TooLarge`] for a bad vertex,
    /// [`GeometryError::Degenerate`] for a triangle collapsed by the move;
    /// the mesh is left as it was.
    pub fn set_vertices(&mut self, vertices: &[V3]) -> Result<(), GeometryError> {
        if vertices.len() != self.vertices.len() {
            return Err(GeometryError::IndexOutOfRange {
                triangle: 0,
                index: vertices.len(),
                n_vertices: self.vertices.len(),
            });
        }
        for (vertex, v) in vertices.iter().enumerate() {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(GeometryError::NonFinite { vertex });
            }
            if let Some(&value) = v.iter().find(|c| c.abs() > Self::MAX_COORDINATE) {
                return Err(GeometryError::TooLarge {
                    vertex,
                    value,
                    max: Self::MAX_COORDINATE,
                });
            }
        }
        for (triangle, t) in self.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| vertices[i]);
            if !((b - a).cross(&(c - a)).norm() > 0.0) {
                return Err(GeometryError::Degenerate { triangle });
            }
        }
        self.vertices.copy_from_slice(vertices);
        for (t, tri) in self.triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|i| self.vertices[i]);
            self.face_normals[t] = (b - a).cross(&(c - a)).normalize();
        }
        for t in 0..self.triangles.len() {
            for k in 0..3 {
                let other = self.neighbours[t][k];
                let sum = if other == usize::MAX {
                    self.face_normals[t]
                } else {
                    self.face_normals[t] + self.face_normals[other]
                };
                self.edge_normals[t][k] = sum.try_normalize(0.0).unwrap_or(self.face_normals[t]);
            }
        }
        self.vertex_normals.fill(V3::zeros());
        for (ti, t) in self.triangles.iter().enumerate() {
            for k in 0..3 {
                let p = self.vertices[t[k]];
                let u = (self.vertices[t[(k + 1) % 3]] - p).normalize();
                let w = (self.vertices[t[(k + 2) % 3]] - p).normalize();
                let angle = u.dot(&w).clamp(-1.0, 1.0).acos();
                self.vertex_normals[t[k]] += self.face_normals[ti] * angle;
            }
        }
        for nv in &mut self.vertex_normals {
            *nv = nv.try_normalize(0.0).unwrap_or_else(V3::z);
        }
        let (vs, ts) = (&self.vertices, &self.triangles);
        self.bvh.refit(|t| triangle_box(vs, &ts[t]));
        Ok(())
    }

    /// The barycentric coordinates of `p` (a point of triangle `t`, as
    /// [`Closest::point`]) in that triangle: `p = sum_k w_k v_k`.
    pub fn barycentric(&self, t: usize, p: &V3) -> [f64; 3] {
        let [a, b, c] = self.corners(t);
        let (e0, e1, d) = (b - a, c - a, p - a);
        let (d00, d01, d11) = (e0.dot(&e0), e0.dot(&e1), e1.dot(&e1));
        let (d20, d21) = (d.dot(&e0), d.dot(&e1));
        let den = d00 * d11 - d01 * d01;
        let v = (d11 * d20 - d01 * d21) / den;
        let w = (d00 * d21 - d01 * d20) / den;
        [1.0 - v - w, v, w]
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
        let (pseudo, boundary) = match q.feature {
            Feature::Face => (self.face_normals[triangle], false),
            Feature::Edge(k) => (
                self.edge_normals[triangle][k as usize],
                self.boundary_edges[triangle] & (1 << k) != 0,
            ),
            Feature::Vertex(k) => {
                let v = self.triangles[triangle][k as usize];
                (self.vertex_normals[v], self.boundary_vertices[v])
            }
        };
        let d = p - q.point;
        let len = d.norm();
        let side = d.dot(&pseudo);
        // Beside an open mesh's boundary is outside: the half-space of a
        // boundary feature's pseudo-normal reaches past the sheet's edge,
        // where nothing separates the two sides.
        let inside = side < 0.0 && !boundary;
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

/// The root of `i`'s part, halving the path on the way.
fn find(part: &mut [usize], mut i: usize) -> usize {
    while part[i] != i {
        part[i] = part[part[i]];
        i = part[i];
    }
    i
}

/// Every closed part of the mesh (a part with no boundary vertex) has a
/// positive signed volume `V = sum (a - o) . ((b - o) x (c - o)) / 6` over
/// its triangles (the divergence theorem; `o` the part's first vertex, for
/// round-off): its counter-clockwise triangles face out. An inside-out part
/// is named by its first triangle.
fn check_outward(
    vertices: &[V3],
    triangles: &[[usize; 3]],
    part: &mut [usize],
    boundary_vertices: &[bool],
) -> Result<(), GeometryError> {
    let n = vertices.len();
    let mut open = vec![false; n];
    for (v, &b) in boundary_vertices.iter().enumerate() {
        if b {
            let r = find(part, v);
            open[r] = true;
        }
    }
    let mut volume = vec![0.0; n];
    let mut first = vec![usize::MAX; n];
    for (ti, t) in triangles.iter().enumerate() {
        let r = find(part, t[0]);
        if open[r] {
            continue;
        }
        if first[r] == usize::MAX {
            first[r] = ti;
        }
        let o = vertices[r];
        let [a, b, c] = t.map(|i| vertices[i] - o);
        volume[r] += a.dot(&b.cross(&c)) / 6.0;
    }
    // In triangle order: the first inside-out part of the file.
    let mut bad: Option<(usize, f64)> = None;
    for (&f, &vol) in first.iter().zip(&volume) {
        if f != usize::MAX && !(vol > 0.0) && bad.is_none_or(|(t, _)| f < t) {
            bad = Some((f, vol));
        }
    }
    match bad {
        Some((triangle, volume)) => Err(GeometryError::InsideOut { triangle, volume }),
        None => Ok(()),
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

    /// A pose set by `set_vertices` answers as a mesh built from those
    /// vertices: the box stretched and moved, against `TriMesh::new` of the
    /// same vertices, at random points; a collapsed face is refused and
    /// leaves the mesh as it was.
    #[test]
    fn set_vertices_matches_a_mesh_built_at_the_pose() {
        let mut m = unit_box();
        let moved: Vec<V3> = m
            .vertices()
            .iter()
            .map(|v| V3::new(2.0 * v.x + 0.3, v.y - 0.1, 0.5 * v.z + v.x))
            .collect();
        let built = TriMesh::new(
            moved.iter().map(|v| [v.x, v.y, v.z]).collect(),
            m.triangles().to_vec(),
        )
        .unwrap();
        m.set_vertices(&moved).unwrap();
        let mut rng = SmallRng::seed_from_u64(7);
        for _ in 0..200 {
            let p = V3::new(
                rng.random_range(-1.0..3.0),
                rng.random_range(-1.0..2.0),
                rng.random_range(-1.0..2.0),
            );
            let (a, b) = (m.closest(&p), built.closest(&p));
            assert!((a.distance - b.distance).abs() < 1e-12, "{p:?}");
            assert!((a.normal - b.normal).norm() < 1e-9, "{p:?}");
        }
        assert!((m.aabb().extent() - built.aabb().extent()).norm() < 1e-15);
        let mut flat = moved.clone();
        for v in &mut flat {
            v.z = 0.0;
        }
        assert!(matches!(
            m.set_vertices(&flat),
            Err(GeometryError::Degenerate { .. })
        ));
        assert!(matches!(
            m.set_vertices(&moved[1..]),
            Err(GeometryError::IndexOutOfRange { .. })
        ));
        assert_eq!(m.vertices(), &moved[..]);
        // Barycentric coordinates reproduce the point.
        let c = m.closest(&V3::new(0.9, 0.4, 2.0));
        let w = m.barycentric(c.triangle, &c.point);
        let t = m.triangles()[c.triangle];
        let back: V3 = (0..3).map(|k| m.vertices()[t[k]] * w[k]).sum();
        assert!((back - c.point).norm() < 1e-12);
    }

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

    /// A point below an open mesh is behind it only where its closest
    /// point is interior; beside a boundary edge or vertex it is outside,
    /// at its Euclidean distance (the closed form of a point and a segment
    /// or a point).
    #[test]
    fn beside_an_open_mesh_is_outside_and_under_its_interior_is_behind() {
        // One triangle in z = 0 (normal +z), and a bowtie: two triangles
        // that share only the vertex (0.5, 0.5, 0).
        let tri = TriMesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        )
        .unwrap();
        assert!(!tri.is_closed());
        // Under the interior: behind, at the depth.
        let c = tri.closest(&V3::new(0.2, 0.2, -0.3));
        assert!((c.distance + 0.3).abs() < 1e-15, "{c:?}");
        // Below and past the hypotenuse x + y = 1: the distance to the
        // segment, positive.
        let p = V3::new(0.8, 0.8, -0.1);
        let want = ((0.6f64 / 2f64.sqrt()).powi(2) + 0.01).sqrt();
        let c = tri.closest(&p);
        assert!(matches!(c.feature, Feature::Edge(1)));
        assert!(
            (c.distance - want).abs() < 1e-14,
            "{} vs {want}",
            c.distance
        );
        assert!(((p - c.point) / want - c.normal).norm() < 1e-12);
        // Below and past a corner: the distance to the vertex, positive.
        let c = tri.closest(&V3::new(-0.3, -0.4, -0.1));
        assert!((c.distance - 0.26f64.sqrt()).abs() < 1e-15, "{c:?}");
        let bowtie = TriMesh::new(
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.5, 0.5, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            vec![[0, 1, 2], [2, 3, 4]],
        )
        .unwrap();
        // Just below the shared vertex, and beside the waist: outside.
        let c = bowtie.closest(&V3::new(0.5, 0.5, -0.01));
        assert!((c.distance - 0.01).abs() < 1e-15, "{c:?}");
        let c = bowtie.closest(&V3::new(0.2, 0.5, -0.05));
        assert!(c.distance > 0.0, "{c:?}");
        // Under a wing's interior: behind.
        assert!((bowtie.closest(&V3::new(0.5, 0.2, -0.05)).distance + 0.05).abs() < 1e-15);
        // A closed mesh keeps its inside at edges and corners.
        let b = unit_box();
        assert!((b.closest(&V3::new(0.01, 0.02, 0.5)).distance + 0.01).abs() < 1e-15);
    }

    #[test]
    fn an_inside_out_closed_part_and_overflowing_coordinates_are_refused() {
        let (v, t): (Vec<[f64; 3]>, Vec<[usize; 3]>) = {
            let b = unit_box();
            (
                b.vertices().iter().map(|p| [p.x, p.y, p.z]).collect(),
                b.triangles().to_vec(),
            )
        };
        let flipped: Vec<[usize; 3]> = t.iter().map(|f| [f[0], f[2], f[1]]).collect();
        // Signed volume -1 (the unit box, its faces reversed).
        match TriMesh::new(v.clone(), flipped.clone()).unwrap_err() {
            GeometryError::InsideOut { triangle, volume } => {
                assert_eq!(triangle, 0);
                assert!((volume + 1.0).abs() < 1e-14, "{volume}");
            }
            e => panic!("{e}"),
        }
        // Two boxes, the second (triangles 12..24) inside-out: it is named.
        let mut v2 = v.clone();
        v2.extend(v.iter().map(|p| [p[0] + 3.0, p[1], p[2]]));
        let mut t2 = t.clone();
        t2.extend(flipped.iter().map(|f| f.map(|i| i + 8)));
        assert!(matches!(
            TriMesh::new(v2, t2).unwrap_err(),
            GeometryError::InsideOut { triangle: 12, .. }
        ));
        // An open sheet has no volume to check, either way round.
        assert!(TriMesh::new(v.clone(), flipped[..10].to_vec()).is_ok());
        // Coordinates: up to the bound accepted, beyond it refused.
        let big = |c: f64| vec![[0.0, 0.0, 0.0], [c, 0.0, 0.0], [0.0, c, 0.0]];
        assert!(TriMesh::new(big(TriMesh::MAX_COORDINATE), vec![[0, 1, 2]]).is_ok());
        assert_eq!(
            TriMesh::new(big(1e155), vec![[0, 1, 2]]).unwrap_err(),
            GeometryError::TooLarge {
                vertex: 1,
                value: 1e155,
                max: TriMesh::MAX_COORDINATE
            }
        );
        // At the bound the normals are finite and the box's distances hold.
        let m = TriMesh::new(big(TriMesh::MAX_COORDINATE), vec![[0, 1, 2]]).unwrap();
        assert!((m.face_normal(0).z - 1.0).abs() < 1e-15);
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
