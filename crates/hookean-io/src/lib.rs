#![doc = include_str!("../README.md")]

mod own;
pub use own::{OwnError, Written, has_banner_mark, with_banner_mark, write_own};

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// What a path names when it is not a regular file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum FileKind {
    /// A folder (directory).
    Folder,
    /// A FIFO (named pipe): opening it for reading waits for a writer.
    Fifo,
    /// A character device (`/dev/null`, `/dev/zero`, a terminal).
    CharDevice,
    /// A block device (a disk).
    BlockDevice,
    /// A Unix socket.
    Socket,
    /// Anything else that is not a regular file.
    Other,
}

impl FileKind {
    /// The kind of `t`, `None` for a regular file.
    fn of(t: std::fs::FileType) -> Option<Self> {
        if t.is_file() {
            return None;
        }
        if t.is_dir() {
            return Some(FileKind::Folder);
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt as _;
            if t.is_fifo() {
                return Some(FileKind::Fifo);
            }
            if t.is_char_device() {
                return Some(FileKind::CharDevice);
            }
            if t.is_block_device() {
                return Some(FileKind::BlockDevice);
            }
            if t.is_socket() {
                return Some(FileKind::Socket);
            }
        }
        Some(FileKind::Other)
    }
}

impl std::fmt::Display for FileKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FileKind::Folder => "a folder",
            FileKind::Fifo => "a FIFO (named pipe)",
            FileKind::CharDevice => "a character device",
            FileKind::BlockDevice => "a block device",
            FileKind::Socket => "a socket",
            FileKind::Other => "a special file",
        })
    }
}

/// A path given to a reader names something other than a regular file.
/// [`open_regular`] returns it inside an `io::Error` of kind
/// `InvalidInput` (`error.get_ref()` downcasts to it), so that every
/// reader's existing "file: reason" message names the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("it is {kind}, not a regular file (only regular files are read)")]
pub struct NotRegularFile {
    /// What it is.
    pub kind: FileKind,
}

fn check_regular(t: std::fs::FileType) -> std::io::Result<()> {
    match FileKind::of(t) {
        None => Ok(()),
        Some(kind) => Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            NotRegularFile { kind },
        )),
    }
}

/// Opens `path` for reading if it is a regular file (links followed),
/// without ever blocking: the path's type is checked before it is opened,
/// the file is opened non-blocking (a FIFO put in its place meanwhile does
/// not wait for a writer), and the opened file's type is checked again.
/// Every reader of the workspace opens its files here.
///
/// ```
/// use hookean_io::{FileKind, NotRegularFile, open_regular};
/// let e = open_regular(std::env::temp_dir()).unwrap_err();
/// let why = e.get_ref().and_then(|e| e.downcast_ref::<NotRegularFile>());
/// assert_eq!(why, Some(&NotRegularFile { kind: FileKind::Folder }));
/// assert!(e.to_string().contains("it is a folder, not a regular file"));
/// ```
///
/// # Errors
/// The `io::Error` of `metadata` or `open` (a missing file, no
/// permission); an `io::Error` of kind `InvalidInput` holding
/// [`NotRegularFile`] for a folder, FIFO, device, socket.
pub fn open_regular(path: impl AsRef<Path>) -> std::io::Result<File> {
    let path = path.as_ref();
    check_regular(std::fs::metadata(path)?.file_type())?;
    let file = open_nonblocking(path)?;
    check_regular(file.metadata()?.file_type())?;
    Ok(file)
}

#[cfg(unix)]
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    use rustix::fs::OFlags;
    use std::os::unix::fs::OpenOptionsExt as _;
    let file = File::options()
        .read(true)
        .custom_flags(OFlags::NONBLOCK.bits() as i32)
        .open(path)?;
    // A regular file reads alike either way; the flag is cleared so that
    // the file behaves as one opened plainly.
    let flags = rustix::fs::fcntl_getfl(&file)?;
    rustix::fs::fcntl_setfl(&file, flags.difference(OFlags::NONBLOCK))?;
    Ok(file)
}

