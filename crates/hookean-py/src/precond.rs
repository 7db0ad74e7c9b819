//! One of Hookean's preconditioners built from a [`System`], applied as
//! `M^-1` (for `scipy.sparse.linalg`) or used by PCG, the same path as
//! `hookean solve` ([`AnyPreconditioner::from_options`], [`PcgMatrix::pcg`]).

use std::ops::ControlFlow;
use std::time::Instant;

use hookean_sparse::{
    AmgPrecision, AmgSmoother, AnyPreconditioner, CgParams, CgProgress, CgWorkspace, PcgMatrix,
    PrecondKind, Preconditioner, PreconditionerOptions,
};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyDictMethods};

use crate::errors::{ConvergenceError, bad, sparse};
use crate::system::System;

/// The most residuals a solve records (its history), like `hookean bench`'s
/// trace: reserved before the solve, so the iterations do not allocate.
const MAX_HISTORY: usize = 100_000;

/// A preconditioner, set up from a [`System`].
#[pyclass(module = "hookean._hookean")]
pub struct Precond {
    p: AnyPreconditioner,
    setup_seconds: f64,
}

/// The multigrid's options from the `amg` dictionary of the Python API:
/// the library's names and ranges (checked by the multigrid's set-up).
fn amg_options(options: &mut PreconditionerOptions, amg: &Bound<'_, PyDict>) -> PyResult<()> {
    let o = &mut options.amg;
    for (key, value) in amg.iter() {
        let key: String = key
            .extract()
            .map_err(|_| bad("amg", "keys must be strings"))?;
        let wrong = |what: &str| bad("amg", format!("'{key}' must be {what}, got {value}"));
        let int = || {
            value
                .extract::<usize>()
                .map_err(|_| wrong("a non-negative integer"))
        };
        let float = || value.extract::<f64>().map_err(|_| wrong("a number"));
        match key.as_str() {
            "strength_threshold" => o.strength_threshold = float()?,
            "jacobi_weight" => o.jacobi_weight = float()?,
            "prolongation_weight" => o.prolongation_weight = float()?,
            "coarse_size" => o.coarse_size = int()?,
            "max_levels" => o.max_levels = int()?,
            "sweeps" => o.sweeps = int()?,
            "power_iterations" => o.power_iterations = int()?,
            "smoother" => {
                o.smoother = match value.extract::<String>().as_deref() {
                    Ok("block-jacobi") => AmgSmoother::BlockJacobi,
                    Ok("gauss-seidel") => AmgSmoother::SymmetricGaussSeidel,
                    Ok("ic0") => AmgSmoother::BlockIc0,
                    _ => return Err(wrong("block-jacobi, gauss-seidel or ic0")),
                }
            }
            "precision" => {
                o.precision = match value.extract::<String>().as_deref() {
                    Ok("single") => AmgPrecision::Single,
                    Ok("double") => AmgPrecision::Double,
                    _ => return Err(wrong("single or double")),
                }
            }
            _ => {
                return Err(bad(
                    "amg",
                    format!(
                        "unknown option '{key}' (expected strength_threshold, coarse_size, \
                         max_levels, smoother, sweeps, jacobi_weight, prolongation_weight, \
                         power_iterations or precision)"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A vector argument as a `Vec`, of `n` finite entries.
fn vector(arg: &str, v: &PyReadonlyArray1<'_, f64>, n: usize) -> PyResult<Vec<f64>> {
    let v = v.as_array();
    if v.len() != n {
        return Err(bad(
            arg,
            format!("has {} entries, the matrix has {n} rows", v.len()),
        ));
    }
    if let Some(i) = v.iter().position(|x| !x.is_finite()) {
        return Err(bad(arg, format!("entry {i} is {}", v[i])));
    }
    Ok(v.to_vec())
}

/// Sets `p` up from `m` without the GIL, in seconds.
fn timed_setup(py: Python<'_>, p: &mut AnyPreconditioner, m: &PcgMatrix) -> PyResult<f64> {
    py.detach(|| {
        let t = Instant::now();
        m.setup(p).map(|()| t.elapsed().as_secs_f64())
    })
    .map_err(|e| sparse("A", e))
}

#[pymethods]
impl Precond {
    /// Builds the preconditioner `name` (none, jacobi, block-jacobi, ssor,
    /// ic0, mic0, amg) from `system`; SSOR with relaxation `omega`, the
    /// multigrid with the options of `amg` and the system's unknowns per
    /// node and near-nullspace.
    #[new]
    #[pyo3(signature = (name, system, omega=None, amg=None))]
    fn new(
        py: Python<'_>,
        name: &str,
        system: &System,
        omega: Option<f64>,
        amg: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let kind: PrecondKind = name.parse().map_err(|e| bad("precond", e))?;
        let kind = match (kind, omega) {
            (PrecondKind::Ssor { .. }, Some(omega)) => PrecondKind::Ssor { omega },
            (PrecondKind::Mic0 { .. }, Some(omega)) => PrecondKind::Mic0 { omega },
            (k, _) => k,
        };
        let mut options = PreconditionerOptions::from(kind);
        if let Some(amg) = amg {
            amg_options(&mut options, amg)?;
        }
        // The system's unknowns per node: the multigrid's and block Jacobi's nodes.
        options.amg.block_size = system.matrix.block_size();
        if kind == PrecondKind::Amg {
            options
                .amg
                .near_nullspace
                .clone_from(&system.near_nullspace);
        }
        if matches!(kind, PrecondKind::Mic0 { .. })
            && matches!(system.matrix, PcgMatrix::Csr { .. })
        {
            return Err(bad(
                "precond",
                "mic0 needs 3x3 block storage: a matrix of 3 unknowns per node whose pattern is \
                 one of whole 3x3 blocks",
            ));
        }
        let arg = if amg.is_some() { "amg" } else { "precond" };
        let mut p = AnyPreconditioner::from_options(&options).map_err(|e| bad(arg, e))?;
        let setup_seconds = timed_setup(py, &mut p, &system.matrix)?;
        Ok(Self { p, setup_seconds })
    }

    /// Sets the preconditioner up again from `system` (new values of the
    /// same pattern: the multigrid refills its hierarchy).
    fn refill(&mut self, py: Python<'_>, system: &System) -> PyResult<()> {
        self.setup_seconds = timed_setup(py, &mut self.p, &system.matrix)?;
        Ok(())
    }

    /// Seconds of the last set-up or refill.
    #[getter]
    fn setup_seconds(&self) -> f64 {
        self.setup_seconds
    }

    /// The preconditioner's name.
    #[getter]
    fn name(&self) -> &'static str {
        self.p.kind().name()
    }

    /// The multigrid's hierarchy (levels, rows and nonzeros per level,
    /// operator and grid complexity), or `None` for another preconditioner.
    fn amg_stats<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let AnyPreconditioner::Amg(amg) = &self.p else {
            return Ok(None);
        };
        let s = amg.stats();
        let d = PyDict::new(py);
        d.set_item("levels", s.levels.len())?;
        d.set_item("rows", s.levels.iter().map(|l| l.rows).collect::<Vec<_>>())?;
        d.set_item(
            "nonzeros",
            s.levels.iter().map(|l| l.nonzeros).collect::<Vec<_>>(),
        )?;
        d.set_item("operator_complexity", s.operator_complexity)?;
        d.set_item("grid_complexity", s.grid_complexity)?;
        Ok(Some(d))
    }

    /// `z = M^-1 r`.
    fn apply<'py>(
        &self,
        py: Python<'py>,
        r: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let n = self.p.dim().unwrap_or(0);
        let r = vector("r", &r, n)?;
        let z = py.detach(|| {
            let mut z = vec![0.0; n];
            self.p.apply(&r, &mut z);
            z
        });
        Ok(PyArray1::from_vec(py, z))
    }

    /// PCG on `system` with this preconditioner from `x0` (default zero) to
    /// `|b - A x| <= rtol |b|`, at most `maxiter` iterations (default 2 n),
    /// calling `callback(xk)` after each iteration. Returns `x` and a
    /// dictionary: iterations, converged, relative_residual (PCG's true
    /// residual at its stop), residual_history (PCG's `|r| / |b|`, from 1 at
    /// the start), solve_seconds. An exception raised by `callback` stops
    /// the solve and propagates.
    #[pyo3(signature = (system, b, x0=None, rtol=1e-8, maxiter=None, callback=None))]
    fn pcg<'py>(
        &self,
        py: Python<'py>,
        system: &System,
        b: PyReadonlyArray1<'_, f64>,
        x0: Option<PyReadonlyArray1<'_, f64>>,
        rtol: f64,
        maxiter: Option<usize>,
        callback: Option<Py<PyAny>>,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyDict>)> {
        let n = system.matrix.dim();
        if self.p.dim().is_some_and(|d| d != n) {
            return Err(bad(
                "A",
                format!(
                    "has {n} rows, the preconditioner was built for {}",
                    self.p.dim().unwrap_or(0)
                ),
            ));
        }
        if !(0.0..1.0).contains(&rtol) {
            return Err(bad("rtol", format!("must lie in [0, 1), got {rtol}")));
        }
        let b = vector("b", &b, n)?;
        let mut x = match &x0 {
            Some(x0) => vector("x0", x0, n)?,
            None => vec![0.0; n],
        };
        let params = CgParams {
            rtol,
            max_iter: maxiter,
            initial_guess: if x0.is_some() {
                hookean_sparse::InitialGuess::Given
            } else {
                hookean_sparse::InitialGuess::Zero
            },
            ..Default::default()
        };
        let history_len = maxiter.unwrap_or(2 * n).min(MAX_HISTORY) + 1;
        let (result, history, seconds, raised) = py.detach(|| {
            let mut history = Vec::with_capacity(history_len);
            history.push(1.0);
            let mut raised: Option<PyErr> = None;
            let mut ws = CgWorkspace::new(n);
            let mut on_iteration = |p: &CgProgress<'_>| {
                if history.len() < history_len {
                    history.push(p.relative_residual);
                }
                if let Some(cb) = &callback {
                    let called = Python::attach(|py| {
                        cb.call1(py, (PyArray1::from_slice(py, p.x),)).map(drop)
                    });
                    if let Err(e) = called {
                        raised = Some(e);
                        return ControlFlow::Break(());
                    }
                }
                ControlFlow::Continue(())
            };
            let t = Instant::now();
            let result = system.matrix.pcg(
                &self.p,
                &b,
                &mut x,
                &params,
                &mut ws,
                Some(&mut on_iteration),
            );
            (result, history, t.elapsed().as_secs_f64(), raised)
        });
        if let Some(e) = raised {
            return Err(e);
        }
        let info = result.map_err(|e| match e {
            hookean_sparse::SparseError::PreconditionerNotPositiveDefinite { .. }
            | hookean_sparse::SparseError::NotPositiveDefinite { .. } => {
                ConvergenceError::new_err(e.to_string())
            }
            e => sparse("A", e),
        })?;
        let d = PyDict::new(py);
        d.set_item("iterations", info.iterations)?;
        d.set_item("converged", info.converged)?;
        d.set_item("relative_residual", info.true_relative_residual)?;
        d.set_item("residual_history", history)?;
        d.set_item("solve_seconds", seconds)?;
        Ok((PyArray1::from_vec(py, x), d))
    }
}
