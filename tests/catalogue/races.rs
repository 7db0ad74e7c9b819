//! Races of the catalogue (issue 28): concurrent runs into one folder, a
//! folder made or changed while a run goes, and signals. The run under test
//! is frozen with SIGSTOP once its staging folder exists, the race is set
//! up, and it is let go with SIGCONT, so the order of events does not
//! depend on the machine's speed.

use std::os::unix::process::ExitStatusExt as _;
use std::path::Path;
use std::process::{Child, Command, Output};
use std::time::{Duration, Instant};

use crate::{case_dir, expand, hookean, leftovers, snapshot};

/// A cloth that takes a while: long enough to be caught while it runs.
const SLOW: &str =
    "duration = 2.0\n[cloth]\nn = 10\n[output]\nframe_rate = 10.0\nwidth = 8\nheight = 8\n";
/// A quick cloth for earlier runs.
const QUICK: &str =
    "duration = 0.02\n[cloth]\nn = 4\n[output]\nframe_rate = 0.0\nwidth = 8\nheight = 8\n";

fn start(dir: &Path, args: &[&str]) -> Child {
    hookean(dir, &expand(args, dir)).spawn().unwrap()
}

fn run(dir: &Path, args: &[&str]) -> Output {
    hookean(dir, &expand(args, dir)).output().unwrap()
}

