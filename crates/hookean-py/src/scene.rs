//! Scene files and their simulations from Python: the facade's
//! [`Scene::from_file`] / [`Scene::from_text`] with `key=value` overrides,
//! [`Scene::build`], and [`Simulation`]'s steps, runs and OBJ writer. The
//! GIL is released during builds and steps. A scene pickles as its file's
//! path, text and overrides (`__reduce__`), rebuilt by
//! [`Scene::from_text`].

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::{Mutex, MutexGuard, PoisonError};

use hookean::HookeanError;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::exceptions::{PyFileExistsError, PyOSError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::errors::ConvergenceError;

/// A facade error as a Python exception: bad input (a scene key, an
/// override, a table that does not make a model) is a `ValueError` with the
/// facade's message, reading or writing a file an `OSError`, a run that
/// failed on valid input `hookean.ConvergenceError`.
fn error(e: HookeanError) -> PyErr {
    match e {
        HookeanError::Scene { .. }
        | HookeanError::Override { .. }
        | HookeanError::Build { .. }
        | HookeanError::InvalidOption { .. }
        | HookeanError::TooLarge { .. } => pyo3::exceptions::PyValueError::new_err(e.to_string()),
        HookeanError::Io { .. } => PyOSError::new_err(e.to_string()),
        e => ConvergenceError::new_err(e.to_string()),
    }
}

/// A parsed scene file with its overrides.
#[pyclass(module = "hookean._hookean", name = "Scene", frozen)]
pub struct PyScene {
    scene: hookean::scene::Scene,
    path: PathBuf,
    text: String,
    overrides: Vec<String>,
}

impl PyScene {
    fn parse(path: PathBuf, text: String, overrides: Vec<String>) -> PyResult<Self> {
        let o: Vec<&str> = overrides.iter().map(String::as_str).collect();
        let scene = hookean::scene::Scene::from_text(&path, &text, &o).map_err(error)?;
        Ok(Self {
            scene,
            path,
            text,
            overrides,
        })
    }
}

#[pymethods]
impl PyScene {
    /// Reads the scene file `path` and applies the `key=value` overrides
    /// in order (`cloth.n=16`; the value is TOML).
    #[staticmethod]
    #[pyo3(signature = (path, overrides=Vec::new()))]
    fn from_file(path: PathBuf, overrides: Vec<String>) -> PyResult<Self> {
        let o: Vec<&str> = overrides.iter().map(String::as_str).collect();
        // The facade reads and checks the file (its errors, its size cap);
        // the text is kept for pickling.
        hookean::scene::Scene::from_file(&path, &o).map_err(error)?;
        let text = std::fs::read_to_string(&path).map_err(|e| error(HookeanError::io(&path, e)))?;
        Self::parse(path, text, overrides)
    }

    /// The scene from the text of the file `path` (unpickling).
    #[staticmethod]
    fn from_text(path: PathBuf, text: String, overrides: Vec<String>) -> PyResult<Self> {
        Self::parse(path, text, overrides)
    }

    /// Builds the model and its integrator, without the GIL.
    fn build(&self, py: Python<'_>) -> PyResult<PySimulation> {
        let sim = py.detach(|| self.scene.build()).map_err(error)?;
        Ok(PySimulation {
            sim: Mutex::new(sim),
        })
    }

    /// The simulated seconds of the scene (`duration`).
    #[getter]
    fn duration(&self) -> f64 {
        self.scene.duration
    }

    /// The file the scene came from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    /// The overrides applied, in order.
    #[getter]
    fn overrides(&self) -> Vec<String> {
        self.overrides.clone()
    }

    /// The file's text as read.
    #[getter]
    fn text(&self) -> &str {
        &self.text
    }

    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let this = slf.get();
        let rebuild = slf.getattr("from_text")?;
        let args = PyTuple::new(
            py,
            [
                this.path.clone().into_pyobject(py)?.into_any(),
                this.text.clone().into_pyobject(py)?.into_any(),
                this.overrides.clone().into_pyobject(py)?.into_any(),
            ],
        )?;
        Ok((rebuild, args))
    }
}

/// A running simulation of a scene.
#[pyclass(module = "hookean._hookean", name = "Simulation")]
pub struct PySimulation {
    /// A `Mutex` makes the simulation `Sync`, as a Python class must be;
    /// `&mut self` methods hold it alone anyway.
    sim: Mutex<hookean::Simulation>,
}

