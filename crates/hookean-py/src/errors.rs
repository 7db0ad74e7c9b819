//! Rust errors as Python exceptions: `ValueError` for bad input (naming the
//! argument), `hookean.ConvergenceError` for a failure on valid input.

use std::fmt::Display;

use hookean_sparse::SparseError;
use pyo3::PyErr;
use pyo3::exceptions::{PyRuntimeError, PyValueError};

pyo3::create_exception!(
    hookean,
    ConvergenceError,
    PyRuntimeError,
    "A solve or set-up that failed on valid input (PCG did not reach the tolerance, \
     a preconditioner broke down)."
);

/// `ValueError("{arg}: {message}")`.
pub fn bad(arg: &str, message: impl Display) -> PyErr {
    PyValueError::new_err(format!("{arg}: {message}"))
}

/// A [`SparseError`] of a set-up or solve: bad input (`ValueError` naming
/// `arg`) when the matrix or a parameter is wrong, else a failure on valid
/// input.
pub fn sparse(arg: &str, e: SparseError) -> PyErr {
    match e {
        SparseError::DimensionMismatch { .. }
        | SparseError::NotSquare { .. }
        | SparseError::NotBlockAligned { .. }
        | SparseError::NotSymmetric { .. }
        | SparseError::NonFinite { .. }
        | SparseError::Empty { .. }
        | SparseError::OneTriangle { .. }
        | SparseError::NullspaceLength { .. }
        | SparseError::InvalidParameter { .. }
        | SparseError::BadlyScaled { .. }
        | SparseError::TooLarge { .. } => bad(arg, e),
        other => ConvergenceError::new_err(other.to_string()),
    }
}
