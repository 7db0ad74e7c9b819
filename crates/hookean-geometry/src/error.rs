//! The one error type of `hookean-geometry`.

use thiserror::Error;

/// A triangle mesh that cannot serve as a contact surface. Triangles and
/// vertices are 0-based indices into the lists given to
/// [`TriMesh::new`](crate::TriMesh::new), so that a reader can map them
/// back to lines of the file they came from.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum GeometryError {
    /// No vertices or no triangles.
    #[error("the mesh has no {what}")]
    Empty {
        /// `"vertices"` or `"triangles"`.
        what: &'static str,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate")]
    NonFinite {
        /// The vertex.
        vertex: usize,
    },
    /// A vertex coordinate beyond [`TriMesh::MAX_COORDINATE`](crate::TriMesh::MAX_COORDINATE)
    /// in magnitude (the normals' products would overflow).
    #[error("vertex {vertex} has the coordinate {value:e}, beyond the largest magnitude {max:e}")]
    TooLarge {
        /// The vertex.
        vertex: usize,
        /// The coordinate.
        value: f64,
        /// The bound.
        max: f64,
    },
    /// A triangle names a vertex that does not exist.
    #[error("triangle {triangle} names vertex {index}, but the mesh has {n_vertices} vertices")]
    IndexOutOfRange {
        /// The triangle.
        triangle: usize,
        /// The offending index.
        index: usize,
        /// Number of vertices.
        n_vertices: usize,
    },
    /// A triangle repeats a vertex or has zero area.
    #[error("triangle {triangle} is degenerate (a repeated vertex or zero area)")]
    Degenerate {
        /// The triangle.
        triangle: usize,
    },
    /// An edge is shared by more than two triangles.
    #[error(
        "edge {a}-{b} of triangle {triangle} is shared by {count} triangles (non-manifold: at most 2)"
    )]
    NonManifoldEdge {
        /// A triangle beyond the second one on the edge.
        triangle: usize,
        /// First vertex of the edge.
        a: usize,
        /// Second vertex.
        b: usize,
        /// Number of triangles on the edge.
        count: usize,
    },
    /// Two triangles on an edge run through it in the same direction: their
    /// normals disagree about which side is outside.
    #[error(
        "triangle {triangle} runs through edge {a}-{b} in the same direction as its neighbour (inconsistent orientation)"
    )]
    Orientation {
        /// The second triangle on the edge.
        triangle: usize,
        /// First vertex of the edge.
        a: usize,
        /// Second vertex.
        b: usize,
    },
    /// A closed part of the mesh is wound inside-out: its signed volume is
    /// not positive (its triangles are clockwise seen from outside).
    #[error(
        "the closed part of the mesh that holds triangle {triangle} is inside-out (signed volume {volume:.3e}: its faces must be counter-clockwise seen from outside)"
    )]
    InsideOut {
        /// The part's first triangle.
        triangle: usize,
        /// Its signed volume.
        volume: f64,
    },
}
