//! Newton's method and its variants: the tutorial's Algorithm 1 (Newton),
//! Algorithm 2 (inexact Newton with residual control, section 3.2) and
//! Algorithm 3 (inexact simplified Newton, section 3.3).

use std::time::Instant;

use hookean_sparse::vecops::norm2;
use hookean_sparse::{AmgOptions, NegativeCurvature, PrecondKind};

use crate::error::{DivergenceReason, NonlinearError, check_len, invalid};
use crate::linear::LinearSolver;
use crate::system::NonlinearSystem;

/// The golden ratio `(1 + sqrt 5) / 2`, the exponent of Eisenstat-Walker
/// choice 1 and of its safeguard.
const GOLDEN: f64 = 1.618_033_988_749_895;

/// How the forcing term `eta_k` of an inexact Newton method is chosen: the
/// linear solve of iteration `k` stops when `|J s_k + G(Y_k)| <= eta_k |G(Y_k)|`
/// (the tutorial's Algorithm 2, step 4).
///
/// The adaptive choices are those of Eisenstat and Walker (SIAM J. Sci.
/// Comput. 17, 1996) with the safeguards KINSOL documents; every `eta_k` is
/// then capped by [`NewtonOptions::eta_max`] and, for the adaptive choices,
/// raised to at least `0.5 tol / |G(Y_k)|` (Kelley's guard against
/// oversolving the last iteration, `tol = atol + rtol |G(Y_0)|`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ForcingTerm {
    /// A constant `eta` in `(0, 1)`; the tutorial uses `0.02` (section 3.2).
    Constant(f64),
    /// Eisenstat-Walker choice 1:
    /// `eta_k = | |G(Y_k)| - |G(Y_{k-1}) + J_{k-1} s_{k-1}| | / |G(Y_{k-1})|`,
    /// safeguarded by `eta_k >= eta_{k-1}^phi` when `eta_{k-1}^phi > 0.1`,
    /// `phi = (1 + sqrt 5) / 2`. Convergence is superlinear (q-order phi).
    EisenstatWalker1,
    /// Eisenstat-Walker choice 2: `eta_k = gamma (|G(Y_k)| / |G(Y_{k-1})|)^alpha`,
    /// safeguarded by `eta_k >= gamma eta_{k-1}^alpha` when that is `> 0.1`.
    /// KINSOL's defaults are `gamma = 0.9`, `alpha = 2`
    /// ([`ForcingTerm::EW2_DEFAULT`]).
    EisenstatWalker2 {
        /// Factor `gamma` in `(0, 1]`.
        gamma: f64,
        /// Exponent `alpha` in `(1, 2]`.
        alpha: f64,
    },
}

impl ForcingTerm {
    /// The tutorial's constant forcing term `eta = 0.02` (section 3.2).
    pub const TUTORIAL: Self = Self::Constant(0.02);
    /// Eisenstat-Walker choice 2 with KINSOL's `gamma = 0.9`, `alpha = 2`.
    pub const EW2_DEFAULT: Self = Self::EisenstatWalker2 {
        gamma: 0.9,
        alpha: 2.0,
    };

    fn validate(&self) -> Result<(), NonlinearError> {
        match *self {
            Self::Constant(eta) if !(eta > 0.0 && eta < 1.0) => Err(invalid(
                "ForcingTerm::Constant",
                format!("eta must lie in (0, 1), got {eta:?}"),
            )),
            Self::EisenstatWalker2 { gamma, alpha }
                if !(gamma > 0.0 && gamma <= 1.0 && alpha > 1.0 && alpha <= 2.0) =>
            {
                Err(invalid(
                    "ForcingTerm::EisenstatWalker2",
                    format!("need gamma in (0, 1] and alpha in (1, 2], got {gamma:?}, {alpha:?}"),
                ))
            }
            _ => Ok(()),
        }
    }
}

