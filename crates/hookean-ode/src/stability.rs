//! Linear stability analysis (the tutorial's section 2.2, eqs. 20-31, and
//! figure 4): stability functions, A-stability and sampled stability regions.

use num_complex::Complex64;

use crate::bdf::BdfCoefficients;
use crate::error::OdeError;
use crate::method::Method;

/// The amplification of `method` on Dahlquist's equation `y' = lambda y`
/// (eq. 20) at `z = h lambda`: `|R(z)|` for the one-step methods (eq. 28),
/// the largest root modulus of the characteristic polynomial for BDF(k)
/// (fixed step; `bdf2-variable` is analysed as BDF2). The method is stable
/// at `z` when the value is `<= 1` (eq. 31, closed). `None` for the
/// second-order-only methods (FB Euler, Verlet), which do not apply to
/// eq. (20); see [`oscillator_spectral_radius`] for them.
pub fn amplification(method: &Method, z: Complex64) -> Option<f64> {
    match method {
        Method::Bdf(k) if *k >= 2 => Some(BdfCoefficients::new(*k).ok()?.max_root_modulus(z)),
        Method::Bdf2Variable => Some(BdfCoefficients::new(2).ok()?.max_root_modulus(z)),
        _ => method.tableau().map(|t| t.stability_function(z).norm()),
    }
}

/// The stability function `R(z)` of a one-step method (eq. 28): the
/// tableau formula of [`ButcherTableau::stability_function`](crate::ButcherTableau::stability_function).
/// `None` for multistep and second-order-only methods.
pub fn stability_function(method: &Method, z: Complex64) -> Option<Complex64> {
    method.tableau().map(|t| t.stability_function(z))
}

/// Checks A-stability (the left half-plane lies in the stability region,
/// eq. 27) numerically: the amplification must be `<= 1 + 1e-9` on the
/// imaginary axis (sampled from `1e-4` to `1e8` in both directions, and 0)
/// and on rays into the left half-plane (radii `1e-4..1e8`, 32 angles in
/// `(pi/2, 3pi/2)`), which catches poles and unbounded growth there.
/// `None` for methods without an amplification (see [`amplification`]).
pub fn is_a_stable(method: &Method) -> Option<bool> {
    let tol = 1.0 + 1e-9;
    amplification(method, Complex64::new(0.0, 0.0))?;
    let radii: Vec<f64> = (0..=120)
        .map(|i| 10f64.powf(-4.0 + 0.1 * i as f64))
        .collect();
    for &r in &radii {
        for sign in [1.0, -1.0] {
            if amplification(method, Complex64::new(0.0, sign * r))? > tol {
                return Some(false);
            }
        }
        for a in 1..32 {
            let phi = std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * a as f64 / 32.0;
            if amplification(method, Complex64::from_polar(r, phi))? > tol {
                return Some(false);
            }
        }
    }
    Some(true)
}

/// A rectangular grid of the complex plane: `nx` real parts from `re.0` to
/// `re.1` and `ny` imaginary parts from `im.0` to `im.1` (both inclusive).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComplexGrid {
    /// Range of real parts.
    pub re: (f64, f64),
    /// Range of imaginary parts.
    pub im: (f64, f64),
    /// Number of real parts (columns), at least 2.
    pub nx: usize,
    /// Number of imaginary parts (rows), at least 2.
    pub ny: usize,
}

impl Default for ComplexGrid {
    /// The window of the tutorial's figure 4: `[-5, 3] x [-4, 4]`, 161 x 161.
    fn default() -> Self {
        Self {
            re: (-5.0, 3.0),
            im: (-4.0, 4.0),
            nx: 161,
            ny: 161,
        }
    }
}

impl ComplexGrid {
    /// The point of column `ix`, row `iy`.
    pub fn point(&self, ix: usize, iy: usize) -> Complex64 {
        let fx = ix as f64 / (self.nx - 1) as f64;
        let fy = iy as f64 / (self.ny - 1) as f64;
        Complex64::new(
            self.re.0 + fx * (self.re.1 - self.re.0),
            self.im.0 + fy * (self.im.1 - self.im.0),
        )
    }
}

