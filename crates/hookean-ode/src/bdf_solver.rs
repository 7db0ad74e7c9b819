//! A variable-order (1 to 5), variable-step BDF solver for stiff first-order
//! problems `y' = f(t, y)`, in the quasi-constant-step form of Shampine and
//! Reichelt ("The MATLAB ODE Suite", SIAM J. Sci. Comput. 18, 1997), which
//! is also the form of SciPy's `BDF`; its Newton iteration, Jacobian and LU
//! re-use and statistics follow CVODE (Hindmarsh et al., "SUNDIALS", ACM
//! TOMS 31, 2005; the CVODE user guide, "Mathematical considerations").
//!
//! **The method.** The solution history is kept as the modified divided
//! differences `D_0 = y_n`, `D_j = nabla^j y_n` of the last `k + 1` points on
//! an equidistant grid of spacing `h` (the last step size). A change of step
//! size by `rho` re-interpolates the history onto the new grid,
//! `D <- (R(rho) U)^T D` (Shampine-Reichelt, section 2.3), so that every step
//! is a constant-step formula. The order-`k` formula, as an NDF (numerical
//! differentiation formula, `kappa_k != 0`, the default) or the classical BDF
//! (`kappa = 0`), is
//! `(1 - kappa_k) gamma_k (y_{n+1} - y^(0)) + sum_{j=1..k} gamma_j nabla^j y_n = h f(t_{n+1}, y_{n+1})`
//! with `gamma_j = sum_{i=1..j} 1/i` and the predictor `y^(0) = sum_{j=0..k} D_j`.
//! Writing `y_{n+1} = y^(0) + d`, `alpha_k = (1 - kappa_k) gamma_k`,
//! `c = h / alpha_k` and `psi = sum_j gamma_j D_j / alpha_k`, the corrector is
//! `d = c f(t_{n+1}, y^(0) + d) - psi`, solved by a simplified Newton
//! iteration with the iteration matrix `M = I - c J`.
//!
//! **Error control and Newton in one norm.** Both use the weighted RMS norm
//! `||v|| = sqrt(1/n sum (v_i / w_i)^2)` with `w_i = atol_i + rtol |y_i|`
//! (`atol` scalar or per component), where the user's tolerances are first
//! mapped to `rtol^p`, `atol rtol^(p - 1)` with `p = 1.2`
//! ([`BdfOptions::tolerance_exponent`]) so that the global error, not only
//! the error per step, follows `rtol`. The local error estimate is
//! `(kappa_k gamma_k + 1/(k+1)) d` and a step is accepted when its norm is
//! `<= 1`. Newton stops when the update `delta` of an iteration, scaled by
//! the estimated contraction rate `rho` (CVODE's `crate`, carried across
//! steps while the iteration matrix is kept), meets
//! `rho / (1 - rho) ||delta|| <= tol` (in the first iteration, where no rate
//! is measured yet, only `||delta|| <= tol` counts) with
//! `tol = max(10 eps / rtol, 0.03)`, a fraction of the error tolerance; it fails when `rho >= 1` or when the rate cannot reach
//! `tol` in the remaining iterations. No absolute residual is involved.
//!
//! **Re-use.** The Jacobian `J` and the LU factors of `M = I - c J` are kept
//! across steps: the LU is refactored when `c` changed by more than
//! [`BdfOptions::max_gamma_change`] (30 %) since the factorisation, after
//! [`BdfOptions::steps_per_factorization`] steps, or when Newton fails; the
//! Jacobian is re-evaluated when Newton fails with a Jacobian from an earlier
//! step, when `c` grew more than 100-fold since it was evaluated (the error
//! `c (J_old - J)` of the Newton matrix grows with `c`; a stale Jacobian
//! can let the simplified Newton iteration stop without solving the
//! corrector), or, optionally, after [`BdfOptions::steps_per_jacobian`] steps. While the kept
//! factorisation was made with `c_old != c`, the Newton update is scaled by
//! `2 / (1 + c / c_old)` (CVODE's correction for a stale `gamma`).
//!
//! **Linear solvers** ([`BdfOptions::linear_solver`]): faer's dense LU,
//! faer's sparse LU on the pattern the problem gives, or matrix-free GMRES
//! ([`BdfLinearSolver::Gmres`]) with products `J v` by difference quotients
//! of `f` and, on the problem's sparse pattern, a hookean-sparse
//! preconditioner of `I - c J` kept as the LU would be.
//!
//! **Order and step size.** After `k + 1` steps of equal size, the errors of
//! orders `k - 1`, `k`, `k + 1` are estimated from `D_k`, `d` and
//! `d - D_{k+1}`; the order with the largest admissible step is taken
//! (Shampine-Reichelt, section 2.4), the step grows by at most 10; a change
//! of the step by a factor in `(0.9, 1.5)` at the same order is not made
//! (CVODE's hysteresis), so that the kept LU stays valid. The first
//! step is order 1 with Hairer-Wanner's initial step estimate (Hairer,
//! Norsett, Wanner, "Solving ODEs I", section II.4).
//!
//! **Output.** [`BdfSolver::interpolate`] evaluates the interpolating
//! polynomial of the current history anywhere in the last step (dense
//! output); [`BdfSolver::solve_at`] returns the solution at requested times,
//! stepping past them; [`Events`] locates roots of user functions (with a
//! direction and a terminal flag) on the interpolant.
//!
//! ```
//! use hookean_ode::{BdfOptions, BdfSolver, FirstOrderProblem};
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
//! let opts = BdfOptions { rtol: 1e-6, atol: vec![1e-8, 1e-12, 1e-8].into(), ..BdfOptions::default() };
//! let mut solver = BdfSolver::new(Robertson, 0.0, &[1.0, 0.0, 0.0], opts)?;
//! let sol = solver.solve_at(&[0.4, 40.0])?;
//! // Hairer-Wanner's reference value y_1(40) = 0.7158270687...
//! assert!((sol.y(1)[0] - 0.7158270687).abs() < 1e-5);
//! assert!(sol.stats.num_lin_solv_setups < sol.stats.num_steps);
//! # Ok::<(), hookean_ode::OdeError>(())
//! ```

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::factor::lu_in_place;
use hookean_nonlinear::{LinearSolver, NonlinearError, SparseLu};
use hookean_problem::FirstOrderProblem;
use hookean_sparse::{AnyPreconditioner, PrecondKind, Preconditioner, PreconditionerSetup};

use crate::error::OdeError;
use crate::krylov::Gmres;
use crate::system::{diagonal_positions, forward_difference_jacobian};

/// The highest order of the solver.
pub const MAX_ORDER: usize = 5;

/// The NDF modification `kappa_k` of orders 0..=5 (Shampine-Reichelt,
/// table 1; order 5 is the BDF).
const NDF_KAPPA: [f64; MAX_ORDER + 1] = [0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0];

/// After an accepted step, the step size is kept (and the order is not
/// changed) while the proposed factor lies in this band.
const KEEP_STEP: (f64, f64) = (0.9, 1.5);

/// Step-size change limits after an accepted step, and after a failure.
const MAX_FACTOR: f64 = 10.0;
const MIN_FACTOR: f64 = 0.2;

/// The Newton tolerance as a fraction of the local error tolerance (the
/// error test is `||err|| <= 1` in the same norm). CVODE's test is
/// `0.1 / tq[4]`-scaled, about the same; SciPy uses `min(0.03, sqrt(rtol))`,
/// which at tight tolerances costs Newton failures and Jacobians for no
/// measurable gain in accuracy (docs/PERFORMANCE.md).
const NEWTON_TOL: f64 = 0.03;

/// The default [`BdfOptions::tolerance_exponent`]: the local error test runs
/// at `rtol^1.2`. With error per step `tol`, order `k` takes steps
/// `h ~ tol^(1/(k+1))`, so the global error, the sum of the local errors,
/// grows like `tol^(k/(k+1))`; `tol = rtol^((k+1)/k)` makes it follow
/// `rtol`. The steps of the stiff test set are mostly of order 5: `6/5`.
/// (Measured with exponent 1: the error grows like `rtol^0.84..rtol^1.03`
/// and is 2.6 to 45 times `rtol` at `rtol = 1e-8`; with 1.2 at most 4.9
/// times over 25 tolerances from 1e-4 to 1e-8, E5's reference-limited 12.8
/// apart; docs/PERFORMANCE.md, issue 17.)
pub const TOLERANCE_EXPONENT: f64 = 1.2;

/// The Jacobian is re-evaluated before a step whose `c = h / alpha_k`
/// exceeds this multiple of the `c` at which it was evaluated. The Newton
/// matrix `I - c J` errs by `c (J_old - J)`: a Jacobian kept from a fast
/// transient (a Van der Pol jump, `h ~ 1e-7`) and used at steps 1e6 times
/// longer can make the simplified Newton iteration take tiny updates that
/// pass the convergence test without solving the corrector, and the error
/// estimate, built from those updates, then accepts a wrong solution.
const JACOBIAN_C_GROWTH: f64 = 100.0;

/// A rate beyond which the Newton iteration counts as diverging.
const MAX_RATE: f64 = 1.0;

