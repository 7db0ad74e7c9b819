//! `hookean bench-precond`: the preconditioner comparison on the reference
//! drape's implicit-Euler systems.
//!
//! For each cloth size `N` and stiffness `k`: the cloth of
//! `hookean_massspring::cloth` (`N x N` particles on the unit square, total
//! mass 1, structural and shear springs `k`, bend springs `k / 10`, spring
//! damping 0.1, pinned at two corners) in a deterministically deformed
//! state (see [`deformed_state`]), and its linearised implicit-Euler system
//! `A = M - h df/dv - h^2 df/dx`, `b = h (f + h df/dx v)` with `h = 0.01`
//! (`MassSpringModel::assemble_implicit_euler`). Every solver then runs
//! exactly as in `hookean solve` (the shared [`run_solver`]).
//!
//! Output: stdout stays pure JSON lines (the records of `hookean solve`
//! with the extra keys `"n"` and `"k"`, one per system and solver), so it
//! can be piped into tools; the markdown summary table goes to stderr.

use clap::Args;
use hookean_massspring::{ClothParams, SpringMaterial, State};
use indicatif::ProgressBar;
use serde::Serialize;

use crate::CliError;
use crate::solve::{Matrix, RunOptions, SolveRecord, Solver, SolverArgs, run_solver};

/// The implicit-Euler step size of the benchmark systems.
pub const H: f64 = 0.01;
/// The spring damping of the benchmark cloth.
pub const DAMPING: f64 = 0.1;

#[derive(Debug, Args)]
pub struct BenchPrecondArgs {
    /// Comma-separated cloth sizes N (N x N particles, 3 N^2 unknowns), each 2 to 1024.
    #[arg(long, value_delimiter = ',', default_values_t = [32, 64, 128])]
    n: Vec<usize>,
    /// Comma-separated structural/shear stiffnesses k (bend k / 10).
    #[arg(long, value_delimiter = ',', default_values_t = [1e2, 1e4, 1e6], allow_hyphen_values = true)]
    k: Vec<f64>,
    #[command(flatten)]
    solver: SolverArgs,
}

/// One JSON line: the `hookean solve` record plus the system's parameters.
#[derive(Debug, Serialize)]
struct BenchRecord {
    n: usize,
    k: f64,
    #[serde(flatten)]
    record: SolveRecord,
}

/// The deformed state of the benchmark: every particle at grid coordinates
/// `(u, v) in [0, 1]^2` (its rest position) moved by a sag
/// `dz = -0.1 sin(pi u) sin(pi v)` and in-plane waves `dx = 0.01 sin(6 pi v)`,
/// `dy = 0.01 sin(4 pi u)` (so springs are stretched, compressed and
/// rotated), with velocities `(0, 0, -0.5 sin(pi u) sin(pi v))`; the pinned
/// corners stay at rest. Deterministic: no random numbers.
pub fn deformed_state(rest: &State, n: usize, pinned: &[usize]) -> State {
    let mut x = rest.x.clone();
    let mut v = vec![0.0; x.len()];
    let pi = std::f64::consts::PI;
    for b in 0..n {
        for a in 0..n {
            let p = a + n * b;
            if pinned.contains(&p) {
                continue;
            }
            let (u, w) = (a as f64 / (n - 1) as f64, b as f64 / (n - 1) as f64);
            let bump = (pi * u).sin() * (pi * w).sin();
            x[3 * p] += 0.01 * (6.0 * pi * w).sin();
            x[3 * p + 1] += 0.01 * (4.0 * pi * u).sin();
            x[3 * p + 2] -= 0.1 * bump;
            v[3 * p + 2] = -0.5 * bump;
        }
    }
    State { x, v }
}

/// The benchmark system `(A, b)` for size `n` and stiffness `k`: exactly
/// what `hookean bench-precond --n n --k k` solves (the example
/// `write_bench_system` writes it to Matrix Market for other solvers).
pub fn deformed_cloth_system(
    n: usize,
    k: f64,
) -> Result<(hookean_sparse::SymBlockMatrix, Vec<f64>), CliError> {
    let params = ClothParams {
        nu: n,
        nv: n,
        structural: SpringMaterial::new(k, DAMPING),
        shear: SpringMaterial::new(k, DAMPING),
        bend: SpringMaterial::new(k / 10.0, DAMPING),
        ..ClothParams::default()
    };
    let input = |e: hookean_massspring::MassSpringError| CliError::Input(e.to_string());
    let (model, rest) = hookean_massspring::cloth(&params).map_err(input)?;
    // The default pins: the two corners of the edge b = n - 1.
    let pinned = [n * (n - 1), n * n - 1];
    let state = deformed_state(&rest, n, &pinned);
    let mut sys = model.implicit_system();
    model
        .assemble_implicit_euler(H, &state.x, &state.v, &mut sys)
        .map_err(input)?;
    Ok((sys.a, sys.b))
}

