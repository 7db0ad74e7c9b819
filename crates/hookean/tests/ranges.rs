//! Every documented range of a scene key, checked at its ends (issues 28
//! and 37): the ranges are read from the key listing (`scene::KEYS`,
//! generated from the keys' docs), so a range that is documented is a
//! range that is tested, and what the listing documents is what is checked.
//! Just outside a range the scene is refused naming the key and the range;
//! at and just inside its ends the scene parses and is built within 64 MiB
//! (a refusal there is a documented range that disagrees with a check
//! downstream: `integrator.rtol = 2` was refused by the integrator while
//! the listing said (0, inf)), and steps twice, ending in a step or a
//! failed run, never a panic, an abort, or a refusal of a parameter. The
//! keys of the variable-step methods are tried with `bdf` and
//! `bdf2-variable`, the methods that read them.

use hookean::HookeanError;
use hookean::scene::{KEYS, Scene};

/// A documented range.
#[derive(Debug, Clone, Copy)]
enum Range {
    /// `Range LO to HI` (integers).
    Int(u64, u64),
    /// `Range LO to the memory cap` (integers).
    IntToCap(u64),
    /// `Range (a, b)`, `[a, b]`, ... (floats; infinite ends allowed).
    Float {
        lo: f64,
        lo_closed: bool,
        hi: f64,
        hi_closed: bool,
    },
}

/// Every `(key, range)` of the listing.
fn documented() -> Vec<(String, Range)> {
    let mut out = Vec::new();
    let mut entries: Vec<(String, String)> = Vec::new();
    for line in KEYS.lines() {
        if let Some(key) = line.strip_prefix("  ").filter(|l| !l.starts_with(' ')) {
            entries.push((key.trim().to_string(), String::new()));
        } else if let Some((_, doc)) = entries.last_mut() {
            doc.push(' ');
            doc.push_str(line.trim());
        }
    }
    for (key, doc) in entries {
        let Some(at) = doc.find("Range ") else {
            continue;
        };
        let text = &doc[at + "Range ".len()..];
        let range = if let Some(rest) = text.strip_prefix(['(', '[']) {
            let close = rest.find([')', ']']).unwrap();
            let (a, b) = rest[..close].split_once(',').unwrap();
            let num = |t: &str| match t.trim() {
                "inf" => f64::INFINITY,
                "-inf" => f64::NEG_INFINITY,
                t => t.parse().unwrap(),
            };
            Range::Float {
                lo: num(a),
                lo_closed: text.starts_with('['),
                hi: num(b),
                hi_closed: rest.as_bytes()[close] == b']',
            }
        } else if let Some((lo, hi)) = text.split_once(" to ") {
            let lo: u64 = lo.trim().parse().unwrap();
            if hi.starts_with("the memory cap") {
                Range::IntToCap(lo)
            } else {
                let hi = hi.trim_start();
                let end = hi.find(|c: char| !c.is_ascii_digit()).unwrap_or(hi.len());
                Range::Int(lo, hi[..end].parse().unwrap())
            }
        } else {
            // "Range: any finite number."
            assert!(text.starts_with(": any finite"), "{key}: {text}");
            Range::Float {
                lo: f64::NEG_INFINITY,
                lo_closed: false,
                hi: f64::INFINITY,
                hi_closed: false,
            }
        };
        out.push((key, range));
    }
    out
}

/// The keys that only the variable-step methods read.
const VARIABLE_STEP_KEYS: &[&str] = &[
    "integrator.rtol",
    "integrator.atol",
    "integrator.h_max",
    "integrator.max_order",
    "integrator.max_steps",
];

/// The scenes that exercise `key`: [`base`], and for the keys of the
/// variable-step methods the same cloth under `bdf` and `bdf2-variable`.
fn bases(key: &str) -> Vec<String> {
    if VARIABLE_STEP_KEYS.contains(&key) {
        ["bdf", "bdf2-variable"]
            .iter()
            .map(|m| {
                format!(
                    "duration = 0.02\n[cloth]\nn = 3\n[output]\nframe_rate = 0\n[integrator]\nmethod = \"{m}\"\n"
                )
            })
            .collect()
    } else {
        vec![base(key).to_string()]
    }
}

/// The smallest scene that has `key`.
fn base(key: &str) -> &'static str {
    let table = key.split('.').next().unwrap();
    match table {
        "rope" => "duration = 0.02\n[rope]\nn = 3\n",
        // At the origin: a spacing below the round-off of the origin's
        // coordinates is a combination the build refuses naming [jelly].
        "jelly" => "duration = 0.02\n[jelly]\nn = [2, 2, 2]\norigin = [0, 0, 0]\n",
        "filter" => {
            "duration = 0.02\n[cloth]\nn = 3\n[integrator]\nmethod = \"fb-euler\"\nh = 1e-4\n[filter]\n"
        }
        "mesh" => concat!(
            "duration = 0.02\n[mesh]\npath = \"",
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/table.obj\"\n[output]\nframe_rate = 0\n"
        ),
        "contact" => {
            "duration = 0.02\n[cloth]\nn = 3\n[output]\nframe_rate = 0\n[contact]\nself_collision = true\n"
        }
        _ if key.starts_with("solver.amg.") => {
            "duration = 0.02\n[cloth]\nn = 3\n[solver]\npreconditioner = \"amg\"\n[solver.amg]\n"
        }
        _ => "duration = 0.02\n[cloth]\nn = 3\n[output]\nframe_rate = 0\n",
    }
}

/// TOML for a float (`inf`, `nan`, and exact shortest forms).
fn toml_float(v: f64) -> String {
    if v.is_nan() {
        "nan".into()
    } else if v.is_infinite() {
        if v > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        format!("{v:e}")
    }
}

