//! Random symmetric positive definite matrices.

use rand::{Rng, SeedableRng, rngs::SmallRng};

/// A random sparse SPD matrix of dimension `n`: a random symmetric pattern
/// with about `per_row` off-diagonal entries per row, values in (-1, 1), made
/// strictly diagonally dominant by `dominance > 1` (so its condition number
/// stays moderate) and then scaled row and column by random factors in
/// (0.5, 2) (so it is not diagonally dominant any more, but still SPD).
pub fn random_spd(n: usize, per_row: usize, dominance: f64, seed: u64) -> sprs::CsMat<f64> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut t = sprs::TriMat::new((n, n));
    let mut row_sum = vec![0.0; n];
    for i in 0..n {
        for _ in 0..per_row / 2 {
            let j = rng.random_range(0..n);
            if j == i {
                continue;
            }
            let v: f64 = rng.random_range(-1.0..1.0);
            t.add_triplet(i, j, v);
            t.add_triplet(j, i, v);
            row_sum[i] += v.abs();
            row_sum[j] += v.abs();
        }
    }
    for (i, s) in row_sum.iter().enumerate() {
        t.add_triplet(i, i, dominance * s + 1.0);
    }
    let a: sprs::CsMat<f64> = t.to_csr();
    let scale: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..2.0)).collect();
    let mut a = a;
    for (i, mut row) in a.outer_iterator_mut().enumerate() {
        for (j, v) in row.iter_mut() {
            *v *= scale[i] * scale[j];
        }
    }
    a
}
