//! Point caches: every frame's vertex positions in one file, the way
//! simulations move between tools (Blender's Mesh Cache modifier, 3ds Max,
//! Maya and Houdini play them back on a mesh of the same vertex order).
//!
//! Two formats, both 32-bit IEEE floats, the layouts Blender's readers
//! (`MOD_meshcache_pc2.cc`, `MOD_meshcache_mdd.cc`) expect:
//!
//! - **PC2** (Point Cache 2, 3ds Max; little-endian): a 32-byte header
//!   `char[12] "POINTCACHE2\0"`, `i32 version = 1`, `i32 vertices`,
//!   `f32 start frame`, `f32 sampling` (frames between samples), `i32
//!   samples`; then per sample `vertices` times `f32 x, y, z`.
//! - **MDD** (LightWave; big-endian): `i32 frames`, `i32 vertices`, `f32
//!   time (s)` per frame, then per frame `vertices` times `f32 x, y, z`.
//!
//! A cache is written from a run's OBJ frames ([`write_from_frames`]), with
//! its rest mesh: frame 0 as an OBJ without colours, of the same vertex
//! order, on which a Mesh Cache modifier plays the cache
//! (docs/OUTPUTS.md, "Point caches").
//!
//! ```
//! use hookean::cache::{CacheFormat, PointCache};
//!
//! let times = [0.0, 0.1];
//! let cache = PointCache { format: CacheFormat::Pc2, vertices: 1, times: &times, frame_rate: 10.0 };
//! let mut bytes = Vec::new();
//! cache.write_header(&mut bytes)?;
//! cache.write_frame(&mut bytes, &[0.0, 0.0, 1.0])?;
//! cache.write_frame(&mut bytes, &[0.0, 0.0, 0.5])?;
//! assert_eq!(&bytes[..12], b"POINTCACHE2\0");
//! assert_eq!(bytes.len(), 32 + 2 * 12);
//! # Ok::<(), std::io::Error>(())
//! ```

use std::io::Write;
use std::path::Path;

use serde::Deserialize;

use crate::HookeanError;

/// The format of a point cache (the scene key `output.cache`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CacheFormat {
    /// Point Cache 2 (`.pc2`, little-endian, uniform sampling).
    Pc2,
    /// LightWave's MDD (`.mdd`, big-endian, a time per frame).
    Mdd,
}

impl CacheFormat {
    /// The file extension (`"pc2"`, `"mdd"`), also the name in scenes.
    pub fn extension(self) -> &'static str {
        match self {
            CacheFormat::Pc2 => "pc2",
            CacheFormat::Mdd => "mdd",
        }
    }

    /// The cache's file name in a run folder: `cache.pc2` or `cache.mdd`.
    pub fn file_name(self) -> String {
        format!("cache.{}", self.extension())
    }
}

impl std::fmt::Display for CacheFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.extension())
    }
}

/// The rest mesh beside a cache in a run folder.
pub const REST_OBJ: &str = "cache-rest.obj";

/// The counts a cache's header holds as `i32` (PC2 and MDD alike).
pub const MAX_COUNT: usize = i32::MAX as usize;

/// One point cache's layout: its format, vertex count and the times of its
/// frames. [`write_header`](Self::write_header) once, then
/// [`write_frame`](Self::write_frame) once per entry of `times`.
#[derive(Debug, Clone, Copy)]
pub struct PointCache<'a> {
    /// The file format.
    pub format: CacheFormat,
    /// Vertices per frame.
    pub vertices: usize,
    /// Simulated time of each frame (s): MDD stores them; PC2 stores the
    /// first as its start frame, `times[0] * frame_rate`.
    pub times: &'a [f64],
    /// Frames per simulated second: PC2's sampling is one frame per
    /// sample at this rate (Blender's scene frame rate should be set to it).
    pub frame_rate: f64,
}

fn count(n: usize, what: &str) -> std::io::Result<i32> {
    i32::try_from(n).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{n} {what}, more than a point cache holds ({MAX_COUNT})"),
        )
    })
}

