//! [`GmresSolver`]: hookean-sparse's restarted GMRES as Newton's linear
//! solver for nonsymmetric Jacobians, on the stored matrix or matrix-free.

use std::cell::{Cell, RefCell};

use hookean_sparse::{
    AnyPreconditioner, GmresParams, GmresWorkspace, LinearOperator, PrecondKind, Preconditioner,
    PreconditionerOptions, PreconditionerSetup, gmres,
};

use super::{JacobianProduct, LinearSolveStats, LinearSolver};
use crate::error::{NonlinearError, check_len, invalid};

/// What a [`GmresSolver`] did since it was built, named after CVODE's
/// counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct GmresCounters {
    /// Products with the Jacobian (`CVodeGetNumLinIters` counts the Krylov
    /// iterations, one product each, plus one per restart).
    pub products: usize,
    /// Preconditioner set-ups (`CVodeGetNumPrecEvals`).
    pub preconditioner_setups: usize,
    /// Preconditioner applications (`CVodeGetNumPrecSolves`).
    pub preconditioner_solves: usize,
    /// Solves that missed their tolerance (`CVodeGetNumLinConvFails`).
    pub convergence_failures: usize,
}

/// Restarted, right-preconditioned GMRES ([`hookean_sparse::gmres`]) for
/// the Newton correction `J s = -G` of a general (nonsymmetric) system, such
/// as the Newton matrix `I - c df/dy` of a stiff first-order problem.
///
/// - **Products.** On the stored Jacobian (a `sprs::CsMat<f64>`), or, when
///   built [`matrix_free`](Self::matrix_free), through the system's
///   [`jacobian_product`](crate::NonlinearSystem::jacobian_product) at the
///   current iterate (then the stored matrix only serves the
///   preconditioner, and may be empty without one).
/// - **Preconditioner.** A hookean-sparse preconditioner of the kind given,
///   set up on the stored matrix at every [`setup`](LinearSolver::setup)
///   ([`PrecondKind::None`]: no set-up, no stored matrix needed).
/// - **Scaling.** With [`set_weights`](Self::set_weights) the solve runs on
///   `S J S^-1 (S x) = S rhs`, `S = diag(1 / w)` (CVODE's scaled SPGMR), so
///   that its 2-norm is `sqrt(n)` times the weighted RMS norm of an ODE
///   solver's tests.
/// - **Tolerance.** `|S (rhs - J x)| <= max(rtol |S rhs|, atol)` with
///   Newton's `rtol` and [`GmresParams::atol`]. A solve that reduced the
///   residual but missed the tolerance is still returned as done (CVODE's
///   rule for its Krylov solvers: the Newton iteration judges the
///   correction) and counted in [`GmresCounters::convergence_failures`].
#[derive(Debug)]
pub struct GmresSolver {
    params: GmresParams,
    precond: AnyPreconditioner,
    preconditioned: bool,
    matrix_free: bool,
    workspace: GmresWorkspace,
    weights: Vec<f64>,
    /// The scaled right-hand side and solution, and the preconditioner's scratch.
    b: Vec<f64>,
    xs: Vec<f64>,
    /// `S^-1 u` of a product, and the preconditioner's `S^-1 u`.
    v: RefCell<Vec<f64>>,
    scratch: RefCell<Vec<f64>>,
    counters: GmresCounters,
    ready: bool,
}

impl GmresSolver {
    /// GMRES with `params` (its `rtol` is replaced by Newton's at each
    /// solve) and the preconditioner `preconditioner` names, multiplying by
    /// the stored Jacobian.
    ///
    /// # Errors
    /// [`NonlinearError::InvalidParameter`] for `krylov_dim = 0` or a
    /// negative `atol`; [`NonlinearError::Linear`] for a bad preconditioner
    /// parameter.
    pub fn new(
        params: GmresParams,
        preconditioner: &PreconditionerOptions,
    ) -> Result<Self, NonlinearError> {
        if params.krylov_dim == 0 {
            return Err(invalid("krylov_dim", "must be at least 1"));
        }
        if !(params.atol >= 0.0) {
            return Err(invalid(
                "atol",
                format!("must be >= 0, got {:?}", params.atol),
            ));
        }
        Ok(Self {
            workspace: GmresWorkspace::new(0, params.krylov_dim),
            params,
            precond: AnyPreconditioner::from_options(preconditioner)?,
            preconditioned: preconditioner.kind != PrecondKind::None,
            matrix_free: false,
            weights: Vec::new(),
            b: Vec::new(),
            xs: Vec::new(),
            v: RefCell::new(Vec::new()),
            scratch: RefCell::new(Vec::new()),
            counters: GmresCounters::default(),
            ready: false,
        })
    }

    /// Multiplies through the system's Jacobian products instead of the
    /// stored matrix (see the type's docs).
    pub fn matrix_free(mut self) -> Self {
        self.matrix_free = true;
        self
    }

    /// Scales the next solves by `S = diag(1 / w)` (positive weights, one per
    /// unknown); an empty slice removes the scaling.
    pub fn set_weights(&mut self, w: &[f64]) {
        self.weights.clear();
        self.weights.extend_from_slice(w);
    }

    /// The counters since the solver was built.
    pub fn counters(&self) -> GmresCounters {
        self.counters
    }

