//! Issue 37: the Matrix Market reader opens only regular files: a FIFO
//! (which blocked it for ever), a folder or a device is an error saying
//! what it is; a byte-order mark is skipped.
#![cfg(unix)]

use hookean_sparse::{MatrixMarket, read_matrix_market_file};
use hookean_testkit::special::{special_files, within_time};

#[test]
fn a_fifo_a_folder_or_a_device_is_refused_without_blocking() {
    let dir = special_files("mtx", "a.mtx");
    for (name, kind) in [
        ("a.mtx", "a FIFO (named pipe)"),
        ("folder", "a folder"),
        ("null", "a character device"),
    ] {
        let path = dir.join(name);
        let e = within_time(move || read_matrix_market_file(path).map(|_| ())).unwrap_err();
        let m = e.to_string();
        assert!(
            m.contains(name) && m.contains(&format!("it is {kind}, not a regular file")),
            "{m}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_byte_order_mark_does_not_hide_the_header() {
    let dir = std::env::temp_dir().join(format!("hookean-bom-mtx-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("a.mtx");
    std::fs::write(
        &p,
        "\u{feff}%%MatrixMarket matrix array real general\n2 1\n3\n4\n",
    )
    .unwrap();
    match read_matrix_market_file(&p).unwrap() {
        MatrixMarket::Dense { rows, cols, values } => {
            assert_eq!((rows, cols, values), (2, 1, vec![3.0, 4.0]));
        }
        other => panic!("{other:?}"),
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
