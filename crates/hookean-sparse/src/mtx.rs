//! Matrix Market I/O: `coordinate real general|symmetric` and `array real
//! general|symmetric`, read and written. Malformed input is a
//! [`SparseError::Parse`] that names the file and the 1-based line.
//!
//! The reader trusts no number of the size line before checking it: an
//! entry count cannot exceed what a matrix of that shape can list (`m n`
//! entries, or `n (n + 1) / 2` for a symmetric file), sizes are multiplied
//! with overflow checks, storage grows with the entries actually read, and
//! a file whose matrix would need more memory than [`ReadOptions::max_bytes`]
//! is refused before anything that large is allocated.

// A parser of user files: no panic on any input (tests/fuzz_mtx.rs).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

use crate::NonExhaustive;
use std::io::{BufRead, Write};

use crate::error::SparseError;

/// The contents of a Matrix Market file.
#[derive(Debug, Clone, PartialEq)]
pub enum MatrixMarket {
    /// A `coordinate` file, as CSR (symmetric files are expanded to both triangles).
    Sparse(sprs::CsMat<f64>),
    /// An `array` file: `rows x cols` values in column-major order
    /// (symmetric files are expanded).
    Dense {
        /// Number of rows.
        rows: usize,
        /// Number of columns.
        cols: usize,
        /// Column-major values.
        values: Vec<f64>,
    },
}

impl MatrixMarket {
    /// `(rows, cols)`.
    pub fn shape(&self) -> (usize, usize) {
        match self {
            MatrixMarket::Sparse(m) => m.shape(),
            MatrixMarket::Dense { rows, cols, .. } => (*rows, *cols),
        }
    }

    /// The contents as a sparse CSR matrix (dense arrays keep their zeros out).
    pub fn into_csr(self) -> sprs::CsMat<f64> {
        match self {
            MatrixMarket::Sparse(m) => m,
            MatrixMarket::Dense { rows, cols, values } => {
                let mut t = sprs::TriMat::new((rows, cols));
                for c in 0..cols {
                    for r in 0..rows {
                        let v = values[c * rows + r];
                        if v != 0.0 {
                            t.add_triplet(r, c, v);
                        }
                    }
                }
                t.to_csr()
            }
        }
    }

    /// The contents as a vector, if the file holds a single column (or row).
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if it has more than one column and row.
    pub fn into_vector(self) -> Result<Vec<f64>, SparseError> {
        let (rows, cols) = self.shape();
        if rows != 1 && cols != 1 {
            return Err(SparseError::InvalidParameter {
                name: "vector file",
                message: format!("expected a single column, found a {rows} x {cols} matrix"),
            });
        }
        Ok(match self {
            MatrixMarket::Dense { values, .. } => values,
            MatrixMarket::Sparse(m) => {
                let mut v = vec![0.0; rows.max(cols)];
                for (&x, (r, c)) in m.iter() {
                    v[r.max(c)] = x;
                }
                v
            }
        })
    }
}

#[derive(PartialEq)]
enum Format {
    Coordinate,
    Array,
}

fn parse_err(line: usize, message: impl Into<String>) -> SparseError {
    SparseError::Parse {
        path: "<input>".into(),
        line,
        message: message.into(),
    }
}

/// What the Matrix Market reader may allocate.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadOptions {
    /// Largest memory the matrix may need once read (CSR arrays with their
    /// triplet staging, or the dense values), in bytes, and the largest
    /// file. Default 4 GiB.
    pub max_bytes: u64,
    /// Longest line, in bytes (a file without line breaks stops here).
    /// Default 1 MiB.
    pub max_line_bytes: usize,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            max_bytes: 4 << 30,
            max_line_bytes: 1 << 20,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// Bytes per stored entry of a coordinate file while reading: the triplet
/// (two indices and a value) and the CSR copy (an index and a value).
const BYTES_PER_ENTRY: u64 = 40;