fn signal(child: &Child, name: &str) {
    let ok = Command::new("kill")
        .args([format!("-{name}"), child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{name}");
}

/// Waits until the run has made its staging folder, then freezes it.
fn catch_while_running(dir: &Path, child: &mut Child) {
    let t0 = Instant::now();
    while leftovers(dir).is_empty() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it could be caught"
        );
        assert!(t0.elapsed() < Duration::from_secs(60), "no staging folder");
        std::thread::sleep(Duration::from_millis(2));
    }
    signal(child, "STOP");
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn two_runs_into_one_new_folder_never_lose_a_result() {
    let dir = case_dir("race-two");
    std::fs::write(dir.join("s.toml"), SLOW).unwrap();
    let args = ["run", "{}/s.toml", "--out", "{}/out", "--quiet"];
    let mut first = start(&dir, &args);
    catch_while_running(&dir, &mut first);
    // The second run starts and finishes while the first is frozen.
    let second = run(&dir, &args);
    assert!(second.status.success(), "{}", stderr(&second));
    let result = snapshot(&dir.join("out"));
    signal(&first, "CONT");
    let first = first.wait_with_output().unwrap();
    assert_eq!(first.status.code(), Some(1), "{}", stderr(&first));
    assert!(stderr(&first).contains("appeared while this command ran"));
    assert!(
        !crate::names_hidden_entry(&stderr(&first)),
        "{}",
        stderr(&first)
    );
    // The second run's output is whole and untouched.
    assert_eq!(snapshot(&dir.join("out")), result);
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_folder_made_while_a_run_goes_is_left_alone() {
    let dir = case_dir("race-user");
    std::fs::write(dir.join("s.toml"), SLOW).unwrap();
    let mut child = start(&dir, &["run", "{}/s.toml", "--out", "{}/out", "--quiet"]);
    catch_while_running(&dir, &mut child);
    std::fs::create_dir(dir.join("out")).unwrap();
    std::fs::write(dir.join("out/mine.txt"), "mine").unwrap();
    signal(&child, "CONT");
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    let names: Vec<_> = std::fs::read_dir(dir.join("out")).unwrap().collect();
    assert_eq!(names.len(), 1);
    assert_eq!(
        std::fs::read_to_string(dir.join("out/mine.txt")).unwrap(),
        "mine"
    );
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_file_added_to_the_replaced_run_meanwhile_stops_the_replacement() {
    let dir = case_dir("race-force");
    std::fs::write(dir.join("s.toml"), SLOW).unwrap();
    std::fs::write(dir.join("q.toml"), QUICK).unwrap();
    assert!(
        run(&dir, &["run", "{}/q.toml", "--out", "{}/out"])
            .status
            .success()
    );
    let mut child = start(
        &dir,
        &["run", "{}/s.toml", "--out", "{}/out", "--force", "--quiet"],
    );
    catch_while_running(&dir, &mut child);
    std::fs::write(dir.join("out/mine.txt"), "mine").unwrap();
    let earlier = snapshot(&dir.join("out"));
    signal(&child, "CONT");
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("mine.txt"), "{}", stderr(&out));
    // The earlier run and the user's file, exactly as they were (the
    // snapshot's paths are under out/, so the folder was put back in place).
    assert_eq!(snapshot(&dir.join("out")), earlier);
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_signal_removes_the_staging_folder_and_keeps_the_earlier_run() {
    for (name, number) in [("INT", 2), ("TERM", 15), ("HUP", 1)] {
        let dir = case_dir(&format!("race-sig{name}"));
        std::fs::write(dir.join("s.toml"), SLOW).unwrap();
        std::fs::write(dir.join("q.toml"), QUICK).unwrap();
        // Into a new folder, and over an earlier run with --force.
        for earlier in [false, true] {
            let _ = std::fs::remove_dir_all(dir.join("out"));
            if earlier {
                assert!(
                    run(&dir, &["run", "{}/q.toml", "--out", "{}/out"])
                        .status
                        .success()
                );
            }
            let before = snapshot(&dir);
            let mut child = start(
                &dir,
                &["run", "{}/s.toml", "--out", "{}/out", "--force", "--quiet"],
            );
            catch_while_running(&dir, &mut child);
            signal(&child, name);
            signal(&child, "CONT");
            let out = child.wait_with_output().unwrap();
            assert_eq!(
                out.status.signal(),
                Some(number),
                "SIG{name}: {:?} {}",
                out.status,
                stderr(&out)
            );
            assert!(
                leftovers(&dir).is_empty(),
                "SIG{name}: {:?}",
                leftovers(&dir)
            );
            assert_eq!(snapshot(&dir), before, "SIG{name}, earlier run: {earlier}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

/// With stderr on a full disk (`2>/dev/full`) every report and error
/// message fails to write: the exit code stays what it would have been
/// (it was 101, a panic, for every command).
#[test]
fn stderr_on_a_full_disk_changes_no_exit_code() {
    let dir = case_dir("stderr-full");
    std::fs::write(dir.join("s.toml"), QUICK).unwrap();
    let cases: [(&[&str], i32); 5] = [
        (&["run", "{}/s.toml", "--out", "{}/out"], 0),
        (&["run", "{}/none.toml", "--out", "{}/out2"], 2),
        (&["solve", "{}/none.mtx"], 2),
        (&["--threads", "0", "scene-keys"], 2),
        (
            &[
                "run",
                "{}/s.toml",
                "--out",
                "{}/out3",
                "--set",
                "integrator.method=fb-euler",
                "--set",
                "integrator.h=0.05",
                "--set",
                "duration=5",
            ],
            1,
        ),
    ];
    for (args, code) in cases {
        let args = expand(args, &dir);
        let out = Command::new("sh")
            .arg("-c")
            .arg("exec \"$0\" \"$@\" 2>/dev/full")
            .arg(env!("CARGO_BIN_EXE_hookean-suite-cli"))
            .args(&args)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(code), "{args:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 37: a run killed with SIGKILL cannot clean up; the next command
/// writing beside its staging folder removes it (its process is gone and
/// its lock free) and says so, naming the target, never the hidden folder;
/// a frozen live run's staging folder is left alone and the run finishes.
#[test]
fn the_staging_folder_of_a_killed_run_is_reclaimed_and_a_live_ones_kept() {
    let dir = case_dir("race-kill");
    std::fs::write(dir.join("s.toml"), SLOW).unwrap();
    std::fs::write(dir.join("q.toml"), QUICK).unwrap();
    // A live run, frozen while the others run beside it.
    let mut live = start(&dir, &["run", "{}/s.toml", "--out", "{}/live", "--quiet"]);
    catch_while_running(&dir, &mut live);
    let mut killed = start(&dir, &["run", "{}/s.toml", "--out", "{}/out", "--quiet"]);
    catch_while_running_beside(&dir, &mut killed, 2);
    signal(&killed, "KILL");
    let status = killed.wait().unwrap();
    assert_eq!(status.signal(), Some(9));
    assert_eq!(leftovers(&dir).len(), 2, "{:?}", leftovers(&dir));
    let next = run(&dir, &["run", "{}/q.toml", "--out", "{}/next"]);
    assert!(next.status.success(), "{}", stderr(&next));
    let said = stderr(&next);
    assert!(
        said.contains(&format!(
            "killed earlier command left beside {}",
            dir.join("out").display()
        )),
        "{said}"
    );
    assert!(!crate::names_hidden_entry(&said), "{said}");
    // The live run's folder is all that is left, and the live run finishes.
    let left = leftovers(&dir);
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(
        left[0].to_string_lossy().contains(".live.hookean-partial-"),
        "{left:?}"
    );
    signal(&live, "CONT");
    let live = live.wait_with_output().unwrap();
    assert!(live.status.success(), "{}", stderr(&live));
    assert!(dir.join("live/summary.json").exists());
    assert!(leftovers(&dir).is_empty(), "{:?}", leftovers(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Waits until `count` staging folders exist under `dir`, then freezes `child`.
fn catch_while_running_beside(dir: &Path, child: &mut Child, count: usize) {
    let t0 = Instant::now();
    while leftovers(dir).len() < count {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it could be caught"
        );
        assert!(t0.elapsed() < Duration::from_secs(60), "no staging folder");
        std::thread::sleep(Duration::from_millis(2));
    }
    signal(child, "STOP");
}

/// Issue 37: with the output's files limited in size (`ulimit -f`, the
/// signal SIGXFSZ ignored: every write past the limit fails as on a full
/// disk) every command that writes fails with exit 1, never calls a folder
/// that did not exist "unchanged", and leaves no hidden entry behind; help
/// and version on a full standard output (`>/dev/full`) fail too (they
/// exited 0).
#[test]
fn a_full_disk_fails_every_command_that_writes_and_says_what_is_left() {
    let dir = case_dir("disk-full");
    std::fs::write(
        dir.join("s.toml"),
        "duration = 0.1\n[cloth]\nn = 12\n[output]\nframe_rate = 20.0\nwidth = 64\nheight = 64\n",
    )
    .unwrap();
    let cases: [&[&str]; 6] = [
        &["run", "{}/s.toml", "--out", "{}/out", "--quiet"],
        &["export-system", "{}/s.toml", "--at", "0", "--out", "{}/sys"],
        &[
            "workprecision",
            "--problem",
            "tutorial1",
            "--methods",
            "rk4",
            "--out",
            "{}/wp.csv",
            "--plot",
            "{}/wp.svg",
        ],
        &["stability", "--methods", "rk4", "--plot", "{}/r.svg"],
        &["bench", "--cloth", "8", "--out", "{}/b", "--quiet"],
        &[
            "filter-analysis",
            "{}/s.toml",
            "--plot",
            "{}/fa",
            "--n",
            "8",
            "--t-end",
            "0.02",
        ],
    ];
    for args in cases {
        let args = expand(args, &dir);
        // 1 KiB per file (dash counts 512-byte blocks).
        let out = Command::new("sh")
            .arg("-c")
            .arg("trap '' XFSZ; ulimit -f 2 && exec \"$0\" \"$@\" >/dev/null")
            .arg(env!("CARGO_BIN_EXE_hookean-suite-cli"))
            .args(&args)
            .current_dir(&dir)
            .output()
            .unwrap();
        let said = stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {said}");
        assert!(said.contains("File too large"), "{args:?}: {said}");
        assert!(!said.contains("unchanged"), "{args:?}: {said}");
        assert!(!crate::names_hidden_entry(&said), "{args:?}: {said}");
        assert!(
            leftovers(&dir).is_empty(),
            "{args:?}: {:?}",
            leftovers(&dir)
        );
    }
    // Neither file of a work-precision sweep whose plot could not be written.
    assert!(!dir.join("wp.csv").exists() && !dir.join("wp.svg").exists());
    for args in [
        &["--help"][..],
        &["--version"],
        &["run", "--help"],
        &["scene-keys"],
    ] {
        let out = Command::new("sh")
            .arg("-c")
            .arg("exec \"$0\" \"$@\" >/dev/full")
            .arg(env!("CARGO_BIN_EXE_hookean-suite-cli"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}: {}", stderr(&out));
        assert!(stderr(&out).contains("standard output"), "{args:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
