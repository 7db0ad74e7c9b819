//! The coefficients of the fixed-step BDF(k) and of variable-step BDF2 that
//! `core.rs` runs: the backward differentiation formulas of the tutorial's
//! eqs. 34, 36, 37 and table 3, derived rather than copied: BDF(k) is
//! `sum_{j=1..k} (1/j) nabla^j y_{n+1} = h f_{n+1}` (Hairer-Wanner III.1), with the
//! backward difference `nabla^j y_{n+1} = sum_{i=0..j} (-1)^i C(j, i) y_{n+1-i}`.

use num_complex::Complex64;

use crate::error::OdeError;

/// The fixed-step BDF(k) formula normalised to a leading coefficient 1:
/// `y_{n+1} + sum_{i=1..k} alpha[i] y_{n+1-i} = h beta f(t_{n+1}, y_{n+1})`
/// (`alpha[0] = 1`). For k = 2: `alpha = [1, -4/3, 1/3]`, `beta = 2/3` (eq. 37).
#[derive(Debug, Clone, PartialEq)]
pub struct BdfCoefficients {
    /// The number of steps (and the order) `k`, 1 to 6.
    pub k: usize,
    /// `alpha[i]` multiplies `y_{n+1-i}`; `alpha[0] = 1`.
    pub alpha: Vec<f64>,
    /// The weight of `h f_{n+1}`.
    pub beta: f64,
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

impl BdfCoefficients {
    /// Derives BDF(k) from `sum_{j=1..k} (1/j) nabla^j y_{n+1} = h f_{n+1}`:
    /// the unnormalised coefficient of `y_{n+1-i}` is
    /// `sum_{j=max(i,1)..k} (1/j) (-1)^i C(j, i)`; dividing by that of
    /// `y_{n+1}` (`sum_{j=1..k} 1/j`) gives `alpha` and `beta = 1 / sum 1/j`.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] unless `1 <= k <= 6` (BDF(k) is not
    /// zero-stable for k > 6, Hairer-Wanner).
    pub fn new(k: usize) -> Result<Self, OdeError> {
        if !(1..=6).contains(&k) {
            return Err(OdeError::InvalidParameter {
                name: "k",
                value: k as f64,
                reason: "BDF(k) exists (is zero-stable) for k = 1..6 only",
            });
        }
        let raw: Vec<f64> = (0..=k)
            .map(|i| {
                let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
                (i.max(1)..=k)
                    .map(|j| sign * binomial(j, i) / j as f64)
                    .sum()
            })
            .collect();
        let lead = raw[0];
        Ok(Self {
            k,
            alpha: raw.iter().map(|a| a / lead).collect(),
            beta: 1.0 / lead,
        })
    }

    /// The residual of the order condition of degree `q`: the formula
    /// applied to `y(t) = t^q` with `t_{n+1} = 0`, `h = 1`:
    /// `sum_i alpha_i (-i)^q - beta q 0^{q-1}`. BDF(k) has order k, so the
    /// residual vanishes for `q = 0..=k` and not for `q = k + 1`.
    pub fn order_residual(&self, q: u32) -> f64 {
        let lhs: f64 = self
            .alpha
            .iter()
            .enumerate()
            .map(|(i, a)| a * (-(i as f64)).powi(q as i32))
            .sum();
        let rhs = if q == 1 { self.beta } else { 0.0 };
        lhs - rhs
    }

    /// The boundary locus of the stability region (figure 4): the points
    /// `z(theta) = rho(e^{i theta}) / sigma(e^{i theta})
    /// = sum_{j=1..k} (1/j) (1 - e^{-i theta})^j` for `n` angles in `[0, 2 pi)`.
    /// The stability region is the part of the complex plane outside the
    /// curve (for k = 1, 2 the curve lies in the right half-plane).
    pub fn boundary_locus(&self, n: usize) -> Vec<Complex64> {
        (0..n)
            .map(|m| {
                let theta = 2.0 * std::f64::consts::PI * m as f64 / n as f64;
                let w = Complex64::new(1.0, 0.0) - Complex64::from_polar(1.0, -theta);
                let mut p = Complex64::new(1.0, 0.0);
                let mut z = Complex64::new(0.0, 0.0);
                for j in 1..=self.k {
                    p *= w;
                    z += p / j as f64;
                }
                z
            })
            .collect()
    }

