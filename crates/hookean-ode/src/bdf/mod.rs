//! The BDF family: the fixed-step BDF(k) and variable-step BDF2 coefficients
//! of the tutorial (`fixed.rs`, run by the integrators' core), and the
//! variable-order (1 to 5), variable-step BDF/NDF for stiff problems
//! ([`Method::VariableBdf`](crate::Method::VariableBdf)) in the
//! quasi-constant-step form of Shampine and Reichelt ("The MATLAB ODE
//! Suite", SIAM J. Sci. Comput. 18, 1997), which is also the form of SciPy's
//! `BDF`; its Newton iteration, Jacobian and Newton-matrix re-use and
//! statistics follow CVODE (Hindmarsh et al., "SUNDIALS", ACM TOMS 31,
//! 2005; the CVODE user guide, "Mathematical considerations").
//!
//! **The method** (`history.rs`). The solution history is kept as the
//! modified divided differences `D_0 = y_n`, `D_j = nabla^j y_n` of the last
//! `k + 1` points on an equidistant grid of spacing `h` (the last step
//! size). A change of step size by `rho` re-interpolates the history onto
//! the new grid, `D <- (R(rho) U)^T D` (Shampine-Reichelt, section 2.3), so
//! that every step is a constant-step formula. The order-`k` formula, as an
//! NDF (numerical differentiation formula, `kappa_k != 0`, the default) or
//! the classical BDF (`kappa = 0`), is
//! `(1 - kappa_k) gamma_k (y_{n+1} - y^(0)) + sum_{j=1..k} gamma_j nabla^j y_n = h f(t_{n+1}, y_{n+1})`
//! with `gamma_j = sum_{i=1..j} 1/i` and the predictor `y^(0) = sum_{j=0..k} D_j`.
//! With `alpha_k = (1 - kappa_k) gamma_k`, `c = h / alpha_k` and
//! `psi = y^(0) - sum_j gamma_j D_j / alpha_k`, the new point is the stage
//! `K = psi + c f(t_{n+1}, K)` that the implicit methods of the
//! integrators solve too.
//!
//! **The corrector** (`corrector.rs`, `first_order.rs`, `second_order.rs`)
//! is solved by `hookean-nonlinear`'s simplified Newton with CVODE's
//! rate-based test ([`Convergence::Rate`](hookean_nonlinear::Convergence::Rate)):
//! on `I - c J` for first-order problems (dense or sparse LU, or matrix-free
//! GMRES, [`BdfLinearSolver`]), and for second-order problems
//! `M x'' = f(t, x, v)` on the reduced velocity form with the sparse SPD
//! matrix `M - c df/dv - c^2 df/dx` and PCG, so that a cloth runs with
//! error control.
//!
//! **Error control and Newton in one norm.** Both use the weighted RMS norm
//! `||v|| = sqrt(1/n sum (v_i / w_i)^2)` with `w_i = atol_i + rtol |y_i|`
//! (`atol` scalar or per component), where the user's tolerances are first
//! mapped to `rtol^p`, `atol rtol^(p - 1)` with `p = (q+1)/q` for the
//! order limit `q` (1.2 at the default 5; [`BdfConfig::exponent`]) so that
//! the global error, not only the error per step, follows `rtol`. The local error estimate is
//! `(kappa_k gamma_k + 1/(k+1)) (y_{n+1} - y^(0))` and a step is accepted
//! when its norm is `<= 1`. Newton stops when the correction scaled by the
//! estimated contraction rate (CVODE's `crate`, carried across steps while
//! the Newton matrix is kept) is below `tol = max(10 eps / rtol, 0.03)`, a
//! fraction of the error tolerance.
//!
//! **Re-use** (`step.rs`). The Jacobian `J` and the Newton matrix
//! `I - c J` (its LU, or the preconditioner) are kept across steps: the
//! matrix is set up again when `c` changed by more than
//! [`BdfConfig::max_gamma_change`] (30 %) since, after
//! [`BdfConfig::steps_per_factorization`] steps, or when Newton fails; the
//! Jacobian is re-evaluated when Newton fails with a Jacobian from an earlier
//! step, when `c` grew more than 100-fold since it was evaluated (the error
//! `c (J_old - J)` of the Newton matrix grows with `c`; a stale Jacobian
//! can let the simplified Newton iteration stop without solving the
//! corrector), or, optionally, after [`BdfConfig::steps_per_jacobian`]
//! steps. While a kept LU was made with `c_old != c`, the Newton update is
//! scaled by `2 / (1 + c / c_old)` (CVODE's correction for a stale `gamma`).
//!
//! **Order and step size.** After `k + 1` steps of equal size, the errors of
//! orders `k - 1`, `k`, `k + 1` are estimated from `D_k`, `d` and
//! `d - D_{k+1}`; the order with the largest admissible step is taken
//! (Shampine-Reichelt, section 2.4), the step grows by at most 10; a change
//! of the step by a factor in `(0.9, 1.5)` at the same order is not made
//! (CVODE's hysteresis), so that the kept LU stays valid. The first
//! step is order 1 with Hairer-Wanner's initial step estimate (Hairer,
//! Norsett, Wanner, "Solving ODEs I", section II.4). Steps stay within the
//! bounds of [`StepSizePolicy`](crate::StepSizePolicy).
//!
//! **Output.** The engine implements the stepping contract of every method
//! ([`Integrator`](crate::Integrator)): the bounded step (the history
//! re-interpolated so that a step ends exactly on its bound) and dense
//! output ([`interpolate`](crate::Integrator::interpolate): the
//! interpolating polynomial of the history, of the step's order); `step_to`,
//! `solve_at` and events are the contract's drivers. Its one door is
//! [`Method::VariableBdf`](crate::Method::VariableBdf) of
//! [`FirstOrderIntegrator`](crate::FirstOrderIntegrator) and
//! [`SecondOrderIntegrator`](crate::SecondOrderIntegrator).
//!
//! ```
//! use hookean_ode::{FirstOrderIntegrator, FirstOrderProblem, Integrator, Method, SolverOptions};
//!
//! /// Robertson's chemical kinetics (Hairer-Wanner II, section IV.1).
//! struct Robertson;
//! impl FirstOrderProblem for Robertson {
//!     fn dim(&self) -> usize { 3 }
//!     fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
//!         dy[0] = -0.04 * y[0] + 1e4 * y[1] * y[2];
//!         dy[2] = 3e7 * y[1] * y[1];
//!         dy[1] = -dy[0] - dy[2];
//!     }
//! }
//!
//! let opts = SolverOptions::with_tolerances(1e-6, vec![1e-8, 1e-12, 1e-8]);
//! let mut solver =
//!     FirstOrderIntegrator::new(Robertson, Method::variable_bdf(), 0.0, &[1.0, 0.0, 0.0], opts)?;
//! let sol = solver.solve_at(&[0.4, 40.0])?;
//! // Hairer-Wanner's reference value y_1(40) = 0.7158270687...
//! assert!((sol.y(1)[0] - 0.7158270687).abs() < 1e-5);
//! assert!(sol.stats.num_lin_solv_setups < sol.stats.num_steps);
//! # Ok::<(), hookean_ode::OdeError>(())
//! ```

mod checkpoint;
mod corrector;
mod engine;
pub(crate) mod first_order;
mod fixed;
mod history;
pub(crate) mod second_order;
mod step;

pub use crate::bdf_config::{BdfConfig, BdfLinearSolver, Formula, MAX_ORDER, TOLERANCE_EXPONENT};
pub(crate) use corrector::Corrector;
pub(crate) use engine::Bdf;
pub use fixed::{BdfCoefficients, variable_bdf2, variable_bdf2_error_constant};
