//! `hookean bench`: every preconditioner on every system of a set of Matrix
//! Market files (and, optionally, the built-in cloth systems), repeated in
//! interleaved rounds, written as one table (`bench.md`, `bench.csv`), one
//! picture per system of the relative residual against time
//! (`residual-NAME.svg`), and over the folder a Dolan-Moré performance
//! profile of the time (`profile.svg`) and one ranking line per metric
//! (time, set-up time, iterations, set-up memory: `ranking.md`, also on
//! stdout after the table; [`crate::perfprofile`]).
//!
//! With `--sequence DIR` it answers the reuse question instead: every
//! policy of rebuilding, refilling or keeping the preconditioner over a
//! run's sequence of Newton systems ([`crate::bench_sequence`]).
//!
//! A system is `NAME.mtx`; beside it, `NAME_b.mtx` is its right-hand side
//! (default `A * ones`) and `NAME_nullspace.mtx` (one column per vector) the
//! multigrid's near-nullspace. A matrix named `NAME-A.mtx` or `NAME_A.mtx`
//! finds its right-hand side as `NAME-b.mtx` or `NAME_b.mtx` too.
//!
//! A solver that fails (no convergence, a breakdown, a preconditioner that
//! cannot be built) and a file that cannot be used (malformed, not
//! symmetric, not square) are rows with their reason: the command still
//! writes everything and exits 0. Bad flags, no systems at all or an
//! output that cannot be written fail it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use clap::Args;
use hookean_sparse::{check_csr_symmetric, nullspace_block_size};

use crate::CliError;
use crate::amg_args::{AmgArgs, read_columns};
use crate::lineplot::{LogLogPlot, ProfilePlot, Series};
use crate::perfprofile::{performance_ratios, profile_steps, ranking};
use crate::solve::{
    BlockSizeSource, Matrix, Plan, RunOptions, SolveRecord, SolverArgs, System, empty_record,
    load_system, run_solver,
};

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Matrix Market files, or folders of them (every `*.mtx` inside;
    /// `NAME_b.mtx` and `NAME_nullspace.mtx` beside `NAME.mtx` are its
    /// right-hand side and near-nullspace, not systems).
    inputs: Vec<PathBuf>,
    /// The preconditioners to compare, comma-separated: none, jacobi, block-jacobi, ssor, ic0, mic0
    /// (block storage only), amg, direct (faer sparse Cholesky), or all.
    #[arg(long, default_value = "jacobi,block-jacobi,ssor,ic0,amg,direct")]
    precond: String,
    /// Also the built-in cloth systems of `hookean bench-precond` (k = 1e4) at these comma-separated
    /// sizes N (N x N particles), each 2 to 512.
    #[arg(long, value_delimiter = ',')]
    cloth: Vec<usize>,
    /// Output folder (default: out/bench). It must not exist unless --force.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Replace an existing output folder of an earlier hookean command.
    #[arg(long)]
    force: bool,
    /// Rounds (1 to 1000): each round runs every solver once, in order, on a system; the table
    /// holds the best set-up and solve times.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Relative residual tolerance |r| / |b| of PCG, in [0, 1).
    #[arg(long, default_value_t = 1e-8, allow_negative_numbers = true)]
    rtol: f64,
    /// PCG iteration limit, 0 to 10^7 (default 2 n).
    #[arg(long)]
    max_iter: Option<usize>,
    /// SSOR relaxation, in (0, 2).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    omega: f64,
    #[command(flatten)]
    amg: AmgArgs,
    /// Matrix storage for PCG: block (symmetric 3x3 blocks), csr, or auto (csr when the nodes have
    /// 1 or 2 unknowns by --block-size, the `_nullspace.mtx` or the pattern; else block when
    /// possible).
    #[arg(long, default_value = "auto")]
    format: String,
    /// Unknowns per node for `amg` on csr storage, 1 to 3 (default: read off the first vector of a
    /// `_nullspace.mtx`, a translation non-zero at every d-th entry, else detected from the pattern:
    /// 2 or 3 when every row of a node couples to the same nodes for exactly one of them, else 1).
    /// The table's `unknowns per node` column says which.
    #[arg(long)]
    block_size: Option<usize>,
    /// Skip a matrix, or a direct factor, that would need more memory than this (GiB), in (0, the
    /// machine's memory].
    #[arg(
        long,
        value_name = "GIB",
        default_value_t = 8.0,
        allow_negative_numbers = true
    )]
    max_memory: f64,
    /// Do not estimate the extreme eigenvalues of M^-1 A from PCG's coefficients (bench.csv's
    /// `lambda_min`, `lambda_max` and `condition` columns then stay empty).
    #[arg(long)]
    no_condition_estimate: bool,
    /// No progress lines on stderr.
    #[arg(long)]
    quiet: bool,
    /// Replay the numbered systems of this folder (`hookean export-system --every K`) with every
    /// reuse policy of the preconditioner instead: sequence.md, sequence.csv and cumulative.svg
    /// (docs/PERFORMANCE.md, "The reuse question").
    #[arg(long, value_name = "DIR")]
    sequence: Option<PathBuf>,
}