/// Refuses a matrix that would need more than `opts.max_bytes`.
fn check_memory(line: usize, bytes: Option<u64>, opts: &ReadOptions) -> Result<(), SparseError> {
    match bytes {
        Some(b) if b <= opts.max_bytes => Ok(()),
        Some(b) => Err(parse_err(
            line,
            format!(
                "the matrix would need about {:.1} GiB, more than the {:.1} GiB allowed \
                 (ReadOptions::max_bytes)",
                b as f64 / (1u64 << 30) as f64,
                opts.max_bytes as f64 / (1u64 << 30) as f64
            ),
        )),
        None => Err(parse_err(
            line,
            "the sizes overflow 64-bit arithmetic: not a matrix this machine can hold",
        )),
    }
}

/// Reads a Matrix Market file from any buffered reader, with the default
/// [`ReadOptions`].
///
/// # Errors
/// As [`read_matrix_market_with`].
pub fn read_matrix_market(reader: impl BufRead) -> Result<MatrixMarket, SparseError> {
    read_matrix_market_with(reader, &ReadOptions::default())
}

/// Reads a Matrix Market file from any buffered reader.
///
/// # Errors
/// [`SparseError::Parse`] naming the line for a bad banner, an unsupported
/// field or symmetry (`complex`, `pattern`, `skew-symmetric`, `hermitian`),
/// a bad size line, an entry count larger than the shape can hold, a matrix
/// larger than `opts.max_bytes`, an entry that is not a number or not
/// finite, an index out of range, an entry above the diagonal of a
/// `symmetric` file (the format lists the lower triangle only), too few or
/// too many entries; [`SparseError::Io`] if reading fails.
pub fn read_matrix_market_with(
    reader: impl BufRead,
    opts: &ReadOptions,
) -> Result<MatrixMarket, SparseError> {
    let limits = hookean_io::LineLimits {
        max_line_bytes: opts.max_line_bytes,
        max_total_bytes: opts.max_bytes,
    };
    let mut lines = hookean_io::capped_lines(reader, limits)
        .enumerate()
        .map(|(i, l)| {
            l.map(|s| (i + 1, s)).map_err(|e| match e {
                hookean_io::TextError::Io(e) => SparseError::Io {
                    path: "<input>".into(),
                    message: e.to_string(),
                },
                e => parse_err(i + 1, format!("{e} (ReadOptions)")),
            })
        });
    let (_, banner) = lines
        .next()
        .transpose()?
        .ok_or_else(|| parse_err(1, "empty file: expected a %%MatrixMarket banner"))?;
    let words: Vec<String> = banner
        .split_whitespace()
        .map(|w| w.to_ascii_lowercase())
        .collect();
    if words.len() != 5 || words[0] != "%%matrixmarket" || words[1] != "matrix" {
        return Err(parse_err(
            1,
            format!(
                "expected '%%MatrixMarket matrix <format> <field> <symmetry>', found '{banner}'"
            ),
        ));
    }
    let format = match words[2].as_str() {
        "coordinate" => Format::Coordinate,
        "array" => Format::Array,
        other => return Err(parse_err(1, format!("unsupported format '{other}'"))),
    };
    match words[3].as_str() {
        "real" | "integer" | "double" => {}
        other => {
            return Err(parse_err(
                1,
                format!("unsupported field '{other}' (only real and integer are supported)"),
            ));
        }
    }
    let symmetric = match words[4].as_str() {
        "general" => false,
        "symmetric" => true,
        other => {
            return Err(parse_err(
                1,
                format!("unsupported symmetry '{other}' (only general and symmetric)"),
            ));
        }
    };
    // Data lines: skip comments and blank lines.
    let mut data = lines.filter(|r| match r {
        Ok((_, s)) => {
            let t = s.trim();
            !t.is_empty() && !t.starts_with('%')
        }
        Err(_) => true,
    });
    let (size_line, size) = data
        .next()
        .transpose()?
        .ok_or_else(|| parse_err(2, "missing size line"))?;
    let dims: Vec<&str> = size.split_whitespace().collect();
    let expected_words = if format == Format::Coordinate { 3 } else { 2 };
    if dims.len() != expected_words {
        return Err(parse_err(
            size_line,
            format!(
                "size line must have {expected_words} integers, found '{}'",
                size.trim()
            ),
        ));
    }
    let mut nums = [0usize; 3];
    for (k, w) in dims.iter().enumerate() {
        nums[k] = w
            .parse()
            .map_err(|_| parse_err(size_line, format!("'{w}' is not a non-negative integer")))?;
    }
    let (rows, cols) = (nums[0], nums[1]);
    if symmetric && rows != cols {
        return Err(parse_err(
            size_line,
            format!("a symmetric matrix must be square, found {rows} x {cols}"),
        ));
    }
    let parse_value = |line: usize, w: &str| -> Result<f64, SparseError> {
        let v: f64 = w
            .parse()
            .map_err(|_| parse_err(line, format!("'{w}' is not a number")))?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(parse_err(line, format!("value '{w}' is not finite")))
        }
    };
    match format {
        Format::Coordinate => {
            let nnz = nums[2];
            let (r64, c64, nnz64) = (rows as u64, cols as u64, nnz as u64);
            let listable = if symmetric {
                r64.checked_mul(r64 + 1).map(|x| x / 2)
            } else {
                r64.checked_mul(c64)
            };
            if listable.is_some_and(|most| nnz64 > most) {
                return Err(parse_err(
                    size_line,
                    format!(
                        "{nnz} entries declared, but a {}{rows} x {cols} matrix has at most {} to list",
                        if symmetric { "symmetric " } else { "" },
                        listable.unwrap_or(0)
                    ),
                ));
            }
            let stored = if symmetric {
                nnz64.checked_mul(2)
            } else {
                Some(nnz64)
            };
            let bytes = stored
                .and_then(|e| e.checked_mul(BYTES_PER_ENTRY))
                .and_then(|e| e.checked_add(r64.checked_add(1)?.checked_mul(8)?));
            check_memory(size_line, bytes, opts)?;
            // Storage grows with the entries actually read (a file may lie
            // about its count until it ends).
            let mut t = sprs::TriMat::with_capacity((rows, cols), nnz.min(1 << 16));
            let mut last_line = size_line;
            for k in 0..nnz {
                let (line, s) = data.next().transpose()?.ok_or_else(|| {
                    parse_err(
                        last_line + 1,
                        format!("expected {nnz} entries, file ends after {k}"),
                    )
                })?;
                last_line = line;
                let w: Vec<&str> = s.split_whitespace().collect();
                if w.len() != 3 {
                    return Err(parse_err(
                        line,
                        format!("expected 'row col value', found '{}'", s.trim()),
                    ));
                }
                let idx = |x: &str, bound: usize, what: &str| -> Result<usize, SparseError> {
                    let i: usize = x.parse().map_err(|_| {
                        parse_err(line, format!("{what} index '{x}' is not an integer"))
                    })?;
                    if i == 0 || i > bound {
                        Err(parse_err(
                            line,
                            format!("{what} index {i} out of range 1..={bound}"),
                        ))
                    } else {
                        Ok(i - 1)
                    }
                };
                let r = idx(w[0], rows, "row")?;
                let c = idx(w[1], cols, "column")?;
                if symmetric && r < c {
                    return Err(parse_err(
                        line,
                        format!(
                            "entry ({}, {}) lies above the diagonal: a symmetric file lists the lower triangle only",
                            r + 1,
                            c + 1
                        ),
                    ));
                }
                let v = parse_value(line, w[2])?;
                t.add_triplet(r, c, v);
                if symmetric && r != c {
                    t.add_triplet(c, r, v);
                }
            }
            if let Some((line, s)) = data.next().transpose()? {
                return Err(parse_err(
                    line,
                    format!("more entries than the {nnz} declared: '{}'", s.trim()),
                ));
            }
            Ok(MatrixMarket::Sparse(t.to_csr()))
        }
        Format::Array => {
            let (r64, c64) = (rows as u64, cols as u64);
            let count = r64.checked_mul(c64);
            check_memory(size_line, count.and_then(|c| c.checked_mul(8)), opts)?;
            let mut values = vec![0.0; rows * cols];
            // The values in file order: column by column, from the diagonal
            // down for a symmetric file.
            let total = if symmetric {
                rows * (rows + 1) / 2
            } else {
                rows * cols
            };
            let (mut r, mut c) = (0, 0);
            let mut k = 0;
            let mut last_line = size_line;
            while k < total {
                let (line, s) = data.next().transpose()?.ok_or_else(|| {
                    parse_err(
                        last_line + 1,
                        format!("expected {total} values, file ends after {k}"),
                    )
                })?;
                last_line = line;
                for w in s.split_whitespace() {
                    if k == total {
                        return Err(parse_err(
                            line,
                            format!("more than the {total} values declared"),
                        ));
                    }
                    let v = parse_value(line, w)?;
                    values[c * rows + r] = v;
                    if symmetric {
                        values[r * rows + c] = v;
                    }
                    k += 1;
                    r += 1;
                    if r == rows {
                        c += 1;
                        r = if symmetric { c } else { 0 };
                    }
                }
            }
            if let Some((line, _)) = data.next().transpose()? {
                return Err(parse_err(
                    line,
                    format!("more than the {total} values declared"),
                ));
            }
            Ok(MatrixMarket::Dense { rows, cols, values })
        }
    }
}

