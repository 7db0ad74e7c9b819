//! Solve a Matrix Market system with PCG, once with Jacobi and once with
//! smoothed-aggregation multigrid, and compare iterations and residuals.
//!
//! `cargo run --example solve_matrix_market -- data/cloth16-A.mtx data/cloth16-b.mtx`

use hookean_sparse::vecops::norm2;
use hookean_sparse::{Amg, AmgOptions, CgParams, Jacobi, LinearOperator, Pcg};
use hookean_sparse::{Preconditioner, PreconditionerSetup, read_matrix_market_file};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let a_path = args.get(1).map_or("data/cloth16-A.mtx", String::as_str);
    let b_path = args.get(2).map_or("data/cloth16-b.mtx", String::as_str);
    let a = read_matrix_market_file(a_path)?.into_csr(); // a sprs::CsMat<f64>
    let b = read_matrix_market_file(b_path)?.into_vector()?;
    let mut jacobi = Jacobi::new();
    jacobi.setup(&a)?;
    let block_size = 3; // cloth: 3 unknowns per particle, aggregated as 3x3 blocks
    let mut amg = Amg::with_options(AmgOptions {
        block_size,
        ..AmgOptions::default()
    })?;
    amg.setup(&a)?;
    let mut pcg = Pcg::new(CgParams::default()); // |r| <= 1e-8 |b|
    for (name, precond) in [("jacobi", &jacobi as &dyn Preconditioner), ("amg", &amg)] {
        let mut x = vec![0.0; b.len()];
        let info = pcg.solve(&a, precond, &b, &mut x)?.ensure_converged()?;
        // The true residual |b - A x| / |b|, not CG's recursive one.
        let mut r = vec![0.0; b.len()];
        a.apply(&x, &mut r);
        r.iter_mut().zip(&b).for_each(|(ri, bi)| *ri = bi - *ri);
        let rel = norm2(&r) / norm2(&b);
        println!(
            "{name}: {} iterations, |b - Ax|/|b| = {rel:.1e}",
            info.iterations
        );
    }
    Ok(())
}
