//! The power method for the dominant eigenvalue, with a hook between
//! iterations (the filtering paper's Algorithm 1 plugs its velocity filter in).

use crate::NonExhaustive;
use crate::error::SparseError;
use crate::operator::LinearOperator;

/// A hook applied to the scaled iterate between power iterations.
pub type PowerHook<'a> = &'a mut dyn FnMut(&mut [f64]);

/// Parameters of [`power_method`].
#[derive(Debug, Clone, PartialEq)]
pub struct PowerParams {
    /// Stop when successive estimates differ by at most `rtol` relatively. Default `1e-8`.
    pub rtol: f64,
    /// Iteration limit. Default `10_000`.
    pub max_iter: usize,
    /// Seed of the deterministic pseudo-random start vector. Default `1`.
    pub seed: u64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for PowerParams {
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            max_iter: 10_000,
            seed: 1,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// The result of [`power_method`].
#[derive(Debug, Clone, PartialEq)]
pub struct PowerInfo {
    /// The dominant eigenvalue estimate (signed).
    pub eigenvalue: f64,
    /// The matching eigenvector estimate, scaled to max-norm 1.
    pub eigenvector: Vec<f64>,
    /// Iterations performed.
    pub iterations: usize,
    /// Whether the estimate settled to `rtol`.
    pub converged: bool,
}

/// The power method with max-norm scaling, as the filtering paper's
/// Algorithm 1: `w <- A v; alpha <- max(w); v <- w / alpha; v <- hook(v)`,
/// where `max(w)` is the entry of largest magnitude, signed by `w_i / v_i`
/// (so that an eigenvector with extreme entries `+c` and `-c` keeps a stable
/// sign). At the fixed point `hook(A v) = alpha v`: alpha is the dominant
/// eigenvalue of `hook o A`.
///
/// The start vector is pseudo-random with entries in [0.5, 1.5), deterministic in
/// [`PowerParams::seed`]. `hook` (optional) transforms the scaled vector
/// between iterations; pass `None` for the plain power method.
///
/// # Errors
/// [`SparseError::NonFinite`] if an iterate becomes NaN or infinite,
/// [`SparseError::InvalidParameter`] for a zero-dimensional operator or an
/// iterate that vanishes (the start vector lies in the null space).
///
/// ```
/// use hookean_sparse::{power_method, MatrixFree, PowerParams};
/// let a = MatrixFree::new(3, |x: &[f64], y: &mut [f64]| {
///     y[0] = 2.0 * x[0];
///     y[1] = 5.0 * x[1];
///     y[2] = 1.0 * x[2];
/// });
/// let info = power_method(&a, &PowerParams::default(), None)?;
/// assert!((info.eigenvalue - 5.0).abs() < 1e-6);
/// # Ok::<(), hookean_sparse::SparseError>(())
/// ```
pub fn power_method<A: LinearOperator + ?Sized>(
    a: &A,
    params: &PowerParams,
    hook: Option<PowerHook<'_>>,
) -> Result<PowerInfo, SparseError> {
    let n = a.nrows();
    crate::error::non_empty("operator", n)?;
    let mut v = vec![0.0; n];
    let mut w = vec![0.0; n];
    let (eigenvalue, iterations, converged) =
        power_iterate(a, params, hook, false, &mut v, &mut w)?;
    Ok(PowerInfo {
        eigenvalue,
        eigenvector: v,
        iterations,
        converged,
    })
}

/// [`power_method`] on caller-owned vectors (`v`, `w` of length `a.nrows()`,
/// at least 1): returns `(eigenvalue, iterations, converged)` and leaves the
/// eigenvector estimate in `v`. With `warm`, `v` is the start vector (e.g.
/// the eigenvector of a previous, similar operator) instead of the seeded
/// pseudo-random one. Allocates nothing (multigrid set-ups call it at every
/// refill).
pub(crate) fn power_iterate<A: LinearOperator + ?Sized>(
    a: &A,
    params: &PowerParams,
    mut hook: Option<PowerHook<'_>>,
    warm: bool,
    v: &mut [f64],
    w: &mut [f64],
) -> Result<(f64, usize, bool), SparseError> {
    let mut state = params.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    for vi in v.iter_mut().take(if warm { 0 } else { usize::MAX }) {
        // xorshift64*: deterministic, no dependency.
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        let u = state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        *vi = 0.5 + u as f64 / (1u64 << 53) as f64;
    }
    let mut alpha = 0.0;
    for k in 1..=params.max_iter {
        a.apply(v, w);
        if w.iter().any(|x| !x.is_finite()) {
            return Err(SparseError::NonFinite {
                what: "power method iterate",
                index: None,
            });
        }
        // alpha is the entry of largest magnitude of w (the paper's max(v)),
        // signed by w_i / v_i: an eigenvector with two extreme entries of
        // equal magnitude and opposite signs then keeps a stable sign.
        let i = largest_entry(w);
        let magnitude = w[i].abs();
        if magnitude == 0.0 {
            return Err(SparseError::InvalidParameter {
                name: "operator",
                message: "the power iterate vanished (start vector in the null space?)".into(),
            });
        }
        let sign = if v[i] != 0.0 {
            (w[i] / v[i]).signum()
        } else {
            w[i].signum()
        };
        let new_alpha = sign * magnitude;
        for (vi, wi) in v.iter_mut().zip(w.iter()) {
            *vi = wi / new_alpha;
        }
        if let Some(h) = hook.as_mut() {
            h(v);
        }
        let settled = k > 1 && (new_alpha - alpha).abs() <= params.rtol * new_alpha.abs();
        alpha = new_alpha;
        if settled {
            return Ok((alpha, k, true));
        }
    }
    Ok((alpha, params.max_iter, false))
}

/// Index of the entry of largest magnitude (the first one on ties).
fn largest_entry(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, x) in v.iter().enumerate() {
        if x.abs() > v[best].abs() {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::precond::testutil::*;

    #[test]
    fn symmetric_eigenvector_with_equal_extremes_keeps_a_positive_estimate() {
        // [[1, -1], [-1, 1]]: eigenvalue 2 with eigenvector (1, -1), whose two
        // entries have equal magnitude and opposite signs.
        let a = crate::MatrixFree::new(2, |x: &[f64], y: &mut [f64]| {
            y[0] = x[0] - x[1];
            y[1] = x[1] - x[0];
        });
        let info = power_method(&a, &PowerParams::default(), None).unwrap();
        assert!(info.converged);
        assert!((info.eigenvalue - 2.0).abs() < 1e-12, "{}", info.eigenvalue);
        // A negative dominant eigenvalue keeps its sign.
        let b = crate::MatrixFree::new(2, |x: &[f64], y: &mut [f64]| {
            y[0] = -3.0 * x[0];
            y[1] = 1.0 * x[1];
        });
        let info = power_method(&b, &PowerParams::default(), None).unwrap();
        assert!((info.eigenvalue + 3.0).abs() < 1e-6, "{}", info.eigenvalue);
    }

    #[test]
    fn dominant_eigenvalue_of_the_1d_laplacian() {
        // Eigenvalues of tridiag(-1, 2, -1) of size n: 2 - 2 cos(k pi / (n + 1)).
        let n = 20;
        let a = crate::MatrixFree::new(n, |x: &[f64], y: &mut [f64]| {
            for i in 0..x.len() {
                let l = if i > 0 { x[i - 1] } else { 0.0 };
                let r = if i + 1 < x.len() { x[i + 1] } else { 0.0 };
                y[i] = 2.0 * x[i] - l - r;
            }
        });
        let exact = 2.0 - 2.0 * (n as f64 * std::f64::consts::PI / (n as f64 + 1.0)).cos();
        let info = power_method(
            &a,
            &PowerParams {
                rtol: 1e-12,
                ..Default::default()
            },
            None,
        )
        .unwrap();
        assert!(info.converged);
        assert!(
            (info.eigenvalue - exact).abs() < 1e-6 * exact,
            "{} vs {exact}",
            info.eigenvalue
        );
    }

    #[test]
    fn hook_is_called_between_iterations() {
        let a = spd_block_matrix(2, 2);
        let mut calls = 0;
        let mut hook = |v: &mut [f64]| {
            calls += 1;
            assert!(v.iter().all(|x| x.abs() <= 1.0 + 1e-15));
        };
        let info = power_method(&a, &PowerParams::default(), Some(&mut hook)).unwrap();
        assert_eq!(calls, info.iterations);
    }

    #[test]
    fn a_hook_that_damps_lowers_the_estimate() {
        // Averaging with neighbours kills the alternating (highest) mode of the Laplacian.
        let n = 16;
        let a = crate::MatrixFree::new(n, |x: &[f64], y: &mut [f64]| {
            for i in 0..x.len() {
                let l = if i > 0 { x[i - 1] } else { 0.0 };
                let r = if i + 1 < x.len() { x[i + 1] } else { 0.0 };
                y[i] = 2.0 * x[i] - l - r;
            }
        });
        let plain = power_method(&a, &PowerParams::default(), None).unwrap();
        let mut smooth = |v: &mut [f64]| {
            let old = v.to_vec();
            for i in 0..old.len() {
                let l = if i > 0 { old[i - 1] } else { old[i] };
                let r = if i + 1 < old.len() {
                    old[i + 1]
                } else {
                    old[i]
                };
                v[i] = 0.5 * old[i] + 0.25 * (l + r);
            }
        };
        let filtered = power_method(&a, &PowerParams::default(), Some(&mut smooth)).unwrap();
        assert!(filtered.eigenvalue < 0.75 * plain.eigenvalue);
    }

    #[test]
    fn nan_operator_is_an_error() {
        let a = crate::MatrixFree::new(2, |_x: &[f64], y: &mut [f64]| y.fill(f64::NAN));
        assert!(matches!(
            power_method(&a, &PowerParams::default(), None),
            Err(SparseError::NonFinite { .. })
        ));
    }
}
