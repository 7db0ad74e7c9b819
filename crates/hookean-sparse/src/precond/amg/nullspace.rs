//! The near-nullspace of smoothed aggregation: the user's vectors as one
//! `B x K` block per node, and the rigid-body modes of an elastic body from
//! its node coordinates.

use super::bsr::{Blk, zero};
use crate::error::SparseError;

/// The rigid-body modes of a body whose node `i` sits at
/// `coordinates[dim * i .. dim * i + dim]` (`dim` = 2 or 3), with `dim`
/// unknowns per node (the displacements, node by node): the translations
/// along each axis, then the infinitesimal rotations `omega x (x - c)`
/// about the centroid `c` (about `z` in 2D, `(-y, x)`; about `x`, `y`,
/// `z` in 3D): 3 vectors in 2D, 6 in 3D, the kernel of the stiffness
/// matrix of linear elasticity without boundary conditions (the
/// near-nullspace of smoothed aggregation for elasticity, Vaněk, Mandel,
/// Brezina 1996, section 4). Measured from the centroid, the rotations are
/// orthogonal to the translations.
///
/// ```
/// let modes = hookean_sparse::rigid_body_modes(&[0.0, 0.0, 1.0, 0.0], 2)?;
/// assert_eq!(modes.len(), 3);
/// // The rotation about the centroid (0.5, 0): node 0 moves down, node 1 up.
/// assert_eq!(modes[2], vec![0.0, -0.5, 0.0, 0.5]);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
///
/// # Errors
/// [`SparseError::InvalidParameter`] when `dim` is not 2 or 3, the
/// coordinates are not a whole number of nodes or there are none, or a
/// coordinate is not finite.
pub fn rigid_body_modes(coordinates: &[f64], dim: usize) -> Result<Vec<Vec<f64>>, SparseError> {
    let bad = |message: String| {
        Err(SparseError::InvalidParameter {
            name: "coordinates",
            message,
        })
    };
    if !(dim == 2 || dim == 3) {
        return bad(format!("dimension {dim} is not 2 or 3"));
    }
    if coordinates.is_empty() || !coordinates.len().is_multiple_of(dim) {
        return bad(format!(
            "{} numbers are not a positive whole number of nodes of {dim} coordinates",
            coordinates.len()
        ));
    }
    if let Some(k) = coordinates.iter().position(|x| !x.is_finite()) {
        return bad(format!(
            "coordinate {} of node {} is not finite",
            k % dim,
            k / dim
        ));
    }
    let n = coordinates.len() / dim;
    let mut centroid = [0.0; 3];
    for x in coordinates.chunks_exact(dim) {
        for (c, xc) in centroid.iter_mut().zip(x) {
            *c += xc / n as f64;
        }
    }
    // Rotation about axis `axis`: the velocity of a point at `x`, `e_axis x x`.
    let rotation = |axis: usize, x: &[f64]| -> [f64; 3] {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut v = [0.0; 3];
        v[a] = -x[b];
        v[b] = x[a];
        v
    };
    let rotations: &[usize] = if dim == 2 { &[2] } else { &[0, 1, 2] };
    let mut modes: Vec<Vec<f64>> = (0..dim)
        .map(|c| (0..n * dim).map(|i| f64::from(i % dim == c)).collect())
        .collect();
    for &axis in rotations {
        let mut v = vec![0.0; n * dim];
        for (vi, x) in v.chunks_exact_mut(dim).zip(coordinates.chunks_exact(dim)) {
            let mut rel = [0.0; 3];
            for c in 0..dim {
                rel[c] = x[c] - centroid[c];
            }
            vi.copy_from_slice(&rotation(axis, &rel)[..dim]);
        }
        modes.push(v);
    }
    Ok(modes)
}

/// The near-nullspace `vectors` (`K` of them, each of length `B n`; empty:
/// the `B` translations, `K = B`) as one `B x K` block per node (column
/// `c` is vector `c`).
///
/// # Errors
/// [`SparseError::NullspaceLength`] for a vector of the wrong length;
/// [`SparseError::InvalidParameter`] for vectors that are not finite or are
/// linearly dependent (a pivot of the Cholesky factor of their Gram matrix
/// below `1e-10` of its diagonal entry).
pub(super) fn nullspace_blocks<const B: usize, const K: usize>(
    vectors: &[Vec<f64>],
    n: usize,
) -> Result<Vec<Blk<B, K>>, SparseError> {
    let bad = |message: String| {
        Err(SparseError::InvalidParameter {
            name: "near_nullspace",
            message,
        })
    };
    if vectors.is_empty() {
        assert_eq!(
            B, K,
            "the default near-nullspace has one vector per unknown"
        );
        let mut identity = zero::<B, K>();
        for (r, row) in identity.iter_mut().enumerate() {
            row[r] = 1.0;
        }
        return Ok(vec![identity; n]);
    }
    assert_eq!(vectors.len(), K);
    for (vector, v) in vectors.iter().enumerate() {
        if v.len() != B * n {
            return Err(SparseError::NullspaceLength {
                vector,
                expected: B * n,
                found: v.len(),
            });
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return bad(format!("entry {i} of vector {vector} is not finite"));
        }
    }
    // Gram matrix G = N^T N and its Cholesky factor, row by row.
    let mut g = [[0.0; K]; K];
    for p in 0..K {
        for q in 0..=p {
            g[p][q] = crate::vecops::dot(&vectors[p], &vectors[q]);
        }
    }
    for j in 0..K {
        let diag = g[j][j];
        let d = diag - (0..j).map(|k| g[j][k] * g[j][k]).sum::<f64>();
        if !(d > 1e-10 * diag) {
            return bad(format!(
                "vector {j} is zero or a combination of the vectors before it"
            ));
        }
        let l = d.sqrt();
        g[j][j] = l;
        for i in j + 1..K {
            let s = g[i][j] - (0..j).map(|k| g[i][k] * g[j][k]).sum::<f64>();
            g[i][j] = s / l;
        }
    }
    Ok((0..n)
        .map(|i| {
            let mut blk = zero::<B, K>();
            for (r, row) in blk.iter_mut().enumerate() {
                for (c, v) in vectors.iter().enumerate() {
                    row[c] = v[B * i + r];
                }
            }
            blk
        })
        .collect())
}
