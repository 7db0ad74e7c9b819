//! Output files and folders that never lose what a user owns
//! (docs/RELIABILITY.md, "Nothing a user gave is lost").
//!
//! The rules, for every command that writes:
//!
//! - **A folder is built aside and moved into place.** A command writes its
//!   output folder into a fresh hidden staging folder beside it
//!   ([`Staging`]) and moves it to `--out` at the end with a rename that
//!   cannot replace anything (`renameat2(RENAME_NOREPLACE)` on Linux): a
//!   folder that appeared at `--out` while the command ran (another run, a
//!   folder the user made) is left as it is, and the command fails.
//! - **Hookean's folders carry a marker.** Every output folder holds
//!   [`MARKER`], the list of every entry hookean wrote into it. `--force`
//!   replaces a folder only if it is empty or every entry in it is listed
//!   there with the kind it was written as (a user's file, or a link, makes
//!   it someone else's folder), and never a folder that holds an input of the
//!   command. The replaced folder is emptied by that list: files, then
//!   folders, each removed only if it is still what hookean wrote.
//! - **Single files are replaced, never written through.** A file outside
//!   a staging folder is written to a fresh temporary name beside it and
//!   renamed over its destination ([`replace_file`]): a link there is
//!   replaced by the file, its target untouched, and nothing is created
//!   outside the destination's folder.
//! - **Signals clean up.** SIGINT, SIGTERM and SIGHUP remove the staging
//!   folders of the process before it dies of the signal; a replacement in
//!   progress finishes its swap first, so the target is never missing.
//!   Messages name `--out`, never a staging folder.
//! - **A killed run's staging folder is reclaimed.** A staging folder is
//!   locked (`flock`) by its process while it lives; SIGKILL (or a crash)
//!   leaves it behind, and the next command that writes beside it removes
//!   it once its lock is free and its process is gone, and says so.
//! - **A failed command's partial output does not block its rerun.** A
//!   failed command moves what it wrote to a free target, marked as the
//!   partial output of that command; the same command may replace it
//!   without `--force` (and says so), any other command only with `--force`.

use std::collections::BTreeSet;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::Mutex;

use crate::CliError;

mod published;
mod reclaim;
pub use published::{is_partial_run, mark};
use reclaim::{lock_staging, reclaim_dead_staging};

/// The file by which hookean recognises its own output folders: its first
/// line is [`MARKER_HEADER`], then one entry per line, the path relative to
/// the folder, with a trailing `/` for folders.
pub const MARKER: &str = ".hookean-output";

/// The first line of [`MARKER`].
const MARKER_HEADER: &str = "hookean output folder, v1: the entries hookean wrote here";

/// The first line of the [`MARKER`] of a failed command's partial output
/// is this, the command's name (`run`), then [`PARTIAL_SUFFIX`].
const PARTIAL_PREFIX: &str = "hookean partial output of a failed `hookean ";
/// See [`PARTIAL_PREFIX`].
const PARTIAL_SUFFIX: &str = "`, v1: the entries hookean wrote here";

/// Entries of this process the signal handler removes: staging folders,
/// temporary files of [`prepare_file`], and an earlier output being
/// removed after its replacement. A replacement
/// holds this lock while it swaps folders, so a signal never leaves the
/// target missing.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A poisoned lock only means a thread panicked while holding it; the
    // list is still valid.
    LIVE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Installs (once) the thread that cleans up on SIGINT, SIGTERM and SIGHUP,
/// then lets the signal end the process as it would have.
fn install_signal_cleanup() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) else {
            return;
        };
        std::thread::spawn(move || {
            for signal in signals.forever() {
                // A checkpointing run stops at its next step (the first
                // SIGINT or SIGTERM only; SIGHUP, or a second signal, ends
                // the process as before).
                if signal != SIGHUP
                    && CHECKPOINTING.load(std::sync::atomic::Ordering::SeqCst)
                    && !STOP.swap(true, std::sync::atomic::Ordering::SeqCst)
                {
                    continue;
                }
                DYING.store(true, std::sync::atomic::Ordering::SeqCst);
                clean_up_live();
                let _ = signal_hook::low_level::emulate_default_handler(signal);
                std::process::exit(128 + signal);
            }
        });
    });
}

