#![doc = include_str!("../README.md")]
//!
//! # The crate's map
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
//! - [`surface`]: a triangle's area vector and the area-weighted vertex
//!   normals of a surface given as a flat position array (shading).
//! - [`ccd`]: continuous collision detection of a vertex and a triangle or
//!   two edges moving linearly over a step (the coplanarity cubic, its roots
//!   in order, the distance at each).

mod aabb;
mod bvh;
pub mod ccd;
pub mod closest;
mod error;
mod mesh;
pub mod proximity;
pub mod surface;

pub use aabb::Aabb;
pub use bvh::{Bvh, Overlaps};
pub use closest::{
    Feature, TrianglePoint, closest_point_triangle, closest_points_segments,
    point_triangle_farther_than, segments_farther_than,
};
pub use error::GeometryError;
pub use mesh::{Closest, TriMesh};
