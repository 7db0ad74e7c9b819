//! The solution history of the variable-order BDF in the quasi-constant-step
//! form of Shampine and Reichelt ("The MATLAB ODE Suite", SIAM J. Sci.
//! Comput. 18, 1997): the modified divided differences `D_0 = y_n`,
//! `D_j = nabla^j y_n` of the last points on an equidistant grid of spacing
//! `h`, with the NDF/BDF coefficients; re-interpolation onto a new spacing,
//! the predictor, the update after a step, and the dense output.

use crate::bdf_config::{Formula, MAX_ORDER};

/// The NDF modification `kappa_k` of orders 0..=5 (Shampine-Reichelt,
/// table 1; order 5 is the BDF).
const NDF_KAPPA: [f64; MAX_ORDER + 1] = [0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0];

/// The fixed coefficients of order `k = 0..=5`: `gamma_k = sum_{i=1..k} 1/i`,
/// `alpha_k = (1 - kappa_k) gamma_k` and the error constant
/// `kappa_k gamma_k + 1 / (k + 1)`.
#[derive(Debug, Clone)]
pub(crate) struct Coefficients {
    pub gamma: [f64; MAX_ORDER + 1],
    pub alpha: [f64; MAX_ORDER + 1],
    pub error_const: [f64; MAX_ORDER + 2],
}

impl Coefficients {
    pub fn new(formula: Formula) -> Self {
        let kappa = match formula {
            Formula::Ndf => NDF_KAPPA,
            Formula::Bdf => [0.0; MAX_ORDER + 1],
        };
        let mut gamma = [0.0; MAX_ORDER + 1];
        for k in 1..=MAX_ORDER {
            gamma[k] = gamma[k - 1] + 1.0 / k as f64;
        }
        let mut alpha = [0.0; MAX_ORDER + 1];
        let mut error_const = [0.0; MAX_ORDER + 2];
        for k in 0..=MAX_ORDER {
            alpha[k] = (1.0 - kappa[k]) * gamma[k];
            error_const[k] = kappa[k] * gamma[k] + 1.0 / (k + 1) as f64;
        }
        error_const[MAX_ORDER + 1] = 1.0 / (MAX_ORDER + 2) as f64;
        Self {
            gamma,
            alpha,
            error_const,
        }
    }
}

/// The matrix `R(rho)` of Shampine-Reichelt (eq. 2.3) for order `k`:
/// `R_ij = prod_{m=1..i} (m - 1 - rho j) / m` (`R_0j = 1`, `R_i0 = 0` for `i > 0`).
fn interpolation_matrix(k: usize, rho: f64) -> [[f64; MAX_ORDER + 1]; MAX_ORDER + 1] {
    let mut r = [[0.0; MAX_ORDER + 1]; MAX_ORDER + 1];
    for j in 0..=k {
        r[0][j] = 1.0;
    }
    for i in 1..=k {
        for j in 1..=k {
            r[i][j] = r[i - 1][j] * ((i - 1) as f64 - rho * j as f64) / i as f64;
        }
    }
    r
}

/// The differences `D_0..D_{MAX_ORDER + 2}` (`D_{k+1}`, `D_{k+2}` hold the
/// last correction and its change, for the error estimates of the
/// neighbouring orders), the grid spacing and the order. The differences
/// are stored one after the other in one buffer (`D_j` at `j n..(j + 1) n`):
/// the loops over them are short (a few unknowns, orders up to 5), and
/// their set-up is most of their cost.
#[derive(Debug, Clone)]
pub(crate) struct History {
    d: Vec<f64>,
    n: usize,
    /// The spacing of the grid (the next step's size).
    pub h: f64,
    pub order: usize,
    /// Steps taken with this spacing and order.
    pub n_equal_steps: usize,
    work: Vec<f64>,
    /// `U = R(1)` of every order (constant).
    u: [[[f64; MAX_ORDER + 1]; MAX_ORDER + 1]; MAX_ORDER + 1],
}

impl History {
    /// A history of the state `y0` (order 1, no grid yet).
    pub fn new(y0: &[f64]) -> Self {
        let n = y0.len();
        let mut d = vec![0.0; (MAX_ORDER + 3) * n];
        d[..n].copy_from_slice(y0);
        Self {
            d,
            n,
            h: f64::NAN,
            order: 1,
            n_equal_steps: 0,
            work: vec![0.0; (MAX_ORDER + 1) * n],
            u: std::array::from_fn(|k| interpolation_matrix(k, 1.0)),
        }
    }