/// The values just outside and just inside (or at) the ends of `range`.
fn probes(range: Range) -> (Vec<String>, Vec<String>) {
    let (mut refused, mut accepted) = (Vec::new(), Vec::new());
    match range {
        Range::Int(lo, hi) => {
            if lo > 0 {
                refused.push((lo - 1).to_string());
            }
            refused.push((hi + 1).to_string());
            refused.extend(["-1".into(), "18446744073709551616".into(), "1.5".into()]);
            accepted.extend([lo.to_string(), hi.to_string()]);
        }
        Range::IntToCap(lo) => {
            if lo > 0 {
                refused.push((lo - 1).to_string());
            }
            refused.extend(["-1".into(), "18446744073709551616".into()]);
            accepted.push(lo.to_string());
        }
        Range::Float {
            lo,
            lo_closed,
            hi,
            hi_closed,
        } => {
            refused.push("nan".into());
            for (end, closed, inward) in [(lo, lo_closed, 1.0), (hi, hi_closed, -1.0)] {
                if end.is_infinite() {
                    refused.push(toml_float(end));
                    accepted.push(toml_float(-inward * 1e300));
                    continue;
                }
                let step = |x: f64, dir: f64| {
                    if dir > 0.0 {
                        x.next_up()
                    } else {
                        x.next_down()
                    }
                };
                refused.push(toml_float(step(end, -inward)));
                if closed {
                    accepted.push(toml_float(end));
                } else {
                    refused.push(toml_float(end));
                    accepted.push(toml_float(step(end, inward)));
                }
            }
        }
    }
    (refused, accepted)
}

#[test]
fn every_documented_range_is_checked_at_its_ends() {
    let keys = documented();
    // Every numeric key documents its range (the count guards the parser).
    assert!(keys.len() >= 45, "{} documented ranges", keys.len());
    let mut failures = Vec::new();
    for (key, range) in &keys {
        for text in bases(key) {
            check_key(key, *range, &text, &mut failures);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The refusal text of a range as the listing writes it (`(0, inf)`,
/// `1 to 1000`), to find in the message.
fn range_words(range: Range) -> Option<String> {
    match range {
        Range::Int(lo, hi) => Some(format!("{lo} to {hi}")),
        Range::IntToCap(_) => None,
        Range::Float {
            lo,
            lo_closed,
            hi,
            hi_closed,
        } => {
            let end = |v: f64| {
                if v.is_infinite() {
                    if v > 0.0 { "inf".into() } else { "-inf".into() }
                } else {
                    format!("{v:e}").replace("e0", "")
                }
            };
            Some(format!(
                "{}{}, {}{}",
                if lo_closed { '[' } else { '(' },
                end(lo),
                end(hi),
                if hi_closed { ']' } else { ')' },
            ))
        }
    }
}

/// Probes `key` of the scene `text` at the ends of its documented `range`.
fn check_key(key: &str, range: Range, text: &str, failures: &mut Vec<String>) {
    let (refused, accepted) = probes(range);
    for value in &refused {
        let set = format!("{key}={value}");
        match Scene::with_overrides("s.toml", text, &[set.as_str()]) {
            Ok(_) => failures.push(format!("{set}: accepted, outside {range:?}")),
            Err(e) if !e.to_string().contains(&set) => {
                failures.push(format!("{set}: the error does not name it: {e}"))
            }
            // The refusal says the documented range (an integer key given
            // a fraction or a negative number says what it expected).
            Err(e) => {
                let a_number_of_its_kind = match range {
                    Range::Float { .. } => true,
                    _ => value.len() < 20 && value.chars().all(|c| c.is_ascii_digit()),
                };
                if let Some(words) = range_words(range).filter(|_| a_number_of_its_kind)
                    && !e.to_string().contains(&words)
                {
                    failures.push(format!("{set}: the error does not say {words}: {e}"))
                }
            }
        }
    }
    for value in &accepted {
        let set = format!("{key}={value}");
        let scene = match Scene::with_overrides("s.toml", text, &[set.as_str()]) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{set}: refused inside {range:?}: {e}"));
                continue;
            }
        };
        // Built within 64 MiB: a value inside its documented range builds
        // (or is too large for the cap); two steps end in a step or a
        // failed run, never a refused parameter.
        match scene.build_within(64 << 20) {
            Ok(mut sim) => {
                for _ in 0..2 {
                    match sim.step() {
                        Ok(_) => {}
                        Err(e) if refuses_a_parameter(&e) => {
                            failures.push(format!("{set}: a step refused a parameter: {e}"));
                            break;
                        }
                        Err(_) => break,
                    }
                }
            }
            Err(HookeanError::TooLarge { .. }) => {}
            // A bound the listing states as the model's (beyond the
            // number's own range): refused at build, naming the key and it.
            Err(e)
                if MODEL_BOUNDS.iter().any(|(k, why)| {
                    *k == key
                        && e.to_string()
                            .contains(key.rsplit('.').next().unwrap_or(key))
                        && e.to_string().contains(why)
                }) => {}
            Err(e) => failures.push(format!(
                "{set} ({}): inside {range:?} but refused when built: {e}",
                text.lines().last().unwrap_or("")
            )),
        }
    }
}

/// Keys whose documented range has, besides the number's own ends, a bound
/// set by the model (`hookean scene-keys` says so), with the words of that
/// bound in the build's refusal.
const MODEL_BOUNDS: &[(&str, &str)] = &[("contact.self_thickness", "smallest altitude")];

/// Whether `e` is a library's refusal of a parameter: a value the scene
/// let through that a crate below refused.
fn refuses_a_parameter(e: &HookeanError) -> bool {
    let text = e.to_string();
    text.contains("invalid parameter") || text.contains("::")
}
