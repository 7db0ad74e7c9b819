#![doc = include_str!("../README.md")]
//!
//! # The pieces
//!
//! - [`NonlinearSystem`]: `dim()`, `residual(y, g)` (writes `G(y)`),
//!   `jacobian(y, &mut J)` (refills the Jacobian storage in place) and,
//!   optionally, `approximate_jacobian` (the tutorial's eq. 50 for cloth).
//! - [`LinearSolver`] for the correction `J s = -G`: [`PcgSolver`] (PCG with
//!   any hookean-sparse preconditioner, optionally filtered by
//!   [`Constraints`](hookean_sparse::Constraints); for SPD Jacobians such as
//!   the cloth matrix, a [`SymBlockMatrix`](hookean_sparse::SymBlockMatrix)),
//!   [`GmresSolver`] (restarted GMRES of hookean-sparse, on the stored
//!   Jacobian or matrix-free, for nonsymmetric systems), [`DenseLu`]
//!   (`faer::Mat<f64>`, small general systems) and [`SparseLu`]
//!   (`sprs::CsMat<f64>`, general sparse). Each reports its iterations.
//! - [`Newton`]: a reusable solver holding the options ([`NewtonOptions`],
//!   the variant in [`NewtonMethod`], the forcing term in [`ForcingTerm`]),
//!   the Jacobian storage, the linear solver and the work vectors;
//!   [`Newton::solve`] returns [`NewtonStats`] or a [`NonlinearError`] that
//!   carries the statistics so far.
//!
//! # Convergence and failure
//!
//! The iteration stops successfully when `|G(Y_k)| <= atol + rtol |G(Y_0)|`
//! or, if [`NewtonOptions::step_tol`] is positive, when the Hairer-Wanner
//! estimate `|s_k| theta_k / (1 - theta_k)` of the remaining error is below
//! it (`theta_k = |s_k| / |s_{k-1}|`). It fails with
//! [`NonlinearError::Diverged`] (theta >= 1 twice in a row, or `|G|` grew by
//! [`NewtonOptions::max_residual_growth`]), [`NonlinearError::MaxIterations`],
//! [`NonlinearError::NonFinite`] or [`NonlinearError::LinearNotConverged`];
//! [`NonlinearError::is_step_failure`] tells an integrator to retry with a
//! smaller step.
//!
//! # Using it from an implicit integrator
//!
//! For a second-order problem `M x'' = f(x, v)`, one implicit Euler step in
//! the reduced velocity form solves
//! `G(dv) = M dv - h f(x + h (v + dv), v + dv) = 0` with the SPD Jacobian
//! `M - h df/dv - h^2 df/dx`: implement [`NonlinearSystem`] with
//! `type Jacobian = SymBlockMatrix`, build one
//! `Newton<SymBlockMatrix, PcgSolver<BlockJacobi>>` (the Jacobian storage on
//! the problem's pattern) and call [`Newton::solve`] every step, starting
//! from `dv = 0` or an extrapolation. For the tutorial's choice use
//! `NewtonMethod::Inexact(ForcingTerm::TUTORIAL)` (`eta = 0.02`). With the
//! simplified variants the Jacobian is kept across calls: call
//! [`Newton::invalidate_jacobian`] whenever `h` or the material changes.
//! Pinned particles: give the [`PcgSolver`] constraints with zero values and
//! return the filtered residual `P G`. For the tutorial's linearised
//! Jacobian (eq. 50) either return it from
//! [`NonlinearSystem::approximate_jacobian`] in the same `SymBlockMatrix`
//! storage, or make it the Jacobian of a wrapper system with
//! `type Jacobian =` [`IsoBlockMatrix`](hookean_sparse::IsoBlockMatrix) (one scalar per block: a third of the
//! nonzeros and of the bytes a CG iteration moves) and use
//! `PcgSolver<BlockJacobi>` on it.
//!
//! # Choosing a variant
//!
//! | method | Jacobian | linear solve | convergence | use |
//! |---|---|---|---|---|
//! | `Exact` | every iterate | to `linear_rtol` | quadratic | reference, small systems with LU |
//! | `Inexact(Constant(eta))` | every iterate | to `eta \|G\|` | linear, rate ~`eta` | cloth with PCG (`eta = 0.02`) |
//! | `Inexact(EisenstatWalker1/2)` | every iterate | adaptive `eta_k` | superlinear | close starting points |
//! | `Simplified` | kept (refreshed on slow contraction) | to `linear_rtol` | linear | costly Jacobians, LU |
//! | `InexactSimplified(f)` | approximation, kept across calls | forcing term | linear | eq. (50), loose accuracy |
//!
//! Measured on the reference drape (docs/perf/hookean-nonlinear.md):
//! inexact Newton with `eta = 0.02` needs 5-6x fewer CG iterations than
//! exact Newton for the same residual.
//!
//! # Example: a small system with a dense LU
//!
//! ```
//! use hookean_nonlinear::*;
//!
//! /// Implicit Euler for the scalar ODE y' = -y^3 from y0 = 1 with h = 0.5:
//! /// G(Y) = Y + h Y^3 - y0.
//! struct EulerStep { h: f64, y0: f64 }
//! impl NonlinearSystem for EulerStep {
//!     type Jacobian = faer::Mat<f64>;
//!     fn dim(&self) -> usize { 1 }
//!     fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
//!         g[0] = y[0] + self.h * y[0].powi(3) - self.y0;
//!         Ok(())
//!     }
//!     fn jacobian(&mut self, y: &[f64], j: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
//!         j[(0, 0)] = 1.0 + 3.0 * self.h * y[0] * y[0];
//!         Ok(())
//!     }
//! }
//!
//! let mut newton = Newton::new(NewtonOptions::default(), faer::Mat::zeros(1, 1), DenseLu::new())?;
//! let mut y = [1.0]; // start from y0
//! let stats = newton.solve(&mut EulerStep { h: 0.5, y0: 1.0 }, &mut y)?;
//! // The real root of Y^3 / 2 + Y - 1 = 0 by Cardano: Y = cbrt(1 + sqrt(1 + 8/27)) + cbrt(1 - sqrt(1 + 8/27)).
//! let d = (1.0f64 + 8.0 / 27.0).sqrt();
//! let exact = (1.0 + d).cbrt() + (1.0 - d).cbrt();
//! assert!((y[0] - exact).abs() < 1e-12);
//! assert!(stats.iterations <= 5 && stats.converged());
//! # Ok::<(), NonlinearError>(())
//! ```
//!
//! # Options structs
//!
//! [`NewtonOptions`] and [`PcgOptions`] have a `Default`:
//! construct them with `..Default::default()`. Each has a hidden field, so
//! that a later version may add an option without breaking your code; a
//! literal naming every field does not compile outside this crate.
//!
//! ```
//! use hookean_nonlinear::{NewtonOptions, PcgOptions, PrecondKind};
//! let newton = NewtonOptions { rtol: 1e-8, max_iter: 20, ..Default::default() };
//! let pcg = PcgOptions { preconditioner: PrecondKind::Jacobi.into(), ..Default::default() };
//! assert_eq!((newton.rtol, newton.max_iter), (1e-8, 20));
//! assert_eq!(pcg.max_iter, PcgOptions::default().max_iter);
//! ```
//!
//! ```compile_fail
//! use hookean_nonlinear::{PcgOptions, PrecondKind, NegativeCurvature};
//! // Every field named, none left to the default: refused outside the crate.
//! let pcg = PcgOptions {
//!     preconditioner: PrecondKind::Jacobi.into(),
//!     max_iter: None,
//!     negative_curvature: NegativeCurvature::Error,
//! };
//! ```

// `!(x > 0.0)` is deliberate: it also rejects NaN parameters.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

hookean_sparse::non_exhaustive_seal!();

mod convergence;
mod error;
mod forcing;
mod linear;
mod newton;
mod options;
mod stats;
mod system;

pub use convergence::{Convergence, weighted_rms};
pub use error::{DivergenceReason, NonlinearError};
pub use forcing::ForcingTerm;
pub use hookean_sparse::{NegativeCurvature, PrecondKind, PreconditionerOptions};
pub use linear::{
    DenseLu, GmresCounters, GmresSolver, JacobianProduct, LinearSolveStats, LinearSolver,
    PcgOptions, PcgSolver, RecordedSolve, SharedRecorder, SolveRecorder, SparseLu,
};
pub use newton::Newton;
pub use options::{NewtonMethod, NewtonOptions};
pub use stats::{ConvergedBy, NewtonStats};
pub use system::NonlinearSystem;
