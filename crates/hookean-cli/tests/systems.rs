//! `hookean bench-precond` and `hookean export-system` end to end.

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::Output;

fn scratch(test: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("hookean-cli-systems-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

fn json_lines(out: &Output) -> Vec<serde_json::Value> {
    String::from_utf8(out.stdout.clone())
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

#[test]
fn bench_precond_prints_a_json_line_per_system_and_solver() {
    let out = hookean(&["bench-precond", "--n", "6,9", "--k", "1e2,1e5"]);
    assert_ok(&out);
    let lines = json_lines(&out);
    let solvers = [
        "none",
        "jacobi",
        "block-jacobi",
        "ssor",
        "ic0",
        "amg",
        "mic0",
        "direct",
    ];
    assert_eq!(lines.len(), 2 * 2 * solvers.len());
    for (i, v) in lines.iter().enumerate() {
        let n = if i < 2 * solvers.len() { 6 } else { 9 };
        assert_eq!(v["n"], n, "{v}");
        assert_eq!(v["rows"], 3 * n * n, "{v}");
        assert_eq!(v["precond"], solvers[i % solvers.len()], "{v}");
        assert_eq!(v["converged"], true, "{v}");
        assert!(v["rel_residual"].as_f64().unwrap() <= 1e-8, "{v}");
    }
    // Stiffer springs make the system harder: unpreconditioned CG needs
    // more iterations for k = 1e5 than for k = 1e2 (condition number grows
    // with h^2 k / m).
    let its = |n: u64, k: f64| {
        lines
            .iter()
            .find(|v| v["n"] == n && v["k"].as_f64() == Some(k) && v["precond"] == "none")
            .unwrap()["iterations"]
            .as_u64()
            .unwrap()
    };
    assert!(its(9, 1e5) > its(9, 1e2));
    assert!(its(9, 1e5) > its(6, 1e5));
    // The table goes to stderr: header, separator, one row per line above.
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert_eq!(stderr.lines().count(), 2 + lines.len());
    assert!(stderr.starts_with("| N | k |"));
}

#[test]
fn bench_precond_rejects_bad_input() {
    assert_input_error(&hookean(&["bench-precond", "--n", "1"]), "--n");
    assert_input_error(&hookean(&["bench-precond", "--k", "-3"]), "--k");
    assert_input_error(
        &hookean(&["bench-precond", "--n", "4", "--precond", "ilu"]),
        "ilu",
    );
    assert_input_error(
        &hookean(&["bench-precond", "--n", "4", "--repeat", "0"]),
        "--repeat",
    );
}

const SCENE: &str = "duration = 0.1\n[cloth]\nn = 6\nmass = 1.0\n[integrator]\nh = 0.01\n";

/// The values of a Matrix Market array file.
fn read_vector(path: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('%'));
    let size: Vec<usize> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    let v: Vec<f64> = lines
        .flat_map(|l| l.split_whitespace())
        .map(|t| t.parse().unwrap())
        .collect();
    assert_eq!(size, [v.len(), 1]);
    v
}

#[test]
fn export_system_at_rest_is_gravity_times_h() {
    let dir = scratch("rest");
    let scene = dir.join("cloth.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out_dir = dir.join("sys");
    let out = hookean(&[
        "export-system",
        &s(&scene),
        "--at",
        "0",
        "--out",
        &s(&out_dir),
    ]);
    assert_ok(&out);
    let a = std::fs::read_to_string(out_dir.join("A.mtx")).unwrap();
    assert!(a.starts_with("%%MatrixMarket matrix coordinate real symmetric"));
    // At rest every spring has its rest length and v = 0, so
    // b = h (f + h K v) = h m g: per free particle (0, 0, 0.01 * 9.81 / 36).
    let b = read_vector(&out_dir.join("b.mtx"));
    assert_eq!(b.len(), 3 * 36);
    let expected = -0.01 * 9.81 / 36.0;
    let pinned = [30, 35];
    for p in (0..36).filter(|p| !pinned.contains(p)) {
        assert!(b[3 * p].abs() < 1e-15 && b[3 * p + 1].abs() < 1e-15);
        assert!((b[3 * p + 2] - expected).abs() < 1e-15, "{}", b[3 * p + 2]);
    }
    let v = json_lines(&out);
    assert_eq!(v[0]["t"], 0.0);
    assert_eq!(v[0]["rows"], 108);
}

#[test]
fn export_system_round_trips_through_solve() {
    let dir = scratch("roundtrip");
    let scene = dir.join("cloth.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out_dir = dir.join("sys");
    let args = [
        "export-system",
        &s(&scene),
        "--at",
        "0.05",
        "--out",
        &s(&out_dir),
    ];
    let out = hookean(&args);
    assert_ok(&out);
    let v = json_lines(&out);
    assert!((v[0]["t"].as_f64().unwrap() - 0.05).abs() < 1e-12);
    assert_eq!(v[0]["steps"], 5);
    let solved = hookean(&[
        "solve",
        &s(&out_dir.join("A.mtx")),
        "--rhs",
        &s(&out_dir.join("b.mtx")),
    ]);
    assert_ok(&solved);
    let lines = json_lines(&solved);
    assert_eq!(lines.len(), 8); // six PCG preconditioners, MIC(0), direct
    for l in &lines {
        assert_eq!(l["rows"], 108);
        assert_eq!(l["converged"], true, "{l}");
        assert!(l["rel_residual"].as_f64().unwrap() <= 1e-8, "{l}");
    }
    // The folder exists now: refused without --force, rewritten with it.
    std::fs::write(out_dir.join("b.mtx"), "garbage").unwrap();
    assert_input_error(&hookean(&args), "exists");
    assert_eq!(
        std::fs::read_to_string(out_dir.join("b.mtx")).unwrap(),
        "garbage"
    );
    let mut forced = args.to_vec();
    forced.push("--force");
    assert_ok(&hookean(&forced));
    assert_eq!(read_vector(&out_dir.join("b.mtx")).len(), 108);
}

#[test]
fn export_system_rejects_bad_input() {
    let dir = scratch("bad");
    let out_dir = s(&dir.join("sys"));
    assert_input_error(
        &hookean(&["export-system", "no-such-scene.toml", "--out", &out_dir]),
        "no-such-scene.toml",
    );
    let scene = dir.join("bad.toml");
    std::fs::write(&scene, "duration = 0.1\n[cloth]\nn = 6\nstiffnes = 3.0\n").unwrap();
    let out = hookean(&["export-system", &s(&scene), "--out", &out_dir]);
    assert_input_error(&out, "bad.toml");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains('4'),
        "the line of the unknown key: {stderr}"
    );
    let good = dir.join("good.toml");
    std::fs::write(&good, SCENE).unwrap();
    assert_input_error(
        &hookean(&["export-system", &s(&good), "--at", "-1", "--out", &out_dir]),
        "--at",
    );
    // A cloth no machine can hold is refused before it is built (it aborted
    // on a failed allocation), naming the scene and the key.
    let huge = hookean(&[
        "export-system",
        &s(&good),
        "--set",
        "cloth.n=100000",
        "--out",
        &out_dir,
    ]);
    assert_input_error(&huge, "good.toml: cloth.n");
    assert!(!dir.join("sys").exists());
}
