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
