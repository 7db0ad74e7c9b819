//! The extreme eigenvalues of the preconditioned operator `M^-1 A` from
//! CG's own coefficients: the CG-Lanczos relation and the symmetric
//! tridiagonal eigenproblem, solved for its two extremes by Sturm-sequence
//! bisection.
//!
//! CG's step lengths `alpha_j = r_j . z_j / p_j . A p_j` and direction
//! updates `beta_j = r_{j+1} . z_{j+1} / r_j . z_j` are the entries of the
//! Lanczos tridiagonal matrix `T_m` of `M^-1 A` (Saad, *Iterative Methods
//! for Sparse Linear Systems*, 2nd ed., sec. 6.7.3, eq. 6.103; Golub and
//! Van Loan, *Matrix Computations*, 4th ed., sec. 11.3.5):
//!
//! ```text
//! T[0][0]   = 1 / alpha_0
//! T[j][j]   = 1 / alpha_j + beta_{j-1} / alpha_{j-1}      (j >= 1)
//! T[j-1][j] = T[j][j-1] = sqrt(beta_{j-1}) / alpha_{j-1}
//! ```
//!
//! Its eigenvalues (the Ritz values) lie in the spectrum of `M^-1 A`, and
//! the extreme ones converge to its extremes first: the largest within a
//! few iterations, the smallest more slowly (it converges as CG does). This
//! is PETSc's `KSPComputeExtremeSingularValues` for CG.

/// The extreme eigenvalues of `M^-1 A` that a CG run's Lanczos matrix
/// gives, and the condition estimate `lambda_max / lambda_min`.
///
/// Both are Ritz values: `lambda_max` lies at or below the true largest
/// eigenvalue and `lambda_min` at or above the true smallest (up to
/// round-off), so `condition` underestimates the condition number, most
/// in the first iterations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConditionEstimate {
    /// The smallest eigenvalue of the Lanczos matrix.
    pub lambda_min: f64,
    /// The largest eigenvalue of the Lanczos matrix.
    pub lambda_max: f64,
    /// `lambda_max / lambda_min`.
    pub condition: f64,
    /// The order of the Lanczos matrix: the CG iterations it records (the
    /// first segment of a restarted run, at most
    /// [`LANCZOS_CAPACITY`](crate::LANCZOS_CAPACITY) iterations).
    pub steps: usize,
}

/// The most CG iterations whose coefficients a run records for its
/// condition estimate (16 bytes each, allocated once per workspace); a
/// longer run's estimate comes from its first this many.
pub const LANCZOS_CAPACITY: usize = 4096;

impl ConditionEstimate {
    /// The estimate from CG's step lengths `alpha` (`m` of them, all
    /// positive) and the `beta` that followed each (at least `m - 1`; a
    /// last extra one is ignored). `None` for no step, or coefficients
    /// that are not positive and finite (a broken-down run).
    pub fn from_cg_coefficients(alpha: &[f64], beta: &[f64]) -> Option<Self> {
        Self::from_cg_coefficients_in(alpha, beta, &mut Vec::new(), &mut Vec::new())
    }

    /// As [`from_cg_coefficients`](Self::from_cg_coefficients), with `T`'s
    /// diagonal and squared off-diagonal written into `diagonal` and
    /// `off_squared` (cleared first; no allocation when they hold room for
    /// `m` entries, as CG's workspace reserves).
    pub(crate) fn from_cg_coefficients_in(
        alpha: &[f64],
        beta: &[f64],
        diagonal: &mut Vec<f64>,
        off_squared: &mut Vec<f64>,
    ) -> Option<Self> {
        let m = alpha.len();
        let usable = |v: &f64| *v > 0.0 && v.is_finite();
        if m == 0 || beta.len() + 1 < m || !alpha.iter().all(usable) {
            return None;
        }
        if !beta[..m - 1].iter().all(usable) {
            return None;
        }
        let t = Tridiagonal::from_cg(alpha, beta, diagonal, off_squared);
        let (lambda_min, lambda_max) = t.extreme_eigenvalues();
        Some(Self {
            lambda_min,
            lambda_max,
            condition: lambda_max / lambda_min,
            steps: m,
        })
    }
}

