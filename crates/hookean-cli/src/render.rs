//! A small software renderer for `final.png`: the model's triangles
//! projected orthographically from an elevated viewpoint, sorted back to
//! front (painter's algorithm), coloured by particle speed (blue = at rest,
//! red = fastest, like the filtering paper's figure 7) and shaded by the
//! surface normal, so that folds read as shapes. Models without triangles
//! (ropes) are drawn as thick spring segments.
//!
//! **Shading** ([`shade`]): two-sided diffuse light from the fixed
//! direction [`light`] with an ambient term, `I = AMBIENT + DIFFUSE
//! max(0, n_s . l)`, where `n_s` is the unit normal turned to the side the
//! viewer sees (a triangle seen from behind is lit by its flipped normal:
//! cloth has no inside). The cloth's normals are the area-weighted vertex
//! normals ([`hookean::massspring::surface::vertex_normals`]); each
//! vertex's colour is its speed colour times its `I`, interpolated across
//! the triangle (Gouraud shading). Colliders are shaded by the same law
//! with their faces' normals.

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
        self.fill_by(p, |_| colour);
    }

    /// Fills the triangle with corners `p`, the colour of each pixel the
    /// corners' `colours` (RGB in [0, 1]) weighted by its barycentric
    /// coordinates (Gouraud shading).
    pub fn fill_triangle_gouraud(&mut self, p: [[f64; 2]; 3], colours: [[f64; 3]; 3]) {
        self.fill_by(p, |w| {
            to_u8(std::array::from_fn(|c| {
                w[0] * colours[0][c] + w[1] * colours[1][c] + w[2] * colours[2][c]
            }))
        });
    }

    /// Sets every pixel whose centre is in the triangle `p` to `colour` of
    /// its barycentric coordinates.
    fn fill_by(&mut self, p: [[f64; 2]; 3], colour: impl Fn([f64; 3]) -> [u8; 3]) {
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
                    self.set(x, y, colour([w0, w1, w2]));
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

/// The ambient term of [`shade`]: the intensity of a surface turned away
/// from the light.
pub const AMBIENT: f64 = 0.3;
/// The diffuse term of [`shade`]: `AMBIENT + DIFFUSE = 1` for a surface
/// facing the light, which is drawn in its base colour.
pub const DIFFUSE: f64 = 0.7;

/// The unit direction towards the light (z up: from above, front left,
/// the viewer's side), shared by `final.png` and `view.html`.
pub fn light() -> [f64; 3] {
    normalise([0.3, -0.5, 1.0])
}

/// Two-sided diffuse intensity `AMBIENT + DIFFUSE max(0, n_s . l)` of a
/// surface of unit normal `normal` seen from the side `facing` (+1: the
/// side `normal` points to, -1: the other; `n_s = facing normal`).
pub fn shade(normal: &[f64; 3], facing: f64, light: &[f64; 3]) -> f64 {
    AMBIENT + DIFFUSE * (facing.signum() * dot3(normal, light)).max(0.0)
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

/// Draws a ball as a disc shaded by [`shade`] with the light `light`,
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
                let n = [dx, dy, (1.0 - q).sqrt()];
                let i = shade(&n, 1.0, &light_cam);
                canvas.set(x, y, to_u8(BODY.map(|c| c * i)));
            }
        }
    }
}

/// The colour of colliders (before shading).
const BODY: [f64; 3] = [0.78, 0.74, 0.68];

