//! Checkpoint and resume (issue 41, docs/OUTPUTS.md "Checkpoint and
//! resume"): a run stopped by SIGTERM (or killed by SIGKILL after a
//! scheduled checkpoint) and resumed with `--resume` leaves a folder whose
//! every file is byte for byte the uninterrupted run's, except the
//! wall-clock fields of summary.json (and of its copy in view.html):
//! `wall_s`, `phases_s` and `simulated_s_per_wall_s`. Bad input (no
//! checkpoint, another scene, another version, a corrupted or truncated
//! checkpoint, a bad `checkpoint_every`) exits 2 and changes nothing.

mod common;
use common::*;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A fresh scratch folder for one test.
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("hookean-resume-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `hookean run SCENE` (a repository path) with `sets` and `extra` arguments, started.
fn spawn_run(scene: &str, sets: &[&str], extra: &[&str]) -> Child {
    let mut c = Command::new(env!("CARGO_BIN_EXE_hookean"));
    c.args(["run", &repo(scene), "--quiet"]);
    for s in sets {
        c.args(["--set", s]);
    }
    c.args(extra)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// `hookean run SCENE` with `sets` and `extra`, to the end.
fn run(scene: &str, sets: &[&str], extra: &[&str]) -> std::process::Output {
    spawn_run(scene, sets, extra).wait_with_output().unwrap()
}

/// Every file under `dir` (relative name, bytes).
fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_type().unwrap().is_file())
        .map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).unwrap())
        })
        .collect()
}

/// `text` with the values of the wall-clock keys (and only those) replaced.
fn without_wall_clock(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    let keys = [
        "\"wall_s\":",
        "\"simulated_s_per_wall_s\":",
        "\"assembly\":",
        "\"preconditioner_setup\":",
        "\"solve\":",
        "\"other\":",
    ];
    while let Some((k, at)) = keys
        .iter()
        .filter_map(|k| rest.find(k).map(|at| (k, at)))
        .min_by_key(|(_, at)| *at)
    {
        out += &rest[..at + k.len()];
        rest = rest[at + k.len()..].trim_start_matches(' ');
        let end = rest
            .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
            .unwrap_or(rest.len());
        assert!(end > 0, "a number after {k}");
        out += "WALL";
        rest = &rest[end..];
    }
    out + rest
}

/// The two folders hold the same files, byte for byte apart from the
/// wall-clock fields of summary.json and view.html.
fn assert_same_run(full: &Path, resumed: &Path) {
    let (a, b) = (files(full), files(resumed));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    let mut timed = 0;
    for (name, bytes) in &a {
        let other = &b[name];
        if name == "summary.json" || name == "view.html" {
            let (x, y) = (
                String::from_utf8_lossy(bytes),
                String::from_utf8_lossy(other),
            );
            assert_eq!(without_wall_clock(&x), without_wall_clock(&y), "{name}");
            timed += 1;
        } else {
            assert!(bytes == other, "{name} differs");
        }
    }
    assert_eq!(timed, 2);
    assert!(a.keys().filter(|k| k.starts_with("frame-")).count() > 10);
}

