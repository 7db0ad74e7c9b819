//! Labelled raster pictures with `plotters`: axes with ticks and units,
//! legends and colour bars, drawn over an RGB [`Canvas`].
//!
//! Text needs a font and CI machines have none installed, so the CLI embeds
//! DejaVu Sans (`assets/DejaVuSans.ttf`, Bitstream Vera licence in
//! `assets/DejaVuSans-LICENSE.txt`) and registers it as plotters'
//! `sans-serif` family (plotters' `ab_glyph` feature) before drawing.
//! Font sizes are even: plotters 0.3.7 places each glyph at
//! `(size / 2 + top) as i32`, which truncates half pixels in different
//! directions above and below zero, so with odd sizes a period sits a pixel
//! or two above the baseline.

use std::sync::Once;

use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::render::Canvas;

/// DejaVu Sans, the only font the pictures use.
const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Registers the embedded font as `sans-serif` (once per process).
pub fn init_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .unwrap_or_else(|_| panic!("the embedded DejaVu Sans is a valid TTF"));
    });
}

/// A plotters drawing error as the CLI's message.
pub fn draw_error(e: impl std::fmt::Display) -> String {
    format!("drawing failed: {e}")
}

/// Draws on `canvas` with plotters (the canvas's pixels are the bitmap).
pub fn draw_on<T>(
    canvas: &mut Canvas,
    f: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<T, String>,
) -> Result<T, String> {
    init_font();
    let (w, h) = canvas.size();
    let root =
        BitMapBackend::with_buffer(canvas.rgb_mut(), (w as u32, h as u32)).into_drawing_area();
    let out = f(&root)?;
    root.present().map_err(draw_error)?;
    Ok(out)
}

/// A 2D chart on `f64` axes drawn on a bitmap.
pub type Chart<'a, 'b> =
    ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A chart on `area` with a caption, over `x` and `y`, its axes drawn with
/// ticks, tick labels and the axis descriptions (with units); `grid` adds
/// light grid lines.
pub fn labelled_chart<'a, 'b>(
    area: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    caption: &str,
    (x, x_desc): (std::ops::Range<f64>, &str),
    (y, y_desc): (std::ops::Range<f64>, &str),
    grid: bool,
) -> Result<Chart<'a, 'b>, String> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y)
        .map_err(draw_error)?;
    let mut mesh = chart.configure_mesh();
    if grid {
        mesh.light_line_style(RGBColor(235, 235, 235));
    } else {
        mesh.disable_mesh();
    }
    mesh.x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&|v| tick_text(*v))
        .y_label_formatter(&|v| tick_text(*v))
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 14))
        .draw()
        .map_err(draw_error)?;
    Ok(chart)
}

/// An SVG document of `size` pixels drawn by `f` on a white background
/// (text is left to the viewer's fonts; the embedded one only measures it).
pub fn svg_document(
    size: (u32, u32),
    f: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>,
) -> Result<String, String> {
    init_font();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(draw_error)?;
        f(&root)?;
        root.present().map_err(draw_error)?;
    }
    Ok(format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{}\n",
        svg.trim_end()
    ))
}

/// Tick positions: multiples of a "nice" step (1, 2 or 5 times a power of
/// ten) giving about 3 to 7 ticks in `[lo, hi]`.
pub fn linear_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return vec![];
    }
    let raw = span / 6.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * p);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

/// Short tick text: no trailing zeros, exponent form for tiny or huge values.
pub fn tick_text(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// A vertical colour bar in the pixel rectangle `(x, y, w, h)` of `area`:
/// `colour(s)` for `s` from `lo` (bottom) to `hi` (top), ticks and their
/// values on the right, `label` above.
pub fn colour_bar(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    (x, y, w, h): (i32, i32, i32, i32),
    (lo, hi): (f64, f64),
    colour: impl Fn(f64) -> RGBColor,
    ticks: Option<Vec<f64>>,
    label: &str,
) -> Result<(), String> {
    for k in 0..h {
        let s = lo + (hi - lo) * (h - 1 - k) as f64 / (h - 1).max(1) as f64;
        area.draw(&Rectangle::new(
            [(x, y + k), (x + w, y + k + 1)],
            colour(s).filled(),
        ))
        .map_err(draw_error)?;
    }
    area.draw(&Rectangle::new([(x, y), (x + w, y + h)], BLACK))
        .map_err(draw_error)?;
    let font = ("sans-serif", 14).into_font().color(&BLACK);
    for t in ticks.unwrap_or_else(|| linear_ticks(lo, hi)) {
        let py = y + ((hi - t) / (hi - lo) * (h - 1) as f64).round() as i32;
        area.draw(&PathElement::new(vec![(x + w, py), (x + w + 4, py)], BLACK))
            .map_err(draw_error)?;
        area.draw(&Text::new(tick_text(t), (x + w + 7, py - 7), font.clone()))
            .map_err(draw_error)?;
    }
    area.draw(&Text::new(
        label.to_string(),
        (x - 6, y - 22),
        ("sans-serif", 14).into_font().color(&BLACK),
    ))
    .map_err(draw_error)?;
    Ok(())
}

/// A time series against its exact solution: the tutorial scenes' picture.
pub struct TimePlot<'a> {
    /// Caption above the plot.
    pub title: &'a str,
    /// Label of the y axis, with units.
    pub y_label: &'a str,
    /// Legend text of the numerical solution.
    pub numerical: &'a str,
    /// `(t, numerical, exact)` samples.
    pub points: &'a [(f64, f64, f64)],
}

