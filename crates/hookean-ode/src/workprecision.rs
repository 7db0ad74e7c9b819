//! Work-precision runs (the tutorial's figures 3, 5 and 7): a method over a
//! sequence of step sizes (or tolerances, for the variable-step method) on
//! a problem with a reference solution, recording the error at `t_end`
//! against the work spent.

use std::io::{self, Write};
use std::time::Instant;

use crate::error::OdeError;
use crate::integrator::{FirstOrderIntegrator, SecondOrderIntegrator};
use crate::method::Method;
use crate::options::SolverOptions;
use crate::stats::Stats;
use crate::stepping::Integrator;
use hookean_problem::{FirstOrderProblem, SecondOrderProblem};

/// What a work-precision run varies.
#[derive(Debug, Clone, PartialEq)]
pub enum Sweep {
    /// Fixed step sizes `h = (t_end - t0) / n` for each `n`.
    Steps(Vec<usize>),
    /// Tolerances `rtol = atol = tol` of the variable-step method (initial
    /// step from the base options).
    Tolerances(Vec<f64>),
}

impl Sweep {
    /// `n0, 2 n0, 4 n0, ...` (`count` entries): step halvings.
    pub fn halvings(n0: usize, count: usize) -> Self {
        Sweep::Steps((0..count).map(|i| n0 << i).collect())
    }
}

/// One point of a work-precision diagram. Plain public fields: write them
/// with [`write_csv`] or [`WorkPrecisionRow::to_json`], or however you like.
#[derive(Debug, Clone, PartialEq)]
pub struct WorkPrecisionRow {
    /// The method's name.
    pub method: String,
    /// The fixed step size (or the initial one for a tolerance run).
    pub h: f64,
    /// The tolerance of a variable-step run.
    pub tol: Option<f64>,
    /// The mean step size `(t_end - t0) / steps`.
    pub h_mean: f64,
    /// The Euclidean norm of the error of the state at `t_end`
    /// (`|Y_{t_end} - y(t_end)|`, the tutorial's y-axis); infinite if the run failed.
    pub error: f64,
    /// The run's counters (steps, f and Jacobian evaluations, Newton and
    /// linear iterations, set-ups, rejections).
    pub stats: Stats,
    /// Wall time of the run in seconds.
    pub wall_time_s: f64,
    /// The error that stopped the run early, if any.
    pub failure: Option<String>,
}

impl WorkPrecisionRow {
    /// The CSV header matching [`to_csv`](Self::to_csv).
    pub const CSV_HEADER: &'static str = "method,h,tol,h_mean,error,steps,rejected_steps,f_evals,jacobian_evals,newton_iterations,linear_iterations,linear_setups,wall_time_s,failure";

    /// One CSV line (no newline).
    pub fn to_csv(&self) -> String {
        let s = &self.stats;
        format!(
            "{},{:e},{},{:e},{:e},{},{},{},{},{},{},{},{:e},{}",
            self.method,
            self.h,
            self.tol.map_or(String::new(), |t| format!("{t:e}")),
            self.h_mean,
            self.error,
            s.num_steps,
            s.num_rejected_steps(),
            s.num_rhs_evals_total(),
            s.num_jac_evals,
            s.num_nonlin_solv_iters,
            s.num_lin_iters,
            s.num_lin_solv_setups,
            self.wall_time_s,
            self.failure
                .as_deref()
                .unwrap_or("")
                .replace([',', '\n'], ";"),
        )
    }

    /// One JSON object (non-finite numbers written as `null`).
    pub fn to_json(&self) -> String {
        let num = |v: f64| {
            if v.is_finite() {
                format!("{v:e}")
            } else {
                "null".to_string()
            }
        };
        let s = &self.stats;
        format!(
            "{{\"method\":\"{}\",\"h\":{},\"tol\":{},\"h_mean\":{},\"error\":{},\"steps\":{},\"rejected_steps\":{},\"f_evals\":{},\"jacobian_evals\":{},\"newton_iterations\":{},\"linear_iterations\":{},\"linear_setups\":{},\"wall_time_s\":{},\"failure\":{}}}",
            self.method,
            num(self.h),
            self.tol.map_or("null".to_string(), num),
            num(self.h_mean),
            num(self.error),
            s.num_steps,
            s.num_rejected_steps(),
            s.num_rhs_evals_total(),
            s.num_jac_evals,
            s.num_nonlin_solv_iters,
            s.num_lin_iters,
            s.num_lin_solv_setups,
            num(self.wall_time_s),
            self.failure
                .as_ref()
                .map_or("null".to_string(), |f| format!(
                    "\"{}\"",
                    f.replace(['"', '\\'], "'")
                )),
        )
    }
}