#[cfg(not(unix))]
fn open_nonblocking(path: &Path) -> std::io::Result<File> {
    File::open(path)
}

/// The lines of the regular file `path` ([`open_regular`], then
/// [`capped_lines`]).
///
/// # Errors
/// The `io::Error` of [`open_regular`].
pub fn file_lines(
    path: impl AsRef<Path>,
    limits: LineLimits,
) -> std::io::Result<CappedLines<BufReader<File>>> {
    Ok(capped_lines(BufReader::new(open_regular(path)?), limits))
}

/// The text of the regular file `path`, at most `max_bytes` bytes
/// ([`open_regular`], then [`read_capped`]).
///
/// # Errors
/// [`TextError::Io`] holding the error of [`open_regular`]; as
/// [`read_capped`].
pub fn read_file(path: impl AsRef<Path>, max_bytes: u64) -> Result<String, TextError> {
    read_capped(open_regular(path)?, max_bytes)
}

/// The UTF-8 byte-order mark some editors put at the start of a text file.
const BOM: &[u8] = b"\xEF\xBB\xBF";

/// Caps of [`capped_lines`] and [`read_capped`]: a value of two numbers,
/// both always given (`..Default::default()` keeps the other's default).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineLimits {
    /// Bytes of one line, without its line break. Default 1 MiB.
    pub max_line_bytes: usize,
    /// Bytes of the whole input. Default 4 GiB.
    pub max_total_bytes: u64,
}

impl Default for LineLimits {
    fn default() -> Self {
        Self {
            max_line_bytes: 1 << 20,
            max_total_bytes: 4 << 30,
        }
    }
}

/// Why a capped read stopped.
#[derive(Debug, thiserror::Error)]
pub enum TextError {
    /// The reader failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// A line is longer than [`LineLimits::max_line_bytes`].
    #[error("line {line} is longer than {max} bytes")]
    LineTooLong {
        /// 1-based line.
        line: usize,
        /// The cap.
        max: usize,
    },
    /// The input is longer than [`LineLimits::max_total_bytes`].
    #[error("the input is larger than {max} bytes (at line {line})")]
    TooLarge {
        /// 1-based line where the cap was reached.
        line: usize,
        /// The cap.
        max: u64,
    },
    /// A line is not UTF-8.
    #[error("line {line} is not UTF-8 text")]
    NotText {
        /// 1-based line.
        line: usize,
    },
}

impl TextError {
    /// The 1-based line the error is at, if any.
    pub fn line(&self) -> Option<usize> {
        match self {
            TextError::Io(_) => None,
            TextError::LineTooLong { line, .. }
            | TextError::TooLarge { line, .. }
            | TextError::NotText { line } => Some(*line),
        }
    }
}

/// The lines of `reader` (without `\n` or `\r\n`, and without a UTF-8
/// byte-order mark at the start of line 1), each at most
/// `limits.max_line_bytes` long, at most `limits.max_total_bytes` in all.
pub fn capped_lines<R: BufRead>(reader: R, limits: LineLimits) -> CappedLines<R> {
    CappedLines {
        reader,
        limits,
        line: 0,
        total: 0,
        buf: Vec::new(),
        done: false,
    }
}

/// The iterator of [`capped_lines`].
#[derive(Debug)]
pub struct CappedLines<R> {
    reader: R,
    limits: LineLimits,
    line: usize,
    total: u64,
    buf: Vec<u8>,
    done: bool,
}