/// Which Newton variant [`Newton::solve`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NewtonMethod {
    /// Algorithm 1: the Jacobian is evaluated at every iterate and
    /// `J s = -G` is solved "exactly" (an iterative solver to
    /// [`NewtonOptions::linear_rtol`]). Quadratic convergence.
    Exact,
    /// Algorithm 2: Jacobian at every iterate, linear solves only to
    /// `|r_k| <= eta_k |G(Y_k)|` with the given forcing term.
    Inexact(ForcingTerm),
    /// Simplified Newton: the Jacobian of the first iterate is kept and
    /// solved exactly; it is re-evaluated at the current iterate when the
    /// contraction rate `theta_k = |s_k| / |s_{k-1}|` exceeds
    /// [`NewtonOptions::refresh_theta`], and kept across calls while the
    /// last solve contracted faster than [`NewtonOptions::keep_jacobian_theta`]
    /// and the caller does not call [`Newton::invalidate_jacobian`] (RADAU5's
    /// rule). A failure with a kept Jacobian is retried once with a fresh one.
    Simplified,
    /// Algorithm 3: the system's cheap approximate Jacobian
    /// ([`NonlinearSystem::approximate_jacobian`], for cloth the constant
    /// linearised Jacobian of eq. 50; the exact one at the first iterate if
    /// the system has none) is evaluated once and kept across calls until
    /// [`Newton::invalidate_jacobian`] (call it when `h` or the material
    /// changes); linear solves use the forcing term. If the system has no
    /// approximation, a failure with a kept Jacobian is retried once with a
    /// freshly evaluated one.
    InexactSimplified(ForcingTerm),
}

impl NewtonMethod {
    fn forcing(&self) -> Option<ForcingTerm> {
        match *self {
            Self::Inexact(f) | Self::InexactSimplified(f) => Some(f),
            _ => None,
        }
    }

    fn keeps_jacobian(&self) -> bool {
        matches!(self, Self::Simplified | Self::InexactSimplified(_))
    }
}

/// Options of [`Newton`]; every field has a documented default.
#[derive(Debug, Clone, PartialEq)]
pub struct NewtonOptions {
    /// The variant. Default [`NewtonMethod::Exact`].
    pub method: NewtonMethod,
    /// Converged when `|G(Y_k)| <= atol + rtol |G(Y_0)|` (Euclidean norms).
    /// Default `1e-12`.
    pub atol: f64,
    /// See [`atol`](Self::atol). Default `1e-8`.
    pub rtol: f64,
    /// Also converged when `|s_k| theta_k / (1 - theta_k) <= step_tol`
    /// (Hairer-Wanner, Solving ODEs II, section IV.8: an estimate of the
    /// remaining error `|Y_{k+1} - Y*|`), for `k >= 1` and `theta_k < 1`. `0` disables it.
    /// Default `0`.
    pub step_tol: f64,
    /// Newton iteration limit per solve. Default `50`.
    pub max_iter: usize,
    /// Relative tolerance of the linear solves of [`NewtonMethod::Exact`]
    /// and [`NewtonMethod::Simplified`] with an iterative solver. Default `1e-10`.
    pub linear_rtol: f64,
    /// First forcing term `eta_0` of the Eisenstat-Walker choices. Default `0.5`.
    pub eta_initial: f64,
    /// Upper bound `eta_max` of every adaptive forcing term. Default `0.9`.
    pub eta_max: f64,
    /// [`NewtonMethod::Simplified`] re-evaluates the Jacobian at the current
    /// iterate when `theta_k > refresh_theta`. Default `0.5`.
    pub refresh_theta: f64,
    /// [`NewtonMethod::Simplified`] keeps its Jacobian for the next call
    /// when the last contraction rate of a converged solve is at most this
    /// (RADAU5's `THET`, whose default is `0.001`). Default `0.001`.
    pub keep_jacobian_theta: f64,
    /// Diverged when `|G(Y_k)| > max_residual_growth |G(Y_0)|`. Default `1e6`.
    pub max_residual_growth: f64,
    /// Iteration limit of each iterative linear solve ([`PcgSolver`](crate::PcgSolver));
    /// `None` means `2 n`. Default `None`.
    pub linear_max_iter: Option<usize>,
    /// The preconditioner of a [`PcgSolver`](crate::PcgSolver) over
    /// [`AnyPreconditioner`](hookean_sparse::AnyPreconditioner) (the integrators of `hookean-ode` use one);
    /// solvers with a fixed preconditioner type ignore it. Default block-Jacobi.
    pub preconditioner: PrecondKind,
    /// The multigrid's options when `preconditioner` is [`PrecondKind::Amg`]
    /// (including what every `setup` of a new Jacobian does: refill, keep,
    /// rebuild). Default [`AmgOptions::default`].
    pub amg: AmgOptions,
    /// What a [`PcgSolver`](crate::PcgSolver) does on a direction of
    /// non-positive curvature: fail the solve (the Newton iteration stops,
    /// default), or truncate it and take the iterate so far as the Newton
    /// correction, shortened by a backtracking line search until `|G|`
    /// falls ([`NegativeCurvature::Truncate`], Newton-CG), which lets Newton
    /// use an exact Jacobian that is indefinite (compressed springs:
    /// `model.clamp_stiffness = false`). The preconditioner must stay
    /// positive definite (MIC(0)'s shift keeps it so).
    pub negative_curvature: NegativeCurvature,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self {
            method: NewtonMethod::Exact,
            atol: 1e-12,
            rtol: 1e-8,
            step_tol: 0.0,
            max_iter: 50,
            linear_rtol: 1e-10,
            eta_initial: 0.5,
            eta_max: 0.9,
            refresh_theta: 0.5,
            keep_jacobian_theta: 1e-3,
            max_residual_growth: 1e6,
            linear_max_iter: None,
            preconditioner: PrecondKind::BlockJacobi,
            amg: AmgOptions::default(),
            negative_curvature: NegativeCurvature::Error,
        }
    }
}

