//! The command line fuzzed (issue 28): generated argument lists and
//! environments (`hookean_testkit::fuzz::invocation`: every subcommand, its
//! flags with odd numbers, names, windows, paths and scene overrides,
//! `--threads` and `RAYON_NUM_THREADS`), each run as a process under the
//! catalogue's memory cap. Every one ends within the time limit with exit
//! 0, 1 or 2, never a panic or an abort; bad input is one `hookean: error:`
//! line; no staging folder is left or named. The long run sets the count:
//! `HOOKEAN_FUZZ_CLI_CASES=20000 cargo test --release -p hookean-suite --test catalogue generated`.

use std::time::{Duration, Instant};

use hookean_testkit::fuzz::invocation;

use crate::{CLOTH, SPD, case_dir, has_long_number, hookean, leftovers, names_hidden_entry};

/// Cases per `cargo test` run (`HOOKEAN_FUZZ_CLI_CASES` sets another count).
const CASES: u64 = 200;
/// Wall-clock limit of one case.
const LIMIT: Duration = Duration::from_secs(60);

/// The inputs a generated line may name (some missing, some of the wrong kind).
const INPUTS: &[(&str, &str)] = &[
    ("s.toml", CLOTH),
    (
        "rope.toml",
        "duration = 0.05\n[rope]\nn = 5\n[output]\nframe_rate = 0\nwidth = 8\nheight = 8\n",
    ),
    ("a.mtx", SPD),
    ("bad.toml", "[cloth\nn = "),
];

/// Runs generated line `seed`; returns its exit code, or what went wrong.
pub(crate) fn check_invocation(seed: u64) -> Result<i32, String> {
    let dir = case_dir(&format!("fuzz-{seed}"));
    for (name, text) in INPUTS {
        std::fs::write(dir.join(name), text).unwrap();
    }
    let names: Vec<&str> = INPUTS
        .iter()
        .map(|(n, _)| *n)
        .chain(["none.toml", "."])
        .collect();
    let inv = invocation(seed, &dir.to_string_lossy(), &names);
    let mut command = hookean(&dir, &inv.args);
    command.env_remove("RAYON_NUM_THREADS");
    for (k, v) in &inv.env {
        command.env(k, v);
    }
    let mut child = command.spawn().unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > LIMIT {
            let _ = child.kill();
            return Err(format!("{inv:?}: still running after {LIMIT:?}"));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let mut problems = Vec::new();
    match out.status.code() {
        Some(0 | 1) => {}
        Some(2) => {
            if !(stderr.starts_with("hookean: error: ") && stderr.trim_end().lines().count() == 1) {
                problems.push("bad input is not one 'hookean: error:' line".to_string());
            }
        }
        other => problems.push(format!("exit {other:?}")),
    }
    if stderr.contains("panicked") || stderr.contains("memory allocation") {
        problems.push("a panic or an abort".into());
    }
    let given: Vec<&str> = inv
        .args
        .iter()
        .chain(inv.env.iter().map(|(_, v)| v))
        .map(String::as_str)
        .collect();
    if has_long_number(&stderr, &given) {
        problems.push("a message prints a number of 20 or more digits".into());
    }
    if names_hidden_entry(&stderr) || !leftovers(&dir).is_empty() {
        problems.push("a staging folder named or left".into());
    }
    let _ = std::fs::remove_dir_all(&dir);
    if problems.is_empty() {
        Ok(out.status.code().unwrap_or(-1))
    } else {
        Err(format!(
            "{inv:?}: {}\n  stderr: {}",
            problems.join("; "),
            stderr.trim_end()
        ))
    }
}

#[test]
fn generated_command_lines_end_with_a_contract_exit_code() {
    let cases = std::env::var("HOOKEAN_FUZZ_CLI_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(CASES);
    let next = std::sync::atomic::AtomicU64::new(0);
    let failures = std::sync::Mutex::new(Vec::new());
    let codes = std::sync::Mutex::new([0usize; 3]);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                loop {
                    let seed = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if seed >= cases {
                        break;
                    }
                    match check_invocation(seed) {
                        Ok(code) => codes.lock().unwrap()[code as usize] += 1,
                        Err(e) => failures.lock().unwrap().push(e),
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    let codes = codes.into_inner().unwrap();
    eprintln!("exit codes 0 / 1 / 2 of {cases} lines: {codes:?}");
    // The generator reaches successes, failed runs and refusals alike.
    assert!(codes.iter().all(|&c| c > 0), "{codes:?}");
    assert!(
        failures.is_empty(),
        "{} of {cases}:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