/// The most systems one run takes.
pub(crate) const MAX_SYSTEMS: usize = 10_000;
/// The most points of one curve drawn (the trace is thinned evenly).
pub(crate) const PLOT_POINTS: usize = 60;
/// The stiffness of the built-in cloth systems.
const CLOTH_K: f64 = 1e4;

/// One system to benchmark.
struct Input {
    /// Its name in the table and the picture's file name.
    name: String,
    source: Source,
}

enum Source {
    File {
        matrix: PathBuf,
        rhs: Option<PathBuf>,
        nullspace: Option<PathBuf>,
    },
    Cloth(usize),
}

/// One row of the table.
struct Row {
    system: String,
    rows: usize,
    nnz: usize,
    record: Option<SolveRecord>,
    /// Why the system or solver has no result, or missed the tolerance.
    status: String,
}

pub fn run(args: &BenchArgs) -> Result<(), CliError> {
    let solver_args = SolverArgs {
        precond: args.precond.clone(),
        omega: args.omega,
        mic_omega: hookean_sparse::PrecondKind::MIC_OMEGA,
        rtol: args.rtol,
        max_iter: args.max_iter,
        repeat: args.repeat,
        amg: args.amg.clone(),
        max_memory: args.max_memory,
        no_condition_estimate: args.no_condition_estimate,
    };
    let plan = solver_args.resolve()?;
    if let Some(b) = args.block_size.filter(|b| !(1..=3).contains(b)) {
        return Err(CliError::Input(format!(
            "--block-size must be 1, 2 or 3, got {b}"
        )));
    }
    if !matches!(args.format.as_str(), "auto" | "block" | "csr") {
        return Err(CliError::Input(format!(
            "unknown --format '{}' (expected block, csr or auto)",
            args.format
        )));
    }
    if let Some(dir) = &args.sequence {
        return run_sequence(args, &plan, dir);
    }
    if let Some(&n) = args.cloth.iter().find(|&&n| !(2..=512).contains(&n)) {
        return Err(CliError::Input(format!(
            "--cloth: size {n} must lie in 2 to 512"
        )));
    }
    let inputs = discover(&args.inputs, &args.cloth)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join("bench"));
    let input_paths: Vec<&Path> = args.inputs.iter().map(PathBuf::as_path).collect();
    let staging = crate::output::Staging::new("bench", &out, "--out", args.force, &input_paths)?;
    match bench(args, &inputs, &plan, staging.dir()) {
        Ok(table) => {
            staging.commit()?;
            crate::outln!("{}", table.trim_end())?;
            if !args.quiet {
                crate::errln!("hookean bench: wrote {}", out.display());
            }
            Ok(())
        }
        Err(e) => Err(staging.abandon(e)),
    }
}