impl NewtonOptions {
    /// Options with the given method and the other defaults.
    pub fn with_method(method: NewtonMethod) -> Self {
        Self {
            method,
            ..Self::default()
        }
    }

    /// Checks every field's range.
    ///
    /// # Errors
    /// [`NonlinearError::InvalidParameter`] naming the first bad field.
    pub fn validate(&self) -> Result<(), NonlinearError> {
        let nonneg = |name, v: f64| {
            if v >= 0.0 && v.is_finite() {
                Ok(())
            } else {
                Err(invalid(name, format!("must be finite and >= 0, got {v:?}")))
            }
        };
        nonneg("atol", self.atol)?;
        nonneg("rtol", self.rtol)?;
        nonneg("step_tol", self.step_tol)?;
        nonneg("keep_jacobian_theta", self.keep_jacobian_theta)?;
        if self.max_iter == 0 {
            return Err(invalid("max_iter", "must be at least 1"));
        }
        if !(self.linear_rtol >= 0.0 && self.linear_rtol < 1.0) {
            return Err(invalid(
                "linear_rtol",
                format!("must lie in [0, 1), got {:?}", self.linear_rtol),
            ));
        }
        for (name, v) in [("eta_initial", self.eta_initial), ("eta_max", self.eta_max)] {
            if !(v > 0.0 && v < 1.0) {
                return Err(invalid(name, format!("must lie in (0, 1), got {v:?}")));
            }
        }
        if !(self.refresh_theta > 0.0) {
            return Err(invalid(
                "refresh_theta",
                format!("must be > 0, got {:?}", self.refresh_theta),
            ));
        }
        if !(self.max_residual_growth > 1.0) {
            return Err(invalid(
                "max_residual_growth",
                format!("must be > 1, got {:?}", self.max_residual_growth),
            ));
        }
        if let Some(f) = self.method.forcing() {
            f.validate()?;
        }
        Ok(())
    }
}

/// Which test declared convergence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConvergedBy {
    /// `|G(Y_k)| <= atol + rtol |G(Y_0)|`.
    Residual,
    /// `|s_k| theta_k / (1 - theta_k) <= step_tol`.
    Step,
}

/// Statistics of one [`Newton::solve`] call (plain counters and histories).
///
/// Histories hold one entry per evaluation, in order; they include the
/// attempt that failed when a kept Jacobian was refreshed and the solve
/// restarted ([`restarts`](Self::restarts)).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NewtonStats {
    /// Newton iterations (linear solves and updates `Y <- Y + s`).
    pub iterations: usize,
    /// Evaluations of `G`.
    pub residual_evaluations: usize,
    /// Evaluations of the Jacobian (exact or approximate).
    pub jacobian_evaluations: usize,
    /// Linear-solver setups (factorisations, preconditioner setups).
    pub linear_setups: usize,
    /// Linear iterations in total (CG iterations; 0 for direct solvers).
    pub linear_iterations: usize,
    /// `|G(Y_k)|` for `k = 0, 1, ...`.
    pub residual_norms: Vec<f64>,
    /// `|s_k|` for `k = 0, 1, ...`.
    pub step_norms: Vec<f64>,
    /// The forcing terms `eta_k` handed to the linear solver (empty for
    /// direct solvers; `linear_rtol` for the exact variants).
    pub forcing_terms: Vec<f64>,
    /// The last contraction rate `theta_k = |s_k| / |s_{k-1}|` (`None`
    /// before the second iteration): the convergence rate estimate.
    pub contraction_rate: Option<f64>,
    /// Which test stopped the iteration (`None` unless converged).
    pub converged_by: Option<ConvergedBy>,
    /// Whether the solve started with a Jacobian kept from an earlier call.
    pub jacobian_reused: bool,
    /// Restarts from `Y_0` with a fresh Jacobian after a failure with a kept one.
    pub restarts: usize,
    /// Linear solves truncated on a direction of non-positive curvature
    /// ([`NewtonOptions::negative_curvature`]) whose iterate so far was
    /// taken as the correction, with a backtracking line search on `|G|`.
    pub truncated_solves: usize,
    /// Wall time of the Jacobian evaluations (assembly), seconds.
    pub jacobian_seconds: f64,
    /// Wall time of the linear solver's set-ups (factorisations,
    /// preconditioner set-ups), seconds.
    pub setup_seconds: f64,
    /// Wall time of the linear solves, seconds.
    pub solve_seconds: f64,
}

