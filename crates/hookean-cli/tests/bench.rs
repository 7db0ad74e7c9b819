//! `hookean bench` end to end: a folder of systems with a right-hand side,
//! a near-nullspace, a malformed and a non-symmetric file; one table row per
//! system and solver (failures as rows with their reason), the iterations of
//! `hookean solve` on the same systems, one picture per solved system, exit 0.

mod common;
use common::*;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-bench-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The 1D Laplacian tridiag(-1, 2, -1) of size n (symmetric storage),
/// whose near-nullspace is the constant vector.
fn laplacian(n: usize) -> String {
    let mut s = format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n",
        2 * n - 1
    );
    for i in 1..=n {
        s += &format!("{i} {i} 2\n");
        if i < n {
            s += &format!("{} {i} -1\n", i + 1);
        }
    }
    s
}

/// `bench.csv` as rows of (system, preconditioner) -> column -> value.
fn read_csv(path: &Path) -> Vec<BTreeMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            // The status (last column) is quoted and may hold commas.
            let (head, status) = l.split_once(",\"").unwrap();
            let mut cells: Vec<String> = head.split(',').map(String::from).collect();
            cells.push(status.trim_end_matches('"').to_string());
            header.iter().cloned().zip(cells).collect()
        })
        .collect()
}

#[test]
fn a_folder_of_systems_gives_one_table_rows_for_failures_and_a_picture_each() {
    let dir = folder("in");
    for f in ["cloth16-A.mtx", "cloth16-b.mtx"] {
        std::fs::copy(repo(&format!("data/{f}")), dir.join(f)).unwrap();
    }
    std::fs::write(dir.join("lap.mtx"), laplacian(50)).unwrap();
    let ones: String = (0..50).map(|_| "1\n").collect();
    std::fs::write(
        dir.join("lap_nullspace.mtx"),
        format!("%%MatrixMarket matrix array real general\n50 1\n{ones}"),
    )
    .unwrap();
    std::fs::write(dir.join("bad.mtx"), "garbage\n").unwrap();
    std::fs::write(
        dir.join("nonsym.mtx"),
        "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 1\n1 2 5\n2 2 1\n",
    )
    .unwrap();
    let out = folder("out").join("result");
    let dir_s = dir.to_string_lossy().into_owned();
    let out_s = out.to_string_lossy().into_owned();
    let run = hookean(&[
        "bench",
        &dir_s,
        "--cloth",
        "8",
        "--precond",
        "jacobi,ssor,ic0,mic0,amg,direct",
        "--format",
        "csr",
        "--repeat",
        "2",
        "--out",
        &out_s,
    ]);
    assert_ok(&run);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        stdout.starts_with("| system |"),
        "the table on stdout: {stdout}"
    );
    let rows = read_csv(&out.join("bench.csv"));
    let row = |system: &str, precond: &str| {
        rows.iter()
            .find(|r| r["system"] == system && r["preconditioner"] == precond)
            .unwrap_or_else(|| panic!("no row {system} {precond}: {rows:?}"))
    };
    // Every usable system has a row per solver; each unusable file one row.
    for system in ["cloth16-A", "lap", "cloth8"] {
        assert_eq!(rows.iter().filter(|r| r["system"] == system).count(), 6);
        assert!(out.join(format!("residual-{system}.svg")).is_file());
        // PCG rows converge to 1e-8 except MIC(0), which CSR storage cannot run.
        for p in ["jacobi", "ssor", "ic0", "amg", "direct"] {
            let r = row(system, p);
            assert_eq!(r["status"], "converged", "{system} {p}: {r:?}");
            assert!(r["rel_residual"].parse::<f64>().unwrap() <= 1e-8, "{r:?}");
        }
        assert!(row(system, "mic0")["status"].contains("MIC(0)"));
    }
    // The unknowns per node and where they came from: the Laplacian's
    // near-nullspace (the constant: 1), the built-in cloth's nodes of 3.
    let nodes = |system: &str| {
        let r = row(system, "amg");
        (r["block_size"].as_str(), r["block_size_source"].as_str())
    };
    assert_eq!(nodes("lap"), ("1", "nullspace"));
    assert_eq!(nodes("cloth8"), ("3", "default"));
    // Jacobi keeps the inverse diagonal: 8 bytes per unknown (768 here),
    // counted by the binary's allocator.
    let kept: usize = row("cloth16-A", "jacobi")["setup_memory_bytes"]
        .parse()
        .unwrap();
    assert!((8 * 768..=8 * 768 + 1024).contains(&kept), "{kept} bytes");
    let bad = rows.iter().find(|r| r["system"] == "bad").unwrap();
    assert!(bad["status"].contains("bad.mtx:1"), "{bad:?}");
    let nonsym = rows.iter().find(|r| r["system"] == "nonsym").unwrap();
    assert!(nonsym["status"].contains("not symmetric"), "{nonsym:?}");
    assert_eq!(rows.iter().filter(|r| r["system"] == "nonsym").count(), 1);
    // The right-hand side beside the matrix is used: the iterations are those
    // of `hookean solve --rhs` on the same files and storage.
    let solve = hookean(&[
        "solve",
        &dir.join("cloth16-A.mtx").to_string_lossy(),
        "--rhs",
        &dir.join("cloth16-b.mtx").to_string_lossy(),
        "--precond",
        "jacobi,ssor,ic0",
        "--format",
        "csr",
    ]);
    assert_ok(&solve);
    for line in String::from_utf8_lossy(&solve.stdout).lines() {
        let json: serde_json::Value = serde_json::from_str(line).unwrap();
        let p = json["precond"].as_str().unwrap();
        let p = if p.starts_with("ssor") { "ssor" } else { p };
        assert_eq!(
            row("cloth16-A", p)["iterations"],
            json["iterations"].to_string(),
            "{p}"
        );
    }
    // The picture names every solver that ran.
    let svg = std::fs::read_to_string(out.join("residual-lap.svg")).unwrap();
    for p in ["jacobi", "ssor", "ic0", "amg", "direct"] {
        assert!(svg.contains(p), "{p} in the legend");
    }
    // The output folder is not replaced without --force.
    let again = hookean(&["bench", &dir_s, "--out", &out_s, "--quiet"]);
    assert_input_error(&again, "--out");
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_dir_all(out.parent().unwrap()).unwrap();
}

