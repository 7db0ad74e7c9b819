//! A `scipy.sparse` matrix converted once into the storage PCG runs on,
//! with the multigrid's unknowns per node and near-nullspace, decided as
//! `hookean solve` decides them ([`PcgMatrix::auto`],
//! [`nullspace_block_size`], [`detect_block_size`]).

use hookean_sparse::{
    AMG_NEAR_NULLSPACE_SHAPES, PcgMatrix, amg_takes_near_nullspace, check_csr_symmetric,
    detect_block_size, nullspace_block_size, rigid_body_modes,
};
use numpy::{PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

use crate::errors::bad;

/// A square symmetric matrix in PCG's storage, with what the multigrid
/// needs to know about its nodes.
#[pyclass(module = "hookean._hookean", frozen)]
pub struct System {
    /// The matrix, as 3x3 blocks or CSR.
    pub matrix: PcgMatrix,
    /// The multigrid's near-nullspace (empty: the translations).
    pub near_nullspace: Vec<Vec<f64>>,
    /// Where the unknowns per node came from.
    pub block_size_source: &'static str,
}

#[pymethods]
impl System {
    /// The number of rows.
    #[getter]
    fn n(&self) -> usize {
        self.matrix.dim()
    }

    /// Unknowns per node (3 on block storage).
    #[getter]
    fn block_size(&self) -> usize {
        self.matrix.block_size()
    }

    /// Where [`block_size`](Self::block_size) came from: `block_size`,
    /// `nullspace`, `coordinates`, `detected` or `default`.
    #[getter]
    fn block_size_source(&self) -> &'static str {
        self.block_size_source
    }

    /// `sym-block-3x3` or `csr`.
    #[getter]
    fn format(&self) -> &'static str {
        self.matrix.format()
    }

    /// Whether `other` is stored on the same pattern (the same 3x3 blocks,
    /// or the same CSR rows and columns), as a refill of a preconditioner
    /// built from `self` needs.
    fn same_pattern(&self, other: &System) -> bool {
        self.matrix.same_pattern(&other.matrix)
    }
}

/// Row pointers or column indices (a NumPy array of `int32` or `int64`) as
/// `usize`, each in `0..=max`: one pass, one copy.
fn indices(arg: &str, what: &str, v: &Bound<'_, PyAny>, max: usize) -> PyResult<Vec<usize>> {
    fn convert<T: Copy + Into<i64>>(
        arg: &str,
        what: &str,
        v: &[T],
        max: usize,
    ) -> PyResult<Vec<usize>> {
        let out: Vec<usize> = v
            .iter()
            .map(|&i| usize::try_from(i.into()).unwrap_or(usize::MAX))
            .collect();
        match out.iter().position(|&u| u > max) {
            Some(k) => Err(bad(
                arg,
                format!("{what} entry {} outside 0 to {max}", v[k].into()),
            )),
            None => Ok(out),
        }
    }
    let contiguous = |e| bad(arg, format!("arrays must be contiguous ({e})"));
    if let Ok(a) = v.extract::<PyReadonlyArray1<'_, i32>>() {
        convert(arg, what, a.as_slice().map_err(contiguous)?, max)
    } else {
        let a: PyReadonlyArray1<'_, i64> = v.extract()?;
        convert(arg, what, a.as_slice().map_err(contiguous)?, max)
    }
}

/// The columns of an `(n, k)` array.
fn columns(a: &PyReadonlyArray2<'_, f64>) -> Vec<Vec<f64>> {
    let a = a.as_array();
    a.columns().into_iter().map(|c| c.to_vec()).collect()
}

