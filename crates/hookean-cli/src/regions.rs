//! Regions of the complex plane as SVG, drawn with plotters: one small
//! panel per method over the same window (the stability regions, the
//! tutorial's figure 4), each with axes `Re z` / `Im z`, ticks and a title,
//! the region shaded and outlines (boundary loci) on top, and a legend
//! below the panels.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::lineplot::PALETTE;
use crate::plot::{draw_error, svg_document, tick_text};

/// One panel of a [`RegionPanels`] figure.
#[derive(Debug, Clone)]
pub struct Panel {
    /// Panel title (the method).
    pub title: String,
    /// Shaded axis-aligned rectangles `(re_lo, im_lo, re_hi, im_hi)` in
    /// data coordinates (the region).
    pub rects: Vec<(f64, f64, f64, f64)>,
    /// Outlines drawn on top (closed curves in data coordinates, e.g. a
    /// boundary locus), cut to the window.
    pub curves: Vec<Vec<(f64, f64)>>,
}

/// A grid of panels over the same window of the complex plane.
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

/// The parts of the closed polyline `curve` inside the window `re x im`:
/// runs of consecutive inside points, each extended to where its segments
/// cross the window's border (Liang-Barsky clipping of every segment).
fn clip_curve(curve: &[(f64, f64)], re: (f64, f64), im: (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    // Whether the first run starts at the curve's first point (inside).
    let mut starts_inside = None;
    let closed = curve.iter().chain(curve.first());
    for (p, q) in closed.clone().zip(closed.skip(1)) {
        let (d0, d1) = (q.0 - p.0, q.1 - p.1);
        // Parameter range [t0, t1] of p + t (q - p) inside the window.
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for (den, num) in [
            (-d0, p.0 - re.0),
            (d0, re.1 - p.0),
            (-d1, p.1 - im.0),
            (d1, im.1 - p.1),
        ] {
            if den == 0.0 {
                if num < 0.0 {
                    t0 = 2.0; // parallel and outside
                }
            } else if den < 0.0 {
                t0 = t0.max(num / den);
            } else {
                t1 = t1.min(num / den);
            }
        }
        if !(p.0.is_finite() && p.1.is_finite() && q.0.is_finite() && q.1.is_finite()) || t0 > t1 {
            open = false;
            continue;
        }
        let at = |t: f64| (p.0 + t * d0, p.1 + t * d1);
        starts_inside.get_or_insert(t0 == 0.0);
        if !open || t0 > 0.0 {
            runs.push(vec![at(t0)]);
        }
        if let Some(run) = runs.last_mut() {
            run.push(at(t1));
        }
        open = t1 >= 1.0;
    }
    // A closed curve that starts inside and is inside again at the end:
    // the last run continues into the first.
    if open && starts_inside == Some(true) && runs.len() > 1 {
        let first = runs.remove(0);
        if let Some(last) = runs.last_mut() {
            last.extend_from_slice(&first[1..]);
        }
    }
    runs
}

impl RegionPanels {
    /// The SVG document.
    pub fn render(&self) -> Result<String, String> {
        let (re, im) = (self.re, self.im);
        let cols = self.panels.len().clamp(1, 4);
        let rows = self.panels.len().div_ceil(cols).max(1);
        let aspect = (im.1 - im.0) / (re.1 - re.0);
        let pw = 200.0;
        let ph = (pw * aspect).clamp(80.0, 400.0);
        let (cell_w, cell_h) = ((pw + 80.0) as u32, (ph + 80.0) as u32);
        let (title_h, legend_h) = (44, 64);
        let (width, height) = (
            cols as u32 * cell_w + 20,
            rows as u32 * cell_h + title_h + legend_h,
        );
        let fill = PALETTE[0].mix(0.45).filled();
        let outline = PALETTE[3].stroke_width(2);
        svg_document((width, height), |root| {
            let (top, rest) = root.split_vertically(title_h);
            let (body, legend) = rest.split_vertically(rows as u32 * cell_h);
            top.draw(&Text::new(
                self.title.clone(),
                (width as i32 / 2, 24),
                ("sans-serif", 18)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            ))
            .map_err(draw_error)?;
            let cells = body.margin(0, 0, 10, 10).split_evenly((rows, cols));
            for (panel, cell) in self.panels.iter().zip(cells.iter()) {
                let mut chart = ChartBuilder::on(cell)
                    .caption(&panel.title, ("sans-serif", 15))
                    .margin(8)
                    .x_label_area_size(34)
                    .y_label_area_size(40)
                    .build_cartesian_2d(re.0..re.1, im.0..im.1)
                    .map_err(draw_error)?;
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_desc("Re z")
                    .y_desc("Im z")
                    .x_labels(6)
                    .y_labels(6)
                    .x_label_formatter(&|v| tick_text(*v))
                    .y_label_formatter(&|v| tick_text(*v))
                    .label_style(("sans-serif", 13))
                    .axis_desc_style(("sans-serif", 14))
                    .draw()
                    .map_err(draw_error)?;
                // Cells own half a grid spacing on each side: cut them to the window.
                chart
                    .draw_series(panel.rects.iter().map(|&(a, b, c, d)| {
                        Rectangle::new(
                            [(a.max(re.0), d.min(im.1)), (c.min(re.1), b.max(im.0))],
                            fill,
                        )
                    }))
                    .map_err(draw_error)?;
                let axis = RGBColor(136, 136, 136);
                if re.0 < 0.0 && re.1 > 0.0 {
                    chart
                        .draw_series([PathElement::new(vec![(0.0, im.0), (0.0, im.1)], axis)])
                        .map_err(draw_error)?;
                }
                if im.0 < 0.0 && im.1 > 0.0 {
                    chart
                        .draw_series([PathElement::new(vec![(re.0, 0.0), (re.1, 0.0)], axis)])
                        .map_err(draw_error)?;
                }
                for curve in &panel.curves {
                    chart
                        .draw_series(
                            clip_curve(curve, re, im)
                                .into_iter()
                                .map(|run| PathElement::new(run, outline)),
                        )
                        .map_err(draw_error)?;
                }
            }
            let text = |s: &str, x: i32, y: i32| {
                Text::new(
                    s.to_string(),
                    (x, y),
                    ("sans-serif", 13)
                        .into_font()
                        .color(&BLACK)
                        .pos(Pos::new(HPos::Left, VPos::Center)),
                )
            };
            legend
                .draw(&Rectangle::new([(30, 14), (54, 26)], fill))
                .map_err(draw_error)?;
            legend
                .draw(&text(&self.fill_label, 60, 20))
                .map_err(draw_error)?;
            legend
                .draw(&PathElement::new(vec![(30, 44), (54, 44)], outline))
                .map_err(draw_error)?;
            legend
                .draw(&text(&self.curve_label, 60, 44))
                .map_err(draw_error)?;
            Ok(())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A circle of radius 2 about the origin in the window [-1, 3] x [-1, 1]:
    /// what is left lies inside the window, ends on its border, and is the
    /// arc of the circle there.
    #[test]
    fn clipped_curves_stay_in_the_window_and_end_on_its_border() {
        let circle: Vec<(f64, f64)> = (0..360)
            .map(|k| {
                let a = (k as f64).to_radians();
                (2.0 * a.cos(), 2.0 * a.sin())
            })
            .collect();
        let (re, im) = ((-1.0, 3.0), (-1.0, 1.0));
        let runs = clip_curve(&circle, re, im);
        assert_eq!(runs.len(), 1, "{runs:?}"); // the arc through (2, 0)
        let run = &runs[0];
        let eps = 1e-12;
        for p in run {
            assert!(
                p.0 >= re.0 - eps && p.0 <= re.1 + eps && p.1 >= im.0 - eps && p.1 <= im.1 + eps
            );
        }
        let (first, last) = (run[0], run[run.len() - 1]);
        assert!((first.1.abs() - 1.0).abs() < eps && (last.1.abs() - 1.0).abs() < eps);
        // Inner points lie on the circle.
        for p in &run[1..run.len() - 1] {
            assert!((p.0.hypot(p.1) - 2.0).abs() < 1e-12);
        }
    }

    #[test]
    fn a_curve_outside_the_window_leaves_nothing() {
        let square = [(5.0, 5.0), (6.0, 5.0), (6.0, 6.0), (5.0, 6.0)];
        assert!(clip_curve(&square, (-1.0, 1.0), (-1.0, 1.0)).is_empty());
    }
}
