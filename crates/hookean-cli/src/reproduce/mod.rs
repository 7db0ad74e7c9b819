//! `hookean reproduce`: every claim of the two papers this project
//! implements, measured and checked, with every figure.
//!
//! Writes into the output folder (default `out/reproduce`): `claims.md` and
//! `claims.json` (claim, the paper's value, the measured value, the
//! tolerance, pass), and the figures: `fig3-tutorial1.svg`,
//! `fig4-regions.svg`, `fig5-tutorial3.svg`, `fig7-wave.svg` (the
//! tutorial's), `filter/fig4-*.png`, `filter/fig5-*.png`, `filter/fig6.svg`,
//! `fig8-particles.svg`, `fig8-k0.svg` and `fig8.csv` (the filtering
//! paper's). Exit code 1 if a claim fails (the outputs are written anyway).

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, Parser, ValueEnum};
use hookean::SimulationOptions;
use hookean_filter::{
    BisectionOptions, ExplicitScheme, Figure8Method, Figure8Row, FilterCoupling, FilterOptions,
    Form, ModelIntegrator, RunOptions, figure8_runs, measure_stable_step, predict_dt_max,
    run_bounded,
};
use hookean_massspring::{ClothParams, MassSpringModel, State, cloth};
use hookean_ode::stability::{ComplexGrid, sample_region};
use hookean_ode::tutorial::{Dahlquist, LinearOscillator};
use hookean_ode::workprecision::{self, Sweep, WorkPrecisionRow, observed_order};
use hookean_ode::{
    FirstOrderIntegrator, ForcingTerm, Method, NewtonMethod, NewtonOptions, SecondOrderIntegrator,
    SecondOrderProblem, SolverOptions,
};
use hookean_sparse::{
    CgParams, CgWorkspace, Constraints, IsoBlockMatrix, LinearOperator, PrecondKind,
    PreconditionerSetup, SymBlockMatrix, filtered_pcg,
};
use serde::Serialize;

use crate::CliError;
use crate::lineplot::{LogLogPlot, Series};

mod filtering;
mod tutorial;

use filtering::*;
use tutorial::*;

/// Which paper's claims to reproduce.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Paper {
    /// Hauth, Numerical Techniques for Soft Object Simulation (claims 1-9).
    Tutorial,
    /// Ahmad et al., Stability Analysis of Filtered Mass-Spring Systems (claims 10-14).
    Filter,
    /// Both.
    All,
}

#[derive(Debug, Args)]
pub struct ReproduceArgs {
    /// Which paper: tutorial (claims 1-9), filter (10-14) or all.
    #[arg(long, value_enum, default_value_t = Paper::All)]
    paper: Paper,
    /// The output folder (default out/reproduce).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Smaller cloths, shorter runs and coarser sweeps: under a minute in
    /// a release build. The tolerances stay the same.
    #[arg(long)]
    quick: bool,
    /// Only these claims (comma-separated numbers 1-14), e.g. for a test.
    #[arg(long, value_delimiter = ',')]
    claims: Vec<usize>,
    /// Replace an existing output folder of an earlier reproduce run.
    #[arg(long)]
    force: bool,
}

/// One row of the table.
#[derive(Debug, Clone, Serialize)]
struct Claim {
    id: usize,
    paper: &'static str,
    claim: &'static str,
    paper_value: String,
    measured: String,
    tolerance: String,
    pass: bool,
    /// Why it misses, or what the number means, in the papers' words.
    note: String,
    /// Wall-clock seconds this claim took.
    seconds: f64,
}

/// What a claim function returns (the id, paper and text are the list's).
struct Outcome {
    paper_value: String,
    measured: String,
    tolerance: String,
    pass: bool,
    note: String,
}

