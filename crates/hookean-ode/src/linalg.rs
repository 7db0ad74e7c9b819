//! Small private dense linear algebra: LU with partial pivoting for the
//! Newton matrices of first-order problems.

/// A dense LU factorisation `P A = L U`, storage reused between factorisations.
#[derive(Debug, Clone, Default)]
pub(crate) struct DenseLu {
    n: usize,
    lu: Vec<f64>,
    piv: Vec<usize>,
}

impl DenseLu {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            n,
            lu: vec![0.0; n * n],
            piv: vec![0; n],
        }
    }

    /// The matrix to factor, row-major; call [`factor`](Self::factor) after filling it.
    pub(crate) fn matrix_mut(&mut self) -> &mut [f64] {
        &mut self.lu
    }

    /// Factors the matrix in place. Returns the index of a zero pivot.
    pub(crate) fn factor(&mut self) -> Result<(), usize> {
        let n = self.n;
        let a = &mut self.lu;
        let scale = a.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for k in 0..n {
            let mut p = k;
            for i in k + 1..n {
                if a[i * n + k].abs() > a[p * n + k].abs() {
                    p = i;
                }
            }
            let pivot = a[p * n + k];
            if !pivot.is_finite() || pivot.abs() <= 1e-300_f64.max(scale * f64::EPSILON * 1e-3) {
                return Err(k);
            }
            self.piv[k] = p;
            if p != k {
                for j in 0..n {
                    a.swap(p * n + j, k * n + j);
                }
            }
            for i in k + 1..n {
                let f = a[i * n + k] / a[k * n + k];
                a[i * n + k] = f;
                if f != 0.0 {
                    for j in k + 1..n {
                        a[i * n + j] -= f * a[k * n + j];
                    }
                }
            }
        }
        Ok(())
    }

    /// Solves `A x = b` in place (`b` becomes `x`).
    pub(crate) fn solve(&self, b: &mut [f64]) {
        let n = self.n;
        let a = &self.lu;
        for k in 0..n {
            b.swap(k, self.piv[k]);
        }
        for i in 0..n {
            let mut s = b[i];
            for j in 0..i {
                s -= a[i * n + j] * b[j];
            }
            b[i] = s;
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for j in i + 1..n {
                s -= a[i * n + j] * b[j];
            }
            b[i] = s / a[i * n + i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_pivoting_system() {
        // A needs a row swap (zero leading entry); x = (1, 2, 3).
        let a = [0.0, 2.0, 1.0, 1.0, 1.0, 1.0, 2.0, 1.0, 3.0];
        let x = [1.0, 2.0, 3.0];
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum())
            .collect();
        let mut lu = DenseLu::new(3);
        lu.matrix_mut().copy_from_slice(&a);
        lu.factor().unwrap();
        lu.solve(&mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-14);
        }
    }

    #[test]
    fn reports_a_singular_matrix() {
        let mut lu = DenseLu::new(2);
        lu.matrix_mut().copy_from_slice(&[1.0, 2.0, 2.0, 4.0]);
        assert_eq!(lu.factor(), Err(1));
    }
}