/// Waits until `ready()` (polling), or panics after `limit`.
fn wait_for(limit: Duration, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(start.elapsed() < limit, "timed out");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A copy of the folder `from` at `to`.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The default implicit integrator with the multigrid (whose refill
/// reuses the aggregates of its first set-up), with checkpoints on (so a
/// signal stops the run with one): SIGTERM mid-run, exit 1
/// with the checkpoint and the command to resume; bad resumes refused;
/// the resumed folder equals the uninterrupted run's.
#[test]
fn a_run_stopped_by_sigterm_and_resumed_writes_the_uninterrupted_runs_files() {
    let dir = scratch("sigterm");
    // No scheduled checkpoint before the signal's (the first is due at 100 s).
    let sets = [
        "cloth.n=24",
        "duration=3.0",
        "solver.preconditioner=amg",
        "output.checkpoint_every=100",
    ];
    let (full, part) = (dir.join("full"), dir.join("part"));
    let out = run("scenes/drape.toml", &sets, &["--out", s(&full)]);
    assert_ok(&out);

    let child = spawn_run("scenes/drape.toml", &sets, &["--out", s(&part)]);
    // Some frames written (frame 5 is t = 0.5 s of 3 s), then SIGTERM.
    wait_for(Duration::from_secs(120), || {
        part.join("frame-0005.obj").exists()
    });
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let stopped = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&stopped.stderr);
    assert_eq!(stopped.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("stopped by a signal at t = "), "{stderr}");
    let checkpoint = part.join("checkpoint.bin");
    assert!(stderr.contains(s(&checkpoint)), "{stderr}");
    assert!(
        stderr.contains(&format!("--resume {}", s(&part))),
        "{stderr}"
    );
    assert!(checkpoint.is_file());
    assert!(
        !part.join("summary.json").exists(),
        "stopped before the end"
    );
    let frames_then = files(&part)
        .keys()
        .filter(|k| k.starts_with("frame-"))
        .count();
    assert!((6..31).contains(&frames_then), "{frames_then} frames");

    // Bad resumes: exit 2, nothing changed.
    let before = files(&part);
    let bad = |sets: &[&str], folder: &Path, needle: &str| {
        let out = run("scenes/drape.toml", sets, &["--resume", s(folder)]);
        assert_input_error(&out, needle);
    };
    bad(&sets[..3], &part, "another scene");
    bad(&sets, &full, "no checkpoint");
    assert_eq!(files(&part), before);
    let header_end = {
        let b = &before["checkpoint.bin"];
        let first = b.iter().position(|&c| c == b'\n').unwrap();
        first + 1 + b[first + 1..].iter().position(|&c| c == b'\n').unwrap()
    };
    let variant = |name: &str, edit: &dyn Fn(&mut Vec<u8>)| {
        let d = dir.join(name);
        copy_dir(&part, &d);
        let mut b = before["checkpoint.bin"].clone();
        edit(&mut b);
        std::fs::write(d.join("checkpoint.bin"), &b).unwrap();
        let listing = files(&d);
        (d, listing)
    };
    for (name, edit, needle) in [
        (
            "version",
            (&|b: &mut Vec<u8>| {
                let text =
                    String::from_utf8_lossy(b).replacen("\"version\":2,", "\"version\":99,", 1);
                *b = text.into_bytes();
            }) as &dyn Fn(&mut Vec<u8>),
            "version 99",
        ),
        (
            "corrupted",
            &|b: &mut Vec<u8>| {
                let k = header_end + 1 + 8 * 7 + 3;
                b[k] ^= 0x10;
            },
            "checksum",
        ),
        (
            "truncated",
            &|b: &mut Vec<u8>| b.truncate(b.len() - 100),
            "truncated",
        ),
    ] {
        if name == "version" {
            // The version test edits text: only valid if the header says version 2.
            assert!(
                String::from_utf8_lossy(&before["checkpoint.bin"][..header_end])
                    .contains("\"version\":2,")
            );
        }
        let (d, listing) = variant(name, edit);
        bad(&sets, &d, needle);
        assert_eq!(files(&d), listing, "{name}: nothing changed");
    }

    // The resume: frames before the checkpoint are not rewritten.
    let frame0 = std::fs::metadata(part.join("frame-0000.obj"))
        .unwrap()
        .modified()
        .unwrap();
    let out = run("scenes/drape.toml", &sets, &["--resume", s(&part)]);
    assert_ok(&out);
    let after = std::fs::metadata(part.join("frame-0000.obj"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(
        frame0, after,
        "frame 0 was not written again (no replay from t = 0)"
    );
    assert!(!checkpoint.exists(), "a finished run keeps no checkpoint");
    assert_same_run(&full, &part);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene with floor contact with friction and pins moved along paths
/// and released (the curtain, without self-collision): checkpoints every
/// 0.5 s, SIGKILL (no signal checkpoint) after the one at 1 s, resumed
/// from it: the same files as the uninterrupted run.
#[test]
fn a_run_killed_after_a_scheduled_checkpoint_resumes_from_it() {
    let dir = scratch("sigkill");
    let sets = [
        "cloth.n=21",
        "contact.self_collision=false",
        "duration=2.5",
        "output.checkpoint_every=0.5",
    ];
    let (full, part) = (dir.join("full"), dir.join("part"));
    assert_ok(&run("scenes/curtain.toml", &sets, &["--out", s(&full)]));
    assert!(!full.join("checkpoint.bin").exists());

    let mut child = spawn_run("scenes/curtain.toml", &sets, &["--out", s(&part)]);
    // The checkpoint at t = 1 s is written after frame 10; kill once frame
    // 13 exists (past it, before the next at 1.5 s).
    wait_for(Duration::from_secs(120), || {
        part.join("frame-0013.obj").exists()
    });
    assert!(
        child.try_wait().unwrap().is_none(),
        "the run ended before the kill"
    );
    child.kill().unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), None, "killed by a signal");
    let checkpoint = std::fs::read(part.join("checkpoint.bin")).unwrap();
    let header = String::from_utf8_lossy(&checkpoint[..400.min(checkpoint.len())]).into_owned();
    assert!(
        header.contains("\"t\":1.0,") || header.contains("\"t\":1.5,"),
        "{header}"
    );

    let out = run("scenes/curtain.toml", &sets, &["--resume", s(&part)]);
    assert_ok(&out);
    assert_same_run(&full, &part);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Cloth self-collision carries its candidate list and its tree from step
/// to step; the checkpoint holds them (docs/OUTPUTS.md): the flag (self-
/// collision, gusting wind, a pinned edge), checkpoints every 0.5 s,
/// SIGKILL after the one at 1 s, resumed from it: the same files as the
/// uninterrupted run.
#[test]
fn a_self_collision_run_killed_after_a_scheduled_checkpoint_resumes_from_it() {
    let dir = scratch("self-collision");
    let sets = ["cloth.n=20", "duration=2.5", "output.checkpoint_every=0.5"];
    let (full, part) = (dir.join("full"), dir.join("part"));
    assert_ok(&run("scenes/flag.toml", &sets, &["--out", s(&full)]));
    assert!(!full.join("checkpoint.bin").exists());

    let mut child = spawn_run("scenes/flag.toml", &sets, &["--out", s(&part)]);
    // Past the checkpoint at t = 1 s (after frame 10), before the next.
    wait_for(Duration::from_secs(120), || {
        part.join("frame-0013.obj").exists()
    });
    assert!(
        child.try_wait().unwrap().is_none(),
        "the run ended before the kill"
    );
    child.kill().unwrap();
    assert_eq!(child.wait().unwrap().code(), None, "killed by a signal");
    let checkpoint = std::fs::read(part.join("checkpoint.bin")).unwrap();
    let header = String::from_utf8_lossy(&checkpoint[..400.min(checkpoint.len())]).into_owned();
    assert!(
        header.contains("\"t\":1.0,") || header.contains("\"t\":1.5,"),
        "{header}"
    );

    let out = run("scenes/flag.toml", &sets, &["--resume", s(&part)]);
    assert_ok(&out);
    assert_same_run(&full, &part);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `output.checkpoint_every` must be positive and finite, and the run's
/// solver covered (a multigrid that carries eigenvector estimates is not);
/// refused with exit 2 before anything is written.
#[test]
fn bad_checkpoint_every_is_refused_and_writes_nothing() {
    let dir = scratch("every");
    let out_dir = dir.join("out");
    for (set, needle) in [
        ("output.checkpoint_every=0", "output.checkpoint_every"),
        ("output.checkpoint_every=-1", "output.checkpoint_every"),
        ("output.checkpoint_every=nan", "output.checkpoint_every"),
    ] {
        let out = run(
            "scenes/drape.toml",
            &["cloth.n=4", set],
            &["--out", s(&out_dir)],
        );
        assert_input_error(&out, needle);
    }
    let out = run(
        "scenes/drape.toml",
        &[
            "cloth.n=4",
            "solver.preconditioner=amg",
            "solver.amg.refill_power_iterations=2",
            "output.checkpoint_every=0.1",
        ],
        &["--out", s(&out_dir)],
    );
    assert_input_error(
        &out,
        "output.checkpoint_every: checkpoints do not cover a multigrid that carries eigenvector estimates from refill to refill (solver.amg.refill_power_iterations > 0",
    );
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        0,
        "nothing written"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `scene` with `sets` (which turn checkpoints on) stopped by SIGTERM once
/// frame 5 is written and resumed: the uninterrupted run's files.
fn stopped_and_resumed(name: &str, scene: &str, sets: &[&str]) {
    let dir = scratch(name);
    let (full, part) = (dir.join("full"), dir.join("part"));
    assert_ok(&run(scene, sets, &["--out", s(&full)]));
    let child = spawn_run(scene, sets, &["--out", s(&part)]);
    wait_for(Duration::from_secs(300), || {
        part.join("frame-0005.obj").exists()
    });
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let stopped = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&stopped.stderr);
    assert_eq!(stopped.status.code(), Some(1), "{name}: {stderr}");
    assert!(part.join("checkpoint.bin").is_file(), "{name}");
    assert!(
        !part.join("summary.json").exists(),
        "{name}: stopped before the end"
    );
    assert_ok(&run(scene, sets, &["--resume", s(&part)]));
    assert_same_run(&full, &part);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The engines that keep more than the state across steps: the
/// simplified Newton variants (a kept Newton matrix; eq. 50's rebuilt from
/// `gh`), IMEX (its factor, rebuilt from its key), the variable-order BDF
/// (history, order, kept Jacobians and Newton matrix) with the multigrid,
/// the velocity filter, and the multigrid that keeps its hierarchy: each
/// stopped by SIGTERM and resumed writes the uninterrupted run's files.
#[test]
fn every_engine_stopped_by_sigterm_resumes_bit_for_bit() {
    let common = ["cloth.n=24", "duration=3.0", "output.checkpoint_every=100"];
    for (name, scene, extra) in [
        (
            "simplified",
            "scenes/drape.toml",
            &["solver.newton=simplified"][..],
        ),
        (
            "eq50",
            "scenes/drape.toml",
            &["solver.newton=inexact-simplified"][..],
        ),
        ("imex", "scenes/drape.toml", &["integrator.method=imex"][..]),
        (
            "bdf",
            "scenes/drape.toml",
            &["integrator.method=bdf", "solver.preconditioner=amg"][..],
        ),
        ("filter", "scenes/drape-filtered.toml", &[][..]),
        (
            "keep",
            "scenes/drape.toml",
            &["solver.preconditioner=amg", "solver.amg.reuse=keep"][..],
        ),
    ] {
        let sets: Vec<&str> = common.iter().chain(extra).copied().collect();
        stopped_and_resumed(name, scene, &sets);
    }
}