/// A stability region sampled on a grid (figure 4), for plotting.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionSample {
    /// The grid.
    pub grid: ComplexGrid,
    /// The amplification ([`amplification`]) at each point, row-major:
    /// `values[iy * nx + ix]`.
    pub values: Vec<f64>,
}

impl RegionSample {
    /// True when the point `(ix, iy)` is in the (closed) stability region.
    pub fn is_stable(&self, ix: usize, iy: usize) -> bool {
        self.values[iy * self.grid.nx + ix] <= 1.0 + 1e-12
    }

    /// The fraction of grid points in the stability region.
    pub fn stable_fraction(&self) -> f64 {
        let n = self.values.iter().filter(|v| **v <= 1.0 + 1e-12).count();
        n as f64 / self.values.len() as f64
    }
}

/// Samples the stability region of `method` on `grid`.
///
/// # Errors
/// [`OdeError::InvalidParameter`] for a grid with fewer than 2 points per
/// axis or non-finite/empty ranges; [`OdeError::UnsupportedMethod`] for
/// FB Euler and Verlet.
pub fn sample_region(method: &Method, grid: &ComplexGrid) -> Result<RegionSample, OdeError> {
    if grid.nx < 2 || grid.ny < 2 {
        return Err(OdeError::InvalidParameter {
            name: "grid size",
            value: grid.nx.min(grid.ny) as f64,
            reason: "need at least 2 points per axis",
        });
    }
    for (name, (a, b)) in [("re range", grid.re), ("im range", grid.im)] {
        if !(a.is_finite() && b.is_finite() && a < b) {
            return Err(OdeError::InvalidParameter {
                name,
                value: b - a,
                reason: "need finite lo < hi",
            });
        }
    }
    let mut values = Vec::with_capacity(grid.nx * grid.ny);
    for iy in 0..grid.ny {
        for ix in 0..grid.nx {
            let v = amplification(method, grid.point(ix, iy)).ok_or_else(|| {
                OdeError::UnsupportedMethod {
                    method: method.to_string(),
                    problem: "Dahlquist test equation (first-order)",
                }
            })?;
            values.push(v);
        }
    }
    Ok(RegionSample {
        grid: *grid,
        values,
    })
}

/// The spectral radius of one step of FB Euler or Stoermer-Verlet on the
/// damped oscillator `x'' = -omega^2 x - d x'`, the second-order analogue
/// of eq. (20). FB Euler: `v1 = (1 - h d) v0 - h omega^2 x0`,
/// `x1 = x0 + h v1`. Verlet in the velocity form (44)-(45) with the force
/// `f(x_n, v_{n-1/2})`: the recursion `v_{n+1/2} = (1 - h d) v_{n-1/2} - h
/// omega^2 x_n`, `x_{n+1} = x_n + h v_{n+1/2}` (the same matrix: the two
/// methods differ in where velocities live, not in their stability).
/// The undamped limit is stable for `h omega <= 2`. `None` for other methods.
pub fn oscillator_spectral_radius(method: &Method, h: f64, omega: f64, d: f64) -> Option<f64> {
    if !matches!(method, Method::FbEuler | Method::Verlet) {
        return None;
    }
    // State (x, v): v1 = a v0 - b x0, x1 = x0 + h v1 = (1 - h b) x0 + h a v0.
    let a = 1.0 - h * d;
    let b = h * omega * omega;
    let m = [[1.0 - h * b, h * a], [-b, a]];
    let tr = m[0][0] + m[1][1];
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let disc = tr * tr / 4.0 - det;
    Some(if disc >= 0.0 {
        let s = disc.sqrt();
        (tr / 2.0 + s).abs().max((tr / 2.0 - s).abs())
    } else {
        det.abs().sqrt()
    })
}
