//! The direct baseline: faer's sparse Cholesky `A = L L^T` (AMD ordering,
//! simplicial or supernodal as faer decides), to compare PCG against exact.

use faer::Side;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};

use crate::error::{SparseError, check_finite, check_len};
use crate::matrix::SymBlockMatrix;
use crate::precond::square_dim;

/// Sparse Cholesky of a symmetric positive definite matrix.
///
/// The symbolic analysis is kept while the sparsity pattern stays the same,
/// so refactoring after a refill only redoes the numeric part.
#[derive(Debug)]
pub struct DirectCholesky {
    pattern: Option<(Vec<usize>, Vec<usize>)>,
    symbolic: Option<SymbolicLlt<usize>>,
    llt: Option<Llt<usize, f64>>,
    n: usize,
    max_bytes: u64,
}

impl Default for DirectCholesky {
    fn default() -> Self {
        Self::with_max_bytes(Self::DEFAULT_MAX_BYTES)
    }
}

impl DirectCholesky {
    /// The default cap on the factor's memory: 8 GiB.
    pub const DEFAULT_MAX_BYTES: u64 = 8 << 30;

    /// An empty solver whose factor may take [`Self::DEFAULT_MAX_BYTES`].
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty solver whose factor may take at most `max_bytes` (the fill
    /// of `L` is known after the symbolic analysis, before the numeric
    /// factorisation allocates it).
    pub fn with_max_bytes(max_bytes: u64) -> Self {
        Self {
            pattern: None,
            symbolic: None,
            llt: None,
            n: 0,
            max_bytes,
        }
    }

    /// Factors a symmetric block matrix.
    ///
    /// # Errors
    /// [`SparseError::NonFinite`], or [`SparseError::Direct`] if a pivot is
    /// not positive (the matrix is not positive definite).
    pub fn factor_block(&mut self, a: &SymBlockMatrix) -> Result<(), SparseError> {
        crate::error::non_empty("matrix", a.dim())?;
        // The upper triangle in CSR is the lower triangle in CSC.
        let (indptr, indices, data) = a.upper_csr_arrays();
        self.factor_lower_csc(a.dim(), indptr, indices, &data)
    }

    /// Factors a symmetric `sprs` matrix (checked: a Cholesky factor reads
    /// one triangle, so a nonsymmetric matrix would be solved as another one).
    ///
    /// # Errors
    /// [`SparseError::NotSquare`], [`SparseError::NonFinite`],
    /// [`SparseError::NotSymmetric`], [`SparseError::Direct`].
    pub fn factor_csr(&mut self, a: &sprs::CsMat<f64>) -> Result<(), SparseError> {
        let n = square_dim(a)?;
        crate::matrix::check_csr_symmetric(a)?;
        // CSC arrays of the lower triangle = CSR arrays of the upper triangle.
        let csr = if a.is_csr() { a.clone() } else { a.to_csr() };
        let mut indptr = Vec::with_capacity(n + 1);
        let mut indices = Vec::new();
        let mut data = Vec::new();
        indptr.push(0);
        for (i, row) in csr.outer_iterator().enumerate() {
            for (j, &v) in row.iter() {
                if j >= i {
                    indices.push(j);
                    data.push(v);
                }
            }
            indptr.push(indices.len());
        }
        self.factor_lower_csc(n, indptr, indices, &data)
    }

    fn factor_lower_csc(
        &mut self,
        n: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
        values: &[f64],
    ) -> Result<(), SparseError> {
        check_finite("matrix", values)?;
        self.llt = None;
        let same = matches!(&self.pattern, Some((p, i)) if *p == col_ptr && *i == row_idx);
        if !same {
            let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
            // The factor's size before it is allocated: a value and a row
            // index per nonzero of L (faer's SymbolicLlt keeps the count private).
            let analysis = faer::sparse::linalg::cholesky::factorize_symbolic_cholesky(
                sym,
                Side::Lower,
                Default::default(),
                Default::default(),
            )
            .map_err(|e| SparseError::Direct {
                message: format!("symbolic analysis failed: {e:?}"),
            })?;
            let bytes = (analysis.len_val() as u64).saturating_mul(16);
            if bytes > self.max_bytes {
                return Err(SparseError::Direct {
                    message: format!(
                        "the Cholesky factor would need about {:.1} GiB ({} nonzeros), more than the {:.1} GiB allowed (DirectCholesky::with_max_bytes)",
                        bytes as f64 / (1u64 << 30) as f64,
                        analysis.len_val(),
                        self.max_bytes as f64 / (1u64 << 30) as f64
                    ),
                });
            }
            let symbolic =
                SymbolicLlt::try_new(sym, Side::Lower).map_err(|e| SparseError::Direct {
                    message: format!("symbolic analysis failed: {e:?}"),
                })?;
            self.symbolic = Some(symbolic);
            self.pattern = Some((col_ptr, row_idx));
        }
        let (col_ptr, row_idx) = self.pattern.as_ref().expect("pattern set above");
        let sym = SymbolicSparseColMatRef::new_checked(n, n, col_ptr, None, row_idx);
        let mat = SparseColMatRef::new(sym, values);
        let symbolic = self.symbolic.clone().expect("symbolic set above");
        let llt = Llt::try_new_with_symbolic(symbolic, mat, Side::Lower).map_err(|e| match e {
            faer::sparse::linalg::LltError::Numeric(n) => SparseError::Direct {
                message: format!("matrix is not positive definite ({n:?})"),
            },
            other => SparseError::Direct {
                message: format!("{other:?}"),
            },
        })?;
        self.llt = Some(llt);
        self.n = n;
        Ok(())
    }

    /// Solves `A x = b` with the last factorisation.
    ///
    /// # Errors
    /// [`SparseError::InvalidParameter`] if nothing was factored,
    /// [`SparseError::DimensionMismatch`] for wrong lengths,
    /// [`SparseError::NonFinite`] for a NaN in `b`.
    pub fn solve(&self, b: &[f64], x: &mut [f64]) -> Result<(), SparseError> {
        let llt = self.llt.as_ref().ok_or(SparseError::InvalidParameter {
            name: "solver",
            message: "solve called before a successful factorisation".into(),
        })?;
        check_len("right-hand side b", b, self.n)?;
        check_len("solution x", x, self.n)?;
        check_finite("right-hand side b", b)?;
        x.copy_from_slice(b);
        llt.solve_in_place(faer::ColMut::from_slice_mut(x));
        Ok(())
    }

    /// Dimension of the factored matrix (0 before the first factorisation).
    pub fn dim(&self) -> usize {
        self.n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::precond::testutil::*;

    #[test]
    fn direct_solve_matches_dense_elimination() {
        let a = spd_block_matrix(3, 3);
        let b = rhs(a.dim());
        let exact = dense_solve(&dense(&a), &b);
        let mut x = vec![0.0; a.dim()];
        let mut d = DirectCholesky::new();
        d.factor_block(&a).unwrap();
        d.solve(&b, &mut x).unwrap();
        assert!(rel_diff(&x, &exact) < 1e-12);
        d.factor_csr(&a.to_csr()).unwrap();
        d.solve(&b, &mut x).unwrap();
        assert!(rel_diff(&x, &exact) < 1e-12);
    }

    #[test]
    fn indefinite_matrix_and_early_solve_are_errors() {
        let d = DirectCholesky::new();
        assert!(matches!(
            d.solve(&[1.0], &mut [0.0]),
            Err(SparseError::InvalidParameter { .. })
        ));
        let mut t = sprs::TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 1, -1.0);
        let mut d = DirectCholesky::new();
        assert!(matches!(
            d.factor_csr(&t.to_csr()),
            Err(SparseError::Direct { .. })
        ));
    }

    /// The factor's fill is checked against the cap before it is allocated.
    #[test]
    fn a_factor_above_the_memory_cap_is_refused_before_it_is_made() {
        let a = spd_block_matrix(30, 3);
        let mut small = DirectCholesky::with_max_bytes(1 << 10);
        let e = small.factor_block(&a).unwrap_err();
        assert!(e.to_string().contains("with_max_bytes"), "{e}");
        assert!(DirectCholesky::new().factor_block(&a).is_ok());
    }
}
