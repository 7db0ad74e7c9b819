//! `hookean`: the command-line front end of the Hookean crates.
//!
//! ```text
//! hookean run SCENE [--out DIR] [--set key=value]... [--force]
//! hookean solve A.mtx [--rhs b.mtx] [--precond all|amg|mic0,amg|...] [--format auto|block|csr] [--block-size 1|2|3] [--omega 1.0] [--rtol 1e-8] [--max-iter N] [--repeat K]
//! hookean workprecision --problem tutorial1|tutorial2|tutorial3|wave [--methods a,b] --out wp.csv [--plot wp.svg] [--force]
//! hookean stability [--methods a,b] --plot regions.svg [--re -5,3] [--im -4,4] [--force]
//! hookean bench-precond [--n 32,64,128] [--k 1e2,1e4,1e6] [--rtol 1e-8] [--repeat K]
//! hookean tune A.mtx [--rhs b.mtx] [--budget 60] [--exhaustive] [--rtol 1e-8] [--out DIR] [--force]
//! hookean export-system SCENE (--at T | --every K) --out DIR [--force]
//! hookean filter-analysis SCENE --plot DIR [--n 16] [--t-end 1.0] [--force]
//! hookean view OUT_DIR [--force]
//! hookean export-cache OUT_DIR --format pc2|mdd [--force]
//! hookean scene-keys
//! hookean reproduce [--paper tutorial|filter|all] [--out DIR] [--quick] [--claims 1,2] [--force]
//! ```
//!
//! Every command takes `--threads N` (default: the scene's `threads` key
//! for `run`, else `RAYON_NUM_THREADS`, else all cores; `threads.rs` decides).
//!
//! Bad input (missing or malformed files, wrong sizes, unknown names) is a
//! one-line message on stderr and exit code 2; a solver that fails on a
//! valid input (e.g. a matrix that is not positive definite, or a direct
//! solve of a nonsymmetric matrix) or does not reach its tolerance is
//! reported in its JSON line and the command exits with 1.

// No panic reachable from user input: failures are `CliError`s.
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::print_stderr,
        clippy::print_stdout
    )
)]

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub use bench_precond::deformed_cloth_system;

pub mod alloc;
mod amg_args;
mod bench;
mod bench_precond;
mod bench_sequence;
mod checkpoint;
mod export_cache;
mod export_system;
mod filter_analysis;
mod lineplot;
mod memory;
mod output;
mod perfprofile;
mod plot;
mod regions;
mod render;
mod reproduce;
mod run;
mod run_outputs;
mod run_resume;
pub mod scene;
mod solve;
mod stability;
mod system_sequence;
mod thin;
mod threads;
mod tune;
mod tutorial_run;
mod view;
mod work;
mod workprecision;

