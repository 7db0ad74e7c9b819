//! The Matrix Market reader on mutated valid files (bit flips, truncation,
//! odd numbers, duplicated and reordered lines; `hookean_testkit::fuzz`):
//! it returns a matrix or a typed error, never panics, never allocates
//! past its cap. A million cases: docs/RELIABILITY.md.

use hookean_sparse::{ReadOptions, SparseError, read_matrix_market_with};
use hookean_testkit::fuzz::mutate;
use proptest::prelude::*;

/// Valid files of every supported kind.
pub const VALID: &[&str] = &[
    "%%MatrixMarket matrix coordinate real symmetric\n% a comment\n3 3 5\n1 1 4\n2 1 1\n2 2 3\n3 2 -1\n3 3 2\n",
    "%%MatrixMarket matrix coordinate real general\n2 3 3\n1 1 1.5\n2 3 -2e-3\n1 2 7\n",
    "%%MatrixMarket matrix coordinate integer general\n2 2 2\n1 1 3\n2 2 4\n",
    "%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n",
    "%%MatrixMarket matrix array real symmetric\n2 2\n4\n1\n3\n",
];

/// A cap small enough that any matrix the mutations declare big is refused.
fn opts() -> ReadOptions {
    ReadOptions {
        max_bytes: 1 << 20,
        max_line_bytes: 1 << 16,
        ..Default::default()
    }
}

fn read(bytes: &[u8]) -> Result<(), SparseError> {
    let m = read_matrix_market_with(bytes, &opts())?;
    // What was read converts without a panic.
    let (rows, cols) = m.shape();
    let csr = m.into_csr();
    assert_eq!(csr.shape(), (rows, cols));
    assert!(csr.data().iter().all(|v| v.is_finite()));
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_files_give_a_matrix_or_a_typed_error(file in 0..VALID.len(), seed in any::<u64>()) {
        let bytes = mutate(VALID[file].as_bytes(), seed);
        match read(&bytes) {
            Ok(()) => {}
            // Parse errors name a line of the file.
            Err(SparseError::Parse { line, .. }) => {
                let lines = bytes.split(|&b| b == b'\n').count();
                prop_assert!(line >= 1 && line <= lines + 1, "line {} of {}", line, lines);
            }
            Err(SparseError::Io { .. }) => {} // not UTF-8
            Err(e) => prop_assert!(false, "unexpected error kind: {e}"),
        }
    }
}

#[test]
fn the_valid_files_read() {
    for f in VALID {
        read(f.as_bytes()).unwrap();
    }
}