/// Set by [`stop_at_signals`]: SIGINT and SIGTERM ask the run to stop
/// ([`stop_requested`]) instead of ending the process.
static CHECKPOINTING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Set by the signal thread at the first SIGINT or SIGTERM of a
/// checkpointing run.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// From now on, the first SIGINT or SIGTERM sets [`stop_requested`]
/// instead of cleaning up and ending the process: a run that can write a
/// checkpoint finishes its step, writes it and exits.
pub fn stop_at_signals() {
    install_signal_cleanup();
    CHECKPOINTING.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Whether a SIGINT or SIGTERM asked the run to stop (one relaxed atomic
/// load: read after every step).
#[inline]
pub fn stop_requested() -> bool {
    STOP.load(std::sync::atomic::Ordering::Relaxed)
}

/// Set by the signal thread before it removes the live folders: the
/// process is about to die of a signal.
static DYING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Waits forever if a signal is ending the process: a command that failed
/// because the signal's clean-up removed its staging folder must not report
/// that failure and exit 1 before the signal ends it (the exit status is
/// the signal's). Returns at once otherwise.
pub fn wait_if_dying() {
    while DYING.load(std::sync::atomic::Ordering::SeqCst) {
        std::thread::park();
    }
}

/// Removes every live folder.
fn clean_up_live() {
    let mut l = live();
    for dir in l.drain(..) {
        // The main thread may still be writing into it: retry a few times.
        for _ in 0..20 {
            let removed = match std::fs::symlink_metadata(&dir) {
                Ok(m) if m.is_dir() => std::fs::remove_dir_all(&dir).is_ok(),
                Ok(_) => std::fs::remove_file(&dir).is_ok(),
                Err(_) => true,
            };
            if removed {
                break;
            }
        }
    }
}

/// The absolute form of `path` with links of its existing ancestors
/// resolved and `.` / `..` applied: two paths that name one file (or would,
/// once created) normalise to the same path.
pub fn normalize(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let parts: Vec<Component<'_>> = abs.components().collect();
    // The longest existing prefix is canonicalised (its links resolved); the
    // rest does not exist, so it holds no links and `..` can be applied lexically.
    for k in (1..=parts.len()).rev() {
        let prefix: PathBuf = parts[..k].iter().collect();
        if let Ok(mut out) = prefix.canonicalize() {
            for c in &parts[k..] {
                match c {
                    Component::ParentDir => {
                        out.pop();
                    }
                    Component::Normal(n) => out.push(n),
                    _ => {}
                }
            }
            return out;
        }
    }
    abs
}

/// Whether `a` and `b` name the same file, existing or not
/// (`o/sub/../a.csv` and `o/a.csv`, a link and its target).
pub fn same_file(a: &Path, b: &Path) -> bool {
    normalize(a) == normalize(b)
}

/// A fresh file for writing inside a staging folder: never opens an
/// existing file or follows a link.
///
/// # Errors
/// The `io::Error` of `open` (`AlreadyExists` for anything at `path`).
pub fn new_file(path: &Path) -> std::io::Result<File> {
    File::options().write(true).create_new(true).open(path)
}

/// A name beside `path` that does not exist yet: `.NAME.hookean-TAG-PID-K`.
fn fresh_sibling(path: &Path, tag: &str, k: u32) -> PathBuf {
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    parent_of(path).join(format!(".{name}.hookean-{tag}-{}-{k}", std::process::id()))
}

/// The folder holding `path` (`.` for a bare name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A file written beside its destination and not yet in place:
/// [`Prepared::commit`] renames it over the destination; dropping it
/// uncommitted removes it. Several outputs of one command are prepared
/// first and committed together, so that a failure of any leaves every
/// destination as it was.
#[derive(Debug)]
pub struct Prepared {
    tmp: PathBuf,
    path: PathBuf,
}

impl Prepared {
    /// Renames the file over its destination.
    ///
    /// # Errors
    /// The `io::Error` of the rename; the file is removed then.
    pub fn commit(self) -> std::io::Result<()> {
        std::fs::rename(&self.tmp, &self.path)
        // Drop removes the temporary file if the rename failed.
    }
}

impl Drop for Prepared {
    fn drop(&mut self) {
        if std::fs::symlink_metadata(&self.tmp).is_ok() {
            let _ = std::fs::remove_file(&self.tmp);
        }
        live().retain(|d| d != &self.tmp);
    }
}

/// Writes `path`'s future content by `write` into a fresh temporary file
/// beside it ([`Prepared`]); nothing at `path` changes yet.
///
/// # Errors
/// The `io::Error` of creating or writing (a full disk); the temporary
/// file is removed then.
pub fn prepare_file(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<Prepared> {
    install_signal_cleanup();
    let mut k = 0;
    let (tmp, file) = loop {
        let tmp = fresh_sibling(path, "tmp", k);
        // Registered before it exists, so a signal never misses it.
        live().push(tmp.clone());
        match new_file(&tmp) {
            Ok(f) => break (tmp, f),
            Err(e) => {
                live().retain(|d| d != &tmp);
                if e.kind() == std::io::ErrorKind::AlreadyExists && k < 1000 {
                    k += 1;
                } else {
                    return Err(e);
                }
            }
        }
    };
    let prepared = Prepared {
        tmp,
        path: path.to_path_buf(),
    };
    let mut w = BufWriter::new(file);
    write(&mut w).and_then(|()| w.flush())?;
    let file = w
        .into_inner()
        .map_err(std::io::IntoInnerError::into_error)?;
    // Written through to the disk: a full disk is reported here, not lost
    // when the file is closed.
    file.sync_all()?;
    Ok(prepared)
}

/// Writes `path` by `write` into a fresh temporary file beside it and
/// renames it over `path`: whatever was at `path` (a file, a link) is
/// replaced as a whole, nothing is written through a link, and a failure
/// leaves `path` as it was.
///
/// # Errors
/// The `io::Error` of creating, writing or renaming; the temporary file is
/// removed then.
pub fn replace_file(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    prepare_file(path, write)?.commit()
}

/// Writes `text` to `path` by [`replace_file`].
///
/// # Errors
/// [`CliError::Failed`] naming `path`.
pub fn write_text(path: &Path, text: &str) -> Result<(), CliError> {
    replace_file(path, |w| w.write_all(text.as_bytes()))
        .map_err(|e| CliError::Failed(format!("cannot write {}: {e}", path.display())))
}

/// Refuses an existing `path` for a single-file output unless `force`; a
/// folder is never replaced by a file.
///
/// # Errors
/// [`CliError::Input`] naming `flag`.
pub fn check_new_file(path: &Path, force: bool, flag: &str) -> Result<(), CliError> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_dir() => Err(CliError::Input(format!(
            "{flag} {} is a folder; name a file",
            path.display()
        ))),
        Ok(_) if !force => Err(CliError::Input(format!(
            "{flag} {} exists (use --force to replace it)",
            path.display()
        ))),
        _ => Ok(()),
    }
}

/// What hookean wrote into a folder, as its [`MARKER`] lists it.
#[derive(Debug, Default, PartialEq)]
struct Manifest {
    files: BTreeSet<PathBuf>,
    dirs: BTreeSet<PathBuf>,
    /// The command (`run`) whose failure left this partial output; `None`
    /// for a finished output.
    failed: Option<String>,
}

impl Manifest {
    /// Every entry under `dir` (not following links), relative to it; a
    /// link or another special file is an error naming it.
    fn of_tree(dir: &Path) -> Result<Self, PathBuf> {
        let mut m = Manifest::default();
        let mut stack = vec![PathBuf::new()];
        while let Some(rel) = stack.pop() {
            let entries = std::fs::read_dir(dir.join(&rel)).map_err(|_| rel.clone())?;
            for entry in entries {
                let entry = entry.map_err(|_| rel.clone())?;
                let name = rel.join(entry.file_name());
                let kind = entry.file_type().map_err(|_| name.clone())?;
                if kind.is_dir() {
                    m.dirs.insert(name.clone());
                    stack.push(name);
                } else if kind.is_file() {
                    m.files.insert(name);
                } else {
                    return Err(name);
                }
            }
        }
        Ok(m)
    }

    fn text(&self) -> String {
        let mut s = match &self.failed {
            None => format!("{MARKER_HEADER}\n"),
            Some(command) => format!("{PARTIAL_PREFIX}{command}{PARTIAL_SUFFIX}\n"),
        };
        for d in &self.dirs {
            s += &format!("{}/\n", d.display());
        }
        for f in &self.files {
            s += &format!("{}\n", f.display());
        }
        s
    }

    /// The marker of `dir`, if it has one that parses.
    fn read(dir: &Path) -> Option<Self> {
        let path = dir.join(MARKER);
        // A marker is a plain file of a few kilobytes per thousand frames.
        let meta = std::fs::symlink_metadata(&path).ok()?;
        if !meta.is_file() || meta.len() > 64 << 20 {
            return None;
        }
        let text = hookean_io::read_file(path, 64 << 20).ok()?;
        let mut lines = text.lines();
        let header = lines.next()?;
        let failed = if header == MARKER_HEADER {
            None
        } else {
            let command = header
                .strip_prefix(PARTIAL_PREFIX)?
                .strip_suffix(PARTIAL_SUFFIX)?;
            if !command.chars().all(|c| c.is_ascii_lowercase() || c == '-') {
                return None;
            }
            Some(command.to_string())
        };
        let mut m = Manifest {
            failed,
            ..Manifest::default()
        };
        for line in lines.filter(|l| !l.is_empty()) {
            let (rel, is_dir) = match line.strip_suffix('/') {
                Some(d) => (PathBuf::from(d), true),
                None => (PathBuf::from(line), false),
            };
            // Only plain relative names: nothing outside the folder.
            if !rel.components().all(|c| matches!(c, Component::Normal(_))) {
                return None;
            }
            if is_dir {
                m.dirs.insert(rel);
            } else {
                m.files.insert(rel);
            }
        }
        Some(m)
    }

    /// Writes the marker listing `self` (and itself) into `dir`.
    fn write(mut self, dir: &Path) -> std::io::Result<()> {
        self.files.insert(PathBuf::from(MARKER));
        let text = self.text();
        replace_file(&dir.join(MARKER), |w| w.write_all(text.as_bytes()))
    }
}

/// Why `dir` is not a folder `--force` may replace: `None` if it is empty or
/// holds nothing but what its marker lists, each entry of the kind listed.
fn foreign_entry(dir: &Path) -> Option<String> {
    let tree = match Manifest::of_tree(dir) {
        Ok(t) => t,
        Err(p) => return Some(format!("{} is a link or a special file", p.display())),
    };
    if tree.files.is_empty() && tree.dirs.is_empty() {
        return None;
    }
    let Some(listed) = Manifest::read(dir) else {
        return Some(format!(
            "it has no {MARKER} (hookean's list of what it wrote)"
        ));
    };
    if let Some(f) = tree.files.iter().find(|f| !listed.files.contains(*f)) {
        return Some(format!("{} was not written by hookean", f.display()));
    }
    if let Some(d) = tree.dirs.iter().find(|d| !listed.dirs.contains(*d)) {
        return Some(format!("{}/ was not written by hookean", d.display()));
    }
    None
}

/// Removes what `dir`'s marker lists, entry by entry (never a file that is
/// not listed, never through a link), then `dir` if that left it empty.
/// Returns whether `dir` is gone.
fn remove_listed(dir: &Path) -> bool {
    if let Some(m) = Manifest::read(dir) {
        for f in &m.files {
            let p = dir.join(f);
            if std::fs::symlink_metadata(&p).is_ok_and(|m| m.is_file()) {
                let _ = std::fs::remove_file(&p);
            }
        }
        // Deepest first: a folder is removed only once empty.
        let mut dirs: Vec<&PathBuf> = m.dirs.iter().collect();
        dirs.sort_by_key(|d| std::cmp::Reverse(d.components().count()));
        for d in dirs {
            let _ = std::fs::remove_dir(dir.join(d));
        }
    }
    std::fs::remove_dir(dir).is_ok()
}

/// Renames `from` to `to` unless something exists at `to`
/// (`ErrorKind::AlreadyExists` then).
fn rename_noreplace(from: &Path, to: &Path) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use rustix::fs::{CWD, RenameFlags, renameat_with};
        match renameat_with(CWD, from, CWD, to, RenameFlags::NOREPLACE) {
            Ok(()) => return Ok(()),
            Err(rustix::io::Errno::EXIST) => {
                return Err(std::io::ErrorKind::AlreadyExists.into());
            }
            // File systems without RENAME_NOREPLACE: the check-then-rename below.
            Err(rustix::io::Errno::INVAL | rustix::io::Errno::NOSYS) => {}
            Err(e) => return Err(e.into()),
        }
    }
    // rename(2) of a folder never replaces a non-empty folder or a file; the
    // check leaves only an empty folder made in between to be replaced.
    if std::fs::symlink_metadata(to).is_ok() {
        return Err(std::io::ErrorKind::AlreadyExists.into());
    }
    std::fs::rename(from, to)
}