/// Soft-object simulation with mass-spring systems: solvers, scenes, plots.
#[derive(Debug, Parser)]
#[command(name = "hookean", version, about)]
struct Cli {
    /// Worker threads of the linear algebra and assembly kernels (default:
    /// the scene's `threads`, else RAYON_NUM_THREADS, else all cores).
    /// Results are bitwise reproducible for a given thread count.
    #[arg(long, global = true, value_name = "N", value_parser = threads::parse)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a scene file: summary.json, steps.csv, OBJ frames, final.png and view.html in the output folder
    /// (docs/OUTPUTS.md); `hookean scene-keys` lists the scene keys.
    Run(run::RunArgs),
    /// Solve A x = b from Matrix Market files with PCG (every preconditioner) or sparse Cholesky,
    /// printing one JSON object per line and per solver.
    Solve(solve::SolveArgs),
    /// Work-precision diagrams of the tutorial's examples (figures 3, 5, 7): CSV and SVG.
    Workprecision(workprecision::WorkPrecisionArgs),
    /// Stability regions of the methods in the complex plane (the tutorial's figure 4): SVG.
    Stability(stability::StabilityArgs),
    /// Preconditioner comparison on cloth implicit-Euler systems: JSON lines on stdout, a table on stderr.
    BenchPrecond(bench_precond::BenchPrecondArgs),
    /// Compare preconditioners over Matrix Market files or folders (and built-in cloth systems):
    /// bench.md, bench.csv and a residual-against-time SVG per system in the output folder; or
    /// (--sequence DIR) the reuse policies of the preconditioner over a run's sequence of systems.
    Bench(bench::BenchArgs),
    /// The filtering paper's figures 4, 5 and 6 for a cloth scene: PNGs, an SVG and analysis.json.
    FilterAnalysis(filter_analysis::FilterAnalysisArgs),
    /// Write view.html (a self-contained WebGL player) for the output folder of an earlier `hookean run`.
    View(view::ViewArgs),
    /// Write a point cache (cache.pc2 or cache.mdd, with cache-rest.obj) of an earlier `hookean run`'s
    /// OBJ frames, for Blender's Mesh Cache modifier (docs/OUTPUTS.md, "Point caches").
    ExportCache(export_cache::ExportCacheArgs),
    /// Find the fastest preconditioner and options for one Matrix Market system (set-up plus
    /// solve to --rtol) within --budget seconds: the default multigrid first, every preconditioner's
    /// defaults, then one option at a time around the best; prints the winner as a `hookean solve`
    /// command line and a scene [solver] table (--out DIR: tune.csv of every candidate).
    Tune(tune::TuneArgs),
    /// Write the linearised implicit-Euler system (A.mtx, b.mtx) of a scene's state at time T, or
    /// (--every K) every K-th linear system Newton hands to PCG during the scene's run.
    ExportSystem(export_system::ExportSystemArgs),
    /// List every scene key (TOML) with its units and default.
    SceneKeys,
    /// Reproduce the claims of both papers: a table (claims.md, claims.json: claim, paper's value,
    /// measured value, tolerance, pass) and every figure; exit code 1 if a claim fails.
    Reproduce(reproduce::ReproduceArgs),
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
    /// Standard output was closed by its reader (`hookean solve ... | head`):
    /// the command stops quietly with exit code 141, as a tool killed by
    /// SIGPIPE does.
    OutputClosed,
}

/// While set, [`write_line`] writes nothing: `hookean reproduce` runs other
/// commands for their files and prints only its own table.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Silences [`write_line`] until dropped.
pub(crate) struct Quiet;

impl Quiet {
    pub(crate) fn new() -> Self {
        QUIET.store(true, std::sync::atomic::Ordering::Relaxed);
        Quiet
    }
}

impl Drop for Quiet {
    fn drop(&mut self) {
        QUIET.store(false, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Writes one line to standard output; a closed pipe is
/// [`CliError::OutputClosed`] instead of a panic.
pub fn write_line(line: std::fmt::Arguments<'_>) -> Result<(), CliError> {
    use std::io::Write;
    if QUIET.load(std::sync::atomic::Ordering::Relaxed) {
        return Ok(());
    }
    let mut out = std::io::stdout().lock();
    match out.write_fmt(line).and_then(|()| out.write_all(b"\n")) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Err(CliError::OutputClosed),
        Err(e) => Err(CliError::Failed(format!("standard output: {e}"))),
    }
}

/// Writes one line to standard error, ignoring a failure: a report or an
/// error message that cannot be written (stderr on a full disk, closed)
/// must not turn into a panic or change the exit code.
pub fn write_error_line(line: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut err = std::io::stderr().lock();
    let _ = err.write_fmt(line).and_then(|()| err.write_all(b"\n"));
}

/// `eprintln!` that cannot panic (see [`write_error_line`]).
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::write_error_line(format_args!($($arg)*))
    };
}
pub(crate) use errln;

/// `println!` for command output: `outln!(...)?` (see [`write_line`]).
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::write_line(format_args!($($arg)*))
    };
}
pub(crate) use outln;