#[test]
fn solvers_that_miss_the_tolerance_or_a_bad_nullspace_are_rows_and_exit_zero() {
    let dir = folder("fail");
    std::fs::write(dir.join("lap.mtx"), laplacian(200)).unwrap();
    std::fs::write(
        dir.join("lap_nullspace.mtx"),
        "%%MatrixMarket matrix array real general\n3 1\n1\n1\n1\n",
    )
    .unwrap();
    let out = folder("fail-out").join("r");
    let run = hookean(&[
        "bench",
        &dir.to_string_lossy(),
        "--precond",
        "jacobi,amg",
        "--max-iter",
        "5",
        "--repeat",
        "1",
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_ok(&run);
    let rows = read_csv(&out.join("bench.csv"));
    assert_eq!(rows.len(), 2, "{rows:?}");
    // 5 Jacobi-CG iterations cannot solve a 200-point Laplacian to 1e-8.
    assert!(
        rows[0]["status"].starts_with("not converged"),
        "{:?}",
        rows[0]
    );
    assert!(
        rows[1]["status"].contains("near-nullspace vectors have 3 entries"),
        "{:?}",
        rows[1]
    );
    // Nothing to benchmark is bad input.
    let empty = folder("empty");
    let run = hookean(&["bench", &empty.to_string_lossy(), "--quiet"]);
    assert_input_error(&run, "nothing to benchmark");
    for d in [dir, empty, out.parent().unwrap().to_path_buf()] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// Over a folder, the ranking lines (on stdout and in ranking.md) and the
/// performance profile: each solver's "best on" count is the number of
/// systems where bench.csv's total is the smallest, and a solver that
/// missed the tolerance on a system solves one system fewer. A scalar
/// matrix of 30 unknowns (divisible by 3) keeps 1 unknown per node.
#[test]
fn the_folder_is_ranked_per_metric_and_profiled() {
    let dir = folder("rank");
    for n in [30, 100, 160] {
        std::fs::write(dir.join(format!("lap{n}.mtx")), laplacian(n)).unwrap();
    }
    let out = folder("rank-out").join("r");
    let run = hookean(&[
        "bench",
        &dir.to_string_lossy(),
        "--precond",
        "none,jacobi,ic0,direct",
        "--max-iter",
        "30",
        "--out",
        &out.to_string_lossy(),
        "--quiet",
    ]);
    assert_ok(&run);
    let rows = read_csv(&out.join("bench.csv"));
    // No flags: scalar storage, 1 unknown per node, although 30 = 3 * 10.
    for r in rows.iter().filter(|r| r["system"] == "lap30") {
        assert_eq!(
            (r["block_size"].as_str(), r["block_size_source"].as_str()),
            ("1", "default")
        );
    }
    // CG on the 1D Laplacian of n unknowns with b = A * ones = (1, 0, ..., 0, 1)
    // needs n / 2 iterations without a preconditioner (and with Jacobi, a
    // constant diagonal): after k its iterate lies in span{b, ..., A^(k-1) b},
    // zero in the middle for k < n / 2. 30 are enough for 30 unknowns, too
    // few for 100 and 160; IC(0) is exact on a tridiagonal matrix.
    let solved = |p: &str| {
        rows.iter()
            .filter(|r| r["preconditioner"] == p && r["status"] == "converged")
            .count()
    };
    assert_eq!(
        ["none", "jacobi", "ic0", "direct"].map(solved),
        [1, 1, 3, 3]
    );
    let mut wins: BTreeMap<String, usize> = BTreeMap::new();
    for system in ["lap30", "lap100", "lap160"] {
        let best = rows
            .iter()
            .filter(|r| r["system"] == system && r["status"] == "converged")
            .min_by(|a, b| {
                let t = |r: &BTreeMap<String, String>| r["total_s"].parse::<f64>().unwrap();
                t(a).total_cmp(&t(b))
            })
            .unwrap();
        *wins.entry(best["preconditioner"].clone()).or_default() += 1;
    }
    let ranking = std::fs::read_to_string(out.join("ranking.md")).unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains(ranking.trim_end()), "{stdout}");
    let lines: Vec<&str> = ranking.lines().collect();
    assert_eq!(lines.len(), 4, "{ranking}");
    assert!(lines[0].starts_with("Ranking by time (set-up + solve) over 3 systems: 1. "));
    for p in ["none", "jacobi", "ic0", "direct"] {
        let w = wins.get(p).copied().unwrap_or(0);
        let entry = format!("{p} (best on {w}, solved {}, ratio", solved(p));
        assert!(lines[0].contains(&entry), "{entry} in {}", lines[0]);
    }
    // The iterations are PCG's: the direct solver is not ranked by them.
    assert!(lines[2].starts_with("Ranking by iterations") && !lines[2].contains("direct"));
    let svg = std::fs::read_to_string(out.join("profile.svg")).unwrap();
    for p in ["none", "jacobi", "ic0", "direct"] {
        assert!(
            svg.contains(&format!(">{p}<")) || svg.contains(&format!("\n{p}\n")),
            "{p}"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_dir_all(out.parent().unwrap()).unwrap();
}