impl TimePlot<'_> {
    /// Draws the plot: the exact solution thick and grey, the numerical one
    /// blue with a marker per step (up to 200 markers), axes, ticks, legend.
    pub fn draw(&self, width: usize, height: usize) -> Result<Canvas, String> {
        let mut canvas = Canvas::new(width, height);
        let t_end = self.points.last().map_or(1.0, |p| p.0).max(1e-12);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in self.points {
            for v in [p.1, p.2] {
                if v.is_finite() {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        if !lo.is_finite() {
            (lo, hi) = (-1.0, 1.0);
        }
        let pad = ((hi - lo) * 0.06).max(1e-9 * hi.abs().max(1.0));
        let (lo, hi) = (lo - pad, hi + pad);
        draw_on(&mut canvas, |root| {
            root.fill(&WHITE).map_err(draw_error)?;
            let mut chart = labelled_chart(
                root,
                self.title,
                (0.0..t_end, "time t (s)"),
                (lo..hi, self.y_label),
                true,
            )?;
            let grey = RGBColor(160, 160, 160);
            chart
                .draw_series(LineSeries::new(
                    self.points
                        .iter()
                        .filter(|p| p.2.is_finite())
                        .map(|p| (p.0, p.2)),
                    grey.stroke_width(5),
                ))
                .map_err(draw_error)?
                .label("exact solution")
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], grey.stroke_width(5))
                });
            let blue = RGBColor(30, 80, 200);
            let finite: Vec<(f64, f64)> = self
                .points
                .iter()
                .filter(|p| p.1.is_finite())
                .map(|p| (p.0, p.1.clamp(lo, hi)))
                .collect();
            chart
                .draw_series(LineSeries::new(
                    finite.iter().copied(),
                    blue.stroke_width(2),
                ))
                .map_err(draw_error)?
                .label(self.numerical)
                .legend(move |(x, y)| {
                    EmptyElement::at((x, y))
                        + PathElement::new(vec![(0, 0), (24, 0)], blue.stroke_width(2))
                        + Circle::new((12, 0), 3, blue.filled())
                });
            if finite.len() <= 200 {
                chart
                    .draw_series(finite.iter().map(|&p| Circle::new(p, 3, blue.filled())))
                    .map_err(draw_error)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.9))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(draw_error)
        })?;
        Ok(canvas)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_and_inside() {
        assert_eq!(linear_ticks(-5.0, 3.0), vec![-4.0, -2.0, 0.0, 2.0]);
        let t = linear_ticks(-4.0, 4.0);
        assert_eq!(t, vec![-4.0, -2.0, 0.0, 2.0, 4.0]);
        assert!(linear_ticks(1.0, 1.0).is_empty());
    }

    #[test]
    fn tick_text_is_short() {
        assert_eq!(tick_text(0.0), "0");
        assert_eq!(tick_text(2.5), "2.5");
        assert_eq!(tick_text(10.0), "10");
        assert_eq!(tick_text(0.125), "0.125");
        assert_eq!(tick_text(1e-6), "1e-6");
    }

    /// Text is drawn with the embedded font: a caption changes pixels
    /// (without a font plotters would draw nothing or fail).
    #[test]
    fn text_renders_with_the_embedded_font() {
        let mut c = Canvas::new(200, 60);
        draw_on(&mut c, |root| {
            root.fill(&WHITE).map_err(draw_error)?;
            root.draw(&Text::new(
                "t = 1.5 s",
                (10, 20),
                ("sans-serif", 20).into_font(),
            ))
            .map_err(draw_error)
        })
        .unwrap();
        let dark = c.rgb().chunks(3).filter(|p| p[0] < 128).count();
        assert!(dark > 50, "{dark} dark pixels");
    }
}