    fn run(
        &mut self,
        stored: &sprs::CsMat<f64>,
        product: Option<&mut JacobianProduct<'_>>,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        if !self.ready {
            return Err(NonlinearError::NotReady(
                "GmresSolver::solve before a successful setup",
            ));
        }
        let n = rhs.len();
        check_len("solution", x, n)?;
        if !self.weights.is_empty() {
            check_len("weights", &self.weights, n)?;
        }
        if product.is_none() {
            check_len("right-hand side", rhs, stored.rows())?;
        }
        self.b.resize(n, 0.0);
        self.xs.resize(n, 0.0);
        self.v.borrow_mut().resize(n, 0.0);
        let w = &self.weights;
        let scale = |i: usize| if w.is_empty() { 1.0 } else { w[i] };
        for (i, (bi, ri)) in self.b.iter_mut().zip(rhs).enumerate() {
            *bi = ri / scale(i);
        }
        let params = GmresParams {
            rtol,
            ..self.params.clone()
        };
        let op = Scaled {
            n,
            weights: w,
            stored,
            product: product.map(RefCell::new),
            v: &self.v,
            error: RefCell::new(None),
            products: Cell::new(0),
        };
        let pre = ScaledPreconditioner {
            weights: w,
            precond: self.preconditioned.then_some(&self.precond),
            scratch: &self.scratch,
        };
        let info = gmres(
            &op,
            &pre,
            &self.b,
            &mut self.xs,
            &params,
            &mut self.workspace,
        );
        if let Some(e) = op.error.into_inner() {
            return Err(e);
        }
        let info = info?;
        for (i, (xi, si)) in x.iter_mut().zip(&self.xs).enumerate() {
            *xi = si * scale(i);
        }
        self.counters.products += op.products.get();
        if self.preconditioned {
            self.counters.preconditioner_solves += info.preconditioner_solves;
        }
        let b_norm = hookean_sparse::vecops::norm2(&self.b);
        if !info.converged {
            self.counters.convergence_failures += 1;
        }
        Ok(LinearSolveStats {
            iterations: info.iterations,
            residual_norm: info.residual_norm,
            relative_residual: info.relative_residual,
            converged: info.converged || info.residual_norm < b_norm,
            truncated: false,
        })
    }
}

impl LinearSolver<sprs::CsMat<f64>> for GmresSolver {
    fn setup(&mut self, jac: &sprs::CsMat<f64>) -> Result<(), NonlinearError> {
        self.ready = false;
        if self.preconditioned {
            self.counters.preconditioner_setups += 1;
            self.precond.setup(jac)?;
            self.scratch.borrow_mut().resize(jac.rows(), 0.0);
        }
        self.ready = true;
        Ok(())
    }

    fn solve(
        &mut self,
        jac: &sprs::CsMat<f64>,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        self.run(jac, None, rhs, x, rtol)
    }

    fn solve_with_product(
        &mut self,
        jac: &sprs::CsMat<f64>,
        product: &mut JacobianProduct<'_>,
        rhs: &[f64],
        x: &mut [f64],
        rtol: f64,
    ) -> Result<LinearSolveStats, NonlinearError> {
        self.run(jac, Some(product), rhs, x, rtol)
    }

    fn is_matrix_free(&self) -> bool {
        self.matrix_free
    }
}

/// `u -> S J S^-1 u`: the stored matrix or the system's product, on the
/// scaled unknowns; the first error of a product is kept for the caller.
struct Scaled<'a, 'p> {
    n: usize,
    weights: &'a [f64],
    stored: &'a sprs::CsMat<f64>,
    product: Option<RefCell<&'a mut JacobianProduct<'p>>>,
    /// `S^-1 u`.
    v: &'a RefCell<Vec<f64>>,
    error: RefCell<Option<NonlinearError>>,
    products: Cell<usize>,
}

impl LinearOperator for Scaled<'_, '_> {
    fn nrows(&self) -> usize {
        self.n
    }

    fn apply(&self, u: &[f64], out: &mut [f64]) {
        let mut v = self.v.borrow_mut();
        if self.weights.is_empty() {
            v.copy_from_slice(u);
        } else {
            for ((vi, ui), wi) in v.iter_mut().zip(u).zip(self.weights) {
                *vi = ui * wi;
            }
        }
        match &self.product {
            Some(p) => {
                self.products.set(self.products.get() + 1);
                if let Err(e) = (p.borrow_mut())(&v, out) {
                    out.fill(0.0);
                    self.error.borrow_mut().get_or_insert(e);
                }
            }
            None => self.stored.apply(&v, out),
        }
        if !self.weights.is_empty() {
            for (o, wi) in out.iter_mut().zip(self.weights) {
                *o /= wi;
            }
        }
    }
}

/// `u -> S M^-1 S^-1 u`, or the identity without a preconditioner.
struct ScaledPreconditioner<'a> {
    weights: &'a [f64],
    precond: Option<&'a AnyPreconditioner>,
    scratch: &'a RefCell<Vec<f64>>,
}

impl Preconditioner for ScaledPreconditioner<'_> {
    fn dim(&self) -> Option<usize> {
        None
    }

    fn apply(&self, u: &[f64], z: &mut [f64]) {
        let Some(p) = self.precond else {
            z.copy_from_slice(u);
            return;
        };
        if self.weights.is_empty() {
            p.apply(u, z);
            return;
        }
        let mut s = self.scratch.borrow_mut();
        for ((si, ui), wi) in s.iter_mut().zip(u).zip(self.weights) {
            *si = ui * wi;
        }
        p.apply(&s, z);
        for (zi, wi) in z.iter_mut().zip(self.weights) {
            *zi /= wi;
        }
    }
}
