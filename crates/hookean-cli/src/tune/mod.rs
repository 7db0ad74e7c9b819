//! `hookean tune`: which preconditioner, with which options, solves one
//! system fastest (set-up plus solve, to the tolerance), within a time
//! budget; the winner as a `hookean solve` command line and as a scene
//! `[solver]` table.
//!
//! # The grid
//! Every candidate is a point of a fixed grid: a preconditioner, a matrix
//! storage (the one `hookean solve` picks first, then CSR with 1, 2 or 3
//! unknowns per node and 3x3 block storage, where the size allows), and one
//! value of each of its options ([`Axis`]): SSOR's omega, MIC(0)'s omega,
//! and the multigrid's smoother, sweeps, strength threshold, coarse size,
//! prolongation weight and precision. IC(0) has no option (no shift
//! exists in hookean-sparse); the multigrid's Jacobi weight, power
//! iterations and level limit stay at their defaults. The first value of
//! every axis is the library's default.
//!
//! # The search
//! 1. The default of every preconditioner, the multigrid's first (the
//!    *default configuration*: `hookean solve --precond amg`).
//! 2. Coordinate descent: every neighbour of the best point (one option,
//!    or the storage, changed) not yet measured; move to the new best and
//!    repeat until no neighbour wins; then the same around the default of
//!    the next-fastest preconditioner, and so on, until the budget is
//!    spent. `--exhaustive` measures the whole grid instead.
//! 3. The front-runners (within 25% of the best, at most 5, and the
//!    default configuration) are measured again in interleaved rounds;
//!    each keeps the best total of its runs: `--repeat` rounds, or more
//!    when a round is short, until the rounds add up to
//!    [`CONFIRM_SECONDS`] (at most [`MAX_ROUNDS`]), so that a candidate
//!    solved in a millisecond is timed by the best of many runs, not of
//!    three.
//!
//! Before step 1 the default configuration is run once untimed: the first
//! solve of a process pays for its page faults and cold caches, and would
//! otherwise count them against the default alone.
//!
//! A candidate is stopped once it has taken twice the best total so far
//! (it cannot win) or the rest of the budget.
//!
//! # The ranking rule
//! Candidates whose solves are the same computation (the same iteration
//! count and the same final residual, bit for bit: an option that does not
//! change this system's hierarchy, such as a coarse size above its
//! coarsest level) are one candidate, timed by the fastest of them. Among
//! the converged candidates, every one within [`MARGIN`] (5%) of the
//! fastest ties; of those, the one with the fewest options away from its
//! preconditioner's defaults wins, then the fastest of those, then the one
//! measured first (equal times). The default
//! configuration is measured first, so it wins unless another is faster by
//! more than the margin. The margin is the bar's own tolerance (a winner
//! within 5% of the best of the grid) and about the spread of one timed
//! solve on a shared machine, so that two runs do not pick two points whose
//! difference is the machine's. The order of the candidates is a pure
//! function of the system's size ([`layouts`], [`grid`], [`neighbours`]);
//! which neighbours are visited depends on measured times, so the same
//! input and budget give the same winner when no two candidates lie near
//! the margin, no two equally simple ones within it lie within their
//! timing spread, and the search ends before the budget does (a budget cut
//! short by a slower machine visits fewer).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use hookean_sparse::{SymBlockMatrix, check_csr_symmetric};

mod grid;
pub use grid::*;

use crate::CliError;
use crate::solve::{
    Matrix, Plan, RunOptions, SolveRecord, Solver, SystemArgs, cg_params, read_system, run_solver,
};

