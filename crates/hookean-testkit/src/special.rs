//! Special files for the readers' tests (docs/RELIABILITY.md, issue 37):
//! a FIFO, a folder and a link to a device, and a time limit so that a
//! reader that blocks fails its test instead of hanging it.

use std::path::PathBuf;
use std::time::Duration;

/// `f()` on another thread, failed (a panic) if it has not answered within
/// 20 s.
pub fn within_time<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(Duration::from_secs(20))
        .expect("the reader blocked")
}

/// A fresh folder (named after `tag` and the process) holding a FIFO
/// `fifo`, a folder `folder` and a link `null` to /dev/null.
pub fn special_files(tag: &str, fifo: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-special-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("folder")).unwrap();
    make_fifo(&dir.join(fifo));
    std::os::unix::fs::symlink("/dev/null", dir.join("null")).unwrap();
    dir
}

/// A FIFO at `path` (by `mkfifo`).
pub fn make_fifo(path: &std::path::Path) {
    let ok = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .unwrap()
        .success();
    assert!(ok, "mkfifo {}", path.display());
}
