//! Small dense helpers for reference solutions in tests.

/// Row-major dense copy of a `sprs` matrix.
pub fn to_dense(a: &sprs::CsMat<f64>) -> Vec<Vec<f64>> {
    let (rows, cols) = a.shape();
    let mut d = vec![vec![0.0; cols]; rows];
    for (&v, (r, c)) in a.iter() {
        d[r][c] += v;
    }
    d
}

/// Solves `m x = b` by Gaussian elimination with partial pivoting.
///
/// # Panics
/// If `m` is singular to working precision.
pub fn solve(m: &[Vec<f64>], b: &[f64]) -> Vec<f64> {
    let n = b.len();
    let mut a: Vec<Vec<f64>> = m.to_vec();
    let mut x = b.to_vec();
    for k in 0..n {
        let p = (k..n)
            .max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))
            .expect("non-empty");
        assert!(a[p][k] != 0.0, "singular matrix");
        a.swap(k, p);
        x.swap(k, p);
        for i in k + 1..n {
            let f = a[i][k] / a[k][k];
            for j in k..n {
                a[i][j] -= f * a[k][j];
            }
            x[i] -= f * x[k];
        }
    }
    for k in (0..n).rev() {
        let s: f64 = (k + 1..n).map(|j| a[k][j] * x[j]).sum();
        x[k] = (x[k] - s) / a[k][k];
    }
    x
}

/// `|a - b|_inf / |b|_inf`.
pub fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0_f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}