/// The linear solver of the Newton systems `(I - c J) x = r`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum BdfLinearSolver {
    /// LU factors kept across steps: faer's dense LU, or faer's sparse LU
    /// on the problem's pattern when it gives one
    /// ([`FirstOrderProblem::sparse_jacobian_pattern`]). The default.
    #[default]
    Direct,
    /// Matrix-free GMRES(`krylov_dim`) ([Saad-Schultz 1986]): each product
    /// `J v` is one evaluation of `f`, `(f(y + s v) - f(y)) / s` with
    /// `s = 1 / ||v||` (CVODE's difference-quotient `jtimes`); right
    /// preconditioned by a hookean-sparse preconditioner set up on the
    /// sparse `I - c J` when it is kept (the problem must give its sparse
    /// pattern and values unless `preconditioner` is
    /// [`PrecondKind::None`]); run on the system scaled by the error
    /// weights and stopped at 0.05 of the Newton tolerance (CVODE's
    /// `eplifac`). Newton then uses the current `J` in every product (an
    /// inexact Newton rather than the simplified one).
    Gmres {
        /// Krylov dimension per cycle (CVODE's `maxl`, 5 there).
        krylov_dim: usize,
        /// Restarts after the first cycle (CVODE's `maxrs`, 0 there).
        restarts: usize,
        /// The preconditioner, set up on `I - c J`.
        preconditioner: PrecondKind,
    },
}

impl BdfLinearSolver {
    /// GMRES with Krylov dimension 10, two restarts and `preconditioner`.
    pub fn gmres(preconditioner: PrecondKind) -> Self {
        BdfLinearSolver::Gmres {
            krylov_dim: 10,
            restarts: 2,
            preconditioner,
        }
    }
}

/// GMRES stops at this fraction of the Newton tolerance (CVODE's `eplifac`).
const KRYLOV_TOL_FACTOR: f64 = 0.05;

/// The absolute tolerance: one value for every component or one per component.
#[derive(Debug, Clone, PartialEq)]
pub enum Tolerance {
    /// The same `atol` for every component.
    Scalar(f64),
    /// `atol_i` per component (length `dim`).
    Vector(Vec<f64>),
}

impl From<f64> for Tolerance {
    fn from(v: f64) -> Self {
        Tolerance::Scalar(v)
    }
}

impl From<Vec<f64>> for Tolerance {
    fn from(v: Vec<f64>) -> Self {
        Tolerance::Vector(v)
    }
}

/// The multistep family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Formula {
    /// The numerical differentiation formulas of Klopfenstein and Shampine
    /// (more accurate than the BDF at the same stability for orders 1-4).
    #[default]
    Ndf,
    /// The classical backward differentiation formulas.
    Bdf,
}

/// Options of [`BdfSolver`]. The defaults are meant to serve the whole
/// stiff test set; only the tolerances are problem-dependent.
#[derive(Debug, Clone, PartialEq)]
pub struct BdfOptions {
    /// Relative tolerance. Default `1e-6`.
    pub rtol: f64,
    /// Absolute tolerance (scalar or per component). Default `1e-10`.
    pub atol: Tolerance,
    /// NDF (default) or BDF.
    pub formula: Formula,
    /// Highest order used, 1 to 5. Default 5.
    pub max_order: usize,
    /// Initial step size; `None` (default) for Hairer-Wanner's estimate.
    pub h0: Option<f64>,
    /// Smallest step size: below it the run fails. Default 0 (then the
    /// floor is 10 units in the last place of `t`).
    pub h_min: f64,
    /// Largest step size. Default infinite.
    pub h_max: f64,
    /// The run fails after this many steps. Default 100 000.
    pub max_steps: usize,
    /// Newton iterations per attempt. Default 4.
    pub max_newton_iterations: usize,
    /// Newton failures on one step before the run fails. Default 10 (CVODE's `MXNCF`).
    pub max_convergence_failures: usize,
    /// Error test failures on one step before the run fails. Default 20
    /// (CVODE's `MXNEF` is 7, SciPy has no limit; 7 stopped Van der Pol at
    /// `rtol = 1.5e-4` in its steep transition, where 20 gets through).
    pub max_error_test_failures: usize,
    /// The LU of `I - c J` is refactored when `|c / c_lu - 1|` exceeds this.
    /// Default 0.3 (CVODE's `DGMAX`).
    pub max_gamma_change: f64,
    /// The LU is refactored after this many steps. Default 20 (CVODE's `MSBP`).
    pub steps_per_factorization: usize,
    /// The Jacobian is re-evaluated after this many steps (CVODE's `MSBJ`,
    /// 50 there). Default `None`: only when Newton fails with a Jacobian of
    /// an earlier step (as SciPy does), which needs fewer evaluations on the
    /// test set at the same accuracy.
    pub steps_per_jacobian: Option<usize>,
    /// The run fails once `max_i |y_i|` exceeds
    /// `max_growth * max(1, max_i |y0_i|)` (a blown-up solution). Default
    /// [`DEFAULT_MAX_GROWTH`](crate::options::DEFAULT_MAX_GROWTH).
    pub max_growth: f64,
    /// The local error test runs with the tolerances
    /// `rtol_local = rtol^p` and `atol_local = atol rtol^(p - 1)` for this
    /// exponent `p` (a tolerance-proportional mapping, as RADAU5 maps its
    /// tolerances): with a local error per step of `rtol_local`, the global
    /// error of order `k` grows like `rtol_local^(k/(k+1))` (times the number
    /// of steps), so `p = (k+1)/k` makes the achieved error follow `rtol`
    /// itself. Default [`TOLERANCE_EXPONENT`] (1.2, for order 5; see
    /// docs/PERFORMANCE.md); 1 gives the plain error-per-step
    /// control of SciPy and CVODE.
    pub tolerance_exponent: f64,
    /// The linear solver of the Newton systems. Default [`BdfLinearSolver::Direct`].
    pub linear_solver: BdfLinearSolver,
}

impl Default for BdfOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: Tolerance::Scalar(1e-10),
            formula: Formula::Ndf,
            max_order: MAX_ORDER,
            h0: None,
            h_min: 0.0,
            h_max: f64::INFINITY,
            max_steps: 100_000,
            max_newton_iterations: 4,
            max_convergence_failures: 10,
            max_error_test_failures: 20,
            max_gamma_change: 0.3,
            steps_per_factorization: 20,
            steps_per_jacobian: None,
            max_growth: crate::options::DEFAULT_MAX_GROWTH,
            tolerance_exponent: TOLERANCE_EXPONENT,
            linear_solver: BdfLinearSolver::Direct,
        }
    }
}

/// Counters of a [`BdfSolver`] run, named after CVODE's `CVodeGetNum*`
/// functions (cumulative since the solver was built).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BdfStats {
    /// Accepted steps (`CVodeGetNumSteps`).
    pub num_steps: usize,
    /// Evaluations of `f` by the integrator, not counting those for
    /// difference-quotient Jacobians (`CVodeGetNumRhsEvals`).
    pub num_rhs_evals: usize,
    /// Evaluations of `f` for difference-quotient Jacobians (`CVodeGetNumLinRhsEvals`).
    pub num_lin_rhs_evals: usize,
    /// Jacobian evaluations, analytic or by differences (`CVodeGetNumJacEvals`).
    pub num_jac_evals: usize,
    /// LU factorisations of the iteration matrix `I - c J` (`CVodeGetNumLinSolvSetups`).
    pub num_lin_solv_setups: usize,
    /// Newton iterations (`CVodeGetNumNonlinSolvIters`).
    pub num_nonlin_solv_iters: usize,
    /// Newton convergence failures (`CVodeGetNumNonlinSolvConvFails`).
    pub num_nonlin_solv_conv_fails: usize,
    /// Local error test failures (`CVodeGetNumErrTestFails`).
    pub num_err_test_fails: usize,
    /// Evaluations of the event functions (`CVodeGetNumGEvals`).
    pub num_g_evals: usize,
    /// The order of the last step (`CVodeGetLastOrder`).
    pub last_order: usize,
    /// The size of the last step (`CVodeGetLastStep`).
    pub last_step: f64,
    /// Krylov iterations of [`BdfLinearSolver::Gmres`] (`CVodeGetNumLinIters`).
    pub num_lin_iters: usize,
    /// GMRES solves that stopped short of their tolerance (`CVodeGetNumLinConvFails`).
    pub num_lin_conv_fails: usize,
    /// Jacobian-vector products by difference quotients (`CVodeGetNumJtimesEvals`).
    pub num_jtimes_evals: usize,
    /// Preconditioner set-ups (`CVodeGetNumPrecEvals`).
    pub num_prec_evals: usize,
    /// Preconditioner applications (`CVodeGetNumPrecSolves`).
    pub num_prec_solves: usize,
}

/// The fixed coefficients of order `k = 0..=5`: `gamma_k`, `alpha_k` and the
/// error constant `kappa_k gamma_k + 1 / (k + 1)`.
#[derive(Debug, Clone)]
struct Coefficients {
    gamma: [f64; MAX_ORDER + 1],
    alpha: [f64; MAX_ORDER + 1],
    error_const: [f64; MAX_ORDER + 2],
}