impl<R: BufRead> Iterator for CappedLines<R> {
    type Item = Result<String, TextError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        self.line += 1;
        self.buf.clear();
        // One byte more than a line may hold (plus its "\r\n") tells a line
        // that is too long from one that just fits.
        let take = self.limits.max_line_bytes as u64 + 3;
        let read = match (&mut self.reader)
            .take(take)
            .read_until(b'\n', &mut self.buf)
        {
            Ok(n) => n,
            Err(e) => {
                self.done = true;
                return Some(Err(e.into()));
            }
        };
        if read == 0 {
            self.done = true;
            return None;
        }
        self.total += read as u64;
        if self.total > self.limits.max_total_bytes {
            self.done = true;
            return Some(Err(TextError::TooLarge {
                line: self.line,
                max: self.limits.max_total_bytes,
            }));
        }
        if self.line == 1 && self.buf.starts_with(BOM) {
            self.buf.drain(..BOM.len());
        }
        if self.buf.last() == Some(&b'\n') {
            self.buf.pop();
            if self.buf.last() == Some(&b'\r') {
                self.buf.pop();
            }
        }
        if self.buf.len() > self.limits.max_line_bytes {
            self.done = true;
            return Some(Err(TextError::LineTooLong {
                line: self.line,
                max: self.limits.max_line_bytes,
            }));
        }
        match String::from_utf8(std::mem::take(&mut self.buf)) {
            Ok(s) => Some(Ok(s)),
            Err(_) => {
                self.done = true;
                Some(Err(TextError::NotText { line: self.line }))
            }
        }
    }
}