#[derive(Debug, Args)]
pub struct TuneArgs {
    /// The matrix A, `--rhs`, the storage measured first (`--format`), `--block-size`,
    /// `--nullspace` and `--coordinates`, as `hookean solve` takes them.
    #[command(flatten)]
    system: SystemArgs,
    /// Wall-clock seconds for the search, > 0 (the default configuration is always measured;
    /// no candidate starts once the budget, less what the final repeats need, is spent).
    #[arg(long, default_value_t = 60.0, allow_negative_numbers = true)]
    budget: f64,
    /// Measure every point of the grid, whatever the budget.
    #[arg(long)]
    exhaustive: bool,
    /// Relative residual tolerance |r| / |b| of PCG, in [0, 1).
    #[arg(long, default_value_t = 1e-8, allow_negative_numbers = true)]
    rtol: f64,
    /// PCG iteration limit, 0 to 10^7 (default 2 n).
    #[arg(long)]
    max_iter: Option<usize>,
    /// Runs of each front-runner (1 to 100), more while they add up to under 0.5 s in all
    /// (at most 100); the best total is kept.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Write tune.csv (every candidate) into this folder; it must not exist unless --force.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Replace an existing --out folder of an earlier hookean command.
    #[arg(long)]
    force: bool,
    /// Refuse a matrix that would need more memory than this (GiB), in (0, the machine's memory].
    #[arg(
        long,
        value_name = "GIB",
        default_value_t = 8.0,
        allow_negative_numbers = true
    )]
    max_memory: f64,
    /// No progress lines on stderr.
    #[arg(long)]
    quiet: bool,
}

/// Candidates within this fraction of the fastest tie (the ranking rule).
pub const MARGIN: f64 = 0.05;
/// A candidate is stopped once it has taken this many times the best total.
const CUTOFF: f64 = 2.0;
/// Front-runners: within this factor of the best single run ...
const FRONT_FACTOR: f64 = 1.25;
/// ... at most this many (besides the default configuration).
const FRONT_MAX: usize = 5;
/// The most `--repeat`.
const MAX_REPEAT: usize = 100;
/// The final rounds last at least this long in all (seconds) ...
pub const CONFIRM_SECONDS: f64 = 0.5;
/// ... in at most this many rounds.
pub const MAX_ROUNDS: usize = 100;

/// Rounds of the final repeats (module doc, step 3) when one round over
/// the front-runners takes `round_s` seconds: `repeat`, or as many as
/// [`CONFIRM_SECONDS`] needs, at most [`MAX_ROUNDS`].
pub fn confirm_rounds(repeat: usize, round_s: f64) -> usize {
    let needed = if round_s > 0.0 {
        (CONFIRM_SECONDS / round_s).ceil().min(MAX_ROUNDS as f64) as usize
    } else {
        MAX_ROUNDS
    };
    repeat.max(needed)
}

/// One measured candidate.
#[derive(Debug, Clone)]
pub struct Trial {
    pub point: Point,
    /// Runs made.
    pub runs: usize,
    pub iterations: usize,
    pub setup_s: f64,
    pub solve_s: f64,
    pub rel_residual: f64,
    pub converged: bool,
    /// `converged`, or why not.
    pub status: String,
}

impl Trial {
    /// Set-up plus solve of the best run.
    pub fn total(&self) -> f64 {
        self.setup_s + self.solve_s
    }
}

/// What a solve computed: its iteration count and its final relative
/// residual's bits. Two trials with the same outcome ran the same
/// computation (the ranking rule).
pub type Outcome = (usize, u64);

/// The winner among `trials` by the ranking rule (module doc): `None` if
/// none converged. `changes` is each trial's [`Point::changes`], `outcomes`
/// each trial's [`Outcome`].
pub fn rank(totals: &[Option<f64>], changes: &[usize], outcomes: &[Outcome]) -> Option<usize> {
    // Each trial timed by the fastest trial of the same computation.
    let time: Vec<Option<f64>> = (0..totals.len())
        .map(|i| {
            totals[i]?;
            (0..totals.len())
                .filter(|&j| outcomes[j] == outcomes[i])
                .filter_map(|j| totals[j])
                .reduce(f64::min)
        })
        .collect();
    let fastest = time.iter().flatten().copied().fold(f64::INFINITY, f64::min);
    if !fastest.is_finite() {
        return None;
    }
    (0..totals.len())
        .filter(|&i| time[i].is_some_and(|t| t <= (1.0 + MARGIN) * fastest))
        .min_by(|&i, &j| {
            changes[i]
                .cmp(&changes[j])
                .then(
                    time[i]
                        .unwrap_or(f64::INFINITY)
                        .total_cmp(&time[j].unwrap_or(f64::INFINITY)),
                )
                .then(i.cmp(&j))
        })
}