impl Coefficients {
    fn new(formula: Formula) -> Self {
        let kappa = match formula {
            Formula::Ndf => NDF_KAPPA,
            Formula::Bdf => [0.0; MAX_ORDER + 1],
        };
        let mut gamma = [0.0; MAX_ORDER + 1];
        for k in 1..=MAX_ORDER {
            gamma[k] = gamma[k - 1] + 1.0 / k as f64;
        }
        let mut alpha = [0.0; MAX_ORDER + 1];
        let mut error_const = [0.0; MAX_ORDER + 2];
        for k in 0..=MAX_ORDER {
            alpha[k] = (1.0 - kappa[k]) * gamma[k];
            error_const[k] = kappa[k] * gamma[k] + 1.0 / (k + 1) as f64;
        }
        error_const[MAX_ORDER + 1] = 1.0 / (MAX_ORDER + 2) as f64;
        Self {
            gamma,
            alpha,
            error_const,
        }
    }
}

/// The matrix `R(rho)` of Shampine-Reichelt (eq. 2.3) for order `k`:
/// `R_ij = prod_{m=1..i} (m - 1 - rho j) / m` (`R_0j = 1`, `R_i0 = 0` for `i > 0`).
fn interpolation_matrix(k: usize, rho: f64) -> [[f64; MAX_ORDER + 1]; MAX_ORDER + 1] {
    let mut r = [[0.0; MAX_ORDER + 1]; MAX_ORDER + 1];
    for j in 0..=k {
        r[0][j] = 1.0;
    }
    for i in 1..=k {
        for j in 1..=k {
            r[i][j] = r[i - 1][j] * ((i - 1) as f64 - rho * j as f64) / i as f64;
        }
    }
    r
}

/// The Jacobian, the iteration matrix `I - c J` and its LU: dense (faer's
/// partial-pivoting LU in place, with its workspace kept so that solves do
/// not allocate) or sparse (faer's sparse LU on the problem's pattern).
enum Matrices {
    Dense {
        jac: Vec<f64>,
        /// `I - c J`, overwritten by its LU factors.
        lu: faer::Mat<f64>,
        perm: Vec<usize>,
        perm_inv: Vec<usize>,
        mem: MemBuffer,
    },
    Sparse(Box<SparseMatrices>),
    Krylov(Box<KrylovMatrices>),
}

/// The GMRES branch of [`Matrices`]: the workspace, and for a
/// preconditioner the sparse `J`, `I - c J` and the preconditioner itself.
struct KrylovMatrices {
    gmres: Gmres,
    restarts: usize,
    /// `(J, I - c J, positions of the diagonal)`; `None` without a preconditioner.
    sparse: Option<(sprs::CsMat<f64>, sprs::CsMat<f64>, Vec<usize>)>,
    precond: AnyPreconditioner,
    /// The scaled right-hand side and solution, and the scratch of a product.
    b: Vec<f64>,
    x: Vec<f64>,
    y_pert: Vec<f64>,
    f_pert: Vec<f64>,
    unscaled: Vec<f64>,
}

/// The sparse branch of [`Matrices`].
struct SparseMatrices {
    jac: sprs::CsMat<f64>,
    m: sprs::CsMat<f64>,
    diag: Vec<usize>,
    lu: SparseLu,
}

/// The Newton system `(I - c J(t, y)) x = r` of a GMRES solve, with `f = f(t, y)`
/// and the error weights `w`.
struct KrylovSystem<'a, P> {
    problem: &'a P,
    y: &'a [f64],
    f: &'a [f64],
    w: &'a [f64],
    t: f64,
    c: f64,
}

impl<P: FirstOrderProblem> KrylovSystem<'_, P> {
    /// Solves for `x` by GMRES on the system scaled by the weights
    /// (`S (I - c J) S^-1 (S x) = S r`, `S = diag(1 / w)`), so that its
    /// 2-norm is `sqrt(n)` times the weighted RMS norm of Newton's test.
    fn solve(
        &self,
        kr: &mut KrylovMatrices,
        r: &[f64],
        x: &mut [f64],
        newton_tol: f64,
        stats: &mut BdfStats,
    ) {
        let n = r.len();
        let KrylovMatrices {
            gmres,
            restarts,
            sparse,
            precond,
            b,
            x: xs,
            y_pert,
            f_pert,
            unscaled,
        } = kr;
        for ((bi, ri), wi) in b.iter_mut().zip(r).zip(self.w) {
            *bi = ri / wi;
        }
        let tol = KRYLOV_TOL_FACTOR * newton_tol * (n as f64).sqrt();
        let preconditioned = sparse.is_some();
        let mut products = 0;
        let apply_a = |u: &[f64], out: &mut [f64]| {
            // out = S (I - c J) S^-1 u, J v by a difference quotient with
            // the step s = 1 / ||v|| (one weight unit along v = S^-1 u).
            let norm = (u.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            if norm == 0.0 {
                out.fill(0.0);
                return;
            }
            let sigma = 1.0 / norm;
            for (((yp, yi), ui), wi) in y_pert.iter_mut().zip(self.y).zip(u).zip(self.w) {
                *yp = yi + sigma * wi * ui;
            }
            self.problem.rhs(self.t, y_pert, f_pert);
            products += 1;
            for ((((o, ui), fp), fi), wi) in
                out.iter_mut().zip(u).zip(&*f_pert).zip(self.f).zip(self.w)
            {
                *o = ui - self.c * (fp - fi) / (sigma * wi);
            }
        };
        let apply_pinv = |u: &[f64], out: &mut [f64]| {
            if preconditioned {
                for ((z, ui), wi) in unscaled.iter_mut().zip(u).zip(self.w) {
                    *z = ui * wi;
                }
                precond.apply(unscaled, out);
                for (o, wi) in out.iter_mut().zip(self.w) {
                    *o /= wi;
                }
            } else {
                out.copy_from_slice(u);
            }
        };
        let outcome = gmres.solve(b, xs, tol, *restarts, apply_a, apply_pinv);
        for ((xi, si), wi) in x.iter_mut().zip(&*xs).zip(self.w) {
            *xi = si * wi;
        }
        stats.num_lin_iters += outcome.iterations;
        stats.num_jtimes_evals += products;
        stats.num_lin_rhs_evals += products;
        if preconditioned {
            stats.num_prec_solves += outcome.preconditioner_solves;
        }
        if !outcome.converged {
            stats.num_lin_conv_fails += 1;
        }
    }
}

/// Refills the sparse Jacobian `jac` (of `nnz` entries) at `(t, y)`;
/// `Ok(false)` if it is not finite.
fn sparse_jacobian<P: FirstOrderProblem>(
    problem: &P,
    t: f64,
    y: &[f64],
    jac: &mut sprs::CsMat<f64>,
    nnz: usize,
) -> Result<bool, OdeError> {
    if !problem.jacobian_sparse(t, y, jac) {
        return Err(invalid(
            "jacobian_sparse",
            t,
            "the problem gave a sparse Jacobian pattern but no values",
        ));
    }
    if jac.nnz() != nnz {
        return Err(OdeError::DimensionMismatch {
            what: "sparse Jacobian entries (jacobian_sparse changed the pattern)",
            expected: nnz,
            found: jac.nnz(),
        });
    }
    Ok(jac.data().iter().all(|v| v.is_finite()))
}

/// `m = I - c jac` on the pattern of `jac` (`diag`: positions of the diagonal).
fn fill_newton_matrix(jac: &sprs::CsMat<f64>, m: &mut sprs::CsMat<f64>, diag: &[usize], c: f64) {
    for (dst, src) in m.data_mut().iter_mut().zip(jac.data()) {
        *dst = -c * src;
    }
    for &k in diag {
        m.data_mut()[k] += 1.0;
    }
}

/// Solves `A x = b` with faer's partial-pivoting factors `P A = L U` held in
/// `lu` (unit `L` below the diagonal, `U` on and above it; `perm` the
/// forward row permutation, `(P b)_i = b_perm[i]`): the permutation, then
/// forward and back substitution by columns. The same operations as faer's
/// `solve_in_place`, without its dispatch, which cost 900 instructions per
/// solve of a 2 x 2 system, 30 % of a Van der Pol run (callgrind).
fn lu_solve(lu: &faer::Mat<f64>, perm: &[usize], b: &[f64], x: &mut [f64]) {
    let n = x.len();
    for (xi, &p) in x.iter_mut().zip(perm) {
        *xi = b[p];
    }
    for j in 0..n {
        let xj = x[j];
        if xj != 0.0 {
            let col = &lu.col_as_slice(j)[j + 1..n];
            for (xi, lij) in x[j + 1..].iter_mut().zip(col) {
                *xi -= lij * xj;
            }
        }
    }
    for j in (0..n).rev() {
        let col = lu.col_as_slice(j);
        x[j] /= col[j];
        let xj = x[j];
        if xj != 0.0 {
            for (xi, uij) in x[..j].iter_mut().zip(&col[..j]) {
                *xi -= uij * xj;
            }
        }
    }
}

/// Why one attempt at a step failed without ending the run.
enum Attempt {
    Converged(usize),
    Failed { iterations: usize, update_norm: f64 },
}

/// The direction of zero crossings an event reacts to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Direction {
    /// Both directions.
    #[default]
    Both,
    /// From negative to positive.
    Rising,
    /// From positive to negative.
    Falling,
}

/// The event functions' callback `g(t, y, out)`.
type EventFn<'a> = Box<dyn FnMut(f64, &[f64], &mut [f64]) + 'a>;

