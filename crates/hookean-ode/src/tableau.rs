//! Butcher tableaus of Runge-Kutta methods (the tutorial's eq. 19 and
//! tables 1-2) and their stability functions.

use num_complex::Complex64;

use crate::error::OdeError;

/// A Runge-Kutta method given by its Butcher tableau `(A, b, c)` (the
/// tutorial's table 1): stages `k_i = Y_n + h sum_j a_ij k'_j`,
/// `k'_i = f(t_n + c_i h, k_i)`, `Y_{n+1} = Y_n + h sum_i b_i k'_i` (eq. 19).
#[derive(Debug, Clone, PartialEq)]
pub struct ButcherTableau {
    name: String,
    s: usize,
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
}

impl ButcherTableau {
    /// A tableau from its rows: `a` is `s x s` (row `i` holds `a_i1..a_is`),
    /// `b` and `c` have `s` entries.
    ///
    /// # Errors
    /// [`OdeError::InvalidTableau`] for no stages, ragged or mismatched
    /// sizes, or non-finite entries.
    pub fn new(
        name: impl Into<String>,
        a: &[Vec<f64>],
        b: &[f64],
        c: &[f64],
    ) -> Result<Self, OdeError> {
        let s = b.len();
        if s == 0 {
            return Err(OdeError::InvalidTableau {
                reason: "no stages",
            });
        }
        if c.len() != s || a.len() != s || a.iter().any(|row| row.len() != s) {
            return Err(OdeError::InvalidTableau {
                reason: "A must be s x s and b, c must have s entries",
            });
        }
        let flat: Vec<f64> = a.iter().flatten().copied().collect();
        if flat.iter().chain(b).chain(c).any(|v| !v.is_finite()) {
            return Err(OdeError::InvalidTableau {
                reason: "non-finite coefficient",
            });
        }
        Ok(Self {
            name: name.into(),
            s,
            a: flat,
            b: b.to_vec(),
            c: c.to_vec(),
        })
    }

    /// Explicit (forward) Euler, eq. (10): `A = [0], b = [1], c = [0]`.
    pub fn explicit_euler() -> Self {
        Self::new("explicit-euler", &[vec![0.0]], &[1.0], &[0.0]).expect("valid")
    }

    /// The explicit midpoint rule, eqs. (16)-(17) (table 2(a)).
    pub fn explicit_midpoint() -> Self {
        Self::new(
            "midpoint",
            &[vec![0.0, 0.0], vec![0.5, 0.0]],
            &[0.0, 1.0],
            &[0.0, 0.5],
        )
        .expect("valid")
    }

    /// "The" Runge-Kutta method of order 4 (table 2(b)).
    pub fn rk4() -> Self {
        Self::new(
            "rk4",
            &[
                vec![0.0, 0.0, 0.0, 0.0],
                vec![0.5, 0.0, 0.0, 0.0],
                vec![0.0, 0.5, 0.0, 0.0],
                vec![0.0, 0.0, 1.0, 0.0],
            ],
            &[1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0],
            &[0.0, 0.5, 0.5, 1.0],
        )
        .expect("valid")
    }

    /// Implicit (backward) Euler, eq. (24), as a one-stage tableau `A = [1]`.
    pub fn implicit_euler() -> Self {
        Self::new("implicit-euler", &[vec![1.0]], &[1.0], &[1.0]).expect("valid")
    }

    /// The implicit midpoint rule, eq. (32), as a one-stage collocation
    /// tableau `A = [1/2], b = [1], c = [1/2]`.
    pub fn implicit_midpoint() -> Self {
        Self::new("implicit-midpoint", &[vec![0.5]], &[1.0], &[0.5]).expect("valid")
    }

    /// The name given at construction.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Number of stages `s`.
    pub fn stages(&self) -> usize {
        self.s
    }

    /// The coefficient `a_ij` (0-based).
    pub fn a(&self, i: usize, j: usize) -> f64 {
        self.a[i * self.s + j]
    }

    /// The weights `b`.
    pub fn b(&self) -> &[f64] {
        &self.b
    }

    /// The abscissae `c`.
    pub fn c(&self) -> &[f64] {
        &self.c
    }

