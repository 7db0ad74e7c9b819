//! Wavefront OBJ: reading triangle meshes (to build models from) and writing
//! frames (positions, optional per-vertex colours, faces) that Blender and
//! MeshLab open.

// A parser of user files: no panic on any input (tests/fuzz_obj.rs).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

use std::io::{BufRead, Write};
use std::path::Path;

use hookean_geometry::{GeometryError, TriMesh};

use crate::error::{MassSpringError, io_err};

/// A triangle mesh read from OBJ.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjMesh {
    /// Vertex positions.
    pub positions: Vec<[f64; 3]>,
    /// Triangles (0-based vertex indices); polygons are fan-triangulated.
    pub triangles: Vec<[usize; 3]>,
    /// The 1-based line of the `f` record of each triangle (empty for a
    /// mesh not read from a file), so that a bad triangle can be named.
    pub face_lines: Vec<usize>,
}

/// Parses OBJ text: `v x y z [w | r g b]` and `f` records (with `i`, `i/t`,
/// `i//n`, `i/t/n` forms, negative (relative) indices, polygons
/// fan-triangulated); every other record (`vt`, `vn`, `o`, `g`, `s`,
/// `usemtl`, `mtllib`, `l`, comments) is ignored.
///
/// # Errors
/// [`MassSpringError::ObjParse`] naming the 1-based line for a malformed
/// number, a vertex with fewer than three coordinates, a face with fewer
/// than three vertices, or an index that is zero or out of range (a face may
/// only refer to vertices defined before it); [`MassSpringError::Io`] if
/// reading fails.
pub fn parse_obj(reader: impl BufRead) -> Result<ObjMesh, MassSpringError> {
    let mut mesh = ObjMesh::default();
    let mut face: Vec<usize> = Vec::new();
    // Lines of at most 1 MiB, 4 GiB in all (hookean_io).
    let lines = hookean_io::capped_lines(reader, Default::default());
    for (k, line) in lines.enumerate() {
        let line_no = k + 1;
        let err = |message: String| MassSpringError::ObjParse {
            line: line_no,
            message,
        };
        let line = line.map_err(|e| match e {
            hookean_io::TextError::Io(e) => io_err("<obj reader>", e),
            e => err(e.to_string()),
        })?;
        let content = line.split('#').next().unwrap_or("");
        let mut tokens = content.split_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut xyz = [0.0; 3];
                for (c, slot) in xyz.iter_mut().enumerate() {
                    let t = tokens
                        .next()
                        .ok_or_else(|| err(format!("vertex has only {c} coordinates, needs 3")))?;
                    let value: f64 = t
                        .parse()
                        .map_err(|_| err(format!("malformed vertex coordinate {t:?}")))?;
                    if !value.is_finite() {
                        return Err(err(format!("non-finite vertex coordinate {t:?}")));
                    }
                    *slot = value;
                }
                for t in tokens {
                    t.parse::<f64>()
                        .map_err(|_| err(format!("malformed vertex value {t:?}")))?;
                }
                mesh.positions.push(xyz);
            }
            Some("f") => {
                face.clear();
                let n = mesh.positions.len();
                for t in tokens {
                    let index_str = t.split('/').next().unwrap_or("");
                    let index: i64 = index_str
                        .parse()
                        .map_err(|_| err(format!("malformed face index {t:?}")))?;
                    let resolved = if index > 0 {
                        index - 1
                    } else if index < 0 {
                        n as i64 + index
                    } else {
                        return Err(err("face index 0 (OBJ indices start at 1)".into()));
                    };
                    if resolved < 0 || resolved >= n as i64 {
                        return Err(err(format!(
                            "face index {index} out of range ({n} vertices defined so far)"
                        )));
                    }
                    face.push(resolved as usize);
                }
                if face.len() < 3 {
                    return Err(err(format!(
                        "face has {} vertices, needs at least 3",
                        face.len()
                    )));
                }
                for w in 1..face.len() - 1 {
                    mesh.triangles.push([face[0], face[w], face[w + 1]]);
                    mesh.face_lines.push(line_no);
                }
            }
            _ => {}
        }
    }
    Ok(mesh)
}

