//! `y' = fun(t, y)` with Python callables, integrated by hookean-ode's
//! variable-order BDF ([`Method::VariableBdf`], its first step from `first_step`) through the one event
//! driver of the stepping contract
//! ([`Integrator::integrate_with_events`]): the native half of
//! `hookean.ode.solve_ivp`.
//!
//! The GIL is released during the run and taken back for each call of
//! `fun`, `jac` and the event functions. An exception raised by one of them
//! is kept, the problem answers NaN from then on (without calling Python
//! again), the integration stops with a non-finite error, and the kept
//! exception is raised to the caller unchanged.

use std::cell::RefCell;
use std::ops::ControlFlow;
use std::sync::{Arc, Mutex, PoisonError};

use hookean_ode::{
    BdfConfig, Direction, EventHit, Events, FirstOrderIntegrator, FirstOrderProblem, Integrator,
    Method, OdeError, SolverOptions, Stats, StepSizePolicy, Tolerance,
};
use numpy::{PyArray1, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use sprs::CsMat;

use crate::errors::bad;

/// Chebyshev-Lobatto nodes per step for the dense output: the BDF's
/// interpolant has the step's order (at most 5), so its values at six
/// nodes give it back exactly (up to rounding) as a polynomial of degree 5.
const DENSE_NODES: usize = 6;

/// `fun` and `jac` of the caller, and the first exception they raised.
struct PyProblem {
    fun: Py<PyAny>,
    /// Returns the dense `(n, n)` Jacobian, or, with `pattern`, the values
    /// of the sparse one in the pattern's CSR order.
    jac: Option<Py<PyAny>>,
    /// The sparse Jacobian's pattern (CSR, the diagonal included, values
    /// ignored): the BDF then factors `I - c J` with a sparse LU.
    pattern: Option<CsMat<f64>>,
    n: usize,
    raised: Arc<Mutex<Option<PyErr>>>,
}

impl PyProblem {
    /// Calls `f(t, y)` and copies its array result (length `len`, as the
    /// Python layer's `np.asarray` made it) into `out`; on any failure
    /// keeps the exception and fills `out` with NaN.
    fn call_into(&self, f: &Py<PyAny>, arg: &str, t: f64, y: &[f64], out: &mut [f64]) {
        if self.raised().is_some() {
            out.fill(f64::NAN);
            return;
        }
        let result = Python::attach(|py| -> PyResult<()> {
            let r = f.call1(py, (t, PyArray1::from_slice(py, y)))?;
            let a: PyReadonlyArrayDyn<'_, f64> = r
                .extract(py)
                .map_err(|_| bad(arg, "must return an array of floats"))?;
            if a.len() != out.len() {
                return Err(bad(
                    arg,
                    format!(
                        "returned shape {}, expected {} values (y0 has {})",
                        tuple(a.shape()),
                        out.len(),
                        self.n
                    ),
                ));
            }
            for (o, v) in out.iter_mut().zip(a.as_array().iter()) {
                *o = *v;
            }
            Ok(())
        });
        if let Err(e) = result {
            *self.raised() = Some(e);
            out.fill(f64::NAN);
        }
    }

    /// The first exception raised, if any.
    fn raised(&self) -> std::sync::MutexGuard<'_, Option<PyErr>> {
        self.raised.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl FirstOrderProblem for PyProblem {
    fn dim(&self) -> usize {
        self.n
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        self.call_into(&self.fun, "fun", t, y, dy);
    }

    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> bool {
        match &self.jac {
            Some(j) if self.pattern.is_none() => {
                self.call_into(j, "jac", t, y, jac);
                true
            }
            _ => false,
        }
    }

    fn sparse_jacobian_pattern(&self) -> Option<CsMat<f64>> {
        self.pattern.clone()
    }

    fn jacobian_sparse(&self, t: f64, y: &[f64], jac: &mut CsMat<f64>) -> bool {
        match (&self.jac, &self.pattern) {
            (Some(j), Some(_)) => {
                self.call_into(j, "jac", t, y, jac.data_mut());
                true
            }
            _ => false,
        }
    }
}

/// The CSR pattern `(indptr, indices)` the Python layer built (sorted
/// columns, the diagonal included) as a matrix of zeros.
fn csr_pattern(n: usize, indptr: Vec<i64>, indices: Vec<i64>) -> PyResult<CsMat<f64>> {
    let wrong = |what: &str| bad("jac_sparsity", what.to_string());
    if indptr.len() != n + 1 {
        return Err(wrong("the pattern's row pointer has the wrong length"));
    }
    let to_usize = |v: &[i64]| -> PyResult<Vec<usize>> {
        v.iter()
            .map(|&i| usize::try_from(i).map_err(|_| wrong("a negative index in the pattern")))
            .collect()
    };
    let (indptr, indices) = (to_usize(&indptr)?, to_usize(&indices)?);
    let data = vec![0.0; indices.len()];
    CsMat::try_new((n, n), indptr, indices, data)
        .map_err(|(_, _, _, e)| wrong(&format!("not a valid CSR pattern ({e})")))
}

/// A shape as Python prints it: `(2,)`, `(2, 3)`.
fn tuple(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => {
            let parts: Vec<String> = shape.iter().map(usize::to_string).collect();
            format!("({})", parts.join(", "))
        }
    }
}

/// What the run collected, also when it failed part way.
#[derive(Default)]
struct Collected {
    t: Vec<f64>,
    y: Vec<f64>,
    segments: Vec<f64>,
    nodes: Vec<f64>,
    events: Vec<EventHit>,
}

/// The value of `ode`'s dense output at `t` in the last step (its state at
/// the step's end).
fn value_at(ode: &impl Integrator, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
    if t == ode.t() {
        out.copy_from_slice(ode.state());
        Ok(())
    } else {
        ode.interpolate(t, out)
    }
}

/// Records one step `[a, b]`: the output times in it (`t_eval`, or its end
/// when `t_eval` is `None`) and, for the dense output, the values at the
/// step's Chebyshev-Lobatto nodes.
fn record(
    ode: &impl Integrator,
    (a, b): (f64, f64),
    t_eval: Option<&[f64]>,
    next: &mut usize,
    dense: bool,
    c: &mut Collected,
) -> Result<(), OdeError> {
    let n = ode.state().len();
    let mut y = vec![0.0; n];
    match t_eval {
        Some(times) => {
            while *next < times.len() && times[*next] <= b {
                value_at(ode, times[*next], &mut y)?;
                c.t.push(times[*next]);
                c.y.extend_from_slice(&y);
                *next += 1;
            }
        }
        None => {
            value_at(ode, b, &mut y)?;
            c.t.push(b);
            c.y.extend_from_slice(&y);
        }
    }
    if dense && b > a {
        c.segments.push(b);
        let last = (DENSE_NODES - 1) as f64;
        for j in 0..DENSE_NODES {
            let s = 0.5 * (1.0 - (std::f64::consts::PI * j as f64 / last).cos());
            let tj = if j == DENSE_NODES - 1 {
                b
            } else {
                a + (b - a) * s
            };
            value_at(ode, tj, &mut y)?;
            c.nodes.extend_from_slice(&y);
        }
    }
    Ok(())
}

/// The counters SciPy reports, with Hookean's own.
fn stats_dict<'py>(py: Python<'py>, s: &Stats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("nfev", s.num_rhs_evals + s.num_lin_rhs_evals)?;
    d.set_item("njev", s.num_jac_evals)?;
    d.set_item("nlu", s.num_lin_solv_setups)?;
    d.set_item("steps", s.num_steps)?;
    d.set_item("rejected_steps", s.num_rejected_steps())?;
    d.set_item("newton_iterations", s.num_nonlin_solv_iters)?;
    d.set_item("event_evaluations", s.num_g_evals)?;
    Ok(d)
}