/// Memory of the benchmark's system per particle (measured 3.1 KB at
/// N = 256 and 512, peak RSS of `--precond none`).
const BYTES_PER_PARTICLE: u64 = 4096;
/// What `direct` adds per particle before its factor (whose fill is
/// checked on its own): 117 nonzeros a particle, about 40 bytes each in the
/// CSC copies and the symbolic analysis (peak RSS 7.9 GB at N = 1024).
const DIRECT_BYTES_PER_PARTICLE: u64 = 4800;

pub fn run(args: &BenchPrecondArgs) -> Result<(), CliError> {
    let plan = args.solver.resolve()?;
    let solvers = &plan.solvers;
    if let Some(&n) = args.n.iter().find(|&&n| !(2..=1024).contains(&n)) {
        return Err(CliError::Input(format!(
            "--n: cloth size {n} must lie in 2 to 1024"
        )));
    }
    if let Some(&k) = args.k.iter().find(|k| !(**k > 0.0 && k.is_finite())) {
        return Err(CliError::Input(format!(
            "--k: stiffness {} must lie in (0, inf)",
            hookean_sparse::AsWritten(k)
        )));
    }
    // The system of each N (the model, the matrix, its CSR copy and the
    // vectors), and with `direct` the copies and symbolic analysis of the
    // factorisation, within --max-memory and what the process can get.
    let cap = plan.cap;
    let per_particle = BYTES_PER_PARTICLE
        + if solvers.iter().any(|s| matches!(s, Solver::Direct)) {
            DIRECT_BYTES_PER_PARTICLE
        } else {
            0
        };
    if let Some(&n) = args
        .n
        .iter()
        .find(|&&n| (n * n) as u64 * per_particle > cap)
    {
        return Err(CliError::Input(format!(
            "--n {n}: the system would need about {:.1} GiB, more than the {:.1} GiB allowed (--max-memory, or the process's memory limit)",
            ((n * n) as u64 * per_particle) as f64 / (1u64 << 30) as f64,
            cap as f64 / (1u64 << 30) as f64
        )));
    }
    if args.n.is_empty() || args.k.is_empty() {
        return Err(CliError::Input(
            "--n and --k need at least one value".into(),
        ));
    }
    let mut table = vec![
        "| N | k | unknowns | precond | iterations | setup (ms) | solve (ms) | rel. residual |"
            .to_string(),
        "|---|---|---|---|---|---|---|---|".to_string(),
    ];
    let mut failed = false;
    // A bar on a terminal (large N and many solvers take minutes).
    let bar = ProgressBar::new((args.n.len() * args.k.len() * solvers.len()) as u64);
    bar.set_style(crate::bar_style(
        "{bar:30} {pos}/{len} {msg} [{elapsed_precise}]",
    ));
    for &n in &args.n {
        for &k in &args.k {
            bar.set_message(format!("N = {n}, k = {k:e}"));
            let (a, b) = deformed_cloth_system(n, k)?;
            let csr = a.to_csr();
            let rows = b.len();
            let nnz = csr.nnz();
            let matrix = Matrix::Block(a);
            for solver in solvers {
                let record = run_solver(solver, &matrix, &csr, &b, &plan, &RunOptions::default());
                let record = SolveRecord {
                    matrix: format!("cloth{n}-k{k:e}"),
                    rows,
                    nnz,
                    ..record
                };
                // A solver that failed or missed the tolerance fails the command (exit 1).
                failed |= record.error.is_some() || !record.converged;
                table.push(format!(
                    "| {n} | {k:e} | {rows} | {} | {} | {:.3} | {:.3} | {:.1e} |{}",
                    record.precond,
                    record.iterations,
                    1e3 * record.setup_s,
                    1e3 * record.solve_s,
                    record.rel_residual,
                    record
                        .error
                        .as_deref()
                        .map_or(String::new(), |e| format!(" error: {e}"))
                ));
                crate::outln!("{}", crate::to_json(&BenchRecord { n, k, record }, false)?)?;
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    for line in table {
        crate::errln!("{line}");
    }
    if failed {
        return Err(CliError::SolverFailed);
    }
    Ok(())
}
