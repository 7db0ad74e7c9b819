//! 3x3 blocks: the unit of storage of [`SymBlockMatrix`](crate::SymBlockMatrix).
//!
//! A block is a plain row-major `[[f64; 3]; 3]`, so no linear-algebra crate
//! leaks into the interface; `nalgebra::Matrix3::into()` converts to it.

/// A 3x3 block, row-major: `m[row][col]`.
pub type Block3 = [[f64; 3]; 3];

/// The zero block.
pub const ZERO: Block3 = [[0.0; 3]; 3];

/// The identity block.
pub const IDENTITY: Block3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// `m * x`.
#[inline(always)]
pub fn mul_vec(m: &Block3, x: &[f64; 3]) -> [f64; 3] {
    [
        m[0][0] * x[0] + m[0][1] * x[1] + m[0][2] * x[2],
        m[1][0] * x[0] + m[1][1] * x[1] + m[1][2] * x[2],
        m[2][0] * x[0] + m[2][1] * x[1] + m[2][2] * x[2],
    ]
}

/// `m^T * x`.
#[inline(always)]
pub fn mul_transpose_vec(m: &Block3, x: &[f64; 3]) -> [f64; 3] {
    [
        m[0][0] * x[0] + m[1][0] * x[1] + m[2][0] * x[2],
        m[0][1] * x[0] + m[1][1] * x[1] + m[2][1] * x[2],
        m[0][2] * x[0] + m[1][2] * x[1] + m[2][2] * x[2],
    ]
}

/// `m^T`.
#[inline]
pub fn transpose(m: &Block3) -> Block3 {
    [
        [m[0][0], m[1][0], m[2][0]],
        [m[0][1], m[1][1], m[2][1]],
        [m[0][2], m[1][2], m[2][2]],
    ]
}

/// `s * m`.
#[inline]
pub fn scale(m: &Block3, s: f64) -> Block3 {
    let mut out = *m;
    for row in &mut out {
        for v in row {
            *v *= s;
        }
    }
    out
}

/// `a + b`.
#[inline]
pub fn add(a: &Block3, b: &Block3) -> Block3 {
    let mut out = *a;
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] += b[r][c];
        }
    }
    out
}

/// The product `a b` (each entry summed left to right over `k`; inlined
/// into the assembly sweeps, which form `P_i B P_j` per spring).
#[inline(always)]
pub fn mul(a: &Block3, b: &Block3) -> Block3 {
    let mut c = [[0.0; 3]; 3];
    for (r, row) in c.iter_mut().enumerate() {
        for (q, v) in row.iter_mut().enumerate() {
            *v = a[r][0] * b[0][q] + a[r][1] * b[1][q] + a[r][2] * b[2][q];
        }
    }
    c
}

/// The outer product `u v^T`.
#[inline]
pub fn outer(u: &[f64; 3], v: &[f64; 3]) -> Block3 {
    [
        [u[0] * v[0], u[0] * v[1], u[0] * v[2]],
        [u[1] * v[0], u[1] * v[1], u[1] * v[2]],
        [u[2] * v[0], u[2] * v[1], u[2] * v[2]],
    ]
}

/// The determinant.
#[inline]
pub fn determinant(m: &Block3) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The inverse by the adjugate, or `None` when the block is singular relative
/// to its size: `|det| <= 1e-14 * max|m_ij|^3` (or not finite).
pub fn inverse(m: &Block3) -> Option<Block3> {
    let det = determinant(m);
    let scale = m.iter().flatten().fold(0.0_f64, |a, v| a.max(v.abs()));
    if !det.is_finite() || det.abs() <= 1e-14 * scale * scale * scale || scale == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    Some([
        [
            (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * inv_det,
            (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * inv_det,
            (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv_det,
        ],
        [
            (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * inv_det,
            (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * inv_det,
            (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv_det,
        ],
        [
            (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * inv_det,
            (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * inv_det,
            (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv_det,
        ],
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_times_matrix_is_identity() {
        let m = [[4.0, 1.0, -2.0], [0.5, 3.0, 1.0], [-1.0, 2.0, 5.0]];
        let inv = inverse(&m).unwrap();
        for r in 0..3 {
            for c in 0..3 {
                let v: f64 = (0..3).map(|k| m[r][k] * inv[k][c]).sum();
                let expected = if r == c { 1.0 } else { 0.0 };
                assert!((v - expected).abs() < 1e-14, "({r},{c}) = {v}");
            }
        }
    }

    #[test]
    fn singular_block_has_no_inverse() {
        let m = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]];
        assert!(inverse(&m).is_none());
        assert!(inverse(&ZERO).is_none());
    }

    #[test]
    fn transpose_product_matches_explicit_transpose() {
        let m = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 10.0]];
        let x = [0.3, -1.0, 2.0];
        assert_eq!(mul_transpose_vec(&m, &x), mul_vec(&transpose(&m), &x));
    }

    /// `(a b) x = a (b x)` for every unit vector, and `a a^-1 = I`.
    #[test]
    fn product_acts_as_the_composition_of_the_maps() {
        let a = [[4.0, 1.0, -2.0], [0.5, 3.0, 1.0], [-1.0, 2.0, 5.0]];
        let b = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 10.0]];
        let ab = mul(&a, &b);
        for k in 0..3 {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            assert_eq!(mul_vec(&ab, &e), mul_vec(&a, &mul_vec(&b, &e)));
        }
        let id = mul(&a, &inverse(&a).unwrap());
        for r in 0..3 {
            for c in 0..3 {
                let expected = if r == c { 1.0 } else { 0.0 };
                assert!((id[r][c] - expected).abs() < 1e-14, "({r},{c})");
            }
        }
    }
}
