//! An output folder written in place: a checkpointing run's folder is
//! moved into place as a partial output of `hookean run` before its first
//! checkpoint (so that a killed run leaves its checkpoint where
//! `--resume` finds it), its marker rewritten at every checkpoint, and
//! marked finished at the end; `--resume` writes into it in place.

use std::path::Path;

use super::{Manifest, Staging};
use crate::CliError;

/// Rewrites `dir`'s marker to list what is in it now: a finished output
/// (`partial_of = None`) or the partial output of the command named.
///
/// # Errors
/// The `io::Error` of listing the folder or writing the marker.
pub fn mark(dir: &Path, partial_of: Option<&str>) -> std::io::Result<()> {
    let mut m = Manifest::of_tree(dir)
        .map_err(|p| std::io::Error::other(format!("unexpected entry {}", p.display())))?;
    m.failed = partial_of.map(str::to_string);
    m.write(dir)
}

/// Whether `dir`'s marker says it is a partial output of `hookean run`
/// (what `--resume` continues). Entries it does not list are allowed: a
/// run killed after a checkpoint wrote frames after the marker's last
/// rewrite, which the resumed run removes and writes again.
pub fn is_partial_run(dir: &Path) -> bool {
    super::partial_of(dir).as_deref() == Some("run")
}

impl Staging {
    /// Moves the folder into place now, marked as this command's partial
    /// output (to a free target, or over a partial output of this
    /// command), and writes into it there from now on ([`Staging::dir`]
    /// is the target); [`commit`](Staging::commit) marks it finished.
    ///
    /// # Errors
    /// [`CliError::Failed`] if it cannot be moved into place (the
    /// target is then as it was).
    pub fn publish(&mut self) -> Result<(), CliError> {
        if self.published {
            return Ok(());
        }
        self.keep_partial().map_err(|why| {
            CliError::Failed(format!("{} {}: {why}", self.flag, self.target.display()))
        })?;
        self.forget();
        self.dir = self.path.clone();
        self.published = true;
        Ok(())
    }

    /// Whether the folder was moved into place ([`publish`](Self::publish)).
    pub fn is_published(&self) -> bool {
        self.published
    }
}
