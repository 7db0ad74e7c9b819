//! Mutations of valid input files, for the parser fuzz tests (Matrix
//! Market, OBJ, scene TOML) and the million-case run
//! (`cargo run --release -p hookean-suite --example fuzz_parsers`,
//! docs/RELIABILITY.md): bit flips, truncation, huge and odd numbers in
//! place of numbers, duplicated, deleted and reordered lines, random bytes.

use rand::{Rng, SeedableRng, rngs::SmallRng};

/// Numbers an adversary writes: huge, tiny, signed zero, non-finite, past
/// 32 and 64 bits, negative where a count is expected.
pub const ODD_NUMBERS: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    "1e-320",
    "NaN",
    "inf",
    "-inf",
    "4294967296",
    "18446744073709551615",
    "18446744073709551616",
    "99999999999999999999999999",
    "100000",
    "0x10",
    "1.5",
    "",
];

/// The mutation `seed` makes of `valid`: one to four edits, chosen and
/// placed by a generator seeded with `seed` (the same seed, the same
/// bytes).
pub fn mutate(valid: &[u8], seed: u64) -> Vec<u8> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut bytes = valid.to_vec();
    for _ in 0..rng.random_range(1..=4) {
        bytes = edit(bytes, &mut rng);
    }
    bytes
}

fn edit(mut bytes: Vec<u8>, rng: &mut SmallRng) -> Vec<u8> {
    let len = bytes.len();
    match rng.random_range(0..8) {
        // A bit flip.
        0 if len > 0 => {
            let i = rng.random_range(0..len);
            bytes[i] ^= 1 << rng.random_range(0..8);
            bytes
        }
        // Truncation.
        1 => {
            bytes.truncate(rng.random_range(0..=len));
            bytes
        }
        // Random bytes inserted (not always UTF-8).
        2 => {
            let at = rng.random_range(0..=len);
            let extra: Vec<u8> = (0..rng.random_range(1..8)).map(|_| rng.random()).collect();
            bytes.splice(at..at, extra);
            bytes
        }
        // An odd number in place of a number (or of any token).
        3 | 4 => replace_token(&bytes, rng),
        // Line edits: duplicate, delete, swap.
        _ => {
            let text = String::from_utf8_lossy(&bytes).into_owned();
            let mut lines: Vec<&str> = text.lines().collect();
            if lines.is_empty() {
                return bytes;
            }
            let i = rng.random_range(0..lines.len());
            let j = rng.random_range(0..lines.len());
            match rng.random_range(0..3) {
                0 => {
                    let copies = rng.random_range(1..4);
                    for _ in 0..copies {
                        lines.insert(j, lines[i]);
                    }
                }
                1 => {
                    lines.remove(i);
                }
                _ => lines.swap(i, j),
            }
            (lines.join("\n") + "\n").into_bytes()
        }
    }
}

