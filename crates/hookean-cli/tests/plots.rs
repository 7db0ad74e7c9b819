//! `hookean workprecision` and `hookean stability` end to end: the files
//! they promise, errors that fall with h for convergent methods, and bad
//! input as one line on stderr with exit code 2.

mod common;
use common::*;

use std::path::PathBuf;

/// A fresh scratch folder per test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-cli-plots-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn s(p: &std::path::Path) -> String {
    p.to_string_lossy().into_owned()
}

/// CSV rows as maps from header names to fields.
fn read_csv(path: &std::path::Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn col(header: &[String], name: &str) -> usize {
    header.iter().position(|h| h == name).unwrap()
}

#[test]
fn workprecision_on_the_wave_equation_writes_csv_and_svg_and_errors_fall_with_h() {
    let dir = scratch("wp3");
    let (csv, svg) = (dir.join("wp.csv"), dir.join("wp.svg"));
    let out = hookean(&[
        "workprecision",
        "--problem",
        "wave",
        "--methods",
        "rk4,verlet,implicit-euler",
        "--n0",
        "100",
        "--levels",
        "5",
        "--out",
        &s(&csv),
        "--plot",
        &s(&svg),
    ]);
    assert_ok(&out);
    let (header, rows) = read_csv(&csv);
    for name in [
        "method",
        "h",
        "error",
        "f_evals",
        "jacobian_evals",
        "linear_iterations",
        "wall_time_s",
    ] {
        assert!(header.iter().any(|h| h == name), "{name} in {header:?}");
    }
    // One row per (method, step size).
    assert_eq!(rows.len(), 3 * 5);
    let (m, h, e, f) = (
        col(&header, "method"),
        col(&header, "h"),
        col(&header, "error"),
        col(&header, "f_evals"),
    );
    // Figure 7's y'' = -5 y on [0, 10]: undamped, so Verlet has its full
    // order 2 and the errors are in the asymptotic regime from h = 0.1.
    for (method, order) in [("rk4", 4.0), ("verlet", 2.0), ("implicit-euler", 1.0)] {
        let r: Vec<&Vec<String>> = rows.iter().filter(|r| r[m] == method).collect();
        assert_eq!(r.len(), 5, "{method}");
        let hs: Vec<f64> = r.iter().map(|r| r[h].parse().unwrap()).collect();
        let errs: Vec<f64> = r.iter().map(|r| r[e].parse().unwrap()).collect();
        let work: Vec<u64> = r.iter().map(|r| r[f].parse().unwrap()).collect();
        // Step halvings from h = 10 / 100.
        assert!((hs[0] - 0.1).abs() < 1e-15);
        for w in hs.windows(2) {
            assert!((w[1] - w[0] / 2.0).abs() < 1e-15);
        }
        // More work, smaller error, at about the method's order over the
        // last halving (ratio 2^p, with slack for pre-asymptotic terms).
        for w in work.windows(2) {
            assert!(w[1] > w[0], "{method}: work {work:?}");
        }
        for w in errs.windows(2) {
            assert!(w[1] < w[0], "{method}: errors {errs:?}");
        }
        let ratio = errs[3] / errs[4];
        let p = ratio.log2();
        assert!(
            (p - order).abs() < 0.35,
            "{method}: observed order {p} from {errs:?}"
        );
    }
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<?xml") && text.trim_end().ends_with("</svg>"));
    // The first series (rk4) is drawn with circles: one per level, one in the legend.
    assert_eq!(text.matches("<circle").count(), 5 + 1);
    for name in ["rk4", "implicit-euler", "verlet", "f evaluations"] {
        assert!(text.contains(name), "{name} missing from the plot");
    }
    // The order table on stdout names every method.
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 2 + 3);
}

#[test]
fn workprecision_defaults_to_the_methods_that_apply() {
    let dir = scratch("wp1");
    let csv = dir.join("wp.csv");
    let out = hookean(&[
        "workprecision",
        "--problem",
        "tutorial1",
        "--lambda",
        "2",
        "--levels",
        "3",
        "--out",
        &s(&csv),
    ]);
    assert_ok(&out);
    let (header, rows) = read_csv(&csv);
    let m = col(&header, "method");
    let mut names: Vec<&str> = rows.iter().map(|r| r[m].as_str()).collect();
    names.dedup();
    // Every named method except the second-order-only FB Euler and Verlet.
    assert_eq!(names.len(), 14 - 2, "{names:?}");
    assert!(!names.contains(&"fb-euler") && !names.contains(&"verlet"));
    assert_eq!(rows.len(), 12 * 3);
    // Explicit Euler on y' = 2 y with h = 1/4: (1 + 1/2)^4 against e^2.
    let e = col(&header, "error");
    let first: f64 = rows[0][e].parse().unwrap();
    assert_eq!(rows[0][m], "explicit-euler");
    assert!(
        (first - (2f64.exp() - 1.5f64.powi(4))).abs() < 1e-12,
        "{first}"
    );
}

