//! Writes the implicit-Euler system of the reference cloth (A.mtx, b.mtx),
//! the bundled example of `hookean solve`:
//!
//! ```text
//! cargo run -p hookean-testkit --example write_cloth_system -- N OUT_PREFIX [--force]
//! ```
//!
//! writes `OUT_PREFIX-A.mtx` (symmetric coordinate) and `OUT_PREFIX-b.mtx`;
//! existing files are kept unless `--force` is given.

use std::fs::File;
use std::io::BufWriter;
use std::process::ExitCode;

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
    for p in [&a_path, &b_path] {
        if std::path::Path::new(p).exists() && !force {
            eprintln!("{p} exists; pass --force to overwrite it");
            return ExitCode::from(2);
        }
    }
    let write = || -> Result<(), Box<dyn std::error::Error>> {
        write_matrix_market(BufWriter::new(File::create(&a_path)?), &a.to_csr(), true)?;
        write_vector_market(BufWriter::new(File::create(&b_path)?), &b)?;
        Ok(())
    };
    match write() {
        Ok(()) => {
            println!("wrote {a_path} ({} rows) and {b_path}", a.dim());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