/// Replaces one whitespace- or punctuation-delimited token, preferring
/// numbers, by one of [`ODD_NUMBERS`].
fn replace_token(bytes: &[u8], rng: &mut SmallRng) -> Vec<u8> {
    let is_sep = |b: u8| b.is_ascii_whitespace() || b"=,[]\"".contains(&b);
    let mut tokens = Vec::new();
    let mut start = None;
    for (i, &b) in bytes.iter().enumerate() {
        match (start, is_sep(b)) {
            (None, false) => start = Some(i),
            (Some(s), true) => {
                tokens.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        tokens.push(s..bytes.len());
    }
    let numeric: Vec<_> = tokens
        .iter()
        .filter(|r| {
            bytes[r.start].is_ascii_digit() || bytes[r.start] == b'-' || bytes[r.start] == b'.'
        })
        .cloned()
        .collect();
    let pool = if numeric.is_empty() || rng.random_bool(0.1) {
        tokens
    } else {
        numeric
    };
    if pool.is_empty() {
        return bytes.to_vec();
    }
    let r = pool[rng.random_range(0..pool.len())].clone();
    let odd = ODD_NUMBERS[rng.random_range(0..ODD_NUMBERS.len())].as_bytes();
    let mut out = bytes[..r.start].to_vec();
    out.extend_from_slice(odd);
    out.extend_from_slice(&bytes[r.end..]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutations_are_deterministic_and_change_the_input() {
        let valid = b"%%MatrixMarket matrix coordinate real symmetric\n2 2 2\n1 1 4\n2 2 3\n";
        assert_eq!(mutate(valid, 7), mutate(valid, 7));
        let changed = (0..200).filter(|&s| mutate(valid, s) != valid).count();
        assert!(changed > 180, "{changed} of 200 mutations changed the file");
        // Every kind of edit occurs: some outputs are shorter, some longer,
        // some carry an odd number.
        let outs: Vec<Vec<u8>> = (0..200).map(|s| mutate(valid, s)).collect();
        assert!(outs.iter().any(|o| o.len() < valid.len()));
        assert!(outs.iter().any(|o| o.len() > valid.len()));
        assert!(outs.iter().any(|o| o.windows(4).any(|w| w == b"1e30")));
    }
}

/// One generated command line of `hookean`: arguments and environment.
#[derive(Debug, Clone, PartialEq)]
pub struct Invocation {
    /// The arguments (without the program name).
    pub args: Vec<String>,
    /// Environment variables to set.
    pub env: Vec<(String, String)>,
}

/// Every subcommand with its flags: `(flag, takes a value)`.
const COMMANDS: &[(&str, &[(&str, bool)])] = &[
    (
        "run",
        &[
            ("--out", true),
            ("--set", true),
            ("--force", false),
            ("--quiet", false),
            ("--max-memory", true),
            ("--max-work", true),
        ],
    ),
    (
        "solve",
        &[
            ("--rhs", true),
            ("--precond", true),
            ("--omega", true),
            ("--rtol", true),
            ("--max-iter", true),
            ("--repeat", true),
            ("--amg-smoother", true),
            ("--format", true),
            ("--block-size", true),
        ],
    ),
    (
        "workprecision",
        &[
            ("--problem", true),
            ("--methods", true),
            ("--out", true),
            ("--plot", true),
            ("--lambda", true),
            ("--levels", true),
            ("--n0", true),
            ("--force", false),
            ("--max-work", true),
        ],
    ),
    (
        "stability",
        &[
            ("--methods", true),
            ("--plot", true),
            ("--re", true),
            ("--im", true),
            ("--resolution", true),
            ("--force", false),
        ],
    ),
    (
        "bench-precond",
        &[
            ("--n", true),
            ("--k", true),
            ("--precond", true),
            ("--rtol", true),
            ("--max-iter", true),
            ("--repeat", true),
        ],
    ),
    (
        "export-system",
        &[
            ("--at", true),
            ("--out", true),
            ("--set", true),
            ("--force", false),
            ("--max-work", true),
        ],
    ),
    (
        "filter-analysis",
        &[
            ("--plot", true),
            ("--n", true),
            ("--t-end", true),
            ("--step-fraction", true),
            ("--force", false),
            ("--max-work", true),
        ],
    ),
    ("view", &[("--force", false)]),
    ("scene-keys", &[]),
    (
        "reproduce",
        &[
            ("--paper", true),
            ("--out", true),
            ("--quick", false),
            ("--claims", true),
            ("--force", false),
        ],
    ),
];

/// Values a flag is given: odd numbers, names, lists, windows, paths.
const VALUES: &[&str] = &[
    "1",
    "2",
    "3",
    "4",
    "8",
    "0.5",
    "1e-3",
    "1024",
    "1025",
    "1e9",
    "1e15",
    "1e16",
    "all",
    "none,jacobi",
    "amg",
    "direct",
    "mic0",
    "block",
    "csr",
    "tutorial1",
    "tutorial3",
    "wave",
    "rk4,bdf2-variable",
    "implicit-euler",
    "-5,3",
    "3,-5",
    "-1e308,1e308",
    "1,2,3",
    "tutorial",
    "filter",
    "block-jacobi",
    "ic0",
];

/// Scene overrides `--set` is given.
const SETS: &[&str] = &[
    "cloth.n=4",
    "cloth.n=1000000000",
    "duration=0.02",
    "duration=1e300",
    "integrator.method=fb-euler",
    "integrator.method=bdf2-variable",
    "integrator.h=1e-9",
    "integrator.h=auto",
    "solver.max_newton=1000",
    "solver.max_cg=1",
    "solver.preconditioner=amg",
    "solver.amg.sweeps=100",
    "output.frame_rate=1e6",
    "output.width=16384",
    "threads=1024",
    "model.gravity=[0,0,-9.81,1]",
    "cloth.origin=[1e308,0,0]",
    "cloth.stiffness=1e300",
    "filter.rings=1000000",
    "nonsense",
    "cloth.k=1",
];

/// The command line `seed` makes (the same seed, the same line): a
/// subcommand, a positional input from `inputs` (files of the case's
/// folder, some missing, some not what the command reads), one to six
/// flags with values from `VALUES`, `ODD_NUMBERS` or `--set`
/// overrides, sometimes `--threads` and `RAYON_NUM_THREADS`. Outputs go
/// to `out/...` paths of the case's folder (`dir`).
pub fn invocation(seed: u64, dir: &str, inputs: &[&str]) -> Invocation {
    let mut rng = SmallRng::seed_from_u64(seed);
    let (command, flags) = COMMANDS[rng.random_range(0..COMMANDS.len())];
    let mut args = Vec::new();
    if rng.random_bool(0.2) {
        args.push("--threads".to_string());
        args.push(pick_value(&mut rng));
    }
    args.push(command.to_string());
    let positional = matches!(
        command,
        "run" | "solve" | "export-system" | "filter-analysis" | "view"
    );
    if positional && rng.random_bool(0.95) {
        args.push(format!(
            "{dir}/{}",
            inputs[rng.random_range(0..inputs.len())]
        ));
    }
    for _ in 0..rng.random_range(0..=6) {
        if flags.is_empty() {
            break;
        }
        let (flag, takes_value) = flags[rng.random_range(0..flags.len())];
        args.push(flag.to_string());
        if takes_value {
            args.push(match flag {
                "--set" => SETS[rng.random_range(0..SETS.len())].to_string(),
                "--out" | "--plot" => format!(
                    "{dir}/out/{}",
                    ["a", "b.csv", "c.svg", "../out/a", "x/y/z"][rng.random_range(0..5)]
                ),
                "--rhs" => format!("{dir}/{}", inputs[rng.random_range(0..inputs.len())]),
                _ => pick_value(&mut rng),
            });
        }
    }
    // Work stays short unless the line asks otherwise: small defaults the
    // fuzz run can afford where the line leaves a flag out.
    let defaults: &[(&str, &str)] = match command {
        "run" | "workprecision" | "export-system" => &[("--max-work", "1e7")],
        "filter-analysis" => &[("--max-work", "1e7"), ("--n", "4"), ("--t-end", "0.05")],
        "bench-precond" => &[("--n", "4"), ("--k", "1e4")],
        "reproduce" => &[("--claims", "2"), ("--quick", "")],
        _ => &[],
    };
    for (flag, value) in defaults {
        if !args.iter().any(|a| a == flag) {
            args.push(flag.to_string());
            if !value.is_empty() {
                args.push(value.to_string());
            }
        }
    }
    let mut env = Vec::new();
    if rng.random_bool(0.2) {
        env.push(("RAYON_NUM_THREADS".to_string(), pick_value(&mut rng)));
    }
    Invocation { args, env }
}

fn pick_value(rng: &mut SmallRng) -> String {
    if rng.random_bool(0.5) {
        VALUES[rng.random_range(0..VALUES.len())].to_string()
    } else {
        ODD_NUMBERS[rng.random_range(0..ODD_NUMBERS.len())].to_string()
    }
}
