//! `hookean`: the command-line front end of the Hookean crates.
//!
//! ```text
//! hookean run SCENE [--out DIR] [--set key=value]... [--force]
//! hookean solve A.mtx [--rhs b.mtx] [--precond all] [--omega 1.0] [--rtol 1e-8] [--max-iter N] [--repeat K]
//! ```
//!
//! Bad input (missing or malformed files, wrong sizes, unknown names) is a
//! one-line message on stderr and exit code 2; a solver that fails on a
//! valid input (e.g. a matrix that is not positive definite) is reported in
//! its JSON line and the command exits with 1.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod render;
mod run;
mod solve;

/// Soft-object simulation with mass-spring systems: solvers, scenes, plots.
#[derive(Debug, Parser)]
#[command(name = "hookean", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a scene file: summary.json, steps.csv, OBJ frames and final.png in the output folder.
    Run(run::RunArgs),
    /// Solve A x = b from Matrix Market files with PCG (every preconditioner) or sparse Cholesky,
    /// printing one JSON object per line and per solver.
    Solve(solve::SolveArgs),
}

/// How a command failed.
#[derive(Debug)]
pub enum CliError {
    /// The user's input is wrong (exit code 2).
    Input(String),
    /// A solver failed on valid input (exit code 1); details were printed.
    SolverFailed,
    /// A run failed on valid input (exit code 1), with the reason.
    Failed(String),
}

impl From<hookean_sparse::SparseError> for CliError {
    fn from(e: hookean_sparse::SparseError) -> Self {
        CliError::Input(e.to_string())
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Solve(args) => solve::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Input(message)) => {
            eprintln!("hookean: error: {message}");
            ExitCode::from(2)
        }
        Err(CliError::SolverFailed) => ExitCode::from(1),
        Err(CliError::Failed(message)) => {
            eprintln!("hookean: error: {message}");
            ExitCode::from(1)
        }
    }
}