impl NewtonStats {
    /// Room for `n` iterations, at most 16: the histories grow as they go,
    /// so an iteration limit of 10^9 does not reserve 10^9 entries.
    fn with_capacity(n: usize) -> Self {
        let n = n.min(16);
        Self {
            residual_norms: Vec::with_capacity(n + 1),
            step_norms: Vec::with_capacity(n),
            forcing_terms: Vec::with_capacity(n),
            ..Self::default()
        }
    }

    /// The last residual norm `|G(Y_k)|` (NaN if none was computed).
    pub fn final_residual(&self) -> f64 {
        self.residual_norms.last().copied().unwrap_or(f64::NAN)
    }

    /// `|G(Y_0)|` (NaN if none was computed).
    pub fn initial_residual(&self) -> f64 {
        self.residual_norms.first().copied().unwrap_or(f64::NAN)
    }

    /// Whether the solve converged.
    pub fn converged(&self) -> bool {
        self.converged_by.is_some()
    }
}

/// Why one attempt stopped without converging (wrapped with the statistics
/// into a [`NonlinearError`] by [`Newton::solve`]).
enum Stop {
    Diverged(DivergenceReason),
    MaxIterations,
    NonFinite,
    LinearNotConverged {
        iterations: usize,
        tolerance: f64,
        relative_residual: f64,
    },
    Other(NonlinearError),
}

impl From<NonlinearError> for Stop {
    fn from(e: NonlinearError) -> Self {
        Stop::Other(e)
    }
}

impl Stop {
    fn into_error(self, stats: NewtonStats) -> NonlinearError {
        let stats = Box::new(stats);
        match self {
            Stop::Diverged(reason) => NonlinearError::Diverged { reason, stats },
            Stop::MaxIterations => NonlinearError::MaxIterations { stats },
            Stop::NonFinite => NonlinearError::NonFinite { stats },
            Stop::LinearNotConverged {
                iterations,
                tolerance,
                relative_residual,
            } => NonlinearError::LinearNotConverged {
                iterations,
                tolerance,
                relative_residual,
                stats,
            },
            Stop::Other(e) => e,
        }
    }

    fn retry_with_fresh_jacobian(&self) -> bool {
        !matches!(self, Stop::Other(_))
    }
}

/// A reusable Newton solver: options, the Jacobian's storage `J`, a linear
/// solver `L` and the work vectors. Once warmed up (first call at a given
/// dimension), iterations with [`PcgSolver`](crate::PcgSolver) allocate
/// nothing (faer's LU factorisations allocate their factors at each
/// setup); a call allocates only the statistics' history vectors.
///
/// ```
/// use hookean_nonlinear::*;
///
/// // G(y) = y^2 - 2, root sqrt(2), with a 1x1 dense Jacobian.
/// struct Sqrt2;
/// impl NonlinearSystem for Sqrt2 {
///     type Jacobian = faer::Mat<f64>;
///     fn dim(&self) -> usize { 1 }
///     fn residual(&mut self, y: &[f64], g: &mut [f64]) -> Result<(), NonlinearError> {
///         g[0] = y[0] * y[0] - 2.0;
///         Ok(())
///     }
///     fn jacobian(&mut self, y: &[f64], j: &mut faer::Mat<f64>) -> Result<(), NonlinearError> {
///         j[(0, 0)] = 2.0 * y[0];
///         Ok(())
///     }
/// }
/// let options = NewtonOptions { rtol: 1e-12, ..NewtonOptions::default() };
/// let mut newton = Newton::new(options, faer::Mat::zeros(1, 1), DenseLu::new())?;
/// let mut y = [1.0];
/// let stats = newton.solve(&mut Sqrt2, &mut y)?;
/// assert!((y[0] - 2f64.sqrt()).abs() < 1e-12);
/// assert!(stats.iterations <= 6);
/// # Ok::<(), NonlinearError>(())
/// ```
#[derive(Debug)]
pub struct Newton<J, L> {
    options: NewtonOptions,
    jacobian: J,
    linear: L,
    g: Vec<f64>,
    s: Vec<f64>,
    rhs: Vec<f64>,
    y0: Vec<f64>,
    /// A Jacobian kept for the next call (simplified variants).
    jacobian_valid: bool,
    /// Whether the Jacobian storage holds the system's approximation.
    approximated: bool,
}

