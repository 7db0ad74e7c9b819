//! Writes the implicit-Euler system of the reference cloth (A.mtx, b.mtx),
//! the bundled example of `hookean solve`:
//!
//! ```text
//! cargo run -p hookean-testkit --example write_cloth_system -- N OUT_PREFIX [--force]
//! ```
//!
//! writes `OUT_PREFIX-A.mtx` (symmetric coordinate) and `OUT_PREFIX-b.mtx`.
//! Run again, it replaces the files it wrote before (they carry its comment
//! line) and keeps any other file at those paths unless `--force` is given.

use std::process::ExitCode;

use hookean_io::{Written, has_banner_mark, with_banner_mark, write_own};

use hookean_sparse::{write_matrix_market, write_vector_market};
use hookean_testkit::cloth::{ClothSystemParams, cloth_system};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let force = args.iter().any(|a| a == "--force");
    let pos: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let (Some(n), Some(prefix)) = (
        pos.first().and_then(|s| s.parse::<usize>().ok()),
        pos.get(1),
    ) else {
        eprintln!("usage: write_cloth_system N OUT_PREFIX [--force]");
        return ExitCode::from(2);
    };
    let (a, b) = cloth_system(&ClothSystemParams {
        n,
        ..Default::default()
    });
    let a_path = format!("{prefix}-A.mtx");
    let b_path = format!("{prefix}-b.mtx");
    let write = || -> Result<Vec<Written>, Box<dyn std::error::Error>> {
        let mut ma = Vec::new();
        write_matrix_market(&mut ma, &a.to_csr(), true)?;
        let mut mb = Vec::new();
        write_vector_market(&mut mb, &b)?;
        let mut out = Vec::new();
        for (path, content) in [(&a_path, ma), (&b_path, mb)] {
            out.push(write_own(
                path,
                &with_banner_mark(&content, MARK),
                |old| has_banner_mark(old, MARK),
                force,
            )?);
        }
        Ok(out)
    };
    match write() {
        Ok(w) => {
            let verb = if w.iter().all(|w| *w == Written::Unchanged) {
                "kept (unchanged)"
            } else {
                "wrote"
            };
            println!("{verb} {a_path} ({} rows) and {b_path}", a.dim());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// The comment line that marks a file as this example's own.
const MARK: &[u8] = b"% written by hookean-testkit's example write_cloth_system\n";
