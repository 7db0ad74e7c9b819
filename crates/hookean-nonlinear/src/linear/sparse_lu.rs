//! [`SparseLu`]: faer's sparse LU for general sparse Jacobians.

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use hookean_sparse::SparseError;

use super::{LinearSolveStats, LinearSolver};
use crate::error::{NonlinearError, check_len, invalid};

/// Sparse LU with partial pivoting (faer, COLAMD ordering) for general
/// sparse Jacobians stored as `sprs::CsMat<f64>` (CSR or CSC).
///
/// The symbolic analysis is kept while the sparsity pattern is unchanged,
/// so a setup after a refill redoes only the numeric factorisation.
#[derive(Debug, Default)]
pub struct SparseLu {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    symbolic: Option<SymbolicLu<usize>>,
    lu: Option<Lu<usize, f64>>,
    n: usize,
}

impl SparseLu {
    /// An empty solver.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether a symbolic analysis is cached (it is reused by the next
    /// [`setup`](LinearSolver::setup) if the pattern is unchanged).
    pub fn has_symbolic(&self) -> bool {
        self.symbolic.is_some()
    }
}

impl LinearSolver<sprs::CsMat<f64>> for SparseLu {
    fn setup(&mut self, jac: &sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        self.lu = None;
        let (r, c) = jac.shape();
        if r != c {
            return Err(SparseError::NotSquare { rows: r, cols: c }.into());
        }
        let csc_owned;
        let csc = if jac.is_csc() {
            jac
        } else {
            csc_owned = jac.to_other_storage();
            &csc_owned
        };
        let same_pattern = self.symbolic.is_some()
            && self.n == r
            && self.col_ptr.as_slice() == csc.indptr().raw_storage()
            && self.row_idx.as_slice() == csc.indices();
        if !same_pattern {
            self.col_ptr.clear();
            self.col_ptr.extend_from_slice(csc.indptr().raw_storage());
            self.row_idx.clear();
            self.row_idx.extend_from_slice(csc.indices());
            let sym =
                SymbolicSparseColMatRef::new_checked(r, r, &self.col_ptr, None, &self.row_idx);
            let symbolic = SymbolicLu::try_new(sym).map_err(|e| {
                invalid(
                    "Jacobian",
                    format!("sparse LU symbolic analysis failed: {e:?}"),
                )
            })?;
            self.symbolic = Some(symbolic);
        }
        self.values.clear();
        self.values.extend_from_slice(csc.data());
        if let Some(i) = self.values.iter().position(|v| !v.is_finite()) {
            return Err(SparseError::NonFinite {
                what: "Jacobian",
                index: Some(i),
            }
            .into());
        }
        let sym = SymbolicSparseColMatRef::new_checked(r, r, &self.col_ptr, None, &self.row_idx);
        let mat = SparseColMatRef::new(sym, &self.values);
        let symbolic = self.symbolic.clone().expect("symbolic analysis set above");
        let lu = Lu::try_new_with_symbolic(symbolic, mat).map_err(|e| match e {
            LuError::SymbolicSingular { index } => NonlinearError::SingularJacobian {
                pivot: index,
                value: 0.0,
            },
            LuError::Generic(g) => invalid("Jacobian", format!("sparse LU failed: {g:?}")),
        })?;
        self.lu = Some(lu);
        self.n = r;
        Ok(())
    }

    fn solve(
        &mut self,
        _jac: &sprs::CsMat<f64>,
        rhs: &[f64],
        x: &mut [f64],
        _rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let lu = self.lu.as_ref().ok_or(NonlinearError::NotReady(
            "SparseLu::solve before a successful setup",
        ))?;
        check_len("right-hand side", rhs, self.n)?;
        check_len("solution", x, self.n)?;
        x.copy_from_slice(rhs);
        lu.solve_in_place(faer::ColMut::from_slice_mut(x));
        // A numerically zero pivot shows up as inf/NaN in the solution.
        if x.iter().any(|v| !v.is_finite()) && rhs.iter().all(|v| v.is_finite()) {
            return Err(NonlinearError::SingularJacobian {
                pivot: 0,
                value: 0.0,
            });
        }
        Ok(LinearSolveStats {
            converged: true,
            ..Default::default()
        })
    }

    fn is_direct(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hookean_testkit::dense::{rel_diff, solve as dense_solve, to_dense};

    /// A nonsymmetric sparse matrix (convection-diffusion-like), diagonally dominant.
    fn nonsymmetric(n: usize) -> sprs::CsMat<f64> {
        let mut t = sprs::TriMat::new((n, n));
        for i in 0..n {
            t.add_triplet(i, i, 4.0 + (i % 3) as f64);
            if i > 0 {
                t.add_triplet(i, i - 1, -1.5);
            }
            if i + 1 < n {
                t.add_triplet(i, i + 1, -0.5);
            }
            if i + 7 < n {
                t.add_triplet(i, i + 7, 0.25);
            }
        }
        t.to_csr()
    }

    #[test]
    fn sparse_lu_solves_nonsymmetric_systems_and_reuses_the_analysis() {
        let a = nonsymmetric(40);
        let b: Vec<f64> = (0..40).map(|i| (i as f64).cos()).collect();
        let exact = dense_solve(&to_dense(&a), &b);
        let mut lu = SparseLu::new();
        let mut x = vec![0.0; 40];
        assert!(matches!(
            lu.solve(&a, &b, &mut x, 0.0),
            Err(NonlinearError::NotReady(_))
        ));
        lu.setup(&a).unwrap();
        let st = lu.solve(&a, &b, &mut x, 0.0).unwrap();
        assert!(st.converged && st.iterations == 0);
        assert!(rel_diff(&x, &exact) < 1e-13);
        // Refill (same pattern, new values) and solve again: CSC input too.
        let mut a2 = a.to_other_storage();
        for v in a2.data_mut() {
            *v *= 2.0;
        }
        lu.setup(&a2).unwrap();
        assert!(lu.has_symbolic());
        lu.solve(&a2, &b, &mut x, 0.0).unwrap();
        let half: Vec<f64> = exact.iter().map(|v| v / 2.0).collect();
        assert!(rel_diff(&x, &half) < 1e-13);
        // Structurally singular (an empty column) and non-square are errors.
        let mut t = sprs::TriMat::new((2, 2));
        t.add_triplet(0, 0, 1.0);
        t.add_triplet(1, 0, 1.0);
        assert!(matches!(
            lu.setup(&t.to_csr()),
            Err(NonlinearError::SingularJacobian { .. })
        ));
        let rect = sprs::CsMat::<f64>::zero((2, 3));
        assert!(lu.setup(&rect).is_err());
    }
}