/// `--sequence DIR`: every reuse policy over the folder's systems
/// ([`crate::bench_sequence`]).
fn run_sequence(args: &BenchArgs, plan: &Plan, dir: &Path) -> Result<(), CliError> {
    if !args.inputs.is_empty() || !args.cloth.is_empty() {
        return Err(CliError::Input(
            "--sequence replays one folder: give no other Matrix Market inputs or --cloth".into(),
        ));
    }
    let options = crate::bench_sequence::SequenceOptions {
        amg: args.amg.options(3, Vec::new())?,
        fallback: crate::bench_sequence::Fallback {
            rtol: args.rtol,
            max_iter: args.max_iter,
        },
        repeat: args.repeat,
        quiet: args.quiet,
        cap: plan.cap,
        dir,
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join("bench"));
    let staging = crate::output::Staging::new("bench", &out, "--out", args.force, &[dir])?;
    match crate::bench_sequence::bench_sequence(&options, staging.dir()) {
        Ok(table) => {
            staging.commit()?;
            crate::outln!("{}", table.trim_end())?;
            if !args.quiet {
                crate::errln!("hookean bench: wrote {}", out.display());
            }
            Ok(())
        }
        Err(e) => Err(staging.abandon(e)),
    }
}

/// The systems named by `paths` (files, or every `*.mtx` of a folder) and
/// the cloth sizes, in order; right-hand sides and near-nullspaces are
/// attached to their matrices.
fn discover(paths: &[PathBuf], cloth: &[usize]) -> Result<Vec<Input>, CliError> {
    let mut files: Vec<PathBuf> = Vec::new();
    for p in paths {
        if p.is_dir() {
            let entries = std::fs::read_dir(p)
                .map_err(|e| CliError::Input(format!("{}: {e}", p.display())))?;
            let mut found: Vec<PathBuf> = entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                // A FIFO or device among them is read by the shared reader
                // (hookean_io::open_regular), which refuses it
                // without waiting: a row saying what it is.
                .filter(|f| f.extension().is_some_and(|x| x == "mtx") && !f.is_dir())
                .collect();
            found.sort();
            files.extend(found);
        } else if std::fs::metadata(p).is_ok() {
            files.push(p.clone());
        } else {
            return Err(CliError::Input(format!(
                "{}: no such file or folder",
                p.display()
            )));
        }
        if files.len() > MAX_SYSTEMS {
            return Err(CliError::Input(format!(
                "more than {MAX_SYSTEMS} Matrix Market files: benchmark fewer at a time"
            )));
        }
    }
    let set: BTreeSet<&Path> = files.iter().map(PathBuf::as_path).collect();
    let stem = |f: &Path| {
        f.file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
    };
    let beside = |f: &Path, name: String| {
        let p = f.with_file_name(format!("{name}.mtx"));
        set.contains(p.as_path()).then_some(p)
    };
    // Right-hand side and near-nullspace candidates of a matrix file.
    let companions = |f: &Path| {
        let s = stem(f);
        let mut rhs = vec![format!("{s}_b")];
        if let Some(base) = s.strip_suffix("-A").or_else(|| s.strip_suffix("_A")) {
            rhs.extend([format!("{base}-b"), format!("{base}_b")]);
        }
        let rhs = rhs.into_iter().find_map(|r| beside(f, r));
        let nullspace = beside(f, format!("{s}_nullspace"));
        (rhs, nullspace)
    };
    let attached: BTreeSet<PathBuf> = files
        .iter()
        .flat_map(|f| {
            let (r, n) = companions(f);
            r.into_iter().chain(n)
        })
        .collect();
    let mut inputs = Vec::new();
    let mut names: BTreeMap<String, usize> = BTreeMap::new();
    for f in files.iter().filter(|f| !attached.contains(*f)) {
        let (rhs, nullspace) = companions(f);
        inputs.push(Input {
            name: unique(&mut names, stem(f)),
            source: Source::File {
                matrix: f.clone(),
                rhs,
                nullspace,
            },
        });
    }
    for &n in cloth {
        inputs.push(Input {
            name: unique(&mut names, format!("cloth{n}")),
            source: Source::Cloth(n),
        });
    }
    if inputs.is_empty() {
        return Err(CliError::Input(
            "nothing to benchmark: give Matrix Market files or folders, or --cloth sizes".into(),
        ));
    }
    Ok(inputs)
}

/// `name`, or `name-2`, `name-3`, ... when taken.
fn unique(names: &mut BTreeMap<String, usize>, name: String) -> String {
    let count = names.entry(name.clone()).or_insert(0);
    *count += 1;
    if *count == 1 {
        name
    } else {
        format!("{name}-{count}")
    }
}