    /// True when `A` is strictly lower triangular, so the stages can be
    /// computed one after the other (the tutorial's remark after table 1).
    pub fn is_explicit(&self) -> bool {
        (0..self.s).all(|i| (i..self.s).all(|j| self.a(i, j) == 0.0))
    }

    /// The stability function `R(z) = 1 + z b^T (I - z A)^{-1} 1` (eq. 28
    /// applied to Dahlquist's equation (20)): the factor by which one step
    /// multiplies `y` when `f = lambda y` and `z = h lambda`. Returns an
    /// infinite value at a pole.
    pub fn stability_function(&self, z: Complex64) -> Complex64 {
        let s = self.s;
        // Solve (I - z A) k = 1 by Gaussian elimination with partial pivoting.
        let mut m: Vec<Complex64> = (0..s * s)
            .map(|idx| {
                let (i, j) = (idx / s, idx % s);
                let id = if i == j { 1.0 } else { 0.0 };
                Complex64::new(id, 0.0) - z * self.a[idx]
            })
            .collect();
        let mut k = vec![Complex64::new(1.0, 0.0); s];
        for col in 0..s {
            let p = (col..s)
                .max_by(|&i, &j| m[i * s + col].norm().total_cmp(&m[j * s + col].norm()))
                .unwrap_or(col);
            if m[p * s + col].norm() == 0.0 {
                return Complex64::new(f64::INFINITY, 0.0);
            }
            if p != col {
                for j in 0..s {
                    m.swap(p * s + j, col * s + j);
                }
                k.swap(p, col);
            }
            for i in col + 1..s {
                let f = m[i * s + col] / m[col * s + col];
                for j in col..s {
                    let v = m[col * s + j];
                    m[i * s + j] -= f * v;
                }
                let kc = k[col];
                k[i] -= f * kc;
            }
        }
        for i in (0..s).rev() {
            let mut acc = k[i];
            for j in i + 1..s {
                acc -= m[i * s + j] * k[j];
            }
            k[i] = acc / m[i * s + i];
        }
        let mut sum = Complex64::new(0.0, 0.0);
        for i in 0..s {
            sum += k[i] * self.b[i];
        }
        Complex64::new(1.0, 0.0) + z * sum
    }

    /// The largest `p <= 4` for which the Runge-Kutta order conditions (the
    /// rooted-tree conditions up to order 4, Hairer-Norsett-Wanner II.2) hold to
    /// `tol`; 0 if not even consistency `sum b_i = 1` holds. Assumes the
    /// row-sum condition `c_i = sum_j a_ij`, which is checked too.
    pub fn order(&self, tol: f64) -> usize {
        let s = self.s;
        let (a, b, c) = (|i: usize, j: usize| self.a(i, j), &self.b, &self.c);
        for i in 0..s {
            let row: f64 = (0..s).map(|j| a(i, j)).sum();
            if (row - c[i]).abs() > tol {
                return 0;
            }
        }
        let ac: Vec<f64> = (0..s)
            .map(|i| (0..s).map(|j| a(i, j) * c[j]).sum())
            .collect();
        let ac2: Vec<f64> = (0..s)
            .map(|i| (0..s).map(|j| a(i, j) * c[j] * c[j]).sum())
            .collect();
        let aac: Vec<f64> = (0..s)
            .map(|i| (0..s).map(|j| a(i, j) * ac[j]).sum())
            .collect();
        let sum = |g: &dyn Fn(usize) -> f64| (0..s).map(|i| b[i] * g(i)).sum::<f64>();
        let conditions: [&[(f64, f64)]; 4] = [
            &[(sum(&|_| 1.0), 1.0)],
            &[(sum(&|i| c[i]), 0.5)],
            &[
                (sum(&|i| c[i] * c[i]), 1.0 / 3.0),
                (sum(&|i| ac[i]), 1.0 / 6.0),
            ],
            &[
                (sum(&|i| c[i].powi(3)), 0.25),
                (sum(&|i| c[i] * ac[i]), 1.0 / 8.0),
                (sum(&|i| ac2[i]), 1.0 / 12.0),
                (sum(&|i| aac[i]), 1.0 / 24.0),
            ],
        ];
        let mut p = 0;
        for conds in conditions {
            if conds.iter().all(|(lhs, rhs)| (lhs - rhs).abs() <= tol) {
                p += 1;
            } else {
                break;
            }
        }
        p
    }
}
