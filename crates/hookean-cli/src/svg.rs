//! Hand-written SVG plots (no fonts needed: text is left to the viewer):
//! log-log line plots with decade ticks, markers and a legend (the
//! work-precision diagrams), and panels of shaded regions of the complex
//! plane with linear ticks (the stability regions).

use std::fmt::Write as _;

/// Distinguishable colours (Tableau 10).
pub const PALETTE: [&str; 10] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf",
];

/// Marker shapes cycled through by the series of a line plot (7 shapes,
/// coprime to the 10 colours and the 3 dash patterns, so that two series
/// with the same colour differ in marker and dash).
const MARKERS: [Marker; 7] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
    Marker::TriangleDown,
    Marker::Cross,
    Marker::Plus,
];

/// Dash patterns (`stroke-dasharray`) cycled through by the series.
const DASHES: [&str; 3] = ["none", "7 3", "2 2"];

#[derive(Debug, Clone, Copy)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
    TriangleDown,
    Cross,
    Plus,
}

/// Colour, marker and dash of series `i`: no two of the first 30 series
/// share all three, and series `i` and `i + 10` (same colour) differ in both
/// marker and dash.
fn series_style(i: usize) -> (&'static str, Marker, &'static str) {
    (
        PALETTE[i % PALETTE.len()],
        MARKERS[i % MARKERS.len()],
        DASHES[i % DASHES.len()],
    )
}

/// Escapes text for SVG element content and attribute values.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// Formats a coordinate with two decimals (keeps files small).
fn c(v: f64) -> String {
    format!("{v:.2}")
}

/// The black frame around a plot area.
fn frame(out: &mut String, left: f64, top: f64, pw: f64, ph: f64) {
    let _ = writeln!(
        out,
        "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>",
        c(left),
        c(top),
        c(pw),
        c(ph)
    );
}

fn header(width: f64, height: f64) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect x=\"0\" y=\"0\" width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n",
        w = c(width),
        h = c(height)
    )
}

fn marker(out: &mut String, m: Marker, x: f64, y: f64, colour: &str) {
    let r = 3.5;
    match m {
        Marker::Circle => {
            let _ = writeln!(
                out,
                "<circle cx=\"{}\" cy=\"{}\" r=\"{r}\" fill=\"{colour}\"/>",
                c(x),
                c(y)
            );
        }
        Marker::Square => {
            let _ = writeln!(
                out,
                "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{colour}\"/>",
                c(x - r),
                c(y - r),
                c(2.0 * r),
                c(2.0 * r)
            );
        }
        Marker::Triangle => {
            let _ = writeln!(
                out,
                "<path d=\"M{} {} L{} {} L{} {} Z\" fill=\"{colour}\"/>",
                c(x),
                c(y - r * 1.2),
                c(x + r),
                c(y + r * 0.8),
                c(x - r),
                c(y + r * 0.8)
            );
        }
        Marker::TriangleDown => {
            let _ = writeln!(
                out,
                "<path d=\"M{} {} L{} {} L{} {} Z\" fill=\"{colour}\"/>",
                c(x),
                c(y + r * 1.2),
                c(x + r),
                c(y - r * 0.8),
                c(x - r),
                c(y - r * 0.8)
            );
        }
        Marker::Cross | Marker::Plus => {
            let (a, b) = if matches!(m, Marker::Cross) {
                ([-r, -r, r, r], [-r, r, r, -r])
            } else {
                ([-r * 1.2, 0.0, r * 1.2, 0.0], [0.0, -r * 1.2, 0.0, r * 1.2])
            };
            let _ = writeln!(
                out,
                "<path d=\"M{} {} L{} {} M{} {} L{} {}\" stroke=\"{colour}\" stroke-width=\"2\" fill=\"none\"/>",
                c(x + a[0]),
                c(y + b[0]),
                c(x + a[2]),
                c(y + b[2]),
                c(x + a[1]),
                c(y + b[1]),
                c(x + a[3]),
                c(y + b[3])
            );
        }
        Marker::Diamond => {
            let _ = writeln!(
                out,
                "<path d=\"M{} {} L{} {} L{} {} L{} {} Z\" fill=\"{colour}\"/>",
                c(x),
                c(y - r * 1.3),
                c(x + r),
                c(y),
                c(x),
                c(y + r * 1.3),
                c(x - r),
                c(y)
            );
        }
    }
}