/// The Lanczos matrix `T_m`: its diagonal `T[j][j]` and squared
/// off-diagonal `T[j-1][j]^2` (entry 0 unused), read off CG's coefficients
/// once, so that each of the bisection's Sturm counts takes one division
/// per row instead of four.
struct Tridiagonal<'a> {
    diagonal: &'a [f64],
    off_squared: &'a [f64],
}

impl<'a> Tridiagonal<'a> {
    /// The entries of the module doc's `T_m` from `m = alpha.len()` step
    /// lengths and the `beta` that followed each.
    fn from_cg(
        alpha: &[f64],
        beta: &[f64],
        diagonal: &'a mut Vec<f64>,
        off_squared: &'a mut Vec<f64>,
    ) -> Self {
        diagonal.clear();
        off_squared.clear();
        for j in 0..alpha.len() {
            let d = 1.0 / alpha[j];
            if j == 0 {
                diagonal.push(d);
                off_squared.push(0.0);
            } else {
                diagonal.push(d + beta[j - 1] / alpha[j - 1]);
                off_squared.push(beta[j - 1] / (alpha[j - 1] * alpha[j - 1]));
            }
        }
        Self {
            diagonal,
            off_squared,
        }
    }

    fn order(&self) -> usize {
        self.diagonal.len()
    }

    /// Whether more than `k` eigenvalues lie below `x`: the count of the
    /// negative pivots of the `LDL^T` factorisation of `T - x I`
    /// (Sylvester's law of inertia; the Sturm-sequence count of Golub and
    /// Van Loan, sec. 8.4.1), stopped as soon as the answer is known (the
    /// count passes `k`, or the rows left cannot take it past `k`), so
    /// that a test against the smallest eigenvalue ends at the first
    /// negative pivot and one against the largest at the first positive.
    /// A zero pivot is nudged to a tiny negative number, as LAPACK's
    /// `dstebz` does.
    fn more_below_than(&self, k: usize, x: f64, tiny: f64) -> bool {
        let m = self.order();
        let mut count = 0;
        let mut q = self.diagonal[0] - x;
        for j in 0..m {
            if j > 0 {
                q = self.diagonal[j] - x - self.off_squared[j] / q;
            }
            if q.abs() < tiny {
                q = -tiny;
            }
            if q < 0.0 {
                count += 1;
                if count > k {
                    return true;
                }
            } else if count + (m - 1 - j) <= k {
                return false;
            }
        }
        false
    }

    /// The smallest and largest eigenvalue, by bisection inside the
    /// Gershgorin interval to a relative accuracy of about `1e-9` (a
    /// condition estimate needs a few digits; each digit costs about 3.3
    /// Sturm counts of `m` rows).
    fn extreme_eigenvalues(&self) -> (f64, f64) {
        let m = self.order();
        let off = |j: usize| {
            if (1..m).contains(&j) {
                self.off_squared[j].sqrt()
            } else {
                0.0
            }
        };
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for j in 0..m {
            let radius = off(j) + off(j + 1);
            lo = lo.min(self.diagonal[j] - radius);
            hi = hi.max(self.diagonal[j] + radius);
        }
        let scale = lo.abs().max(hi.abs());
        let tiny = f64::MIN_POSITIVE.max(f64::EPSILON * scale * 1e-3);
        // The k-th smallest eigenvalue (k = 0 or m - 1): the point where
        // the count of eigenvalues below it passes k.
        let kth = |k: usize| {
            let (mut a, mut b) = (lo, hi);
            for _ in 0..BISECTION_STEPS {
                let mid = 0.5 * (a + b);
                if self.more_below_than(k, mid, tiny) {
                    b = mid;
                } else {
                    a = mid;
                }
                if b - a <= 1e-9 * a.abs().max(b.abs()) {
                    break;
                }
            }
            0.5 * (a + b)
        };
        (kth(0), kth(m - 1))
    }
}

/// Enough halvings of a Gershgorin interval for double precision.
const BISECTION_STEPS: usize = 200;

#[cfg(test)]
mod tests {
    use super::*;

