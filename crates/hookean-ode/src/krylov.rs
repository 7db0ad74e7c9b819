//! Restarted GMRES (Saad and Schultz, "GMRES: a generalized minimal residual
//! algorithm for solving nonsymmetric linear systems", SIAM J. Sci. Stat.
//! Comput. 7, 1986) with right preconditioning, for the matrix-free Newton
//! solves of [`BdfSolver`](crate::BdfSolver): Arnoldi with modified
//! Gram-Schmidt, the least-squares problem by Givens rotations, all
//! workspace allocated once. hookean-sparse has CG for symmetric positive
//! definite matrices only; `I - c J` of a first-order problem is not.

/// The workspace of GMRES(m) in dimension `n`.
#[derive(Debug, Clone)]
pub(crate) struct Gmres {
    m: usize,
    /// The Arnoldi basis `v_0..v_m`, `n` values each.
    v: Vec<f64>,
    /// The Hessenberg matrix by columns, `(m + 1) x m`.
    h: Vec<f64>,
    cs: Vec<f64>,
    sn: Vec<f64>,
    /// The right-hand side of the least-squares problem, `||r_0|| e_1` rotated.
    g: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    w: Vec<f64>,
}

/// What one GMRES solve did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GmresOutcome {
    /// Krylov iterations (products with the matrix).
    pub iterations: usize,
    /// Preconditioner applications.
    pub preconditioner_solves: usize,
    /// Whether `||b - A x||_2 <= tol` was reached.
    pub converged: bool,
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

impl Gmres {
    /// Workspace for Krylov dimension `m` (at least 1) in dimension `n`.
    pub(crate) fn new(n: usize, m: usize) -> Self {
        let m = m.max(1);
        Self {
            m,
            v: vec![0.0; n * (m + 1)],
            h: vec![0.0; (m + 1) * m],
            cs: vec![0.0; m],
            sn: vec![0.0; m],
            g: vec![0.0; m + 1],
            y: vec![0.0; m],
            z: vec![0.0; n],
            w: vec![0.0; n],
        }
    }