/// An output folder being written: a fresh hidden folder beside its target,
/// moved into place by [`Staging::commit`].
#[derive(Debug)]
pub struct Staging {
    /// The target as the user named it (for messages).
    target: PathBuf,
    /// Its normalised form (for the renames).
    path: PathBuf,
    /// The staging folder.
    dir: PathBuf,
    /// `--force`: an earlier output of hookean at the target may be replaced.
    force: bool,
    /// Folders made for the target's parent, removed again if nothing is kept.
    made_parents: Vec<PathBuf>,
    /// How the flag that names the target is spelled in messages (`--out`).
    flag: &'static str,
    /// The command writing (`run`), as a partial output's marker names it.
    command: &'static str,
    /// Whether something was at the target when the command started.
    existed: bool,
    /// The target held this command's partial output when it started: it
    /// is replaced without `--force`.
    replaces_partial: bool,
    /// The staging folder's lock, held while this process lives
    /// ([`reclaim_dead_staging`]).
    _lock: Option<File>,
    /// Moved into place as a partial output ([`Staging::publish`]): `dir`
    /// is the target, written in place.
    published: bool,
}

/// The command whose failure left the partial output in `dir`, if `dir`
/// is a folder whose marker says so.
fn partial_of(dir: &Path) -> Option<String> {
    Manifest::read(dir).and_then(|m| m.failed)
}