/// Integrates `y' = fun(t, y)` from `(t0, y0)` to `t_end` with the
/// variable-order BDF; the Python layer (`hookean.ode.solve_ivp`) has
/// checked every argument and wrapped `fun`, `jac` and the events to
/// return float arrays; with `pattern` (a CSR `(indptr, indices)` with the
/// diagonal) `jac` returns the sparse Jacobian's values in that order and
/// the Newton matrix is factored by a sparse LU. `directions` and `terminal` describe `events`
/// (`-1`, `0`, `1`: falling, both, rising). Returns a dict: `t`, `y`
/// (flattened, `n` per time), `segments` and `nodes` (the dense output:
/// step ends after `t0` and six values per step), `events` (a list of
/// `(index, t, y)`), `status` (0 reached `t_end`, 1 terminal event, -1
/// failed), `message` and the counters.
#[pyfunction]
#[pyo3(signature = (fun, jac, pattern, t0, y0, t_end, rtol, atol, first_step, max_step, t_eval, dense, events, directions, terminal))]
#[allow(clippy::too_many_arguments)]
pub fn bdf_solve<'py>(
    py: Python<'py>,
    fun: Py<PyAny>,
    jac: Option<Py<PyAny>>,
    pattern: Option<(Vec<i64>, Vec<i64>)>,
    t0: f64,
    y0: Vec<f64>,
    t_end: f64,
    rtol: f64,
    atol: Vec<f64>,
    first_step: Option<f64>,
    max_step: f64,
    t_eval: Option<Vec<f64>>,
    dense: bool,
    events: Vec<Py<PyAny>>,
    directions: Vec<i32>,
    terminal: Vec<bool>,
) -> PyResult<Bound<'py, PyDict>> {
    let n = y0.len();
    if atol.len() != n && atol.len() != 1 {
        return Err(bad(
            "atol",
            format!("has {} entries, y0 has {n}", atol.len()),
        ));
    }
    if directions.len() != events.len() || terminal.len() != events.len() {
        return Err(bad("events", "one direction and terminal flag per event"));
    }
    let options = SolverOptions {
        rtol,
        atol: if atol.len() == 1 {
            Tolerance::Scalar(atol[0])
        } else {
            Tolerance::Vector(atol)
        },
        step: StepSizePolicy {
            h_max: max_step,
            ..Default::default()
        },
        ..Default::default()
    };
    let raised_slot = Arc::new(Mutex::new(None));
    let pattern = pattern
        .map(|(indptr, indices)| csr_pattern(n, indptr, indices))
        .transpose()?;
    let problem = PyProblem {
        fun,
        jac,
        pattern,
        n,
        raised: Arc::clone(&raised_slot),
    };
    let (collected, outcome, stats, raised) = py.detach(move || {
        let event_raised: RefCell<Option<PyErr>> = RefCell::new(None);
        let mut c = Collected::default();
        let method = Method::VariableBdf(BdfConfig {
            initial_step: first_step,
            ..Default::default()
        });
        let mut ode = match FirstOrderIntegrator::new(problem, method, t0, &y0, options) {
            Ok(ode) => ode,
            Err(e) => return (c, Err(e), Stats::default(), None),
        };
        let mut next = 0;
        match &t_eval {
            Some(times) => {
                while next < times.len() && times[next] <= t0 {
                    c.t.push(times[next]);
                    c.y.extend_from_slice(&y0);
                    next += 1;
                }
            }
            None => {
                c.t.push(t0);
                c.y.extend_from_slice(&y0);
            }
        }
        if dense {
            c.segments.push(t0);
        }
        let g = |t: f64, y: &[f64], out: &mut [f64]| {
            if event_raised.borrow().is_some() {
                out.fill(f64::NAN);
                return;
            }
            let called = Python::attach(|py| -> PyResult<()> {
                let ya = PyArray1::from_slice(py, y);
                for (o, e) in out.iter_mut().zip(&events) {
                    *o = e.call1(py, (t, &ya))?.extract::<f64>(py)?;
                }
                Ok(())
            });
            if let Err(e) = called {
                *event_raised.borrow_mut() = Some(e);
                out.fill(f64::NAN);
            }
        };
        let dirs = directions
            .iter()
            .map(|d| match d.signum() {
                1 => Direction::Rising,
                -1 => Direction::Falling,
                _ => Direction::Both,
            })
            .collect();
        let mut ev = match Events::new(g, dirs, terminal) {
            Ok(ev) => ev,
            Err(e) => return (c, Err(e), Stats::default(), None),
        };
        let has_events = !events.is_empty();
        let mut failed = None;
        let run =
            ode.integrate_with_events(t_end, has_events.then_some(&mut ev), |ode, step, hits| {
                c.events.extend_from_slice(hits);
                match record(ode, step, t_eval.as_deref(), &mut next, dense, &mut c) {
                    Ok(()) => ControlFlow::Continue(()),
                    Err(e) => {
                        failed = Some(e);
                        ControlFlow::Break(())
                    }
                }
            });
        let outcome = match (run, failed) {
            (Err(e), _) | (Ok(_), Some(e)) => Err(e),
            (Ok(run), None) => Ok(run.terminal),
        };
        let stats = ode.stats();
        drop(ev);
        (c, outcome, stats, event_raised.into_inner())
    });
    let raised = raised_slot
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .take()
        .or(raised);
    if let Some(e) = raised {
        return Err(e);
    }
    let (status, message) = match outcome {
        Ok(false) => (
            0,
            "The solver successfully reached the end of the integration interval.".to_string(),
        ),
        Ok(true) => (1, "A termination event occurred.".to_string()),
        Err(e) => (-1, e.to_string()),
    };
    let d = stats_dict(py, &stats)?;
    d.set_item("t", collected.t)?;
    d.set_item("y", collected.y)?;
    d.set_item("segments", collected.segments)?;
    d.set_item("nodes", collected.nodes)?;
    let hits = PyList::empty(py);
    for h in collected.events {
        hits.append((h.index, h.t, h.y))?;
    }
    d.set_item("events", hits)?;
    d.set_item("status", status)?;
    d.set_item("message", message)?;
    Ok(d)
}
