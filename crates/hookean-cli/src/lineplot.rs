//! Log-log line plots as SVG, drawn with plotters: the work-precision
//! diagrams (the tutorial's figures 3, 5, 7) and the filtering paper's
//! figure 6; and staircases over a log axis (`hookean bench`'s
//! performance profiles). Each series has its own colour, marker and dash pattern, the
//! axes have ticks at every power of ten (and at 2 and 5 times it on short
//! axes), and the legend sits beside the plot.

use plotters::coord::CoordTranslate;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::plot::{draw_error, svg_document, tick_text};

/// Distinguishable colours (Tableau 10).
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0x7f, 0x7f, 0x7f),
    RGBColor(0xbc, 0xbd, 0x22),
    RGBColor(0x17, 0xbe, 0xcf),
];

/// Marker shapes (7: coprime to the 10 colours and the 3 dash patterns).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    TriangleDown,
    Cross,
    Plus,
}

const MARKERS: [Marker; 7] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Cross,
    Marker::Plus,
];

/// Dash patterns as (dash, gap) in pixels; `None` is a solid line.
const DASHES: [Option<(u32, u32)>; 3] = [None, Some((8, 4)), Some((2, 3))];

/// Colour, marker and dash of series `i`: no two of the first 30 series
/// share all three, and series `i` and `i + 10` (same colour) differ in both
/// marker and dash.
fn series_style(i: usize) -> (RGBColor, Marker, Option<(u32, u32)>) {
    (
        PALETTE[i % PALETTE.len()],
        MARKERS[i % MARKERS.len()],
        DASHES[i % DASHES.len()],
    )
}

/// Draws the marker `m` centred on `at` (chart or pixel coordinates of `area`).
fn draw_marker<DB: DrawingBackend, CT: CoordTranslate>(
    area: &DrawingArea<DB, CT>,
    m: Marker,
    at: CT::From,
    colour: RGBColor,
) -> Result<(), String>
where
    CT::From: Clone,
{
    let fill = colour.filled();
    let line = colour.stroke_width(2);
    let e = || EmptyElement::at(at.clone());
    match m {
        Marker::Circle => area.draw(&(e() + Circle::new((0, 0), 4, fill))),
        Marker::Square => area.draw(&(e() + Rectangle::new([(-3, -3), (4, 4)], fill))),
        Marker::Triangle => area.draw(&(e() + Polygon::new(vec![(0, -5), (4, 3), (-4, 3)], fill))),
        Marker::TriangleDown => {
            area.draw(&(e() + Polygon::new(vec![(0, 5), (4, -3), (-4, -3)], fill)))
        }
        Marker::Diamond => {
            area.draw(&(e() + Polygon::new(vec![(0, -5), (4, 0), (0, 5), (-4, 0)], fill)))
        }
        Marker::Cross => area.draw(
            &(e()
                + PathElement::new(vec![(-4, -4), (4, 4)], line)
                + PathElement::new(vec![(-4, 4), (4, -4)], line)),
        ),
        Marker::Plus => area.draw(
            &(e()
                + PathElement::new(vec![(-5, 0), (5, 0)], line)
                + PathElement::new(vec![(0, -5), (0, 5)], line)),
        ),
    }
    .map_err(draw_error)
}

/// Draws `points` as one series' line, 2 px wide: solid, or dashed
/// `(on, off)` pixels.
fn draw_curve<DB, X, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
    colour: RGBColor,
    dash: Option<(u32, u32)>,
) -> Result<(), String>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let style = colour.stroke_width(2);
    let points = points.iter().copied();
    match dash {
        None => chart.draw_series(LineSeries::new(points, style)),
        Some((on, off)) => chart.draw_series(DashedLineSeries::new(points, on, off, style)),
    }
    .map(|_| ())
    .map_err(draw_error)
}

/// One curve of a [`LogLogPlot`].
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points; those that are not finite and positive are left out.
    pub points: Vec<(f64, f64)>,
}