/// Why a target cannot be replaced, for messages.
fn refuse_replace(flag: &str, target: &Path, why: &str) -> CliError {
    CliError::Input(format!(
        "{flag} {} exists and is not hookean's output ({why}); --force replaces only a folder \
         that holds nothing but an earlier hookean output: choose another {flag}",
        target.display()
    ))
}

impl Staging {
    /// Starts an output folder of `command` (`run`) for `target` (named by
    /// `flag` on the command line). An existing `target` is an error unless
    /// `force`, and then it must be a folder that [`foreign_entry`]
    /// accepts; without `force` it may only be the partial output a failed
    /// `command` left there. No file of `inputs` may lie inside `target`.
    /// Staging folders of killed runs beside `target` are removed first.
    ///
    /// # Errors
    /// [`CliError::Input`] for a target that exists without `--force`, is a
    /// file or a link, holds what hookean did not write or holds an input;
    /// [`CliError::Failed`] if the staging folder cannot be made.
    pub fn new(
        command: &'static str,
        target: &Path,
        flag: &'static str,
        force: bool,
        inputs: &[&Path],
    ) -> Result<Self, CliError> {
        let path = normalize(target);
        if path.parent().is_none() {
            return Err(CliError::Input(format!(
                "{flag} {}: the root folder cannot be an output folder",
                target.display()
            )));
        }
        for input in inputs {
            if normalize(input).starts_with(&path) {
                return Err(CliError::Input(format!(
                    "{flag} {} holds {}, which this command reads: choose another {flag}",
                    target.display(),
                    input.display()
                )));
            }
        }
        let existing = std::fs::symlink_metadata(target);
        let existed = existing.is_ok();
        let mut replaces_partial = false;
        match existing {
            // The partial output of this command's failed run: its
            // corrected rerun replaces it.
            Ok(m)
                if !force
                    && m.is_dir()
                    && partial_of(target).as_deref() == Some(command)
                    && foreign_entry(target).is_none() =>
            {
                replaces_partial = true;
            }
            Ok(_) if !force => {
                return Err(CliError::Input(format!(
                    "{flag} {} exists; pass --force to replace it",
                    target.display()
                )));
            }
            Ok(m) if m.file_type().is_symlink() => {
                return Err(refuse_replace(flag, target, "it is a link"));
            }
            Ok(m) if !m.is_dir() => {
                return Err(refuse_replace(flag, target, "it is a file"));
            }
            Ok(_) => {
                if let Some(why) = foreign_entry(target) {
                    return Err(refuse_replace(flag, target, &why));
                }
            }
            Err(_) => {}
        }
        // Parent folders the user asked for, made now and removed again if
        // the command leaves nothing.
        let mut made_parents = Vec::new();
        let mut p = parent_of(&path);
        while !p.exists() {
            made_parents.push(p.clone());
            if !p.pop() {
                break;
            }
        }
        let parent = parent_of(&path);
        std::fs::create_dir_all(&parent)
            .map_err(|e| CliError::Input(format!("{flag} {}: {e}", target.display())))?;
        install_signal_cleanup();
        reclaim_dead_staging(&parent);
        let mut k = 0;
        let (dir, lock) = loop {
            let dir = fresh_sibling(&path, "partial", k);
            // Registered before it exists, so a signal never misses it.
            live().push(dir.clone());
            match std::fs::create_dir(&dir) {
                Ok(()) => break (dir.clone(), lock_staging(&dir)),
                Err(e) => {
                    live().retain(|d| d != &dir);
                    if e.kind() == std::io::ErrorKind::AlreadyExists && k < 1000 {
                        k += 1;
                    } else {
                        return Err(CliError::Failed(format!(
                            "{flag} {}: cannot write beside it: {e}",
                            target.display()
                        )));
                    }
                }
            }
        };
        Ok(Self {
            target: target.to_path_buf(),
            path,
            dir,
            force,
            made_parents,
            flag,
            command,
            existed,
            replaces_partial,
            _lock: lock,
            published: false,
        })
    }

