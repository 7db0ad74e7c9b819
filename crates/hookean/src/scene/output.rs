//! The `[output]` table of a scene.

use super::*;

/// `[output]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputScene {
    /// OBJ frames per simulated second (0: none). Range [0, inf). Default 10.
    #[serde(default = "d_frame_rate", deserialize_with = "non_negative")]
    pub frame_rate: f64,
    /// A point cache of every OBJ frame in one file, for Blender's Mesh
    /// Cache modifier and other tools: "pc2" (cache.pc2, Point Cache 2) or
    /// "mdd" (cache.mdd, LightWave's MDD), with cache-rest.obj, the mesh of
    /// the same vertex order to play it on; needs frame_rate > 0. In
    /// Blender: set the scene's frame rate to frame_rate and its start
    /// frame to 0, import cache-rest.obj with forward axis Y and up axis Z,
    /// add a Mesh Cache modifier (format PC2 or MDD, the cache file, frame
    /// start 0); docs/OUTPUTS.md, "Point caches", has every step. Default:
    /// none.
    #[serde(default)]
    pub cache: Option<crate::cache::CacheFormat>,
}

impl Default for OutputScene {
    fn default() -> Self {
        Self {
            frame_rate: d_frame_rate(),
            cache: None,
        }
    }
}

/// The number of `v` records of an OBJ file, counted in fixed-size chunks
/// (no line is held in memory, so a huge file costs no memory here); 0 for
/// a file that cannot be read (building the scene then names the error).
pub(super) fn obj_vertex_count(path: &Path) -> u64 {
    use std::io::Read;
    // Only a regular file (never waits on a FIFO).
    let Ok(mut file) = hookean_io::open_regular(path) else {
        return 0;
    };
    let mut buf = [0u8; 1 << 16];
    // 0: at a line start, 1: after a leading 'v', 2: elsewhere in a line.
    let (mut state, mut count) = (0u8, 0u64);
    loop {
        let Ok(k) = file.read(&mut buf) else {
            return count;
        };
        if k == 0 {
            return count;
        }
        for &b in &buf[..k] {
            state = match (state, b) {
                (_, b'\n') => 0,
                (0, b'v') => 1,
                (0, b' ' | b'\t') => 0,
                (1, b' ' | b'\t') => {
                    count += 1;
                    2
                }
                _ => 2,
            };
        }
    }
}

pub(super) fn d_frame_rate() -> f64 {
    10.0
}