impl PySimulation {
    fn lock(&self) -> MutexGuard<'_, hookean::Simulation> {
        self.sim.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// `(n, 3)` copy of a flat `[x0, y0, z0, x1, ...]`.
fn rows<'py>(py: Python<'py>, v: &[f64]) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray1::from_slice(py, v).reshape([v.len() / 3, 3])
}

#[pymethods]
impl PySimulation {
    /// One step, without the GIL; returns the time reached.
    fn step(&mut self, py: Python<'_>) -> PyResult<f64> {
        let mut guard = self.lock();
        let sim = &mut *guard;
        py.detach(|| sim.step()).map_err(error)?;
        Ok(sim.t())
    }

    /// Steps to `t` (the last step lands on it), without the GIL; calls
    /// `callback(t)` after each step (with the GIL) and stops when it returns
    /// `False`. An exception in `callback` propagates. Returns the time
    /// reached.
    #[pyo3(signature = (t, callback=None))]
    fn run_until(&mut self, py: Python<'_>, t: f64, callback: Option<Py<PyAny>>) -> PyResult<f64> {
        let mut guard = self.lock();
        let sim = &mut *guard;
        if !t.is_finite() || t < sim.t() {
            return Err(crate::errors::bad(
                "t",
                format!("must be finite and not before the current time {}", sim.t()),
            ));
        }
        let mut raised: Option<PyErr> = None;
        let result = py.detach(|| {
            sim.run_until_with(t, |s, _| {
                let Some(cb) = &callback else {
                    return ControlFlow::Continue(());
                };
                let t_now = s.t();
                let r = Python::attach(|py| -> PyResult<bool> {
                    let v = cb.call1(py, (t_now,))?;
                    let v = v.bind(py);
                    // Only `False` stops (None, the usual return, continues).
                    Ok(!v.is_instance_of::<pyo3::types::PyBool>() || v.is_truthy()?)
                });
                match r {
                    Ok(true) => ControlFlow::Continue(()),
                    Ok(false) => ControlFlow::Break(()),
                    Err(e) => {
                        raised = Some(e);
                        ControlFlow::Break(())
                    }
                }
            })
        });
        if let Some(e) = raised {
            return Err(e);
        }
        result.map_err(error)?;
        Ok(sim.t())
    }

    /// The simulated time (s).
    #[getter]
    fn t(&self) -> f64 {
        self.lock().t()
    }

    /// The positions, `(n, 3)` (a copy).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, self.lock().x())
    }

    /// The velocities, `(n, 3)` (a copy).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, self.lock().v())
    }

    /// The integrator's counters (CVODE's names).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let sim = self.lock();
        let s = sim.stats();
        let d = PyDict::new(py);
        d.set_item("steps", s.num_steps)?;
        d.set_item("rhs_evals", s.num_rhs_evals)?;
        d.set_item("jac_evals", s.num_jac_evals)?;
        d.set_item("lin_solv_setups", s.num_lin_solv_setups)?;
        d.set_item("newton_iterations", s.num_nonlin_solv_iters)?;
        d.set_item("newton_failures", s.num_nonlin_solv_conv_fails)?;
        d.set_item("error_test_failures", s.num_err_test_fails)?;
        d.set_item("linear_iterations", s.num_lin_iters)?;
        d.set_item("last_step", s.last_step)?;
        d.set_item("wall_seconds", sim.wall().as_secs_f64())?;
        Ok(d)
    }

    /// Writes the current positions as OBJ to `path`; an existing file is
    /// replaced only with `overwrite=True` (else `FileExistsError`).
    #[pyo3(signature = (path, overwrite=false))]
    fn write_obj(&self, path: PathBuf, overwrite: bool) -> PyResult<()> {
        if overwrite {
            return self.lock().write_obj(&path).map_err(error);
        }
        let file = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(|e| {
                if e.kind() == std::io::ErrorKind::AlreadyExists {
                    PyFileExistsError::new_err(format!(
                        "{}: exists (pass overwrite=True to replace it)",
                        path.display()
                    ))
                } else {
                    error(HookeanError::io(&path, e))
                }
            })?;
        let mut w = std::io::BufWriter::new(file);
        self.lock().write_obj_to(&mut w).map_err(error)?;
        std::io::Write::flush(&mut w).map_err(|e| error(HookeanError::io(&path, e)))
    }
}
