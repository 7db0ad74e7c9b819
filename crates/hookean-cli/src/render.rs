//! A small software renderer for `final.png`: the model's triangles
//! projected orthographically from an elevated viewpoint, sorted back to
//! front (painter's algorithm), flat-shaded and coloured by particle speed
//! (blue = at rest, red = fastest), like the filtering paper's figure 7.
//! Models without triangles (ropes) are drawn as thick spring segments.

use std::io::BufWriter;
use std::path::Path;

/// An RGB image being drawn.
pub struct Canvas {
    width: usize,
    height: usize,
    pixels: Vec<[u8; 3]>,
}

impl Canvas {
    /// A white canvas.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![[255, 255, 255]; width * height],
        }
    }

    /// Sets one pixel (ignored outside the canvas).
    pub fn set(&mut self, x: usize, y: usize, colour: [u8; 3]) {
        if x < self.width && y < self.height {
            self.pixels[y * self.width + x] = colour;
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
                    self.pixels[y * self.width + x] = colour;
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

    /// The pixels, row-major.
    #[cfg(test)]
    pub fn pixels(&self) -> &[[u8; 3]] {
        &self.pixels
    }

    /// Writes the canvas as an 8-bit RGB PNG.
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut encoder =
            png::Encoder::new(BufWriter::new(file), self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder
            .write_header()
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let data: Vec<u8> = self.pixels.iter().flatten().copied().collect();
        writer
            .write_image_data(&data)
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

/// Renders particles `x` (with speeds from `v`) of a model with `faces`
/// (or, without faces, its `segments`) into a canvas.
pub fn render(
    x: &[f64],
    v: &[f64],
    faces: &[[usize; 3]],
    segments: &[(usize, usize)],
    width: usize,
    height: usize,
) -> Canvas {
    let mut canvas = Canvas::new(width, height);
    let n = x.len() / 3;
    if n == 0 {
        return canvas;
    }
    // Camera: looking along -dir from an elevated front-left viewpoint, z up.
    let dir = normalise([0.8, -1.6, 1.0]);
    let right = normalise(cross([0.0, 0.0, 1.0], dir));
    let up = cross(dir, right);
    let project = |p: &[f64]| -> [f64; 3] { [dot3(p, &right), dot3(p, &up), dot3(p, &dir)] };
    let proj: Vec<[f64; 3]> = x.chunks_exact(3).map(project).collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for q in &proj {
        for c in 0..2 {
            lo[c] = lo[c].min(q[c]);
            hi[c] = hi[c].max(q[c]);
        }
    }
    let span = ((hi[0] - lo[0]) / width as f64)
        .max((hi[1] - lo[1]) / height as f64)
        .max(1e-9);
    let scale = 0.85 / span;
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let to_pixel = |q: &[f64; 3]| -> [f64; 2] {
        [
            width as f64 / 2.0 + (q[0] - centre[0]) * scale,
            height as f64 / 2.0 - (q[1] - centre[1]) * scale,
        ]
    };
    let speeds: Vec<f64> = v
        .chunks_exact(3)
        .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
        .collect();
    let top = speeds.iter().copied().fold(0.0, f64::max).max(1e-9);
    let light = normalise([0.3, -0.5, 1.0]);
    if faces.is_empty() {
        let half = (width.min(height) as f64 / 200.0).max(1.5);
        let mut order: Vec<usize> = (0..segments.len()).collect();
        order.sort_by(|&a, &b| {
            let da = proj[segments[a].0][2] + proj[segments[a].1][2];
            let db = proj[segments[b].0][2] + proj[segments[b].1][2];
            da.total_cmp(&db)
        });
        for k in order {
            let (i, j) = segments[k];
            let c = speed_colour(0.5 * (speeds[i] + speeds[j]) / top);
            canvas.thick_line(to_pixel(&proj[i]), to_pixel(&proj[j]), half, to_u8(c));
        }
        return canvas;
    }
    // Painter's algorithm: far triangles (small depth along dir) first.
    let mut order: Vec<usize> = (0..faces.len()).collect();
    let depth = |f: &[usize; 3]| proj[f[0]][2] + proj[f[1]][2] + proj[f[2]][2];
    order.sort_by(|&a, &b| depth(&faces[a]).total_cmp(&depth(&faces[b])));
    for k in order {
        let f = faces[k];
        let p: Vec<&[f64]> = f.iter().map(|&i| &x[3 * i..3 * i + 3]).collect();
        let normal = normalise(cross(sub(p[1], p[0]), sub(p[2], p[0])));
        // Two-sided lighting: cloth has no inside.
        let lambert = dot3(&normal, &light).abs();
        let shade = 0.35 + 0.65 * lambert;
        let speed = (speeds[f[0]] + speeds[f[1]] + speeds[f[2]]) / (3.0 * top);
        let c = speed_colour(speed);
        let colour = to_u8([c[0] * shade, c[1] * shade, c[2] * shade]);
        canvas.fill_triangle(
            [
                to_pixel(&proj[f[0]]),
                to_pixel(&proj[f[1]]),
                to_pixel(&proj[f[2]]),
            ],
            colour,
        );
    }
    canvas
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
    fn a_flat_square_renders_non_blank_and_inside_the_frame() {
        let x = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
        let v = [0.0; 12];
        let c = render(&x, &v, &[[0, 1, 2], [0, 2, 3]], &[], 64, 48);
        let coloured = c.pixels().iter().filter(|p| **p != [255, 255, 255]).count();
        assert!(coloured > 64 * 48 / 10, "{coloured}");
        // The border rows stay white (the model is fitted with a margin).
        assert!(c.pixels()[..64].iter().all(|p| *p == [255, 255, 255]));
    }
}