/// The front-runners of `totals` (the converged trials' times): the first
/// trial if it converged, and those within [`FRONT_FACTOR`] of the
/// fastest, fastest first, at most [`FRONT_MAX`] of them.
pub fn front_runners(totals: &[Option<f64>]) -> Vec<usize> {
    let fastest = totals
        .iter()
        .flatten()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let mut near: Vec<usize> = (0..totals.len())
        .filter(|&i| totals[i].is_some_and(|t| t <= FRONT_FACTOR * fastest))
        .collect();
    near.sort_by(|&i, &j| {
        totals[i]
            .unwrap_or(f64::INFINITY)
            .total_cmp(&totals[j].unwrap_or(f64::INFINITY))
            .then(i.cmp(&j))
    });
    near.truncate(FRONT_MAX);
    if totals.first().is_some_and(Option::is_some) && !near.contains(&0) {
        near.insert(0, 0);
    }
    near
}

/// The search's state: the system, its storages, the trials so far.
struct Tuner<'a> {
    args: &'a TuneArgs,
    a: sprs::CsMat<f64>,
    b: Vec<f64>,
    near_nullspace: Vec<Vec<f64>>,
    layouts: Vec<Layout>,
    /// The system in each storage (or why it cannot be).
    matrices: Vec<Result<Matrix, String>>,
    plan: Plan,
    trials: Vec<Trial>,
    start: Instant,
}