impl<J, L: LinearSolver<J>> Newton<J, L> {
    /// A solver with the given options, Jacobian storage (e.g. a
    /// `SymBlockMatrix` on the system's pattern, or `faer::Mat::zeros(n, n)`)
    /// and linear solver.
    ///
    /// # Errors
    /// [`NonlinearError::InvalidParameter`] for out-of-range options.
    pub fn new(options: NewtonOptions, jacobian: J, mut linear: L) -> Result<Self, NonlinearError> {
        options.validate()?;
        linear.configure(&options)?;
        Ok(Self {
            options,
            jacobian,
            linear,
            g: Vec::new(),
            s: Vec::new(),
            rhs: Vec::new(),
            y0: Vec::new(),
            jacobian_valid: false,
            approximated: false,
        })
    }

    /// The options.
    pub fn options(&self) -> &NewtonOptions {
        &self.options
    }

    /// Replaces the options (the kept Jacobian is invalidated if the method changes).
    ///
    /// # Errors
    /// [`NonlinearError::InvalidParameter`] for out-of-range options.
    pub fn set_options(&mut self, options: NewtonOptions) -> Result<(), NonlinearError> {
        options.validate()?;
        if options.method != self.options.method {
            self.jacobian_valid = false;
        }
        self.linear.configure(&options)?;
        self.options = options;
        Ok(())
    }

    /// Tells the solver that a kept Jacobian is stale (the step size, the
    /// material or the problem changed): the next call evaluates a new one.
    pub fn invalidate_jacobian(&mut self) {
        self.jacobian_valid = false;
    }

    /// Whether the next call will reuse a kept Jacobian.
    pub fn jacobian_is_kept(&self) -> bool {
        self.jacobian_valid
    }

    /// The Jacobian storage (the last matrix evaluated).
    pub fn jacobian(&self) -> &J {
        &self.jacobian
    }

    /// The linear solver.
    pub fn linear_solver(&self) -> &L {
        &self.linear
    }

    /// The linear solver, e.g. to refill its constraints between steps.
    pub fn linear_solver_mut(&mut self) -> &mut L {
        &mut self.linear
    }

    /// The last residual `G(Y)` computed (at the returned iterate after a
    /// successful solve).
    pub fn residual(&self) -> &[f64] {
        &self.g
    }