/// Runs every solver on every system in `dir`; returns the markdown table.
fn bench(args: &BenchArgs, inputs: &[Input], plan: &Plan, dir: &Path) -> Result<String, CliError> {
    let (solvers, cap) = (&plan.solvers, plan.cap);
    // `--repeat` rounds over all solvers, each solver once per round.
    let one_round = Plan {
        repeat: 1,
        ..plan.clone()
    };
    let mut rows: Vec<Row> = Vec::new();
    for (k, input) in inputs.iter().enumerate() {
        if !args.quiet {
            crate::errln!("hookean bench: [{}/{}] {}", k + 1, inputs.len(), input.name);
        }
        let (system, nullspace) = match load(input, args, cap) {
            Ok(s) => s,
            Err(reason) => {
                rows.push(Row {
                    system: input.name.clone(),
                    rows: 0,
                    nnz: 0,
                    record: None,
                    status: reason,
                });
                continue;
            }
        };
        let (n, nnz) = (system.b.len(), system.a.nnz());
        // MIC(0) exists for block storage only: on CSR it is a row saying so.
        let mut best: Vec<Option<SolveRecord>> = solvers.iter().map(|_| None).collect();
        for _ in 0..args.repeat {
            for (s, solver) in solvers.iter().enumerate() {
                if best[s].as_ref().is_some_and(|r| r.error.is_some()) {
                    continue;
                }
                let run = RunOptions {
                    trace: true,
                    near_nullspace: match &nullspace {
                        Ok(v) if solver.is_amg() => v.clone(),
                        _ => Vec::new(),
                    },
                    ..Default::default()
                };
                let mut record = match &nullspace {
                    Err(reason) if solver.is_amg() => {
                        let mut r = empty_record("hookean-pcg", solver.name(), "");
                        r.error = Some(reason.clone());
                        r
                    }
                    _ => run_solver(
                        solver,
                        &system.matrix,
                        &system.a,
                        &system.b,
                        &one_round,
                        &run,
                    ),
                };
                record.block_size = Some(system.block_size);
                record.block_size_source = Some(system.block_size_source);
                if let Some(prev) = best[s].take() {
                    record = merge(prev, record);
                }
                best[s] = Some(record);
            }
        }
        for record in best {
            let Some(record) = record else { continue };
            let status = match (&record.error, record.converged) {
                (Some(e), _) => format!("failed: {e}"),
                (None, true) => "converged".to_string(),
                (None, false) => format!("not converged (|r|/|b| = {:.1e})", record.rel_residual),
            };
            if !args.quiet {
                crate::errln!(
                    "  {:<13} {:>6} iterations, {:>10.3} ms, {status}",
                    record.precond,
                    record.iterations,
                    1e3 * (record.setup_s + record.solve_s)
                );
            }
            rows.push(Row {
                system: input.name.clone(),
                rows: n,
                nnz,
                record: Some(record),
                status,
            });
        }
        plot(&input.name, &rows, dir)?;
    }
    let (markdown, csv) = table(&rows);
    crate::output::write_text(&dir.join("bench.md"), &markdown)?;
    crate::output::write_text(&dir.join("bench.csv"), &csv)?;
    let ranking = rankings(&rows);
    crate::output::write_text(&dir.join("ranking.md"), &ranking)?;
    profile_plot(&rows, dir)?;
    Ok(format!("{}\n\n{ranking}", markdown.trim_end()))
}

