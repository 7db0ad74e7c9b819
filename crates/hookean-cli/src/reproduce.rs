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
    let staging = crate::output::Staging::new(&out, "--out", args.force, &[])?;
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

/// A work-precision sweep of a second-order tutorial problem.
fn oscillator_rows(
    o: LinearOscillator,
    m: &Method,
    n0: usize,
    levels: usize,
) -> Result<Vec<WorkPrecisionRow>, CliError> {
    workprecision::second_order(
        || o.particle(),
        m,
        0.0,
        &o.x0(),
        &o.v0_vec(),
        o.t_end,
        &o.exact_particle(o.t_end),
        &Sweep::halvings(n0, levels),
        &crate::workprecision::tight_options(),
    )
    .map_err(|e| failed(format!("{m}: {e}")))
}

// ---- the tutorial -------------------------------------------------------

/// Claim 1, and the work-precision figures 3, 5 and 7.
fn orders(ctx: &Ctx) -> Result<Outcome, CliError> {
    let levels = if ctx.quick { 8 } else { 11 };
    for (problem, file) in [
        ("tutorial1", "fig3-tutorial1"),
        ("tutorial3", "fig5-tutorial3"),
        ("wave", "fig7-wave"),
    ] {
        let csv = ctx.dir.join(format!("{file}.csv"));
        let svg = ctx.dir.join(format!("{file}.svg"));
        let args: crate::workprecision::WorkPrecisionArgs = subcommand(&[
            "--problem".into(),
            problem.into(),
            "--out".into(),
            path_arg(&csv),
            "--plot".into(),
            path_arg(&svg),
            "--levels".into(),
            levels.to_string(),
        ])?;
        crate::workprecision::run(&args)?;
    }
    let wave = LinearOscillator::undamped(5.0);
    let methods = [
        Method::ExplicitEuler,
        Method::Midpoint,
        Method::Rk4,
        Method::FbEuler,
        Method::Verlet,
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(2),
        Method::Bdf(3),
    ];
    let mut worst: f64 = 0.0;
    let mut parts = Vec::new();
    for m in &methods {
        let rows = oscillator_rows(wave, m, 20, if ctx.quick { 8 } else { 10 })?;
        let finite: Vec<WorkPrecisionRow> = rows
            .into_iter()
            .filter(|r| r.error.is_finite() && r.error > 1e-13)
            .collect();
        let q = observed_order(&finite[finite.len().saturating_sub(4)..]).unwrap_or(f64::NAN);
        let dev = (q - m.order() as f64).abs();
        worst = if dev.is_nan() {
            f64::INFINITY
        } else {
            worst.max(dev)
        };
        parts.push(format!("{m} {q:.2}"));
    }
    Ok(Outcome {
        paper_value: "slope = order (1, 2, 4, 1, 2, 1, 2, 2, 3)".into(),
        measured: parts.join(", "),
        tolerance: "|observed - order| <= 0.25 (4 finest steps, wave y'' = -5 y)".into(),
        pass: worst <= 0.25,
        note: format!("largest deviation {worst:.3}"),
    })
}