/// Reads an OBJ file with [`parse_obj`].
///
/// # Errors
/// As [`parse_obj`]; [`MassSpringError::Io`] if the file cannot be opened
/// or is not a regular file (a folder, a FIFO, a device:
/// [`hookean_io::open_regular`]).
pub fn read_obj_file(path: impl AsRef<Path>) -> Result<ObjMesh, MassSpringError> {
    let p = path.as_ref();
    // Only a regular file: a FIFO or a device is refused, never waited on.
    let file = hookean_io::open_regular(p).map_err(|e| io_err(&p.display().to_string(), e))?;
    parse_obj(std::io::BufReader::new(file))
}

/// Reads a triangle mesh from the OBJ file `path` for contact: every
/// coordinate scaled by `scale`, then moved by `offset`; the mesh checked as
/// a contact surface ([`TriMesh::new`]: finite, no degenerate triangle,
/// manifold, consistently oriented). Returns the mesh as read (for the
/// builders) and as a contact surface (for colliders and self-collision).
///
/// # Errors
/// [`MassSpringError::MeshFile`] naming the file and, where one is to
/// blame, the line: a missing or unreadable file, a malformed record, no
/// triangles, a non-finite coordinate (also after scaling) or one beyond
/// [`TriMesh::MAX_COORDINATE`], a degenerate, non-manifold or inconsistently
/// oriented triangle, a closed surface wound inside-out;
/// [`MassSpringError::InvalidParameter`] for a non-positive `scale` or a
/// non-finite `offset`.
pub fn read_surface(
    path: impl AsRef<Path>,
    scale: f64,
    offset: [f64; 3],
) -> Result<(ObjMesh, TriMesh), MassSpringError> {
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(MassSpringError::InvalidParameter {
            name: "scale",
            message: format!("{scale:?} must be positive and finite"),
        });
    }
    if offset.iter().any(|c| !c.is_finite()) {
        return Err(MassSpringError::InvalidParameter {
            name: "offset",
            message: format!("{offset:?} must be finite"),
        });
    }
    let p = path.as_ref();
    let file = p.display().to_string();
    let at = |line: Option<usize>, message: String| MassSpringError::MeshFile {
        path: file.clone(),
        line,
        message,
    };
    let mut mesh = match read_obj_file(p) {
        Ok(m) => m,
        Err(MassSpringError::ObjParse { line, message }) => return Err(at(Some(line), message)),
        Err(MassSpringError::Io { message, .. }) => return Err(at(None, message)),
        Err(e) => return Err(at(None, e.to_string())),
    };
    for v in &mut mesh.positions {
        for c in 0..3 {
            v[c] = v[c] * scale + offset[c];
        }
    }
    let surface = TriMesh::new(mesh.positions.clone(), mesh.triangles.clone()).map_err(|e| {
        let triangle = match e {
            GeometryError::IndexOutOfRange { triangle, .. }
            | GeometryError::Degenerate { triangle }
            | GeometryError::NonManifoldEdge { triangle, .. }
            | GeometryError::Orientation { triangle, .. }
            | GeometryError::InsideOut { triangle, .. } => Some(triangle),
            _ => None,
        };
        let message = match e {
            GeometryError::NonFinite { vertex } => format!(
                "vertex {} is not finite after scaling by {scale:?}",
                vertex + 1
            ),
            // Vertex numbers as the file counts them (from 1).
            GeometryError::NonManifoldEdge { a, b, count, .. } => format!(
                "the edge between vertices {} and {} is shared by {count} faces (non-manifold: at most 2)",
                a + 1,
                b + 1
            ),
            GeometryError::Orientation { a, b, .. } => format!(
                "this face runs through the edge {}-{} in the same direction as a neighbour (inconsistent orientation)",
                a + 1,
                b + 1
            ),
            GeometryError::TooLarge { vertex, value, max } => format!(
                "vertex {} has the coordinate {value:e} (after scaling by {scale:?}), beyond the largest magnitude {max:e} m",
                vertex + 1
            ),
            GeometryError::InsideOut { volume, .. } => format!(
                "the closed surface this face belongs to is inside-out (signed volume {volume:.3e} m^3): its faces must be counter-clockwise seen from outside; reverse the order of every face's vertices"
            ),
            GeometryError::Degenerate { .. } => {
                "degenerate face (a repeated vertex or zero area)".to_string()
            }
            other => other.to_string(),
        };
        at(triangle.and_then(|t| mesh.face_lines.get(t).copied()), message)
    })?;
    Ok((mesh, surface))
}