    /// Solves `system(y) = 0`, starting from and overwriting `y`.
    ///
    /// On success `y` holds the converged iterate. On an iteration failure
    /// (the error's [`is_step_failure`](NonlinearError::is_step_failure) is
    /// true) `y` holds the last iterate, which the caller should discard.
    ///
    /// # Errors
    /// [`NonlinearError::Diverged`], [`NonlinearError::MaxIterations`],
    /// [`NonlinearError::NonFinite`], [`NonlinearError::LinearNotConverged`]
    /// (all with the statistics so far); errors of the system and of the
    /// linear solver as they come; [`NonlinearError::DimensionMismatch`].
    pub fn solve<S>(&mut self, system: &mut S, y: &mut [f64]) -> Result<NewtonStats, NonlinearError>
    where
        S: NonlinearSystem<Jacobian = J> + ?Sized,
    {
        let n = system.dim();
        check_len("iterate y", y, n)?;
        if self.g.len() != n {
            self.g = vec![0.0; n];
            self.s = vec![0.0; n];
            self.rhs = vec![0.0; n];
            self.y0 = vec![0.0; n];
            self.jacobian_valid = false;
        }
        let mut stats = NewtonStats::with_capacity(self.options.max_iter);
        if y.iter().any(|v| !v.is_finite()) {
            return Err(NonlinearError::NonFinite {
                stats: Box::new(stats),
            });
        }
        let keeps = self.options.method.keeps_jacobian();
        let reuse = keeps && self.jacobian_valid;
        stats.jacobian_reused = reuse;
        if reuse {
            self.y0.copy_from_slice(y);
        }
        let mut outcome = self.attempt(system, y, &mut stats, reuse);
        if let Err(stop) = &outcome
            && reuse
            && !self.approximated
            && stop.retry_with_fresh_jacobian()
        {
            // RADAU5: a failure with an old Jacobian is retried with a new one
            // (not for a state-independent approximation: it would not change).
            y.copy_from_slice(&self.y0);
            stats.restarts += 1;
            outcome = self.attempt(system, y, &mut stats, false);
        }
        match outcome {
            Ok(fresh_or_kept) => {
                self.jacobian_valid = match self.options.method {
                    NewtonMethod::Exact | NewtonMethod::Inexact(_) => false,
                    NewtonMethod::Simplified => {
                        fresh_or_kept
                            && stats.contraction_rate.unwrap_or(0.0)
                                <= self.options.keep_jacobian_theta
                    }
                    NewtonMethod::InexactSimplified(_) => fresh_or_kept,
                };
                Ok(stats)
            }
            Err(stop) => {
                self.jacobian_valid = false;
                Err(stop.into_error(stats))
            }
        }
    }

    /// Evaluates the (approximate) Jacobian at `y` and sets up the linear solver.
    fn evaluate_jacobian<S>(
        &mut self,
        system: &mut S,
        y: &[f64],
        stats: &mut NewtonStats,
        approximate: bool,
    ) -> Result<(), NonlinearError>
    where
        S: NonlinearSystem<Jacobian = J> + ?Sized,
    {
        self.approximated = false;
        let start = Instant::now();
        let approximated = approximate && system.approximate_jacobian(y, &mut self.jacobian)?;
        if !approximated {
            system.jacobian(y, &mut self.jacobian)?;
        }
        self.approximated = approximated;
        stats.jacobian_evaluations += 1;
        let assembled = Instant::now();
        stats.jacobian_seconds += (assembled - start).as_secs_f64();
        let setup = self.linear.setup(&self.jacobian);
        stats.setup_seconds += assembled.elapsed().as_secs_f64();
        setup?;
        stats.linear_setups += 1;
        Ok(())
    }

