//! Solves `A x = b` from Matrix Market files with the library's PCG, as a
//! Rust user would write it, and prints `x`, one entry per line in Rust's
//! shortest round-trip form (the exact `f64`): the Rust API's answer that
//! the Python package's `hookean.sparse.solve` is compared with bit for bit.
//!
//! ```sh
//! cargo run -p hookean-sparse --example pcg_solution -- A.mtx b.mtx amg [nullspace.mtx]
//! ```

use std::io::Write;
use std::process::ExitCode;

use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, PcgMatrix, PrecondKind, PreconditionerOptions,
    detect_block_size, nullspace_block_size, read_matrix_market_file,
};

fn solve(args: &[String]) -> Result<Vec<f64>, String> {
    let [a, b, precond, rest @ ..] = args else {
        return Err("usage: pcg_solution A.mtx B.mtx PRECOND [NULLSPACE.mtx]".into());
    };
    let read = |p: &str| read_matrix_market_file(p).map_err(|e| e.to_string());
    let a = read(a)?.into_csr();
    let b: Vec<f64> = read(b)?.into_csr().to_dense().iter().copied().collect();
    // The near-nullspace's columns, each a vector of the matrix's length.
    let nullspace: Vec<Vec<f64>> = match rest.first() {
        Some(p) => {
            let v = read(p)?.into_csr().to_csc();
            v.outer_iterator()
                .map(|col| col.to_dense().to_vec())
                .collect()
        }
        None => Vec::new(),
    };
    let kind: PrecondKind = precond.parse().map_err(|e| format!("PRECOND: {e}"))?;
    let block_size = nullspace_block_size(&nullspace).unwrap_or_else(|| detect_block_size(&a));
    let m = PcgMatrix::auto(a, block_size);
    let mut options = PreconditionerOptions::from(kind);
    // The multigrid's and block Jacobi's unknowns per node.
    options.amg.block_size = m.block_size();
    if kind == PrecondKind::Amg {
        options.amg.near_nullspace = nullspace;
    }
    let mut p = AnyPreconditioner::from_options(&options).map_err(|e| e.to_string())?;
    m.setup(&mut p).map_err(|e| e.to_string())?;
    let mut x = vec![0.0; m.dim()];
    let params = CgParams {
        rtol: 1e-8,
        ..Default::default()
    };
    let mut ws = CgWorkspace::new(m.dim());
    m.pcg(&p, &b, &mut x, &params, &mut ws, None)
        .map_err(|e| e.to_string())?;
    Ok(x)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match solve(&args) {
        Ok(x) => {
            let mut out = std::io::BufWriter::new(std::io::stdout().lock());
            match x
                .iter()
                .try_for_each(|v| writeln!(out, "{v:?}"))
                .and_then(|()| out.flush())
            {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("error: writing x: {e}");
                    ExitCode::from(1)
                }
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
