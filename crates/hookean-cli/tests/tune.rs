//! `hookean tune` end to end: the winner is a measured candidate, its
//! `hookean solve` command line runs, its scene table names real keys, and
//! bad input is exit code 2 (or rows with their reasons and exit code 1).

mod common;
use common::*;

use std::path::PathBuf;

fn data(name: &str) -> String {
    repo(&format!("data/{name}"))
}

/// A fresh folder for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-tune-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The words of a POSIX shell line with single quotes (what tune prints).
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quoted = false;
    let mut any = false;
    for c in line.chars() {
        match c {
            '\'' => {
                quoted = !quoted;
                any = true;
            }
            ' ' if !quoted => {
                if any || !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
                any = false;
            }
            '\\' if !quoted => {}
            c => word.push(c),
        }
    }
    if any || !word.is_empty() {
        words.push(word);
    }
    words
}

#[test]
fn the_winner_is_a_candidate_and_its_command_line_runs() {
    let dir = scratch("winner");
    let out = dir.join("out");
    let run = hookean(&[
        "tune",
        &data("cloth16-A.mtx"),
        "--rhs",
        &data("cloth16-b.mtx"),
        "--budget",
        "20",
        "--repeat",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_ok(&run);
    let stdout = String::from_utf8(run.stdout).unwrap();
    let stderr = String::from_utf8(run.stderr).unwrap();
    // One progress line per candidate (and one per repeated front-runner).
    let csv = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    let rows: Vec<Vec<String>> = csv
        .lines()
        .skip(1)
        .map(|l| l.splitn(13, ',').map(str::to_string).collect())
        .collect();
    assert!(rows.len() >= 7, "every preconditioner's default: {csv}");
    let progress = stderr
        .lines()
        .filter(|l| l.starts_with("hookean tune: [") && !l.contains("best of"))
        .count();
    assert_eq!(progress, rows.len(), "{stderr}");
    // The defaults first, the multigrid's the very first.
    let first: Vec<&str> = rows[..7].iter().map(|r| r[1].as_str()).collect();
    assert_eq!(
        first,
        [
            "amg",
            "ic0",
            "ssor",
            "block-jacobi",
            "jacobi",
            "mic0",
            "none"
        ]
    );
    assert!(rows[..7].iter().all(|r| r[4] == "0"), "no option changed");
    // Exactly one winner, converged, and never slower than the default.
    let winners: Vec<&Vec<String>> = rows.iter().filter(|r| r[11] == "true").collect();
    assert_eq!(winners.len(), 1, "{csv}");
    let w = winners[0];
    assert_eq!(w[12], "\"converged\"");
    let total = |r: &Vec<String>| r[9].parse::<f64>().unwrap();
    assert!(total(w) <= total(&rows[0]), "{csv}");
    // Every converged candidate meets the tolerance (true residual).
    for r in rows.iter().filter(|r| r[12] == "\"converged\"") {
        assert!(r[10].parse::<f64>().unwrap() <= 1e-8, "{r:?}");
    }
    // The command line: the winner's preconditioner, and it runs.
    let line = stdout
        .lines()
        .find(|l| l.starts_with("hookean solve "))
        .unwrap_or_else(|| panic!("{stdout}"));
    let words = shell_words(line);
    let args: Vec<&str> = words[1..].iter().map(String::as_str).collect();
    let solve = hookean(&args);
    assert_ok(&solve);
    let record: serde_json::Value =
        serde_json::from_str(String::from_utf8(solve.stdout).unwrap().trim()).unwrap();
    assert_eq!(record["precond"], w[1].as_str());
    assert_eq!(record["converged"], true);
    let format = if w[2] == "block" {
        "sym-block-3x3"
    } else {
        "csr"
    };
    assert_eq!(record["format"], format);
    // The scene table names only keys `hookean scene-keys` lists.
    let keys = String::from_utf8(hookean(&["scene-keys"]).stdout).unwrap();
    let mut table = "";
    for l in stdout.lines().skip_while(|l| !l.starts_with("[solver]")) {
        if l.starts_with('[') {
            table = l.trim_matches(['[', ']']);
        } else if let Some((key, _)) = l.split_once(" = ") {
            let full = format!("  {table}.{key}\n");
            assert!(keys.contains(&full), "{full} not a scene key: {stdout}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_bad_budget_is_refused() {
    for budget in ["0", "-1", "NaN", "inf"] {
        let out = hookean(&["tune", &data("cloth16-A.mtx"), "--budget", budget]);
        assert_input_error(&out, "--budget");
    }
}

#[test]
fn a_missing_file_is_named() {
    let out = hookean(&["tune", &data("no-such-matrix.mtx")]);
    assert_input_error(&out, "no-such-matrix.mtx");
    let out = hookean(&[
        "tune",
        &data("cloth16-A.mtx"),
        "--rhs",
        &data("no-such-rhs.mtx"),
    ]);
    assert_input_error(&out, "no-such-rhs.mtx");
}

#[test]
fn a_nonsymmetric_matrix_is_refused() {
    let dir = scratch("nonsymmetric");
    let a = dir.join("a.mtx");
    std::fs::write(
        &a,
        "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 2\n1 2 1\n2 2 2\n",
    )
    .unwrap();
    let out = hookean(&["tune", a.to_str().unwrap()]);
    assert_input_error(&out, "symmetric");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_matrix_no_solver_converges_on_is_rows_with_reasons() {
    // diag(1, -1) with b = A * ones = (1, -1): p^T A p = 0 for CG without a
    // preconditioner, a negative diagonal for every other one.
    let dir = scratch("indefinite");
    let a = dir.join("a.mtx");
    std::fs::write(
        &a,
        "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1\n2 2 -1\n",
    )
    .unwrap();
    let out = dir.join("out");
    let run = hookean(&[
        "tune",
        a.to_str().unwrap(),
        "--budget",
        "5",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(stderr.contains("no candidate reached --rtol"), "{stderr}");
    assert!(run.stdout.is_empty());
    let csv = std::fs::read_to_string(out.join("tune.csv")).unwrap();
    for row in csv.lines().skip(1) {
        assert!(row.contains("failed: "), "a reason: {row}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_users_file_is_not_overwritten() {
    let dir = scratch("overwrite");
    let mine = dir.join("mine");
    std::fs::write(&mine, "keep me").unwrap();
    let out = hookean(&[
        "tune",
        &data("cloth16-A.mtx"),
        "--budget",
        "1",
        "--out",
        mine.to_str().unwrap(),
    ]);
    assert_input_error(&out, "--out");
    assert_eq!(std::fs::read_to_string(&mine).unwrap(), "keep me");
    let _ = std::fs::remove_dir_all(&dir);
}
