//! The native part of the `hookean` Python package (`hookean._hookean`):
//! a symmetric system converted once from a `scipy.sparse` matrix
//! (`system::System`), Hookean's preconditioners built from it and PCG
//! (`precond::Precond`).
//!
//! The Python layer (`python/hookean/`) checks the arguments users pass and
//! hands this module contiguous NumPy arrays; this module checks them again
//! (a structure that would make a Rust routine panic is refused with a
//! `ValueError`), releases the GIL during set-ups and solves, and raises
//! `hookean.ConvergenceError` for a solve that fails on valid input; and
//! `y' = f(t, y)` with Python callables on hookean-ode's variable-order BDF
//! (`ode::bdf_solve`, under `hookean.ode.solve_ivp`); scene files and their
//! simulations through the facade (`scene::PyScene`, `scene::PySimulation`).

mod errors;
mod ode;
mod precond;
mod scene;
mod system;

use pyo3::prelude::*;

/// The native module: `hookean._hookean`.
#[pymodule]
fn _hookean(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add(
        "ConvergenceError",
        m.py().get_type::<errors::ConvergenceError>(),
    )?;
    m.add_class::<system::System>()?;
    m.add_class::<precond::Precond>()?;
    m.add_class::<scene::PyScene>()?;
    m.add_class::<scene::PySimulation>()?;
    m.add_function(wrap_pyfunction!(system::system, m)?)?;
    m.add_function(wrap_pyfunction!(ode::bdf_solve, m)?)?;
    Ok(())
}
