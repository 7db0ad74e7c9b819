//! Output folders written whole or not at all. A run writes into a staging
//! folder beside its target (`.NAME.partial-PID`) and renames it into place
//! when it succeeds, so `--force` leaves exactly what this run wrote (no
//! frames of an earlier, longer run), and a run that fails leaves the
//! previous results intact and says where its partial output is.

use std::path::{Path, PathBuf};

use crate::CliError;

/// Files by which a folder is recognised as the output of an earlier run,
/// which `--force` may replace.
const RUN_FILES: [&str; 5] = [
    "summary.json",
    "steps.csv",
    "final.png",
    "view.html",
    "claims.json",
];

/// A staging folder for the output folder `target`.
#[derive(Debug)]
pub struct Staging {
    target: PathBuf,
    dir: PathBuf,
}

fn io(path: &Path, e: std::io::Error) -> CliError {
    CliError::Failed(format!("{}: {e}", path.display()))
}

/// A sibling of `target` named `.NAME.TAG-PID`.
fn sibling(target: &Path, tag: &str) -> PathBuf {
    let name = target
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let parent = match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    parent.join(format!(".{name}.{tag}-{}", std::process::id()))
}

impl Staging {
    /// Creates the staging folder. An existing `target` must be a folder
    /// that is empty or holds an earlier run's output (it is replaced only
    /// when the run succeeds).
    ///
    /// # Errors
    /// [`CliError::Input`] for a `target` that is a file or a folder of
    /// something else; [`CliError::Failed`] if the folder cannot be made.
    pub fn new(target: &Path) -> Result<Self, CliError> {
        if target.exists() {
            let entries: Vec<String> = std::fs::read_dir(target)
                .map_err(|e| {
                    CliError::Input(format!(
                        "{}: {e} (the output must be a folder)",
                        target.display()
                    ))
                })?
                .filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            let is_run =
                entries.is_empty() || entries.iter().any(|e| RUN_FILES.contains(&e.as_str()));
            if !is_run {
                return Err(CliError::Input(format!(
                    "{} exists and does not hold a hookean run (no summary.json, steps.csv, final.png \
                     or view.html); --force replaces only run folders: choose another --out",
                    target.display()
                )));
            }
        }
        let dir = sibling(target, "partial");
        if dir.exists() {
            std::fs::remove_dir_all(&dir).map_err(|e| io(&dir, e))?;
        }
        std::fs::create_dir_all(&dir).map_err(|e| io(&dir, e))?;
        Ok(Self {
            target: target.to_path_buf(),
            dir,
        })
    }

    /// Where the run writes.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Moves the finished output into place, replacing an earlier run's.
    ///
    /// # Errors
    /// [`CliError::Failed`] if a rename fails (the new output is then still
    /// in the staging folder, which the message names).
    pub fn commit(self) -> Result<(), CliError> {
        let moved = |e: std::io::Error| {
            CliError::Failed(format!(
                "could not move the output into {}: {e}; it is in {}",
                self.target.display(),
                self.dir.display()
            ))
        };
        if self.target.exists() {
            let old = sibling(&self.target, "old");
            std::fs::rename(&self.target, &old).map_err(moved)?;
            if let Err(e) = std::fs::rename(&self.dir, &self.target) {
                // Put the earlier run back before reporting.
                let _ = std::fs::rename(&old, &self.target);
                return Err(moved(e));
            }
            std::fs::remove_dir_all(&old).map_err(|e| io(&old, e))?;
        } else {
            std::fs::rename(&self.dir, &self.target).map_err(moved)?;
        }
        Ok(())
    }

    /// Leaves the target as it was; keeps a non-empty partial output for
    /// inspection and names it in the error.
    pub fn abandon(self, error: CliError) -> CliError {
        let empty = std::fs::read_dir(&self.dir).map_or(true, |mut d| d.next().is_none());
        if empty {
            let _ = std::fs::remove_dir(&self.dir);
            return error;
        }
        let note = format!(
            "; the partial output is in {} ({} is unchanged)",
            self.dir.display(),
            self.target.display()
        );
        match error {
            CliError::Input(m) => CliError::Input(m + &note),
            CliError::Failed(m) => CliError::Failed(m + &note),
            other => other,
        }
    }
}
