//! `hookean workprecision`: the tutorial's work-precision diagrams
//! (figures 3, 5 and 7): the error at `t_end` against the work (f
//! evaluations) for each method over a sequence of step halvings.
//!
//! Problems (from `hookean_ode::tutorial`, with exact solutions):
//! - `tutorial1`: example 1, Dahlquist's `y' = lambda y` on `[0, 1]`
//!   (`--lambda`, default -15; figure 3(a) uses 2). First-order problem, so
//!   FB Euler and Verlet do not apply.
//! - `tutorial2`: example 2, `y'' = -5/2 y - 5 y'` on `[0, 10]`.
//! - `tutorial3`: example 3, the particle on a damped spring on `[0, 2]`.
//! - `wave`: figure 7's undamped `y'' = -5 y` on `[0, 10]`.
//!
//! The second-order problems run as one particle in 3D (so FB Euler and
//! Verlet apply; the implicit methods use the reduced velocity form), with
//! tight Newton and linear tolerances so the curves show the
//! discretisation error. Fixed-step methods use `n0 * 2^i` steps
//! (`i < --levels`), variable-step BDF2 the tolerances `10^-1 .. 10^-levels`.

use std::io::Write as _;
use std::path::PathBuf;

use clap::Args;
use hookean_ode::tutorial::{Dahlquist, LinearOscillator};
use hookean_ode::workprecision::{self, Sweep, WorkPrecisionRow, observed_order};
use hookean_ode::{Method, NewtonOptions, SolverOptions};

use crate::CliError;
use crate::lineplot::{LogLogPlot, Series};
use crate::output::check_new_file;

#[derive(Debug, Args)]
pub struct WorkPrecisionArgs {
    /// tutorial1 (y' = lambda y), tutorial2 (overdamped oscillator),
    /// tutorial3 (particle on a spring) or wave (y'' = -5 y).
    #[arg(long)]
    problem: String,
    /// Comma-separated method names (default: every named method that
    /// applies to the problem).
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
    /// The CSV file to write (one row per method and step size).
    #[arg(long)]
    out: PathBuf,
    /// The SVG work-precision diagram to write.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// lambda of tutorial1.
    #[arg(long, default_value_t = -15.0, allow_hyphen_values = true)]
    lambda: f64,
    /// Number of step halvings (tolerances for bdf2-variable), 1 to 16.
    #[arg(long, default_value_t = 12)]
    levels: usize,
    /// Steps of the coarsest run (default: 4 for tutorial1, 10 for
    /// tutorial2 and wave, 5 for tutorial3).
    #[arg(long)]
    n0: Option<usize>,
    /// Overwrite existing output files.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    work: crate::work::WorkCap,
}

/// The problems of the command.
#[derive(Debug, Clone, Copy)]
enum Problem {
    Dahlquist(Dahlquist),
    Oscillator(LinearOscillator, &'static str),
}

impl Problem {
    fn parse(name: &str, lambda: f64) -> Result<Self, CliError> {
        Ok(match name {
            "tutorial1" => {
                if !lambda.is_finite() {
                    return Err(CliError::Input(format!(
                        "--lambda must be finite, got {lambda:?}"
                    )));
                }
                Problem::Dahlquist(Dahlquist { lambda })
            }
            "tutorial2" => Problem::Oscillator(LinearOscillator::example2(), "example 2"),
            "tutorial3" => Problem::Oscillator(LinearOscillator::example3(), "example 3"),
            "wave" => Problem::Oscillator(LinearOscillator::undamped(5.0), "y'' = -5 y"),
            other => {
                return Err(CliError::Input(format!(
                    "unknown problem '{other}' (expected tutorial1, tutorial2, tutorial3 or wave)"
                )));
            }
        })
    }

    fn applies(&self, m: &Method) -> bool {
        match self {
            Problem::Dahlquist(_) => !m.is_second_order_only(),
            Problem::Oscillator(..) => true,
        }
    }