/// Event functions `g(t, y)` whose roots [`BdfSolver::solve_at_with_events`]
/// locates on the dense output, each with a direction and a terminal flag
/// (a terminal event ends the run at the root).
pub struct Events<'a> {
    g: EventFn<'a>,
    directions: Vec<Direction>,
    terminal: Vec<bool>,
    g_old: Vec<f64>,
    g_new: Vec<f64>,
    g_mid: Vec<f64>,
}

impl<'a> Events<'a> {
    /// `directions.len()` event functions, written by `g(t, y, out)` into `out`.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`] if `terminal` and `directions` differ in length.
    pub fn new(
        g: impl FnMut(f64, &[f64], &mut [f64]) + 'a,
        directions: Vec<Direction>,
        terminal: Vec<bool>,
    ) -> Result<Self, OdeError> {
        let m = directions.len();
        if terminal.len() != m {
            return Err(OdeError::DimensionMismatch {
                what: "event terminal flags",
                expected: m,
                found: terminal.len(),
            });
        }
        Ok(Self {
            g: Box::new(g),
            directions,
            terminal,
            g_old: vec![0.0; m],
            g_new: vec![0.0; m],
            g_mid: vec![0.0; m],
        })
    }

    fn crosses(&self, i: usize, a: f64, b: f64) -> bool {
        let rising = a < 0.0 && b >= 0.0;
        let falling = a > 0.0 && b <= 0.0;
        match self.directions[i] {
            Direction::Both => rising || falling,
            Direction::Rising => rising,
            Direction::Falling => falling,
        }
    }
}

/// A located event.
#[derive(Debug, Clone, PartialEq)]
pub struct EventHit {
    /// Which event function.
    pub index: usize,
    /// The time of the root.
    pub t: f64,
    /// The state there (from the dense output).
    pub y: Vec<f64>,
    /// Whether the event is terminal (the run ended here).
    pub terminal: bool,
}

/// The result of [`BdfSolver::solve_at`].
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The output times reached (all requested ones unless a terminal event stopped the run).
    pub t: Vec<f64>,
    /// The states at `t`, one after the other (`dim` values each).
    pub values: Vec<f64>,
    /// The events located, in time order.
    pub events: Vec<EventHit>,
    /// The statistics after the run.
    pub stats: BdfStats,
    dim: usize,
}

impl Solution {
    /// The state at `t[i]`.
    pub fn y(&self, i: usize) -> &[f64] {
        &self.values[i * self.dim..(i + 1) * self.dim]
    }
}