/// A log-log line plot with a legend on the right.
#[derive(Debug, Clone)]
pub struct LogLogPlot {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis, with units.
    pub x_label: String,
    /// Label of the y axis, with units.
    pub y_label: String,
    /// The curves.
    pub series: Vec<Series>,
}

/// The decade range `[floor(log10 lo), ceil(log10 hi)]` covering the values
/// (at least one decade wide); `(0, 1)` when there are none.
pub fn decades(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v.log10());
        hi = hi.max(v.log10());
    }
    if !lo.is_finite() {
        return (0, 1);
    }
    let (a, mut b) = (lo.floor() as i32, hi.ceil() as i32);
    if b <= a {
        b = a + 1;
    }
    (a, b)
}

/// Tick positions on a log axis over the decades `[lo, hi]`: every power of
/// ten (every n-th on long axes, at most about 10), and 2 and 5 times each
/// power on axes of at most two decades.
fn log_ticks(lo: i32, hi: i32) -> Vec<f64> {
    let every = ((hi - lo) / 10 + 1).max(1);
    let mut t = Vec::new();
    for k in lo..=hi {
        if (k - lo) % every == 0 {
            t.push(10f64.powi(k));
        }
        if hi - lo <= 2 && k < hi {
            t.extend([2.0, 5.0].map(|m| m * 10f64.powi(k)));
        }
    }
    t.sort_by(f64::total_cmp);
    t
}

/// `10^k` or `m·10^k` with a superscript exponent (plain for `k = 0, 1`).
fn power_label(v: f64) -> String {
    const SUP: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let k = (v.log10() + 1e-9).floor() as i32;
    let m = (v / 10f64.powi(k)).round() as i32;
    if k == 0 || k == 1 {
        return tick_text(v);
    }
    let exp: String = k
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => SUP[d.to_digit(10).unwrap_or(0) as usize],
        })
        .collect();
    if m == 1 {
        format!("10{exp}")
    } else {
        format!("{m}·10{exp}")
    }
}

fn usable(p: &(f64, f64)) -> bool {
    p.0.is_finite() && p.0 > 0.0 && p.1.is_finite() && p.1 > 0.0
}

impl LogLogPlot {
    /// The SVG document. A series without usable points gets a legend
    /// entry but no line.
    pub fn render(&self) -> Result<String, String> {
        let pts = || {
            self.series
                .iter()
                .flat_map(|s| s.points.iter().filter(|p| usable(p)))
        };
        let (x0, x1) = decades(pts().map(|p| p.0));
        let (y0, y1) = decades(pts().map(|p| p.1));
        let (xt, yt) = (log_ticks(x0, x1), log_ticks(y0, y1));
        let legend_rows = self.series.len() as u32;
        let height = 540.max(60 + 22 * legend_rows);
        svg_document((900, height), |root| {
            let (plot, legend) = root.split_horizontally(680);
            let mut chart = ChartBuilder::on(&plot)
                .caption(&self.title, ("sans-serif", 16))
                .margin(14)
                .x_label_area_size(50)
                .y_label_area_size(80)
                .build_cartesian_2d(
                    (10f64.powi(x0)..10f64.powi(x1)).log_scale(),
                    (10f64.powi(y0)..10f64.powi(y1)).log_scale(),
                )
                .map_err(draw_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .x_labels(0)
                .y_labels(0)
                .x_label_formatter(&|_| String::new())
                .y_label_formatter(&|_| String::new())
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 14))
                .draw()
                .map_err(draw_error)?;
            // Grid lines and labelled ticks at our positions (plotters'
            // own log ticks skip the 2 and 5 on short axes).
            let (xs, ys) = (
                10f64.powi(x0)..10f64.powi(x1),
                10f64.powi(y0)..10f64.powi(y1),
            );
            let grid = RGBColor(225, 225, 225);
            let area = chart.plotting_area();
            for &x in &xt {
                area.draw(&PathElement::new(vec![(x, ys.start), (x, ys.end)], grid))
                    .map_err(draw_error)?;
            }
            for &y in &yt {
                area.draw(&PathElement::new(vec![(xs.start, y), (xs.end, y)], grid))
                    .map_err(draw_error)?;
            }
            let label = ("sans-serif", 12).into_font().color(&BLACK);
            for &x in &xt {
                let (px, py) = chart.backend_coord(&(x, ys.start));
                plot.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK))
                    .map_err(draw_error)?;
                let style = label.clone().pos(Pos::new(HPos::Center, VPos::Top));
                plot.draw(&Text::new(power_label(x), (px, py + 8), style))
                    .map_err(draw_error)?;
            }
            for &y in &yt {
                let (px, py) = chart.backend_coord(&(xs.start, y));
                plot.draw(&PathElement::new(vec![(px - 5, py), (px, py)], BLACK))
                    .map_err(draw_error)?;
                let style = label.clone().pos(Pos::new(HPos::Right, VPos::Center));
                plot.draw(&Text::new(power_label(y), (px - 8, py), style))
                    .map_err(draw_error)?;
            }
            for (i, s) in self.series.iter().enumerate() {
                let (colour, m, dash) = series_style(i);
                let p: Vec<(f64, f64)> = s.points.iter().copied().filter(usable).collect();
                draw_curve(&mut chart, &p, colour, dash)?;
                for &q in &p {
                    draw_marker(chart.plotting_area(), m, q, colour)?;
                }
                legend_entry(&legend, i, &s.name)?;
            }
            Ok(())
        })
    }
}