impl Tuner<'_> {
    fn totals(&self) -> Vec<Option<f64>> {
        self.trials
            .iter()
            .map(|t| t.converged.then(|| t.total()))
            .collect()
    }

    fn best(&self) -> Option<usize> {
        let changes: Vec<usize> = self
            .trials
            .iter()
            .map(|t| t.point.changes(&self.layouts))
            .collect();
        let outcomes: Vec<Outcome> = self
            .trials
            .iter()
            .map(|t| (t.iterations, t.rel_residual.to_bits()))
            .collect();
        rank(&self.totals(), &changes, &outcomes)
    }

    /// Seconds of the budget left after the final repeats of today's
    /// front-runners (infinite with `--exhaustive`).
    fn left(&self) -> f64 {
        if self.args.exhaustive {
            return f64::INFINITY;
        }
        let totals = self.totals();
        let round: f64 = front_runners(&totals)
            .iter()
            .filter_map(|&i| totals[i])
            .sum();
        let reserve = round * (confirm_rounds(self.args.repeat, round) - 1) as f64;
        self.args.budget - self.start.elapsed().as_secs_f64() - reserve
    }

    /// One run of `point` stopped after `limit` seconds.
    fn run(&self, point: &Point, limit: Option<f64>) -> SolveRecord {
        match &self.matrices[point.layout] {
            Ok(matrix) => run_solver(
                &Solver::Pcg(point.options()),
                matrix,
                &self.a,
                &self.b,
                &self.plan,
                &RunOptions {
                    near_nullspace: if point.kind == Kind::Amg {
                        self.near_nullspace.clone()
                    } else {
                        Vec::new()
                    },
                    time_limit: limit,
                    ..Default::default()
                },
            ),
            Err(reason) => {
                let mut r = crate::solve::empty_record("hookean-pcg", String::new(), "");
                r.error = Some(reason.clone());
                r
            }
        }
    }

    /// Measures `point` once (unless measured or the budget is spent);
    /// `false` when the budget is spent.
    fn measure(&mut self, point: Point) -> bool {
        if self.trials.iter().any(|t| t.point == point) {
            return true;
        }
        let left = self.left();
        if !self.trials.is_empty() && left <= 0.0 {
            return false;
        }
        let best = self.best().map(|i| CUTOFF * self.trials[i].total());
        let limit = [best, left.is_finite().then_some(left.max(0.0))]
            .into_iter()
            .flatten()
            .reduce(f64::min);
        let record = self.run(&point, limit);
        let status = match (&record.error, record.converged) {
            (Some(e), _) => format!("failed: {e}"),
            (None, true) => "converged".to_string(),
            (None, false) if record.timed_out => match best {
                Some(b) if limit == Some(b) => {
                    format!(
                        "stopped at {CUTOFF}x the best total ({:.3} ms)",
                        1e3 * b / CUTOFF
                    )
                }
                _ => "stopped: the budget is spent".to_string(),
            },
            (None, false) => format!("not converged (|r|/|b| = {:.1e})", record.rel_residual),
        };
        let trial = Trial {
            point,
            runs: 1,
            iterations: record.iterations,
            setup_s: record.setup_s,
            solve_s: record.solve_s,
            rel_residual: record.rel_residual,
            converged: record.converged && record.error.is_none(),
            status,
        };
        self.progress(self.trials.len(), &trial, "");
        self.trials.push(trial);
        true
    }

    fn progress(&self, index: usize, t: &Trial, note: &str) {
        if self.args.quiet {
            return;
        }
        crate::errln!(
            "hookean tune: [{}] {:<60} {:>10.3} ms {:>6} iterations  {}{note}",
            index + 1,
            t.point.label(&self.layouts),
            1e3 * t.total(),
            t.iterations,
            t.status
        );
    }

    /// Coordinate descent from `start`: `false` when the budget is spent.
    fn descend(&mut self, start: Point) -> bool {
        let mut center = start;
        loop {
            for p in neighbours(&center, &self.layouts) {
                if !self.measure(p) {
                    return false;
                }
            }
            let Some(best) = self.best() else {
                return true;
            };
            let next = self.trials[best].point;
            // Only a neighbour of the center that wins moves it.
            if next == center || next.kind != center.kind {
                return true;
            }
            center = next;
        }
    }

    /// The budgeted search (module doc, steps 1 and 2), after one untimed
    /// run of the default configuration.
    fn search(&mut self) {
        let defaults: Vec<Point> = KINDS
            .iter()
            .filter_map(|&k| Point::default_of(k, &self.layouts))
            .collect();
        if let Some(first) = defaults.first() {
            if !self.args.quiet {
                crate::errln!(
                    "hookean tune: warming up: {} once, untimed",
                    first.label(&self.layouts)
                );
            }
            let left = self.args.budget - self.start.elapsed().as_secs_f64();
            let limit = (!self.args.exhaustive).then_some(left.max(0.0));
            self.run(first, limit);
        }
        for &d in &defaults {
            if !self.measure(d) {
                return;
            }
        }
        if self.args.exhaustive {
            for p in grid(&self.layouts) {
                self.measure(p);
            }
            return;
        }
        // The kinds by their default's time, fastest first; the failed last.
        let mut order: Vec<usize> = (0..self.trials.len()).collect();
        order.sort_by(|&i, &j| {
            let t = |k: usize| {
                let tr = &self.trials[k];
                if tr.converged {
                    tr.total()
                } else {
                    f64::INFINITY
                }
            };
            t(i).total_cmp(&t(j)).then(i.cmp(&j))
        });
        // Around the overall best first (perhaps a tuned point), then each
        // kind's default.
        if let Some(best) = self.best()
            && !self.descend(self.trials[best].point)
        {
            return;
        }
        for i in order {
            if self.trials[i].converged && !self.descend(self.trials[i].point) {
                return;
            }
        }
    }

    /// The final repeats (module doc, step 3): interleaved rounds over the
    /// front-runners, each keeping its best total.
    fn confirm(&mut self) -> Vec<usize> {
        let totals = self.totals();
        let front = front_runners(&totals);
        let round: f64 = front.iter().filter_map(|&i| totals[i]).sum();
        for _ in 1..confirm_rounds(self.args.repeat, round) {
            for &i in &front {
                let r = self.run(&self.trials[i].point, None);
                let t = &mut self.trials[i];
                if r.error.is_none() && r.converged {
                    t.runs += 1;
                    if r.setup_s + r.solve_s < t.total() {
                        t.setup_s = r.setup_s;
                        t.solve_s = r.solve_s;
                        t.iterations = r.iterations;
                        t.rel_residual = r.rel_residual;
                    }
                }
            }
        }
        for &i in &front {
            let note = format!(" (best of {} runs)", self.trials[i].runs);
            self.progress(i, &self.trials[i], &note);
        }
        front
    }
}

