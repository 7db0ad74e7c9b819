//! `hookean solve` end to end: JSON output on the bundled system, and bad
//! input as one line on stderr with exit code 2.

mod common;
use common::*;

use std::process::Output;

/// Bad input prints no JSON, then follows the shared error convention.
fn assert_input_error(out: &Output, needle: &str) {
    assert!(out.stdout.is_empty(), "no JSON on bad input");
    common::assert_input_error(out, needle);
}

fn data(name: &str) -> String {
    repo(&format!("data/{name}"))
}

fn scratch(name: &str, contents: &str) -> String {
    let dir = std::env::temp_dir().join(format!("hookean-cli-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p.to_string_lossy().into_owned()
}

#[test]
fn solves_the_bundled_system_with_every_solver() {
    let out = hookean(&[
        "solve",
        &data("cloth16-A.mtx"),
        "--rhs",
        &data("cloth16-b.mtx"),
        "--precond",
        "all",
        "--repeat",
        "2",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let names: Vec<&str> = lines
        .iter()
        .map(|v| v["precond"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        [
            "none",
            "jacobi",
            "block-jacobi",
            "ssor",
            "ic0",
            "amg",
            "mic0",
            "direct"
        ]
    );
    // The multigrid's hierarchy is reported: 768 unknowns, more than the
    // default coarse size (500), so at least two levels.
    let amg = &lines[5]["amg"];
    assert!(amg["levels"].as_u64().unwrap() >= 2, "{amg}");
    assert_eq!(amg["rows"][0], 768);
    let oc = amg["operator_complexity"].as_f64().unwrap();
    assert!((1.0..2.0).contains(&oc), "{amg}");
    for v in &lines {
        assert_eq!(v["rows"], 768);
        assert_eq!(v["converged"], true, "{v}");
        // The residual is recomputed from the matrix as read: PCG honours 1e-8.
        assert!(v["rel_residual"].as_f64().unwrap() <= 1e-8, "{v}");
        assert!(v["setup_s"].as_f64().unwrap() >= 0.0);
        for key in ["matrix", "solver", "nnz", "solve_s", "iterations"] {
            assert!(v.get(key).is_some(), "{key} missing in {v}");
        }
    }
}

#[test]
fn default_rhs_is_a_times_ones_and_csr_storage_meets_the_tolerance() {
    // A 3x3 SPD matrix in CSR form (n not a multiple of 3 would use CSR too).
    let a = scratch(
        "spd.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n3 3 5\n1 1 4\n2 1 1\n2 2 3\n3 2 -1\n3 3 2\n",
    );
    let out = hookean(&[
        "solve",
        &a,
        "--precond",
        "ic0",
        "--format",
        "csr",
        "--rtol",
        "1e-12",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["format"], "csr");
    assert!(v["rel_residual"].as_f64().unwrap() < 1e-12);
}

#[test]
fn amg_runs_on_csr_storage_and_in_a_list_with_mic0() {
    let cloth = data("cloth16-A.mtx");
    let out = hookean(&[
        "solve",
        &data("cloth16-A.mtx"),
        "--rhs",
        &data("cloth16-b.mtx"),
        "--precond",
        "mic0,amg",
    ]);
    assert!(out.status.success());
    let lines: Vec<serde_json::Value> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    assert_eq!(
        (&lines[0]["precond"], &lines[1]["precond"]),
        (&"mic0".into(), &"amg".into())
    );
    assert!(lines[0].get("amg").is_none());
    let out = hookean(&[
        "solve",
        &data("cloth16-A.mtx"),
        "--precond",
        "amg",
        "--format",
        "csr",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["format"], "csr");
    assert_eq!(v["converged"], true);
    assert!(v["rel_residual"].as_f64().unwrap() <= 1e-8);
    assert!(v["amg"]["levels"].as_u64().unwrap() >= 2, "{v}");
    // Grouped into 3x3 blocks, CSR storage gives the block storage's hierarchy.
    let run = |extra: &[&str]| {
        let mut args = vec!["solve", &*cloth, "--precond", "amg"];
        args.extend_from_slice(extra);
        let out = hookean(&args);
        assert!(out.status.success());
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let grouped = run(&["--format", "csr", "--block-size", "3"]);
    let block = run(&["--format", "block"]);
    assert_eq!(grouped["iterations"], block["iterations"]);
    assert_eq!(grouped["amg"], block["amg"]);
    assert_input_error(
        &hookean(&["solve", &cloth, "--block-size", "4"]),
        "--block-size",
    );
}

#[test]
fn bad_input_is_one_line_and_exit_code_2() {
    let missing = hookean(&["solve", "/nonexistent/A.mtx"]);
    assert_input_error(&missing, "/nonexistent/A.mtx");

    let malformed = scratch(
        "bad.mtx",
        "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n2 x 1.0\n",
    );
    assert_input_error(&hookean(&["solve", &malformed]), "bad.mtx:4: ");

    let rect = scratch(
        "rect.mtx",
        "%%MatrixMarket matrix coordinate real general\n2 3 1\n1 1 1.0\n",
    );
    assert_input_error(&hookean(&["solve", &rect]), "not square");

    let short_b = scratch(
        "b.mtx",
        "%%MatrixMarket matrix array real general\n2 1\n1\n2\n",
    );
    assert_input_error(
        &hookean(&["solve", &data("cloth16-A.mtx"), "--rhs", &short_b]),
        "2 entries",
    );

    assert_input_error(
        &hookean(&["solve", &data("cloth16-A.mtx"), "--precond", "ilu"]),
        "unknown preconditioner",
    );
    assert_input_error(
        &hookean(&["solve", &data("cloth16-A.mtx"), "--omega", "2.5"]),
        "omega",
    );
    assert_input_error(
        &hookean(&["solve", &rect, "--format", "block"]),
        "not square",
    );
}

#[test]
fn a_matrix_that_is_not_positive_definite_is_reported_per_solver() {
    let indefinite = scratch(
        "indef.mtx",
        "%%MatrixMarket matrix coordinate real general\n2 2 2\n1 1 1.0\n2 2 -1.0\n",
    );
    let out = hookean(&["solve", &indefinite, "--precond", "none"]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(
        v["error"]
            .as_str()
            .unwrap()
            .contains("not positive definite"),
        "{v}"
    );
}

/// A solve that stops short of its tolerance is a failed run (exit 1), its
/// JSON saying `"converged": false`; so is a direct (Cholesky) or PCG solve
/// of a nonsymmetric matrix, which would otherwise read one triangle and
/// solve another system.
#[test]
fn unconverged_and_nonsymmetric_solves_exit_1() {
    let one_line = |out: &Output| -> serde_json::Value {
        serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {out:?}"))
    };
    let system = data("cloth16-A.mtx");
    for limit in [["--max-iter", "0"], ["--rtol", "0"]] {
        let mut args = vec!["solve", system.as_str(), "--precond", "jacobi"];
        args.extend(limit);
        let out = hookean(&args);
        assert_eq!(out.status.code(), Some(1), "{limit:?}");
        assert_eq!(one_line(&out)["converged"], false, "{limit:?}");
    }
    // [[2, 1], [0, 2]]: lower triangle [[2, 0], [0, 2]] would give x = b / 2.
    let general = scratch(
        "nonsym.mtx",
        "%%MatrixMarket matrix coordinate real general\n2 2 3\n1 1 2.0\n1 2 1.0\n2 2 2.0\n",
    );
    // PCG too: SSOR reads one triangle, CG assumes A = A^T.
    for precond in ["direct", "jacobi", "ssor", "ic0", "amg"] {
        let out = hookean(&["solve", &general, "--precond", precond]);
        assert_eq!(out.status.code(), Some(1), "{precond}");
        let v = one_line(&out);
        assert!(
            v["error"].as_str().unwrap().contains("not symmetric"),
            "{precond}: {v}"
        );
        assert_eq!(v["converged"], false, "{precond}");
    }
}

/// A reader that closes the pipe early (`hookean solve ... | head -1`) ends
/// the command quietly with exit code 141 (as SIGPIPE does), not a panic.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_hookean"))
        .args([
            "solve",
            &repo("data/cloth16-A.mtx"),
            "--rhs",
            &repo("data/cloth16-b.mtx"),
            "--precond",
            "all",
            // Each line then takes 100 solves (tenths of a second), so the
            // reader is gone long before the last one is written.
            "--repeat",
            "100",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the hookean binary runs");
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    assert!(first.starts_with('{'), "{first}");
    // The reader is gone: later lines hit a closed pipe.
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(141), "{stderr}");
}

/// The multigrid's flags: each value out of range is an input error naming
/// its flag; a near-nullspace from `--coordinates` (rigid-body modes: 6 on
/// nodes of 3 unknowns) gives coarse levels of 6 unknowns per node; one of
/// the wrong length is an input error naming `--nullspace`.
#[test]
fn amg_flags_are_checked_and_the_near_nullspace_is_used() {
    let cloth = data("cloth16-A.mtx");
    for (flag, value) in [
        ("--amg-strength", "1.5"),
        ("--amg-sweeps", "0"),
        ("--amg-coarse-size", "0"),
        ("--amg-max-levels", "0"),
        ("--amg-prolongation-weight", "2"),
        ("--amg-jacobi-weight", "0"),
        ("--amg-power-iterations", "101"),
        ("--amg-sweeps", "101"),
        ("--amg-coarse-size", "4097"),
        ("--amg-max-levels", "65"),
        ("--amg-precision", "half"),
        ("--amg-smoother", "sor"),
    ] {
        assert_input_error(
            &hookean(&["solve", &cloth, "--precond", "amg", flag, value]),
            flag,
        );
    }
    // A coordinate-format nullspace whose size line declares 10^12 columns:
    // refused by the byte cap before its dense columns are allocated.
    let huge = scratch(
        "huge_nullspace.mtx",
        "%%MatrixMarket matrix coordinate real general\n768 1000000000000 1\n1 1 1.0\n",
    );
    assert_input_error(
        &hookean(&["solve", &cloth, "--precond", "amg", "--nullspace", &huge]),
        "huge_nullspace.mtx",
    );
    // 256 nodes of the 16 x 16 cloth on a grid (not its true positions: any
    // rigid-body modes are a valid near-nullspace).
    let coordinates: String = (0..256)
        .map(|i| format!("{}\n{}\n{}\n", i % 16, i / 16, 0.1 * (i % 3) as f64))
        .collect::<Vec<_>>()
        .join("");
    // Array format is column-major: x of every node, then y, then z.
    let mut columns = vec![String::new(); 3];
    for (k, v) in coordinates.lines().enumerate() {
        columns[k % 3].push_str(v);
        columns[k % 3].push('\n');
    }
    let x = scratch(
        "x.mtx",
        &format!(
            "%%MatrixMarket matrix array real general\n256 3\n{}",
            columns.concat()
        ),
    );
    for format in ["block", "csr"] {
        let out = hookean(&[
            "solve",
            &cloth,
            "--precond",
            "amg",
            "--coordinates",
            &x,
            "--format",
            format,
            "--amg-coarse-size",
            "50",
        ]);
        assert!(out.status.success(), "{out:?}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["converged"], true, "{v}");
        let rows = v["amg"]["rows"].as_array().unwrap();
        assert!(rows.len() >= 2, "{v}");
        assert_eq!(rows[0], 768);
        assert_eq!(rows[1].as_u64().unwrap() % 6, 0, "{v}");
    }
    let short = scratch(
        "ns.mtx",
        "%%MatrixMarket matrix array real general\n3 1\n1\n1\n1\n",
    );
    assert_input_error(
        &hookean(&["solve", &cloth, "--precond", "amg", "--nullspace", &short]),
        "--nullspace",
    );
}

/// `(L + I/10) ⊗ K` in Matrix Market (lower triangle, symmetric): `L` the
/// 5-point Laplacian of an `m x m` grid of nodes, `K` the `d x d` coupling
/// of a node's unknowns (`[[2, 1], [1, 2]]` for d = 2, `[1]` for d = 1),
/// SPD as a Kronecker product of SPD factors.
fn grid_system(m: usize, d: usize) -> String {
    let k = |p: usize, q: usize| if p == q { 2.0 } else { 1.0 };
    let mut entries = Vec::new();
    for node in 0..m * m {
        let (x, y) = (node % m, node / m);
        let mut neighbours = vec![(node, 4.1)];
        if x > 0 {
            neighbours.push((node - 1, -1.0));
        }
        if y > 0 {
            neighbours.push((node - m, -1.0));
        }
        for (other, l) in neighbours {
            for p in 0..d {
                for q in 0..d {
                    let (r, c) = (d * node + p, d * other + q);
                    if c <= r {
                        entries.push(format!("{} {} {}", r + 1, c + 1, l * k(p, q)));
                    }
                }
            }
        }
    }
    let n = m * m * d;
    format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n{}\n",
        entries.len(),
        entries.join("\n")
    )
}

/// Without flags the multigrid takes the unknowns per node the pattern
/// shows (2 on a 2D vector grid of 72 unknowns, which block storage would
/// have grouped in 3s), a flag overrides it, and a scalar grid of 36
/// unknowns says nothing: 1 on scalar storage, though 36 is divisible by
/// 3; the JSON names the source.
#[test]
fn the_block_size_is_detected_from_the_pattern_and_reported() {
    let vector = scratch("vector2d.mtx", &grid_system(6, 2));
    let scalar = scratch("scalar2d.mtx", &grid_system(6, 1));
    let solve = |path: &str, extra: &[&str]| {
        let mut args = vec!["solve", path, "--precond", "amg", "--amg-coarse-size", "10"];
        args.extend_from_slice(extra);
        let out = hookean(&args);
        assert_ok(&out);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["converged"], true, "{v}");
        (
            v["block_size"].as_u64().unwrap(),
            v["block_size_source"].as_str().unwrap().to_string(),
            v["format"].as_str().unwrap().to_string(),
        )
    };
    let expect = |b: u64, source: &str, format: &str| (b, source.to_string(), format.to_string());
    assert_eq!(solve(&vector, &[]), expect(2, "detected", "csr"));
    assert_eq!(
        solve(&vector, &["--block-size", "1"]),
        expect(1, "flag", "csr")
    );
    assert_eq!(
        solve(&vector, &["--format", "block"]),
        expect(3, "default", "sym-block-3x3")
    );
    assert_eq!(solve(&scalar, &[]), expect(1, "default", "csr"));
    assert_eq!(
        solve(&scalar, &["--block-size", "3"]),
        expect(3, "flag", "sym-block-3x3")
    );
    assert_eq!(
        solve(&scalar, &["--format", "csr"]),
        expect(1, "default", "csr")
    );
}

/// 2D linear elasticity (plane stress, E = 1, nu = 0.3) with bilinear
/// elements on an `m x m` grid of the unit square, the nodes of the left
/// edge clamped (identity rows and columns); unknowns `(u_x, u_y)` per
/// node. The dense matrix.
fn elasticity_2d(m: usize) -> Vec<Vec<f64>> {
    let (e, nu) = (1.0, 0.3);
    let h = 1.0 / m as f64;
    let c = e / (1.0 - nu * nu);
    let d = [
        [c, c * nu, 0.0],
        [c * nu, c, 0.0],
        [0.0, 0.0, e / (2.0 * (1.0 + nu))],
    ];
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    // Element stiffness by 2 x 2 Gauss quadrature: sum B^T D B det J.
    let mut ke = [[0.0; 8]; 8];
    let g = 1.0 / 3.0_f64.sqrt();
    for (xi, eta) in [(-g, -g), (g, -g), (g, g), (-g, g)] {
        let mut bm = [[0.0; 8]; 3];
        for (a, &(xa, ya)) in corners.iter().enumerate() {
            let dx = xa * (1.0 + eta * ya) / 2.0 / h;
            let dy = ya * (1.0 + xi * xa) / 2.0 / h;
            bm[0][2 * a] = dx;
            bm[1][2 * a + 1] = dy;
            bm[2][2 * a] = dy;
            bm[2][2 * a + 1] = dx;
        }
        for r in 0..8 {
            for s in 0..8 {
                for p in 0..3 {
                    for q in 0..3 {
                        ke[r][s] += bm[p][r] * d[p][q] * bm[q][s] * h * h / 4.0;
                    }
                }
            }
        }
    }
    let nodes = m + 1;
    let n = 2 * nodes * nodes;
    let mut a = vec![vec![0.0; n]; n];
    for el in 0..m * m {
        let (ex, ey) = (el % m, el / m);
        let v = [
            ey * nodes + ex,
            ey * nodes + ex + 1,
            (ey + 1) * nodes + ex + 1,
            (ey + 1) * nodes + ex,
        ];
        for r in 0..8 {
            for s in 0..8 {
                a[2 * v[r / 2] + r % 2][2 * v[s / 2] + s % 2] += ke[r][s];
            }
        }
    }
    for i in (0..n).filter(|i| (i / 2) % nodes == 0) {
        for j in 0..n {
            a[i][j] = 0.0;
            a[j][i] = 0.0;
        }
        a[i][i] = 1.0;
    }
    a
}

/// The dense matrix of [`grid_system`].
fn dense_of(mtx: &str) -> Vec<Vec<f64>> {
    let mut lines = mtx.lines().filter(|l| !l.starts_with('%'));
    let n: usize = lines
        .next()
        .unwrap()
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let mut a = vec![vec![0.0; n]; n];
    for l in lines {
        let w: Vec<&str> = l.split_whitespace().collect();
        let (r, c, v): (usize, usize, f64) = (
            w[0].parse().unwrap(),
            w[1].parse().unwrap(),
            w[2].parse().unwrap(),
        );
        a[r - 1][c - 1] = v;
        a[c - 1][r - 1] = v;
    }
    a
}

/// A dense matrix as Matrix Market (lower triangle, symmetric).
fn mtx_of(a: &[Vec<f64>]) -> String {
    let n = a.len();
    let entries: Vec<String> = (0..n)
        .flat_map(|r| (0..=r).map(move |c| (r, c)))
        .filter(|&(r, c)| a[r][c] != 0.0)
        .map(|(r, c)| format!("{} {} {:e}", r + 1, c + 1, a[r][c]))
        .collect();
    format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n{}\n",
        entries.len(),
        entries.join("\n")
    )
}

/// Textbook PCG from x = 0 on dense `a` with the block-diagonal
/// preconditioner of nodes of `d` unknowns, each block inverted by
/// Gauss-Jordan elimination: the iterations to `|r| <= rtol |b|`.
fn dense_block_jacobi_pcg(a: &[Vec<f64>], b: &[f64], d: usize, rtol: f64) -> usize {
    let n = a.len();
    let mut inv = vec![vec![0.0; d]; n];
    for node in 0..n / d {
        let o = node * d;
        let mut m: Vec<Vec<f64>> = (0..d)
            .map(|r| {
                let mut row: Vec<f64> = (0..d).map(|c| a[o + r][o + c]).collect();
                row.extend((0..d).map(|c| f64::from(c == r)));
                row
            })
            .collect();
        for k in 0..d {
            let pivot = m[k][k];
            m[k].iter_mut().for_each(|v| *v /= pivot);
            for r in (0..d).filter(|&r| r != k) {
                let f = m[r][k];
                for c in 0..2 * d {
                    m[r][c] -= f * m[k][c];
                }
            }
        }
        for r in 0..d {
            inv[o + r] = m[r][d..].to_vec();
        }
    }
    let precond = |r: &[f64]| -> Vec<f64> {
        (0..n)
            .map(|i| {
                let o = i / d * d;
                (0..d).map(|c| inv[i][c] * r[o + c]).sum()
            })
            .collect()
    };
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(x, y)| x * y).sum::<f64>();
    let b_norm = dot(b, b).sqrt();
    let mut r = b.to_vec();
    let mut z = precond(&r);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    for k in 0..10 * n {
        if dot(&r, &r).sqrt() <= rtol * b_norm {
            return k;
        }
        let q: Vec<f64> = a.iter().map(|row| dot(row, &p)).collect();
        let alpha = rz / dot(&p, &q);
        for i in 0..n {
            r[i] -= alpha * q[i];
        }
        z = precond(&r);
        let rz_new = dot(&r, &z);
        for i in 0..n {
            p[i] = z[i] + rz_new / rz * p[i];
        }
        rz = rz_new;
    }
    panic!("dense PCG did not converge");
}

/// `a` with `0.3 (i mod 7)` added to its diagonal: still SPD on the same
/// pattern, but no longer a Kronecker product (whose block-Jacobi PCG ends
/// in as many iterations as the grid factor has distinct eigenvalues).
fn uneven(mut a: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += 0.3 * (i % 7) as f64;
    }
    a
}

/// Block Jacobi with no flags on a scalar grid (36 unknowns: 1 per node,
/// scalar storage), 2D elasticity (2 per node, detected) and a 3D vector
/// grid (3 per node, block storage) takes the iterations of a dense
/// block-Jacobi PCG with those nodes.
#[test]
fn block_jacobi_takes_the_unknowns_per_node_of_the_system() {
    let rtol = 1e-8;
    for (name, a, d, format) in [
        ("scalar", dense_of(&grid_system(6, 1)), 1, "csr"),
        ("elasticity2d", elasticity_2d(6), 2, "csr"),
        (
            "vector3d",
            uneven(dense_of(&grid_system(4, 3))),
            3,
            "sym-block-3x3",
        ),
    ] {
        let n = a.len();
        let path = scratch(&format!("bj-{name}.mtx"), &mtx_of(&a));
        // b = A * ones, as `hookean solve` takes without --rhs.
        let b: Vec<f64> = a.iter().map(|row| row.iter().sum()).collect();
        let out = hookean(&[
            "solve",
            &path,
            "--precond",
            "block-jacobi",
            "--rtol",
            "1e-8",
        ]);
        assert_ok(&out);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["converged"], true, "{name}: {v}");
        assert_eq!(v["block_size"], d as u64, "{name}: {v}");
        assert_eq!(v["format"], format, "{name}: {v}");
        let expected = dense_block_jacobi_pcg(&a, &b, d, rtol);
        assert!(expected >= 5, "{name}: {expected} iterations test nothing");
        assert_eq!(
            v["iterations"], expected as u64,
            "{name} ({n} unknowns): {v}"
        );
    }
}