    /// `D_j`.
    #[inline]
    pub fn d(&self, j: usize) -> &[f64] {
        &self.d[j * self.n..(j + 1) * self.n]
    }

    /// `D_j`, to write.
    #[inline]
    pub fn d_mut(&mut self, j: usize) -> &mut [f64] {
        &mut self.d[j * self.n..(j + 1) * self.n]
    }

    /// Starts the grid at `y = D_0` with spacing `h` and slope `f`:
    /// `D_1 = h f`, order 1.
    pub fn start(&mut self, h: f64, f: &[f64]) {
        self.h = h;
        for (d1, fi) in self.d_mut(1).iter_mut().zip(f) {
            *d1 = h * fi;
        }
        self.order = 1;
        self.n_equal_steps = 0;
    }

    /// Re-interpolates the history onto a grid of spacing `rho h`:
    /// `D <- (R(rho) U)^T D` with `U = R(1)` (Shampine-Reichelt, eq. 2.3).
    pub fn rescale(&mut self, rho: f64) {
        let k = self.order;
        let r = interpolation_matrix(k, rho);
        let u = &self.u[k];
        let n = self.n;
        let (d, work) = (&self.d[..(k + 1) * n], &mut self.work[..(k + 1) * n]);
        for (j, out) in work.chunks_exact_mut(n).enumerate() {
            out.fill(0.0);
            for (i, d_i) in d.chunks_exact(n).enumerate() {
                // U is upper triangular (R(1)_mj = 0 for m > j): the terms
                // m > j of (R U)_ij are exact zeros.
                let ru: f64 = (0..=j).map(|m| r[i][m] * u[m][j]).sum();
                if ru != 0.0 {
                    for (o, v) in out.iter_mut().zip(d_i) {
                        *o += ru * v;
                    }
                }
            }
        }
        self.d[..(k + 1) * n].copy_from_slice(work);
        self.h *= rho;
        self.n_equal_steps = 0;
    }

    /// The predictor `y^(0) = sum_{j=0..k} D_j` and the corrector's
    /// `psi = sum_{j=1..k} gamma_j D_j / alpha_k` of the order-`k` formula
    /// `(1 - kappa_k) gamma_k (y_{n+1} - y^(0)) + sum_{j=1..k} gamma_j nabla^j y_n = h f(t_{n+1}, y_{n+1})`.
    #[allow(clippy::needless_range_loop)]
    pub fn predict(&self, coef: &Coefficients, y_pred: &mut [f64], psi: &mut [f64]) {
        let (k, n) = (self.order, self.n);
        let (d, y_pred, psi) = (&self.d[..(k + 1) * n], &mut y_pred[..n], &mut psi[..n]);
        let alpha = coef.alpha[k];
        for i in 0..n {
            let mut p = 0.0 + d[i];
            let mut s = 0.0;
            for j in 1..=k {
                let v = d[j * n + i];
                p += v;
                s += coef.gamma[j] * v;
            }
            y_pred[i] = p;
            psi[i] = s / alpha;
        }
    }

    /// After an accepted step with the correction `dcor = y_{n+1} - y^(0)`:
    /// `D_{k+2} = dcor - D_{k+1}`, `D_{k+1} = dcor`, `D_j += D_{j+1}` for
    /// `j = k..0` (Shampine-Reichelt, eq. 2.4).
    #[allow(clippy::needless_range_loop)]
    pub fn update(&mut self, dcor: &[f64]) {
        let (k, n) = (self.order, self.n);
        let (d, dcor) = (&mut self.d[..(k + 3) * n], &dcor[..n]);
        for i in 0..n {
            let e = dcor[i];
            d[(k + 2) * n + i] = e - d[(k + 1) * n + i];
            d[(k + 1) * n + i] = e;
            let mut next = e;
            for j in (0..=k).rev() {
                next += d[j * n + i];
                d[j * n + i] = next;
            }
        }
        self.n_equal_steps += 1;
    }

    /// What the next steps read, for a checkpoint: `[h, order,
    /// n_equal_steps, D_0, ..., D_{order+2}]`. The later differences are
    /// written before they are read (a step at order `k` reads `D_0` to
    /// `D_{k+2}` and writes `D_{k+1}`, `D_{k+2}`; the order moves by one at
    /// a time), and the rescaling's work is scratch.
    pub fn carried(&self) -> Vec<f64> {
        let mut c = vec![self.h, self.order as f64, self.n_equal_steps as f64];
        c.extend_from_slice(&self.d[..(self.order + 3).min(MAX_ORDER + 3) * self.n]);
        c
    }

