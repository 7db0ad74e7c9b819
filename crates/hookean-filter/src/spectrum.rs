//! Frequency analysis of a cloth grid's velocity field (section 5 and
//! figures 4 and 5 of the filtering paper).

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;

use crate::error::FilterError;

/// The 2D discrete Fourier transform of an `nx x ny` grid's velocity field
/// (particle `(x, y)` at index `y nx + x`, 3 velocity components each): the
/// power `|V(kx, ky)|^2` summed over the components, row-major in `ky`,
/// with the zero frequency at index 0 (unshifted; see [`fftshift`]).
///
/// # Errors
/// [`FilterError::GridMismatch`] if `v.len() != 3 nx ny`;
/// [`FilterError::NonFinite`] for NaN velocities.
pub fn power_spectrum(v: &[f64], nx: usize, ny: usize) -> Result<Vec<f64>, FilterError> {
    if v.len() != 3 * nx * ny || nx == 0 || ny == 0 {
        return Err(FilterError::GridMismatch {
            nx,
            ny,
            particles: v.len() / 3,
        });
    }
    if v.iter().any(|x| !x.is_finite()) {
        return Err(FilterError::NonFinite {
            what: "velocity field",
        });
    }
    let mut planner = FftPlanner::<f64>::new();
    let fx = planner.plan_fft_forward(nx);
    let fy = planner.plan_fft_forward(ny);
    let mut power = vec![0.0; nx * ny];
    let mut grid = vec![Complex::new(0.0, 0.0); nx * ny];
    let mut column = vec![Complex::new(0.0, 0.0); ny];
    for c in 0..3 {
        for (g, p) in grid.iter_mut().zip(v.chunks_exact(3)) {
            *g = Complex::new(p[c], 0.0);
        }
        for row in grid.chunks_exact_mut(nx) {
            fx.process(row);
        }
        for x in 0..nx {
            for y in 0..ny {
                column[y] = grid[y * nx + x];
            }
            fy.process(&mut column);
            for y in 0..ny {
                grid[y * nx + x] = column[y];
            }
        }
        for (p, g) in power.iter_mut().zip(&grid) {
            *p += g.norm_sqr();
        }
    }
    Ok(power)
}

/// Moves the zero frequency of an `nx x ny` spectrum to the centre, for pictures.
pub fn fftshift(spectrum: &[f64], nx: usize, ny: usize) -> Vec<f64> {
    let mut out = vec![0.0; nx * ny];
    for y in 0..ny {
        for x in 0..nx {
            out[((y + ny / 2) % ny) * nx + (x + nx / 2) % nx] = spectrum[y * nx + x];
        }
    }
    out
}

/// The share of the velocity field's non-constant energy at high spatial
/// frequency: `sum_{r > cutoff} |V|^2 / sum_{k != 0} |V|^2`, where
/// `r = sqrt((kx / (nx/2))^2 + (ky / (ny/2))^2)` is the frequency radius
/// relative to Nyquist (signed wave numbers). `cutoff = 0.5` splits the band
/// in the middle. Returns 0 for a uniform field.
///
/// # Errors
/// As [`power_spectrum`].
pub fn high_frequency_fraction(
    v: &[f64],
    nx: usize,
    ny: usize,
    cutoff: f64,
) -> Result<f64, FilterError> {
    let p = power_spectrum(v, nx, ny)?;
    let signed = |k: usize, n: usize| {
        if k <= n / 2 {
            k as f64
        } else {
            k as f64 - n as f64
        }
    };
    let (mut high, mut total) = (0.0, 0.0);
    for ky in 0..ny {
        for kx in 0..nx {
            if kx == 0 && ky == 0 {
                continue;
            }
            let rx = signed(kx, nx) / (nx as f64 / 2.0).max(1.0);
            let ry = signed(ky, ny) / (ny as f64 / 2.0).max(1.0);
            let e = p[ky * nx + kx];
            total += e;
            if (rx * rx + ry * ry).sqrt() > cutoff {
                high += e;
            }
        }
    }
    Ok(if total > 0.0 { high / total } else { 0.0 })
}

/// The picture of the paper's figure 4: one row of pixels per time step, one
/// pixel per particle (grid flattened row by row, figure 3), the velocity
/// mapped to RGB (`128 + 127 v_c / scale`, clamped).
#[derive(Debug, Clone, Default)]
pub struct VelocityImage {
    width: usize,
    rows: Vec<[u8; 3]>,
}

