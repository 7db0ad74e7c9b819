//! A jump-coefficient diffusion system: an ill-conditioned SPD test matrix
//! on which CG's recursive residual drifts from the true one.

/// The five-point finite-difference matrix of `-div(k grad u) = f` on the
/// unit square, `n x n` interior nodes (spacing `h = 1 / (n + 1)`), zero
/// Dirichlet boundary, with `k = k_inner` on the middle square
/// `[1/4, 3/4]^2` and `k = 1` elsewhere; the coefficient of a face between
/// two nodes is the harmonic mean of theirs (so a face across the jump
/// carries `2 k_inner / (1 + k_inner)`). Entries are scaled by `h^2`:
/// row `i` holds `sum_faces k_f` on the diagonal and `-k_f` for each
/// interior neighbour. SPD; its condition number grows as `k_inner n^2`.
/// Returns the matrix (CSR, both triangles) and the right-hand side
/// `f = h^2` (a unit source), scaled as the matrix.
pub fn jump_diffusion(n: usize, k_inner: f64) -> (sprs::CsMat<f64>, Vec<f64>) {
    let h = 1.0 / (n as f64 + 1.0);
    let k = |i: usize, j: usize| {
        let (x, y) = ((i + 1) as f64 * h, (j + 1) as f64 * h);
        if (0.25..=0.75).contains(&x) && (0.25..=0.75).contains(&y) {
            k_inner
        } else {
            1.0
        }
    };
    // The boundary nodes outside the grid take the coefficient 1.
    let face = |a: f64, b: f64| 2.0 * a * b / (a + b);
    let index = |i: usize, j: usize| i * n + j;
    let mut t = sprs::TriMat::new((n * n, n * n));
    for i in 0..n {
        for j in 0..n {
            let kij = k(i, j);
            let mut diag = 0.0;
            let neighbours = [
                (i.checked_sub(1), Some(j)),
                ((i + 1 < n).then_some(i + 1), Some(j)),
                (Some(i), j.checked_sub(1)),
                (Some(i), (j + 1 < n).then_some(j + 1)),
            ];
            for (ni, nj) in neighbours {
                match (ni, nj) {
                    (Some(a), Some(b)) => {
                        let kf = face(kij, k(a, b));
                        diag += kf;
                        t.add_triplet(index(i, j), index(a, b), -kf);
                    }
                    _ => diag += face(kij, 1.0),
                }
            }
            t.add_triplet(index(i, j), index(i, j), diag);
        }
    }
    (t.to_csr(), vec![h * h; n * n])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_sum_to_the_boundary_faces_and_the_jump_faces_are_harmonic_means() {
        let (a, b) = jump_diffusion(6, 1e4);
        assert_eq!(a.rows(), 36);
        assert_eq!(b.len(), 36);
        // Symmetric.
        for (i, row) in a.outer_iterator().enumerate() {
            for (j, v) in row.iter() {
                assert_eq!(a.get(j, i), Some(v));
            }
        }
        // An interior row of the outer region (node (0, 0) has two boundary
        // faces of k = 1): row sum 2, diagonal 4.
        let row0: f64 = a.outer_view(0).unwrap().iter().map(|(_, v)| v).sum();
        assert!((row0 - 2.0).abs() < 1e-12);
        assert_eq!(a.get(0, 0), Some(&4.0));
        // Nodes (1, 1) (x = y = 2/7, inside) and (0, 1) (outside): their
        // face is 2 * 1e4 / (1 + 1e4).
        let jump = 2.0 * 1e4 / (1.0 + 1e4);
        assert!((a.get(1, 7).unwrap() + jump).abs() < 1e-12);
        // Between two inner nodes (1, 1) and (1, 2): -1e4.
        assert_eq!(a.get(7, 8), Some(&-1e4));
    }
}