#[test]
fn workprecision_rejects_bad_input() {
    let dir = scratch("wpbad");
    let csv = s(&dir.join("wp.csv"));
    let out = hookean(&["workprecision", "--problem", "tutorial9", "--out", &csv]);
    assert_input_error(&out, "unknown problem 'tutorial9'");
    // Two outputs to one path (also spelled differently): refused before
    // anything is written.
    let dotted = s(&dir.join(".").join("wp.csv"));
    let out = hookean(&[
        "workprecision",
        "--problem",
        "tutorial1",
        "--out",
        &csv,
        "--plot",
        &dotted,
    ]);
    assert_input_error(&out, "the same file");
    assert!(!dir.join("wp.csv").exists());
    let out = hookean(&[
        "workprecision",
        "--problem",
        "tutorial2",
        "--methods",
        "rk4,euler-maruyama",
        "--out",
        &csv,
    ]);
    assert_input_error(&out, "euler-maruyama");
    let out = hookean(&[
        "workprecision",
        "--problem",
        "tutorial1",
        "--methods",
        "fb-euler",
        "--out",
        &csv,
    ]);
    assert_input_error(&out, "first order");
    assert!(!dir.join("wp.csv").exists(), "nothing written on bad input");
    // An existing file is kept unless --force.
    std::fs::write(dir.join("wp.csv"), "keep me").unwrap();
    let args = [
        "workprecision",
        "--problem",
        "tutorial2",
        "--methods",
        "rk4",
        "--levels",
        "2",
        "--out",
        &csv,
    ];
    assert_input_error(&hookean(&args), "exists");
    assert_eq!(
        std::fs::read_to_string(dir.join("wp.csv")).unwrap(),
        "keep me"
    );
    let mut forced = args.to_vec();
    forced.push("--force");
    assert_ok(&hookean(&forced));
    assert_eq!(read_csv(&dir.join("wp.csv")).1.len(), 2);
}

#[test]
fn stability_plot_has_a_panel_per_method_and_the_right_shading() {
    let dir = scratch("stab");
    let svg = dir.join("regions.svg");
    let out = hookean(&[
        "stability",
        "--methods",
        "explicit-euler,implicit-euler,bdf2",
        "--resolution",
        "81",
        "--plot",
        &s(&svg),
    ]);
    assert_ok(&out);
    let text = std::fs::read_to_string(&svg).unwrap();
    assert!(text.starts_with("<?xml") && text.trim_end().ends_with("</svg>"));
    // One panel per method (each with its axis titles), a boundary locus
    // (in red, BDF2 only) besides the legend's red sample line.
    assert_eq!(text.matches("\nRe z\n").count(), 3);
    assert_eq!(text.matches("\nIm z\n").count(), 3);
    for name in ["explicit-euler", "implicit-euler", "bdf2"] {
        assert!(text.contains(&format!("\n{name}\n")), "no panel {name}");
    }
    assert!(text.matches("stroke=\"#D62728\"").count() >= 2);
    // Stable fractions of the window [-5, 3] x [-4, 4] on stdout: explicit
    // Euler's disc |1 + z| <= 1 covers pi / 64 of it (about 0.049), implicit
    // Euler all but the disc |1 - z| < 1 (about 1 - pi / 64).
    let stdout = String::from_utf8(out.stdout).unwrap();
    let fraction = |name: &str| -> f64 {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("{name}:")))
            .unwrap();
        line.rsplit(' ').next().unwrap().parse().unwrap()
    };
    let disc = std::f64::consts::PI / 64.0;
    assert!((fraction("explicit-euler") - disc).abs() < 0.01);
    assert!((fraction("implicit-euler") - (1.0 - disc)).abs() < 0.01);
    // BDF2 is A-stable: at least the left half-plane (5/8 of the window).
    assert!(fraction("bdf2") > 0.625);
}

#[test]
fn stability_rejects_bad_input() {
    let dir = scratch("stabbad");
    let svg = s(&dir.join("r.svg"));
    assert_input_error(
        &hookean(&["stability", "--methods", "verlet", "--plot", &svg]),
        "second-order",
    );
    assert_input_error(
        &hookean(&["stability", "--methods", "rk5", "--plot", &svg]),
        "rk5",
    );
    assert_input_error(
        &hookean(&["stability", "--re", "3,-5", "--plot", &svg]),
        "--re",
    );
    std::fs::write(dir.join("r.svg"), "keep").unwrap();
    assert_input_error(
        &hookean(&["stability", "--methods", "rk4", "--plot", &svg]),
        "exists",
    );
    assert_eq!(std::fs::read_to_string(dir.join("r.svg")).unwrap(), "keep");
}
