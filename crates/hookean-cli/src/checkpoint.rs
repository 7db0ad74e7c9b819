//! The checkpoint file of `hookean run` (docs/OUTPUTS.md, "Checkpoint and
//! resume"): a run folder's `checkpoint.bin` holds the whole state of the
//! run between two steps ([`hookean::StateRecord`]: the simulation's, and
//! the outputs' bookkeeping under `out.`), so that
//! `hookean run SCENE --resume RUN_FOLDER` continues it bit for bit.
//!
//! The file: the line [`MAGIC`], one line of JSON (the [`Header`]: the
//! format's version, the scene's hash, the time, the entries' names and
//! lengths, the FNV-1a 64 checksum of the numbers), then every entry's
//! numbers as little-endian `f64`, in order. It is written to a temporary
//! name beside it and renamed over the last one, so a run killed while
//! writing leaves the earlier checkpoint whole.

use std::io::Write;
use std::path::{Path, PathBuf};

use hookean::StateRecord;
use serde::{Deserialize, Serialize};

use crate::CliError;

/// The checkpoint's name in a run folder.
pub const FILE: &str = "checkpoint.bin";
/// The temporary name it is written to first.
const TEMPORARY: &str = ".checkpoint.bin.tmp";
/// The checkpoint file's first line.
const MAGIC: &str = "hookean checkpoint";
/// The format's version: a checkpoint of another version is refused.
pub const VERSION: u32 = 2;
/// The largest checkpoint read (a corrupted length never allocates more).
const MAX_BYTES: u64 = 16 << 30;

/// The checkpoint's JSON line.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// [`VERSION`].
    pub version: u32,
    /// [`scene_hash`] of the scene and overrides the run was started with.
    pub scene_hash: String,
    /// The simulated time of the checkpoint (s), for messages.
    pub t: f64,
    /// Each entry's name and number of values, in the file's order.
    pub entries: Vec<(String, usize)>,
    /// FNV-1a 64 of the values' bytes, in hex.
    pub checksum: String,
}

/// FNV-1a, 64 bits, continued from `h` over `bytes`.
fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}
const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// The identity of a scene: FNV-1a 64 of the scene file's bytes and of
/// every `--set` in order (a different scene, or the same with other
/// overrides, has another hash).
///
/// # Errors
/// [`CliError::Input`] naming the scene if it cannot be read.
pub fn scene_hash(scene: &Path, set: &[String]) -> Result<String, CliError> {
    let bytes = hookean_io::read_file(scene, 64 << 20)
        .map_err(|e| CliError::Input(format!("{}: {e}", scene.display())))?;
    let mut h = fnv1a(FNV_OFFSET, bytes.as_bytes());
    for s in set {
        h = fnv1a(h, b"\0--set\0");
        h = fnv1a(h, s.as_bytes());
    }
    Ok(format!("{h:016x}"))
}

/// Writes `record` as `dir/checkpoint.bin` (aside, then renamed into
/// place); returns its size in bytes.
///
/// # Errors
/// [`CliError::Failed`] naming the file if writing fails.
pub fn write(dir: &Path, record: &StateRecord, scene_hash: &str, t: f64) -> Result<u64, CliError> {
    let mut bytes = Vec::new();
    let mut entries = Vec::new();
    for (name, values) in record.entries() {
        entries.push((name.to_string(), values.len()));
        for v in values {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let header = Header {
        version: VERSION,
        scene_hash: scene_hash.to_string(),
        t,
        entries,
        checksum: format!("{:016x}", fnv1a(FNV_OFFSET, &bytes)),
    };
    let json = serde_json::to_string(&header).map_err(|e| CliError::Failed(e.to_string()))?;
    let (tmp, path) = (dir.join(TEMPORARY), dir.join(FILE));
    let failed = |e: std::io::Error| CliError::Failed(format!("{}: {e}", path.display()));
    let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp).map_err(failed)?);
    writeln!(f, "{MAGIC}").map_err(failed)?;
    writeln!(f, "{json}").map_err(failed)?;
    f.write_all(&bytes).map_err(failed)?;
    f.flush().map_err(failed)?;
    drop(f);
    std::fs::rename(&tmp, &path).map_err(failed)?;
    Ok((MAGIC.len() + json.len() + 2 + bytes.len()) as u64)
}

