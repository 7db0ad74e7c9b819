#![doc = include_str!("../README.md")]
//!
//! # The crate's map
//!
//! - [`FirstOrderProblem`]: `y' = f(t, y)` (the tutorial's eq. 7), with an
//!   optional dense or sparse Jacobian.
//! - [`SecondOrderProblem`]: `M x'' = f(t, x, v)` with a lumped mass, 3x3
//!   block Jacobians `df/dx`, `df/dv` on a pattern built once, and the
//!   per-step velocity constraints (pins, contacts).
//!
//! Vectors are flat `f64` slices; for particle systems three entries per
//! particle, xyz interleaved (docs/ARCHITECTURE.md).
//!
//! ```
//! use hookean_problem::FirstOrderProblem;
//!
//! /// Dahlquist's equation y' = lambda y (the tutorial's eq. 20).
//! struct Dahlquist(f64);
//! impl FirstOrderProblem for Dahlquist {
//!     fn dim(&self) -> usize { 1 }
//!     fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) { dy[0] = self.0 * y[0]; }
//! }
//!
//! let mut dy = [0.0];
//! Dahlquist(-15.0).rhs(0.0, &[2.0], &mut dy);
//! assert_eq!(dy[0], -30.0);
//! ```

use std::sync::Arc;

/// `hookean-sparse`, whose matrices this API speaks ([`SymBlockMatrix`],
/// [`Constraints`]), and `sprs` (the sparse Jacobian of
/// [`FirstOrderProblem::jacobian_sparse`]): use these re-exports to get the
/// same versions.
pub use hookean_sparse::{self, sprs};

use hookean_sparse::{BlockPattern, Constraints, IsoBlockMatrix, SparseError, SymBlockMatrix};

/// A first-order system `y' = f(t, y)` (the tutorial's eq. 7).
pub trait FirstOrderProblem {
    /// Dimension of `y`.
    fn dim(&self) -> usize;

    /// Writes `f(t, y)` into `dy`.
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]);

    /// The optional dense Jacobian `df/dy` at `(t, y)`: writes it row-major
    /// into `jac` (`dim x dim`, `jac[i * dim + j] = df_i/dy_j`) and returns
    /// `true`, or returns `false` (the default) if the problem has none, in
    /// which case implicit methods use forward differences (`dim` extra
    /// evaluations of `f` per Jacobian, counted in the statistics).
    fn jacobian(&self, _t: f64, _y: &[f64], _jac: &mut [f64]) -> bool {
        false
    }

    /// The optional sparsity pattern of `df/dy` (`dim x dim`, CSR or CSC,
    /// values ignored; it must contain the diagonal). When it is `Some`,
    /// implicit methods factor the sparse Newton matrix `I - c h df/dy` with
    /// a sparse LU (the symbolic analysis is kept between steps) and take
    /// the values from [`jacobian_sparse`](Self::jacobian_sparse) instead of
    /// [`jacobian`](Self::jacobian). Default `None`. Called once.
    fn sparse_jacobian_pattern(&self) -> Option<sprs::CsMat<f64>> {
        None
    }

    /// Refills the values of `jac` (the pattern of
    /// [`sparse_jacobian_pattern`](Self::sparse_jacobian_pattern), which must
    /// not change) with `df/dy` at `(t, y)` and returns `true`. The default
    /// returns `false`, which is an error when a pattern was given.
    fn jacobian_sparse(&self, _t: f64, _y: &[f64], _jac: &mut sprs::CsMat<f64>) -> bool {
        false
    }
}

/// A second-order system `M x'' = f(t, x, v)` with a lumped (diagonal) mass
/// matrix `M` (the filtering paper's eq. 1; the tutorial's setting (5)/(6)).
///
/// The force Jacobians `df/dx` and `df/dv` are symmetric 3x3 block matrices
/// on one sparsity pattern ([`jacobian_pattern`](Self::jacobian_pattern)),
/// built once per topology; [`force_jacobians`](Self::force_jacobians)
/// refills them in place. Implicit integrators solve the reduced velocity
/// form `(M - c h df/dv - (c h)^2 df/dx) dv = ...` with PCG, filtered by the
/// [`Constraints`] that [`begin_step`](Self::begin_step) sets.
pub trait SecondOrderProblem {
    /// Number of scalar degrees of freedom (`3 x` particles).
    fn dim(&self) -> usize;

    /// The diagonal of the lumped mass matrix `M` (length [`dim`](Self::dim)).
    fn mass(&self) -> &[f64];

    /// Writes the force `f(t, x, v)` into `f`. Never allocates.
    fn force(&self, t: f64, x: &[f64], v: &[f64], f: &mut [f64]);

    /// The sparsity pattern of `df/dx` and `df/dv` (shared, built once).
    fn jacobian_pattern(&self) -> Arc<BlockPattern>;

