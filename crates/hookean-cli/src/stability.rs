//! `hookean stability`: the tutorial's figure 4, the stability regions
//! `{z : |R(z)| <= 1}` of the methods in the complex plane, one small panel
//! per method.
//!
//! The shading is [`hookean_ode::stability::sample_region`] on a grid (the
//! stability function `|R(z)|` for one-step methods, eq. 28; the largest
//! root modulus of the characteristic polynomial for BDF(k)), drawn as one
//! rectangle per run of stable cells in a grid row. For BDF(k) the boundary
//! locus `z(theta) = sum_{j=1..k} (1 - e^{-i theta})^j / j` is drawn on
//! top: the region is the outside of that curve.

use std::path::PathBuf;

use clap::Args;
use hookean_ode::Method;
use hookean_ode::bdf::BdfCoefficients;
use hookean_ode::stability::{ComplexGrid, RegionSample, sample_region};

use crate::CliError;
use crate::output::{check_new_file, write_text};
use crate::regions::{Panel, RegionPanels};

#[derive(Debug, Args)]
pub struct StabilityArgs {
    /// Comma-separated method names (default: explicit-euler, midpoint,
    /// rk4, implicit-euler, implicit-midpoint, bdf1..bdf6). FB Euler and
    /// Verlet have no stability function on y' = lambda y.
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
    /// The SVG file to write.
    #[arg(long)]
    plot: PathBuf,
    /// Real range of the window, "lo,hi".
    #[arg(long, default_value = "-5,3", allow_hyphen_values = true)]
    re: String,
    /// Imaginary range of the window, "lo,hi".
    #[arg(long, default_value = "-4,4", allow_hyphen_values = true)]
    im: String,
    /// Grid points per axis (2 to 1001).
    #[arg(long, default_value_t = 161)]
    resolution: usize,
    /// Overwrite an existing plot.
    #[arg(long)]
    force: bool,
}

/// The largest `|lo|`, `|hi|` of a window: wide enough for any stiffness
/// a region plot shows, small enough that the width and the grid spacing
/// are ordinary numbers (a window of +-1e308 overflowed to an infinite width).
const MAX_WINDOW: f64 = 1e6;

fn range(flag: &str, s: &str) -> Result<(f64, f64), CliError> {
    let bad = || {
        CliError::Input(format!(
            "{flag} expects 'lo,hi' with -{MAX_WINDOW:e} <= lo < hi <= {MAX_WINDOW:e}, got '{s}'"
        ))
    };
    let (a, b) = s.split_once(',').ok_or_else(bad)?;
    let a: f64 = a.trim().parse().map_err(|_| bad())?;
    let b: f64 = b.trim().parse().map_err(|_| bad())?;
    if a >= -MAX_WINDOW && b <= MAX_WINDOW && a < b {
        Ok((a, b))
    } else {
        Err(bad())
    }
}

/// The default methods of figure 4.
fn default_methods() -> Vec<Method> {
    let mut v = vec![
        Method::ExplicitEuler,
        Method::Midpoint,
        Method::Rk4,
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
    ];
    v.extend((1..=6).map(Method::Bdf));
    v
}

/// Runs of stable cells per grid row as rectangles in data coordinates;
/// each grid point owns the cell of half a spacing around it.
fn stable_rects(sample: &RegionSample) -> Vec<(f64, f64, f64, f64)> {
    let g = &sample.grid;
    let dx = (g.re.1 - g.re.0) / (g.nx - 1) as f64;
    let dy = (g.im.1 - g.im.0) / (g.ny - 1) as f64;
    let mut rects = Vec::new();
    for iy in 0..g.ny {
        let y = g.point(0, iy).im;
        let mut ix = 0;
        while ix < g.nx {
            if !sample.is_stable(ix, iy) {
                ix += 1;
                continue;
            }
            let start = ix;
            while ix < g.nx && sample.is_stable(ix, iy) {
                ix += 1;
            }
            let x0 = g.point(start, iy).re - dx / 2.0;
            let x1 = g.point(ix - 1, iy).re + dx / 2.0;
            rects.push((x0, y - dy / 2.0, x1, y + dy / 2.0));
        }
    }
    rects
}

pub fn run(args: &StabilityArgs) -> Result<(), CliError> {
    let re = range("--re", &args.re)?;
    let im = range("--im", &args.im)?;
    if !(2..=1001).contains(&args.resolution) {
        return Err(CliError::Input(format!(
            "--resolution must lie in 2 to 1001, got {}",
            args.resolution
        )));
    }
    let methods = if args.methods.is_empty() {
        default_methods()
    } else {
        let mut v = Vec::new();
        for name in &args.methods {
            let m: Method = name
                .trim()
                .parse()
                .map_err(|e| CliError::Input(format!("{e}")))?;
            if m.is_second_order_only() {
                return Err(CliError::Input(format!(
                    "method {m} has no stability function on y' = lambda y (it needs a second-order problem)"
                )));
            }
            v.push(m);
        }
        v
    };
    check_new_file(&args.plot, args.force, "--plot")?;
    let grid = ComplexGrid {
        re,
        im,
        nx: args.resolution,
        ny: args.resolution,
    };
    let mut panels = Vec::new();
    for m in &methods {
        let sample = sample_region(m, &grid).map_err(|e| CliError::Input(format!("{m}: {e}")))?;
        let k = match m {
            Method::Bdf(k) if *k >= 2 => Some(*k),
            Method::Bdf2Variable => Some(2),
            _ => None,
        };
        let curves = match k {
            Some(k) => {
                let c = BdfCoefficients::new(k).map_err(|e| CliError::Input(e.to_string()))?;
                vec![
                    c.boundary_locus(720)
                        .into_iter()
                        .map(|z| (z.re, z.im))
                        .collect(),
                ]
            }
            None => vec![],
        };
        crate::outln!(
            "{m}: stable fraction of the window {:.4}",
            sample.stable_fraction()
        )?;
        panels.push(Panel {
            title: m.to_string(),
            rects: stable_rects(&sample),
            curves,
        });
    }
    let fig = RegionPanels {
        title: "Stability regions (shaded): |R(h lambda)| <= 1 on y' = lambda y".into(),
        re,
        im,
        panels,
        fill_label: "stable: |R(z)| <= 1 (largest root modulus for BDF)".into(),
        curve_label: "BDF(k) boundary locus".into(),
    };
    write_text(&args.plot, &fig.render().map_err(CliError::Failed)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Explicit Euler's region is the disc |1 + z| <= 1: the shaded area
    /// approaches pi as the grid is refined.
    #[test]
    fn explicit_euler_rects_cover_the_unit_disc_around_minus_one() {
        let grid = ComplexGrid {
            re: (-2.5, 0.5),
            im: (-1.5, 1.5),
            nx: 301,
            ny: 301,
        };
        let s = sample_region(&Method::ExplicitEuler, &grid).unwrap();
        let area: f64 = stable_rects(&s)
            .iter()
            .map(|(a, b, c, d)| (c - a) * (d - b))
            .sum();
        assert!((area - std::f64::consts::PI).abs() < 0.05, "{area}");
    }

    #[test]
    fn ranges_parse() {
        assert_eq!(range("--re", "-5, 3").unwrap(), (-5.0, 3.0));
        assert!(range("--re", "3,-5").is_err());
        assert!(range("--re", "x").is_err());
    }
}
