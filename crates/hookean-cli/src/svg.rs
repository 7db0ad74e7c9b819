//! Hand-written SVG: panels of shaded regions of the complex plane with
//! linear ticks (the stability regions; one clipped group of run-length
//! rectangles per panel keeps the file small). Line plots are in
//! [`crate::lineplot`] (plotters).

use std::fmt::Write as _;

use plotters::style::RGBColor;

use crate::lineplot::PALETTE;

/// `#rrggbb` of colour `k` of the line plots' palette.
fn palette(k: usize) -> String {
    let RGBColor(r, g, b) = PALETTE[k];
    format!("#{r:02x}{g:02x}{b:02x}")
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
                palette(0)
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
                    palette(3),
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
            palette(0),
            c(ly),
            escape(&self.fill_label)
        );
        let _ = writeln!(
            out,
            "<line x1=\"30\" y1=\"{y}\" x2=\"54\" y2=\"{y}\" stroke=\"{}\" stroke-width=\"1.5\"/><text x=\"60\" y=\"{}\">{}</text>",
            palette(3),
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
    fn ticks_are_nice_and_inside() {
        assert_eq!(linear_ticks(-5.0, 3.0), vec![-4.0, -2.0, 0.0, 2.0]);
        let t = linear_ticks(-4.0, 4.0);
        assert_eq!(t, vec![-4.0, -2.0, 0.0, 2.0, 4.0]);
        assert!(linear_ticks(1.0, 1.0).is_empty());
    }
}