/// `s` quoted for a POSIX shell when it needs it.
fn shell_word(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./:=+,@%".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

/// The winner as a `hookean solve` command line (every flag away from
/// `hookean solve`'s defaults, the storage always).
fn solve_command(args: &TuneArgs, point: &Point, layouts: &[Layout]) -> String {
    let mut w: Vec<String> = vec![
        "hookean".into(),
        "solve".into(),
        args.system.matrix.display().to_string(),
    ];
    if let Some(r) = &args.system.rhs {
        w.extend(["--rhs".into(), r.display().to_string()]);
    }
    // The near-nullspace and the coordinates are the multigrid's inputs;
    // for another winner they are left out (the storage flags below say
    // what they would have said about the nodes, and a near-nullspace of
    // one vector per scalar unknown does not fit 3x3 block storage).
    if point.kind == Kind::Amg {
        if let Some(p) = &args.system.nullspace {
            w.extend(["--nullspace".into(), p.display().to_string()]);
        }
        if let Some(p) = &args.system.coordinates {
            w.extend(["--coordinates".into(), p.display().to_string()]);
        }
    }
    w.extend(["--precond".into(), point.kind.name().into()]);
    w.extend(layouts[point.layout].flags());
    for (k, axis) in point.own_axes() {
        if point.axes[k] != 0 {
            w.extend([axis.flag().into(), axis.value(point.axes[k])]);
        }
    }
    w.extend(["--rtol".into(), format!("{:?}", args.rtol)]);
    if let Some(m) = args.max_iter {
        w.extend(["--max-iter".into(), m.to_string()]);
    }
    w.iter()
        .map(|s| shell_word(s))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The winner as a scene's `[solver]` (and `[solver.amg]`) table, with a
/// comment for what a scene cannot say.
fn scene_table(args: &TuneArgs, point: &Point, layouts: &[Layout]) -> String {
    let mut solver = vec![format!("preconditioner = \"{}\"", point.kind.name())];
    if args.rtol > 0.0 {
        solver.push(format!("cg_rtol = {:?}", args.rtol));
    }
    let mut amg = Vec::new();
    for (k, axis) in point.own_axes() {
        if point.axes[k] != 0 {
            let (table, key) = axis.scene_key();
            let line = format!("{key} = {}", axis.toml(point.axes[k]));
            if table == "solver" {
                solver.push(line);
            } else {
                amg.push(line);
            }
        }
    }
    let mut s = format!("[solver]\n{}\n", solver.join("\n"));
    if !amg.is_empty() {
        s.push_str(&format!("\n[solver.amg]\n{}\n", amg.join("\n")));
    }
    if layouts[point.layout] != Layout::Block {
        s.push_str(&format!(
            "# storage {}: no scene key (a scene's systems are 3x3 blocks, one per particle)\n",
            layouts[point.layout].label()
        ));
    }
    s
}

/// `tune.csv`: one row per trial, in measuring order.
fn csv(trials: &[Trial], layouts: &[Layout], winner: Option<usize>) -> String {
    let mut s = String::from(
        "index,preconditioner,storage,options,changes,runs,iterations,setup_s,solve_s,total_s,rel_residual,winner,status\n",
    );
    for (i, t) in trials.iter().enumerate() {
        let label = t.point.label(layouts);
        let options: Vec<&str> = label.split(' ').skip(2).collect();
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{:e},{:e},{:e},{:e},{},\"{}\"\n",
            i + 1,
            t.point.kind.name(),
            layouts[t.point.layout].label(),
            options.join(";"),
            t.point.changes(layouts),
            t.runs,
            t.iterations,
            t.setup_s,
            t.solve_s,
            t.total(),
            t.rel_residual,
            winner == Some(i),
            t.status.replace('"', "\"\"")
        ));
    }
    s
}

