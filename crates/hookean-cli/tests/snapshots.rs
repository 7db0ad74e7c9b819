//! Snapshots (insta) of the numbers the command prints for users: the
//! per-preconditioner JSON of `solve` and the `summary.json` of `run`, with
//! the wall-clock fields and paths removed (times belong to benchmarks) and
//! real numbers rounded to 6 significant digits (their last bits depend on
//! the build's instruction set). A change in an iteration count is a
//! reviewed diff of `tests/snapshots/`.

mod common;

use common::{assert_ok, hookean, repo, run_scene};

/// The JSON fields that measure time or name this machine's paths.
const UNSTABLE: [&str; 7] = [
    "setup_s",
    "solve_s",
    "wall_s",
    "phases_s",
    "simulated_s_per_wall_s",
    "scene",
    "matrix",
];

/// `value` with the unstable fields removed and real numbers rounded to 6
/// significant digits, one key per line.
fn stable(value: &serde_json::Value) -> String {
    let mut v = value.clone();
    if let Some(map) = v.as_object_mut() {
        for key in UNSTABLE {
            map.remove(key);
        }
        for x in map.values_mut() {
            if let Some(f) = x.as_f64().filter(|_| x.is_f64()) {
                *x = serde_json::Value::String(format!("{f:.5e}"));
            }
        }
    }
    serde_json::to_string_pretty(&v).expect("JSON")
}

#[test]
fn solve_reports_every_preconditioner() {
    let out = hookean(&[
        "solve",
        &repo("data/cloth16-A.mtx"),
        "--rhs",
        &repo("data/cloth16-b.mtx"),
        "--precond",
        "all",
    ]);
    assert_ok(&out);
    let lines: Vec<String> = String::from_utf8(out.stdout)
        .expect("UTF-8")
        .lines()
        .map(|l| stable(&serde_json::from_str(l).expect("one JSON object per line")))
        .collect();
    insta::assert_snapshot!(lines.join("\n"));
}

#[test]
fn run_summary_of_a_small_drape() {
    let dir = std::env::temp_dir().join(format!("hookean-snapshot-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let summary = run_scene(
        &dir,
        "scenes/drape.toml",
        &[
            "cloth.n=12".to_string(),
            "duration=0.3".to_string(),
            "threads=1".to_string(),
        ],
    );
    let _ = std::fs::remove_dir_all(&dir);
    insta::assert_snapshot!(stable(&summary));
}