    /// One Newton run from `y`. Returns whether a Jacobian was evaluated or
    /// reused (so that it can be kept for the next call).
    fn attempt<S>(
        &mut self,
        system: &mut S,
        y: &mut [f64],
        stats: &mut NewtonStats,
        use_kept: bool,
    ) -> Result<bool, Stop>
    where
        S: NonlinearSystem<Jacobian = J> + ?Sized,
    {
        let opts = self.options.clone();
        let direct = self.linear.is_direct();
        let forcing = opts.method.forcing();

        system.residual(y, &mut self.g)?;
        stats.residual_evaluations += 1;
        let mut gnorm = norm2(&self.g);
        stats.residual_norms.push(gnorm);
        if !gnorm.is_finite() {
            return Err(Stop::NonFinite);
        }
        let g0 = gnorm;
        let tol = opts.atol + opts.rtol * g0;
        if gnorm <= tol {
            stats.converged_by = Some(ConvergedBy::Residual);
            return Ok(use_kept);
        }

        let approximate = matches!(opts.method, NewtonMethod::InexactSimplified(_));
        if !use_kept {
            self.evaluate_jacobian(system, y, stats, approximate)?;
        }

        let mut snorm_prev: Option<f64> = None;
        let mut theta_ge_one = 0usize;
        // Forcing-term state: eta_{k-1}, |G(Y_{k-1})|, |G(Y_{k-1}) + J s_{k-1}|.
        let mut eta_prev = opts.eta_initial;
        let mut gnorm_prev = f64::NAN;
        let mut linres_prev = f64::NAN;

        for k in 0..opts.max_iter {
            let eta = match forcing {
                None => opts.linear_rtol,
                Some(f) => forcing_term(f, k, &opts, gnorm, gnorm_prev, linres_prev, eta_prev, tol),
            };
            for (r, g) in self.rhs.iter_mut().zip(&self.g) {
                *r = -g;
            }
            self.s.fill(0.0);
            let start = Instant::now();
            let lin = self
                .linear
                .solve(&self.jacobian, &self.rhs, &mut self.s, eta);
            stats.solve_seconds += start.elapsed().as_secs_f64();
            let lin = lin?;
            stats.linear_iterations += lin.iterations;
            if !direct {
                stats.forcing_terms.push(eta);
            }
            if lin.truncated {
                stats.truncated_solves += 1;
            } else if !lin.converged {
                return Err(Stop::LinearNotConverged {
                    iterations: lin.iterations,
                    tolerance: eta,
                    relative_residual: lin.relative_residual,
                });
            }
            let snorm = norm2(&self.s);
            if !snorm.is_finite() {
                return Err(Stop::NonFinite);
            }
            for (yi, si) in y.iter_mut().zip(&self.s) {
                *yi += si;
            }
            stats.iterations += 1;
            stats.step_norms.push(snorm);

            gnorm_prev = gnorm;
            linres_prev = if direct { 0.0 } else { lin.residual_norm };
            eta_prev = eta;

            system.residual(y, &mut self.g)?;
            stats.residual_evaluations += 1;
            gnorm = norm2(&self.g);
            // A truncated solve's correction is a descent direction of the
            // local quadratic model, not a Newton step: backtrack (halve it)
            // until the residual decreases (Armijo on |G|).
            let mut lambda = 1.0;
            if lin.truncated {
                while !(gnorm <= (1.0 - 1e-4 * lambda) * gnorm_prev) && lambda > 1.0 / 64.0 {
                    lambda *= 0.5;
                    for (yi, si) in y.iter_mut().zip(&self.s) {
                        *yi -= lambda * si;
                    }
                    system.residual(y, &mut self.g)?;
                    stats.residual_evaluations += 1;
                    gnorm = norm2(&self.g);
                }
                if lambda < 1.0
                    && let Some(last) = stats.step_norms.last_mut()
                {
                    *last *= lambda;
                }
            }
            let snorm = lambda * snorm;
            let theta = match snorm_prev {
                Some(p) if p > 0.0 => Some(snorm / p),
                _ => None,
            };
            if theta.is_some() {
                stats.contraction_rate = theta;
            }
            stats.residual_norms.push(gnorm);
            if !gnorm.is_finite() {
                return Err(Stop::NonFinite);
            }
            if gnorm <= tol {
                stats.converged_by = Some(ConvergedBy::Residual);
                return Ok(true);
            }
            if let Some(th) = theta
                && opts.step_tol > 0.0
                && th < 1.0
                && snorm * th / (1.0 - th) <= opts.step_tol
            {
                stats.converged_by = Some(ConvergedBy::Step);
                return Ok(true);
            }
            if let Some(th) = theta {
                if th >= 1.0 {
                    theta_ge_one += 1;
                    if theta_ge_one >= 2 {
                        return Err(Stop::Diverged(DivergenceReason::Contraction { theta: th }));
                    }
                } else {
                    theta_ge_one = 0;
                }
            }
            if gnorm > opts.max_residual_growth * g0 {
                return Err(Stop::Diverged(DivergenceReason::ResidualGrowth {
                    ratio: gnorm / g0,
                }));
            }
            if k + 1 == opts.max_iter {
                break;
            }
            match opts.method {
                NewtonMethod::Exact | NewtonMethod::Inexact(_) => {
                    self.evaluate_jacobian(system, y, stats, false)?;
                }
                NewtonMethod::Simplified => {
                    if theta.is_some_and(|th| th > opts.refresh_theta) {
                        self.evaluate_jacobian(system, y, stats, false)?;
                    }
                }
                NewtonMethod::InexactSimplified(_) => {}
            }
            snorm_prev = Some(snorm);
        }
        Err(Stop::MaxIterations)
    }
}

