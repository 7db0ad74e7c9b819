//! Normals of a triangulated surface given as a flat position array (a
//! cloth's particles): each triangle's area vector, and the area-weighted
//! vertex normals that shading interpolates.
//!
//! ```
//! use hookean_geometry::surface::vertex_normals;
//! // Two triangles folded 90 degrees along the edge 0-1, one facing +z,
//! // the other -y: the edge's vertices get the mean of the two unit
//! // normals (equal areas), (0, -1, 1) / sqrt 2.
//! let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0];
//! let mut n = [0.0; 12];
//! vertex_normals(&x, &[[0, 1, 2], [1, 0, 3]], &mut n);
//! let s = 0.5f64.sqrt();
//! assert!(n[0].abs() < 1e-15 && (n[1] + s).abs() < 1e-15 && (n[2] - s).abs() < 1e-15);
//! assert_eq!(&n[6..9], &[0.0, 0.0, 1.0]);
//! ```

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// The area vector `(b - a) x (c - a) / 2` of the triangle `(a, b, c)`:
/// its length is the triangle's area, its direction the unit normal of the
/// counter-clockwise side.
pub fn area_vector(a: &V3, b: &V3, c: &V3) -> V3 {
    (b - a).cross(&(c - a)) * 0.5
}

/// Area-weighted vertex normals: `n_i = sum_t A_t n_t / |sum_t A_t n_t|`
/// over the triangles `t` at vertex `i` (`A_t n_t` the [`area_vector`]), so
/// a large triangle counts in proportion to its area. `x` holds `3 n`
/// coordinates and `normals` receives `3 n`; a vertex of no triangle (or
/// whose area vectors cancel) gets the zero vector. Triangles with an index
/// past `x` are skipped. No allocation.
///
/// # Panics
/// If `normals` is shorter than `x`.
pub fn vertex_normals(x: &[f64], triangles: &[[usize; 3]], normals: &mut [f64]) {
    assert!(
        normals.len() >= x.len(),
        "normals: {} < {}",
        normals.len(),
        x.len()
    );
    let n = x.len() / 3;
    let p = |i: usize| V3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
    normals[..3 * n].fill(0.0);
    for t in triangles.iter().filter(|t| t.iter().all(|&i| i < n)) {
        let s = area_vector(&p(t[0]), &p(t[1]), &p(t[2]));
        for &i in t {
            for c in 0..3 {
                normals[3 * i + c] += s[c];
            }
        }
    }
    for v in normals[..3 * n].chunks_exact_mut(3) {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l > 0.0 && l.is_finite() {
            v.iter_mut().for_each(|c| *c /= l);
        } else {
            v.fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_area_vector_of_a_right_triangle_is_half_its_legs() {
        let s = area_vector(
            &V3::zeros(),
            &V3::new(2.0, 0.0, 0.0),
            &V3::new(0.0, 3.0, 0.0),
        );
        assert_eq!(s, V3::new(0.0, 0.0, 3.0));
    }

    /// A fan of two triangles at vertex 0, one of area 1 facing +z and one
    /// of area 3 facing +x: the normal at 0 is (3, 0, 1) / sqrt(10).
    #[test]
    fn vertex_normals_weigh_triangles_by_area() {
        #[rustfmt::skip]
        let x = [
            0.0, 0.0, 0.0,   1.0, 0.0, 0.0,   0.0, 2.0, 0.0, // z-facing, area 1
            0.0, 3.0, 0.0,   0.0, 0.0, 2.0,                  // x-facing, area 3
        ];
        let mut n = [0.0; 15];
        vertex_normals(&x, &[[0, 1, 2], [0, 3, 4]], &mut n);
        let r = 10f64.sqrt();
        for (got, want) in n[0..3].iter().zip([3.0 / r, 0.0, 1.0 / r]) {
            assert!((got - want).abs() < 1e-15, "{n:?}");
        }
        assert_eq!(&n[3..6], &[0.0, 0.0, 1.0]);
        assert_eq!(&n[9..12], &[1.0, 0.0, 0.0]);
    }

    #[test]
    fn a_vertex_of_no_triangle_has_no_normal() {
        let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 5.0, 5.0, 5.0];
        let mut n = [9.0; 12];
        vertex_normals(&x, &[[0, 1, 2], [0, 1, 7]], &mut n);
        assert_eq!(&n[9..12], &[0.0, 0.0, 0.0]);
        assert_eq!(&n[0..3], &[0.0, 0.0, 1.0]);
    }
}