/// Legend entry `i` of `area`: a 30-pixel sample of series `i`'s line with
/// its marker, and `name`.
fn legend_entry<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    i: usize,
    name: &str,
) -> Result<(), String> {
    let (colour, m, dash) = series_style(i);
    let style = colour.stroke_width(2);
    let y = 50 + 22 * i as i32;
    let sample = match dash {
        None => vec![(10, 40)],
        Some((on, off)) => (0..)
            .map(|k| 10 + k * (on + off) as i32)
            .take_while(|&a| a < 40)
            .map(|a| (a, (a + on as i32).min(40)))
            .collect(),
    };
    for (a, b) in sample {
        area.draw(&PathElement::new(vec![(a, y), (b, y)], style))
            .map_err(draw_error)?;
    }
    draw_marker(area, m, (25, y), colour)?;
    area.draw(&Text::new(
        name.to_string(),
        (48, y),
        ("sans-serif", 13)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Left, VPos::Center)),
    ))
    .map_err(draw_error)
}

/// A staircase plot of fractions in [0, 1] over a log axis from 1: the
/// performance profiles of `hookean bench` ([`crate::perfprofile`]). Each
/// series' points are its staircase's corners; its markers sit where it
/// steps up.
#[derive(Debug, Clone)]
pub struct ProfilePlot {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
    pub y_label: String,
    /// The staircases, `(tau, fraction)` with `tau >= 1`.
    pub series: Vec<Series>,
}