/// Largest step whose `steps` steps on `y' = -15 y` do not grow `|y|`
/// (bisection to a relative 1e-4).
fn dahlquist_limit(m: &Method) -> Result<f64, CliError> {
    let grows = |h: f64| -> Result<bool, CliError> {
        let mut ode = FirstOrderIntegrator::new(
            Dahlquist { lambda: -15.0 },
            m.clone(),
            0.0,
            &[1.0],
            SolverOptions::with_h(h),
        )
        .map_err(failed)?;
        for _ in 0..400 {
            // A non-finite state (overflow) is growth too.
            if ode.step().is_err() || ode.y()[0].abs() > 1.0 {
                return Ok(true);
            }
        }
        Ok(false)
    };
    let (mut lo, mut hi) = (0.01, 1.0);
    while hi / lo - 1.0 > 1e-4 {
        let mid = 0.5 * (lo + hi);
        if grows(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(lo)
}

/// Claim 2.
fn stability_limits(_: &Ctx) -> Result<Outcome, CliError> {
    let ee = dahlquist_limit(&Method::ExplicitEuler)?;
    let rk4 = dahlquist_limit(&Method::Rk4)?;
    // RK4's interval: 1 + z + z^2/2 + z^3/6 + z^4/24 = -1 at z = -2.78529.
    let (ee_exact, rk4_exact) = (2.0 / 15.0, 2.785_293_563_405_282 / 15.0);
    let rel = ((ee / ee_exact - 1.0).abs()).max((rk4 / rk4_exact - 1.0).abs());
    Ok(Outcome {
        paper_value: format!("{ee_exact:.5}, {rk4_exact:.5}"),
        measured: format!("{ee:.5}, {rk4:.5} (400 steps not growing |y|, bisection)"),
        tolerance: "1%".into(),
        pass: rel <= 0.01,
        note: String::new(),
    })
}

/// Claim 3, and figure 4.
fn regions(ctx: &Ctx) -> Result<Outcome, CliError> {
    let svg = ctx.dir.join("fig4-regions.svg");
    let args: crate::stability::StabilityArgs = subcommand(&[
        "--plot".into(),
        path_arg(&svg),
        "--resolution".into(),
        (if ctx.quick { "81" } else { "161" }).into(),
    ])?;
    crate::stability::run(&args)?;
    let left = ComplexGrid {
        re: (-20.0, -1e-9),
        im: (-20.0, 20.0),
        nx: 101,
        ny: 101,
    };
    let mut fractions = Vec::new();
    for m in [
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(2),
    ] {
        let s = sample_region(&m, &left).map_err(failed)?;
        fractions.push((m, s.stable_fraction()));
    }
    let disc = ComplexGrid {
        re: (-2.5, 0.5),
        im: (-1.5, 1.5),
        nx: 401,
        ny: 401,
    };
    let area = sample_region(&Method::ExplicitEuler, &disc)
        .map_err(failed)?
        .stable_fraction()
        * 9.0;
    let pi = std::f64::consts::PI;
    let a_stable = fractions.iter().all(|(_, f)| *f == 1.0);
    Ok(Outcome {
        paper_value: format!("left half-plane stable: 1; disc area pi = {pi:.4}"),
        measured: format!(
            "{}; explicit Euler area {area:.4}",
            fractions
                .iter()
                .map(|(m, f)| format!("{m} {f:.4}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        tolerance: "fractions exactly 1 (101 x 101 points of [-20, 0) x [-20, 20]); area within 2%"
            .into(),
        pass: a_stable && (area / pi - 1.0).abs() <= 0.02,
        note: String::new(),
    })
}

/// Claim 4: at the coarsest steps of example 3, the implicit methods'
/// errors stay of the size of the solution while explicit Euler's grow.
fn large_steps(_: &Ctx) -> Result<Outcome, CliError> {
    let ex3 = LinearOscillator::example3();
    let scale = (0..=200)
        .map(|i| {
            let [z, v] = ex3.exact(ex3.t_end * i as f64 / 200.0);
            z.abs().max(v.abs())
        })
        .fold(0.0f64, f64::max);
    let mut worst_implicit: f64 = 0.0;
    for m in [
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(2),
    ] {
        let rows = oscillator_rows(ex3, &m, 5, 3)?;
        for r in rows {
            worst_implicit = worst_implicit.max(r.error);
        }
    }
    let ee = oscillator_rows(ex3, &Method::ExplicitEuler, 5, 1)?;
    let ee_err = ee.first().map_or(f64::INFINITY, |r| r.error);
    Ok(Outcome {
        paper_value: "implicit: error <= solution size; explicit Euler: unbounded".into(),
        measured: format!(
            "largest implicit error {worst_implicit:.3} at 5-20 steps (solution size {scale:.3}); explicit Euler at 5 steps {ee_err:.3e}"
        ),
        tolerance:
            "implicit error <= max(|z|, |v|) of the solution; explicit Euler error > 10x that"
                .into(),
        pass: worst_implicit <= scale && !(ee_err <= 10.0 * scale),
        note: "example 3 (particle on a damped spring), 5, 10 and 20 steps".into(),
    })
}

/// Claim 5.
fn example3_bounded(_: &Ctx) -> Result<Outcome, CliError> {
    let ex3 = LinearOscillator::example3();
    let scale = (0..=200)
        .map(|i| ex3.exact(ex3.t_end * i as f64 / 200.0)[0].abs())
        .fold(0.0f64, f64::max);
    let h = ex3.t_end / 10.0;
    let peak = |m: Method| -> Result<f64, CliError> {
        let mut ode = SecondOrderIntegrator::new(
            ex3.particle(),
            m,
            0.0,
            &ex3.x0(),
            &ex3.v0_vec(),
            SolverOptions {
                h,
                ..crate::workprecision::tight_options()
            },
        )
        .map_err(failed)?;
        let mut peak: f64 = 0.0;
        while ode.step_to(ex3.t_end).map_err(failed)?.is_some() {
            peak = peak.max(ode.x()[2].abs());
        }
        Ok(peak)
    };
    let ie = peak(Method::ImplicitEuler)?;
    let ee = peak(Method::ExplicitEuler)?;
    Ok(Outcome {
        paper_value: "bounded (fig. 2b)".into(),
        measured: format!("max |z| {ie:.3} (exact max {scale:.3}); explicit Euler {ee:.3e}"),
        tolerance: "implicit Euler max |z| <= exact max; explicit Euler > 10x".into(),
        pass: ie <= scale * (1.0 + 1e-9) && !(ee <= 10.0 * scale),
        note: format!("h = t_end / 10 = {h:.3} s"),
    })
}

/// Claim 6: f evaluations to reach error 1e-3 on the wave.
fn verlet_best(_: &Ctx) -> Result<Outcome, CliError> {
    let wave = LinearOscillator::undamped(5.0);
    let target = 1e-3;
    let mut work = Vec::new();
    for m in [
        Method::ExplicitEuler,
        Method::ImplicitEuler,
        Method::ImplicitMidpoint,
        Method::Bdf(2),
        Method::Verlet,
    ] {
        let rows = oscillator_rows(wave, &m, 10, 14)?;
        let evals = rows
            .iter()
            .filter(|r| r.error <= target)
            .map(|r| r.stats.f_evals)
            .min();
        work.push((m, evals));
    }
    let verlet = work.last().and_then(|w| w.1).unwrap_or(usize::MAX);
    let best_other = work[..work.len() - 1]
        .iter()
        .filter_map(|w| w.1)
        .min()
        .unwrap_or(usize::MAX);
    Ok(Outcome {
        paper_value: "Verlet one of the best (fig. 7)".into(),
        measured: work
            .iter()
            .map(|(m, e)| match e {
                Some(e) => format!("{m} {e}"),
                None => format!("{m} -"),
            })
            .collect::<Vec<_>>()
            .join(", "),
        tolerance: "Verlet's f evaluations to error <= 1e-3 the fewest".into(),
        pass: verlet < best_other,
        note: "undamped wave y'' = -5 y on the tutorial's interval".into(),
    })
}

/// The drape at `n`, its mass-spring model and state.
fn drape(n: usize) -> Result<(MassSpringModel, State), CliError> {
    cloth(&ClothParams::drape(n)).map_err(failed)
}

/// Claim 7: total PCG iterations of 10 implicit Euler steps.
fn inexact_newton(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = ctx.cloth_n();
    let cg = |method: NewtonMethod| -> Result<usize, CliError> {
        let (model, state) = drape(n)?;
        let options = SolverOptions {
            h: 0.01,
            newton: NewtonOptions {
                method,
                rtol: 1e-6,
                max_iter: 30,
                preconditioner: PrecondKind::BlockJacobi,
                ..SolverOptions::default_newton()
            },
            ..SolverOptions::default()
        };
        let mut sim = ModelIntegrator::new(model, &state, Method::ImplicitEuler, options, None)
            .map_err(failed)?;
        for _ in 0..10 {
            sim.step().map_err(failed)?;
        }
        Ok(sim.stats().linear_iterations)
    };
    let exact = cg(NewtonMethod::Exact)?;
    let inexact = cg(NewtonMethod::Inexact(ForcingTerm::Constant(0.02)))?;
    Ok(Outcome {
        paper_value: "fewer (section 3.2)".into(),
        measured: format!("{inexact} against {exact} CG iterations"),
        tolerance: "inexact < exact".into(),
        pass: inexact < exact,
        note: format!(
            "{n} x {n} drape, 10 implicit Euler steps of 0.01 s, Newton to 1e-6, block-Jacobi PCG ({:.1}x fewer)",
            exact as f64 / inexact.max(1) as f64
        ),
    })
}

/// Best of `rounds` interleaved timings of `a` and `b` (seconds each).
fn interleaved(rounds: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> (f64, f64) {
    let (mut ta, mut tb) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..rounds {
        let t = Instant::now();
        a();
        ta = ta.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        b();
        tb = tb.min(t.elapsed().as_secs_f64());
    }
    (ta, tb)
}

/// Claim 8: nonzeros and the cost of a product (the CG iteration's kernel).
fn eq50(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = if ctx.quick { 32 } else { 64 };
    let (model, _) = drape(n)?;
    let pattern = model.jacobian_pattern();
    let (mut k, mut d) = (
        IsoBlockMatrix::new(pattern.clone()),
        IsoBlockMatrix::new(pattern.clone()),
    );
    model.assemble_linearized_iso(&mut k, &mut d);
    let (mut kf, mut df) = model.new_jacobians();
    model.assemble_linearized(&mut kf, &mut df);
    let full_nnz = pattern.full_nnz();
    let iso_nnz = k.full_nnz();
    let x: Vec<f64> = (0..3 * n * n).map(|i| (i as f64 * 0.37).sin()).collect();
    let (mut y1, mut y2) = (vec![0.0; x.len()], vec![0.0; x.len()]);
    let (t_full, t_iso) = interleaved(
        if ctx.quick { 200 } else { 500 },
        || kf.apply(&x, &mut y1),
        || k.apply(&x, &mut y2),
    );
    let speed = t_full / t_iso;
    Ok(Outcome {
        paper_value: "1/3 of the nonzeros, 1/3 of the time".into(),
        measured: format!(
            "{iso_nnz} / {full_nnz} = {:.3} of the nonzeros; product {:.1} us against {:.1} us ({speed:.2}x)",
            iso_nnz as f64 / full_nnz as f64,
            t_iso * 1e6,
            t_full * 1e6
        ),
        tolerance: "nonzeros 1/3 exactly; product >= 1.5x faster".into(),
        pass: iso_nnz * 3 == full_nnz && speed >= 1.5,
        note: format!(
            "{n} x {n} drape's pattern, best of interleaved rounds of K x (isotropic) and K x (3x3 blocks). In the integrator, IMEX uses it (claim 14) and so does inexact simplified Newton (NewtonMethod::InexactSimplified): 2.06x cheaper per Newton iteration and 1.33x faster end to end than the full Jacobian on a membrane pre-tensioned to 5x its rest size, 27x slower on the drape, whose springs sit at rest length where eq. 50 drops half the stiffness (docs/PERFORMANCE.md, example eq50)"
        ),
    })
}

/// Claim 9: the drape's implicit-Euler system with its pins and a sliding
/// constraint on every tenth particle, solved by filtered PCG.
fn filtered_cg(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = ctx.cloth_n();
    let (model, state) = drape(n)?;
    let h = 0.01;
    let (mut kx, mut kv) = model.new_jacobians();
    model.force_jacobians(0.0, &state.x, &state.v, &mut kx, &mut kv);
    let mut a = SymBlockMatrix::new(model.jacobian_pattern());
    a.assign_diagonal_plus_combination(model.mass(), -h * h, &kx, -h, &kv)
        .map_err(failed)?;
    let mut f = vec![0.0; state.x.len()];
    model.force(0.0, &state.x, &state.v, &mut f);
    let b: Vec<f64> = f.iter().map(|fi| h * fi).collect();
    let mut c = Constraints::new(n * n);
    c.pin(0, [0.0; 3]).map_err(failed)?;
    c.pin(n - 1, [0.0; 3]).map_err(failed)?;
    for p in (n..n * n).step_by(10) {
        c.constrain(p, [0.0, 0.0, 1.0], 0.01).map_err(failed)?;
    }
    let mut pre = hookean_sparse::BlockJacobi::new();
    pre.setup(&a).map_err(failed)?;
    let mut x = vec![0.0; b.len()];
    let info = filtered_pcg(
        &a,
        &pre,
        &b,
        &mut x,
        &c,
        &CgParams {
            rtol: 1e-8,
            ..CgParams::default()
        },
        &mut CgWorkspace::new(b.len()),
        None,
    )
    .map_err(failed)?;
    let violation = c.violation(&x);
    Ok(Outcome {
        paper_value: "exactly (to round-off)".into(),
        measured: format!(
            "constraint violation {violation:.1e} after {} iterations (residual {:.1e})",
            info.iterations, info.relative_residual
        ),
        tolerance: "violation <= 1e-14, converged".into(),
        pass: info.converged && violation <= 1e-14,
        note: format!(
            "{n} x {n} drape, 2 pins and {} sliding constraints",
            (n * n - n).div_ceil(10)
        ),
    })
}

// ---- the filtering paper ------------------------------------------------

/// The stable FB Euler step of the 12 x 12 drape (bisection, 0.5 s runs).
fn stable_step(filter: Option<FilterOptions>) -> Result<f64, CliError> {
    let build = || cloth(&ClothParams::drape(12)).map_err(hookean_filter::FilterError::from);
    let (model, state) = build().map_err(failed)?;
    let guess = predict_dt_max(
        &model,
        &state.x,
        filter.as_ref(),
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .map_err(failed)?
    .dt_max;
    let options = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        rel_tol: 0.01,
        ..Default::default()
    };
    let s = measure_stable_step(
        &build,
        &Method::FbEuler,
        filter.map(|f| (f, FilterCoupling::Increment)),
        guess,
        &options,
    )
    .map_err(failed)?;
    Ok(s.lo)
}

/// Claim 10, and the filtering paper's figures 4, 5 and 6 (filter-analysis).
fn figure6(_: &Ctx) -> Result<Outcome, CliError> {
    let plain = |lambda: f64| FilterOptions {
        kernel: hookean_filter::Kernel::Exponential { lambda },
        form: Form::Plain,
        ..FilterOptions::default()
    };
    let none = stable_step(None)?;
    let one = stable_step(Some(plain(1.0)))? / none;
    let twenty = stable_step(Some(plain(20.0)))? / none;
    let symmetric = stable_step(Some(FilterOptions::default()))? / none;
    Ok(Outcome {
        paper_value: "2x at lambda = 1; 1x for lambda > 10".into(),
        measured: format!("{one:.2}x at lambda = 1, {twenty:.3}x at lambda = 20"),
        tolerance: ">= 1.8x; <= 1.05x".into(),
        pass: one >= 1.8 && twenty <= 1.05,
        note: format!(
            "{}12 x 12 drape, plain form, the velocity change filtered; the symmetric form the paper recommends gives {symmetric:.2}x (it averages each particle with its filtered neighbourhood, halving the filter's effect on the stiffest mode; figure 6 of it: filter/fig6.svg)",
            if one < 1.8 {
                format!(
                    "misses: lambda = 1 enlarges the stable step {one:.2}x, {:.0}% short of 1.8x (the filter does not damp the cloth's stiffest mode as much as the paper's). ",
                    100.0 * (1.0 - one / 1.8)
                )
            } else if twenty > 1.05 {
                format!(
                    "misses: lambda = 20 still enlarges the step {twenty:.3}x (the paper: no change for lambda > 10, as the neighbours' weights e^-20 vanish). "
                )
            } else {
                String::new()
            }
        ),
    })
}

/// Claim 11.
fn step_125(_: &Ctx) -> Result<Outcome, CliError> {
    let none = stable_step(None)?;
    let h = 1.25 * none;
    let (model, state) = cloth(&ClothParams::drape(12)).map_err(failed)?;
    let bounded = |filter: Option<FilterOptions>| -> Result<bool, CliError> {
        let mut sim = ModelIntegrator::new(
            model.clone(),
            &state,
            Method::FbEuler,
            SolverOptions::with_h(h),
            filter.map(|f| (f, FilterCoupling::Increment)),
        )
        .map_err(failed)?;
        Ok(run_bounded(
            &mut sim,
            &RunOptions {
                t_end: 2.0,
                ..Default::default()
            },
        )
        .map_err(failed)?
        .bounded)
    };
    let filtered = bounded(Some(FilterOptions::default()))?;
    let unfiltered = bounded(None)?;
    Ok(Outcome {
        paper_value: "stable with the filter, unstable without".into(),
        measured: format!(
            "h = 1.25 x {none:.3e} s: filtered {}, unfiltered {}",
            if filtered { "bounded" } else { "blew up" },
            if unfiltered { "bounded" } else { "blew up" }
        ),
        tolerance: "filtered bounded and unfiltered not, 2 s".into(),
        pass: filtered && !unfiltered,
        note: "12 x 12 drape, lambda = 1, symmetric form".into(),
    })
}

/// Per-step times of plain and filtered FB Euler through the facade on the
/// `n x n` drape, in `blocks` blocks of `rounds` interleaved rounds of 5
/// steps of each (plain first in even rounds, filtered first in odd ones):
/// the best plain and best filtered step, and per block the median over its
/// rounds of filtered / plain.
fn step_times(n: usize, rounds: usize, blocks: usize) -> Result<StepTimes, CliError> {
    let (model, state) = drape(n)?;
    let dt = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .map_err(failed)?
    .dt_max;
    let options = |filter: Option<FilterOptions>| SimulationOptions {
        method: Method::FbEuler,
        solver: SolverOptions::with_h(0.5 * dt),
        filter,
        ..SimulationOptions::default()
    };
    let mut plain =
        hookean::Simulation::new(model.clone(), state.clone(), options(None)).map_err(failed)?;
    let mut filtered =
        hookean::Simulation::new(model, state, options(Some(FilterOptions::default())))
            .map_err(failed)?;
    let mut times = (Vec::new(), Vec::new());
    let mut error = None;
    for round in 0..rounds * blocks {
        // A B B A: the order alternates, so a drift within a round (caches,
        // clock) favours neither.
        let mut pair = [(&mut plain, &mut times.0), (&mut filtered, &mut times.1)];
        if round % 2 == 1 {
            pair.reverse();
        }
        for (sim, times) in pair {
            let t = Instant::now();
            for _ in 0..5 {
                if let Err(e) = sim.step() {
                    error = Some(e.to_string());
                }
            }
            times.push(t.elapsed().as_secs_f64() / 5.0);
        }
    }
    if let Some(e) = error {
        return Err(failed(e));
    }
    // Each round's filtered / plain ratio: the two ran back to back, so a
    // slow spell of the machine slows both alike.
    let ratios: Vec<f64> = times.0.iter().zip(&times.1).map(|(p, f)| f / p).collect();
    let block_medians = ratios
        .chunks(rounds)
        .map(|block| {
            let mut block = block.to_vec();
            block.sort_by(f64::total_cmp);
            block[block.len() / 2]
        })
        .collect();
    let best = |v: &[f64]| v.iter().copied().fold(f64::INFINITY, f64::min);
    Ok(StepTimes {
        best_plain: best(&times.0),
        best_filtered: best(&times.1),
        block_medians,
    })
}

/// What [`step_times`] measured.
struct StepTimes {
    best_plain: f64,
    best_filtered: f64,
    /// Per block, the median of the rounds' filtered / plain time ratios.
    block_medians: Vec<f64>,
}

impl StepTimes {
    /// The least block median: another program on the machine only ever
    /// adds time, and seems to add more to the filtered step (which streams
    /// four more vectors; not measured apart), so the quietest block is the
    /// closest to the filter's own cost (timeit's rule: the minimum, not the
    /// mean, of repeats). It leans low by design; the instruction count
    /// (docs/PERFORMANCE.md) is the figure that does not depend on the machine.
    fn ratio(&self) -> f64 {
        self.block_medians
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
    }
}

/// Claim 12: per-step cost through the facade, interleaved rounds, on one
/// thread as the paper's machine (the filter is not threaded; with more
/// threads the force sweep is, and the filter's share grows).
fn filter_cost(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = 64;
    let (rounds, blocks) = if ctx.quick { (100, 4) } else { (200, 4) };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(failed)?;
    let measured = one.install(|| step_times(n, rounds, blocks))?;
    let (tp, tf, ratio) = (
        measured.best_plain,
        measured.best_filtered,
        measured.ratio(),
    );
    let spread = measured
        .block_medians
        .iter()
        .map(|r| format!("{:.1}", 100.0 * (r - 1.0)))
        .collect::<Vec<_>>()
        .join(", ");
    let threads = rayon::current_num_threads();
    let threaded = if threads > 1 {
        let r = step_times(n, rounds / 2, blocks)?.ratio();
        format!(
            "; with {threads} threads (the force sweep threaded, the filter not): cost {:.1}%, speed-up {:.1}%",
            100.0 * (r - 1.0),
            100.0 * (1.25 / r - 1.0)
        )
    } else {
        String::new()
    };
    let cost = ratio - 1.0;
    let speedup = 1.25 / ratio - 1.0;
    let miss = if cost <= 0.08 && speedup >= 0.10 {
        String::new()
    } else {
        format!(
            "misses: a filtered step costs {:.1}% more than an unfiltered one ({:.1} points over the 8% allowed; the paper: 5%), so a filtered run at 1.25x the step is {:.1}% faster (10% needed). These are wall-clock times of one thread: another program on the machine inflates them unevenly, so a rerun tells whether the filter or the machine is at fault. ",
            100.0 * cost,
            (100.0 * cost - 8.0).max(0.0),
            100.0 * speedup
        )
    };
    Ok(Outcome {
        paper_value: "cost 5%, net speed-up 20%".into(),
        measured: format!(
            "cost {:.1}%, net speed-up {:.1}% (one thread; fastest steps {:.0} us filtered, {:.0} us plain)",
            100.0 * cost,
            100.0 * speedup,
            tf * 1e6,
            tp * 1e6
        ),
        tolerance: "cost <= 8%, speed-up >= 10%".into(),
        pass: cost <= 0.08 && speedup >= 0.10,
        note: format!(
            "{miss}{n} x {n} drape through Simulation::step: {blocks} blocks of {rounds} rounds of 5 plain and 5 filtered steps (the order alternating); per block the median of the rounds' time ratios ({spread}% over the blocks), the least of them taken (another program on the machine only adds time, and seems to add more to the filtered step; the least leans low, the instruction count below does not depend on the machine); speed-up = 1.25 t_plain / t_filtered - 1 (a filtered run takes 1/1.25 the steps){threaded}. In instructions (callgrind, docs/PERFORMANCE.md) the filter costs 5.0% (7.97% before its passes ran at the stencil's width with fused multiply-adds)",
        ),
    })
}

/// Claim 13, with the filter-analysis figures 4, 5 and 6.
fn spectra(ctx: &Ctx) -> Result<Outcome, CliError> {
    let n = if ctx.quick { 12 } else { 16 };
    let scene = ctx.dir.join("filter-drape.toml");
    crate::output::write_text(&scene, "[cloth]\n")?;
    let plot = ctx.dir.join("filter");
    let args: crate::filter_analysis::FilterAnalysisArgs = subcommand(&[
        path_arg(&scene),
        "--plot".into(),
        path_arg(&plot),
        "--n".into(),
        n.to_string(),
        "--t-end".into(),
        (if ctx.quick { "0.5" } else { "1.0" }).into(),
    ])?;
    crate::filter_analysis::run(&args)?;
    let _ = std::fs::remove_file(&scene);
    let json = std::fs::read_to_string(plot.join("analysis.json")).map_err(failed)?;
    let analysis: serde_json::Value = serde_json::from_str(&json).map_err(failed)?;
    let hf_of = |name: &str, key: &str| -> f64 {
        analysis["figure4"]
            .as_array()
            .and_then(|rows| rows.iter().find(|r| r["method"] == name))
            .and_then(|r| r[key].as_f64())
            .unwrap_or(f64::NAN)
    };
    // Figure 5 is a snapshot: the spectrum of the last state.
    let final_key = "final_high_frequency_fraction";
    let hf = [
        hf_of("fb-euler", final_key),
        hf_of("backward-euler", final_key),
        hf_of("filtered-fb-euler", final_key),
    ];
    let mean_key = "mean_high_frequency_fraction";
    let means = [
        hf_of("fb-euler", mean_key),
        hf_of("backward-euler", mean_key),
        hf_of("filtered-fb-euler", mean_key),
    ];
    let (fb, be, fil) = (hf[0], hf[1], hf[2]);
    let step_choice = analysis["step_choice"].as_str().unwrap_or_default();
    Ok(Outcome {
        paper_value: "FB Euler > filtered ~ backward Euler".into(),
        measured: format!(
            "high-frequency share of the last state's spectrum: FB Euler {fb:.4}, backward Euler {be:.4}, filtered {fil:.4}"
        ),
        tolerance: "FB Euler > filtered, and filtered closer to backward Euler than FB Euler is"
            .into(),
        pass: fb > fil && (fil - be).abs() < (fb - be).abs(),
        note: format!(
            "{n} x {n} drape at h = 0.9 dt_max for all three (hookean filter-analysis, filter/analysis.json): the velocity spectrum's share beyond half the Nyquist radius. At a step this small every scheme filters little, so the differences are a few percent; averaged over the run (figure 4) the shares are {:.4}, {:.4}, {:.4}. Why this step: {step_choice}. Pictures in filter/",
            means[0], means[1], means[2]
        ),
    })
}

/// Claim 14: figure 8, both panels.
fn figure8(ctx: &Ctx) -> Result<Outcome, CliError> {
    let (sizes, k0s, t_end): (Vec<usize>, Vec<f64>, f64) = if ctx.quick {
        (vec![8, 16], vec![1e4, 1e6, 1e8], 0.5)
    } else {
        (vec![16, 32, 64], vec![1e4, 1e5, 1e6, 1e7, 1e8, 1e9], 2.0)
    };
    let k0_panel_n = if ctx.quick { 8 } else { 16 };
    let mut best = SimulationOptions::drape_solver();
    best.newton.preconditioner = PrecondKind::Mic0 {
        omega: PrecondKind::MIC_OMEGA,
    };
    let methods = Figure8Method::ALL;
    let mut rows: Vec<Figure8Row> = Vec::new();
    for &n in &sizes {
        rows.extend(figure8_runs(n, 1e6, t_end, &methods, &best, |_| {}).map_err(failed)?);
    }
    let mut k0_rows: Vec<Figure8Row> = Vec::new();
    for &k0 in &k0s {
        if k0 == 1e6 && sizes.contains(&k0_panel_n) {
            k0_rows.extend(rows.iter().filter(|r| r.n == k0_panel_n).copied());
            continue;
        }
        k0_rows
            .extend(figure8_runs(k0_panel_n, k0, t_end, &methods, &best, |_| {}).map_err(failed)?);
    }
    // fig8.csv and the two panels.
    let mut csv = String::from(
        "panel,n,particles,k0,k0_run,method,h,steps,linear_iterations,bounded,seconds\n",
    );
    for (panel, list) in [("particles", &rows), ("k0", &k0_rows)] {
        for r in list.iter() {
            csv += &format!(
                "{panel},{},{},{:e},{:e},{},{:e},{},{},{},{:.6}\n",
                r.n,
                r.n * r.n,
                r.k0,
                r.k0_run,
                r.method.name(),
                r.h,
                r.steps,
                r.linear_iterations,
                r.bounded,
                r.seconds
            );
        }
    }
    crate::output::write_text(&ctx.dir.join("fig8.csv"), &csv)?;
    let series = |list: &[Figure8Row], x: fn(&Figure8Row) -> f64| -> Vec<Series> {
        methods
            .iter()
            .map(|&m| Series {
                name: m.name().into(),
                points: list
                    .iter()
                    .filter(|r| r.method == m && r.bounded)
                    .map(|r| (x(r), r.seconds))
                    .collect(),
            })
            .collect()
    };
    let top = LogLogPlot {
        title: format!("Figure 8 (top): {t_end} s of the drape at k0 = 1e6"),
        x_label: "particles".into(),
        y_label: "wall time (s)".into(),
        series: series(&rows, |r| (r.n * r.n) as f64),
    };
    crate::output::write_text(
        &ctx.dir.join("fig8-particles.svg"),
        &top.render().map_err(CliError::Failed)?,
    )?;
    let bottom = LogLogPlot {
        title: format!("Figure 8 (bottom): {t_end} s of the {k0_panel_n} x {k0_panel_n} drape"),
        x_label: "k0 (1/s^2, rest state)".into(),
        y_label: "wall time (s)".into(),
        series: series(&k0_rows, |r| r.k0),
    };
    crate::output::write_text(
        &ctx.dir.join("fig8-k0.svg"),
        &bottom.render().map_err(CliError::Failed)?,
    )?;
    // The crossover: the smallest k0 from which the faster of backward
    // Euler (BW98) and IMEX beats every bounded explicit run.
    let explicit = |m: Figure8Method| {
        matches!(
            m,
            Figure8Method::FbEuler
                | Figure8Method::FilteredFbEuler
                | Figure8Method::Verlet
                | Figure8Method::FilteredVerlet
                | Figure8Method::Rk4
                | Figure8Method::FilteredRk4
        )
    };
    let time_of = |k0: f64, pick: &dyn Fn(Figure8Method) -> bool| {
        k0_rows
            .iter()
            .filter(|r| r.k0 == k0 && r.bounded && pick(r.method))
            .map(|r| r.seconds)
            .fold(f64::INFINITY, f64::min)
    };
    let mut summary = Vec::new();
    let mut crossover = None;
    for &k0 in &k0s {
        let e = time_of(k0, &explicit);
        let i = time_of(k0, &|m| {
            matches!(m, Figure8Method::BackwardEuler | Figure8Method::Imex)
        });
        summary.push(format!(
            "k0 {k0:.0e}: fastest explicit {:.1} ms, implicit/IMEX {:.1} ms",
            1e3 * e,
            1e3 * i
        ));
        if i < e {
            crossover.get_or_insert(k0);
        } else {
            crossover = None;
        }
    }
    let imex_bounded = k0_rows
        .iter()
        .filter(|r| r.method == Figure8Method::Imex)
        .all(|r| r.bounded);
    let pass = crossover.is_some_and(|k| (1e5..=1e8).contains(&k));
    // Every method's time at every k0 of the sweep (ms; "blew up" where the
    // energy was not bounded).
    let per_method = methods
        .iter()
        .map(|&m| {
            let times = k0s
                .iter()
                .map(|&k0| {
                    k0_rows.iter().find(|r| r.k0 == k0 && r.method == m).map_or(
                        "-".to_string(),
                        |r| {
                            if r.bounded {
                                format!("{:.1}", 1e3 * r.seconds)
                            } else {
                                "blew up".to_string()
                            }
                        },
                    )
                })
                .collect::<Vec<_>>()
                .join(" / ");
            format!("{} {times}", m.name())
        })
        .collect::<Vec<_>>()
        .join(", ");
    let k0_list = k0s
        .iter()
        .map(|k| format!("{k:.0e}"))
        .collect::<Vec<_>>()
        .join(" / ");
    let miss = if pass {
        String::new()
    } else {
        match crossover {
            Some(k) => format!(
                "misses: the implicit schemes overtake the explicit ones from k0 = {k:.0e}, outside 1e5-1e8 (the explicit steps shrink as 1/sqrt(k0) by eq. 11, the implicit step stays 0.01 s, so where they cross depends on the cost of one implicit step against one explicit step on this machine). "
            ),
            None => "misses: no k0 of the sweep where backward Euler or IMEX beats every explicit method (the explicit steps shrink as 1/sqrt(k0) by eq. 11 while the implicit step stays 0.01 s: the sweep does not reach stiff enough springs, or an implicit step costs more than the paper's). ".into(),
        }
    };
    Ok(Outcome {
        paper_value: "crossover at k0 ~ 1e6".into(),
        measured: format!(
            "{}; ms at k0 = {k0_list} ({k0_panel_n} x {k0_panel_n} drape, {t_end} s): {per_method}",
            match crossover {
                Some(k) => format!("implicit/IMEX faster from k0 = {k:.0e} on"),
                None => "no crossover in the sweep".into(),
            }
        ),
        tolerance: "crossover within a decade or two: 1e5 <= k0 <= 1e8".into(),
        pass,
        note: format!(
            "{miss}{}; IMEX bounded at every k0: {imex_bounded}; fig8-particles.svg, fig8-k0.svg, fig8.csv",
            summary.join("; ")
        ),
    })
}
