//! Issue 37: the Matrix Market reader opens only regular files: a FIFO
//! (which blocked it for ever), a folder or a device is an error saying
//! what it is; a byte-order mark is skipped.
#![cfg(unix)]

use hookean_sparse::{MatrixMarket, read_matrix_market_file};

/// `f()` on another thread, failed if it has not answered within 20 s: a
/// reader that blocks fails the test instead of hanging it.
fn within_time<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(std::time::Duration::from_secs(20))
        .expect("the reader blocked")
}

/// A fresh folder holding a FIFO `name`, a folder `folder` and a link
/// `null` to /dev/null.
fn special_files(tag: &str, name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-special-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("folder")).unwrap();
    let ok = std::process::Command::new("mkfifo")
        .arg(dir.join(name))
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo");
    std::os::unix::fs::symlink("/dev/null", dir.join("null")).unwrap();
    dir
}

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
