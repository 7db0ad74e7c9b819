//! A small software renderer for `final.png`: the model's triangles
//! projected orthographically from an elevated viewpoint, sorted back to
//! front (painter's algorithm), flat-shaded and coloured by particle speed
//! (blue = at rest, red = fastest), like the filtering paper's figure 7.
//! Models without triangles (ropes) are drawn as thick spring segments.

use std::path::Path;

use plotters::prelude::*;

use crate::plot::tick_text;
use crate::view::ViewCollider;

/// An RGB image being drawn (row-major, 3 bytes per pixel: the layout
/// plotters' bitmap backend draws on, see [`crate::plot::draw_on`]).
pub struct Canvas {
    width: usize,
    height: usize,
    rgb: Vec<u8>,
}

impl Canvas {
    /// A white canvas.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            rgb: vec![255; 3 * width * height],
        }
    }

    /// `(width, height)` in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The pixels, row-major RGB.
    pub fn rgb(&self) -> &[u8] {
        &self.rgb
    }

    /// The pixels, mutable.
    pub fn rgb_mut(&mut self) -> &mut [u8] {
        &mut self.rgb
    }

    /// Sets one pixel (ignored outside the canvas).
    pub fn set(&mut self, x: usize, y: usize, colour: [u8; 3]) {
        if x < self.width && y < self.height {
            let k = 3 * (y * self.width + x);
            self.rgb[k..k + 3].copy_from_slice(&colour);
        }
    }

    /// Fills the triangle with corners `p` (pixel coordinates) in one colour.
    pub fn fill_triangle(&mut self, p: [[f64; 2]; 3], colour: [u8; 3]) {
        let min_x = p
            .iter()
            .map(|q| q[0])
            .fold(f64::INFINITY, f64::min)
            .floor()
            .max(0.0) as usize;
        let max_x = p
            .iter()
            .map(|q| q[0])
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil();
        let min_y = p
            .iter()
            .map(|q| q[1])
            .fold(f64::INFINITY, f64::min)
            .floor()
            .max(0.0) as usize;
        let max_y = p
            .iter()
            .map(|q| q[1])
            .fold(f64::NEG_INFINITY, f64::max)
            .ceil();
        if max_x < 0.0 || max_y < 0.0 {
            return;
        }
        let max_x = (max_x as usize).min(self.width.saturating_sub(1));
        let max_y = (max_y as usize).min(self.height.saturating_sub(1));
        let edge = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
            (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        };
        let area = edge(p[0], p[1], p[2]);
        if area.abs() < 1e-12 {
            return;
        }
        for y in min_y..=max_y {
            for x in min_x..=max_x {
                let c = [x as f64 + 0.5, y as f64 + 0.5];
                let w0 = edge(p[1], p[2], c) / area;
                let w1 = edge(p[2], p[0], c) / area;
                let w2 = edge(p[0], p[1], c) / area;
                if w0 >= -1e-9 && w1 >= -1e-9 && w2 >= -1e-9 {
                    self.set(x, y, colour);
                }
            }
        }
    }

    /// Draws a segment of the given half-width as two triangles.
    pub fn thick_line(&mut self, a: [f64; 2], b: [f64; 2], half_width: f64, colour: [u8; 3]) {
        let d = [b[0] - a[0], b[1] - a[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt().max(1e-12);
        let n = [-d[1] / len * half_width, d[0] / len * half_width];
        let q = [
            [a[0] + n[0], a[1] + n[1]],
            [b[0] + n[0], b[1] + n[1]],
            [b[0] - n[0], b[1] - n[1]],
            [a[0] - n[0], a[1] - n[1]],
        ];
        self.fill_triangle([q[0], q[1], q[2]], colour);
        self.fill_triangle([q[0], q[2], q[3]], colour);
    }

    /// The pixels as RGB triples.
    #[cfg(test)]
    pub fn pixels(&self) -> Vec<[u8; 3]> {
        self.rgb
            .chunks_exact(3)
            .map(|p| [p[0], p[1], p[2]])
            .collect()
    }

    /// Writes the canvas as an 8-bit RGB PNG, replacing `path` whole (a link
    /// there is replaced, never written through: `output::replace_file`).
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        crate::output::replace_file(path, |w| {
            let mut encoder = png::Encoder::new(w, self.width as u32, self.height as u32);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
            writer
                .write_image_data(self.rgb())
                .map_err(std::io::Error::other)?;
            writer.finish().map_err(std::io::Error::other)
        })
        .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// Blue (slow) to red (fast) through white-ish green, for `t` in [0, 1].
pub fn speed_colour(t: f64) -> [f64; 3] {
    let t = t.clamp(0.0, 1.0);
    if t < 0.5 {
        let s = t / 0.5;
        [0.15 + 0.25 * s, 0.35 + 0.5 * s, 0.9 - 0.3 * s]
    } else {
        let s = (t - 0.5) / 0.5;
        [0.4 + 0.55 * s, 0.85 - 0.6 * s, 0.6 - 0.45 * s]
    }
}

/// What `final.png` shows.
pub struct RenderScene<'a> {
    /// Positions, `3 n` values.
    pub x: &'a [f64],
    /// Velocities, `3 n` values (colour = speed).
    pub v: &'a [f64],
    /// Triangles, shaded; without them the `segments` are drawn.
    pub faces: &'a [[usize; 3]],
    /// Springs drawn as thick lines when there are no faces.
    pub segments: &'a [(usize, usize)],
    /// Planes (the first is the ground), spheres and meshes.
    pub colliders: &'a [ViewCollider],
    /// The box the view is fitted to: every frame of the run, so that the
    /// scale is the run's (an exploded run does not shrink back into view).
    pub bounds: ([f64; 3], [f64; 3]),
    /// The top of the fixed colour scale (m/s).
    pub speed_max: f64,
    /// Simulated time of the state.
    pub t: f64,
}

/// Width of the colour-bar strip on the right.
const BAR_STRIP: usize = 120;

/// One thing the painter's algorithm draws.
#[derive(Debug, Clone, Copy)]
enum Item {
    Face(usize),
    Segment(usize),
    Sphere([f64; 3], f64),
    /// A piece of a mesh collider's triangle.
    MeshFace(usize),
}

/// An orthographic camera looking along `-dir` from an elevated front-left
/// viewpoint (z up), scaled so that the run's box (and the spheres) fill
/// 80% of the view.
struct Camera {
    right: [f64; 3],
    up: [f64; 3],
    dir: [f64; 3],
    /// Pixels per metre.
    scale: f64,
    /// Projected centre of the fitted box.
    centre: [f64; 2],
    /// Pixel position of `centre`.
    origin: [f64; 2],
}

impl Camera {
    fn fit(s: &RenderScene<'_>, view_w: usize, height: usize) -> Self {
        let dir = normalise([0.8, -1.6, 1.0]);
        let right = normalise(cross([0.0, 0.0, 1.0], dir));
        let up = cross(dir, right);
        let mut cam = Camera {
            right,
            up,
            dir,
            scale: 1.0,
            centre: [0.0; 2],
            origin: [view_w as f64 / 2.0, height as f64 * 0.53],
        };
        let (lo3, hi3) = s.bounds;
        let corners = (0..8).map(|c| {
            let p = [
                if c & 1 == 0 { lo3[0] } else { hi3[0] },
                if c & 2 == 0 { lo3[1] } else { hi3[1] },
                if c & 4 == 0 { lo3[2] } else { hi3[2] },
            ];
            (cam.project(&p), 0.0)
        });
        let spheres = s.colliders.iter().filter_map(|c| match c {
            ViewCollider::Sphere { center, radius } => Some((cam.project(center), *radius)),
            _ => None,
        });
        let meshes: Vec<([f64; 3], f64)> = s
            .colliders
            .iter()
            .flat_map(|c| c.mesh_vertices_at(s.t))
            .map(|p| (cam.project(&p), 0.0))
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (q, r) in corners.chain(spheres).chain(meshes) {
            for c in 0..2 {
                lo[c] = lo[c].min(q[c] - r);
                hi[c] = hi[c].max(q[c] + r);
            }
        }
        let span = ((hi[0] - lo[0]) / view_w as f64)
            .max((hi[1] - lo[1]) / height as f64)
            .max(1e-9);
        cam.scale = 0.8 / span;
        cam.centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        cam
    }

    /// Camera coordinates `(right, up, depth)`; larger depth is nearer.
    fn project(&self, p: &[f64]) -> [f64; 3] {
        [dot3(p, &self.right), dot3(p, &self.up), dot3(p, &self.dir)]
    }

    /// Pixel coordinates of camera coordinates `q`.
    fn pixel(&self, q: &[f64; 3]) -> [f64; 2] {
        [
            self.origin[0] + (q[0] - self.centre[0]) * self.scale,
            self.origin[1] - (q[1] - self.centre[1]) * self.scale,
        ]
    }
}

/// Draws the ground, a square of twice the run's extent with grid lines:
/// the first plane collider, or the horizontal plane under the lowest point
/// of the run. Returns the grid spacing (m) and whether the plane is implied.
fn draw_ground(canvas: &mut Canvas, cam: &Camera, s: &RenderScene<'_>) -> (f64, bool) {
    let (lo3, hi3) = s.bounds;
    let (point, normal, implied) = s
        .colliders
        .iter()
        .find_map(|c| match c {
            ViewCollider::Plane { point, normal } => Some((*point, normalise(*normal), false)),
            _ => None,
        })
        .unwrap_or(([0.0, 0.0, lo3[2]], [0.0, 0.0, 1.0], true));
    // Centred under the middle of the box, spanned by u and w.
    let mid: [f64; 3] = std::array::from_fn(|c| (lo3[c] + hi3[c]) / 2.0);
    let off = dot3(&sub(&mid, &point), &normal);
    let o: [f64; 3] = std::array::from_fn(|c| mid[c] - off * normal[c]);
    let axis = if normal[2].abs() < 0.9 {
        [0.0, 0.0, 1.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let u = normalise(cross(axis, normal));
    let w = cross(normal, u);
    let half = (0..3).map(|c| hi3[c] - lo3[c]).fold(1e-3, f64::max);
    let grid = crate::view::nice_ceiling(2.0 * half / 12.0);
    let at = |a: f64, b: f64| -> [f64; 2] {
        let p: [f64; 3] = std::array::from_fn(|c| o[c] + a * u[c] + b * w[c]);
        cam.pixel(&cam.project(&p))
    };
    let fill = [236, 236, 232];
    canvas.fill_triangle([at(-half, -half), at(half, -half), at(half, half)], fill);
    canvas.fill_triangle([at(-half, -half), at(half, half), at(-half, half)], fill);
    let k = (half / grid).floor() as i64;
    for i in -k..=k {
        let a = i as f64 * grid;
        let line = [200, 200, 196];
        canvas.thick_line(at(a, -half), at(a, half), 0.6, line);
        canvas.thick_line(at(-half, a), at(half, a), 0.6, line);
    }
    (grid, implied)
}

/// Draws a ball as a disc shaded by Lambert's law with the light `light`,
/// 2% smaller than its radius: flat triangles resting on it cut into the
/// true sphere and would disappear behind it.
fn draw_sphere(
    canvas: &mut Canvas,
    cam: &Camera,
    center: &[f64; 3],
    radius: f64,
    light: &[f64; 3],
) {
    let (width, height) = canvas.size();
    let light_cam = cam.project(light);
    let c = cam.pixel(&cam.project(center));
    let r = 0.98 * radius * cam.scale;
    let (x0, x1) = ((c[0] - r).floor().max(0.0), (c[0] + r).ceil().max(0.0));
    let (y0, y1) = ((c[1] - r).floor().max(0.0), (c[1] + r).ceil().max(0.0));
    for y in y0 as usize..=(y1 as usize).min(height.saturating_sub(1)) {
        for x in x0 as usize..=(x1 as usize).min(width.saturating_sub(1)) {
            // The visible hemisphere's normal at this pixel, in camera coordinates.
            let (dx, dy) = ((x as f64 + 0.5 - c[0]) / r, (c[1] - y as f64 - 0.5) / r);
            let q = dx * dx + dy * dy;
            if q <= 1.0 {
                let nz = (1.0 - q).sqrt();
                let lambert = (dx * light_cam[0] + dy * light_cam[1] + nz * light_cam[2]).max(0.0);
                let shade = 0.35 + 0.65 * lambert;
                canvas.set(x, y, to_u8([0.78 * shade, 0.74 * shade, 0.68 * shade]));
            }
        }
    }
}

/// Renders the scene: the ground (a plane collider, or a horizontal plane
/// under the lowest point of the run) with a grid, spheres, and the model's
/// triangles (or springs) sorted back to front, flat-shaded and coloured by
/// speed on the fixed scale `[0, speed_max]`; then, with plotters, the time,
/// the colour bar in m/s, a scale bar and a note on what is drawn.
pub fn render(s: &RenderScene<'_>, width: usize, height: usize) -> Result<Canvas, String> {
    let mut canvas = Canvas::new(width, height);
    let view_w = width.saturating_sub(BAR_STRIP).max(width / 2);
    let cam = Camera::fit(s, view_w, height);
    let light = normalise([0.3, -0.5, 1.0]);
    let (grid, implied) = draw_ground(&mut canvas, &cam, s);

    let proj: Vec<[f64; 3]> = s.x.chunks_exact(3).map(|p| cam.project(p)).collect();
    let px = |i: usize| cam.pixel(&proj[i]);
    let speeds: Vec<f64> =
        s.v.chunks_exact(3)
            .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
            .collect();
    let top = s.speed_max.max(1e-12);
    // Painter's algorithm: far items (small depth) first; depths are sums
    // over three points so that faces, segments and spheres compare.
    let mut items: Vec<(f64, Item)> = if s.faces.is_empty() {
        s.segments
            .iter()
            .enumerate()
            .map(|(k, &(i, j))| (1.5 * (proj[i][2] + proj[j][2]), Item::Segment(k)))
            .collect()
    } else {
        s.faces
            .iter()
            .enumerate()
            .map(|(k, f)| (proj[f[0]][2] + proj[f[1]][2] + proj[f[2]][2], Item::Face(k)))
            .collect()
    };
    // Mesh colliders at the time of the state, cut into pieces about the
    // size of the cloth's: the painter's algorithm sorts whole triangles,
    // and a table top drawn as one triangle would cover the cloth on it.
    let (lo3, hi3) = s.bounds;
    let piece = (0..3).map(|c| hi3[c] - lo3[c]).fold(1e-3, f64::max) / 48.0;
    let meshes: Vec<[[f64; 3]; 3]> = s
        .colliders
        .iter()
        .flat_map(|c| {
            let v = c.mesh_vertices_at(s.t);
            let triangles = match c {
                ViewCollider::Mesh { triangles, .. } => triangles.clone(),
                _ => Vec::new(),
            };
            triangles
                .into_iter()
                .flat_map(move |t| subdivide(t.map(|i| v[i]), piece))
                .collect::<Vec<_>>()
        })
        .collect();
    for c in s.colliders {
        if let ViewCollider::Sphere { center, radius } = c {
            items.push((3.0 * cam.project(center)[2], Item::Sphere(*center, *radius)));
        }
    }
    for (k, t) in meshes.iter().enumerate() {
        let depth: f64 = t.iter().map(|p| cam.project(p)[2]).sum();
        items.push((depth, Item::MeshFace(k)));
    }
    items.sort_by(|a, b| a.0.total_cmp(&b.0));
    let half_width = (width.min(height) as f64 / 200.0).max(1.5);
    for (_, item) in items {
        match item {
            Item::Segment(k) => {
                let (i, j) = s.segments[k];
                let c = speed_colour(0.5 * (speeds[i] + speeds[j]) / top);
                canvas.thick_line(px(i), px(j), half_width, to_u8(c));
            }
            Item::Face(k) => {
                let f = s.faces[k];
                let p: Vec<&[f64]> = f.iter().map(|&i| &s.x[3 * i..3 * i + 3]).collect();
                let normal = normalise(cross(sub(p[1], p[0]), sub(p[2], p[0])));
                // Two-sided lighting: cloth has no inside.
                let shade = 0.35 + 0.65 * dot3(&normal, &light).abs();
                let c = speed_colour((speeds[f[0]] + speeds[f[1]] + speeds[f[2]]) / (3.0 * top));
                canvas.fill_triangle(
                    [px(f[0]), px(f[1]), px(f[2])],
                    to_u8([c[0] * shade, c[1] * shade, c[2] * shade]),
                );
            }
            Item::Sphere(center, radius) => draw_sphere(&mut canvas, &cam, &center, radius, &light),
            Item::MeshFace(k) => {
                let p = meshes[k];
                let normal = normalise(cross(sub(&p[1], &p[0]), sub(&p[2], &p[0])));
                let shade = 0.35 + 0.65 * dot3(&normal, &light).abs();
                let px3 = p.map(|q| cam.pixel(&cam.project(&q)));
                canvas.fill_triangle(px3, to_u8([0.78 * shade, 0.74 * shade, 0.68 * shade]));
            }
        }
    }
    draw_labels(&mut canvas, s, &cam, view_w, grid, implied)?;
    Ok(canvas)
}

/// The time, what the ground and the spheres are, a scale bar in metres
/// and the colour bar of speed in m/s.
fn draw_labels(
    canvas: &mut Canvas,
    s: &RenderScene<'_>,
    cam: &Camera,
    view_w: usize,
    grid: f64,
    implied: bool,
) -> Result<(), String> {
    let (width, height) = canvas.size();
    let bar_h = (height as i32 - 150).max(40);
    let scale_m = crate::view::nice_ceiling(0.2 * view_w as f64 / cam.scale);
    let scale_px = (scale_m * cam.scale).round() as i32;
    let note = if implied {
        format!(
            "ground: grid of {} m squares under the run's lowest point",
            tick_text(grid)
        )
    } else {
        format!(
            "ground: plane collider, grid of {} m squares",
            tick_text(grid)
        )
    };
    let spheres: Vec<String> = s
        .colliders
        .iter()
        .filter_map(|c| match c {
            ViewCollider::Sphere { radius, .. } => {
                Some(format!("sphere collider r = {} m", tick_text(*radius)))
            }
            ViewCollider::Mesh { triangles, .. } => {
                Some(format!("mesh collider ({} triangles)", triangles.len()))
            }
            _ => None,
        })
        .collect();
    let top = s.speed_max.max(1e-12);
    crate::plot::draw_on(canvas, |root| {
        let big = ("sans-serif", 22).into_font().color(&BLACK);
        let small = ("sans-serif", 14).into_font().color(&RGBColor(60, 60, 60));
        let err = crate::plot::draw_error;
        root.draw(&Text::new(format!("t = {:.3} s", s.t), (12, 10), big))
            .map_err(err)?;
        root.draw(&Text::new(note, (12, 40), small.clone()))
            .map_err(err)?;
        if !spheres.is_empty() {
            root.draw(&Text::new(spheres.join(", "), (12, 58), small.clone()))
                .map_err(err)?;
        }
        let (sx, sy) = (16, height as i32 - 24);
        root.draw(&PathElement::new(
            vec![
                (sx, sy - 5),
                (sx, sy),
                (sx + scale_px, sy),
                (sx + scale_px, sy - 5),
            ],
            BLACK.stroke_width(2),
        ))
        .map_err(err)?;
        root.draw(&Text::new(
            format!("{} m", tick_text(scale_m)),
            (sx + scale_px + 8, sy - 10),
            small,
        ))
        .map_err(err)?;
        crate::plot::colour_bar(
            root,
            (width as i32 - 110, 75, 20, bar_h),
            (0.0, s.speed_max),
            |v| {
                let c = to_u8(speed_colour(v / top));
                RGBColor(c[0], c[1], c[2])
            },
            None,
            "speed |v| (m/s)",
        )
    })
}

/// Triangle `t` cut into `k^2` similar pieces, `k` the smallest count that
/// makes every edge at most `size` (at most 64 per edge).
fn subdivide(t: [[f64; 3]; 3], size: f64) -> Vec<[[f64; 3]; 3]> {
    let longest = (0..3)
        .map(|e| {
            let d = sub(&t[(e + 1) % 3], &t[e]);
            (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        })
        .fold(0.0, f64::max);
    let k = ((longest / size).ceil() as usize).clamp(1, 64);
    let at = |i: usize, j: usize| -> [f64; 3] {
        let (a, b) = (i as f64 / k as f64, j as f64 / k as f64);
        std::array::from_fn(|c| t[0][c] + a * (t[1][c] - t[0][c]) + b * (t[2][c] - t[0][c]))
    };
    let mut out = Vec::with_capacity(k * k);
    for i in 0..k {
        for j in 0..k - i {
            out.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
            if i + j + 1 < k {
                out.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    out
}

fn to_u8(c: [f64; 3]) -> [u8; 3] {
    c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
}

fn dot3(a: &[f64], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub(a: &[f64], b: &[f64]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalise(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt().max(1e-300);
    [a[0] / l, a[1] / l, a[2] / l]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_covers_about_half_its_bounding_box() {
        let mut c = Canvas::new(100, 100);
        c.fill_triangle([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0]], [0, 0, 0]);
        let dark = c.pixels().iter().filter(|p| **p == [0, 0, 0]).count();
        assert!((dark as f64 - 5000.0).abs() < 150.0, "{dark}");
    }

    #[test]
    fn subdivided_triangles_tile_the_triangle() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        let pieces = subdivide(t, 0.5);
        // Longest edge sqrt(5) = 2.24: k = 5, 25 pieces of a 25th of the area.
        assert_eq!(pieces.len(), 25);
        let area = |p: &[[f64; 3]; 3]| {
            let c = cross(sub(&p[1], &p[0]), sub(&p[2], &p[0]));
            0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
        };
        let total: f64 = pieces.iter().map(area).sum();
        assert!((total - area(&t)).abs() < 1e-12);
    }

    #[test]
    fn a_flat_square_renders_non_blank_and_inside_the_frame() {
        let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
        let v = [0.0; 12];
        let scene = RenderScene {
            x: &x,
            v: &v,
            faces: &[[0, 1, 2], [0, 2, 3]],
            segments: &[],
            colliders: &[],
            bounds: ([0.0; 3], [1.0, 1.0, 0.0]),
            speed_max: 1.0,
            t: 0.0,
        };
        let c = render(&scene, 400, 300).unwrap();
        // At rest: the square is drawn in the colour of speed 0 (shaded), nothing in red.
        let blue = c
            .pixels()
            .iter()
            .filter(|p| p[2] > 150 && p[0] < 100)
            .count();
        assert!(blue > 400 * 300 / 20, "{blue}");
        let red_in_view = (0..300)
            .flat_map(|y| (0..400 - BAR_STRIP).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                let p = c.pixels()[y * 400 + x];
                p[0] > 200 && p[1] < 120 && p[2] < 100
            })
            .count();
        assert_eq!(red_in_view, 0);
    }
}