    fn default_n0(&self) -> usize {
        match self {
            Problem::Dahlquist(_) => 4,
            Problem::Oscillator(o, _) if o.t_end < 5.0 => 5,
            Problem::Oscillator(..) => 10,
        }
    }

    /// The end of the integration interval.
    fn t_end(&self) -> f64 {
        match self {
            Problem::Dahlquist(_) => Dahlquist::T_END,
            Problem::Oscillator(o, _) => o.t_end,
        }
    }

    fn title(&self) -> String {
        match self {
            Problem::Dahlquist(d) => {
                format!("Work-precision, example 1: y' = {} y on [0, 1]", d.lambda)
            }
            Problem::Oscillator(o, name) => {
                format!("Work-precision, {name} on [0, {}]", o.t_end)
            }
        }
    }

    fn run(&self, m: &Method, sweep: &Sweep) -> Result<Vec<WorkPrecisionRow>, CliError> {
        let opts = tight_options();
        let rows = match *self {
            Problem::Dahlquist(d) => workprecision::first_order(
                || d,
                m,
                0.0,
                &[1.0],
                Dahlquist::T_END,
                &[d.exact(Dahlquist::T_END)],
                sweep,
                &opts,
            ),
            Problem::Oscillator(o, _) => workprecision::second_order(
                || o.particle(),
                m,
                0.0,
                &o.x0(),
                &o.v0_vec(),
                o.t_end,
                &o.exact_particle(o.t_end),
                sweep,
                &opts,
            ),
        };
        rows.map_err(|e| CliError::Input(format!("{m}: {e}")))
    }
}

/// Tight Newton and linear tolerances: the error shown is the
/// discretisation error, not the solver's (also `hookean reproduce`'s).
pub(crate) fn tight_options() -> SolverOptions {
    SolverOptions {
        h: 1e-3,
        newton: NewtonOptions {
            rtol: 1e-13,
            atol: 1e-14,
            linear_rtol: 1e-13,
            ..SolverOptions::default_newton()
        },
        ..SolverOptions::default()
    }
}

/// The methods named on the command line, or every named method that
/// applies; a method that does not apply to the problem is an input error.
fn methods(
    names: &[String],
    problem: &Problem,
    problem_name: &str,
) -> Result<Vec<Method>, CliError> {
    if names.is_empty() {
        return Ok(Method::all_named()
            .into_iter()
            .filter(|m| problem.applies(m))
            .collect());
    }
    let mut out = Vec::new();
    for name in names {
        let m: Method = name
            .trim()
            .parse()
            .map_err(|e| CliError::Input(format!("{e}")))?;
        if !problem.applies(&m) {
            return Err(CliError::Input(format!(
                "method {m} needs a second-order problem; {problem_name} is first order"
            )));
        }
        out.push(m);
    }
    Ok(out)
}

pub fn run(args: &WorkPrecisionArgs) -> Result<(), CliError> {
    let problem = Problem::parse(&args.problem, args.lambda)?;
    let methods = methods(&args.methods, &problem, &args.problem)?;
    if !(1..=16).contains(&args.levels) {
        return Err(CliError::Input(format!(
            "--levels must lie in 1 to 16, got {}",
            args.levels
        )));
    }
    let n0 = args.n0.unwrap_or_else(|| problem.default_n0());
    if n0 == 0 {
        return Err(CliError::Input("--n0 must be at least 1".into()));
    }
    // Every fixed-step method runs n0 (2^levels - 1) steps of a scalar
    // problem; a variable-step method of order p at tolerance tol about
    // 10 t_end tol^(-1/(p+1)) steps (measured: bdf2-variable takes 0.5-3.1
    // million steps at tol = 1e-16 on the four problems, this says 2-11).
    let fixed = methods.iter().filter(|m| !m.is_variable_step()).count();
    let variable: f64 = methods
        .iter()
        .filter(|m| m.is_variable_step())
        .map(|m| {
            (1..=args.levels)
                .map(|e| 10.0 * problem.t_end() * 10f64.powf(e as f64 / (m.order() as f64 + 1.0)))
                .sum::<f64>()
        })
        .sum();
    args.work.check(
        fixed as f64 * n0 as f64 * (2f64.powi(args.levels as i32) - 1.0) + variable,
        1.0,
        &format!(
            "--n0 {n0} with --levels {} for {} methods",
            args.levels,
            methods.len()
        ),
    )?;
    check_new_file(&args.out, args.force, "--out")?;
    if let Some(p) = &args.plot {
        check_new_file(p, args.force, "--plot")?;
        if crate::output::same_file(&args.out, p) {
            return Err(CliError::Input(format!(
                "--out and --plot name the same file {}: the plot would overwrite the table",
                p.display()
            )));
        }
    }
    let mut all = Vec::new();
    let mut series = Vec::new();
    crate::outln!(
        "| method | order | observed order (4 finest) | f evals (finest) | error (finest) |"
    )?;
    crate::outln!("|---|---|---|---|---|")?;
    // A bar on a terminal: fine sweeps of many methods take a while.
    let bar = indicatif::ProgressBar::new(methods.len() as u64);
    bar.set_style(crate::bar_style(
        "{bar:30} {pos}/{len} {msg} [{elapsed_precise}]",
    ));
    for m in &methods {
        bar.set_message(m.to_string());
        let sweep = if m.is_variable_step() {
            Sweep::Tolerances((1..=args.levels).map(|e| 10f64.powi(-(e as i32))).collect())
        } else {
            Sweep::halvings(n0, args.levels)
        };
        let rows = problem.run(m, &sweep)?;
        bar.inc(1);
        let finite: Vec<WorkPrecisionRow> = rows
            .iter()
            .filter(|r| r.error.is_finite() && r.error > 0.0)
            .cloned()
            .collect();
        let tail = &finite[finite.len().saturating_sub(4)..];
        let Some(last) = rows.last() else {
            return Err(CliError::Failed(format!("{m}: the sweep produced no rows")));
        };
        crate::outln!(
            "| {m} | {} | {} | {} | {:.3e} |",
            m.order(),
            observed_order(tail).map_or("-".to_string(), |q| format!("{q:.2}")),
            last.stats.num_rhs_evals_total(),
            last.error
        )?;
        series.push(Series {
            name: m.to_string(),
            points: rows
                .iter()
                .map(|r| (r.stats.num_rhs_evals_total() as f64, r.error))
                .collect(),
        });
        all.extend(rows);
    }
    bar.finish_and_clear();
    // Both files are written aside first and put in place together: a
    // failure of either (the plot cannot be drawn, a full disk) leaves
    // --out and --plot as they were, and the rerun needs no --force.
    let cannot = |p: &std::path::Path, e: &dyn std::fmt::Display| {
        CliError::Failed(format!(
            "cannot write {}: {e}; nothing was written",
            p.display()
        ))
    };
    let svg = match &args.plot {
        Some(p) => {
            let plot = LogLogPlot {
                title: problem.title(),
                x_label: "work: f evaluations".into(),
                y_label: "error |Y(t_end) - y(t_end)|".into(),
                series,
            };
            let svg = plot.render().map_err(|e| cannot(p, &e))?;
            Some((p, svg))
        }
        None => None,
    };
    let csv = crate::output::prepare_file(&args.out, |w| workprecision::write_csv(w, &all))
        .map_err(|e| cannot(&args.out, &e))?;
    let svg = match svg {
        Some((p, svg)) => Some((
            p,
            crate::output::prepare_file(p, |w| w.write_all(svg.as_bytes()))
                .map_err(|e| cannot(p, &e))?,
        )),
        None => None,
    };
    csv.commit().map_err(|e| cannot(&args.out, &e))?;
    if let Some((p, svg)) = svg {
        svg.commit().map_err(|e| {
            CliError::Failed(format!(
                "cannot write {}: {e}; the table {} was written",
                p.display(),
                args.out.display()
            ))
        })?;
    }
    Ok(())
}
