//! Contact geometry for deforming triangle meshes, independent of any
//! physics (the mass-spring model of `hookean-massspring` uses it for mesh
//! colliders and cloth self-collision; nothing here knows about masses,
//! forces or time integration).
//!
//! - [`Aabb`] and [`Bvh`]: a tree of axis-aligned boxes, one primitive per
//!   leaf, built once per topology and refitted in place as the primitives
//!   move; box queries, the nearest primitive by branch and bound, and all
//!   overlapping pairs of its own leaves ([`Bvh::self_overlaps`], on rayon
//!   threads, results in a fixed order for every thread count).
//! - [`closest`]: closest points of a point and a triangle (with the
//!   feature: vertex, edge or face) and of two segments.
//! - [`TriMesh`]: a validated static mesh (finite, no degenerate triangle,
//!   manifold, consistently oriented; open or closed) with the closest point,
//!   the signed distance through angle-weighted pseudo-normals, and the first
//!   crossing of a segment with the surface.
//! - [`proximity`]: vertex-face and edge-edge pairs closer than a distance
//!   (the repulsion pairs of Bridson, Fedkiw and Anderson 2002).
//! - [`ccd`]: continuous collision detection of a vertex and a triangle or
//!   two edges moving linearly over a step (the coplanarity cubic, its roots
//!   in order, the distance at each).
//!
//! # Example: a particle above a box, and a step that would cross a face
//!
//! ```
//! use hookean_geometry::TriMesh;
//! use nalgebra::Vector3;
//!
//! // The unit square at z = 0 as two triangles facing +z (an open mesh).
//! let v = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
//! let floor = TriMesh::new(v, vec![[0, 1, 2], [0, 2, 3]])?;
//! let p = Vector3::new(0.3, 0.6, 0.25);
//! let c = floor.closest(&p);
//! assert!((c.distance - 0.25).abs() < 1e-15);
//! assert!((c.normal - Vector3::z()).norm() < 1e-15);
//! // Moving to z = -0.75 crosses the floor a quarter of the way.
//! let (s, _triangle) = floor.first_hit(&p, &Vector3::new(0.3, 0.6, -0.75)).unwrap();
//! assert!((s - 0.25).abs() < 1e-15);
//! # Ok::<(), hookean_geometry::GeometryError>(())
//! ```

mod aabb;
mod bvh;
pub mod ccd;
pub mod closest;
mod error;
mod mesh;
pub mod proximity;

pub use aabb::Aabb;
pub use bvh::{Bvh, Overlaps};
pub use closest::{
    Feature, TrianglePoint, closest_point_triangle, closest_points_segments,
    point_triangle_farther_than, segments_farther_than,
};
pub use error::GeometryError;
pub use mesh::{Closest, TriMesh};