/// Converts the CSR arrays of a square `n x n` matrix (`A` in the user's
/// words) into a [`System`]: structure checked, finite and symmetric
/// (PCG's matrix), the unknowns per node from `block_size`, the first
/// vector of `nullspace` (an `(n, k)` array), the columns of `coordinates`
/// (an `(n / d, d)` array whose rigid-body modes become the
/// near-nullspace) or the pattern. The index arrays may be `int32` or
/// `int64`. The entries are copied once, into the storage PCG runs on
/// (the CSR copy itself becomes block storage when that is chosen), and
/// symmetry is checked once, by the conversion.
#[pyfunction]
#[pyo3(signature = (n, indptr, indices_, data, block_size=None, nullspace=None, coordinates=None))]
pub fn system(
    py: Python<'_>,
    n: usize,
    indptr: &Bound<'_, PyAny>,
    indices_: &Bound<'_, PyAny>,
    data: PyReadonlyArray1<'_, f64>,
    block_size: Option<i64>,
    nullspace: Option<PyReadonlyArray2<'_, f64>>,
    coordinates: Option<PyReadonlyArray2<'_, f64>>,
) -> PyResult<System> {
    let contiguous = |e| bad("A", format!("arrays must be contiguous ({e})"));
    if n == 0 {
        return Err(bad(
            "A",
            "the matrix is empty (0 x 0): there is nothing to solve",
        ));
    }
    let val = data.as_slice().map_err(contiguous)?;
    if let Some(k) = val.iter().position(|v| !v.is_finite()) {
        return Err(bad("A", format!("entry {k} of its data is {}", val[k])));
    }
    let nnz = val.len();
    let ptr = indices("A", "row pointer", indptr, nnz)?;
    let idx = indices("A", "column index", indices_, n.saturating_sub(1))?;
    let a = sprs::CsMat::try_new((n, n), ptr, idx, val.to_vec())
        .map_err(|(.., e)| bad("A", format!("not a valid CSR matrix: {e}")))?;
    let (near_nullspace, implied) = match (&nullspace, &coordinates) {
        (Some(_), Some(_)) => {
            return Err(bad("nullspace", "give nullspace or coordinates, not both"));
        }
        (Some(v), None) => {
            let (rows, k) = v.as_array().dim();
            if rows != n {
                return Err(bad(
                    "nullspace",
                    format!("has {rows} rows, the matrix has {n}; expected an {n} x k array"),
                ));
            }
            let v = columns(v);
            if v.iter().flatten().any(|x| !x.is_finite()) {
                return Err(bad("nullspace", "has a NaN or infinite entry"));
            }
            if k == 0 {
                return Err(bad("nullspace", "has no vectors (0 columns)"));
            }
            if let Some(j) = v.iter().position(|c| c.iter().all(|&x| x == 0.0)) {
                return Err(bad("nullspace", format!("column {j} is zero")));
            }
            let d = nullspace_block_size(&v).map(|d| (d, "nullspace"));
            (v, d)
        }
        (None, Some(c)) => {
            let (nodes, d) = c.as_array().dim();
            if !(d == 2 || d == 3) || nodes * d != n {
                return Err(bad(
                    "coordinates",
                    format!(
                        "has shape ({nodes}, {d}); expected ({}, 2) or ({}, 3): one row per \
                         node of 2 or 3 unknowns of the {n} rows",
                        n / 2,
                        n / 3
                    ),
                ));
            }
            let flat: Vec<f64> = c.as_array().iter().copied().collect();
            let v = rigid_body_modes(&flat, d).map_err(|e| bad("coordinates", e))?;
            (v, Some((d, "coordinates")))
        }
        (None, None) => (Vec::new(), None),
    };
    let given = match block_size {
        Some(b @ 1..=3) => Some((b as usize, "block_size")),
        Some(b) => return Err(bad("block_size", format!("must be 1, 2 or 3, got {b}"))),
        None => implied,
    };
    // The pattern detection and the conversion read the whole matrix:
    // without the GIL. Both storages check symmetry as they are built
    // (`SymBlockMatrix::from_csr`, `SymCsrMatrix::from_csr`); CSR without
    // the symmetric product is a matrix that failed it, whose first
    // offending entry the check names.
    let (matrix, source) = py
        .detach(move || {
            let (b, source) = given.unwrap_or_else(|| match detect_block_size(&a) {
                1 => (1, "default"),
                d => (d, "detected"),
            });
            let m = PcgMatrix::auto(a, b);
            // Block storage has 3 unknowns per node whatever was asked.
            let source = if m.block_size() != b {
                "default"
            } else {
                source
            };
            let symmetric = match &m {
                PcgMatrix::Csr {
                    a, product: None, ..
                } => check_csr_symmetric(a),
                _ => Ok(()),
            };
            symmetric.map(|()| (m, source))
        })
        .map_err(|e| bad("A", format!("{e} (PCG needs a symmetric matrix)")))?;
    let (b, k) = (matrix.block_size(), near_nullspace.len());
    if k > 0 && !amg_takes_near_nullspace(b, k) {
        let arg = if nullspace.is_some() {
            "nullspace"
        } else {
            "coordinates"
        };
        return Err(bad(
            arg,
            format!(
                "{k} vectors on nodes of {b} unknown{} (from {source}); expected an {n} x k \
                 array of k near-nullspace vectors: {AMG_NEAR_NULLSPACE_SHAPES}",
                if b == 1 { "" } else { "s" }
            ),
        ));
    }
    Ok(System {
        matrix,
        near_nullspace,
        block_size_source: source,
    })
}
