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
//! (the system `hookean bench-precond --n N --k K` solves).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::process::ExitCode;

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
    for p in [&a_path, &b_path] {
        if std::path::Path::new(p).exists() && !force {
            eprintln!("{p} exists; pass --force to overwrite it");
            return ExitCode::from(2);
        }
    }
    let (a, b) = match deformed_cloth_system(n, k) {
        Ok(system) => system,
        Err(e) => {
            eprintln!("error: {e:?}");
            return ExitCode::from(2);
        }
    };
    let csr = a.to_csr();
    let write = || -> Result<(), Box<dyn std::error::Error>> {
        let mut wa = BufWriter::new(File::create(&a_path)?);
        write_matrix_market(&mut wa, &csr, true)?;
        wa.flush()?;
        let mut wb = BufWriter::new(File::create(&b_path)?);
        write_vector_market(&mut wb, &b)?;
        wb.flush()?;
        Ok(())
    };
    match write() {
        Ok(()) => {
            println!(
                "wrote {a_path} ({} rows, {} stored entries of the full matrix) and {b_path}",
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