/// A metric of the rankings: its name, the cost of a converged record
/// (`None`: the metric does not apply to that solver, e.g. the direct
/// solver's iterations) and its resolution ([`performance_ratios`]' floor).
type Metric = (&'static str, fn(&SolveRecord) -> Option<f64>, f64);

/// Time, set-up time, iterations and set-up memory, each down to its
/// resolution: 1 µs, 1 iteration, 1 KiB.
const METRICS: [Metric; 4] = [
    (
        "time (set-up + solve)",
        |r| Some(r.setup_s + r.solve_s),
        1e-6,
    ),
    ("set-up time", |r| Some(r.setup_s), 1e-6),
    (
        "iterations",
        |r| (r.solver == "hookean-pcg").then_some(r.iterations as f64),
        1.0,
    ),
    ("set-up memory", |r| r.setup_bytes.map(|b| b as f64), 1024.0),
];

/// The systems with results (a file that could not be read has none) and
/// the solvers the metric applies to, in the table's order, with the cost
/// of each pair: `None` for a solver that failed or missed the tolerance.
fn cost_table(rows: &[Row], metric: &Metric) -> (Vec<String>, Vec<Vec<Option<f64>>>) {
    let mut systems: Vec<&str> = Vec::new();
    let mut solvers: Vec<&str> = Vec::new();
    for r in rows {
        let Some(rec) = &r.record else { continue };
        if !systems.contains(&r.system.as_str()) {
            systems.push(&r.system);
        }
        if (metric.1)(rec).is_some() && !solvers.contains(&rec.precond.as_str()) {
            solvers.push(&rec.precond);
        }
    }
    let costs = systems
        .iter()
        .map(|system| {
            solvers
                .iter()
                .map(|solver| {
                    rows.iter()
                        .filter(|r| r.system == *system)
                        .filter_map(|r| r.record.as_ref())
                        .find(|rec| rec.precond == *solver)
                        .filter(|rec| rec.error.is_none() && rec.converged)
                        .and_then(metric.1)
                })
                .collect()
        })
        .collect();
    (solvers.iter().map(|s| s.to_string()).collect(), costs)
}

/// One line per metric: the solvers from best to worst over the folder
/// ([`ranking`]), with how many systems each is best on and solves, and
/// its geometric-mean ratio to the best.
fn rankings(rows: &[Row]) -> String {
    let mut out = String::new();
    for metric in &METRICS {
        let (solvers, costs) = cost_table(rows, metric);
        let ratios = performance_ratios(&costs, metric.2);
        let entries: Vec<String> = ranking(&ratios)
            .iter()
            .enumerate()
            .map(|(k, rank)| {
                format!(
                    "{}. {} (best on {}, solved {}, ratio {:.2})",
                    k + 1,
                    solvers[rank.solver],
                    rank.wins,
                    rank.solved,
                    rank.mean_ratio
                )
            })
            .collect();
        out.push_str(&format!(
            "Ranking by {} over {} systems: {}\n",
            metric.0,
            costs.len(),
            entries.join("; ")
        ));
    }
    out
}

/// `profile.svg`: the performance profile of the total time, the fraction
/// of the systems each solver solves within `tau` of the fastest.
fn profile_plot(rows: &[Row], dir: &Path) -> Result<(), CliError> {
    let (solvers, costs) = cost_table(rows, &METRICS[0]);
    if costs.is_empty() || solvers.is_empty() {
        return Ok(());
    }
    let ratios = performance_ratios(&costs, METRICS[0].2);
    let largest = ratios
        .iter()
        .flatten()
        .copied()
        .filter(|r| r.is_finite())
        .fold(10.0_f64, f64::max);
    let tau_max = 10f64.powf((largest.log10() - 1e-9).ceil());
    let plot = ProfilePlot {
        title: format!(
            "Performance profile of the time to |r| <= rtol |b| over {} systems",
            costs.len()
        ),
        x_label: "tau: time / the fastest solver's time on the system".into(),
        y_label: "fraction of the systems solved within tau".into(),
        series: solvers
            .iter()
            .enumerate()
            .map(|(s, name)| Series {
                name: name.clone(),
                points: profile_steps(&ratios, s, tau_max),
            })
            .collect(),
    };
    let svg = plot.render().map_err(CliError::Failed)?;
    crate::output::write_text(&dir.join("profile.svg"), &svg)
}

/// The best of two rounds of one solver: the fastest set-up and solve, the
/// trace of the fastest total, the largest memory; an error wins.
fn merge(prev: SolveRecord, next: SolveRecord) -> SolveRecord {
    if next.error.is_some() {
        return next;
    }
    let faster = next.setup_s + next.solve_s < prev.setup_s + prev.solve_s;
    SolveRecord {
        setup_s: prev.setup_s.min(next.setup_s),
        solve_s: prev.solve_s.min(next.solve_s),
        setup_bytes: prev.setup_bytes.max(next.setup_bytes),
        trace: if faster { next.trace } else { prev.trace },
        ..next
    }
}

/// Reads (or builds) one system and its near-nullspace; `Err` is the reason
/// the system is a row without results.
#[allow(clippy::type_complexity)]
fn load(
    input: &Input,
    args: &BenchArgs,
    cap: u64,
) -> Result<(System, Result<Vec<Vec<f64>>, String>), String> {
    match &input.source {
        Source::Cloth(n) => {
            let (a, b) = crate::deformed_cloth_system(*n, CLOTH_K).map_err(reason)?;
            let csr = a.to_csr();
            let (block_size, source) = match args.block_size {
                Some(d) => (d, BlockSizeSource::Flag),
                None => (3, BlockSizeSource::Default),
            };
            let (matrix, block_size) = match args.format.as_str() {
                "csr" => (Matrix::csr(csr.clone(), block_size), block_size),
                _ => (Matrix::Block(a), 3),
            };
            let system = System {
                a: csr,
                b,
                matrix,
                block_size,
                block_size_source: source,
            };
            Ok((system, Ok(Vec::new())))
        }
        Source::File {
            matrix,
            rhs,
            nullspace,
        } => {
            let nullspace = match nullspace {
                Some(p) => read_columns(p, cap),
                None => Ok(Vec::new()),
            };
            // The flag, else the near-nullspace's, else the pattern's (and
            // `auto` takes scalar storage for nodes of 1 or 2 unknowns).
            let block_size =
                args.block_size
                    .map(|d| (d, BlockSizeSource::Flag))
                    .or(match &nullspace {
                        Ok(v) => nullspace_block_size(v).map(|d| (d, BlockSizeSource::Nullspace)),
                        Err(_) => None,
                    });
            let system = load_system(matrix, rhs.as_deref(), &args.format, block_size, cap)
                .map_err(reason)?;
            check_csr_symmetric(&system.a)
                .map_err(|e| format!("{}: {e} (PCG needs a symmetric matrix)", matrix.display()))?;
            let nullspace = nullspace.and_then(|v| match v.first() {
                Some(c) if c.len() != system.b.len() => Err(format!(
                    "near-nullspace vectors have {} entries, the matrix has {} rows",
                    c.len(),
                    system.b.len()
                )),
                _ => Ok(v),
            });
            // The multigrid takes k vectors on nodes of B unknowns for the
            // pairs it supports (rigid-body modes: 3 on 2, 6 on 3); another
            // pair is its row's error.
            Ok((system, nullspace))
        }
    }
}

/// The message of an error that makes a system a row without results.
fn reason(e: CliError) -> String {
    match e {
        CliError::Input(m) | CliError::Failed(m) => m,
        CliError::SolverFailed => "the solver failed".into(),
        CliError::OutputClosed => "output closed".into(),
    }
}

/// `residual-NAME.svg`: the relative residual of every solver of `system`
/// against the time since its set-up started.
fn plot(system: &str, rows: &[Row], dir: &Path) -> Result<(), CliError> {
    let series: Vec<Series> = rows
        .iter()
        .filter(|r| r.system == system)
        .filter_map(|r| r.record.as_ref())
        .map(|rec| Series {
            name: rec.precond.clone(),
            points: thin(&rec.trace, PLOT_POINTS),
        })
        .collect();
    if series.is_empty() {
        return Ok(());
    }
    let plot = LogLogPlot {
        title: format!("{system}: relative residual against time"),
        x_label: "time since the set-up started (s)".into(),
        y_label: "|r| / |b|".into(),
        series,
    };
    let svg = plot.render().map_err(CliError::Failed)?;
    crate::output::write_text(
        &dir.join(format!("residual-{}.svg", file_name(system))),
        &svg,
    )
}

/// At most `max` points of `trace`, evenly spaced, with the first and last.
pub(crate) fn thin(trace: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if trace.len() <= max {
        return trace.to_vec();
    }
    let step = (trace.len() - 1) as f64 / (max - 1) as f64;
    (0..max)
        .map(|k| trace[((k as f64 * step).round() as usize).min(trace.len() - 1)])
        .collect()
}

/// `name` with every character but letters, digits, `-`, `_` and `.` as `_`.
fn file_name(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The markdown and CSV tables. In markdown, the fastest converged solver
/// of each system is bold.
fn table(rows: &[Row]) -> (String, String) {
    let mut md = String::from(
        "| system | rows | nonzeros | unknowns per node | preconditioner | iterations | set-up (ms) | solve (ms) | total (ms) | \\|r\\|/\\|b\\| | set-up memory (MiB) | status |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut csv = String::from(
        "system,rows,nonzeros,block_size,block_size_source,preconditioner,iterations,setup_s,solve_s,total_s,rel_residual,recursive_rel_residual,setup_memory_bytes,lambda_min,lambda_max,condition,status\n",
    );
    let mut fastest: BTreeMap<&str, f64> = BTreeMap::new();
    for r in rows {
        if let Some(rec) = r
            .record
            .as_ref()
            .filter(|x| x.converged && x.error.is_none())
        {
            let t = fastest.entry(&r.system).or_insert(f64::INFINITY);
            *t = t.min(rec.setup_s + rec.solve_s);
        }
    }
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:e}"));
    let num = |v: f64, scale: f64, digits: usize| {
        if v.is_finite() {
            format!("{:.*}", digits, v * scale)
        } else {
            "-".into()
        }
    };
    for r in rows {
        let md_status = r.status.replace('|', "\\|");
        let csv_status = format!("\"{}\"", r.status.replace('"', "\"\""));
        // `3 (detected)` in the markdown, `3,detected` in the CSV.
        let (nodes, csv_nodes) = match r
            .record
            .as_ref()
            .and_then(|x| x.block_size.zip(x.block_size_source))
        {
            Some((d, source)) => (
                format!("{d} ({})", source.name()),
                format!("{d},{}", source.name()),
            ),
            None => ("-".into(), ",".into()),
        };
        match &r.record {
            None => {
                md.push_str(&format!(
                    "| {} | - | - | - | - | - | - | - | - | - | - | {md_status} |\n",
                    r.system
                ));
                csv.push_str(&format!("{},,,,,,,,,,,,,,,,{csv_status}\n", r.system));
            }
            Some(rec) if rec.error.is_some() => {
                md.push_str(&format!(
                    "| {} | {} | {} | {nodes} | {} | - | - | - | - | - | - | {md_status} |\n",
                    r.system, r.rows, r.nnz, rec.precond
                ));
                csv.push_str(&format!(
                    "{},{},{},{csv_nodes},{},,,,,,,,,,,{csv_status}\n",
                    r.system, r.rows, r.nnz, rec.precond
                ));
            }
            Some(rec) => {
                let total = rec.setup_s + rec.solve_s;
                let bold = fastest.get(r.system.as_str()) == Some(&total);
                let name = if bold {
                    format!("**{}**", rec.precond)
                } else {
                    rec.precond.clone()
                };
                let memory = rec.setup_bytes.map_or("-".into(), |b| {
                    format!("{:.1}", b as f64 / (1 << 20) as f64)
                });
                md.push_str(&format!(
                    "| {} | {} | {} | {nodes} | {name} | {} | {} | {} | {} | {} | {memory} | {md_status} |\n",
                    r.system,
                    r.rows,
                    r.nnz,
                    rec.iterations,
                    num(rec.setup_s, 1e3, 3),
                    num(rec.solve_s, 1e3, 3),
                    num(total, 1e3, 3),
                    if rec.rel_residual.is_finite() {
                        format!("{:.1e}", rec.rel_residual)
                    } else {
                        "-".into()
                    },
                ));
                csv.push_str(&format!(
                    "{},{},{},{csv_nodes},{},{},{:e},{:e},{:e},{:e},{},{},{},{},{},{csv_status}\n",
                    r.system,
                    r.rows,
                    r.nnz,
                    rec.precond,
                    rec.iterations,
                    rec.setup_s,
                    rec.solve_s,
                    total,
                    rec.rel_residual,
                    rec.recursive_rel_residual
                        .map_or(String::new(), |v| format!("{v:e}")),
                    rec.setup_bytes.map_or(String::new(), |b| b.to_string()),
                    opt(rec.lambda_min),
                    opt(rec.lambda_max),
                    opt(rec.condition),
                ));
            }
        }
    }
    (md, csv)
}
