//! [`FirstOrderForm`]: a second-order problem as the first-order system (6).

use std::cell::RefCell;

use hookean_problem::{FirstOrderProblem, SecondOrderProblem};
use hookean_sparse::SymBlockMatrix;

/// A second-order problem `M x'' = f(t, x, v)` seen as the first-order
/// system (6) of size `2 dim`: `y = [x; v]`, `y' = [v; M^{-1} f]`, with the
/// dense Jacobian `[[0, I], [M^{-1} df/dx, M^{-1} df/dv]]`. For comparisons
/// and small problems (it allocates in `jacobian`); the integrators,
/// the variable-order BDF included, solve second-order problems in the
/// reduced form on the sparse block matrix instead.
pub struct FirstOrderForm<P> {
    problem: P,
    scratch: RefCell<(SymBlockMatrix, SymBlockMatrix, Vec<f64>)>,
}

impl<P: SecondOrderProblem> FirstOrderForm<P> {
    /// Wraps `problem`.
    pub fn new(problem: P) -> Self {
        let pattern = problem.jacobian_pattern();
        let n = problem.dim();
        Self {
            scratch: RefCell::new((
                SymBlockMatrix::new(pattern.clone()),
                SymBlockMatrix::new(pattern),
                vec![0.0; n],
            )),
            problem,
        }
    }

    /// The wrapped problem.
    pub fn inner(&self) -> &P {
        &self.problem
    }
}

impl<P: SecondOrderProblem> FirstOrderProblem for FirstOrderForm<P> {
    fn dim(&self) -> usize {
        2 * self.problem.dim()
    }

    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
        let n = self.problem.dim();
        let (x, v) = y.split_at(n);
        let (dx, dv) = dy.split_at_mut(n);
        dx.copy_from_slice(v);
        self.problem.force(t, x, v, dv);
        for (a, m) in dv.iter_mut().zip(self.problem.mass()) {
            *a /= m;
        }
    }

    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> bool {
        let n = self.problem.dim();
        let n2 = 2 * n;
        let (x, v) = y.split_at(n);
        let mut s = self.scratch.borrow_mut();
        let (dfdx, dfdv, _) = &mut *s;
        self.problem.force_jacobians(t, x, v, dfdx, dfdv);
        jac.fill(0.0);
        for i in 0..n {
            jac[i * n2 + n + i] = 1.0;
        }
        let mass = self.problem.mass();
        for (mat, off) in [(&*dfdx, 0), (&*dfdv, n)] {
            let csr = mat.to_csr();
            for (&val, (r, c)) in csr.iter() {
                jac[(n + r) * n2 + off + c] += val / mass[r];
            }
        }
        true
    }
}