/// Reads a Matrix Market file from a path; errors name the path and line.
///
/// # Errors
/// [`SparseError::Io`] if the file cannot be read; [`SparseError::Parse`]
/// (with the path prefixed to the message) if it is malformed.
pub fn read_matrix_market_file(
    path: impl AsRef<std::path::Path>,
) -> Result<MatrixMarket, SparseError> {
    read_matrix_market_file_with(path, &ReadOptions::default())
}

/// [`read_matrix_market_file`] with [`ReadOptions`].
///
/// # Errors
/// As [`read_matrix_market_file`].
pub fn read_matrix_market_file_with(
    path: impl AsRef<std::path::Path>,
    opts: &ReadOptions,
) -> Result<MatrixMarket, SparseError> {
    let path = path.as_ref();
    let file = hookean_io::open_regular(path).map_err(|e| SparseError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    read_matrix_market_with(std::io::BufReader::new(file), opts).map_err(|e| match e {
        SparseError::Parse { line, message, .. } => SparseError::Parse {
            path: path.display().to_string(),
            line,
            message,
        },
        SparseError::Io { message, .. } => SparseError::Io {
            path: path.display().to_string(),
            message,
        },
        other => other,
    })
}

fn io_err(e: std::io::Error) -> SparseError {
    SparseError::Io {
        path: "<output>".into(),
        message: e.to_string(),
    }
}

/// Writes a sparse matrix as `coordinate real general`, or as
/// `coordinate real symmetric` (lower triangle only) when `symmetric` is set.
/// Values are written with 17 significant digits, so they read back bit-exact.
///
/// # Errors
/// [`SparseError::Io`] if writing fails; [`SparseError::NotSquare`] if
/// `symmetric` is set for a non-square matrix.
pub fn write_matrix_market(
    mut w: impl Write,
    a: &sprs::CsMat<f64>,
    symmetric: bool,
) -> Result<(), SparseError> {
    let (rows, cols) = a.shape();
    if symmetric && rows != cols {
        return Err(SparseError::NotSquare { rows, cols });
    }
    let entries: Vec<(usize, usize, f64)> = a
        .iter()
        .map(|(&v, (r, c))| (r, c, v))
        .filter(|&(r, c, _)| !symmetric || r >= c)
        .collect();
    let kind = if symmetric { "symmetric" } else { "general" };
    writeln!(w, "%%MatrixMarket matrix coordinate real {kind}").map_err(io_err)?;
    writeln!(w, "% written by hookean-sparse").map_err(io_err)?;
    writeln!(w, "{rows} {cols} {}", entries.len()).map_err(io_err)?;
    for (r, c, v) in entries {
        writeln!(w, "{} {} {:.16e}", r + 1, c + 1, v).map_err(io_err)?;
    }
    Ok(())
}

/// Writes a vector as an `array real general` column.
///
/// # Errors
/// [`SparseError::Io`] if writing fails.
pub fn write_vector_market(mut w: impl Write, v: &[f64]) -> Result<(), SparseError> {
    writeln!(w, "%%MatrixMarket matrix array real general").map_err(io_err)?;
    writeln!(w, "{} 1", v.len()).map_err(io_err)?;
    for x in v {
        writeln!(w, "{x:.16e}").map_err(io_err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(s: &str) -> Result<MatrixMarket, SparseError> {
        read_matrix_market(s.as_bytes())
    }

    fn line_of(e: SparseError) -> usize {
        match e {
            SparseError::Parse { line, .. } => line,
            other => panic!("expected a parse error, got {other:?}"),
        }
    }

    #[test]
    fn symmetric_coordinate_is_expanded() {
        let m = read(
            "%%MatrixMarket matrix coordinate real symmetric\n% comment\n3 3 4\n1 1 2.0\n2 1 -1\n2 2 2\n3 3 1e1\n",
        )
        .unwrap()
        .into_csr();
        assert_eq!(m.nnz(), 5);
        assert_eq!(m.get(0, 1), Some(&-1.0));
        assert_eq!(m.get(1, 0), Some(&-1.0));
        assert_eq!(m.get(2, 2), Some(&10.0));
    }

    #[test]
    fn array_general_and_symmetric() {
        let m = read("%%MatrixMarket matrix array real general\n2 2\n1\n2\n3 4\n").unwrap();
        assert_eq!(
            m,
            MatrixMarket::Dense {
                rows: 2,
                cols: 2,
                values: vec![1.0, 2.0, 3.0, 4.0]
            }
        );
        let s = read("%%MatrixMarket matrix array real symmetric\n2 2\n1\n2\n3\n").unwrap();
        assert_eq!(
            s,
            MatrixMarket::Dense {
                rows: 2,
                cols: 2,
                values: vec![1.0, 2.0, 2.0, 3.0]
            }
        );
        let v = read("%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n")
            .unwrap()
            .into_vector()
            .unwrap();
        assert_eq!(v, vec![1.0, 2.0, 3.0]);
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let mut t = sprs::TriMat::new((3, 3));
        t.add_triplet(0, 0, std::f64::consts::PI);
        t.add_triplet(2, 1, -1.0 / 3.0);
        t.add_triplet(1, 2, -1.0 / 3.0);
        t.add_triplet(1, 1, 1e-300);
        let a: sprs::CsMat<f64> = t.to_csr();
        for symmetric in [false, true] {
            let mut buf = Vec::new();
            write_matrix_market(&mut buf, &a, symmetric).unwrap();
            let back = read_matrix_market(buf.as_slice()).unwrap().into_csr();
            assert_eq!(back, a);
        }
        let v = vec![0.1, -2.5e10, 7.0];
        let mut buf = Vec::new();
        write_vector_market(&mut buf, &v).unwrap();
        assert_eq!(
            read_matrix_market(buf.as_slice())
                .unwrap()
                .into_vector()
                .unwrap(),
            v
        );
    }

    #[test]
    fn malformed_files_name_their_line() {
        let cases: &[(&str, usize)] = &[
            ("", 1),
            ("%%MatrixMarket tensor coordinate real general\n", 1),
            ("%%MatrixMarket matrix coordinate complex general\n", 1),
            ("%%MatrixMarket matrix coordinate pattern general\n", 1),
            ("%%MatrixMarket matrix coordinate real hermitian\n", 1),
            ("%%MatrixMarket matrix coordinate real general\n", 2),
            ("%%MatrixMarket matrix coordinate real general\n2 2\n", 2),
            ("%%MatrixMarket matrix coordinate real general\n2 x 1\n", 2),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 1\n1 3 1.0\n",
                3,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 1\n0 1 1.0\n",
                3,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n% c\n2 2 abc\n",
                5,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n",
                4,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 1\n1 1 1.0\n2 2 1.0\n",
                4,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 1\n1 1 nan\n",
                3,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n2 2 1\n1 1\n",
                3,
            ),
            (
                "%%MatrixMarket matrix coordinate real symmetric\n2 3 1\n1 1 1\n",
                2,
            ),
            ("%%MatrixMarket matrix array real general\n2 1\n1\n", 4),
            ("%%MatrixMarket matrix array real general\n2 1\n1 2 3\n", 3),
            // Sizes that no file could back: refused on the size line, before
            // anything that large is allocated.
            (
                "%%MatrixMarket matrix coordinate real general\n1000000000000 1000000000000 3\n",
                2,
            ),
            (
                "%%MatrixMarket matrix coordinate real general\n10 10 10000000000000000000\n",
                2,
            ),
            (
                "%%MatrixMarket matrix coordinate real symmetric\n3 3 7\n",
                2,
            ),
            (
                "%%MatrixMarket matrix array real general\n4294967296 4294967296\n",
                2,
            ),
            (
                "%%MatrixMarket matrix array real general\n100000 100000\n",
                2,
            ),
            // A symmetric file lists one triangle: an entry above the
            // diagonal would be counted twice.
            (
                "%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 4\n1 2 -1\n",
                4,
            ),
        ];
        for (text, line) in cases {
            let got = line_of(read(text).unwrap_err());
            assert_eq!(got, *line, "for {text:?}");
        }
    }

    #[test]
    fn sizes_are_checked_against_the_entries_and_the_memory_cap() {
        // 6 entries is the most a symmetric 3 x 3 file can list.
        let ok = "%%MatrixMarket matrix coordinate real symmetric\n3 3 6\n1 1 1\n2 1 1\n2 2 1\n3 1 1\n3 2 1\n3 3 1\n";
        assert_eq!(read(ok).unwrap().into_csr().nnz(), 9);
        // A 100 x 100 array needs 80 000 bytes: refused under a 64 KiB cap,
        // read under 128 KiB.
        let mut text = String::from("%%MatrixMarket matrix array real general\n100 100\n");
        for _ in 0..10_000 {
            text.push_str("1\n");
        }
        let small = ReadOptions {
            max_bytes: 64 << 10,
            ..Default::default()
        };
        let err = read_matrix_market_with(text.as_bytes(), &small).unwrap_err();
        assert!(err.to_string().contains("max_bytes"), "{err}");
        let enough = ReadOptions {
            max_bytes: 128 << 10,
            ..Default::default()
        };
        assert_eq!(
            read_matrix_market_with(text.as_bytes(), &enough)
                .unwrap()
                .shape(),
            (100, 100)
        );
    }

    #[test]
    fn parse_errors_read_file_colon_line() {
        let dir = std::env::temp_dir().join(format!("hookean-mtx-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.mtx");
        std::fs::write(
            &path,
            "%%MatrixMarket matrix coordinate real general\n2 2 1\n1 3 1.0\n",
        )
        .unwrap();
        let err = read_matrix_market_file(&path).unwrap_err().to_string();
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(err.starts_with(&format!("{}:3: ", path.display())), "{err}");
    }

    #[test]
    fn matrix_is_not_a_vector() {
        let m = read("%%MatrixMarket matrix array real general\n2 2\n1\n2\n3\n4\n").unwrap();
        assert!(matches!(
            m.into_vector(),
            Err(SparseError::InvalidParameter { .. })
        ));
    }

    /// A file without line breaks (`/dev/zero`) or with one absurd line is
    /// refused at the line cap, naming the line, before it fills memory.
    #[test]
    fn lines_are_capped() {
        let endless = std::io::BufReader::new(std::io::repeat(0));
        let err = read_matrix_market(endless).unwrap_err();
        assert!(matches!(err, SparseError::Parse { line: 1, .. }), "{err}");
        assert!(err.to_string().contains("longer than"), "{err}");
        let mut text = String::from("%%MatrixMarket matrix coordinate real general\n%");
        text.push_str(&"x".repeat(100));
        text.push_str("\n1 1 1\n1 1 2\n");
        let short = ReadOptions {
            max_line_bytes: 64,
            ..Default::default()
        };
        let err = read_matrix_market_with(text.as_bytes(), &short).unwrap_err();
        assert!(matches!(err, SparseError::Parse { line: 2, .. }), "{err}");
        assert!(read_matrix_market(text.as_bytes()).is_ok());
    }
}