pub fn run(args: &TuneArgs) -> Result<(), CliError> {
    if !(args.budget > 0.0 && args.budget.is_finite()) {
        return Err(CliError::Input(format!(
            "--budget must be a positive number of seconds, got {}",
            hookean_sparse::AsWritten(args.budget)
        )));
    }
    if !(1..=MAX_REPEAT).contains(&args.repeat) {
        return Err(CliError::Input(format!(
            "--repeat must lie in 1 to {MAX_REPEAT}, got {}",
            args.repeat
        )));
    }
    let params = cg_params(args.rtol, args.max_iter)?;
    let cap = crate::memory::cap_bytes(args.max_memory)?;
    // The output folder is checked before the search, not after it.
    let staging = match &args.out {
        Some(out) => {
            let mut inputs: Vec<&Path> = vec![&args.system.matrix];
            inputs.extend(args.system.rhs.as_deref());
            inputs.extend(args.system.nullspace.as_deref());
            inputs.extend(args.system.coordinates.as_deref());
            Some(crate::output::Staging::new(
                "tune", out, "--out", args.force, &inputs,
            )?)
        }
        None => None,
    };
    let (system, near_nullspace) = read_system(&args.system, cap)?;
    check_csr_symmetric(&system.a).map_err(|e| {
        CliError::Input(format!(
            "{}: {e} (PCG needs a symmetric matrix)",
            args.system.matrix.display()
        ))
    })?;
    let first = match system.matrix {
        Matrix::Block(_) => Layout::Block,
        Matrix::Csr { block_size, .. } => Layout::Csr(block_size),
    };
    let layouts = layouts(system.b.len(), first);
    let mut first_matrix = Some(system.matrix);
    let matrices = layouts
        .iter()
        .map(|&l| match (l, first_matrix.take()) {
            (_, Some(m)) => Ok(m),
            (Layout::Csr(d), None) => Ok(Matrix::csr(system.a.clone(), d)),
            (Layout::Block, None) => SymBlockMatrix::from_csr(&system.a)
                .map(Matrix::Block)
                .map_err(|e| format!("no block storage: {e}")),
        })
        .collect();
    let plan = Plan {
        solvers: Vec::new(),
        params,
        repeat: 1,
        cap,
        mic0_from_all: false,
    };
    let mut tuner = Tuner {
        args,
        a: system.a,
        b: system.b,
        near_nullspace,
        layouts,
        matrices,
        plan,
        trials: Vec::new(),
        start: Instant::now(),
    };
    tuner.search();
    tuner.confirm();
    let winner = tuner.best();
    let layouts = &tuner.layouts;
    if let Some(staging) = staging {
        let text = csv(&tuner.trials, layouts, winner);
        match crate::output::write_text(&staging.dir().join("tune.csv"), &text) {
            Ok(()) => staging.commit()?,
            Err(e) => return Err(staging.abandon(e)),
        }
    }
    let Some(w) = winner else {
        return Err(CliError::Failed(format!(
            "{}: no candidate reached --rtol {} ({} tried; their reasons are above)",
            args.system.matrix.display(),
            hookean_sparse::AsWritten(args.rtol),
            tuner.trials.len()
        )));
    };
    let t = &tuner.trials[w];
    let default = &tuner.trials[0];
    crate::outln!(
        "winner: {} — {:.3} ms (set-up {:.3} + solve {:.3}), {} iterations, best of {} runs; \
         the default ({}) {}; {} candidates in {:.1} s",
        t.point.label(layouts),
        1e3 * t.total(),
        1e3 * t.setup_s,
        1e3 * t.solve_s,
        t.iterations,
        t.runs,
        default.point.label(layouts),
        if default.converged {
            format!(
                "{:.3} ms ({:.2}x)",
                1e3 * default.total(),
                default.total() / t.total()
            )
        } else {
            default.status.clone()
        },
        tuner.trials.len(),
        tuner.start.elapsed().as_secs_f64()
    )?;
    crate::outln!("")?;
    crate::outln!("{}", solve_command(args, &t.point, layouts))?;
    crate::outln!("")?;
    crate::outln!("{}", scene_table(args, &t.point, layouts).trim_end())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use hookean_sparse::{AmgOptions, PrecondKind, PreconditionerOptions};

    #[test]
    fn the_first_value_of_every_axis_is_the_librarys_default() {
        let d = AmgOptions::default();
        assert_eq!(SMOOTHERS[0], d.smoother);
        assert_eq!(SWEEPS[0], d.sweeps);
        assert_eq!(STRENGTHS[0], d.strength_threshold);
        assert_eq!(COARSE_SIZES[0], d.coarse_size);
        assert_eq!(PROLONGATION_WEIGHTS[0], d.prolongation_weight);
        assert_eq!(PRECISIONS[0], d.precision);
        assert_eq!(MIC_OMEGAS[0], 0.99);
        assert_eq!(OMEGAS[0], 1.0);
        let p = Point::default_of(Kind::Amg, &[Layout::Csr(1)]).unwrap();
        assert_eq!(p.options(), PreconditionerOptions::from(PrecondKind::Amg));
    }

    #[test]
    fn storages_follow_the_size() {
        assert_eq!(
            layouts(10, Layout::Csr(1)),
            [Layout::Csr(1), Layout::Csr(2)]
        );
        assert_eq!(
            layouts(12, Layout::Block),
            [
                Layout::Block,
                Layout::Csr(1),
                Layout::Csr(2),
                Layout::Csr(3)
            ]
        );
        assert_eq!(layouts(7, Layout::Csr(1)), [Layout::Csr(1)]);
    }

    #[test]
    fn the_grid_is_the_product_of_the_axes_in_a_fixed_order() {
        let l = layouts(12, Layout::Block); // 4 storages, 2 of them kinds
        let g = grid(&l);
        // amg: 3 * 3 * 4 * 3 * 2 * 2 = 432 per storage; ssor 6 on 2
        // storages; mic0 5 on block; block-jacobi 4 storages; ic0, jacobi,
        // none 2 storages each.
        assert_eq!(g.len(), 432 * 4 + 6 * 2 + 5 + 4 + 3 * 2);
        // Each point once.
        for (i, p) in g.iter().enumerate() {
            assert!(!g[..i].contains(p), "{p:?} twice");
        }
        // The defaults first, the multigrid's the very first.
        let kinds: Vec<Kind> = g[..7].iter().map(|p| p.kind).collect();
        assert_eq!(kinds, KINDS);
        assert!(g[..7].iter().all(|p| p.changes(&l) == 0));
        assert_eq!(g[0].layout, 0);
        // Deterministic.
        assert_eq!(g, grid(&l));
        // No MIC(0) without block storage.
        assert!(
            grid(&layouts(10, Layout::Csr(1)))
                .iter()
                .all(|p| p.kind != Kind::Mic0)
        );
    }

    #[test]
    fn neighbours_change_one_thing() {
        let l = layouts(12, Layout::Block);
        let c = Point::default_of(Kind::Amg, &l).unwrap();
        let n = neighbours(&c, &l);
        // (3-1) + (3-1) + (4-1) + (3-1) + (2-1) + (2-1) options, 3 storages.
        assert_eq!(n.len(), 11 + 3);
        assert!(n.iter().all(|p| p.changes(&l) == 1));
        assert!(n.iter().all(|p| grid(&l).contains(p)));
        let ssor = Point::default_of(Kind::Ssor, &l).unwrap();
        assert_eq!(neighbours(&ssor, &l).len(), 5 + 1);
    }

    #[test]
    fn short_rounds_are_repeated_until_they_add_up() {
        // 0.1 s rounds: --repeat's 3 already cover 0.3 s, 5 are needed for 0.5 s.
        assert_eq!(confirm_rounds(3, 0.1), 5);
        // 0.3 s rounds: 2 reach 0.5 s, but --repeat asks for 3.
        assert_eq!(confirm_rounds(3, 0.3), 3);
        // A millisecond round: 500 would be needed; the cap holds.
        assert_eq!(confirm_rounds(3, 1e-3), MAX_ROUNDS);
        assert_eq!(confirm_rounds(1, 0.0), MAX_ROUNDS);
        // --repeat above what the time needs is kept.
        assert_eq!(confirm_rounds(7, 1.0), 7);
    }

    #[test]
    fn the_ranking_favours_the_simpler_within_the_margin() {
        // Every trial a computation of its own.
        let own = |n: usize| (0..n).map(|i| (i, 0)).collect::<Vec<Outcome>>();
        // The default (0 changes) 4% slower than a tuned point: the default wins.
        assert_eq!(rank(&[Some(1.04), Some(1.0)], &[0, 1], &own(2)), Some(0));
        // 6% slower: the tuned point wins.
        assert_eq!(rank(&[Some(1.06), Some(1.0)], &[0, 1], &own(2)), Some(1));
        // Of equally simple ones within the margin, the fastest (not the
        // first measured: ties by index alone let a winner be up to the
        // margin slower than an equally simple rival) ...
        assert_eq!(
            rank(&[Some(1.03), Some(1.0), Some(1.01)], &[1, 1, 1], &own(3)),
            Some(1)
        );
        // ... and of equal times, the first measured.
        assert_eq!(
            rank(&[Some(1.0), Some(1.0), Some(1.01)], &[1, 1, 1], &own(3)),
            Some(0)
        );
        // A simpler one within the margin still beats a faster one.
        assert_eq!(
            rank(&[Some(1.03), Some(1.0), Some(1.04)], &[2, 2, 1], &own(3)),
            Some(2)
        );
        // Failed trials never win.
        assert_eq!(rank(&[None, Some(3.0)], &[0, 2], &own(2)), Some(1));
        assert_eq!(rank(&[None, None], &[0, 0], &own(2)), None);
    }

    #[test]
    fn the_same_computation_is_one_candidate_timed_by_its_fastest_run() {
        // Trials 0 and 2 ran the same solve (same iterations and residual
        // bits): 2's faster time is 0's, so the simpler 0 ties with the
        // fastest, 1, and wins on its fewer changes.
        let same = 1e-9f64.to_bits();
        let outcomes = [(18, same), (18, 2e-9f64.to_bits()), (18, same)];
        let totals = [Some(1.10), Some(1.0), Some(1.01)];
        assert_eq!(rank(&totals, &[1, 2, 2], &outcomes), Some(0));
        // Apart, 0 is 10% slower than 1 and loses.
        let apart = [(18, same), (18, 2e-9f64.to_bits()), (18, 3e-9f64.to_bits())];
        assert_eq!(rank(&totals, &[1, 2, 2], &apart), Some(1));
        // A failed trial lends no time to its computation.
        assert_eq!(
            rank(&[Some(1.10), Some(1.0), None], &[1, 2, 2], &outcomes),
            Some(1)
        );
    }

    #[test]
    fn the_front_runners_hold_the_default() {
        let totals = [Some(2.0), Some(1.0), Some(1.2), None, Some(1.3)];
        assert_eq!(front_runners(&totals), [0, 1, 2]);
        assert_eq!(front_runners(&[None, Some(1.0)]), [1]);
    }

    #[test]
    fn the_command_line_names_the_near_nullspace_for_a_multigrid_winner_only() {
        #[derive(clap::Parser)]
        struct Wrap {
            #[command(flatten)]
            tune: TuneArgs,
        }
        let l = layouts(966, Layout::Csr(1));
        let amg = Point::default_of(Kind::Amg, &l).unwrap();
        // IC(0) on 3x3 blocks: a one-vector near-nullspace of scalar
        // unknowns would not fit the blocks, and IC(0) does not read it.
        let ic0 = Point::default_of(Kind::Ic0, &l).unwrap();
        for (flag, file) in [("--nullspace", "B.mtx"), ("--coordinates", "C.mtx")] {
            let args = <Wrap as clap::Parser>::try_parse_from(["tune", "A.mtx", flag, file])
                .unwrap()
                .tune;
            let line = solve_command(&args, &amg, &l);
            assert!(line.contains(&format!("{flag} {file}")), "{line}");
            let line = solve_command(&args, &ic0, &l);
            assert!(
                !line.contains(flag) && line.contains("--precond ic0"),
                "{line}"
            );
        }
    }

    #[test]
    fn words_with_spaces_are_quoted() {
        assert_eq!(shell_word("data/a.mtx"), "data/a.mtx");
        assert_eq!(shell_word("my dir/a.mtx"), "'my dir/a.mtx'");
        assert_eq!(shell_word("it's"), "'it'\\''s'");
    }
}