/// One curve of a [`LogLogPlot`].
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points; those that are not finite and positive are left out.
    pub points: Vec<(f64, f64)>,
}

/// A log-log line plot: one polyline with markers per series, decade ticks
/// with `10^k` labels on both axes, and a legend on the right.
#[derive(Debug, Clone)]
pub struct LogLogPlot {
    /// Title above the plot.
    pub title: String,
    /// Label of the x axis.
    pub x_label: String,
    /// Label of the y axis.
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

/// Label every `n`-th decade so that at most about 10 labels share an axis.
fn label_every(lo: i32, hi: i32) -> i32 {
    ((hi - lo) / 10 + 1).max(1)
}

/// The ticks at `m 10^k` (`m = 2..9`) inside the decades `[lo, hi]`, with
/// an SVG label for `m = 2, 5` when the axis spans at most two decades.
fn minor_ticks(lo: i32, hi: i32) -> Vec<(f64, Option<String>)> {
    (lo..hi)
        .flat_map(|k| {
            (2..10).map(move |m| {
                let label = (hi - lo <= 2 && (m == 2 || m == 5))
                    .then(|| format!("{m}·10<tspan dy=\"-4\" font-size=\"8\">{k}</tspan>"));
                (m as f64 * 10f64.powi(k), label)
            })
        })
        .collect()
}

fn usable(p: &(f64, f64)) -> bool {
    p.0.is_finite() && p.0 > 0.0 && p.1.is_finite() && p.1 > 0.0
}

impl LogLogPlot {
    /// The SVG document. A series without usable points gets a legend
    /// entry but no polyline.
    pub fn render(&self) -> String {
        let (pw, ph) = (560.0, 420.0);
        let (left, top, legend_w, bottom) = (80.0, 40.0, 190.0, 60.0);
        let (width, height) = (left + pw + 20.0 + legend_w, top + ph + bottom);
        let pts = || {
            self.series
                .iter()
                .flat_map(|s| s.points.iter().filter(|p| usable(p)))
        };
        let (x0, x1) = decades(pts().map(|p| p.0));
        let (y0, y1) = decades(pts().map(|p| p.1));
        let sx = |x: f64| left + (x.log10() - x0 as f64) / (x1 - x0) as f64 * pw;
        let sy = |y: f64| top + ph - (y.log10() - y0 as f64) / (y1 - y0) as f64 * ph;
        let mut out = header(width, height);
        let _ = writeln!(
            out,
            "<text x=\"{}\" y=\"24\" text-anchor=\"middle\" font-size=\"15\">{}</text>",
            c(left + pw / 2.0),
            escape(&self.title)
        );
        // Grid and decade ticks.
        let _ = writeln!(out, "<g stroke=\"#dddddd\" stroke-width=\"1\">");
        for k in x0..=x1 {
            let x = sx(10f64.powi(k));
            let _ = writeln!(
                out,
                "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\"/>",
                c(x),
                c(top),
                c(x),
                c(top + ph)
            );
        }
        for k in y0..=y1 {
            let y = sy(10f64.powi(k));
            let _ = writeln!(
                out,
                "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\"/>",
                c(left),
                c(y),
                c(left + pw),
                c(y)
            );
        }
        let _ = writeln!(out, "</g>");
        frame(&mut out, left, top, pw, ph);
        // Every decade gets a tick; labels thin out to at most about 10 per axis.
        let (lx, ly) = (label_every(x0, x1), label_every(y0, y1));
        for k in x0..=x1 {
            let x = sx(10f64.powi(k));
            let _ = writeln!(
                out,
                "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>",
                c(x),
                c(top + ph),
                c(x),
                c(top + ph + 5.0)
            );
            if (k - x0) % lx != 0 {
                continue;
            }
            let _ = writeln!(
                out,
                "<text x=\"{x}\" y=\"{t}\" text-anchor=\"middle\">10<tspan dy=\"-5\" font-size=\"9\">{k}</tspan></text>",
                x = c(x),
                t = c(top + ph + 20.0)
            );
        }
        for k in y0..=y1 {
            let y = sy(10f64.powi(k));
            let _ = writeln!(
                out,
                "<line x1=\"{}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"black\"/>",
                c(left - 5.0),
                c(left),
                y = c(y)
            );
            if (k - y0) % ly != 0 {
                continue;
            }
            let _ = writeln!(
                out,
                "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">10<tspan dy=\"-5\" font-size=\"9\">{k}</tspan></text>",
                c(left - 8.0),
                c(y + 4.0)
            );
        }
        // Ticks at 2..9 times each decade; on axes of at most two decades
        // those at 2 and 5 are labelled too (else all data may sit between
        // two labels).
        for (v, label) in minor_ticks(x0, x1) {
            let x = c(sx(v));
            let _ = writeln!(
                out,
                "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{}\" stroke=\"black\"/>",
                c(top + ph),
                c(top + ph + 3.0)
            );
            if let Some(l) = label {
                let _ = writeln!(
                    out,
                    "<text x=\"{x}\" y=\"{}\" text-anchor=\"middle\" font-size=\"10\">{l}</text>",
                    c(top + ph + 18.0)
                );
            }
        }
        for (v, label) in minor_ticks(y0, y1) {
            let y = sy(v);
            let _ = writeln!(
                out,
                "<line x1=\"{}\" y1=\"{yy}\" x2=\"{}\" y2=\"{yy}\" stroke=\"black\"/>",
                c(left - 3.0),
                c(left),
                yy = c(y)
            );
            if let Some(l) = label {
                let _ = writeln!(
                    out,
                    "<text x=\"{}\" y=\"{}\" text-anchor=\"end\" font-size=\"10\">{l}</text>",
                    c(left - 8.0),
                    c(y + 4.0)
                );
            }
        }
        let _ = writeln!(
            out,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            c(left + pw / 2.0),
            c(top + ph + 45.0),
            escape(&self.x_label)
        );
        let _ = writeln!(
            out,
            "<text x=\"20\" y=\"{y}\" text-anchor=\"middle\" transform=\"rotate(-90 20 {y})\">{}</text>",
            escape(&self.y_label),
            y = c(top + ph / 2.0)
        );
        // Curves.
        for (i, s) in self.series.iter().enumerate() {
            let (colour, m, dash) = series_style(i);
            let p: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|p| usable(p))
                .map(|&(x, y)| (sx(x), sy(y)))
                .collect();
            if !p.is_empty() {
                let coords: Vec<String> = p
                    .iter()
                    .map(|(x, y)| format!("{},{}", c(*x), c(*y)))
                    .collect();
                let _ = writeln!(
                    out,
                    "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.5\" stroke-dasharray=\"{dash}\" points=\"{}\"><title>{}</title></polyline>",
                    coords.join(" "),
                    escape(&s.name)
                );
                for (x, y) in &p {
                    marker(&mut out, m, *x, *y, colour);
                }
            }
            // Legend entry.
            let ly = top + 10.0 + 20.0 * i as f64;
            let lx = left + pw + 20.0;
            let _ = writeln!(
                out,
                "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{colour}\" stroke-width=\"1.5\" stroke-dasharray=\"{dash}\"/>",
                c(lx),
                c(ly),
                c(lx + 24.0),
                c(ly)
            );
            marker(&mut out, m, lx + 12.0, ly, colour);
            let _ = writeln!(
                out,
                "<text x=\"{}\" y=\"{}\">{}</text>",
                c(lx + 30.0),
                c(ly + 4.0),
                escape(&s.name)
            );
        }
        out.push_str("</svg>\n");
        out
    }
}

