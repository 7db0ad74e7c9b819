//! `hookean export-system --every K` and `hookean bench --sequence`: a run's
//! sequence of Newton systems written, read back and replayed.

mod common;
use common::*;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "hookean-cli-sequence-{}-{test}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// The rows of a CSV file as maps from its header's names.
fn csv_rows(path: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(str::to_string))
                .collect()
        })
        .collect()
}

fn count(row: &BTreeMap<String, String>, key: &str) -> usize {
    row[key].parse().unwrap()
}

/// The drape's overrides: a cloth of `n` x `n`, `duration` s, one frame.
fn drape_sets(n: usize, duration: f64, precond: &str) -> Vec<String> {
    vec![
        format!("cloth.n={n}"),
        format!("duration={duration}"),
        "output.frame_rate=1".into(),
        format!("solver.preconditioner={precond}"),
    ]
}

fn export(out: &Path, sets: &[String], every: &str) -> serde_json::Value {
    let mut args = vec![
        "export-system".to_string(),
        repo("scenes/drape.toml"),
        "--every".into(),
        every.into(),
        "--out".into(),
        s(out),
    ];
    for x in sets {
        args.extend(["--set".to_string(), x.clone()]);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = hookean(&args);
    assert_ok(&o);
    serde_json::from_str(String::from_utf8(o.stdout).unwrap().trim()).unwrap()
}

fn bench_sequence(dir: &Path, out: &Path) -> String {
    let o = hookean(&[
        "bench",
        "--sequence",
        &s(dir),
        "--out",
        &s(out),
        "--repeat",
        "1",
        "--quiet",
    ]);
    assert_ok(&o);
    String::from_utf8(o.stdout).unwrap()
}

/// The run (`steps.csv`) against the export of the same scene with
/// `--every 1`, then the replay with the scene's own policy against the
/// iterations the run recorded.
fn export_matches_the_run_and_replays_it(test: &str, n: usize, precond: &str, policy: &str) {
    let dir = scratch(test);
    let sets = drape_sets(n, 0.08, precond);
    run_scene(&dir.join("run"), "scenes/drape.toml", &sets);
    let steps = csv_rows(&dir.join("run/steps.csv"));
    let newton: usize = steps.iter().map(|r| count(r, "newton_iterations")).sum();
    assert!(newton >= steps.len() && !steps.is_empty(), "{newton}");

    let seq = dir.join("seq");
    let record = export(&seq, &sets, "1");
    // One system per Newton iteration of the run.
    assert_eq!(record["systems"], newton, "{record}");
    assert_eq!(record["solves"], newton, "{record}");
    let files = std::fs::read_dir(&seq)
        .unwrap()
        .filter(|e| {
            let name = e.as_ref().unwrap().file_name();
            let name = name.to_string_lossy();
            name.starts_with("system-") && name.ends_with("-A.mtx")
        })
        .count();
    assert_eq!(files, newton);
    // Per step: as many solves as Newton iterations, and PCG's iterations
    // summing to the step's cg_iterations.
    let index = csv_rows(&seq.join("index.csv"));
    assert_eq!(index.len(), newton);
    for (k, step) in steps.iter().enumerate() {
        let rows: Vec<_> = index.iter().filter(|r| count(r, "step") == k + 1).collect();
        assert_eq!(
            rows.len(),
            count(step, "newton_iterations"),
            "step {}",
            k + 1
        );
        let cg: usize = rows.iter().map(|r| count(r, "iterations")).sum();
        assert_eq!(cg, count(step, "cg_iterations"), "step {}", k + 1);
    }
    // The pins are constraints of filtered PCG; steps after the first start warm.
    assert!(seq.join("system-00001-constraints.csv").exists());
    assert!(seq.join(format!("system-{newton:05}-x0.mtx")).exists());

    // The replay with the scene's policy takes the run's iterations, system by system.
    let table = bench_sequence(&seq, &dir.join("bench"));
    assert!(table.contains("Chosen policy: "), "{table}");
    assert!(dir.join("bench/cumulative.svg").exists());
    let replay = csv_rows(&dir.join("bench/sequence.csv"));
    let mine: Vec<_> = replay.iter().filter(|r| r["policy"] == policy).collect();
    assert_eq!(mine.len(), newton);
    for (r, run) in mine.iter().zip(&index) {
        assert_eq!(r["system"], run["system"]);
        assert_eq!(r["iterations"], run["iterations"], "system {}", r["system"]);
        assert_eq!(r["converged"], run["converged"], "system {}", r["system"]);
    }
    // Every policy replayed every system.
    assert_eq!(replay.len(), 13 * newton);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mic0_drape_export_matches_the_run_and_replays_it() {
    export_matches_the_run_and_replays_it("mic0", 8, "mic0", "mic0-rebuild");
}

/// 16 x 16 particles, 768 unknowns: above the multigrid's coarse size
/// (500), so there is a hierarchy to refill.
#[test]
fn amg_drape_export_matches_the_run_and_replays_it() {
    export_matches_the_run_and_replays_it("amg", 16, "amg", "amg-refill");
}

#[test]
fn every_k_writes_the_first_solve_and_every_kth_after_it() {
    let dir = scratch("every3");
    let sets = drape_sets(6, 0.08, "mic0");
    let all = export(&dir.join("all"), &sets, "1");
    let third = export(&dir.join("third"), &sets, "3");
    let solves = all["solves"].as_u64().unwrap();
    assert_eq!(third["solves"], solves);
    assert_eq!(third["systems"], solves.div_ceil(3));
    let index = csv_rows(&dir.join("third/index.csv"));
    for (k, r) in index.iter().enumerate() {
        assert_eq!(count(r, "system"), k + 1);
        assert_eq!(count(r, "solve"), 3 * k + 1);
    }
    // The same system as the 4th of --every 1, byte for byte.
    let a = |d: &str, k: usize| std::fs::read(dir.join(d).join(format!("system-{k:05}-A.mtx")));
    assert_eq!(a("third", 2).unwrap(), a("all", 4).unwrap());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn export_every_rejects_bad_flags() {
    let dir = scratch("flags");
    let out = s(&dir.join("out"));
    let scene = repo("scenes/drape.toml");
    let o = hookean(&[
        "export-system",
        &scene,
        "--at",
        "0.1",
        "--every",
        "2",
        "--out",
        &out,
    ]);
    assert_input_error(&o, "--at");
    assert_input_error(&o, "--every");
    assert_input_error(
        &hookean(&["export-system", &scene, "--every", "0", "--out", &out]),
        "--every",
    );
    // An existing --out is refused before the run.
    std::fs::create_dir_all(dir.join("out")).unwrap();
    assert_input_error(
        &hookean(&["export-system", &scene, "--every", "1", "--out", &out]),
        &out,
    );
    // An explicit method solves nothing with PCG.
    let o = hookean(&[
        "export-system",
        &repo("scenes/drape-filtered.toml"),
        "--every",
        "1",
        "--out",
        &s(&dir.join("explicit")),
    ]);
    assert_input_error(&o, "--every");
    assert!(!dir.join("explicit").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 3 x 3 block system: one particle, `A = diag(d, d, d)`.
const ONE_BLOCK: &str =
    "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 2.0\n2 2 2.0\n3 3 2.0\n";
/// Two particles, uncoupled.
const TWO_BLOCKS: &str = "%%MatrixMarket matrix coordinate real symmetric\n6 6 6\n1 1 2.0\n2 2 2.0\n3 3 2.0\n4 4 3.0\n5 5 3.0\n6 6 3.0\n";
/// Two particles, coupled: another pattern than [`TWO_BLOCKS`].
const TWO_COUPLED: &str = "%%MatrixMarket matrix coordinate real symmetric\n6 6 9\n1 1 4.0\n2 2 4.0\n3 3 4.0\n4 4 4.0\n5 5 4.0\n6 6 4.0\n4 1 -1.0\n5 2 -1.0\n6 3 -1.0\n";

fn vector(n: usize) -> String {
    let mut v = format!("%%MatrixMarket matrix array real general\n{n} 1\n");
    for k in 0..n {
        v.push_str(&format!("{}\n", k + 1));
    }
    v
}

/// A folder of numbered systems: `(number, A's text or None, b's size or None)`.
fn folder(test: &str, systems: &[(usize, Option<&str>, Option<usize>)]) -> PathBuf {
    let dir = scratch(test).join("seq");
    std::fs::create_dir_all(&dir).unwrap();
    for &(k, a, b) in systems {
        if let Some(a) = a {
            std::fs::write(dir.join(format!("system-{k:05}-A.mtx")), a).unwrap();
        }
        if let Some(n) = b {
            std::fs::write(dir.join(format!("system-{k:05}-b.mtx")), vector(n)).unwrap();
        }
    }
    dir
}

fn replay_error(dir: &Path, needle: &str) {
    let out = dir.parent().unwrap().join("bench");
    let o = hookean(&["bench", "--sequence", &s(dir), "--out", &s(&out), "--quiet"]);
    assert_input_error(&o, needle);
    assert!(!out.exists(), "no output for bad input");
}

#[test]
fn a_good_hand_written_sequence_replays() {
    let dir = folder(
        "good",
        &[
            (1, Some(TWO_COUPLED), Some(6)),
            (2, Some(TWO_COUPLED), Some(6)),
        ],
    );
    let out = dir.parent().unwrap().join("bench");
    let table = bench_sequence(&dir, &out);
    // 13 policies, each a row: 2 systems, all converged.
    assert_eq!(table.matches("| 2/2 |").count(), 13, "{table}");
    let rows = csv_rows(&out.join("sequence.csv"));
    assert_eq!(rows.len(), 26);
}

#[test]
fn bad_sequences_are_refused_naming_the_file() {
    let empty = folder("empty", &[]);
    replay_error(&empty, &s(&empty));
    let gap = folder(
        "gap",
        &[(1, Some(ONE_BLOCK), Some(3)), (3, Some(ONE_BLOCK), Some(3))],
    );
    replay_error(&gap, "system-00002-A.mtx");
    let no_rhs = folder(
        "no-rhs",
        &[(1, Some(ONE_BLOCK), None), (2, Some(ONE_BLOCK), Some(3))],
    );
    replay_error(&no_rhs, "system-00001-b.mtx");
    let sizes = folder(
        "sizes",
        &[
            (1, Some(ONE_BLOCK), Some(3)),
            (2, Some(TWO_BLOCKS), Some(6)),
        ],
    );
    replay_error(&sizes, "system-00002-A.mtx");
    let patterns = folder(
        "patterns",
        &[
            (1, Some(TWO_BLOCKS), Some(6)),
            (2, Some(TWO_COUPLED), Some(6)),
        ],
    );
    replay_error(&patterns, "system-00002-A.mtx");
    let garbage = folder(
        "garbage",
        &[
            (1, Some(ONE_BLOCK), Some(3)),
            (2, Some("not a matrix\n"), Some(3)),
        ],
    );
    replay_error(&garbage, "system-00002-A.mtx");
    let short_rhs = folder(
        "short-rhs",
        &[(1, Some(ONE_BLOCK), Some(3)), (2, Some(ONE_BLOCK), Some(2))],
    );
    replay_error(&short_rhs, "system-00002-b.mtx");
    let missing = scratch("missing").join("nowhere");
    replay_error(&missing, "nowhere");
    // An index.csv that does not fit the folder.
    let index = folder("index", &[(1, Some(ONE_BLOCK), Some(3))]);
    std::fs::write(index.join("index.csv"), "system,solve\n1,1\n").unwrap();
    replay_error(&index, "index.csv");
}