    /// Refills `df/dx` and `df/dv` at `(t, x, v)`. Both matrices have the
    /// pattern of [`jacobian_pattern`](Self::jacobian_pattern). Never allocates.
    fn force_jacobians(
        &self,
        t: f64,
        x: &[f64],
        v: &[f64],
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
    );

    /// The Newton matrix of the implicit methods' reduced velocity form,
    /// `A = M + a df/dx + b df/dv` at `(t, x, v)` (implicit Euler and the
    /// stages of the other implicit methods: `a = -gh^2`, `b = -gh`), into
    /// `out`, on the pattern of [`jacobian_pattern`](Self::jacobian_pattern).
    ///
    /// The default refills `dfdx` and `dfdv` by
    /// [`force_jacobians`](Self::force_jacobians) and combines them
    /// ([`SymBlockMatrix::assign_diagonal_plus_combination`]); a model may
    /// instead assemble `A` in one sweep straight into `out`, leaving `dfdx`
    /// and `dfdv` as they are (equal to round-off: the terms are summed in
    /// another order). Never allocates.
    ///
    /// # Errors
    /// [`SparseError`] if `out`, `dfdx` or `dfdv` is not on the pattern.
    #[allow(clippy::too_many_arguments)]
    fn step_matrix(
        &self,
        t: f64,
        x: &[f64],
        v: &[f64],
        a: f64,
        b: f64,
        dfdx: &mut SymBlockMatrix,
        dfdv: &mut SymBlockMatrix,
        out: &mut SymBlockMatrix,
    ) -> Result<(), SparseError> {
        self.force_jacobians(t, x, v, dfdx, dfdv);
        out.assign_diagonal_plus_combination(self.mass(), a, dfdx, b, dfdv)
    }

    /// The tutorial's constant linearised Jacobians (eq. 50), for simplified
    /// Newton: writes them and returns `true`, or returns `false` if the
    /// model has none. They change only when the material changes.
    fn linearized_jacobians(&self, _dfdx: &mut SymBlockMatrix, _dfdv: &mut SymBlockMatrix) -> bool {
        false
    }

    /// The same linearised Jacobians in isotropic storage (one scalar per
    /// 3x3 block, a third of the nonzeros): `K = df_lin/dx` and `D =
    /// df_lin/dv` of the linear force `f_lin(x, v) = K x + D v` of eq. 50,
    /// without the permanent constraints (integrators filter them). Writes
    /// them and returns `true`, or returns `false` (the default) if the
    /// problem has none. Read by inexact simplified Newton (Algorithm 3)
    /// and by the IMEX scheme of Eberhardt, Etzmuss and Hauth (2000), which
    /// integrates `f_lin` implicitly and `f - f_lin` explicitly; both keep
    /// what they build from them until the step size or
    /// [`material_revision`](Self::material_revision) changes.
    fn linearized_jacobians_iso(
        &self,
        _dfdx: &mut IsoBlockMatrix,
        _dfdv: &mut IsoBlockMatrix,
    ) -> bool {
        false
    }

    /// Whether the linearised Jacobians are near enough to the true ones to
    /// be simplified Newton's matrix (eq. 50, Algorithm 3). `false` where a
    /// stiff part of `f` depends on the state in a way `f_lin` leaves out
    /// (a mass-spring model's wind drag, whose `df/dv` turns with each
    /// triangle): inexact simplified Newton then keeps the true Jacobian of
    /// the step's start instead, while IMEX, which integrates `f - f_lin`
    /// explicitly, still uses `f_lin`. Default `true`.
    fn linearization_is_newton_matrix(&self) -> bool {
        true
    }

    /// A counter that changes whenever the linearised Jacobians change
    /// (material, damping model, permanent constraints). Default 0 (never).
    fn material_revision(&self) -> u64 {
        0
    }

    /// Called by integrators before every step (and again before a retried
    /// step): the model may project `x` and `v` back onto admissible states
    /// (collisions) and must fill `constraints` with the velocity constraints
    /// of the step (pinned and colliding particles; cleared beforehand).
    /// The default does nothing.
    fn begin_step(
        &mut self,
        _t: f64,
        _x: &mut [f64],
        _v: &mut [f64],
        _constraints: &mut Constraints,
    ) {
    }

    /// Called by integrators after every accepted step from `t` to `t + h`
    /// (after its retries, if any): `x_start` holds the positions the step
    /// started from (after [`begin_step`](Self::begin_step)), `x` and `v`
    /// the new state, which the model may correct (continuous collision
    /// handling: a state whose straight path from `x_start` crosses a
    /// surface). Returns `true` if it changed `x` or `v`, so that the
    /// integrator drops what it derived from the uncorrected state
    /// (multistep history, cached forces). The default does nothing.
    fn end_step(
        &mut self,
        _t: f64,
        _h: f64,
        _x_start: &[f64],
        _x: &mut [f64],
        _v: &mut [f64],
    ) -> bool {
        false
    }
}