impl PointCache<'_> {
    /// Writes the header (and MDD's frame times).
    ///
    /// # Errors
    /// Writing fails, or a count is past [`MAX_COUNT`].
    pub fn write_header(&self, w: &mut impl Write) -> std::io::Result<()> {
        let vertices = count(self.vertices, "vertices")?;
        let frames = count(self.times.len(), "frames")?;
        match self.format {
            CacheFormat::Pc2 => {
                w.write_all(b"POINTCACHE2\0")?;
                w.write_all(&1i32.to_le_bytes())?;
                w.write_all(&vertices.to_le_bytes())?;
                let start = self.times.first().map_or(0.0, |t| t * self.frame_rate);
                w.write_all(&(start as f32).to_le_bytes())?;
                w.write_all(&1f32.to_le_bytes())?;
                w.write_all(&frames.to_le_bytes())
            }
            CacheFormat::Mdd => {
                w.write_all(&frames.to_be_bytes())?;
                w.write_all(&vertices.to_be_bytes())?;
                for &t in self.times {
                    w.write_all(&(t as f32).to_be_bytes())?;
                }
                Ok(())
            }
        }
    }

    /// Writes one frame's positions `x` (`3 vertices` numbers, x y z per vertex).
    ///
    /// # Errors
    /// Writing fails, or `x` does not hold `3 vertices` numbers.
    pub fn write_frame(&self, w: &mut impl Write, x: &[f64]) -> std::io::Result<()> {
        if x.len() != 3 * self.vertices {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidData,
                format!(
                    "a frame of {} vertices in a cache of {}",
                    x.len() / 3,
                    self.vertices
                ),
            ));
        }
        for &c in x {
            let c = c as f32;
            match self.format {
                CacheFormat::Pc2 => w.write_all(&c.to_le_bytes())?,
                CacheFormat::Mdd => w.write_all(&c.to_be_bytes())?,
            }
        }
        Ok(())
    }
}

/// Writes the point cache of the OBJ frames `frame-0000.obj`, ... of `dir`
/// (one per entry of `times`, [`crate::sinks::frame_path`]) to `cache`, and
/// its rest mesh (frame 0 without the vertex colours, its `f` and `l`
/// records as they are) to `rest`.
///
/// # Errors
/// [`HookeanError::Io`] naming the frame that cannot be read, is malformed
/// or has another vertex count than frame 0, or a failed write;
/// [`HookeanError::InvalidOption`] for no frames.
pub fn write_from_frames(
    dir: &Path,
    times: &[f64],
    frame_rate: f64,
    format: CacheFormat,
    cache: &mut impl Write,
    rest: &mut impl Write,
) -> Result<(), HookeanError> {
    if times.is_empty() {
        return Err(HookeanError::InvalidOption {
            name: "cache".into(),
            message: format!("{}: no frames to cache", dir.display()),
        });
    }
    let read = |k: usize| -> Result<Vec<f64>, HookeanError> {
        let path = crate::sinks::frame_path(dir, k);
        let mesh = hookean_massspring::read_obj_file(&path).map_err(|e| {
            HookeanError::io(
                &path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
            )
        })?;
        Ok(mesh.positions.iter().flatten().copied().collect())
    };
    let first = read(0)?;
    let layout = PointCache {
        format,
        vertices: first.len() / 3,
        times,
        frame_rate,
    };
    let write_err = |e: std::io::Error| HookeanError::Io {
        path: None,
        source: e,
    };
    layout.write_header(cache).map_err(write_err)?;
    layout.write_frame(cache, &first).map_err(write_err)?;
    for k in 1..times.len() {
        let x = read(k)?;
        if x.len() != first.len() {
            let path = crate::sinks::frame_path(dir, k);
            return Err(HookeanError::io(
                &path,
                std::io::Error::new(
                    std::io::ErrorKind::InvalidData,
                    format!(
                        "{} vertices, frame 0 has {}: not the frames of one run",
                        x.len() / 3,
                        first.len() / 3
                    ),
                ),
            ));
        }
        layout.write_frame(cache, &x).map_err(write_err)?;
    }
    write_rest(&crate::sinks::frame_path(dir, 0), rest)
}

/// Copies the OBJ frame at `frame` to `rest` with each `v` record cut to
/// its position (`v x y z`), every other record as it is.
fn write_rest(frame: &Path, rest: &mut impl Write) -> Result<(), HookeanError> {
    let file = hookean_io::open_regular(frame).map_err(|e| HookeanError::io(frame, e))?;
    let reader = std::io::BufReader::new(file);
    writeln!(
        rest,
        "# the rest mesh of a hookean point cache (vertex order of its frames)"
    )
    .map_err(|e| HookeanError::Io {
        path: None,
        source: e,
    })?;
    for line in hookean_io::capped_lines(reader, Default::default()) {
        let line = line.map_err(|e| {
            HookeanError::io(
                frame,
                std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
            )
        })?;
        let out = if line.starts_with("v ") {
            line.split_whitespace()
                .take(4)
                .collect::<Vec<_>>()
                .join(" ")
        } else if line.starts_with('#') {
            continue;
        } else {
            line
        };
        writeln!(rest, "{out}").map_err(|e| HookeanError::Io {
            path: None,
            source: e,
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names() {
        assert_eq!(CacheFormat::Pc2.file_name(), "cache.pc2");
        assert_eq!(CacheFormat::Mdd.to_string(), "mdd");
    }

    #[test]
    fn a_frame_of_the_wrong_size_is_refused() {
        let cache = PointCache {
            format: CacheFormat::Mdd,
            vertices: 2,
            times: &[0.0],
            frame_rate: 1.0,
        };
        let e = cache.write_frame(&mut Vec::new(), &[0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("1 vertices in a cache of 2"), "{e}");
    }
}
