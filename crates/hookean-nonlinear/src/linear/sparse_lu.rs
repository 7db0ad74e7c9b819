//! [`SparseLu`]: faer's sparse LU for general sparse Jacobians, refactored
//! and solved in storage it keeps.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::sparse::linalg::LuError;
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu, factorize_symbolic_lu};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par};
use hookean_sparse::{CscCopy, SparseError};

use super::{LinearSolveStats, LinearSolver};
use crate::error::{NonlinearError, check_len, invalid};

/// Sparse LU with partial pivoting (faer, COLAMD ordering) for general
/// sparse Jacobians stored as `sprs::CsMat<f64>` (CSR or CSC).
///
/// The symbolic analysis, the numeric factors' storage, faer's workspace
/// and the column-major copy of the input (hookean-sparse's [`CscCopy`])
/// are kept while the sparsity pattern is unchanged: a setup after a
/// refill redoes only the numeric factorisation, and neither it nor a
/// solve allocates once the factors have grown to their size.
pub struct SparseLu {
    /// The column-major copy `A` factors (hookean-sparse keeps its pattern).
    csc: CscCopy,
    symbolic: Option<SymbolicLu<usize>>,
    numeric: NumericLu<usize, f64>,
    mem: MemBuffer,
    n: usize,
    ready: bool,
}

impl std::fmt::Debug for SparseLu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SparseLu")
            .field("n", &self.n)
            .field("nnz", &self.csc.values().len())
            .field("ready", &self.ready)
            .finish_non_exhaustive()
    }
}

impl Default for SparseLu {
    fn default() -> Self {
        Self::new()
    }
}

impl SparseLu {
    /// An empty solver.
    pub fn new() -> Self {
        Self {
            csc: CscCopy::new(),
            symbolic: None,
            numeric: NumericLu::new(),
            mem: MemBuffer::new(StackReq::EMPTY),
            n: 0,
            ready: false,
        }
    }

    /// Whether a symbolic analysis is cached (it is reused by the next
    /// [`setup`](LinearSolver::setup) if the pattern is unchanged).
    pub fn has_symbolic(&self) -> bool {
        self.symbolic.is_some()
    }

    /// The symbolic analysis of the copy's pattern and the workspace of
    /// the numeric factorisation and of a solve.
    fn analyse(&mut self) -> Result<(), NonlinearError> {
        self.symbolic = None;
        let n = self.csc.shape().0;
        let sym = SymbolicSparseColMatRef::new_checked(
            n,
            n,
            self.csc.col_ptr(),
            None,
            self.csc.row_idx(),
        );
        let symbolic = factorize_symbolic_lu(sym, Default::default()).map_err(|e| {
            invalid(
                "Jacobian",
                format!("sparse LU symbolic analysis failed: {e:?}"),
            )
        })?;
        let req = StackReq::any_of(&[
            symbolic.factorize_numeric_lu_scratch::<f64>(Par::Seq, Default::default()),
            symbolic.solve_in_place_scratch::<f64>(1, Par::Seq),
        ]);
        self.mem = MemBuffer::new(req);
        self.symbolic = Some(symbolic);
        self.n = n;
        Ok(())
    }
}

impl LinearSolver<sprs::CsMat<f64>> for SparseLu {
    fn setup(&mut self, jac: &sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        self.ready = false;
        let (r, c) = jac.shape();
        if r != c {
            return Err(SparseError::NotSquare { rows: r, cols: c }.into());
        }
        let changed = self.csc.update(jac);
        if changed || self.symbolic.is_none() {
            self.analyse()?;
        }
        if let Some(i) = self.csc.values().iter().position(|v| !v.is_finite()) {
            return Err(SparseError::NonFinite {
                what: "Jacobian",
                index: Some(i),
            }
            .into());
        }
        let symbolic = self.symbolic.as_ref().expect("analysed above");
        let sym = SymbolicSparseColMatRef::new_checked(
            r,
            r,
            self.csc.col_ptr(),
            None,
            self.csc.row_idx(),
        );
        symbolic
            .factorize_numeric_lu(
                &mut self.numeric,
                SparseColMatRef::new(sym, self.csc.values()),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| match e {
                LuError::SymbolicSingular { index } => NonlinearError::SingularJacobian {
                    pivot: index,
                    value: 0.0,
                },
                LuError::Generic(g) => invalid("Jacobian", format!("sparse LU failed: {g:?}")),
            })?;
        self.ready = true;
        Ok(())
    }

    fn solve(
        &mut self,
        _jac: &sprs::CsMat<f64>,
        rhs: &[f64],
        x: &mut [f64],
        _rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        let (true, Some(symbolic)) = (self.ready, self.symbolic.as_ref()) else {
            return Err(NonlinearError::NotReady(
                "SparseLu::solve before a successful setup",
            ));
        };
        check_len("right-hand side", rhs, self.n)?;
        check_len("solution", x, self.n)?;
        x.copy_from_slice(rhs);
        // The factors come from `factorize_numeric_lu` with this symbolic
        // analysis (setup), as `new_unchecked` requires.
        LuRef::new_unchecked(symbolic, &self.numeric).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, self.n, 1),
            Par::Seq,
            MemStack::new(&mut self.mem),
        );
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