/// One panel of a [`RegionPanels`] figure.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Panel title (the method).
    pub title: String,
    /// Shaded axis-aligned rectangles `(re_lo, im_lo, re_hi, im_hi)` in
    /// data coordinates (the region).
    pub rects: Vec<(f64, f64, f64, f64)>,
    /// Outlines drawn on top (closed curves in data coordinates, e.g. a
    /// boundary locus), clipped to the panel.
    pub curves: Vec<Vec<(f64, f64)>>,
}

/// A grid of small panels over the same window of the complex plane, each
/// with axes `Re z` / `Im z`, integer ticks and a title, and a legend below.
#[derive(Debug, Clone)]
pub struct RegionPanels {
    /// Figure title.
    pub title: String,
    /// Real range of every panel.
    pub re: (f64, f64),
    /// Imaginary range of every panel.
    pub im: (f64, f64),
    /// Panels, row by row.
    pub panels: Vec<Panel>,
    /// Legend text of the shading.
    pub fill_label: String,
    /// Legend text of the outlines.
    pub curve_label: String,
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

fn tick_label(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

impl RegionPanels {
    /// The SVG document.
    pub fn render(&self) -> String {
        let cols = self.panels.len().clamp(1, 4);
        let rows = self.panels.len().div_ceil(cols).max(1);
        let aspect = (self.im.1 - self.im.0) / (self.re.1 - self.re.0);
        let pw = 200.0;
        let ph = (pw * aspect).clamp(80.0, 400.0);
        let (cell_w, cell_h) = (pw + 70.0, ph + 75.0);
        let (width, height) = (cols as f64 * cell_w + 20.0, rows as f64 * cell_h + 110.0);
        let mut out = header(width, height);
        let _ = writeln!(
            out,
            "<text x=\"{}\" y=\"24\" text-anchor=\"middle\" font-size=\"15\">{}</text>",
            c(width / 2.0),
            escape(&self.title)
        );
        let ticks_x = linear_ticks(self.re.0, self.re.1);
        let ticks_y = linear_ticks(self.im.0, self.im.1);
        for (i, panel) in self.panels.iter().enumerate() {
            let (col, row) = (i % cols, i / cols);
            let left = 20.0 + col as f64 * cell_w + 40.0;
            let top = 40.0 + row as f64 * cell_h + 25.0;
            let sx = |x: f64| left + (x - self.re.0) / (self.re.1 - self.re.0) * pw;
            let sy = |y: f64| top + ph - (y - self.im.0) / (self.im.1 - self.im.0) * ph;
            let _ = writeln!(
                out,
                "<clipPath id=\"clip{i}\"><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/></clipPath>",
                c(left),
                c(top),
                c(pw),
                c(ph)
            );
            let _ = writeln!(
                out,
                "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"13\">{}</text>",
                c(left + pw / 2.0),
                c(top - 8.0),
                escape(&panel.title)
            );
            let _ = writeln!(
                out,
                "<g clip-path=\"url(#clip{i})\"><g fill=\"{}\" fill-opacity=\"0.45\" stroke=\"none\">",
                PALETTE[0]
            );
            for &(a, b, cc, d) in &panel.rects {
                let (x0, x1) = (sx(a), sx(cc));
                let (y0, y1) = (sy(d), sy(b));
                let _ = writeln!(
                    out,
                    "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"/>",
                    c(x0),
                    c(y0),
                    c(x1 - x0),
                    c(y1 - y0)
                );
            }
            let _ = writeln!(out, "</g>");
            // Axes through the origin.
            if self.re.0 < 0.0 && self.re.1 > 0.0 {
                let _ = writeln!(
                    out,
                    "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{}\" stroke=\"#888888\" stroke-width=\"0.7\"/>",
                    c(top),
                    c(top + ph),
                    x = c(sx(0.0))
                );
            }
            if self.im.0 < 0.0 && self.im.1 > 0.0 {
                let _ = writeln!(
                    out,
                    "<line x1=\"{}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"#888888\" stroke-width=\"0.7\"/>",
                    c(left),
                    c(left + pw),
                    y = c(sy(0.0))
                );
            }
            for curve in &panel.curves {
                let coords: Vec<String> = curve
                    .iter()
                    .filter(|p| p.0.is_finite() && p.1.is_finite())
                    .map(|&(x, y)| format!("{},{}", c(sx(x)), c(sy(y))))
                    .collect();
                let _ = writeln!(
                    out,
                    "<polygon fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\" points=\"{}\"/>",
                    PALETTE[3],
                    coords.join(" ")
                );
            }
            let _ = writeln!(out, "</g>");
            frame(&mut out, left, top, pw, ph);
            for &t in &ticks_x {
                let x = c(sx(t));
                let _ = writeln!(
                    out,
                    "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{}\" stroke=\"black\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\" font-size=\"10\">{}</text>",
                    c(top + ph),
                    c(top + ph + 4.0),
                    c(top + ph + 15.0),
                    tick_label(t)
                );
            }
            for &t in &ticks_y {
                let y = sy(t);
                let _ = writeln!(
                    out,
                    "<line x1=\"{}\" y1=\"{yy}\" x2=\"{}\" y2=\"{yy}\" stroke=\"black\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\" font-size=\"10\">{}</text>",
                    c(left - 4.0),
                    c(left),
                    c(left - 6.0),
                    c(y + 3.5),
                    tick_label(t),
                    yy = c(y)
                );
            }
            let _ = writeln!(
                out,
                "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"11\">Re z</text>",
                c(left + pw / 2.0),
                c(top + ph + 30.0)
            );
            let _ = writeln!(
                out,
                "<text x=\"{x}\" y=\"{y}\" text-anchor=\"middle\" font-size=\"11\" transform=\"rotate(-90 {x} {y})\">Im z</text>",
                x = c(left - 28.0),
                y = c(top + ph / 2.0)
            );
        }
        // Legend: one entry per line (the texts are long).
        let ly = height - 44.0;
        let _ = writeln!(
            out,
            "<rect x=\"30\" y=\"{}\" width=\"24\" height=\"12\" fill=\"{}\" fill-opacity=\"0.45\"/><text x=\"60\" y=\"{}\">{}</text>",
            c(ly - 10.0),
            PALETTE[0],
            c(ly),
            escape(&self.fill_label)
        );
        let _ = writeln!(
            out,
            "<line x1=\"30\" y1=\"{y}\" x2=\"54\" y2=\"{y}\" stroke=\"{}\" stroke-width=\"1.5\"/><text x=\"60\" y=\"{}\">{}</text>",
            PALETTE[3],
            c(ly + 22.0),
            escape(&self.curve_label),
            y = c(ly + 18.0)
        );
        out.push_str("</svg>\n");
        out
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
                let same_marker = std::mem::discriminant(&a.1) == std::mem::discriminant(&b.1);
                assert!(
                    a.0 != b.0 || (!same_marker && a.2 != b.2),
                    "series {i} and {j} look alike"
                );
            }
        }
    }