/// A record as JSON (`pretty`: indented, for files).
pub fn to_json<T: serde::Serialize>(record: &T, pretty: bool) -> Result<String, CliError> {
    let json = if pretty {
        serde_json::to_string_pretty(record)
    } else {
        serde_json::to_string(record)
    };
    json.map_err(|e| CliError::Failed(format!("cannot write a record as JSON: {e}")))
}

/// A progress bar's style from an indicatif template (the default bar if
/// the template does not parse).
pub fn bar_style(template: &str) -> indicatif::ProgressStyle {
    indicatif::ProgressStyle::with_template(template)
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
}

impl From<hookean_sparse::SparseError> for CliError {
    fn from(e: hookean_sparse::SparseError) -> Self {
        CliError::Input(e.to_string())
    }
}

/// Help and version as clap prints them; a bad argument as every other bad
/// input: one `hookean: error:` line, exit code 2.
fn argument_error(e: &clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp
        | ErrorKind::DisplayVersion
        | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => match e.print() {
            // Help and version go to stdout: one that cannot be written (a
            // full disk) is a failure, as for every other command's output;
            // a closed pipe ends quietly. A failure to write to stderr
            // changes no exit code.
            Err(err) if !e.use_stderr() => {
                if err.kind() == std::io::ErrorKind::BrokenPipe {
                    ExitCode::from(141)
                } else {
                    errln!("hookean: error: standard output: {err}");
                    ExitCode::from(1)
                }
            }
            _ => ExitCode::from(e.exit_code().clamp(0, 255) as u8),
        },
        _ => {
            // The first paragraph of clap's message, on one line.
            let text = e.to_string();
            let paragraph: Vec<&str> = text
                .lines()
                .map(str::trim)
                .take_while(|l| !l.is_empty())
                .collect();
            let joined = paragraph.join(" ");
            let message = joined.strip_prefix("error: ").unwrap_or(&joined);
            errln!("hookean: error: {message} (see hookean --help)");
            ExitCode::from(2)
        }
    }
}

/// The `hookean` command: parses the process's arguments, runs the
/// subcommand and returns its exit code (0 success, 1 a failed run, 2 bad
/// input, 141 a closed standard output). The `hookean` binary is this
/// function; the workspace's catalogue of bad inputs (tests/catalogue.rs)
/// builds a binary of its own from it.
pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return argument_error(&e),
    };
    let threads = cli.threads;
    // RAYON_NUM_THREADS matters only without --threads.
    let env = if threads.is_none() {
        threads::check_env()
    } else {
        Ok(())
    };
    let result = env
        .and_then(|()| threads::install(threads, || dispatch(cli.command, threads)))
        .and_then(|r| r);
    if result.is_err() {
        output::wait_if_dying();
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError::Input(message)) => {
            errln!("hookean: error: {message}");
            ExitCode::from(2)
        }
        Err(CliError::SolverFailed) => ExitCode::from(1),
        Err(CliError::Failed(message)) => {
            errln!("hookean: error: {message}");
            ExitCode::from(1)
        }
        Err(CliError::OutputClosed) => ExitCode::from(141),
    }
}

/// Runs one command (inside the thread pool of [`threads::install`]).
fn dispatch(command: Command, threads: Option<usize>) -> Result<(), CliError> {
    match command {
        Command::Run(args) => run::run(&args, threads),
        Command::Solve(args) => solve::run(&args),
        Command::Workprecision(args) => workprecision::run(&args),
        Command::Stability(args) => stability::run(&args),
        Command::BenchPrecond(args) => bench_precond::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Tune(args) => tune::run(&args),
        Command::ExportSystem(args) => export_system::run(&args),
        Command::ExportCache(args) => export_cache::run(&args),
        Command::FilterAnalysis(args) => filter_analysis::run(&args),
        Command::View(args) => view::run(&args),
        Command::SceneKeys => outln!("{}", scene::KEYS.trim_end()),
        Command::Reproduce(args) => reproduce::run(&args),
    }
}
