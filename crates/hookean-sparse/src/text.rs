//! Line-oriented text input with a cap on the bytes of one line and of the
//! whole input: the one reader under every text format of the workspace
//! (Matrix Market here, OBJ in `hookean-massspring`, scene files in the
//! facade), so that a file without line breaks (`/dev/zero`) or of absurd
//! size is an error naming the line, never an allocation that aborts.
//!
//! ```
//! use hookean_sparse::text::{LineLimits, capped_lines};
//! let lines: Vec<String> = capped_lines(&b"a\nbb\n"[..], LineLimits::default())
//!     .collect::<Result<_, _>>()
//!     .unwrap();
//! assert_eq!(lines, ["a", "bb"]);
//! let long = capped_lines(&b"0123456789\n"[..], LineLimits { max_line_bytes: 4, ..Default::default() })
//!     .next()
//!     .unwrap();
//! assert!(long.unwrap_err().to_string().contains("line 1"));
//! ```

use std::io::{BufRead, Read};

/// Caps of [`capped_lines`] and [`read_capped`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineLimits {
    /// Bytes of one line, without its line break. Default 1 MiB.
    pub max_line_bytes: usize,
    /// Bytes of the whole input. Default 4 GiB.
    pub max_total_bytes: u64,
    /// Not an option: it makes adding options a non-breaking change.
    /// Construct with `..Default::default()`.
    #[doc(hidden)]
    pub __non_exhaustive: (),
}

impl Default for LineLimits {
    fn default() -> Self {
        Self {
            max_line_bytes: 1 << 20,
            max_total_bytes: 4 << 30,
            __non_exhaustive: (),
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

/// The lines of `reader` (without `\n` or `\r\n`), each at most
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

/// The whole of `reader` as text, at most `max_bytes` bytes.
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
            ..Default::default()
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
}