/// Renders the scene: the ground (a plane collider, or a horizontal plane
/// under the lowest point of the run) with a grid, spheres, mesh colliders
/// at their pose at the state's time, and the model's triangles (or
/// springs) sorted back to front, coloured by speed on the fixed scale
/// `[0, speed_max]` and shaded (module docs); then, with plotters, the
/// time, the colour bar in m/s, a scale bar and a note on what is drawn.
pub fn render(s: &RenderScene<'_>, width: usize, height: usize) -> Result<Canvas, String> {
    let mut canvas = Canvas::new(width, height);
    let view_w = width.saturating_sub(BAR_STRIP).max(width / 2);
    let cam = Camera::fit(s, view_w, height);
    let light = light();
    let (grid, implied) = draw_ground(&mut canvas, &cam, s);
    let mut normals = vec![0.0; s.x.len()];
    hookean::massspring::surface::vertex_normals(s.x, s.faces, &mut normals);

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
    // A collider's pieces sort one piece size farther than they are: cloth
    // resting on a surface (at the contact thickness, far less than a piece
    // above it) is drawn over it, not speckled by pieces whose centroids
    // happen to be nearer than the cloth triangle's above them.
    for (k, t) in meshes.iter().enumerate() {
        let depth: f64 = t.iter().map(|p| cam.project(p)[2]).sum();
        items.push((depth - 3.0 * piece, Item::MeshFace(k)));
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
                let face = face_normal(f.map(|i| point(s.x, i)));
                // The side the camera sees: a face seen from behind is lit by its flipped normal.
                let facing = dot3(&face, &cam.dir);
                let colours = f.map(|i| {
                    let n = point(&normals, i);
                    let n = if n == [0.0; 3] { face } else { n };
                    let c = speed_colour(speeds[i] / top);
                    let shade = shade(&n, facing, &light);
                    c.map(|v| v * shade)
                });
                canvas.fill_triangle_gouraud([px(f[0]), px(f[1]), px(f[2])], colours);
            }
            Item::Sphere(center, radius) => draw_sphere(&mut canvas, &cam, &center, radius, &light),
            Item::MeshFace(k) => {
                let p = meshes[k];
                let normal = face_normal(p);
                let shade = shade(&normal, dot3(&normal, &cam.dir), &light);
                let px3 = p.map(|q| cam.pixel(&cam.project(&q)));
                canvas.fill_triangle(px3, to_u8(BODY.map(|c| c * shade)));
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

/// Point `i` of the flat array `x`.
fn point(x: &[f64], i: usize) -> [f64; 3] {
    [x[3 * i], x[3 * i + 1], x[3 * i + 2]]
}

/// The unit normal of the counter-clockwise side of a triangle.
fn face_normal(p: [[f64; 3]; 3]) -> [f64; 3] {
    normalise(cross(sub(&p[1], &p[0]), sub(&p[2], &p[0])))
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

    /// The corners of the unit square of centre `c` spanned by the unit
    /// vectors `e1` and `e2` (counter-clockwise about `e1 x e2`).
    fn square(c: [f64; 3], e1: [f64; 3], e2: [f64; 3]) -> Vec<f64> {
        [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
            .iter()
            .flat_map(|&(a, b)| (0..3).map(move |k| c[k] + a * e1[k] + b * e2[k]))
            .collect()
    }

    /// The pixel at the projected centre of a square drawn alone, its
    /// corners `x`, its four vertices at `speed` on the scale [0, 1].
    fn centre_pixel(x: &[f64], faces: &[[usize; 3]], speed: f64) -> [u8; 3] {
        let v: Vec<f64> = (0..4).flat_map(|_| [speed, 0.0, 0.0]).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in x.chunks_exact(3) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let scene = RenderScene {
            x,
            v: &v,
            faces,
            segments: &[],
            colliders: &[],
            bounds: (lo, hi),
            speed_max: 1.0,
            t: 0.0,
        };
        let (w, h) = (400, 300);
        let canvas = render(&scene, w, h).unwrap();
        let cam = Camera::fit(&scene, w - BAR_STRIP, h);
        let centre: [f64; 3] = std::array::from_fn(|k| (x[k] + x[6 + k]) / 2.0);
        let p = cam.pixel(&cam.project(&centre));
        canvas.pixels()[p[1] as usize * w + p[0] as usize]
    }

    /// Unit vectors `e1`, `e2` with `e1 x e2 = n` (unit `n`).
    fn basis(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
        let e1 = normalise(cross([0.0, 0.0, 1.0], n));
        (e1, cross(n, e1))
    }

    fn rotate_towards(a: [f64; 3], b: [f64; 3], degrees: f64) -> [f64; 3] {
        let (c, s) = (degrees.to_radians().cos(), degrees.to_radians().sin());
        std::array::from_fn(|k| c * a[k] + s * b[k])
    }

    /// The light's direction tilted by 60 degrees (about a line across
    /// it), the way that turns it to the camera (`Camera::dir`).
    fn tilted_60() -> [f64; 3] {
        let (_, e2) = basis(light());
        let eye = normalise([0.8, -1.6, 1.0]);
        let tilt = if dot3(&e2, &eye) > 0.0 {
            e2
        } else {
            e2.map(|c| -c)
        };
        rotate_towards(light(), tilt, 60.0)
    }

    /// The blue channel of the colour of speed 0 (0.9) under intensity `i`.
    fn blue_at(i: f64) -> f64 {
        255.0 * 0.9 * i
    }

    /// A square facing the light is drawn in its base colour (I = 0.3 +
    /// 0.7 = 1); one tilted by 60 degrees (towards the viewer) at I = 0.3 +
    /// 0.7 cos 60 = 0.65; one facing the viewer with the light behind it
    /// at the ambient 0.3 alone (its normal 100 degrees from the light).
    #[test]
    fn intensity_is_ambient_plus_diffuse_cosine() {
        let l = light();
        let faces = [[0, 1, 2], [0, 2, 3]];
        let (e1, e2) = basis(l);
        let facing = centre_pixel(&square([0.0; 3], e1, e2), &faces, 0.0);
        assert!((facing[2] as f64 - blue_at(1.0)).abs() <= 1.0, "{facing:?}");

        let eye = normalise([0.8, -1.6, 1.0]);
        let n = tilted_60();
        assert!(dot3(&n, &eye) > 0.2);
        let (f1, f2) = basis(n);
        let tilted = centre_pixel(&square([0.0; 3], f1, f2), &faces, 0.0);
        assert!(
            (tilted[2] as f64 - blue_at(0.65)).abs() <= 1.0,
            "{tilted:?}"
        );
        let ratio = tilted[2] as f64 / facing[2] as f64;
        assert!((ratio - 0.65).abs() < 0.01, "{ratio}");

        // Normal 100 degrees from the light, in the plane of the light and
        // the eye: still facing the eye (n . eye > 0), lit from behind.
        let m = normalise(std::array::from_fn(|k| eye[k] - dot3(&eye, &l) * l[k]));
        let n = rotate_towards(l, m, 100.0);
        assert!(dot3(&n, &eye) > 0.2 && dot3(&n, &l) < 0.0);
        let (g1, g2) = basis(n);
        let behind = centre_pixel(&square([0.0; 3], g1, g2), &faces, 0.0);
        assert!((behind[2] as f64 - blue_at(0.3)).abs() <= 1.0, "{behind:?}");
    }

    /// The square facing the light with its triangles wound the other way
    /// (so seen from behind) is lit by its flipped normal: the same pixel.
    #[test]
    fn a_face_seen_from_behind_is_lit_like_its_front() {
        let (e1, e2) = basis(light());
        let x = square([0.0; 3], e1, e2);
        let front = centre_pixel(&x, &[[0, 1, 2], [0, 2, 3]], 0.0);
        let back = centre_pixel(&x, &[[0, 2, 1], [0, 3, 2]], 0.0);
        assert_eq!(front, back);
        // Tilted by 60 degrees as well.
        let (f1, f2) = basis(tilted_60());
        let x = square([0.0; 3], f1, f2);
        let front = centre_pixel(&x, &[[0, 1, 2], [0, 2, 3]], 0.0);
        let back = centre_pixel(&x, &[[0, 2, 1], [0, 3, 2]], 0.0);
        assert_eq!(front, back);
    }

    /// The hue (degrees) of an RGB colour.
    fn hue(c: [f64; 3]) -> f64 {
        let (max, min) = (c[0].max(c[1]).max(c[2]), c[0].min(c[1]).min(c[2]));
        let d = max - min;
        let h = if max == c[0] {
            (c[1] - c[2]) / d
        } else if max == c[1] {
            2.0 + (c[2] - c[0]) / d
        } else {
            4.0 + (c[0] - c[1]) / d
        };
        (60.0 * h).rem_euclid(360.0)
    }

    /// Shading scales a colour, so the hue of a slow and of a fast square
    /// (tilted 60 degrees: I = 0.65) is that of the speed colour: blue
    /// (0.15, 0.35, 0.9) has hue 224 degrees, the top of the scale (0.95,
    /// 0.25, 0.15) 7.5 degrees.
    #[test]
    fn the_speed_colour_survives_shading() {
        let (f1, f2) = basis(tilted_60());
        let x = square([0.0; 3], f1, f2);
        let faces = [[0, 1, 2], [0, 2, 3]];
        let to_f = |p: [u8; 3]| p.map(|c| c as f64);
        let slow = to_f(centre_pixel(&x, &faces, 0.0));
        let fast = to_f(centre_pixel(&x, &faces, 1.0));
        assert!((hue(slow) - 224.0).abs() < 1.5, "{slow:?}: {}", hue(slow));
        assert!((hue(fast) - 7.5).abs() < 1.5, "{fast:?}: {}", hue(fast));
        // And shaded: darker than the base colour.
        assert!((fast[0] - 255.0 * 0.95 * 0.65).abs() <= 1.0, "{fast:?}");
    }
}