/// Removes the checkpoint of a finished run (and a temporary one a kill
/// left), so that its folder holds what an uninterrupted run's does.
pub fn remove(dir: &Path) {
    for name in [FILE, TEMPORARY] {
        let _ = std::fs::remove_file(dir.join(name));
    }
}

/// The checkpoint in the run folder `dir` of the scene whose
/// [`scene_hash`] is `hash`: its header and record.
///
/// # Errors
/// [`CliError::Input`] naming the file for a missing, truncated or
/// corrupted checkpoint, one of another version or of another scene.
pub fn read(dir: &Path, hash: &str) -> Result<(Header, StateRecord), CliError> {
    let path = dir.join(FILE);
    let bad = |why: String| CliError::Input(format!("--resume {}: {why}", path.display()));
    let meta = std::fs::metadata(&path).map_err(|e| {
        bad(format!(
            "no checkpoint ({e}); a run writes one every output.checkpoint_every seconds and when SIGINT or SIGTERM stops it"
        ))
    })?;
    if !meta.is_file() || meta.len() > MAX_BYTES {
        return Err(bad("not a checkpoint file".into()));
    }
    let data = std::fs::read(&path).map_err(|e| bad(e.to_string()))?;
    let rest = data
        .strip_prefix(MAGIC.as_bytes())
        .and_then(|r| r.strip_prefix(b"\n"))
        .ok_or_else(|| {
            bad(format!(
                "not a checkpoint (its first line is not {MAGIC:?})"
            ))
        })?;
    let end = rest
        .iter()
        .position(|&b| b == b'\n')
        .ok_or_else(|| bad("truncated in its header".into()))?;
    let header: Header = std::str::from_utf8(&rest[..end])
        .ok()
        .and_then(|s| serde_json::from_str(s).ok())
        .ok_or_else(|| bad("its header is corrupted".into()))?;
    if header.version != VERSION {
        return Err(bad(format!(
            "checkpoint format version {}, this hookean reads version {VERSION}",
            header.version
        )));
    }
    if header.scene_hash != hash {
        return Err(bad(
            "the checkpoint is of another scene (the scene file or its --set overrides differ \
             from the run's): resume with the scene and --set of the run"
                .into(),
        ));
    }
    let payload = &rest[end + 1..];
    let count: usize = header.entries.iter().map(|(_, n)| *n).sum();
    if payload.len() != count.saturating_mul(8) {
        return Err(bad(format!(
            "truncated or corrupted: {} bytes of numbers, its header lists {}",
            payload.len(),
            count.saturating_mul(8)
        )));
    }
    if format!("{:016x}", fnv1a(FNV_OFFSET, payload)) != header.checksum {
        return Err(bad("corrupted (its checksum does not match)".into()));
    }
    let mut record = StateRecord::default();
    let mut values = payload
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])));
    for (name, n) in &header.entries {
        let v: Vec<f64> = values.by_ref().take(*n).collect();
        record.put(name, &v);
    }
    Ok((header, record))
}

/// When the next scheduled checkpoint is due.
#[derive(Debug, Clone)]
pub struct Schedule {
    /// `output.checkpoint_every` (s).
    every: f64,
    /// The number of the next scheduled checkpoint: due at `k * every`.
    k: u64,
}

impl Schedule {
    /// Checkpoints every `every` seconds from a run at time `t`.
    pub fn new(every: f64, t: f64) -> Self {
        let mut s = Self { every, k: 1 };
        s.pass(t);
        s
    }

    /// Whether a checkpoint is due at time `t` (within round-off of its slot).
    pub fn due(&self, t: f64) -> bool {
        t >= (self.k as f64 * self.every) * (1.0 - 1e-12)
    }

    /// Moves the next slot past `t`.
    pub fn pass(&mut self, t: f64) {
        while self.due(t) {
            self.k += 1;
        }
    }
}

/// `dir/checkpoint.bin`, for messages.
pub fn path(dir: &Path) -> PathBuf {
    dir.join(FILE)
}
