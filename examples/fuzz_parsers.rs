//! The parsers' long fuzz run (docs/RELIABILITY.md): `N` mutated files
//! (`hookean_testkit::fuzz`, seeds 0..N) for each of the Matrix Market
//! reader, the OBJ reader with the mesh builder and the scene parser, and
//! `M` (default N / 100) scenes also built within 64 MiB and stepped twice
//! when they have at most 400 particles (a build and two steps cost
//! milliseconds, a parse microseconds).
//! Counts accepted and refused inputs, panics (caught, each one a failure)
//! and the slowest case; exits 1 on any panic or a case over 10 s.
//!
//! ```text
//! cargo run --release -p hookean-suite --example fuzz_parsers -- 1000000 [M]
//! ```

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use hookean::massspring::{MeshParams, from_mesh, parse_obj};
use hookean::scene::Scene;
use hookean::sparse::{ReadOptions, read_matrix_market_with};
use hookean_cli::scene::ProgramKeys;
use hookean_testkit::fuzz::mutate;

const MTX: &[&str] = &[
    "%%MatrixMarket matrix coordinate real symmetric\n% a comment\n3 3 5\n1 1 4\n2 1 1\n2 2 3\n3 2 -1\n3 3 2\n",
    "%%MatrixMarket matrix coordinate real general\n2 3 3\n1 1 1.5\n2 3 -2e-3\n1 2 7\n",
    "%%MatrixMarket matrix array real general\n3 1\n1\n2\n3\n",
];
const OBJ: &[&str] = &[
    "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nf 1/1/1 2/1/1 3/1/1\nf 1 3 4\n",
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf -4 -3 -2\nf 1 2 4\nf 1 3 4\nf 2 3 4\n",
];
const SCENES: &[&str] = &[
    include_str!("../scenes/drape.toml"),
    include_str!("../scenes/rope.toml"),
    include_str!("../scenes/jelly.toml"),
    include_str!("../scenes/cloth-sphere.toml"),
    include_str!("../scenes/drape-filtered.toml"),
    include_str!("../scenes/tutorial1.toml"),
];

/// Outcomes of one parser's run.
#[derive(Default)]
struct Tally {
    accepted: u64,
    refused: u64,
    panics: Vec<u64>,
    slowest: (Duration, u64),
}

fn fuzz(name: &str, valid: &[&str], n: u64, parse: impl Fn(&[u8]) -> bool) -> Tally {
    let mut t = Tally::default();
    let start = Instant::now();
    for seed in 0..n {
        let bytes = mutate(valid[(seed % valid.len() as u64) as usize].as_bytes(), seed);
        let t0 = Instant::now();
        match catch_unwind(AssertUnwindSafe(|| parse(&bytes))) {
            Ok(true) => t.accepted += 1,
            Ok(false) => t.refused += 1,
            Err(_) => t.panics.push(seed),
        }
        let dt = t0.elapsed();
        if dt > t.slowest.0 {
            t.slowest = (dt, seed);
        }
        if (seed + 1) % 100_000 == 0 {
            eprintln!(
                "{name}: {} cases, {:.0} s",
                seed + 1,
                start.elapsed().as_secs_f64()
            );
        }
    }
    println!(
        "| {name} | {n} | {} | {} | {} | {:.1} ms (seed {}) | {:.0} s |",
        t.accepted,
        t.refused,
        t.panics.len(),
        t.slowest.0.as_secs_f64() * 1e3,
        t.slowest.1,
        start.elapsed().as_secs_f64()
    );
    t
}

fn main() -> ExitCode {
    let arg = |i: usize| std::env::args().nth(i).map(|a| a.parse::<u64>());
    let (n, m) = match (arg(1), arg(2)) {
        (None, None) => (1_000_000, 10_000),
        (Some(Ok(n)), None) => (n, n / 100),
        (Some(Ok(n)), Some(Ok(m))) => (n, m),
        _ => {
            eprintln!("usage: fuzz_parsers [CASES_PER_PARSER [SCENES_BUILT]]");
            return ExitCode::from(2);
        }
    };
    // A panic is counted, not printed a million times.
    std::panic::set_hook(Box::new(|_| {}));
    println!(
        "| parser | cases | accepted | refused (typed error) | panics | slowest case | wall |"
    );
    println!("|---|---|---|---|---|---|---|");
    let opts = ReadOptions {
        max_bytes: 1 << 20,
        max_line_bytes: 1 << 16,
        ..Default::default()
    };
    let tallies = [
        fuzz("Matrix Market", MTX, n, |b| {
            read_matrix_market_with(b, &opts).is_ok_and(|m| {
                m.into_csr();
                true
            })
        }),
        fuzz("OBJ + mesh builder", OBJ, n, |b| {
            parse_obj(b).is_ok_and(|mesh| from_mesh(&mesh, &MeshParams::default()).is_ok())
        }),
        fuzz("scene TOML (parse)", SCENES, n, |b| {
            std::str::from_utf8(b)
                .is_ok_and(|text| Scene::parse_with::<ProgramKeys>("s.toml", text, &[]).is_ok())
        }),
        fuzz("scene TOML + build + 2 steps", SCENES, m, |b| {
            let Ok(text) = std::str::from_utf8(b) else {
                return false;
            };
            let Ok((scene, program)) = Scene::parse_with::<ProgramKeys>("s.toml", text, &[]) else {
                return false;
            };
            if program.tutorial.is_some() {
                return true;
            }
            let Ok(mut sim) = scene.build_within(64 << 20) else {
                return false;
            };
            sim.model().n_particles() > 400 || (sim.step().is_ok() && sim.step().is_ok())
        }),
    ];
    let bad = tallies
        .iter()
        .any(|t| !t.panics.is_empty() || t.slowest.0 > Duration::from_secs(10));
    for t in &tallies {
        if !t.panics.is_empty() {
            eprintln!("panicking seeds: {:?}", &t.panics[..t.panics.len().min(20)]);
        }
    }
    if bad {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}