impl ProfilePlot {
    /// The SVG document.
    pub fn render(&self) -> Result<String, String> {
        let tau_max = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0))
            .filter(|t| t.is_finite() && *t > 1.0)
            .fold(10.0_f64, f64::max);
        // The decades from 1 up to tau_max (at least one).
        let x1 = ((tau_max.log10() - 1e-9).ceil() as i32).max(1);
        let x_end = 10f64.powi(x1);
        let xt = log_ticks(0, x1);
        let height = 540.max(60 + 22 * self.series.len() as u32);
        svg_document((900, height), |root| {
            let (plot, legend) = root.split_horizontally(680);
            let mut chart = ChartBuilder::on(&plot)
                .caption(&self.title, ("sans-serif", 16))
                .margin(14)
                .x_label_area_size(50)
                .y_label_area_size(60)
                .build_cartesian_2d((1.0..x_end).log_scale(), -0.02..1.02)
                .map_err(draw_error)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc(&self.x_label)
                .y_desc(&self.y_label)
                .x_labels(0)
                .x_label_formatter(&|_| String::new())
                .y_labels(6)
                .y_label_formatter(&|v| tick_text(*v))
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 14))
                .draw()
                .map_err(draw_error)?;
            let grid = RGBColor(225, 225, 225);
            let label = ("sans-serif", 12).into_font().color(&BLACK);
            for &x in &xt {
                chart
                    .plotting_area()
                    .draw(&PathElement::new(vec![(x, -0.02), (x, 1.02)], grid))
                    .map_err(draw_error)?;
                let (px, py) = chart.backend_coord(&(x, -0.02));
                plot.draw(&PathElement::new(vec![(px, py), (px, py + 5)], BLACK))
                    .map_err(draw_error)?;
                let style = label.clone().pos(Pos::new(HPos::Center, VPos::Top));
                plot.draw(&Text::new(power_label(x), (px, py + 8), style))
                    .map_err(draw_error)?;
            }
            for (i, s) in self.series.iter().enumerate() {
                let (colour, m, dash) = series_style(i);
                let p: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .map(|&(x, y)| (x.min(x_end), y))
                    .filter(|(x, y)| x.is_finite() && *x >= 1.0 && y.is_finite())
                    .collect();
                draw_curve(&mut chart, &p, colour, dash)?;
                // Markers where the staircase rises (and at its start).
                for (k, &q) in p.iter().enumerate() {
                    if k == 0 || (q.0 == p[k - 1].0 && q.1 > p[k - 1].1) {
                        draw_marker(chart.plotting_area(), m, q, colour)?;
                    }
                }
                legend_entry(&legend, i, &s.name)?;
            }
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decade_range_covers_the_values() {
        assert_eq!(decades([3e-7, 0.5, 20.0].into_iter()), (-7, 2));
        assert_eq!(decades([1.0].into_iter()), (0, 1));
        assert_eq!(decades([f64::NAN, -1.0].into_iter()), (0, 1));
    }

    #[test]
    fn series_styles_are_distinct_and_same_colours_differ_in_marker_and_dash() {
        for i in 0..30 {
            for j in i + 1..30 {
                let (a, b) = (series_style(i), series_style(j));
                assert!(
                    a.0 != b.0 || (a.1 != b.1 && a.2 != b.2),
                    "series {i} and {j} look alike"
                );
            }
        }
    }

    #[test]
    fn short_axes_get_ticks_at_2_and_5() {
        assert_eq!(log_ticks(-4, -3).len(), 4); // 1e-4, 2e-4, 5e-4, 1e-3
        assert_eq!(log_ticks(0, 8).len(), 9);
        assert_eq!(log_ticks(-20, 10).len(), 8); // every fourth power: -20, -16, ..., 8
    }

    #[test]
    fn power_labels() {
        assert_eq!(power_label(1e-6), "10⁻⁶");
        assert_eq!(power_label(5e-4), "5·10⁻⁴");
        assert_eq!(power_label(100.0), "10²");
        assert_eq!(power_label(10.0), "10");
        assert_eq!(power_label(2.0), "2");
        assert_eq!(power_label(1e5), "10⁵");
    }

    #[test]
    fn a_series_without_usable_points_has_a_legend_entry_but_no_line() {
        let plot = LogLogPlot {
            title: "a < b".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![
                Series {
                    name: "one".into(),
                    points: vec![(1.0, 1.0), (10.0, 0.1)],
                },
                Series {
                    name: "failed".into(),
                    points: vec![(1.0, f64::INFINITY)],
                },
            ],
        };
        let svg = plot.render().unwrap();
        assert!(svg.starts_with("<?xml") && svg.trim_end().ends_with("</svg>"));
        assert!(svg.contains("a &lt; b"));
        assert!(svg.contains("\nfailed\n") && svg.contains("\none\n"));
        // The second colour (orange) only in the legend: one line sample, no curve.
        let orange = svg.matches("#FF7F0E").count();
        let blue = svg.matches("#1F77B4").count();
        assert!(blue > orange, "blue {blue}, orange {orange}");
    }
}