    /// Restores [`carried`](Self::carried); `None` (and `self` unchanged)
    /// if it does not fit this history.
    pub fn restore(&mut self, c: &[f64]) -> Option<()> {
        let (&[h, order, n_equal], d) = c.split_first_chunk::<3>()?;
        let count = |v: f64| v >= 0.0 && v.fract() == 0.0 && v < 9.007_199_254_740_992e15;
        if !(count(order) && count(n_equal) && (1.0..=MAX_ORDER as f64).contains(&order)) {
            return None;
        }
        let order = order as usize;
        if d.len() != (order + 3).min(MAX_ORDER + 3) * self.n {
            return None;
        }
        self.d[..d.len()].copy_from_slice(d);
        self.h = h;
        self.order = order;
        self.n_equal_steps = n_equal as usize;
        Some(())
    }

    /// The interpolating polynomial of the history at `t`, the grid ending
    /// at `t_n`:
    /// `p(t) = D_0 + sum_{j=1..k} D_j prod_{m=0..j-1} (t - t_n + m h) / ((m + 1) h)`.
    pub fn interpolate(&self, t: f64, t_n: f64, out: &mut [f64]) {
        out.copy_from_slice(self.d(0));
        if t == t_n {
            return;
        }
        let mut p = 1.0;
        for j in 1..=self.order {
            let m = (j - 1) as f64;
            p *= (t - (t_n - m * self.h)) / ((m + 1.0) * self.h);
            for (o, dj) in out.iter_mut().zip(self.d(j)) {
                *o += p * dj;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The backward differences `nabla^j p(-i h)` of `p` on the grid `0, -h, ..`.
    fn differences(p: impl Fn(f64) -> f64, h: f64, k: usize) -> Vec<f64> {
        let mut v: Vec<f64> = (0..=k).map(|i| p(-(i as f64) * h)).collect();
        let mut d = vec![0.0; k + 1];
        for j in 0..=k {
            d[j] = v[0];
            for i in 0..k - j {
                v[i] -= v[i + 1];
            }
        }
        d
    }

    #[test]
    fn rescaling_the_history_keeps_the_interpolating_polynomial() {
        // D of the cubic p(t) = t^3 on the grid 0, -1, -2, -3 (h = 1), then
        // re-interpolated onto h = 0.37: the new differences are those of p
        // on the grid 0, -0.37, -0.74, -1.11.
        let p = |t: f64| t.powi(3);
        let mut hist = History::new(&[0.0]);
        for (j, dj) in differences(p, 1.0, 3).into_iter().enumerate() {
            hist.d_mut(j)[0] = dj;
        }
        hist.order = 3;
        hist.h = 1.0;
        hist.rescale(0.37);
        for (j, dj) in differences(p, 0.37, 3).into_iter().enumerate() {
            assert!(
                (hist.d(j)[0] - dj).abs() < 1e-12,
                "D_{j}: {} vs {dj}",
                hist.d(j)[0]
            );
        }
        assert!((hist.h - 0.37).abs() < 1e-15);
        // The dense output reproduces the cubic between the grid points.
        let mut out = [0.0];
        for t in [-1.1, -0.5, -0.2, 0.0] {
            hist.interpolate(t, 0.0, &mut out);
            assert!((out[0] - p(t)).abs() < 1e-12, "{t}: {}", out[0]);
        }
    }

    #[test]
    fn the_coefficients_are_those_of_shampine_reichelt() {
        // gamma_2 = 3/2, alpha_2 = (1 + 1/9) 3/2 = 5/3, error constant of
        // NDF2 = -1/9 * 3/2 + 1/3 = 1/6; BDF2's is 1/3.
        let ndf = Coefficients::new(Formula::Ndf);
        assert!((ndf.gamma[2] - 1.5).abs() < 1e-15);
        assert!((ndf.alpha[2] - 5.0 / 3.0).abs() < 1e-15);
        assert!((ndf.error_const[2] - 1.0 / 6.0).abs() < 1e-15);
        let bdf = Coefficients::new(Formula::Bdf);
        assert!((bdf.alpha[2] - 1.5).abs() < 1e-15);
        assert!((bdf.error_const[2] - 1.0 / 3.0).abs() < 1e-15);
    }
}