    #[test]
    fn minor_ticks_are_labelled_only_on_short_axes() {
        let t = minor_ticks(-4, -3);
        assert_eq!(t.len(), 8);
        assert!((t[0].0 - 2e-4).abs() < 1e-18 && (t[7].0 - 9e-4).abs() < 1e-18);
        let labelled: Vec<f64> = t.iter().filter(|x| x.1.is_some()).map(|x| x.0).collect();
        assert_eq!(labelled.len(), 2);
        assert!(minor_ticks(-4, 0).iter().all(|x| x.1.is_none()));
    }

    #[test]
    fn ticks_are_nice_and_inside() {
        assert_eq!(linear_ticks(-5.0, 3.0), vec![-4.0, -2.0, 0.0, 2.0]);
        let t = linear_ticks(-4.0, 4.0);
        assert_eq!(t, vec![-4.0, -2.0, 0.0, 2.0, 4.0]);
        assert!(linear_ticks(1.0, 1.0).is_empty());
    }

    #[test]
    fn loglog_plot_has_one_polyline_per_usable_series() {
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
        let svg = plot.render();
        assert_eq!(svg.matches("<polyline").count(), 1);
        assert!(svg.contains("a &lt; b"));
        assert!(svg.contains(">failed<"));
        assert!(svg.trim_end().ends_with("</svg>"));
    }
}
