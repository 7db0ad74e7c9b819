//! The `[output]` table of a scene.

use super::*;

/// `[output]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputScene {
    /// OBJ frames per simulated second (0: none). Range [0, inf). Default 10.
    #[serde(default = "d_frame_rate", deserialize_with = "non_negative")]
    pub frame_rate: f64,
}

impl Default for OutputScene {
    fn default() -> Self {
        Self {
            frame_rate: d_frame_rate(),
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