    /// Where the command writes.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Lists what was written in the marker and moves the folder into place:
    /// to a free target, or, with `--force`, over a folder that is still an
    /// earlier hookean output, which is then removed entry by entry.
    ///
    /// # Errors
    /// [`CliError::Failed`] if the target changed meanwhile into something
    /// that may not be replaced (it is left as it is and this output is
    /// discarded) or a rename fails.
    pub fn commit(self) -> Result<(), CliError> {
        if self.published {
            return published::mark(&self.dir, None).map_err(|e| {
                CliError::Failed(format!("{} {}: {e}", self.flag, self.target.display()))
            });
        }
        let write_marker = Manifest::of_tree(&self.dir)
            .map_err(|p| std::io::Error::other(format!("unexpected entry {}", p.display())))
            .and_then(|m| m.write(&self.dir));
        if let Err(e) = write_marker {
            return Err(self.discard(&format!("cannot finish the output: {e}")));
        }
        match rename_noreplace(&self.dir, &self.path) {
            Ok(()) => {
                self.forget();
                return Ok(());
            }
            Err(e) if e.kind() != std::io::ErrorKind::AlreadyExists => {
                return Err(self.discard(&format!("cannot move the output into place: {e}")));
            }
            Err(_) => {}
        }
        // Something is at the target now: an earlier output (replaced only
        // with --force, or a partial output of this command), or something
        // that appeared while this ran.
        if !self.force && !self.replaces_partial {
            return Err(self.discard(
                "it appeared while this command ran (another run, or a folder made meanwhile); \
                 it was left as it is",
            ));
        }
        if let Err(why) = self.replace_target(!self.force) {
            return Err(self.discard(&why));
        }
        self.forget();
        if !self.force {
            crate::errln!(
                "hookean: replaced the partial output that a failed `hookean {}` left in {}",
                self.command,
                self.target.display()
            );
        }
        Ok(())
    }