/// The variable-order, variable-step BDF/NDF solver (see the module docs).
pub struct BdfSolver<P> {
    problem: P,
    opts: BdfOptions,
    n: usize,
    atol: Vec<f64>,
    coef: Coefficients,
    newton_tol: f64,
    bound: f64,
    t: f64,
    t_prev: f64,
    /// The step size of the history grid (the next step's size).
    h: f64,
    order: usize,
    n_equal_steps: usize,
    /// False until the history is started (first step, or after a restart).
    started: bool,
    /// The differences `D_0..D_{MAX_ORDER + 2}`.
    d: Vec<Vec<f64>>,
    mats: Matrices,
    /// `c` of the kept LU (NaN: none).
    lu_c: f64,
    lu_age: usize,
    jac_age: usize,
    jac_evaluated: bool,
    jac_current: bool,
    /// `c` of the step at which the kept Jacobian was evaluated.
    jac_c: f64,
    /// The relative tolerance of the local error test (`rtol^p`, see
    /// [`BdfOptions::tolerance_exponent`]); `atol` holds the mapped `atol_i`.
    rtol: f64,
    /// CVODE's `crate`: the contraction rate estimate of the kept LU.
    rate: f64,
    /// Fixed order and step (no error test, no order or step change): for
    /// the tests of each formula's order.
    frozen: bool,
    stats: BdfStats,
    y_pred: Vec<f64>,
    psi: Vec<f64>,
    y_new: Vec<f64>,
    dcor: Vec<f64>,
    f: Vec<f64>,
    w: Vec<f64>,
    dy: Vec<f64>,
    rhs: Vec<f64>,
    tmp: Vec<f64>,
    col: Vec<f64>,
    work: Vec<f64>,
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> OdeError {
    OdeError::InvalidParameter {
        name,
        value,
        reason,
    }
}

impl BdfOptions {
    fn check(&self, n: usize) -> Result<Vec<f64>, OdeError> {
        if !(self.rtol > 0.0 && self.rtol < 1.0) {
            return Err(invalid("rtol", self.rtol, "must be in (0, 1)"));
        }
        let atol = match &self.atol {
            Tolerance::Scalar(a) => vec![*a; n],
            Tolerance::Vector(v) => {
                if v.len() != n {
                    return Err(OdeError::DimensionMismatch {
                        what: "atol",
                        expected: n,
                        found: v.len(),
                    });
                }
                v.clone()
            }
        };
        if let Some(a) = atol.iter().find(|a| !(**a >= 0.0 && a.is_finite())) {
            return Err(invalid("atol", *a, "must be finite and non-negative"));
        }
        if !(1..=MAX_ORDER).contains(&self.max_order) {
            return Err(invalid("max_order", self.max_order as f64, "must be 1..=5"));
        }
        if let Some(h0) = self.h0
            && !(h0 > 0.0 && h0.is_finite())
        {
            return Err(invalid("h0", h0, "must be positive and finite"));
        }
        if !(self.h_min >= 0.0 && self.h_min.is_finite()) {
            return Err(invalid(
                "h_min",
                self.h_min,
                "must be finite and non-negative",
            ));
        }
        if !(self.h_max > self.h_min) {
            return Err(invalid("h_max", self.h_max, "must exceed h_min"));
        }
        if !(self.max_gamma_change >= 0.0) {
            return Err(invalid(
                "max_gamma_change",
                self.max_gamma_change,
                "must be non-negative",
            ));
        }
        if !(1.0..=2.0).contains(&self.tolerance_exponent) {
            return Err(invalid(
                "tolerance_exponent",
                self.tolerance_exponent,
                "must be in [1, 2]",
            ));
        }
        if let BdfLinearSolver::Gmres { krylov_dim, .. } = self.linear_solver
            && krylov_dim == 0
        {
            return Err(invalid("krylov_dim", 0.0, "must be at least 1"));
        }
        if !(self.max_growth > 1.0) {
            return Err(invalid("max_growth", self.max_growth, "must exceed 1"));
        }
        for (name, v) in [
            ("max_newton_iterations", self.max_newton_iterations),
            ("steps_per_factorization", self.steps_per_factorization),
            ("steps_per_jacobian", self.steps_per_jacobian.unwrap_or(1)),
        ] {
            if v == 0 {
                return Err(invalid(name, 0.0, "must be at least 1"));
            }
        }
        Ok(atol)
    }
}

/// The weighted RMS norm `sqrt(1/n sum (v_i / w_i)^2)`.
fn rms(v: &[f64], w: &[f64]) -> f64 {
    let n = v.len().max(1);
    (v.iter().zip(w).map(|(a, b)| (a / b).powi(2)).sum::<f64>() / n as f64).sqrt()
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

impl<P: FirstOrderProblem> BdfSolver<P> {
    /// A solver for `problem` from `(t0, y0)`.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] / [`OdeError::DimensionMismatch`] for
    /// bad options, sizes or a sparse pattern without its diagonal;
    /// [`OdeError::NonFinite`] for a non-finite `t0` or `y0`.
    pub fn new(problem: P, t0: f64, y0: &[f64], opts: BdfOptions) -> Result<Self, OdeError> {
        let n = problem.dim();
        let mut atol = opts.check(n)?;
        if y0.len() != n {
            return Err(OdeError::DimensionMismatch {
                what: "initial state",
                expected: n,
                found: y0.len(),
            });
        }
        if !t0.is_finite() || y0.iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "initial time or state",
                t: t0,
            });
        }
        let mats = match (opts.linear_solver, problem.sparse_jacobian_pattern()) {
            (
                BdfLinearSolver::Gmres {
                    krylov_dim,
                    restarts,
                    preconditioner,
                },
                pattern,
            ) => {
                let sparse = match (preconditioner, pattern) {
                    (PrecondKind::None, _) => None,
                    (_, None) => {
                        return Err(invalid(
                            "linear_solver",
                            f64::NAN,
                            "a GMRES preconditioner needs the problem's sparse Jacobian pattern",
                        ));
                    }
                    (_, Some(pattern)) => {
                        let diag = diagonal_positions(&pattern, n)?;
                        Some((pattern.clone(), pattern, diag))
                    }
                };
                Matrices::Krylov(Box::new(KrylovMatrices {
                    gmres: Gmres::new(n, krylov_dim),
                    restarts,
                    sparse,
                    precond: AnyPreconditioner::new(preconditioner)?,
                    b: vec![0.0; n],
                    x: vec![0.0; n],
                    y_pert: vec![0.0; n],
                    f_pert: vec![0.0; n],
                    unscaled: vec![0.0; n],
                }))
            }
            (BdfLinearSolver::Direct, None) => {
                let par = faer::Par::Seq;
                let req = faer::linalg::lu::partial_pivoting::factor::lu_in_place_scratch::<
                    usize,
                    f64,
                >(n, n, par, Default::default());
                Matrices::Dense {
                    jac: vec![0.0; n * n],
                    lu: faer::Mat::zeros(n, n),
                    perm: vec![0; n],
                    perm_inv: vec![0; n],
                    mem: MemBuffer::new(req),
                }
            }
            (BdfLinearSolver::Direct, Some(pattern)) => {
                let diag = diagonal_positions(&pattern, n)?;
                Matrices::Sparse(Box::new(SparseMatrices {
                    m: pattern.clone(),
                    jac: pattern,
                    diag,
                    lu: SparseLu::new(),
                }))
            }
        };
        let rtol = opts.rtol.powf(opts.tolerance_exponent);
        let atol_scale = rtol / opts.rtol;
        for a in &mut atol {
            *a *= atol_scale;
        }
        let mut d = vec![vec![0.0; n]; MAX_ORDER + 3];
        d[0].copy_from_slice(y0);
        Ok(Self {
            problem,
            coef: Coefficients::new(opts.formula),
            newton_tol: (10.0 * f64::EPSILON / rtol).max(NEWTON_TOL),
            bound: opts.max_growth * max_abs(y0).max(1.0),
            opts,
            n,
            atol,
            t: t0,
            t_prev: t0,
            h: f64::NAN,
            order: 1,
            n_equal_steps: 0,
            started: false,
            d,
            mats,
            lu_c: f64::NAN,
            lu_age: 0,
            jac_age: 0,
            jac_evaluated: false,
            jac_current: false,
            jac_c: f64::NAN,
            rtol,
            rate: 1.0,
            frozen: false,
            stats: BdfStats::default(),
            y_pred: vec![0.0; n],
            psi: vec![0.0; n],
            y_new: vec![0.0; n],
            dcor: vec![0.0; n],
            f: vec![0.0; n],
            w: vec![0.0; n],
            dy: vec![0.0; n],
            rhs: vec![0.0; n],
            tmp: vec![0.0; n],
            col: vec![0.0; n],
            work: vec![0.0; (MAX_ORDER + 1) * n],
        })
    }

    /// The current time (the end of the last accepted step).
    pub fn t(&self) -> f64 {
        self.t
    }

    /// The current state.
    pub fn y(&self) -> &[f64] {
        &self.d[0]
    }

    /// The statistics so far.
    pub fn stats(&self) -> &BdfStats {
        &self.stats
    }

    /// The order the next step will use.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The problem.
    pub fn problem(&self) -> &P {
        &self.problem
    }

    /// The step size the next step will try (NaN before the first step).
    pub fn h_next(&self) -> f64 {
        self.h
    }

    /// Restarts the method at `(t, y)` (order 1, a new initial step; the
    /// Jacobian and its LU are kept), e.g. after a discontinuity.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`].
    pub fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        if y.len() != self.n {
            return Err(OdeError::DimensionMismatch {
                what: "state",
                expected: self.n,
                found: y.len(),
            });
        }
        if !t.is_finite() || y.iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "restart time or state",
                t,
            });
        }
        self.d[0].copy_from_slice(y);
        self.t = t;
        self.t_prev = t;
        self.started = false;
        self.order = 1;
        self.n_equal_steps = 0;
        Ok(())
    }

    fn fail(&self, source: OdeError) -> OdeError {
        OdeError::Run {
            t: self.t,
            stats: Box::new(self.stats),
            source: Box::new(source),
        }
    }

    fn eval_rhs(&mut self, t: f64, y_is_pred: bool) {
        let y = if y_is_pred { &self.y_pred } else { &self.y_new };
        self.problem.rhs(t, y, &mut self.f);
        self.stats.num_rhs_evals += 1;
    }

    /// Hairer-Wanner's starting step (Solving ODEs I, II.4, for order 1):
    /// `h0 = 0.01 ||y0|| / ||f0||`, then `h1 = (0.01 / max(||f0||, ||f'||))^(1/2)`
    /// with `f'` a difference quotient along `f0`; the result `min(100 h0, h1)`.
    fn initial_step(&mut self, span: f64) -> f64 {
        let rtol = self.rtol;
        for i in 0..self.n {
            self.w[i] = self.atol[i] + rtol * self.d[0][i].abs();
        }
        // f0 is in self.f.
        let d0 = rms(&self.d[0], &self.w);
        let d1 = rms(&self.f, &self.w);
        let mut h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        h0 = h0.min(span);
        for i in 0..self.n {
            self.y_new[i] = self.d[0][i] + h0 * self.f[i];
        }
        self.problem.rhs(self.t + h0, &self.y_new, &mut self.rhs);
        self.stats.num_rhs_evals += 1;
        for i in 0..self.n {
            self.tmp[i] = self.rhs[i] - self.f[i];
        }
        let d2 = rms(&self.tmp, &self.w) / h0;
        let h1 = if d1 <= 1e-15 && d2 <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / d1.max(d2)).sqrt()
        };
        (100.0 * h0).min(h1).min(span)
    }

    /// Re-interpolates the history onto a grid of spacing `rho h`:
    /// `D <- (R(rho) U)^T D` with `U = R(1)` (Shampine-Reichelt, eq. 2.3).
    fn rescale(&mut self, rho: f64) {
        let k = self.order;
        let r = interpolation_matrix(k, rho);
        let u = interpolation_matrix(k, 1.0);
        let n = self.n;
        for j in 0..=k {
            let out = &mut self.work[j * n..(j + 1) * n];
            out.fill(0.0);
            for i in 0..=k {
                let ru: f64 = (0..=k).map(|m| r[i][m] * u[m][j]).sum();
                if ru != 0.0 {
                    for (o, v) in out.iter_mut().zip(&self.d[i]) {
                        *o += ru * v;
                    }
                }
            }
        }
        for j in 0..=k {
            self.d[j].copy_from_slice(&self.work[j * n..(j + 1) * n]);
        }
        self.h *= rho;
        self.n_equal_steps = 0;
    }

    /// Evaluates `J = df/dy` at `(t, y_pred)`; `Ok(false)` if it is not
    /// finite (a recoverable failure: the step is retried smaller, and the
    /// next attempt evaluates the Jacobian again).
    fn eval_jacobian(&mut self, t: f64) -> Result<bool, OdeError> {
        if let Matrices::Krylov(kr) = &self.mats
            && kr.sparse.is_none()
        {
            // Matrix-free and unpreconditioned: no Jacobian to keep.
            self.jac_age = 0;
            self.jac_evaluated = true;
            self.jac_current = true;
            return Ok(true);
        }
        self.stats.num_jac_evals += 1;
        let n = self.n;
        match &mut self.mats {
            Matrices::Dense { jac, .. } => {
                if !self.problem.jacobian(t, &self.y_pred, jac) {
                    self.problem.rhs(t, &self.y_pred, &mut self.rhs);
                    let rtol = self.rtol;
                    let atol = &self.atol;
                    forward_difference_jacobian(
                        &self.problem,
                        t,
                        &self.y_pred,
                        &self.rhs,
                        |j, yj| {
                            let inc = f64::EPSILON.sqrt() * yj.abs().max(atol[j] / rtol);
                            if inc > 0.0 { inc } else { f64::EPSILON.sqrt() }
                        },
                        &mut self.tmp,
                        &mut self.col,
                        jac,
                    );
                    self.stats.num_lin_rhs_evals += n + 1;
                }
                if jac.iter().any(|v| !v.is_finite()) {
                    self.jac_evaluated = false;
                    return Ok(false);
                }
            }
            Matrices::Sparse(sp) => {
                let SparseMatrices { jac, m, .. } = &mut **sp;
                if !sparse_jacobian(&self.problem, t, &self.y_pred, jac, m.nnz())? {
                    self.jac_evaluated = false;
                    return Ok(false);
                }
            }
            Matrices::Krylov(kr) => {
                if let Some((jac, m, _)) = &mut kr.sparse
                    && !sparse_jacobian(&self.problem, t, &self.y_pred, jac, m.nnz())?
                {
                    self.jac_evaluated = false;
                    return Ok(false);
                }
            }
        }
        self.jac_age = 0;
        self.jac_evaluated = true;
        self.jac_current = true;
        Ok(true)
    }

    /// Factors `M = I - c J`. A singular matrix is a recoverable failure
    /// (`Ok(false)`: the step is retried smaller).
    fn factor(&mut self, c: f64) -> Result<bool, OdeError> {
        self.stats.num_lin_solv_setups += 1;
        self.lu_c = f64::NAN;
        let result = match &mut self.mats {
            Matrices::Dense {
                jac,
                lu,
                perm,
                perm_inv,
                mem,
            } => {
                let n = self.n;
                for j in 0..n {
                    for i in 0..n {
                        let id = if i == j { 1.0 } else { 0.0 };
                        lu[(i, j)] = id - c * jac[i * n + j];
                    }
                }
                lu_in_place(
                    lu.as_mut(),
                    perm,
                    perm_inv,
                    faer::Par::Seq,
                    MemStack::new(mem),
                    Default::default(),
                );
                // A pivot |u_kk| <= n eps max |u_ij| counts as singular.
                let mut umax = 0.0f64;
                for j in 0..n {
                    for i in 0..=j {
                        umax = umax.max(lu[(i, j)].abs());
                    }
                }
                let tiny = n as f64 * f64::EPSILON * umax;
                if (0..n).all(|k| lu[(k, k)].abs() > tiny) {
                    Ok(())
                } else {
                    Err(NonlinearError::SingularJacobian {
                        pivot: 0,
                        value: 0.0,
                    })
                }
            }
            Matrices::Sparse(sp) => {
                let SparseMatrices { jac, m, diag, lu } = &mut **sp;
                fill_newton_matrix(jac, m, diag, c);
                lu.setup(m)
            }
            Matrices::Krylov(kr) => {
                let KrylovMatrices {
                    sparse, precond, ..
                } = &mut **kr;
                match sparse {
                    Some((jac, m, diag)) => {
                        fill_newton_matrix(jac, m, diag, c);
                        self.stats.num_prec_evals += 1;
                        // A preconditioner that cannot be set up (e.g. a
                        // non-positive pivot of IC(0)) fails the attempt:
                        // the step is retried smaller, as for a singular LU.
                        precond
                            .setup(&*m)
                            .map_err(|_| NonlinearError::SingularJacobian {
                                pivot: 0,
                                value: 0.0,
                            })
                    }
                    None => Ok(()),
                }
            }
        };
        match result {
            Ok(()) => {
                self.lu_c = c;
                self.lu_age = 0;
                self.rate = 1.0;
                Ok(true)
            }
            Err(NonlinearError::SingularJacobian { .. }) => Ok(false),
            Err(e) => Err(OdeError::NewtonSolver {
                t: self.t,
                source: e,
            }),
        }
    }

    /// Solves `M x = rhs` into `dy`: with the kept LU, or by GMRES on
    /// `I - c J(t, y_new)` (products by difference quotients around
    /// `(y_new, f)`, the current Newton iterate and its `f`).
    fn solve_linear(&mut self, t: f64, c: f64) -> Result<(), OdeError> {
        if let Matrices::Krylov(kr) = &mut self.mats {
            let x = KrylovSystem {
                problem: &self.problem,
                y: &self.y_new,
                f: &self.f,
                w: &self.w,
                t,
                c,
            };
            x.solve(
                kr,
                &self.rhs,
                &mut self.dy,
                self.newton_tol,
                &mut self.stats,
            );
            return Ok(());
        }
        let result = match &mut self.mats {
            Matrices::Dense { lu, perm, .. } => {
                lu_solve(lu, perm, &self.rhs, &mut self.dy);
                Ok(Default::default())
            }
            Matrices::Sparse(sp) => sp.lu.solve(&sp.m, &self.rhs, &mut self.dy, 0.0),
            Matrices::Krylov(_) => unreachable!("handled above"),
        };
        match result {
            Ok(_) | Err(NonlinearError::SingularJacobian { .. }) => Ok(()),
            Err(e) => Err(OdeError::NewtonSolver {
                t: self.t,
                source: e,
            }),
        }
    }

    /// The simplified Newton iteration for `d = c f(t_new, y_pred + d) - psi`
    /// with the kept LU, stopped in the weighted norm (see the module docs).
    fn newton(&mut self, t_new: f64, c: f64) -> Result<Attempt, OdeError> {
        self.y_new.copy_from_slice(&self.y_pred);
        self.dcor.fill(0.0);
        let maxit = self.opts.max_newton_iterations;
        let tol = self.newton_tol;
        // CVODE's correction for an LU made with another c.
        let gamrat = c / self.lu_c;
        let scale = if gamrat != 1.0 && !matches!(self.mats, Matrices::Krylov(_)) {
            2.0 / (1.0 + gamrat)
        } else {
            1.0
        };
        let mut old = f64::NAN;
        let mut last = f64::NAN;
        for k in 0..maxit {
            self.eval_rhs(t_new, false);
            if self.f.iter().any(|v| !v.is_finite()) {
                return Ok(Attempt::Failed {
                    iterations: k,
                    update_norm: f64::NAN,
                });
            }
            for i in 0..self.n {
                self.rhs[i] = c * self.f[i] - self.psi[i] - self.dcor[i];
            }
            self.solve_linear(t_new, c)?;
            if scale != 1.0 {
                for v in &mut self.dy {
                    *v *= scale;
                }
            }
            self.stats.num_nonlin_solv_iters += 1;
            let norm = rms(&self.dy, &self.w);
            last = norm;
            if !norm.is_finite() {
                return Ok(Attempt::Failed {
                    iterations: k + 1,
                    update_norm: norm,
                });
            }
            if k > 0 {
                let rate = norm / old;
                if rate >= MAX_RATE || rate.powi((maxit - k) as i32) / (1.0 - rate) * norm > tol {
                    return Ok(Attempt::Failed {
                        iterations: k + 1,
                        update_norm: norm,
                    });
                }
                self.rate = (0.3 * self.rate).max(rate);
            }
            for i in 0..self.n {
                self.y_new[i] += self.dy[i];
                self.dcor[i] += self.dy[i];
            }
            // The first iteration's rate is not measured yet: the carried
            // estimate (CVODE's crate) may be stale after the step and
            // order changes, so the first update only counts when it is
            // already within the tolerance.
            let rho = self.rate;
            if norm == 0.0 || (rho < 1.0 && rho / (1.0 - rho) * norm < tol && (k > 0 || norm < tol))
            {
                return Ok(Attempt::Converged(k + 1));
            }
            old = norm;
        }
        Ok(Attempt::Failed {
            iterations: maxit,
            update_norm: last,
        })
    }

    /// Starts the history: `f0`, the initial step, `D_1 = h f0`.
    fn start(&mut self, t_bound: f64) -> Result<(), OdeError> {
        let span = t_bound - self.t;
        self.problem.rhs(self.t, &self.d[0], &mut self.f);
        self.stats.num_rhs_evals += 1;
        if self.f.iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "right-hand side",
                t: self.t,
            });
        }
        let h = match self.opts.h0 {
            Some(h0) => h0.min(span),
            None => self.initial_step(span),
        };
        let h = h.min(self.opts.h_max).max(self.opts.h_min);
        if !(h > 0.0 && h.is_finite()) {
            return Err(OdeError::StepSizeUnderflow { t: self.t, h });
        }
        self.h = h;
        for i in 0..self.n {
            self.d[1][i] = h * self.f[i];
        }
        self.order = 1;
        self.n_equal_steps = 0;
        self.started = true;
        Ok(())
    }

    /// One accepted step that does not pass `t_bound` (`t_bound > t`).
    ///
    /// # Errors
    /// [`OdeError::Run`] with the time, the statistics and the cause:
    /// [`OdeError::TooManySteps`], [`OdeError::StepSizeUnderflow`],
    /// [`OdeError::NewtonFailed`], [`OdeError::ErrorTestFailed`],
    /// [`OdeError::NonFinite`], [`OdeError::StateGrowth`], or an error of
    /// the problem's Jacobian or of the linear solver.
    pub fn step(&mut self, t_bound: f64) -> Result<(), OdeError> {
        if !(t_bound > self.t) || !t_bound.is_finite() {
            return Err(invalid(
                "t_bound",
                t_bound,
                "must be finite and after the current time",
            ));
        }
        if self.stats.num_steps >= self.opts.max_steps {
            return Err(self.fail(OdeError::TooManySteps {
                t: self.t,
                max_steps: self.opts.max_steps,
            }));
        }
        self.step_inner(t_bound).map_err(|e| self.fail(e))
    }

    fn step_inner(&mut self, t_bound: f64) -> Result<(), OdeError> {
        if !self.started {
            self.start(t_bound)?;
        }
        let t = self.t;
        let ulp = (t.abs() * f64::EPSILON).max(f64::MIN_POSITIVE);
        let h_floor = (10.0 * ulp).max(self.opts.h_min);
        if self.h > self.opts.h_max {
            self.rescale(self.opts.h_max / self.h);
        } else if self.h < h_floor {
            self.rescale(h_floor / self.h);
        }
        let mut conv_fails = 0;
        let mut err_fails = 0;
        let rtol = self.rtol;
        loop {
            if self.h < h_floor {
                return Err(OdeError::StepSizeUnderflow { t, h: self.h });
            }
            let mut t_new = t + self.h;
            if t_new >= t_bound {
                self.rescale((t_bound - t) / self.h);
                t_new = t_bound;
            }
            let k = self.order;
            let h = self.h;
            for i in 0..self.n {
                let mut p = 0.0;
                let mut s = 0.0;
                for j in 0..=k {
                    p += self.d[j][i];
                    if j > 0 {
                        s += self.coef.gamma[j] * self.d[j][i];
                    }
                }
                self.y_pred[i] = p;
                self.psi[i] = s / self.coef.alpha[k];
                self.w[i] = self.atol[i] + rtol * p.abs();
            }
            let c = h / self.coef.alpha[k];
            let attempt = loop {
                let mut refactor = !(self.lu_c.abs() > 0.0)
                    || (c / self.lu_c - 1.0).abs() > self.opts.max_gamma_change
                    || self.lu_age >= self.opts.steps_per_factorization;
                let jac_old = self
                    .opts
                    .steps_per_jacobian
                    .is_some_and(|n| self.jac_age >= n)
                    || c > JACOBIAN_C_GROWTH * self.jac_c;
                let mut usable = true;
                if !self.jac_evaluated || jac_old {
                    usable = self.eval_jacobian(t_new)?;
                    self.jac_c = c;
                    refactor = true;
                }
                let factored = usable && (!refactor || self.factor(c)?);
                let attempt = if factored {
                    self.newton(t_new, c)?
                } else {
                    Attempt::Failed {
                        iterations: 0,
                        update_norm: f64::NAN,
                    }
                };
                if let Attempt::Converged(_) = attempt {
                    break attempt;
                }
                self.stats.num_nonlin_solv_conv_fails += 1;
                if self.jac_current || !usable {
                    break attempt;
                }
                // Slow convergence with an old Jacobian: a fresh one and a new LU.
                if !self.eval_jacobian(t_new)? {
                    break attempt;
                }
                self.jac_c = c;
                self.lu_c = f64::NAN;
            };
            let iterations = match attempt {
                Attempt::Converged(it) => it,
                Attempt::Failed {
                    iterations,
                    update_norm,
                } => {
                    conv_fails += 1;
                    if conv_fails >= self.opts.max_convergence_failures {
                        return Err(OdeError::NewtonFailed {
                            t,
                            h,
                            retries: conv_fails - 1,
                            iterations,
                            update_norm,
                        });
                    }
                    self.lu_c = f64::NAN;
                    self.rescale(0.5);
                    // The Jacobian was taken at this attempt's predictor; the
                    // smaller step predicts another point: if Newton fails
                    // again, the Jacobian is re-evaluated there first.
                    self.jac_current = false;
                    continue;
                }
            };
            let maxit = self.opts.max_newton_iterations as f64;
            let safety = 0.9 * (2.0 * maxit + 1.0) / (2.0 * maxit + iterations as f64);
            for i in 0..self.n {
                self.w[i] = self.atol[i] + rtol * self.y_new[i].abs();
            }
            let error_norm = self.coef.error_const[k] * rms(&self.dcor, &self.w);
            if !error_norm.is_finite() {
                return Err(OdeError::NonFinite {
                    what: "local error estimate",
                    t,
                });
            }
            if error_norm > 1.0 && !self.frozen {
                self.stats.num_err_test_fails += 1;
                err_fails += 1;
                if err_fails >= self.opts.max_error_test_failures {
                    return Err(OdeError::ErrorTestFailed {
                        t,
                        h,
                        failures: err_fails,
                    });
                }
                let factor = (safety * error_norm.powf(-1.0 / (k as f64 + 1.0))).max(MIN_FACTOR);
                if err_fails < 3 {
                    self.rescale(factor);
                } else {
                    // Repeated failures: the history is not to be trusted;
                    // restart at order 1 from f(t_n, y_n) with a tenth of
                    // the step at most (CVODE's MXNEF1 and ETAMIN rules).
                    self.h *= factor.min(0.1);
                    self.order = 1;
                    self.n_equal_steps = 0;
                    self.problem.rhs(t, &self.d[0], &mut self.f);
                    self.stats.num_rhs_evals += 1;
                    for i in 0..self.n {
                        self.d[1][i] = self.h * self.f[i];
                    }
                }
                continue;
            }
            self.accept(t_new, h, safety, error_norm)?;
            return Ok(());
        }
    }

    /// Books an accepted step, updates the differences (Shampine-Reichelt,
    /// eq. 2.4) and chooses the next order and step size.
    fn accept(&mut self, t_new: f64, h: f64, safety: f64, error_norm: f64) -> Result<(), OdeError> {
        let k = self.order;
        self.t_prev = self.t;
        self.t = t_new;
        self.stats.num_steps += 1;
        self.stats.last_order = k;
        self.stats.last_step = h;
        self.lu_age += 1;
        self.jac_age += 1;
        self.jac_current = false;
        self.n_equal_steps += 1;
        for i in 0..self.n {
            self.d[k + 2][i] = self.dcor[i] - self.d[k + 1][i];
            self.d[k + 1][i] = self.dcor[i];
        }
        for j in (0..=k).rev() {
            let (lo, hi) = self.d.split_at_mut(j + 1);
            for (a, b) in lo[j].iter_mut().zip(&hi[0]) {
                *a += b;
            }
        }
        if self.d[0].iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "state after the step",
                t: t_new,
            });
        }
        let norm = max_abs(&self.d[0]);
        if norm > self.bound {
            return Err(OdeError::StateGrowth {
                t: t_new,
                norm,
                bound: self.bound,
            });
        }
        if self.n_equal_steps < k + 1 || self.frozen {
            return Ok(());
        }
        let err_m = if k > 1 {
            self.coef.error_const[k - 1] * rms(&self.d[k], &self.w)
        } else {
            f64::INFINITY
        };
        let err_p = if k < self.opts.max_order {
            self.coef.error_const[k + 1] * rms(&self.d[k + 2], &self.w)
        } else {
            f64::INFINITY
        };
        let factors = [
            err_m.powf(-1.0 / k as f64),
            error_norm.powf(-1.0 / (k as f64 + 1.0)),
            err_p.powf(-1.0 / (k as f64 + 2.0)),
        ];
        let mut best = 1;
        for (i, f) in factors.iter().enumerate() {
            if *f > factors[best] {
                best = i;
            }
        }
        self.order = k + best - 1;
        let factor = (safety * factors[best]).min(MAX_FACTOR);
        // Hysteresis: keep the order and step unless the change is worth
        // the re-interpolation and a likely refactorisation (CVODE keeps h
        // for growth below THRESH = 1.5).
        if best != 1 || !(KEEP_STEP.0 < factor && factor < KEEP_STEP.1) {
            self.rescale(factor);
        }
        Ok(())
    }

    /// The dense output: the interpolating polynomial of the history,
    /// `p(t) = D_0 + sum_{j=1..k} D_j prod_{m=0..j-1} (t - t_n + m h) / ((m + 1) h)`,
    /// at `t` in the last step `[t_prev, t_n]`, written into `out`.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] for `t` outside the last step,
    /// [`OdeError::DimensionMismatch`] for a wrong `out`.
    pub fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        if out.len() != self.n {
            return Err(OdeError::DimensionMismatch {
                what: "interpolation output",
                expected: self.n,
                found: out.len(),
            });
        }
        let slack = 8.0 * f64::EPSILON * self.t.abs().max(t.abs());
        if !(t >= self.t_prev - slack && t <= self.t + slack) {
            return Err(invalid(
                "t",
                t,
                "dense output is available in the last step only",
            ));
        }
        out.copy_from_slice(&self.d[0]);
        if t == self.t || !self.started {
            return Ok(());
        }
        let mut p = 1.0;
        for j in 1..=self.order {
            let m = (j - 1) as f64;
            p *= (t - (self.t - m * self.h)) / ((m + 1.0) * self.h);
            for (o, dj) in out.iter_mut().zip(&self.d[j]) {
                *o += p * dj;
            }
        }
        Ok(())
    }

    /// Steps to `t_end` (the last step ends on it).
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn solve_to(&mut self, t_end: f64) -> Result<BdfStats, OdeError> {
        while self.t < t_end {
            self.step(t_end)?;
        }
        Ok(self.stats)
    }

    /// The solution at the non-decreasing `times` (none before the current
    /// time), stepping to the last one and interpolating the others.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] for bad times; run failures as
    /// [`step`](Self::step).
    pub fn solve_at(&mut self, times: &[f64]) -> Result<Solution, OdeError> {
        self.run(times, None)
    }

    /// [`solve_at`](Self::solve_at) with event location: after every step the
    /// event functions are compared at both ends; a sign change in an
    /// event's direction is located on the dense output by the Illinois
    /// variant of regula falsi, to `4 eps max(|t|, |h|)`. A terminal event
    /// ends the run there: the solver restarts at the root (order 1) and the
    /// output times after it are not reached.
    ///
    /// # Errors
    /// As [`solve_at`](Self::solve_at); [`OdeError::DimensionMismatch`] for
    /// events of another size.
    pub fn solve_at_with_events(
        &mut self,
        times: &[f64],
        events: &mut Events<'_>,
    ) -> Result<Solution, OdeError> {
        self.run(times, Some(events))
    }

    fn run(
        &mut self,
        times: &[f64],
        mut events: Option<&mut Events<'_>>,
    ) -> Result<Solution, OdeError> {
        for (i, &t) in times.iter().enumerate() {
            if !t.is_finite() || t < self.t || (i > 0 && t < times[i - 1]) {
                return Err(invalid(
                    "times",
                    t,
                    "must be finite, non-decreasing and not before the current time",
                ));
            }
        }
        let n = self.n;
        let mut sol = Solution {
            t: Vec::with_capacity(times.len()),
            values: Vec::with_capacity(times.len() * n),
            events: Vec::new(),
            stats: self.stats,
            dim: n,
        };
        let Some(&t_end) = times.last() else {
            return Ok(sol);
        };
        if let Some(ev) = events.as_deref_mut() {
            (ev.g)(self.t, &self.d[0], &mut ev.g_old);
            self.stats.num_g_evals += 1;
        }
        let mut next = 0;
        let mut y = vec![0.0; n];
        while next < times.len() && times[next] <= self.t {
            sol.t.push(times[next]);
            sol.values.extend_from_slice(&self.d[0]);
            next += 1;
        }
        while self.t < t_end {
            self.step(t_end)?;
            let mut stop_at = self.t;
            let mut terminal = false;
            if let Some(ev) = events.as_deref_mut() {
                let first = sol.events.len();
                terminal = self.locate_events(ev, &mut sol.events)?;
                if terminal {
                    stop_at = sol.events.last().map_or(self.t, |e| e.t);
                }
                debug_assert!(sol.events[first..].windows(2).all(|w| w[0].t <= w[1].t));
            }
            while next < times.len() && times[next] <= stop_at {
                self.interpolate(times[next], &mut y)?;
                sol.t.push(times[next]);
                sol.values.extend_from_slice(&y);
                next += 1;
            }
            if terminal {
                let hit = sol.events.last().expect("a terminal event was recorded");
                let (t_root, y_root) = (hit.t, hit.y.clone());
                self.restart(t_root, &y_root)?;
                break;
            }
        }
        sol.stats = self.stats;
        Ok(sol)
    }

    /// Finds the roots of the event functions in the last step, appends them
    /// (in time order, up to and including the first terminal one) to
    /// `hits`; returns whether a terminal event was hit.
    fn locate_events(
        &mut self,
        ev: &mut Events<'_>,
        hits: &mut Vec<EventHit>,
    ) -> Result<bool, OdeError> {
        let m = ev.directions.len();
        (ev.g)(self.t, &self.d[0], &mut ev.g_new);
        self.stats.num_g_evals += 1;
        let (ta, tb) = (self.t_prev, self.t);
        let tol = 4.0 * f64::EPSILON * ta.abs().max(tb.abs()).max(tb - ta);
        let mut found: Vec<(f64, usize)> = Vec::new();
        let mut y = vec![0.0; self.n];
        for i in 0..m {
            let (ga, gb) = (ev.g_old[i], ev.g_new[i]);
            if !ev.crosses(i, ga, gb) {
                continue;
            }
            // Illinois: regula falsi, halving the weight of a retained end.
            let (mut a, mut b, mut fa, mut fb) = (ta, tb, ga, gb);
            let mut side = 0i32;
            let mut root = tb;
            for _ in 0..100 {
                if (b - a).abs() <= tol {
                    break;
                }
                let mut tm = (a * fb - b * fa) / (fb - fa);
                if !(tm > a && tm < b) {
                    tm = 0.5 * (a + b);
                }
                self.interpolate(tm, &mut y)?;
                (ev.g)(tm, &y, &mut ev.g_mid);
                self.stats.num_g_evals += 1;
                let fm = ev.g_mid[i];
                if fm == 0.0 {
                    a = tm;
                    b = tm;
                    break;
                }
                if (fm > 0.0) == (fb > 0.0) {
                    b = tm;
                    fb = fm;
                    if side == 1 {
                        fa *= 0.5;
                    }
                    side = 1;
                } else {
                    a = tm;
                    fa = fm;
                    if side == -1 {
                        fb *= 0.5;
                    }
                    side = -1;
                }
                root = b;
            }
            if a == b {
                root = a;
            }
            found.push((root, i));
        }
        found.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut terminal = false;
        for (t_root, i) in found {
            self.interpolate(t_root, &mut y)?;
            hits.push(EventHit {
                index: i,
                t: t_root,
                y: y.clone(),
                terminal: ev.terminal[i],
            });
            if ev.terminal[i] {
                terminal = true;
                (ev.g)(t_root, &y, &mut ev.g_old);
                self.stats.num_g_evals += 1;
                break;
            }
        }
        if !terminal {
            std::mem::swap(&mut ev.g_old, &mut ev.g_new);
        }
        Ok(terminal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `y' = -y^2 + sin^2 t + cos t`, exact solution `y = sin t`.
    struct Sine;
    impl FirstOrderProblem for Sine {
        fn dim(&self) -> usize {
            1
        }
        fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) {
            dy[0] = -y[0] * y[0] + t.sin().powi(2) + t.cos();
        }
        fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
            j[0] = -2.0 * y[0];
            true
        }
    }

    /// `N` steps of order `k` and step `h = 1/N` from `t0 = 1` with the
    /// exact history `D_j = nabla^j y(t0)`; returns the errors at `t0 + 1`
    /// and of the dense output at the middle of the last step.
    fn frozen_run(formula: Formula, k: usize, n: usize) -> (f64, f64) {
        let (t0, h) = (1.0f64, 1.0 / n as f64);
        let opts = BdfOptions {
            rtol: 1e-12,
            atol: Tolerance::Scalar(1e-12),
            formula,
            max_order: k,
            max_newton_iterations: 20,
            ..BdfOptions::default()
        };
        let mut s = BdfSolver::new(Sine, t0, &[t0.sin()], opts).unwrap();
        // Backward differences of the exact values y(t0 - i h), i = 0..=k.
        let mut diff: Vec<f64> = (0..=k).map(|i| (t0 - i as f64 * h).sin()).collect();
        for j in 0..=k {
            s.d[j][0] = diff[0];
            for i in 0..k - j {
                diff[i] -= diff[i + 1];
            }
        }
        s.h = h;
        s.order = k;
        s.started = true;
        s.frozen = true;
        let t_end = t0 + 1.0;
        while s.t() < t_end - 0.5 * h {
            s.step(t_end + 1.0).unwrap();
        }
        assert!((s.t() - t_end).abs() < 1e-12 && s.order() == k);
        assert_eq!(s.stats().num_nonlin_solv_conv_fails, 0);
        let mut mid = [0.0];
        let tm = s.t() - 0.5 * h;
        s.interpolate(tm, &mut mid).unwrap();
        ((s.y()[0] - t_end.sin()).abs(), (mid[0] - tm.sin()).abs())
    }

    #[test]
    fn each_order_converges_with_its_order_and_so_does_the_dense_output() {
        for formula in [Formula::Bdf, Formula::Ndf] {
            for k in 1..=MAX_ORDER {
                let (e1, m1) = frozen_run(formula, k, 80);
                let (e2, m2) = frozen_run(formula, k, 160);
                let p = (e1 / e2).log2();
                let q = (m1 / m2).log2();
                assert!(
                    (p - k as f64).abs() < 0.3,
                    "{formula:?} order {k}: observed {p}"
                );
                assert!(
                    (q - k as f64).abs() < 0.4,
                    "{formula:?} order {k}: dense output {q}"
                );
            }
        }
    }

    /// `y' = A y` with a fixed non-symmetric `A` whose LU needs pivoting.
    struct Linear5;
    const A5: [[f64; 5]; 5] = [
        [0.0, 2.0, -1.0, 0.5, 3.0],
        [4.0, -1.0, 0.0, 2.0, 1.0],
        [-2.0, 3.0, 1.0, 0.0, -4.0],
        [1.0, 0.0, 5.0, -3.0, 2.0],
        [0.5, -2.0, 1.5, 1.0, 0.0],
    ];
    impl FirstOrderProblem for Linear5 {
        fn dim(&self) -> usize {
            5
        }
        fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
            for i in 0..5 {
                dy[i] = (0..5).map(|j| A5[i][j] * y[j]).sum();
            }
        }
        fn jacobian(&self, _t: f64, _y: &[f64], j: &mut [f64]) -> bool {
            for r in 0..5 {
                j[r * 5..r * 5 + 5].copy_from_slice(&A5[r]);
            }
            true
        }
    }

    #[test]
    fn the_dense_lu_solve_solves_the_newton_system() {
        // M = I - c A with c = 0.7 has a zero in no pivot position of A's
        // first column but needs row exchanges; the residual of the solve
        // of M x = b is at round-off.
        let mut s = BdfSolver::new(Linear5, 0.0, &[1.0; 5], BdfOptions::default()).unwrap();
        let c = 0.7;
        assert!(s.eval_jacobian(0.0).unwrap());
        assert!(s.factor(c).unwrap());
        let Matrices::Dense { perm, .. } = &s.mats else {
            panic!("dense")
        };
        assert!(perm.iter().enumerate().any(|(i, &p)| i != p), "pivoting");
        let b = [1.0, -2.0, 0.5, 3.0, -1.5];
        s.rhs.copy_from_slice(&b);
        s.solve_linear(0.0, c).unwrap();
        for i in 0..5 {
            let mx: f64 = (0..5)
                .map(|j| (if i == j { 1.0 } else { 0.0 } - c * A5[i][j]) * s.dy[j])
                .sum();
            assert!((mx - b[i]).abs() < 1e-13, "row {i}: {mx} vs {}", b[i]);
        }
    }

    #[test]
    fn rescaling_the_history_keeps_the_interpolating_polynomial() {
        // D of the cubic p(t) = t^3 on the grid 0, -1, -2, -3 (h = 1), then
        // re-interpolated onto h = 0.37: the new differences are those of p
        // on the grid 0, -0.37, -0.74, -1.11.
        let opts = BdfOptions::default();
        let mut s = BdfSolver::new(Sine, 0.0, &[0.0], opts).unwrap();
        let p = |t: f64| t.powi(3);
        let diffs = |h: f64| {
            let mut v: Vec<f64> = (0..4).map(|i| p(-(i as f64) * h)).collect();
            let mut d = vec![0.0; 4];
            for j in 0..4 {
                d[j] = v[0];
                for i in 0..3 - j {
                    v[i] -= v[i + 1];
                }
            }
            d
        };
        for (j, dj) in diffs(1.0).into_iter().enumerate() {
            s.d[j][0] = dj;
        }
        s.order = 3;
        s.h = 1.0;
        s.rescale(0.37);
        for (j, dj) in diffs(0.37).into_iter().enumerate() {
            assert!(
                (s.d[j][0] - dj).abs() < 1e-12,
                "D_{j}: {} vs {dj}",
                s.d[j][0]
            );
        }
        assert!((s.h - 0.37).abs() < 1e-15);
    }
}