/// The whole of `reader` as text, at most `max_bytes` bytes, without a
/// UTF-8 byte-order mark at its start.
///
/// # Errors
/// [`TextError::TooLarge`] past the cap (line 1: the position is not
/// tracked), [`TextError::NotText`] for bytes that are not UTF-8,
/// [`TextError::Io`] if reading fails.
pub fn read_capped(reader: impl Read, max_bytes: u64) -> Result<String, TextError> {
    let mut bytes = Vec::new();
    reader
        .take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(TextError::TooLarge {
            line: 1,
            max: max_bytes,
        });
    }
    if bytes.starts_with(BOM) {
        bytes.drain(..BOM.len());
    }
    String::from_utf8(bytes).map_err(|e| {
        let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        TextError::NotText {
            line: valid.iter().filter(|&&b| b == b'\n').count() + 1,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all(text: &[u8], limits: LineLimits) -> Result<Vec<String>, TextError> {
        capped_lines(text, limits).collect()
    }

    #[test]
    fn lines_split_on_lf_and_crlf_and_the_last_line_needs_no_break() {
        let l = LineLimits::default();
        assert_eq!(all(b"a\r\nb\nc", l).unwrap(), ["a", "b", "c"]);
        assert_eq!(all(b"", l).unwrap(), Vec::<String>::new());
        assert_eq!(all(b"\n\n", l).unwrap(), ["", ""]);
    }

    #[test]
    fn a_line_at_the_cap_passes_and_one_byte_more_is_refused() {
        let l = LineLimits {
            max_line_bytes: 4,
            ..Default::default()
        };
        assert_eq!(all(b"abcd\r\nabcd", l).unwrap(), ["abcd", "abcd"]);
        let e = all(b"ok\nabcde\n", l).unwrap_err();
        assert!(
            matches!(e, TextError::LineTooLong { line: 2, max: 4 }),
            "{e}"
        );
        // An endless line stops at the cap (a reader that never ends).
        let e = capped_lines(std::io::BufReader::new(std::io::repeat(0)), l)
            .next()
            .unwrap()
            .unwrap_err();
        assert!(matches!(e, TextError::LineTooLong { line: 1, .. }));
    }

    #[test]
    fn the_total_cap_counts_every_byte() {
        let l = LineLimits {
            max_line_bytes: 100,
            max_total_bytes: 6,
        };
        assert_eq!(all(b"ab\ncd\n", l).unwrap(), ["ab", "cd"]);
        let e = all(b"ab\ncd\ne", l).unwrap_err();
        assert!(matches!(e, TextError::TooLarge { line: 3, max: 6 }), "{e}");
        let e = capped_lines(std::io::BufReader::new(std::io::repeat(b'\n')), l)
            .find_map(Result::err)
            .unwrap();
        assert!(matches!(e, TextError::TooLarge { line: 7, .. }));
    }

    #[test]
    fn bytes_that_are_not_text_name_their_line() {
        let e = all(b"ok\n\xff\xfe\n", LineLimits::default()).unwrap_err();
        assert!(matches!(e, TextError::NotText { line: 2 }));
        assert!(matches!(
            read_capped(&b"a\nb\n\xff"[..], 100),
            Err(TextError::NotText { line: 3 })
        ));
        assert!(matches!(
            read_capped(std::io::repeat(b'x'), 10),
            Err(TextError::TooLarge { max: 10, .. })
        ));
        assert_eq!(read_capped(&b"abc"[..], 3).unwrap(), "abc");
    }

    #[test]
    fn a_byte_order_mark_at_the_start_is_skipped_and_nowhere_else() {
        let l = LineLimits::default();
        assert_eq!(
            all(b"\xEF\xBB\xBFv 1 2 3\r\nv 4 5 6\n", l).unwrap(),
            ["v 1 2 3", "v 4 5 6"]
        );
        // Only at the start: a second mark is text (U+FEFF).
        assert_eq!(all(b"a\n\xEF\xBB\xBFb\n", l).unwrap(), ["a", "\u{feff}b"]);
        assert_eq!(
            read_capped(&b"\xEF\xBB\xBFk = 1\n"[..], 100).unwrap(),
            "k = 1\n"
        );
        assert_eq!(read_capped(&b"\xEF\xBB\xBF"[..], 3).unwrap(), "");
    }

    /// `f()` on another thread, failed if it has not answered within 20 s
    /// (a reader that blocks fails the test instead of hanging it).
    #[cfg(unix)]
    pub(crate) fn within_time<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(f());
        });
        rx.recv_timeout(std::time::Duration::from_secs(20))
            .expect("the reader blocked")
    }

    #[cfg(unix)]
    fn kind_of(e: &std::io::Error) -> Option<FileKind> {
        e.get_ref()
            .and_then(|e| e.downcast_ref::<NotRegularFile>())
            .map(|n| n.kind)
    }

    #[cfg(unix)]
    #[test]
    fn only_regular_files_are_opened_and_a_fifo_never_blocks() {
        let dir = std::env::temp_dir().join(format!("hookean-text-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("fifo.mtx");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        let file = dir.join("a.txt");
        std::fs::write(&file, b"\xEF\xBB\xBFa\nb\n").unwrap();
        let link = dir.join("link.txt");
        std::os::unix::fs::symlink(&fifo, &link).unwrap();
        for (path, kind) in [
            (fifo.clone(), FileKind::Fifo),
            (link.clone(), FileKind::Fifo),
            (dir.clone(), FileKind::Folder),
            ("/dev/null".into(), FileKind::CharDevice),
        ] {
            let p = path.clone();
            let e = within_time(move || open_regular(&p).map(|_| ())).unwrap_err();
            assert_eq!(kind_of(&e), Some(kind), "{}: {e}", path.display());
            assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
            let p = path.clone();
            let e = within_time(move || read_file(&p, 100)).unwrap_err();
            assert!(e.to_string().starts_with(&format!("it is {kind}")), "{e}");
            let p = path.clone();
            assert!(
                within_time(move || file_lines(&p, LineLimits::default()).map(|_| ())).is_err()
            );
        }
        // A missing file is the system's error; a regular file reads (its mark skipped).
        let e = open_regular(dir.join("none")).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::NotFound);
        assert_eq!(read_file(&file, 100).unwrap(), "a\nb\n");
        let lines: Vec<String> = file_lines(&file, LineLimits::default())
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(lines, ["a", "b"]);
        // The regular file is opened blocking again (the flag was cleared).
        let f = open_regular(&file).unwrap();
        assert!(
            !rustix::fs::fcntl_getfl(&f)
                .unwrap()
                .contains(rustix::fs::OFlags::NONBLOCK)
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