    /// Swaps the staging folder in for the earlier output at the target
    /// (only a partial output of this command if `partial_only`) and
    /// removes the earlier output; or says why the target was left as it is.
    fn replace_target(&self, partial_only: bool) -> Result<(), String> {
        // The swap holds the signal handler's lock: a signal waits until the
        // earlier output is either back at the target or replaced.
        let aside = {
            let mut signals_wait = live();
            self.swap_in(&mut signals_wait, partial_only)?
        };
        let removed = remove_listed(&aside);
        live().retain(|d| d != &aside);
        if !removed {
            crate::errln!(
                "hookean: warning: the earlier output moved aside to {} kept entries hookean did \
                 not write; it was left there",
                aside.display()
            );
        }
        Ok(())
    }

    /// Moves the target aside, checks that it is still an earlier hookean
    /// output (a partial output of this command if `partial_only`) and
    /// moves the staging folder in its place; returns the folder moved
    /// aside, or why the target was put back (or left) as it was.
    fn swap_in(&self, live: &mut Vec<PathBuf>, partial_only: bool) -> Result<PathBuf, String> {
        let mut k = 0;
        let aside = loop {
            let aside = fresh_sibling(&self.path, "old", k);
            match rename_noreplace(&self.path, &aside) {
                Ok(()) => break aside,
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && k < 1000 => k += 1,
                Err(e) => return Err(format!("cannot replace it: {e}")),
            }
        };
        // Checked again now that it cannot change under us: still only
        // hookean's entries?
        let foreign =
            std::fs::symlink_metadata(&aside).map_or(Some("it vanished".to_string()), |m| {
                if m.is_dir() {
                    foreign_entry(&aside)
                } else {
                    Some("it is not a folder".to_string())
                }
            });
        let put_back = |why: String| match rename_noreplace(&aside, &self.path) {
            Ok(()) => why,
            // Only if a third folder appeared at the target in between.
            Err(_) => format!("{why}; the earlier output is in {}", aside.display()),
        };
        let foreign = foreign.or_else(|| {
            (partial_only && partial_of(&aside).as_deref() != Some(self.command)).then(|| {
                format!(
                    "it is no longer the partial output of a failed `hookean {}`",
                    self.command
                )
            })
        });
        if let Some(why) = foreign {
            return Err(put_back(format!(
                "it changed while this command ran ({why}); it was left as it is"
            )));
        }
        match rename_noreplace(&self.dir, &self.path) {
            Ok(()) => {
                // Ours, checked: removed on a signal from here on.
                live.push(aside.clone());
                Ok(aside)
            }
            Err(e) => Err(put_back(format!("cannot move the output into place: {e}"))),
        }
    }

    /// Ends a failed command: a partial output goes to a free target, or
    /// over an earlier partial output of the same command (so its frames
    /// can be viewed), marked as this command's partial output; any other
    /// existing target is left as it was and the partial output dropped.
    /// Returns `error` with what happened appended.
    pub fn abandon(self, error: CliError) -> CliError {
        if self.published {
            let note = match published::mark(&self.dir, Some(self.command)) {
                Ok(()) => format!("; the partial output is in {}", self.target.display()),
                Err(e) => format!("; {} could not be marked: {e}", self.target.display()),
            };
            return match error {
                CliError::Input(m) => CliError::Input(m + &note),
                CliError::Failed(m) => CliError::Failed(m + &note),
                other => other,
            };
        }
        let empty = std::fs::read_dir(&self.dir).map_or(true, |mut d| d.next().is_none());
        let note = if empty {
            String::new()
        } else {
            match self.keep_partial() {
                Ok(()) => format!("; the partial output is in {}", self.target.display()),
                Err(why) => {
                    let now = std::fs::symlink_metadata(&self.path).is_ok();
                    let target = self.target.display();
                    match (self.existed, now) {
                        (true, true) => format!(
                            "; {target} is unchanged (this run's partial output was discarded: \
                             run into a new folder to keep it)"
                        ),
                        (false, true) => format!(
                            "; {target} appeared while this command ran and was left as it is \
                             (this run's partial output was discarded)"
                        ),
                        (true, false) => format!(
                            "; {target} was removed while this command ran; this run's partial \
                             output was discarded ({why})"
                        ),
                        (false, false) => format!(
                            "; nothing was written to {target}: this run's partial output could \
                             not be kept ({why})"
                        ),
                    }
                }
            }
        };
        // Messages name the target, never the staging folder.
        let (staging, target) = (
            self.dir.display().to_string(),
            self.target.display().to_string(),
        );
        drop(self);
        match error {
            CliError::Input(m) => CliError::Input(m.replace(&staging, &target) + &note),
            CliError::Failed(m) => CliError::Failed(m.replace(&staging, &target) + &note),
            other => other,
        }
    }