    /// The largest modulus of the roots `zeta` of the characteristic
    /// polynomial `(1 - z beta) zeta^k + sum_{i=1..k} alpha_i zeta^{k-i}` of
    /// BDF(k) applied to Dahlquist's equation with `z = h lambda`; the
    /// numerical solution stays bounded when it is `< 1` (`<= 1` for simple
    /// roots). Infinite when `z = 1/beta` (the leading coefficient vanishes).
    pub fn max_root_modulus(&self, z: Complex64) -> f64 {
        let lead = Complex64::new(1.0, 0.0) - z * self.beta;
        if lead.norm() < 1e-300 {
            return f64::INFINITY;
        }
        // Monic coefficients c[0] zeta^k + c[1] zeta^{k-1} + ... + c[k].
        let c: Vec<Complex64> = self
            .alpha
            .iter()
            .map(|a| Complex64::new(*a, 0.0) / lead)
            .collect();
        let roots = polynomial_roots(&c[1..]);
        roots.iter().map(|r| r.norm()).fold(0.0, f64::max)
    }
}

/// Roots of the monic polynomial `zeta^k + c[0] zeta^{k-1} + ... + c[k-1]`
/// by the Durand-Kerner (Weierstrass) iteration, polished by Newton steps.
fn polynomial_roots(c: &[Complex64]) -> Vec<Complex64> {
    let k = c.len();
    let eval = |z: Complex64| {
        c.iter()
            .fold(Complex64::new(1.0, 0.0), |acc, ci| acc * z + ci)
    };
    let deriv = |z: Complex64| {
        let mut p = Complex64::new(1.0, 0.0);
        let mut dp = Complex64::new(0.0, 0.0);
        for ci in c {
            dp = dp * z + p;
            p = p * z + ci;
        }
        dp
    };
    let radius = 1.0 + c.iter().map(|v| v.norm()).fold(0.0, f64::max);
    let mut z: Vec<Complex64> = (0..k)
        .map(|i| {
            Complex64::from_polar(
                radius * 0.9,
                0.4 + 2.0 * std::f64::consts::PI * i as f64 / k as f64,
            )
        })
        .collect();
    for _ in 0..500 {
        let mut change: f64 = 0.0;
        for i in 0..k {
            let mut denom = Complex64::new(1.0, 0.0);
            for j in 0..k {
                if i != j {
                    denom *= z[i] - z[j];
                }
            }
            if denom.norm() == 0.0 {
                denom = Complex64::new(1e-12, 0.0);
            }
            let delta = eval(z[i]) / denom;
            z[i] -= delta;
            change = change.max(delta.norm());
        }
        if change < 1e-15 * radius {
            break;
        }
    }
    for zi in &mut z {
        for _ in 0..3 {
            let d = deriv(*zi);
            if d.norm() > 0.0 {
                let step = eval(*zi) / d;
                if step.is_finite() {
                    *zi -= step;
                }
            }
        }
    }
    z
}

/// Coefficients of the variable-step BDF2 formula for the step ratio
/// `omega = h_n / h_{n-1}` (Hairer-Wanner III.5):
/// `y_{n+1} + a1 y_n + a2 y_{n-1} = h_n beta f_{n+1}` with
/// `a1 = -(1 + omega)^2 / (1 + 2 omega)`, `a2 = omega^2 / (1 + 2 omega)`,
/// `beta = (1 + omega) / (1 + 2 omega)`; omega = 1 gives eq. (37).
pub fn variable_bdf2(omega: f64) -> (f64, f64, f64) {
    let d = 1.0 + 2.0 * omega;
    (
        -(1.0 + omega).powi(2) / d,
        omega * omega / d,
        (1.0 + omega) / d,
    )
}

/// The local error constant of variable-step BDF2: the local error is
/// `C(omega) h_n^3 y'''` with `C = (1 + omega)^2 / (6 omega (1 + 2 omega))`
/// (derived by applying the formula to a cubic; `C(1) = 2/9`).
pub fn variable_bdf2_error_constant(omega: f64) -> f64 {
    (1.0 + omega).powi(2) / (6.0 * omega * (1.0 + 2.0 * omega))
}