/// The forcing term `eta_k` (see [`ForcingTerm`]).
#[allow(clippy::too_many_arguments)]
fn forcing_term(
    f: ForcingTerm,
    k: usize,
    opts: &NewtonOptions,
    gnorm: f64,
    gnorm_prev: f64,
    linres_prev: f64,
    eta_prev: f64,
    tol: f64,
) -> f64 {
    let eta = match f {
        ForcingTerm::Constant(eta) => return eta,
        _ if k == 0 => opts.eta_initial,
        ForcingTerm::EisenstatWalker1 => {
            let mut eta = (gnorm - linres_prev).abs() / gnorm_prev;
            let safe = eta_prev.powf(GOLDEN);
            if safe > 0.1 {
                eta = eta.max(safe);
            }
            eta
        }
        ForcingTerm::EisenstatWalker2 { gamma, alpha } => {
            let mut eta = gamma * (gnorm / gnorm_prev).powf(alpha);
            let safe = gamma * eta_prev.powf(alpha);
            if safe > 0.1 {
                eta = eta.max(safe);
            }
            eta
        }
    };
    let eta = eta.min(opts.eta_max);
    // Kelley: do not oversolve the last linear system.
    eta.max(0.5 * tol / gnorm).min(opts.eta_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forcing_terms_follow_eisenstat_walker_with_safeguards() {
        let opts = NewtonOptions::default();
        // First iteration: eta_initial.
        assert_eq!(
            forcing_term(
                ForcingTerm::EW2_DEFAULT,
                0,
                &opts,
                1.0,
                f64::NAN,
                f64::NAN,
                0.5,
                0.0
            ),
            0.5
        );
        // Choice 2: gamma (|G_k|/|G_{k-1}|)^alpha = 0.9 * 0.01 = 0.009, but the
        // safeguard gamma eta_prev^alpha = 0.9 * 0.25 = 0.225 > 0.1 wins.
        let e = forcing_term(ForcingTerm::EW2_DEFAULT, 1, &opts, 0.1, 1.0, 0.0, 0.5, 0.0);
        approx::assert_abs_diff_eq!(e, 0.225, epsilon = 1e-15);
        // With eta_prev = 0.3 the safeguard is 0.081 < 0.1: not applied.
        let e = forcing_term(ForcingTerm::EW2_DEFAULT, 1, &opts, 0.1, 1.0, 0.0, 0.3, 0.0);
        approx::assert_abs_diff_eq!(e, 0.009, epsilon = 1e-15);
        // Choice 1: | |G_k| - |lin res| | / |G_{k-1}| = |0.1 - 0.05| / 1 = 0.05;
        // safeguard 0.3^phi = 0.1431 > 0.1 wins.
        let e = forcing_term(
            ForcingTerm::EisenstatWalker1,
            2,
            &opts,
            0.1,
            1.0,
            0.05,
            0.3,
            0.0,
        );
        approx::assert_abs_diff_eq!(e, 0.3f64.powf(GOLDEN), epsilon = 1e-15);
        let e = forcing_term(
            ForcingTerm::EisenstatWalker1,
            2,
            &opts,
            0.1,
            1.0,
            0.05,
            0.2,
            0.0,
        );
        approx::assert_abs_diff_eq!(e, 0.05, epsilon = 1e-15);
        // eta_max caps: |G| grew.
        let e = forcing_term(ForcingTerm::EW2_DEFAULT, 1, &opts, 3.0, 1.0, 0.0, 0.2, 0.0);
        assert_eq!(e, 0.9);
        // Kelley's oversolving guard: 0.5 tol / |G_k| = 0.5 * 1e-3 / 1e-3 = 0.5.
        let e = forcing_term(
            ForcingTerm::EW2_DEFAULT,
            1,
            &opts,
            1e-3,
            1.0,
            0.0,
            0.2,
            1e-3,
        );
        assert_eq!(e, 0.5);
        // Constant is constant.
        assert_eq!(
            forcing_term(ForcingTerm::TUTORIAL, 5, &opts, 1e-3, 1.0, 0.0, 0.2, 1e-3),
            0.02
        );
    }

    #[test]
    fn options_are_validated() {
        assert!(NewtonOptions::default().validate().is_ok());
        let bad = [
            NewtonOptions {
                rtol: -1.0,
                ..Default::default()
            },
            NewtonOptions {
                max_iter: 0,
                ..Default::default()
            },
            NewtonOptions {
                linear_rtol: 1.0,
                ..Default::default()
            },
            NewtonOptions {
                eta_max: 1.0,
                ..Default::default()
            },
            NewtonOptions::with_method(NewtonMethod::Inexact(ForcingTerm::Constant(1.5))),
            NewtonOptions::with_method(NewtonMethod::Inexact(ForcingTerm::EisenstatWalker2 {
                gamma: 0.9,
                alpha: 3.0,
            })),
            NewtonOptions {
                atol: f64::NAN,
                ..Default::default()
            },
        ];
        for o in bad {
            assert!(
                matches!(o.validate(), Err(NonlinearError::InvalidParameter { .. })),
                "{o:?}"
            );
        }
    }
}