    /// Marks the staging folder as this command's partial output and moves
    /// it to the target: a free one, or over an earlier partial output of
    /// this command.
    fn keep_partial(&self) -> Result<(), String> {
        Manifest::of_tree(&self.dir)
            .map_err(|p| format!("unexpected entry {}", p.display()))
            .and_then(|mut m| {
                m.failed = Some(self.command.to_string());
                m.write(&self.dir).map_err(|e| e.to_string())
            })?;
        match rename_noreplace(&self.dir, &self.path) {
            Ok(()) => Ok(()),
            Err(e)
                if e.kind() == std::io::ErrorKind::AlreadyExists
                    && partial_of(&self.path).as_deref() == Some(self.command) =>
            {
                self.replace_target(true)
            }
            Err(e) => Err(e.to_string()),
        }
    }

    /// Drops this output and returns the failure naming the target.
    fn discard(self, why: &str) -> CliError {
        CliError::Failed(format!("{} {}: {why}", self.flag, self.target.display()))
    }

    /// Removes the staging folder (if still there) and parent folders made
    /// for a target that does not exist.
    fn drop_staging(&self) {
        if self.dir.exists() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
        if !self.path.exists() {
            for p in &self.made_parents {
                let _ = std::fs::remove_dir(p);
            }
        }
        self.forget();
    }

    fn forget(&self) {
        live().retain(|d| d != &self.dir);
    }
}

impl Drop for Staging {
    /// An output neither committed nor moved into place is removed (a
    /// command that returned early, or a failure).
    fn drop(&mut self) {
        if live().contains(&self.dir) {
            self.drop_staging();
        }
    }
}

/// Adds `name` (a file just written into `dir`) to `dir`'s marker, if it
/// has one, so that `--force` may later replace the folder with it.
///
/// # Errors
/// The `io::Error` of rewriting the marker.
pub fn add_to_marker(dir: &Path, name: &str) -> std::io::Result<()> {
    match Manifest::read(dir) {
        Some(mut m) => {
            m.files.insert(PathBuf::from(name));
            m.write(dir)
        }
        None => Ok(()),
    }
}