/// The whole record (claims.json).
#[derive(Debug, Serialize)]
struct Record {
    quick: bool,
    threads: usize,
    seconds: f64,
    passed: usize,
    total: usize,
    claims: Vec<Claim>,
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

/// The claims, in the order of the README's list.
type ClaimFn = fn(&Ctx) -> Result<Outcome, CliError>;
const CLAIMS: [(&str, &str, ClaimFn); 14] = [
    (
        "tutorial",
        "observed orders of convergence equal the methods' orders (figs. 3, 5, 7)",
        orders,
    ),
    (
        "tutorial",
        "stability limits on y' = -15 y: explicit Euler h < 2/15, RK4 h < 2.785/15 (example 1)",
        stability_limits,
    ),
    (
        "tutorial",
        "stability regions (fig. 4): implicit Euler, midpoint and BDF2 are A-stable; explicit Euler's region is the disc |1 + z| <= 1",
        regions,
    ),
    (
        "tutorial",
        "work-precision (fig. 5): implicit methods give approximations even at large steps, explicit Euler does not",
        large_steps,
    ),
    (
        "tutorial",
        "implicit Euler stays bounded on example 3 at a large step (fig. 2b)",
        example3_bounded,
    ),
    (
        "tutorial",
        "Verlet is the cheapest method on the undamped wave y'' = -5 y (fig. 7)",
        verlet_best,
    ),
    (
        "tutorial",
        "inexact Newton (eta = 0.02) needs fewer CG iterations than exact Newton (section 3.2)",
        inexact_newton,
    ),
    (
        "tutorial",
        "eq. 50: a third of the nonzeros, so a CG iteration takes a third of the time (section 3.3)",
        eq50,
    ),
    (
        "tutorial",
        "filtered CG meets the constraints exactly (section 4.2)",
        filtered_cg,
    ),
    (
        "filter",
        "lambda = 1 doubles the stable step, lambda > 10 does not change it (fig. 6)",
        figure6,
    ),
    (
        "filter",
        "a 1.25x larger step is stable only with the filter (section 7.1)",
        step_125,
    ),
    (
        "filter",
        "filtering costs about 5% of a step and gives about 20% net speed-up at 1.25x the step (section 7.1)",
        filter_cost,
    ),
    (
        "filter",
        "spectra (figs. 4, 5): FB Euler has more high frequencies; filtered FB Euler is close to backward Euler",
        spectra,
    ),
    (
        "filter",
        "time comparison (fig. 8): explicit methods competitive up to k0 = 1e6, implicit and IMEX faster above",
        figure8,
    ),
];

/// What the claims share: the output folder and the size of the run.
struct Ctx {
    dir: PathBuf,
    quick: bool,
}

impl Ctx {
    /// The drape size of the cloth claims: 32 (quick: 16).
    fn cloth_n(&self) -> usize {
        if self.quick { 16 } else { 32 }
    }
}

pub fn run(args: &ReproduceArgs) -> Result<(), CliError> {
    let wanted: Vec<usize> = if args.claims.is_empty() {
        (1..=14).collect()
    } else {
        for &c in &args.claims {
            if !(1..=14).contains(&c) {
                return Err(CliError::Input(format!(
                    "--claims: claim numbers are 1 to 14, got {c}"
                )));
            }
        }
        args.claims.clone()
    };
    let selected: Vec<usize> = wanted
        .into_iter()
        .filter(|&c| match args.paper {
            Paper::Tutorial => c <= 9,
            Paper::Filter => c >= 10,
            Paper::All => true,
        })
        .collect();
    if selected.is_empty() {
        return Err(CliError::Input(
            "--claims and --paper select no claim (the tutorial's are 1-9, the filtering paper's 10-14)"
                .into(),
        ));
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join("reproduce"));
    let staging = crate::output::Staging::new("reproduce", &out, "--out", args.force, &[])?;
    let result = reproduce(args, &selected, staging.dir());
    match result {
        Ok((record, table)) => {
            staging.commit()?;
            crate::outln!("{table}")?;
            let failed: Vec<String> = record
                .claims
                .iter()
                .filter(|c| !c.pass)
                .map(|c| c.id.to_string())
                .collect();
            crate::errln!(
                "reproduce: {} of {} claims hold in {:.1} s; wrote {}",
                record.passed,
                record.total,
                record.seconds,
                out.display()
            );
            if failed.is_empty() {
                Ok(())
            } else {
                Err(CliError::Failed(format!(
                    "claims {} fail (see {})",
                    failed.join(", "),
                    out.join("claims.md").display()
                )))
            }
        }
        Err(e) => Err(staging.abandon(e)),
    }
}

fn reproduce(
    args: &ReproduceArgs,
    selected: &[usize],
    dir: &Path,
) -> Result<(Record, String), CliError> {
    let ctx = Ctx {
        dir: dir.to_path_buf(),
        quick: args.quick,
    };
    let start = Instant::now();
    let bar = indicatif::ProgressBar::new(selected.len() as u64);
    bar.set_style(crate::bar_style(
        "{bar:30} {pos}/{len} claim {msg} [{elapsed_precise}]",
    ));
    bar.enable_steady_tick(std::time::Duration::from_millis(200));
    let mut claims = Vec::new();
    let quiet = crate::Quiet::new();
    for &id in selected {
        let (paper, claim, f) = CLAIMS[id - 1];
        bar.set_message(format!("{id}: {claim}"));
        let t0 = Instant::now();
        let o = f(&ctx)?;
        // A miss says so first; the claims with a known cause say why in
        // their own note, the others name the tolerance missed.
        let note = if o.pass || o.note.starts_with("misses") {
            o.note
        } else {
            format!(
                "misses: {} is outside the tolerance ({}). {}",
                o.measured, o.tolerance, o.note
            )
        };
        claims.push(Claim {
            id,
            paper,
            claim,
            paper_value: o.paper_value,
            measured: o.measured,
            tolerance: o.tolerance,
            pass: o.pass,
            note,
            seconds: t0.elapsed().as_secs_f64(),
        });
        bar.inc(1);
    }
    drop(quiet);
    bar.finish_and_clear();
    let record = Record {
        quick: args.quick,
        threads: rayon::current_num_threads(),
        seconds: start.elapsed().as_secs_f64(),
        passed: claims.iter().filter(|c| c.pass).count(),
        total: claims.len(),
        claims,
    };
    let table = markdown(&record);
    crate::output::write_text(&dir.join("claims.md"), &table)?;
    crate::output::write_text(
        &dir.join("claims.json"),
        &(crate::to_json(&record, true)? + "\n"),
    )?;
    Ok((record, table))
}

/// The markdown table of the record.
fn markdown(r: &Record) -> String {
    let mut s = format!(
        "{} of {} claims hold ({} run, {} thread(s), {:.1} s).\n\n",
        r.passed,
        r.total,
        if r.quick { "--quick" } else { "full" },
        r.threads,
        r.seconds
    );
    s += "| # | paper | claim | paper's value | measured | tolerance | pass | note |\n";
    s += "|---|---|---|---|---|---|---|---|\n";
    // A '|' inside a cell (|y|, |1 + z|) would end it.
    let cell = |t: &str| t.replace('|', "\\|");
    for c in &r.claims {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            c.id,
            c.paper,
            cell(c.claim),
            cell(&c.paper_value),
            cell(&c.measured),
            cell(&c.tolerance),
            if c.pass { "yes" } else { "**no**" },
            cell(&c.note)
        );
    }
    s
}

/// Runs a subcommand's `run` on arguments as the command line would give them.
fn subcommand<A: Args>(argv: &[String]) -> Result<A, CliError> {
    #[derive(Parser)]
    struct Wrap<A: Args> {
        #[command(flatten)]
        args: A,
    }
    let mut full = vec!["hookean".to_string()];
    full.extend_from_slice(argv);
    Wrap::<A>::try_parse_from(full)
        .map(|w| w.args)
        .map_err(|e| failed(format!("internal arguments {argv:?}: {e}")))
}

fn path_arg(p: &Path) -> String {
    p.display().to_string()
}