/// Writes rows as CSV with a header.
///
/// # Errors
/// The writer's I/O errors.
pub fn write_csv<W: Write>(mut w: W, rows: &[WorkPrecisionRow]) -> io::Result<()> {
    writeln!(w, "{}", WorkPrecisionRow::CSV_HEADER)?;
    for r in rows {
        writeln!(w, "{}", r.to_csv())?;
    }
    Ok(())
}

/// The observed order: minus the least-squares slope of `log(error)`
/// against `log(h_mean)`, i.e. the `p` of `error ~ C h^p`, over the rows
/// with finite positive errors. `None` with fewer than two such rows.
pub fn observed_order(rows: &[WorkPrecisionRow]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.error.is_finite() && r.error > 0.0)
        .map(|r| (r.h_mean.ln(), r.error.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    Some(sxy / sxx)
}

fn check_sweep(sweep: &Sweep, method: &Method) -> Result<(), OdeError> {
    match sweep {
        Sweep::Steps(ns) => {
            if method.is_variable_step() {
                return Err(OdeError::InvalidParameter {
                    name: "sweep",
                    value: ns.len() as f64,
                    reason: "the variable-step method needs a tolerance sweep",
                });
            }
            if let Some(&n) = ns.iter().find(|&&n| n == 0) {
                return Err(OdeError::InvalidParameter {
                    name: "steps",
                    value: n as f64,
                    reason: "must be positive",
                });
            }
        }
        Sweep::Tolerances(ts) => {
            if !method.is_variable_step() {
                return Err(OdeError::InvalidParameter {
                    name: "sweep",
                    value: ts.len() as f64,
                    reason: "fixed-step methods need a step sweep",
                });
            }
            if let Some(&t) = ts.iter().find(|t| !(**t > 0.0 && t.is_finite())) {
                return Err(OdeError::InvalidParameter {
                    name: "tol",
                    value: t,
                    reason: "must be positive and finite",
                });
            }
        }
    }
    Ok(())
}

fn settings(sweep: &Sweep, base: &SolverOptions, span: f64) -> Vec<(SolverOptions, Option<f64>)> {
    match sweep {
        Sweep::Steps(ns) => ns
            .iter()
            .map(|&n| {
                (
                    SolverOptions {
                        h: span / n as f64,
                        ..base.clone()
                    },
                    None,
                )
            })
            .collect(),
        Sweep::Tolerances(ts) => ts
            .iter()
            .map(|&tol| {
                (
                    SolverOptions {
                        rtol: tol,
                        atol: tol.into(),
                        // A sweep to tight tolerances takes millions of steps
                        // (bdf2-variable: 0.5-3.1 million at 1e-16): its caller
                        // bounds the work, not the step cap of a single run.
                        max_steps: usize::MAX,
                        ..base.clone()
                    },
                    Some(tol),
                )
            })
            .collect(),
    }
}

fn error_norm(y: &[f64], exact: &[f64]) -> f64 {
    y.iter()
        .zip(exact)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn row(
    method: &Method,
    opts: &SolverOptions,
    tol: Option<f64>,
    span: f64,
    error: f64,
    stats: Stats,
    wall: f64,
    failure: Option<String>,
) -> WorkPrecisionRow {
    WorkPrecisionRow {
        method: method.to_string(),
        h: opts.h,
        tol,
        h_mean: span / stats.num_steps.max(1) as f64,
        error: if failure.is_some() {
            f64::INFINITY
        } else {
            error
        },
        stats,
        wall_time_s: wall,
        failure,
    }
}

/// Runs `method` on a first-order problem for every setting of `sweep`,
/// from `(t0, y0)` to `t_end`, comparing with `exact = y(t_end)`. A run
/// that fails (instability, Newton failure) gives a row with infinite error
/// and its message, not an error.
///
/// # Errors
/// [`OdeError::InvalidParameter`] for a sweep that does not fit the method
/// or `t_end <= t0`; [`OdeError::DimensionMismatch`] for `exact`; set-up
/// errors of the integrator.
pub fn first_order<P, F>(
    mut make_problem: F,
    method: &Method,
    t0: f64,
    y0: &[f64],
    t_end: f64,
    exact: &[f64],
    sweep: &Sweep,
    base: &SolverOptions,
) -> Result<Vec<WorkPrecisionRow>, OdeError>
where
    P: FirstOrderProblem + Send + 'static,
    F: FnMut() -> P,
{
    check_sweep(sweep, method)?;
    let span = check_span(t0, t_end)?;
    if exact.len() != y0.len() {
        return Err(OdeError::DimensionMismatch {
            what: "exact solution",
            expected: y0.len(),
            found: exact.len(),
        });
    }
    sweep_rows(method, sweep, base, span, |opts| {
        let mut ode =
            FirstOrderIntegrator::new(make_problem(), method.clone(), t0, y0, opts.clone())?;
        let res = ode.integrate(t_end);
        Ok((error_norm(ode.y(), exact), ode.stats(), res.err()))
    })
}

/// As [`first_order`] for a second-order problem from `(t0, x0, v0)`;
/// `exact` is the state `[x; v]` at `t_end`.
///
/// # Errors
/// As [`first_order`].
pub fn second_order<P, F>(
    mut make_problem: F,
    method: &Method,
    t0: f64,
    x0: &[f64],
    v0: &[f64],
    t_end: f64,
    exact: &[f64],
    sweep: &Sweep,
    base: &SolverOptions,
) -> Result<Vec<WorkPrecisionRow>, OdeError>
where
    P: SecondOrderProblem + Send + 'static,
    F: FnMut() -> P,
{
    check_sweep(sweep, method)?;
    let span = check_span(t0, t_end)?;
    if exact.len() != x0.len() + v0.len() {
        return Err(OdeError::DimensionMismatch {
            what: "exact solution [x; v]",
            expected: x0.len() + v0.len(),
            found: exact.len(),
        });
    }
    sweep_rows(method, sweep, base, span, |opts| {
        let mut ode =
            SecondOrderIntegrator::new(make_problem(), method.clone(), t0, x0, v0, opts.clone())?;
        let res = ode.integrate(t_end);
        Ok((error_norm(ode.state(), exact), ode.stats(), res.err()))
    })
}

/// One row per setting of the sweep: `run` integrates with the options and
/// returns the error at `t_end`, the counters and the failure (if any);
/// the wall time covers `run`.
fn sweep_rows(
    method: &Method,
    sweep: &Sweep,
    base: &SolverOptions,
    span: f64,
    mut run: impl FnMut(&SolverOptions) -> Result<(f64, Stats, Option<OdeError>), OdeError>,
) -> Result<Vec<WorkPrecisionRow>, OdeError> {
    let mut rows = Vec::new();
    for (opts, tol) in settings(sweep, base, span) {
        let start = Instant::now();
        let (err, stats, failure) = run(&opts)?;
        let wall = start.elapsed().as_secs_f64();
        rows.push(row(
            method,
            &opts,
            tol,
            span,
            err,
            stats,
            wall,
            failure.map(|e| e.to_string()),
        ));
    }
    Ok(rows)
}

fn check_span(t0: f64, t_end: f64) -> Result<f64, OdeError> {
    let span = t_end - t0;
    if !(span > 0.0 && span.is_finite()) {
        return Err(OdeError::InvalidParameter {
            name: "t_end - t0",
            value: span,
            reason: "must be positive and finite",
        });
    }
    Ok(span)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn synthetic(h: f64, error: f64) -> WorkPrecisionRow {
        WorkPrecisionRow {
            method: "m".into(),
            h,
            tol: None,
            h_mean: h,
            error,
            stats: Stats {
                num_steps: 10,
                ..Stats::default()
            },
            wall_time_s: 0.5,
            failure: None,
        }
    }

    #[test]
    fn observed_order_of_an_exact_power_law() {
        // error = 3 h^2.5 exactly: the fitted slope is 2.5.
        let rows: Vec<_> = (0..5)
            .map(|i| {
                let h = 0.1 / 2f64.powi(i);
                synthetic(h, 3.0 * h.powf(2.5))
            })
            .collect();
        assert!((observed_order(&rows).unwrap() - 2.5).abs() < 1e-12);
        // Failed runs (infinite error) are left out; one point is not enough.
        let mut with_failure = rows.clone();
        with_failure.push(synthetic(1.0, f64::INFINITY));
        assert!((observed_order(&with_failure).unwrap() - 2.5).abs() < 1e-12);
        assert!(observed_order(&rows[..1]).is_none());
    }

    #[test]
    fn csv_and_json_rows() {
        let mut r = synthetic(0.25, 1e-3);
        r.failure = Some("a, b".into());
        let line = r.to_csv();
        assert_eq!(
            line.split(',').count(),
            WorkPrecisionRow::CSV_HEADER.split(',').count()
        );
        assert!(line.starts_with("m,2.5e-1,,2.5e-1,1e-3,10,"));
        let mut out = Vec::new();
        write_csv(&mut out, &[r.clone()]).unwrap();
        assert_eq!(String::from_utf8(out).unwrap().lines().count(), 2);
        let json = r.to_json();
        assert!(json.contains("\"error\":1e-3") && json.contains("\"tol\":null"));
        assert!(json.contains("\"failure\":\"a, b\""));
        r.error = f64::INFINITY;
        assert!(r.to_json().contains("\"error\":null"));
    }
}
