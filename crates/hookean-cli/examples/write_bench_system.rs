//! Writes the systems of `hookean bench-precond` (A.mtx, b.mtx) so that
//! other solvers (AMGCL in `scripts/amgcl-compare.sh`) and `hookean solve`
//! can run on exactly the same matrices and right-hand sides:
//!
//! ```text
//! cargo run --release -p hookean-cli --example write_bench_system -- N K OUT_PREFIX [--force]
//! ```
//!
//! writes `OUT_PREFIX-A.mtx` (symmetric coordinate, full precision) and
//! `OUT_PREFIX-b.mtx` for the cloth of `N x N` particles and stiffness `K`
//! (the system `hookean bench-precond --n N --k K` solves). Run again, it
//! replaces the files it wrote before (they carry its comment line) and
//! keeps any other file at those paths unless `--force` is given.

use std::process::ExitCode;

use hookean_io::{Written, has_banner_mark, with_banner_mark, write_own};

use hookean_cli::deformed_cloth_system;
use hookean_sparse::{write_matrix_market, write_vector_market};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let force = args.iter().any(|a| a == "--force");
    let pos: Vec<&String> = args.iter().filter(|a| !a.starts_with("--")).collect();
    let (Some(n), Some(k), Some(prefix)) = (
        pos.first().and_then(|s| s.parse::<usize>().ok()),
        pos.get(1).and_then(|s| s.parse::<f64>().ok()),
        pos.get(2),
    ) else {
        eprintln!("usage: write_bench_system N K OUT_PREFIX [--force]");
        return ExitCode::from(2);
    };
    let a_path = format!("{prefix}-A.mtx");
    let b_path = format!("{prefix}-b.mtx");
    let (a, b) = match deformed_cloth_system(n, k) {
        Ok(system) => system,
        Err(e) => {
            eprintln!("error: {e:?}");
            return ExitCode::from(2);
        }
    };
    let csr = a.to_csr();
    let write = || -> Result<Vec<Written>, Box<dyn std::error::Error>> {
        let mut ma = Vec::new();
        write_matrix_market(&mut ma, &csr, true)?;
        let mut mb = Vec::new();
        write_vector_market(&mut mb, &b)?;
        let mut out = Vec::new();
        for (path, content) in [(&a_path, ma), (&b_path, mb)] {
            let content = with_banner_mark(&content, MARK);
            out.push(write_own(
                path,
                &content,
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
            println!(
                "{verb} {a_path} ({} rows, {} stored entries of the full matrix) and {b_path}",
                b.len(),
                csr.nnz()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// The comment line that marks a file as this example's own.
const MARK: &[u8] = b"% written by hookean-cli's example write_bench_system\n";