    /// CG without preconditioner on `diag(lambda)` with `b` of equal
    /// weights finds all n eigenvalues in n steps (exactly, the Lanczos
    /// matrix then has the spectrum of A): here the coefficients of a run,
    /// computed in closed form by plain CG on the diagonal matrix.
    fn cg_coefficients(lambda: &[f64], steps: usize) -> (Vec<f64>, Vec<f64>) {
        let n = lambda.len();
        let mut x = vec![0.0; n];
        let mut r = vec![1.0; n];
        let mut p = r.clone();
        let mut rr: f64 = r.iter().map(|v| v * v).sum();
        let (mut alpha, mut beta) = (Vec::new(), Vec::new());
        for _ in 0..steps {
            let q: Vec<f64> = p.iter().zip(lambda).map(|(p, l)| p * l).collect();
            let pq: f64 = p.iter().zip(&q).map(|(a, b)| a * b).sum();
            let a = rr / pq;
            for i in 0..n {
                x[i] += a * p[i];
                r[i] -= a * q[i];
            }
            let rr_new: f64 = r.iter().map(|v| v * v).sum();
            let b = rr_new / rr;
            for i in 0..n {
                p[i] = r[i] + b * p[i];
            }
            rr = rr_new;
            alpha.push(a);
            beta.push(b);
        }
        (alpha, beta)
    }

    #[test]
    fn n_steps_of_cg_on_a_diagonal_matrix_give_its_extreme_eigenvalues() {
        let lambda = [0.5, 1.0, 2.0, 3.0, 7.0, 11.0];
        let (alpha, beta) = cg_coefficients(&lambda, lambda.len());
        let e = ConditionEstimate::from_cg_coefficients(&alpha, &beta).unwrap();
        approx::assert_relative_eq!(e.lambda_min, 0.5, max_relative = 1e-9);
        approx::assert_relative_eq!(e.lambda_max, 11.0, max_relative = 1e-9);
        approx::assert_relative_eq!(e.condition, 22.0, max_relative = 1e-9);
        assert_eq!(e.steps, 6);
    }

    /// One step: `T = [1 / alpha_0]`, the Rayleigh quotient of `b`.
    #[test]
    fn one_step_gives_the_rayleigh_quotient() {
        let lambda = [1.0, 3.0];
        let (alpha, beta) = cg_coefficients(&lambda, 1);
        let e = ConditionEstimate::from_cg_coefficients(&alpha, &beta).unwrap();
        // b = (1, 1): b.A b / b.b = 2.
        approx::assert_relative_eq!(e.lambda_min, 2.0, max_relative = 1e-9);
        approx::assert_relative_eq!(e.lambda_max, 2.0, max_relative = 1e-9);
    }

    /// The 2x2 Lanczos matrix of given coefficients against its
    /// eigenvalues from the quadratic formula.
    #[test]
    fn a_two_by_two_lanczos_matrix_matches_the_quadratic_formula() {
        let (alpha, beta) = ([0.25, 0.5], [0.36]);
        let (a, d): (f64, f64) = (4.0, 2.0 + 0.36 / 0.25);
        let b2 = 0.36 / (0.25 * 0.25);
        let mean = 0.5 * (a + d);
        let half = (0.25 * (a - d) * (a - d) + b2).sqrt();
        let e = ConditionEstimate::from_cg_coefficients(&alpha, &beta).unwrap();
        approx::assert_relative_eq!(e.lambda_min, mean - half, max_relative = 1e-9);
        approx::assert_relative_eq!(e.lambda_max, mean + half, max_relative = 1e-9);
    }

    #[test]
    fn no_step_or_broken_coefficients_give_none() {
        assert_eq!(ConditionEstimate::from_cg_coefficients(&[], &[]), None);
        assert_eq!(
            ConditionEstimate::from_cg_coefficients(&[1.0, -1.0], &[0.5]),
            None
        );
        assert_eq!(
            ConditionEstimate::from_cg_coefficients(&[1.0, 1.0], &[f64::NAN]),
            None
        );
        assert_eq!(
            ConditionEstimate::from_cg_coefficients(&[1.0, 1.0], &[]),
            None
        );
    }
}