/// Whether `dir/name` is a regular file that `dir`'s marker lists (an output
/// of hookean that `--force` may replace).
pub fn is_listed_file(dir: &Path, name: &str) -> bool {
    std::fs::symlink_metadata(dir.join(name)).is_ok_and(|m| m.is_file())
        && Manifest::read(dir).is_some_and(|m| m.files.contains(Path::new(name)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("hookean-output-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn normalize_applies_dotdot_below_an_existing_prefix() {
        let d = scratch("normalize");
        std::fs::create_dir(d.join("o")).unwrap();
        assert_eq!(
            normalize(&d.join("o/sub/../a.csv")),
            normalize(&d.join("o/a.csv"))
        );
        assert!(same_file(&d.join("o/./a.csv"), &d.join("o/a.csv")));
        assert!(!same_file(&d.join("o/a.csv"), &d.join("o/b.csv")));
        // A link to a folder resolves to the folder.
        std::os::unix::fs::symlink(d.join("o"), d.join("l")).unwrap();
        assert!(same_file(&d.join("l/a.csv"), &d.join("o/a.csv")));
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn replace_file_replaces_a_link_and_leaves_its_target() {
        let d = scratch("replace");
        std::fs::write(d.join("mine.txt"), "mine").unwrap();
        std::os::unix::fs::symlink(d.join("mine.txt"), d.join("view.html")).unwrap();
        replace_file(&d.join("view.html"), |w| w.write_all(b"<html>")).unwrap();
        assert_eq!(std::fs::read_to_string(d.join("mine.txt")).unwrap(), "mine");
        assert!(
            !std::fs::symlink_metadata(d.join("view.html"))
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(
            std::fs::read_to_string(d.join("view.html")).unwrap(),
            "<html>"
        );
        // A dangling link: the file is made here, not at the link's target.
        std::os::unix::fs::symlink(d.join("elsewhere.txt"), d.join("b.html")).unwrap();
        replace_file(&d.join("b.html"), |w| w.write_all(b"b")).unwrap();
        assert!(!d.join("elsewhere.txt").exists());
        // Nothing else is left in the folder.
        let names: BTreeSet<String> = std::fs::read_dir(&d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            ["b.html", "mine.txt", "view.html"].map(String::from).into()
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_folder_is_replaceable_only_with_nothing_but_its_listed_entries() {
        let d = scratch("foreign");
        let run = d.join("run");
        std::fs::create_dir_all(run.join("sub")).unwrap();
        assert_eq!(
            foreign_entry(&run),
            Some("it has no .hookean-output (hookean's list of what it wrote)".into())
        );
        std::fs::write(run.join("steps.csv"), "t\n").unwrap();
        std::fs::write(run.join("sub/a.png"), "p").unwrap();
        Manifest::of_tree(&run).unwrap().write(&run).unwrap();
        assert_eq!(foreign_entry(&run), None);
        std::fs::write(run.join("notes.txt"), "mine").unwrap();
        assert!(foreign_entry(&run).unwrap().contains("notes.txt"));
        std::fs::remove_file(run.join("notes.txt")).unwrap();
        // A listed name turned into a link is not hookean's any more.
        std::fs::remove_file(run.join("steps.csv")).unwrap();
        std::os::unix::fs::symlink(d.join("x"), run.join("steps.csv")).unwrap();
        assert!(foreign_entry(&run).unwrap().contains("link"));
        std::fs::remove_file(run.join("steps.csv")).unwrap();
        // remove_listed removes listed files only.
        std::fs::write(run.join("sub/mine.txt"), "mine").unwrap();
        assert!(!remove_listed(&run));
        assert_eq!(
            std::fs::read_to_string(run.join("sub/mine.txt")).unwrap(),
            "mine"
        );
        assert!(!run.join("sub/a.png").exists());
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn rename_noreplace_never_replaces() {
        let d = scratch("noreplace");
        std::fs::create_dir(d.join("a")).unwrap();
        std::fs::create_dir(d.join("b")).unwrap();
        let e = rename_noreplace(&d.join("a"), &d.join("b")).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
        assert!(d.join("a").exists());
        rename_noreplace(&d.join("a"), &d.join("c")).unwrap();
        assert!(d.join("c").exists() && !d.join("a").exists());
        std::fs::remove_dir_all(&d).unwrap();
    }

    fn message(e: CliError) -> String {
        match e {
            CliError::Input(m) | CliError::Failed(m) => m,
            other => format!("{other:?}"),
        }
    }

    /// A command that fails after writing `file` into `target`.
    fn fail(command: &'static str, target: &Path, force: bool, file: &str) -> String {
        let s = Staging::new(command, target, "--out", force, &[]).unwrap();
        std::fs::write(s.dir().join(file), "partial").unwrap();
        message(s.abandon(CliError::Failed("it failed".into())))
    }

    #[test]
    fn a_failed_commands_partial_output_is_replaced_by_its_own_rerun_only() {
        let d = scratch("partial");
        let out = d.join("out");
        let m = fail("run", &out, false, "steps.csv");
        assert!(
            m.ends_with(&format!("; the partial output is in {}", out.display())),
            "{m}"
        );
        assert_eq!(partial_of(&out).as_deref(), Some("run"));
        // Another command needs --force; the same command does not.
        let e = message(Staging::new("filter-analysis", &out, "--out", false, &[]).unwrap_err());
        assert!(e.contains("exists; pass --force"), "{e}");
        // A rerun that fails again replaces the partial output with its own.
        let m = fail("run", &out, false, "frame-0000.obj");
        assert!(m.contains("the partial output is in"), "{m}");
        assert!(out.join("frame-0000.obj").exists() && !out.join("steps.csv").exists());
        // The corrected rerun replaces it and leaves a finished output.
        let s = Staging::new("run", &out, "--out", false, &[]).unwrap();
        std::fs::write(s.dir().join("summary.json"), "{}").unwrap();
        s.commit().unwrap();
        assert!(out.join("summary.json").exists() && !out.join("frame-0000.obj").exists());
        assert_eq!(Manifest::read(&out).unwrap().failed, None);
        // A finished output is replaced only with --force; a run that fails
        // then leaves it as it was, and says so.
        let e = message(Staging::new("run", &out, "--out", false, &[]).unwrap_err());
        assert!(e.contains("exists; pass --force"), "{e}");
        let m = fail("run", &out, true, "steps.csv");
        assert!(m.contains("is unchanged"), "{m}");
        assert!(out.join("summary.json").exists() && !out.join("steps.csv").exists());
        // A partial output holding a file of the user's is the user's folder.
        let other = d.join("other");
        fail("filter-analysis", &other, false, "fig4.png");
        std::fs::write(other.join("notes.txt"), "mine").unwrap();
        let e = message(Staging::new("filter-analysis", &other, "--plot", false, &[]).unwrap_err());
        assert!(e.contains("exists; pass --force"), "{e}");
        assert_eq!(
            std::fs::read_to_string(other.join("notes.txt")).unwrap(),
            "mine"
        );
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_partial_output_that_cannot_be_kept_is_not_called_unchanged() {
        let d = scratch("unkept");
        let out = d.join("out");
        let s = Staging::new("run", &out, "--out", false, &[]).unwrap();
        std::fs::write(s.dir().join("steps.csv"), "t\n").unwrap();
        // A link inside the staging folder: the marker cannot list it, so
        // the partial output cannot be kept (as when the disk is full).
        std::os::unix::fs::symlink("/", s.dir().join("odd")).unwrap();
        let m = message(s.abandon(CliError::Failed("it failed".into())));
        assert!(!m.contains("unchanged"), "{m}");
        assert!(
            m.contains(&format!("nothing was written to {}", out.display())),
            "{m}"
        );
        assert!(!out.exists());
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