    /// Solves `A x = b` from `x = 0` until `||b - A x||_2 <= tol`, with at
    /// most `restarts` restarts of `m` iterations each. `apply_a(u, out)`
    /// writes `A u`, `apply_pinv(u, out)` writes `P^-1 u` (right
    /// preconditioning: GMRES runs on `A P^-1`, so the residual it
    /// minimises is the true one).
    pub(crate) fn solve(
        &mut self,
        b: &[f64],
        x: &mut [f64],
        tol: f64,
        restarts: usize,
        mut apply_a: impl FnMut(&[f64], &mut [f64]),
        mut apply_pinv: impl FnMut(&[f64], &mut [f64]),
    ) -> GmresOutcome {
        let n = b.len();
        let m = self.m;
        x.fill(0.0);
        let mut out = GmresOutcome {
            iterations: 0,
            preconditioner_solves: 0,
            converged: false,
        };
        for cycle in 0..=restarts {
            // r_0 = b - A x into v_0.
            let (v0, _) = self.v.split_at_mut(n);
            if cycle == 0 {
                v0.copy_from_slice(b);
            } else {
                apply_a(x, &mut self.w);
                out.iterations += 1;
                for ((r, bi), ax) in v0.iter_mut().zip(b).zip(&self.w) {
                    *r = bi - ax;
                }
            }
            let beta = dot(v0, v0).sqrt();
            if beta <= tol {
                out.converged = true;
                return out;
            }
            v0.iter_mut().for_each(|r| *r /= beta);
            self.g.fill(0.0);
            self.g[0] = beta;
            let mut k = 0;
            while k < m {
                // w = A P^-1 v_k, orthogonalised against v_0..v_k.
                apply_pinv(&self.v[k * n..(k + 1) * n], &mut self.z);
                out.preconditioner_solves += 1;
                apply_a(&self.z, &mut self.w);
                out.iterations += 1;
                let col = &mut self.h[k * (m + 1)..(k + 1) * (m + 1)];
                for (i, hik) in col.iter_mut().enumerate().take(k + 1) {
                    let vi = &self.v[i * n..(i + 1) * n];
                    *hik = dot(&self.w, vi);
                    axpy(-*hik, vi, &mut self.w);
                }
                let hnext = dot(&self.w, &self.w).sqrt();
                col[k + 1] = hnext;
                if hnext > 0.0 {
                    let vk1 = &mut self.v[(k + 1) * n..(k + 2) * n];
                    for (a, wi) in vk1.iter_mut().zip(&self.w) {
                        *a = wi / hnext;
                    }
                }
                // The earlier rotations, then a new one to zero h_{k+1,k}.
                for i in 0..k {
                    let (a, bb) = (col[i], col[i + 1]);
                    col[i] = self.cs[i] * a + self.sn[i] * bb;
                    col[i + 1] = -self.sn[i] * a + self.cs[i] * bb;
                }
                let (a, bb) = (col[k], col[k + 1]);
                let r = a.hypot(bb);
                let (c, s) = if r > 0.0 { (a / r, bb / r) } else { (1.0, 0.0) };
                self.cs[k] = c;
                self.sn[k] = s;
                col[k] = r;
                col[k + 1] = 0.0;
                self.g[k + 1] = -s * self.g[k];
                self.g[k] *= c;
                k += 1;
                if self.g[k].abs() <= tol || hnext == 0.0 {
                    break;
                }
            }
            // y = H^-1 g (upper triangular), x += P^-1 (V y).
            for i in (0..k).rev() {
                let mut s = self.g[i];
                for j in i + 1..k {
                    s -= self.h[j * (m + 1) + i] * self.y[j];
                }
                let hii = self.h[i * (m + 1) + i];
                self.y[i] = if hii != 0.0 { s / hii } else { 0.0 };
            }
            self.w.fill(0.0);
            for j in 0..k {
                axpy(self.y[j], &self.v[j * n..(j + 1) * n], &mut self.w);
            }
            apply_pinv(&self.w, &mut self.z);
            out.preconditioner_solves += 1;
            axpy(1.0, &self.z, x);
            if self.g[k].abs() <= tol {
                out.converged = true;
                return out;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A non-symmetric, non-normal 6 x 6 matrix (convection-diffusion-like).
    fn a(u: &[f64], out: &mut [f64]) {
        let n = u.len();
        for i in 0..n {
            let left = if i > 0 { u[i - 1] } else { 0.0 };
            let right = if i + 1 < n { u[i + 1] } else { 0.0 };
            out[i] = 4.0 * u[i] - 2.5 * left - 0.5 * right;
        }
    }

    #[test]
    fn full_gmres_solves_exactly_in_n_iterations() {
        // In exact arithmetic GMRES(n) finds the solution in at most n steps.
        let n = 6;
        let b: Vec<f64> = (0..n).map(|i| (i as f64 + 1.0).sin()).collect();
        let mut x = vec![0.0; n];
        let mut g = Gmres::new(n, n);
        let out = g.solve(&b, &mut x, 1e-12, 0, a, |u, z| z.copy_from_slice(u));
        assert!(out.converged && out.iterations <= n, "{out:?}");
        let mut ax = vec![0.0; n];
        a(&x, &mut ax);
        for i in 0..n {
            assert!((ax[i] - b[i]).abs() < 1e-11, "{i}: {} vs {}", ax[i], b[i]);
        }
    }

    #[test]
    fn restarts_and_an_exact_preconditioner() {
        let n = 6;
        let b = vec![1.0; n];
        // GMRES(2) with restarts reaches the tolerance.
        let mut x = vec![0.0; n];
        let mut g = Gmres::new(n, 2);
        let out = g.solve(&b, &mut x, 1e-10, 50, a, |u, z| z.copy_from_slice(u));
        assert!(out.converged, "{out:?}");
        let mut ax = vec![0.0; n];
        a(&x, &mut ax);
        let res: f64 = ax.iter().zip(&b).map(|(p, q)| (p - q).powi(2)).sum::<f64>();
        assert!(res.sqrt() <= 1e-10);
        // With P = A (the lower bidiagonal part is exact for a lower
        // bidiagonal A) one iteration suffices.
        let lower = |u: &[f64], out: &mut [f64]| {
            for i in 0..u.len() {
                let left = if i > 0 { u[i - 1] } else { 0.0 };
                out[i] = 4.0 * u[i] - 2.5 * left;
            }
        };
        let lower_inv = |u: &[f64], z: &mut [f64]| {
            for i in 0..u.len() {
                let left = if i > 0 { z[i - 1] } else { 0.0 };
                z[i] = (u[i] + 2.5 * left) / 4.0;
            }
        };
        let mut g = Gmres::new(n, 3);
        let out = g.solve(&b, &mut x, 1e-12, 0, lower, lower_inv);
        assert!(out.converged && out.iterations == 1, "{out:?}");
        assert!(x.iter().all(|v| v.is_finite()));
    }
}
