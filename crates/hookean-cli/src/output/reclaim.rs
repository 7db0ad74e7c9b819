//! Staging folders of dead commands: each staging folder is locked by its
//! process while it lives, and one that a killed command left behind is
//! removed by the next command that writes beside it (docs/RELIABILITY.md).

use std::fs::File;
use std::path::Path;

/// Locks the fresh staging folder `dir` for the life of the process (the
/// lock goes with the returned file, and with the process on SIGKILL).
/// `None` where the folder cannot be opened or locked: it is then never
/// reclaimed while its process lives ([`reclaim_dead_staging`] also asks
/// whether the process is alive).
pub(super) fn lock_staging(dir: &Path) -> Option<File> {
    #[cfg(unix)]
    {
        use rustix::fs::{FlockOperation, flock};
        let f = File::open(dir).ok()?;
        flock(&f, FlockOperation::NonBlockingLockExclusive).ok()?;
        Some(f)
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

/// The target name and process of a staging folder's name
/// `.NAME.hookean-partial-PID-K`.
fn staging_owner(name: &str) -> Option<(&str, u32)> {
    let rest = name.strip_prefix('.')?;
    let (target, tail) = rest.rsplit_once(".hookean-partial-")?;
    let (pid, k) = tail.split_once('-')?;
    k.parse::<u32>().ok()?;
    Some((target, pid.parse().ok()?))
}

/// Removes the staging folders in `parent` that killed runs left behind
/// (SIGKILL, a crash, a power cut): a folder is reclaimed only if its
/// process no longer exists and no process holds its lock
/// ([`lock_staging`]), so a live run's folder (in this PID namespace or
/// another) is never touched. Says what it removed, naming the target the
/// dead run wrote for (never the hidden folder).
pub(super) fn reclaim_dead_staging(parent: &Path) {
    #[cfg(unix)]
    {
        use rustix::fs::{FlockOperation, flock};
        let Ok(entries) = std::fs::read_dir(parent) else {
            return;
        };
        for entry in entries.filter_map(Result::ok) {
            let name = entry.file_name();
            let Some((target, pid)) = name.to_str().and_then(staging_owner) else {
                continue;
            };
            let alive = pid == std::process::id()
                || rustix::process::Pid::from_raw(pid as i32).is_none_or(|p| {
                    !matches!(
                        rustix::process::test_kill_process(p),
                        Err(rustix::io::Errno::SRCH)
                    )
                });
            let dir = entry.path();
            let is_dir = std::fs::symlink_metadata(&dir).is_ok_and(|m| m.is_dir());
            if alive || !is_dir {
                continue;
            }
            let Ok(lock) = File::open(&dir) else { continue };
            if flock(&lock, FlockOperation::NonBlockingLockExclusive).is_err() {
                continue;
            }
            let bytes = folder_bytes(&dir);
            if std::fs::remove_dir_all(&dir).is_ok() {
                crate::errln!(
                    "hookean: removed the unfinished output ({:.1} MB) that a killed earlier command \
                     left beside {}",
                    bytes as f64 / 1e6,
                    parent.join(target).display()
                );
            }
        }
    }
    #[cfg(not(unix))]
    let _ = parent;
}

/// The bytes of the regular files under `dir` (links not followed).
fn folder_bytes(dir: &Path) -> u64 {
    let mut total = 0;
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            match entry.metadata() {
                Ok(m) if m.is_dir() => stack.push(entry.path()),
                Ok(m) if m.is_file() => total += m.len(),
                _ => {}
            }
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staging_folders_of_dead_processes_are_reclaimed_and_live_ones_kept() {
        let d = std::env::temp_dir().join(format!("hookean-reclaim-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let dead = {
            let mut child = std::process::Command::new("true").spawn().unwrap();
            let pid = child.id();
            child.wait().unwrap();
            pid
        };
        let mut live_child = std::process::Command::new("sleep")
            .arg("30")
            .spawn()
            .unwrap();
        let folder = |name: &str, pid: u32| {
            let p = d.join(format!(".{name}.hookean-partial-{pid}-0"));
            std::fs::create_dir_all(p.join("sub")).unwrap();
            std::fs::write(p.join("sub/frame-0000.obj"), vec![b'v'; 1000]).unwrap();
            p
        };
        let gone = folder("out", dead);
        let running = folder("b", live_child.id());
        let mine = folder("c", std::process::id());
        // Its process gone but its lock held (a run in another PID namespace).
        let locked = folder("e", dead + 1_000_000);
        let _lock = lock_staging(&locked).unwrap();
        let unlocked_dead = folder("f", dead + 1_000_001);
        // Names hookean does not make are never touched.
        let odd = d.join(".out.hookean-partial-x-0");
        std::fs::create_dir(&odd).unwrap();
        reclaim_dead_staging(&d);
        assert!(!gone.exists() && !unlocked_dead.exists());
        assert!(running.exists() && mine.exists() && locked.exists() && odd.exists());
        assert_eq!(
            staging_owner(".a.b.hookean-partial-12-3"),
            Some(("a.b", 12))
        );
        assert_eq!(staging_owner(".a.hookean-old-12-3"), None);
        live_child.kill().unwrap();
        live_child.wait().unwrap();
        std::fs::remove_dir_all(&d).unwrap();
    }
}
