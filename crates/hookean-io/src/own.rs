//! Writing a program's own output file so that running the program again
//! replaces what it wrote before, and nothing else: a file at the path that
//! the program did not write is kept unless the user asks (`force`).

use std::io::{Read, Write};
use std::path::Path;

/// What [`write_own`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Written {
    /// There was no file: it was created.
    Created,
    /// The file was the program's own (or `force` was given): replaced.
    Replaced,
    /// The file already held exactly these bytes: left as it was.
    Unchanged,
}

/// Why [`write_own`] wrote nothing.
#[derive(Debug, thiserror::Error)]
pub enum OwnError {
    /// A file the program did not write is at the path.
    #[error("{path} exists and was not written by this program; pass --force to replace it")]
    NotOwn {
        /// The path, as given.
        path: String,
    },
    /// Reading the existing file or writing the new one failed.
    #[error("{path}: {source}")]
    Io {
        /// The path, as given.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Writes `content` to `path`, replacing a file that is there only when it
/// holds the same bytes, when `own` recognises it as the program's own
/// output (say, by a header line only the program writes), or when `force`.
/// The new file is written beside the old one and renamed over it, so a
/// failed write leaves the old file whole. The existing file is read only
/// if it is a regular file ([`open_regular`](crate::open_regular)) of at
/// most `content.len() + 1 MiB` bytes; a larger one is not the program's.
///
/// ```
/// use hookean_io::{write_own, OwnError, Written};
/// let dir = std::env::temp_dir().join(format!("hookean-io-own-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("table.csv");
/// let own = |old: &[u8]| old.starts_with(b"# written by the example\n");
/// let first = b"# written by the example\n1,2\n";
/// assert_eq!(write_own(&path, first, own, false).unwrap(), Written::Created);
/// assert_eq!(write_own(&path, first, own, false).unwrap(), Written::Unchanged);
/// assert_eq!(write_own(&path, b"# written by the example\n3\n", own, false).unwrap(), Written::Replaced);
/// std::fs::write(&path, "a user's notes").unwrap();
/// assert!(matches!(write_own(&path, first, own, false), Err(OwnError::NotOwn { .. })));
/// assert_eq!(std::fs::read_to_string(&path).unwrap(), "a user's notes");
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
///
/// # Errors
/// [`OwnError::NotOwn`] for a file that is not the program's (nothing is
/// written), [`OwnError::Io`] when reading or writing fails.
pub fn write_own(
    path: impl AsRef<Path>,
    content: &[u8],
    own: impl Fn(&[u8]) -> bool,
    force: bool,
) -> Result<Written, OwnError> {
    let path = path.as_ref();
    let shown = path.display().to_string();
    let io = |source| OwnError::Io {
        path: shown.clone(),
        source,
    };
    let existed = match std::fs::symlink_metadata(path) {
        Ok(_) => true,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
        Err(e) => return Err(io(e)),
    };
    if existed {
        let old = crate::open_regular(path).and_then(|f| {
            let mut old = Vec::new();
            f.take(content.len() as u64 + (1 << 20))
                .read_to_end(&mut old)?;
            Ok(old)
        });
        match old {
            Ok(old) if old == content => return Ok(Written::Unchanged),
            Ok(old) if force || own(&old) => {}
            _ if force => {}
            _ => return Err(OwnError::NotOwn { path: shown }),
        }
    }
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let staged = path.with_file_name(format!(".{name}.{}.partial", std::process::id()));
    let written = std::fs::File::create(&staged)
        .and_then(|mut f| f.write_all(content).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&staged, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&staged);
        return Err(io(e));
    }
    Ok(if existed {
        Written::Replaced
    } else {
        Written::Created
    })
}

/// `content` with the line `mark` (ending in a line break) inserted after
/// its first line, a format's banner (Matrix Market's `%%MatrixMarket ...`
/// takes `%` comment lines after it): how a program marks a file as its
/// own for [`write_own`] and [`has_banner_mark`].
///
/// ```
/// let marked = hookean_io::with_banner_mark(b"%%banner\n1 1\n", b"% mine\n");
/// assert_eq!(marked, b"%%banner\n% mine\n1 1\n");
/// assert!(hookean_io::has_banner_mark(&marked, b"% mine\n"));
/// assert!(!hookean_io::has_banner_mark(b"%%banner\n1 1\n", b"% mine\n"));
/// ```
pub fn with_banner_mark(content: &[u8], mark: &[u8]) -> Vec<u8> {
    let cut = content
        .iter()
        .position(|&c| c == b'\n')
        .map_or(content.len(), |i| i + 1);
    [&content[..cut], mark, &content[cut..]].concat()
}

/// Whether the second line of `old` is `mark` (see [`with_banner_mark`]).
pub fn has_banner_mark(old: &[u8], mark: &[u8]) -> bool {
    let start = old
        .iter()
        .position(|&c| c == b'\n')
        .map_or(old.len(), |i| i + 1);
    old[start..].starts_with(mark)
}
