//! The stability criterion of section 6: `dt_max = 2 / sqrt(k0)` (eq. 11),
//! with `k0` from the modified power method (Algorithm 1).

use hookean_sparse::{LinearOperator, PowerInfo, PowerParams, power_method};

use crate::error::FilterError;
use crate::velocity::VelocityFilter;

/// The explicit schemes the criterion covers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExplicitScheme {
    /// Forward Euler.
    ForwardEuler,
    /// Forward-backward (symplectic) Euler.
    ForwardBackwardEuler,
    /// Stoermer-Verlet.
    Verlet,
    /// Classical Runge-Kutta of order 4.
    Rk4,
}

impl ExplicitScheme {
    /// The scheme of an explicit `hookean-ode` method that eq. 11 covers
    /// (explicit Euler, FB Euler, Verlet, RK4); `None` otherwise.
    pub fn from_method(method: &hookean_ode::Method) -> Option<Self> {
        use hookean_ode::Method;
        match method {
            Method::ExplicitEuler => Some(ExplicitScheme::ForwardEuler),
            Method::FbEuler => Some(ExplicitScheme::ForwardBackwardEuler),
            Method::Verlet => Some(ExplicitScheme::Verlet),
            Method::Rk4 => Some(ExplicitScheme::Rk4),
            _ => None,
        }
    }

    /// The constant `c` of `dt_max = c / sqrt(k0)`: 2 for forward Euler,
    /// forward-backward Euler and Verlet (eq. 11), `sqrt(8.75)` for RK4
    /// (Shinya 2005, as the paper's section 7.2 uses).
    pub fn stability_constant(self) -> f64 {
        match self {
            ExplicitScheme::ForwardEuler
            | ExplicitScheme::ForwardBackwardEuler
            | ExplicitScheme::Verlet => 2.0,
            ExplicitScheme::Rk4 => 8.75_f64.sqrt(),
        }
    }
}

/// `dt_max = c / sqrt(k0)` for the scheme (eq. 11).
///
/// ```
/// use hookean_filter::{dt_max, ExplicitScheme};
/// assert_eq!(dt_max(1e4, ExplicitScheme::ForwardBackwardEuler), 0.02);
/// ```
pub fn dt_max(k0: f64, scheme: ExplicitScheme) -> f64 {
    scheme.stability_constant() / k0.sqrt()
}

/// The modified power method (Algorithm 1): the dominant eigenvalue `k0` of
/// the stiffness operator `M^-1 K` (`K = -df/dx`), with the velocity filter
/// applied to the iterate between iterations (`None`: the plain power method).
///
/// # Errors
/// [`FilterError::DimensionMismatch`] if the filter and the operator disagree
/// in size; the power method's errors as [`FilterError::Sparse`].
pub fn filtered_k0<A: LinearOperator + ?Sized>(
    stiffness: &A,
    filter: Option<&mut VelocityFilter>,
    params: &PowerParams,
) -> Result<PowerInfo, FilterError> {
    match filter {
        None => Ok(power_method(stiffness, params, None)?),
        Some(f) => {
            if 3 * f.n_particles() != stiffness.nrows() {
                return Err(FilterError::DimensionMismatch {
                    what: "filter (3 x particles) against the stiffness operator",
                    expected: stiffness.nrows(),
                    found: 3 * f.n_particles(),
                });
            }
            let mut hook = |v: &mut [f64]| f.apply_unchecked(v);
            Ok(power_method(stiffness, params, Some(&mut hook))?)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::velocity::{Edge, FilterOptions};
    use hookean_sparse::MatrixFree;

    /// M^-1 K of a free chain of n unit masses and unit springs along x only
    /// (the path-graph Laplacian on the x components; y and z carry no stiffness).
    fn chain_stiffness(n: usize) -> impl LinearOperator {
        MatrixFree::new(3 * n, move |x: &[f64], y: &mut [f64]| {
            y.fill(0.0);
            for i in 1..n {
                let d = x[3 * i] - x[3 * (i - 1)];
                y[3 * i] += d;
                y[3 * (i - 1)] -= d;
            }
        })
    }

    #[test]
    fn unfiltered_k0_is_the_largest_laplacian_eigenvalue() {
        // Path graph Laplacian eigenvalues: 2 - 2 cos(k pi / n), k = 0..n-1.
        let n = 12;
        let exact = 2.0 - 2.0 * ((n - 1) as f64 * std::f64::consts::PI / n as f64).cos();
        let info = filtered_k0(
            &chain_stiffness(n),
            None,
            &PowerParams {
                rtol: 1e-12,
                ..Default::default()
            },
        )
        .unwrap();
        assert!((info.eigenvalue - exact).abs() < 1e-6 * exact);
        assert!(
            (dt_max(info.eigenvalue, ExplicitScheme::Verlet) - 2.0 / exact.sqrt()).abs() < 1e-6
        );
    }

    #[test]
    fn filtering_lowers_k0_and_raises_dt_max() {
        let n = 12;
        let edges: Vec<Edge> = (1..n)
            .map(|i| Edge {
                i: i - 1,
                j: i,
                rest_length: 1.0,
            })
            .collect();
        let plain = filtered_k0(&chain_stiffness(n), None, &PowerParams::default()).unwrap();
        let mut f = VelocityFilter::new(n, &edges, None, FilterOptions::default()).unwrap();
        let filtered =
            filtered_k0(&chain_stiffness(n), Some(&mut f), &PowerParams::default()).unwrap();
        assert!(
            filtered.eigenvalue < 0.8 * plain.eigenvalue,
            "{} vs {}",
            filtered.eigenvalue,
            plain.eigenvalue
        );
        let bad = VelocityFilter::new(3, &edges[..2], None, FilterOptions::default()).unwrap();
        let mut bad = bad;
        assert!(matches!(
            filtered_k0(&chain_stiffness(n), Some(&mut bad), &PowerParams::default()),
            Err(FilterError::DimensionMismatch { .. })
        ));
    }

    #[test]
    fn rk4_constant_is_sqrt_8_75() {
        assert!((ExplicitScheme::Rk4.stability_constant() - 2.958_039_891_549_808).abs() < 1e-12);
    }
}