/// Writes an OBJ frame: `v x y z` lines (or `v x y z r g b` with per-vertex
/// colours in [0, 1], the extension MeshLab and Blender read), then `f`
/// lines for `faces`, then `l i j` lines for `lines` (e.g. a rope's springs).
///
/// # Errors
/// [`MassSpringError::DimensionMismatch`] if `x.len()` is not a multiple of
/// 3 or `colours` has the wrong length; [`MassSpringError::NoSuchParticle`]
/// for an index out of range; [`MassSpringError::Io`] if writing fails.
pub fn write_obj(
    mut w: impl Write,
    x: &[f64],
    colours: Option<&[[f64; 3]]>,
    faces: &[[usize; 3]],
    lines: &[(usize, usize)],
) -> Result<(), MassSpringError> {
    if !x.len().is_multiple_of(3) {
        return Err(MassSpringError::DimensionMismatch {
            what: "x",
            expected: 3 * (x.len() / 3),
            found: x.len(),
        });
    }
    let n = x.len() / 3;
    if let Some(c) = colours
        && c.len() != n
    {
        return Err(MassSpringError::DimensionMismatch {
            what: "colours",
            expected: n,
            found: c.len(),
        });
    }
    let check = |p: usize| {
        if p < n {
            Ok(())
        } else {
            Err(MassSpringError::NoSuchParticle {
                particle: p,
                n_particles: n,
            })
        }
    };
    for f in faces {
        f.iter().try_for_each(|&p| check(p))?;
    }
    for &(i, j) in lines {
        check(i)?;
        check(j)?;
    }
    let e = |e| io_err("<obj writer>", e);
    writeln!(w, "# written by hookean-massspring: {n} vertices").map_err(e)?;
    for p in 0..n {
        let (a, b, c) = (x[3 * p], x[3 * p + 1], x[3 * p + 2]);
        match colours {
            Some(col) => {
                let [r, g, bl] = col[p];
                writeln!(w, "v {a:.9e} {b:.9e} {c:.9e} {r:.4} {g:.4} {bl:.4}").map_err(e)?
            }
            None => writeln!(w, "v {a:.9e} {b:.9e} {c:.9e}").map_err(e)?,
        }
    }
    for f in faces {
        writeln!(w, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1).map_err(e)?;
    }
    for &(i, j) in lines {
        writeln!(w, "l {} {}", i + 1, j + 1).map_err(e)?;
    }
    Ok(())
}

/// Per-vertex colours by speed `|v_p|`: blue (at rest) through green to red
/// (at `max_speed` and above). `max_speed <= 0` uses the largest speed.
pub fn speed_colours(v: &[f64], max_speed: f64) -> Vec<[f64; 3]> {
    let speeds: Vec<f64> = v
        .chunks_exact(3)
        .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
        .collect();
    let top = if max_speed > 0.0 {
        max_speed
    } else {
        speeds.iter().copied().fold(0.0, f64::max)
    };
    speeds
        .iter()
        .map(|&s| {
            let t = if top > 0.0 && s.is_finite() {
                (s / top).clamp(0.0, 1.0)
            } else {
                0.0
            };
            // Piecewise linear blue -> green -> red.
            if t < 0.5 {
                [0.0, 2.0 * t, 1.0 - 2.0 * t]
            } else {
                [2.0 * t - 1.0, 2.0 - 2.0 * t, 0.0]
            }
        })
        .collect()
}

impl crate::MassSpringModel {
    /// Writes the frame `x` as OBJ with [`write_obj`]: the model's triangles
    /// as `f` lines, or, for models without triangles (ropes), its springs as
    /// `l` lines; optional per-vertex colours (e.g. [`speed_colours`]).
    ///
    /// # Errors
    /// As [`write_obj`]; [`MassSpringError::DimensionMismatch`] if `x` does
    /// not have `3 n` entries.
    pub fn write_obj(
        &self,
        w: impl Write,
        x: &[f64],
        colours: Option<&[[f64; 3]]>,
    ) -> Result<(), MassSpringError> {
        if x.len() != 3 * self.n_particles() {
            return Err(MassSpringError::DimensionMismatch {
                what: "x",
                expected: 3 * self.n_particles(),
                found: x.len(),
            });
        }
        let lines: Vec<(usize, usize)> = if self.faces().is_empty() {
            self.springs().iter().map(|s| (s.i, s.j)).collect()
        } else {
            Vec::new()
        };
        write_obj(w, x, colours, self.faces(), &lines)
    }
}