impl VelocityImage {
    /// An empty picture for `n_particles` particles.
    pub fn new(n_particles: usize) -> Self {
        Self {
            width: n_particles,
            rows: Vec::new(),
        }
    }

    /// Appends the row of one step, with velocities scaled by `scale` (m/s).
    ///
    /// # Errors
    /// [`FilterError::DimensionMismatch`] if `v.len() != 3 width`.
    pub fn push(&mut self, v: &[f64], scale: f64) -> Result<(), FilterError> {
        if v.len() != 3 * self.width {
            return Err(FilterError::DimensionMismatch {
                what: "velocity vector",
                expected: 3 * self.width,
                found: v.len(),
            });
        }
        let s = if scale > 0.0 { scale } else { 1.0 };
        for p in v.chunks_exact(3) {
            let px = [0, 1, 2].map(|c| {
                let t = (p[c] / s).clamp(-1.0, 1.0);
                if t.is_nan() {
                    128
                } else {
                    (128.0 + 127.0 * t).round() as u8
                }
            });
            self.rows.push(px);
        }
        Ok(())
    }

    /// Width in pixels (particles).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels (steps pushed).
    pub fn height(&self) -> usize {
        self.rows.len().checked_div(self.width).unwrap_or(0)
    }

    /// The pixels, row-major.
    pub fn pixels(&self) -> &[[u8; 3]] {
        &self.rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(nx: usize, ny: usize, f: impl Fn(usize, usize) -> f64) -> Vec<f64> {
        let mut v = Vec::new();
        for y in 0..ny {
            for x in 0..nx {
                v.extend([f(x, y), 0.0, 0.0]);
            }
        }
        v
    }

    #[test]
    fn a_single_cosine_lands_in_its_two_bins() {
        let (nx, ny) = (16, 8);
        let v = field(nx, ny, |x, _| {
            (2.0 * std::f64::consts::PI * 3.0 * x as f64 / nx as f64).cos()
        });
        let p = power_spectrum(&v, nx, ny).unwrap();
        // cos splits into kx = 3 and kx = nx - 3, each with amplitude nx ny / 2.
        let amp = (nx * ny) as f64 / 2.0;
        assert!((p[3] - amp * amp).abs() < 1e-8 * amp * amp);
        assert!((p[nx - 3] - amp * amp).abs() < 1e-8 * amp * amp);
        let rest: f64 = p.iter().sum::<f64>() - p[3] - p[nx - 3];
        assert!(rest < 1e-16 * amp * amp);
        // Parseval: sum |V|^2 = N sum |v|^2.
        let energy: f64 = v.iter().map(|x| x * x).sum();
        assert!((p.iter().sum::<f64>() - (nx * ny) as f64 * energy).abs() < 1e-8);
    }

    #[test]
    fn checkerboard_is_all_high_frequency_and_a_slow_wave_is_not() {
        let (nx, ny) = (16, 16);
        let checker = field(nx, ny, |x, y| if (x + y) % 2 == 0 { 1.0 } else { -1.0 });
        assert!((high_frequency_fraction(&checker, nx, ny, 0.5).unwrap() - 1.0).abs() < 1e-12);
        let slow = field(nx, ny, |x, _| {
            (2.0 * std::f64::consts::PI * x as f64 / nx as f64).sin()
        });
        assert!(high_frequency_fraction(&slow, nx, ny, 0.5).unwrap() < 1e-12);
        assert!(matches!(
            power_spectrum(&checker, 15, 16),
            Err(FilterError::GridMismatch { .. })
        ));
    }

    #[test]
    fn fftshift_centres_the_zero_frequency() {
        let mut s = vec![0.0; 12];
        s[0] = 1.0;
        let c = fftshift(&s, 4, 3);
        assert_eq!(c[4 + 2], 1.0);
    }

    #[test]
    fn velocity_image_maps_components_to_rgb() {
        let mut img = VelocityImage::new(2);
        img.push(&[1.0, -1.0, 0.0, 0.5, 10.0, f64::NAN], 1.0)
            .unwrap();
        assert_eq!(img.height(), 1);
        assert_eq!(img.pixels(), &[[255, 1, 128], [192, 255, 128]]);
        assert!(img.push(&[0.0; 5], 1.0).is_err());
    }
}
