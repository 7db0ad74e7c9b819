//! Restarted GMRES (Saad and Schultz, "GMRES: a generalized minimal residual
//! algorithm for solving nonsymmetric linear systems", SIAM J. Sci. Stat.
//! Comput. 7, 1986) with right preconditioning, for general (nonsymmetric)
//! square systems such as the Newton matrix `I - c J` of a stiff first-order
//! problem, where [`pcg`](crate::pcg) does not apply: Arnoldi with modified
//! Gram-Schmidt, the least-squares problem by Givens rotations, every vector
//! in a [`GmresWorkspace`] allocated once.

use crate::NonExhaustive;
use crate::error::{SparseError, check_finite, check_len};
use crate::operator::LinearOperator;
use crate::precond::Preconditioner;
use crate::vecops::{dot, norm2};

/// Parameters of [`gmres`].
#[derive(Debug, Clone, PartialEq)]
pub struct GmresParams {
    /// Krylov dimension `m` per cycle (GMRES(m); CVODE's `maxl`, 5 there).
    /// Default 10.
    pub krylov_dim: usize,
    /// Restarts after the first cycle (CVODE's `maxrs`, 0 there). Default 2.
    pub restarts: usize,
    /// Stop when `|b - A x| <= rtol |b|`. Default `1e-8`.
    pub rtol: f64,
    /// ... or when `|b - A x| <= atol`. Default `0`.
    pub atol: f64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for GmresParams {
    fn default() -> Self {
        Self {
            krylov_dim: 10,
            restarts: 2,
            rtol: 1e-8,
            atol: 0.0,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// What a GMRES run did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GmresInfo {
    /// Products with `A` (one per Arnoldi step, one per true residual at
    /// the end of each cycle).
    pub iterations: usize,
    /// Applications of the preconditioner.
    pub preconditioner_solves: usize,
    /// The true `|b - A x|` of the returned `x`, computed by a product.
    pub residual_norm: f64,
    /// `residual_norm / |b|` (`residual_norm` for `b = 0`).
    pub relative_residual: f64,
    /// The least-squares residual of the last cycle: the recursive estimate
    /// of `|b - A x|` (exact in exact arithmetic, GMRES minimises the true
    /// residual under right preconditioning; round-off makes them drift).
    /// Equal to `residual_norm` when no cycle ran.
    pub recursive_residual_norm: f64,
    /// Whether the true residual met the tolerance.
    pub converged: bool,
}

/// The Arnoldi basis, the Hessenberg matrix and the rotations of
/// GMRES(`m`) in dimension `n`. Create once, reuse for every solve of the
/// same shape: solves then allocate nothing.
#[derive(Debug, Clone, Default)]
pub struct GmresWorkspace {
    n: usize,
    m: usize,
    /// `v_0..v_m`, `n` values each.
    v: Vec<f64>,
    /// The Hessenberg matrix by columns, `(m + 1) x m`.
    h: Vec<f64>,
    cs: Vec<f64>,
    sn: Vec<f64>,
    /// The right-hand side of the least-squares problem, `|r_0| e_1` rotated.
    g: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    w: Vec<f64>,
}

impl GmresWorkspace {
    /// A workspace for Krylov dimension `m` (at least 1) in dimension `n`
    /// (about `8 n (m + 3)` bytes).
    ///
    /// # Panics
    /// If `n (m + 1)` overflows or the allocator cannot give the basis (as
    /// `Vec` does); [`try_new`](Self::try_new) returns an error instead.
    pub fn new(n: usize, m: usize) -> Self {
        let m = m.max(1);
        Self {
            n,
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

    /// A workspace as [`new`](Self::new) gives, or an error where it panics.
    ///
    /// # Errors
    /// [`SparseError::TooLarge`] if the basis and the Hessenberg matrix
    /// cannot be allocated (or their sizes overflow).
    pub fn try_new(n: usize, m: usize) -> Result<Self, SparseError> {
        let what = "GMRES workspace";
        let m = m.max(1);
        let overflow = SparseError::TooLarge {
            what,
            entries: n,
            bytes: None,
        };
        let basis = n.checked_mul(m + 1).ok_or(overflow.clone())?;
        let hessenberg = (m + 1).checked_mul(m).ok_or(overflow.clone())?;
        let total = [basis, hessenberg, 2 * n, 4 * m + 1]
            .iter()
            .try_fold(0usize, |acc, &k| acc.checked_add(k))
            .ok_or(overflow)?;
        crate::error::try_grow(what, &mut Vec::<f64>::new(), total)?;
        Ok(Self::new(n, m))
    }

    fn ensure(&mut self, n: usize, m: usize) -> Result<(), SparseError> {
        if self.n != n || self.m != m.max(1) {
            *self = Self::try_new(n, m)?;
        }
        Ok(())
    }
}

/// Solves `A x = b` by restarted, right-preconditioned GMRES from `x = 0`:
/// GMRES runs on `A M^-1` (`M^-1` the preconditioner's `apply`), so the
/// residual it minimises is the true one, and stops when
/// `|b - A x| <= max(rtol |b|, atol)` or after `restarts + 1` cycles of
/// [`krylov_dim`](GmresParams::krylov_dim) steps. A cycle ends when its
/// least-squares residual (the recursive estimate) meets the tolerance;
/// the true residual `b - A x`, computed by one product, then decides: a
/// solve that missed the tolerance goes on to the next cycle from it.
///
/// Returns [`GmresInfo`] with `converged = false` when the cycles run out
/// without the true residual meeting the tolerance.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] for wrong sizes (of `b`, `x`, the
/// preconditioner), [`SparseError::NonFinite`] for NaN or infinite `b`,
/// [`SparseError::InvalidParameter`] for `krylov_dim = 0` or a negative tolerance.
///
/// ```
/// use hookean_sparse::{GmresParams, GmresWorkspace, Identity, gmres};
/// // A nonsymmetric 2 x 2 system: [[4, 1], [-2, 3]] x = [1, 2].
/// let a = sprs::CsMat::new((2, 2), vec![0, 2, 4], vec![0, 1, 0, 1], vec![4.0, 1.0, -2.0, 3.0]);
/// let mut x = [0.0; 2];
/// let params = GmresParams { rtol: 1e-12, ..GmresParams::default() };
/// let info = gmres(&a, &Identity, &[1.0, 2.0], &mut x, &params, &mut GmresWorkspace::new(2, 2))?;
/// // Two Arnoldi products, one for the true residual.
/// assert!(info.converged && info.iterations <= 3);
/// assert!((x[0] - 1.0 / 14.0).abs() < 1e-12 && (x[1] - 5.0 / 7.0).abs() < 1e-12);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
pub fn gmres<A, P>(
    a: &A,
    precond: &P,
    b: &[f64],
    x: &mut [f64],
    params: &GmresParams,
    workspace: &mut GmresWorkspace,
) -> Result<GmresInfo, SparseError>
where
    A: LinearOperator + ?Sized,
    P: Preconditioner + ?Sized,
{
    let n = a.nrows();
    check_len("right-hand side", b, n)?;
    check_len("solution", x, n)?;
    if let Some(d) = precond.dim()
        && d != n
    {
        return Err(SparseError::DimensionMismatch {
            what: "preconditioner",
            expected: n,
            found: d,
        });
    }
    if params.krylov_dim == 0 {
        return Err(SparseError::InvalidParameter {
            name: "krylov_dim",
            message: "must be at least 1".into(),
        });
    }
    if !(params.rtol >= 0.0 && params.atol >= 0.0) {
        return Err(SparseError::InvalidParameter {
            name: "rtol/atol",
            message: format!(
                "must be non-negative, got {:?}, {:?}",
                params.rtol, params.atol
            ),
        });
    }
    check_finite("right-hand side", b)?;
    workspace.ensure(n, params.krylov_dim)?;
    let b_norm = norm2(b);
    let tol = (params.rtol * b_norm).max(params.atol);
    let mut info = run(a, precond, b, x, tol, params.restarts, workspace);
    info.relative_residual = if b_norm > 0.0 {
        info.residual_norm / b_norm
    } else {
        info.residual_norm
    };
    Ok(info)
}

/// The cycles of [`gmres`], after its checks.
fn run<A, P>(
    a: &A,
    precond: &P,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    restarts: usize,
    ws: &mut GmresWorkspace,
) -> GmresInfo
where
    A: LinearOperator + ?Sized,
    P: Preconditioner + ?Sized,
{
    let (n, m) = (ws.n, ws.m);
    x.fill(0.0);
    let mut out = GmresInfo::default();
    // Each cycle starts from the true residual of the last one's x, which
    // decides convergence; the pass after the last cycle only checks it.
    for cycle in 0..=restarts + 1 {
        // r_0 = b - A x into v_0.
        let (v0, _) = ws.v.split_at_mut(n);
        if cycle == 0 {
            v0.copy_from_slice(b);
        } else {
            a.apply(x, &mut ws.w);
            out.iterations += 1;
            for ((r, bi), ax) in v0.iter_mut().zip(b).zip(&ws.w) {
                *r = bi - ax;
            }
        }
        let beta = norm2(v0);
        out.residual_norm = beta;
        if cycle == 0 {
            out.recursive_residual_norm = beta;
        }
        if beta <= tol {
            out.converged = true;
            return out;
        }
        if cycle > restarts {
            return out;
        }
        v0.iter_mut().for_each(|r| *r /= beta);
        ws.g.fill(0.0);
        ws.g[0] = beta;
        let mut k = 0;
        while k < m {
            // w = A M^-1 v_k, orthogonalised against v_0..v_k.
            precond.apply(&ws.v[k * n..(k + 1) * n], &mut ws.z);
            out.preconditioner_solves += 1;
            a.apply(&ws.z, &mut ws.w);
            out.iterations += 1;
            let col = &mut ws.h[k * (m + 1)..(k + 1) * (m + 1)];
            for (i, hik) in col.iter_mut().enumerate().take(k + 1) {
                let vi = &ws.v[i * n..(i + 1) * n];
                *hik = dot(&ws.w, vi);
                for (wj, vj) in ws.w.iter_mut().zip(vi) {
                    *wj -= *hik * vj;
                }
            }
            let hnext = norm2(&ws.w);
            col[k + 1] = hnext;
            if hnext > 0.0 {
                let vk1 = &mut ws.v[(k + 1) * n..(k + 2) * n];
                for (a, wi) in vk1.iter_mut().zip(&ws.w) {
                    *a = wi / hnext;
                }
            }
            // The earlier rotations, then a new one to zero h_{k+1,k}.
            for i in 0..k {
                let (p, q) = (col[i], col[i + 1]);
                col[i] = ws.cs[i] * p + ws.sn[i] * q;
                col[i + 1] = -ws.sn[i] * p + ws.cs[i] * q;
            }
            let (p, q) = (col[k], col[k + 1]);
            let r = p.hypot(q);
            let (c, s) = if r > 0.0 { (p / r, q / r) } else { (1.0, 0.0) };
            ws.cs[k] = c;
            ws.sn[k] = s;
            col[k] = r;
            col[k + 1] = 0.0;
            ws.g[k + 1] = -s * ws.g[k];
            ws.g[k] *= c;
            k += 1;
            if ws.g[k].abs() <= tol || hnext == 0.0 {
                break;
            }
        }
        // y = H^-1 g (upper triangular), x += M^-1 (V y).
        for i in (0..k).rev() {
            let mut s = ws.g[i];
            for j in i + 1..k {
                s -= ws.h[j * (m + 1) + i] * ws.y[j];
            }
            let hii = ws.h[i * (m + 1) + i];
            ws.y[i] = if hii != 0.0 { s / hii } else { 0.0 };
        }
        ws.w.fill(0.0);
        for j in 0..k {
            let yj = ws.y[j];
            for (wi, vi) in ws.w.iter_mut().zip(&ws.v[j * n..(j + 1) * n]) {
                *wi += yj * vi;
            }
        }
        precond.apply(&ws.w, &mut ws.z);
        out.preconditioner_solves += 1;
        for (xi, zi) in x.iter_mut().zip(&ws.z) {
            *xi += zi;
        }
        out.recursive_residual_norm = ws.g[k].abs();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::operator::MatrixFree;
    use crate::precond::Identity;

    /// A non-symmetric, non-normal matrix (convection-diffusion-like).
    fn convection(u: &[f64], out: &mut [f64]) {
        let n = u.len();
        for i in 0..n {
            let left = if i > 0 { u[i - 1] } else { 0.0 };
            let right = if i + 1 < n { u[i + 1] } else { 0.0 };
            out[i] = 4.0 * u[i] - 2.5 * left - 0.5 * right;
        }
    }

    fn residual(x: &[f64], b: &[f64]) -> f64 {
        let mut ax = vec![0.0; x.len()];
        convection(x, &mut ax);
        ax.iter()
            .zip(b)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    #[test]
    fn full_gmres_solves_exactly_in_n_iterations() {
        // In exact arithmetic GMRES(n) finds the solution in at most n steps.
        let n = 6;
        let a = MatrixFree::new(n, convection);
        let b: Vec<f64> = (0..n).map(|i| (i as f64 + 1.0).sin()).collect();
        let mut x = vec![0.0; n];
        let params = GmresParams {
            krylov_dim: n,
            restarts: 0,
            rtol: 0.0,
            atol: 1e-12,
            ..Default::default()
        };
        let mut ws = GmresWorkspace::new(n, n);
        let info = gmres(&a, &Identity, &b, &mut x, &params, &mut ws).unwrap();
        // n Arnoldi products and the true residual's.
        assert!(info.converged && info.iterations <= n + 1, "{info:?}");
        assert!(residual(&x, &b) < 1e-11);
        // The reported residual is the true one, to round-off.
        assert!((info.residual_norm - residual(&x, &b)).abs() < 1e-11);
    }

    #[test]
    fn restarts_and_an_exact_preconditioner() {
        let n = 6;
        let a = MatrixFree::new(n, convection);
        let b = vec![1.0; n];
        // GMRES(2) with restarts reaches the tolerance.
        let mut x = vec![0.0; n];
        let params = GmresParams {
            krylov_dim: 2,
            restarts: 50,
            rtol: 0.0,
            atol: 1e-10,
            ..Default::default()
        };
        let info = gmres(
            &a,
            &Identity,
            &b,
            &mut x,
            &params,
            &mut GmresWorkspace::new(n, 2),
        );
        assert!(info.unwrap().converged);
        assert!(residual(&x, &b) <= 1e-10);
        // With M = A (its lower bidiagonal part is exact for a lower
        // bidiagonal A) one iteration suffices.
        struct LowerInverse;
        impl Preconditioner for LowerInverse {
            fn dim(&self) -> Option<usize> {
                None
            }
            fn apply(&self, u: &[f64], z: &mut [f64]) {
                for i in 0..u.len() {
                    let left = if i > 0 { z[i - 1] } else { 0.0 };
                    z[i] = (u[i] + 2.5 * left) / 4.0;
                }
            }
        }
        let lower = MatrixFree::new(n, |u: &[f64], out: &mut [f64]| {
            for i in 0..u.len() {
                let left = if i > 0 { u[i - 1] } else { 0.0 };
                out[i] = 4.0 * u[i] - 2.5 * left;
            }
        });
        let params = GmresParams {
            krylov_dim: 3,
            restarts: 0,
            rtol: 1e-12,
            atol: 0.0,
            ..Default::default()
        };
        let mut ws = GmresWorkspace::new(n, 3);
        let info = gmres(&lower, &LowerInverse, &b, &mut x, &params, &mut ws).unwrap();
        // One Arnoldi product and the true residual's.
        assert!(info.converged && info.iterations == 2, "{info:?}");
        assert!(x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn bad_input_is_an_error() {
        let a = MatrixFree::new(3, convection);
        let mut ws = GmresWorkspace::default();
        let p = GmresParams::default();
        assert!(gmres(&a, &Identity, &[1.0; 2], &mut [0.0; 3], &p, &mut ws).is_err());
        assert!(gmres(&a, &Identity, &[f64::NAN; 3], &mut [0.0; 3], &p, &mut ws).is_err());
        let zero = GmresParams {
            krylov_dim: 0,
            ..GmresParams::default()
        };
        assert!(gmres(&a, &Identity, &[1.0; 3], &mut [0.0; 3], &zero, &mut ws).is_err());
    }
}
