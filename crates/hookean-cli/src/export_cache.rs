//! Point caches of a run's OBJ frames (`cache.pc2` / `cache.mdd` with
//! `cache-rest.obj`, the facade's [`hookean::cache`]): written by `hookean
//! run` for a scene with `[output] cache`, and by `hookean export-cache RUN
//! --format pc2|mdd` for the folder of an earlier run.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use hookean::cache::{CacheFormat, REST_OBJ};

use crate::CliError;
use crate::view::RunFrames;

/// `--format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FormatArg {
    /// Point Cache 2 (cache.pc2).
    Pc2,
    /// LightWave's MDD (cache.mdd).
    Mdd,
}

impl From<FormatArg> for CacheFormat {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Pc2 => CacheFormat::Pc2,
            FormatArg::Mdd => CacheFormat::Mdd,
        }
    }
}

#[derive(Debug, Args)]
pub struct ExportCacheArgs {
    /// The output folder of an earlier `hookean run` (with its frame-NNNN.obj files).
    dir: PathBuf,
    /// The cache's format.
    #[arg(long, value_enum)]
    format: FormatArg,
    /// Replace a cache (and cache-rest.obj) hookean wrote there before.
    #[arg(long)]
    force: bool,
}

/// The frame rate of a run: `summary.json`'s `frame_rate`, else (older
/// summaries) the spacing of its first two frames, else 1 per second.
fn frame_rate_of(frames: &RunFrames) -> f64 {
    if let Some(r) = frames.summary["frame_rate"].as_f64().filter(|r| *r > 0.0) {
        return r;
    }
    match frames.times[..] {
        [a, b, ..] if b > a => 1.0 / (b - a),
        _ => 1.0,
    }
}

/// Writes `dir`'s cache and rest mesh into the fresh files `cache` and
/// `rest` (inside a run's staging folder, or prepared beside their place).
fn write(
    dir: &Path,
    times: &[f64],
    frame_rate: f64,
    format: CacheFormat,
    cache: &mut impl std::io::Write,
    rest: &mut impl std::io::Write,
) -> Result<(), String> {
    hookean::cache::write_from_frames(dir, times, frame_rate, format, cache, rest)
        .map_err(|e| e.to_string())
}

/// The cache of a run being written in its staging folder `dir` (`hookean
/// run`, `[output] cache`): `cache.EXT` and `cache-rest.obj`.
pub fn write_in_run(
    dir: &Path,
    times: &[f64],
    frame_rate: f64,
    format: CacheFormat,
) -> Result<(), CliError> {
    let open = |name: &str| {
        crate::output::new_file(&dir.join(name))
            .map(std::io::BufWriter::new)
            .map_err(|e| CliError::Failed(format!("{name}: {e}")))
    };
    let (mut cache, mut rest) = (open(&format.file_name())?, open(REST_OBJ)?);
    write(dir, times, frame_rate, format, &mut cache, &mut rest).map_err(CliError::Failed)?;
    for (name, w) in [(format.file_name(), cache), (REST_OBJ.to_string(), rest)] {
        w.into_inner()
            .map_err(|e| e.into_error())
            .and_then(|f| f.sync_all())
            .map_err(|e| CliError::Failed(format!("{name}: {e}")))?;
    }
    Ok(())
}

/// Refuses `name` in `dir` unless absent, or `replace` and a file hookean
/// listed there.
fn check_replaceable(dir: &Path, name: &str, replace: bool) -> Result<(), CliError> {
    let path = dir.join(name);
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(());
    }
    if !replace {
        return Err(CliError::Input(format!(
            "{} exists; pass --force to replace it",
            path.display()
        )));
    }
    if !crate::output::is_listed_file(dir, name) {
        return Err(CliError::Input(format!(
            "{} was not written by hookean (it is not a file listed in {}): \
             remove it yourself, or copy the run to a new folder",
            path.display(),
            dir.join(crate::output::MARKER).display()
        )));
    }
    Ok(())
}

/// `hookean export-cache RUN --format pc2|mdd`: writes `RUN/cache.EXT` and
/// `RUN/cache-rest.obj` from the run's frames.
pub fn run(args: &ExportCacheArgs) -> Result<(), CliError> {
    let format = CacheFormat::from(args.format);
    let frames = RunFrames::read(&args.dir)?;
    let name = format.file_name();
    check_replaceable(&args.dir, &name, args.force)?;
    // The rest mesh is frame 0 whatever the format: one hookean wrote is
    // written again as it was, without --force.
    check_replaceable(&args.dir, REST_OBJ, true)?;
    let rate = frame_rate_of(&frames);
    // Both files are written aside first: a bad frame leaves the folder as it was.
    let mut rest_bytes = Vec::new();
    let mut failure = None;
    let cache = crate::output::prepare_file(&args.dir.join(&name), |w| {
        write(&args.dir, &frames.times, rate, format, w, &mut rest_bytes).map_err(|e| {
            failure = Some(e);
            std::io::Error::other("cannot write the cache")
        })
    });
    let cache = match (cache, failure) {
        (_, Some(why)) => return Err(CliError::Input(why)),
        (Err(e), None) => return Err(CliError::Failed(format!("{name}: {e}"))),
        (Ok(c), None) => c,
    };
    let rest = crate::output::prepare_file(&args.dir.join(REST_OBJ), |w| {
        std::io::Write::write_all(w, &rest_bytes)
    })
    .map_err(|e| CliError::Failed(format!("{REST_OBJ}: {e}")))?;
    for (prepared, file) in [(cache, name.as_str()), (rest, REST_OBJ)] {
        prepared
            .commit()
            .and_then(|()| crate::output::add_to_marker(&args.dir, file))
            .map_err(|e| CliError::Failed(format!("{}: {e}", args.dir.join(file).display())))?;
    }
    crate::errln!(
        "wrote {} ({} frames at {} per second) and {}",
        args.dir.join(&name).display(),
        frames.times.len(),
        hookean_sparse::Short(rate),
        args.dir.join(REST_OBJ).display()
    );
    Ok(())
}
