//! [`Newton`]: the iteration of the tutorial's Algorithms 1-3 (Newton,
//! inexact Newton with residual control, inexact simplified Newton) and the
//! simplified Newton of stiff ODE solvers with CVODE's rate-based test.

use std::time::Instant;

use hookean_sparse::vecops::{negate_into, norm2};

use crate::convergence::{Convergence, RateEstimate, RateVerdict};
use crate::error::{DivergenceReason, NonlinearError, check_len};
use crate::forcing::forcing_term;
use crate::linear::LinearSolver;
use crate::options::{NewtonMethod, NewtonOptions};
use crate::stats::{ConvergedBy, NewtonStats};
use crate::system::NonlinearSystem;

/// A reusable Newton solver: options, the Jacobian's storage `J`, a linear
/// solver `L` and the work vectors. Once warmed up (first call at a given
/// dimension), a call allocates nothing with [`PcgSolver`](crate::PcgSolver)
/// or [`DenseLu`](crate::DenseLu) (faer's sparse LU allocates its factors at
/// each setup), unless the histories are recorded
/// ([`NewtonOptions::record_history`]).
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
    /// The weights of the norm of [`Convergence::Rate`].
    weights: Vec<f64>,
    /// The carried contraction rate of [`Convergence::Rate`] (CVODE's `crate`).
    rate: RateEstimate,
    /// A Jacobian kept for the next call (simplified variants).
    jacobian_valid: bool,
    /// Whether the Jacobian storage holds the system's approximation.
    approximated: bool,
    /// Whether to clock the phases into [`NewtonStats`] (see [`Newton::time_phases`]).
    timed: bool,
}

impl<J, L: LinearSolver<J>> Newton<J, L> {
    /// A solver with the given options, Jacobian storage (e.g. a
    /// `SymBlockMatrix` on the system's pattern, or `faer::Mat::zeros(n, n)`)
    /// and linear solver.
    ///
    /// # Errors
    /// [`NonlinearError::InvalidParameter`] for out-of-range options.
    pub fn new(options: NewtonOptions, jacobian: J, linear: L) -> Result<Self, NonlinearError> {
        options.validate()?;
        Ok(Self {
            options,
            jacobian,
            linear,
            g: Vec::new(),
            s: Vec::new(),
            rhs: Vec::new(),
            y0: Vec::new(),
            weights: Vec::new(),
            rate: RateEstimate::default(),
            jacobian_valid: false,
            approximated: false,
            timed: false,
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
        self.options = options;
        Ok(())
    }

    /// Tells the solver that a kept Jacobian is stale (the step size, the
    /// material or the problem changed): the next call evaluates a new one.
    pub fn invalidate_jacobian(&mut self) {
        self.jacobian_valid = false;
    }

    /// The weights `w_i` of the norm of [`Convergence::Rate`], to be filled
    /// by the caller before a solve (length `n`, all positive).
    pub fn weights_mut(&mut self, n: usize) -> &mut [f64] {
        self.weights.resize(n, 1.0);
        &mut self.weights
    }

    /// The contraction rate estimate carried by [`Convergence::Rate`]
    /// (1 after a set-up of the linear solver).
    pub fn rate_estimate(&self) -> f64 {
        self.rate.rate
    }

    /// What one call leaves for the next, besides a kept Jacobian: the
    /// carried contraction rate of [`Convergence::Rate`] and whether a
    /// Jacobian is kept (`[rate, has known rate, known rate, kept]`), for a
    /// checkpoint. (The forcing terms start afresh at every call.)
    pub fn carried_state(&self) -> [f64; 4] {
        let flag = |b: bool| f64::from(u8::from(b));
        [
            self.rate.rate,
            flag(self.rate.known.is_some()),
            self.rate.known.unwrap_or(0.0),
            flag(self.jacobian_valid),
        ]
    }

    /// Restores [`carried_state`](Self::carried_state) (a kept Jacobian
    /// is not restored: the next call evaluates one).
    pub fn set_carried_state(&mut self, state: [f64; 4]) {
        self.rate.rate = state[0];
        self.rate.known = (state[1] == 1.0).then_some(state[2]);
        self.jacobian_valid = false;
    }

    /// Whether the Jacobian storage holds the system's approximation
    /// ([`NonlinearSystem::approximate_jacobian`](crate::NonlinearSystem::approximate_jacobian)) rather than its
    /// Jacobian: with a kept Jacobian ([`jacobian_is_kept`](Self::jacobian_is_kept)), what a
    /// failure with it may retry (for a checkpoint).
    pub fn jacobian_is_approximated(&self) -> bool {
        self.approximated
    }

    /// Makes the Jacobian storage the kept Jacobian of the next call, as
    /// if a call of a system of `n` unknowns had evaluated it
    /// (`approximated`: [`jacobian_is_approximated`](Self::jacobian_is_approximated)) and kept it: `fill`
    /// writes the matrix, then the linear solver is set up on it when
    /// `setup` (not when the caller restored that set-up itself). How a
    /// checkpoint restores a simplified Newton's kept Jacobian; call it
    /// after [`set_carried_state`](Self::set_carried_state).
    ///
    /// # Errors
    /// The linear solver's set-up error (nothing is kept then).
    pub fn keep_jacobian(
        &mut self,
        n: usize,
        approximated: bool,
        setup: bool,
        fill: impl FnOnce(&mut J),
    ) -> Result<(), NonlinearError> {
        self.jacobian_valid = false;
        if self.g.len() != n {
            self.g = vec![0.0; n];
            self.s = vec![0.0; n];
            self.rhs = vec![0.0; n];
            self.y0 = vec![0.0; n];
        }
        fill(&mut self.jacobian);
        if setup {
            self.linear.setup(&self.jacobian)?;
        }
        self.approximated = approximated;
        self.jacobian_valid = true;
        Ok(())
    }

    /// Tells [`Convergence::Rate`] the contraction rate of the next calls'
    /// iterations when the caller knows it (`None`: measure it): `Some(0.0)`
    /// for a linear system solved with its exact Newton matrix, whose first
    /// correction then converges without a second iteration to measure it.
    pub fn set_known_rate(&mut self, rate: Option<f64>) {
        self.rate.known = rate;
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
        if n == 0 {
            return Err(NonlinearError::InvalidParameter {
                name: "system",
                message: "it has no unknowns (dim = 0): there is nothing to solve".into(),
            });
        }
        check_len("iterate y", y, n)?;
        if self.g.len() != n {
            self.g = vec![0.0; n];
            self.s = vec![0.0; n];
            self.rhs = vec![0.0; n];
            self.y0 = vec![0.0; n];
            self.jacobian_valid = false;
        }
        if matches!(self.options.convergence, Convergence::Rate { .. }) {
            check_len("weights (Newton::weights_mut)", &self.weights, n)?;
        }
        let mut stats = NewtonStats::new(self.options.max_iter, self.options.record_history);
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
            && self.options.retry_fresh
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

    /// Clocks the phases of every solve (Jacobian evaluation, linear-solver
    /// set-up, linear solves) into [`NewtonStats`]' `*_seconds`: three clock
    /// reads per iteration, worth it on systems whose iterations take
    /// milliseconds (cloth), not on stiff systems of a few unknowns. Off by
    /// default.
    pub fn time_phases(&mut self, on: bool) {
        self.timed = on;
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
        let start = self.timed.then(Instant::now);
        let approximated = approximate && system.approximate_jacobian(y, &mut self.jacobian)?;
        if !approximated {
            system.jacobian(y, &mut self.jacobian)?;
        }
        self.approximated = approximated;
        stats.jacobian_evaluations += 1;
        let assembled = start.map(|s| {
            stats.jacobian_seconds += s.elapsed().as_secs_f64();
            Instant::now()
        });
        let setup = self.linear.setup(&self.jacobian);
        if let Some(a) = assembled {
            stats.setup_seconds += a.elapsed().as_secs_f64();
        }
        setup?;
        stats.linear_setups += 1;
        self.rate.reset();
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
        let opts = self.options;
        if let Convergence::Rate { tol } = opts.convergence {
            return self.attempt_rate(system, y, stats, use_kept, tol);
        }
        let direct = self.linear.is_direct();
        let forcing = opts.method.forcing();

        system.residual(y, &mut self.g)?;
        stats.residual_evaluations += 1;
        let mut gnorm = norm2(&self.g);
        stats.push_residual(gnorm);
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
            negate_into(&self.g, &mut self.rhs);
            let lin = self.timed_linear_solve(system, y, eta, stats)?;
            stats.linear_iterations += lin.iterations;
            if !direct {
                stats.push_forcing(eta);
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
            stats.push_step(snorm);

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
                if lambda < 1.0 {
                    stats.scale_last_step(lambda);
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
            stats.push_residual(gnorm);
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

    /// One run of simplified Newton with [`Convergence::Rate`] from `y` (see
    /// there): the residual is evaluated at the start and after every
    /// correction that does not end the iteration, the corrections are
    /// measured in the weighted norm; `|G|` is never formed (the residual
    /// norms of the statistics stay NaN). Returns whether a Jacobian was
    /// evaluated or reused.
    fn attempt_rate<S>(
        &mut self,
        system: &mut S,
        y: &mut [f64],
        stats: &mut NewtonStats,
        use_kept: bool,
        tol: f64,
    ) -> Result<bool, Stop>
    where
        S: NonlinearSystem<Jacobian = J> + ?Sized,
    {
        let max_iter = self.options.max_iter;
        let eta = self.options.linear_rtol;
        system.residual(y, &mut self.g)?;
        stats.residual_evaluations += 1;
        if !self.g.iter().all(|v| v.is_finite()) {
            return Err(Stop::NonFinite);
        }
        if !use_kept {
            self.evaluate_jacobian(system, y, stats, false)?;
        }
        let mut previous = f64::NAN;
        for k in 0..max_iter {
            negate_into(&self.g, &mut self.rhs);
            let lin = self.timed_linear_solve(system, y, eta, stats)?;
            stats.linear_iterations += lin.iterations;
            if !lin.converged {
                return Err(Stop::LinearNotConverged {
                    iterations: lin.iterations,
                    tolerance: eta,
                    relative_residual: lin.relative_residual,
                });
            }
            stats.iterations += 1;
            // The update and its weighted norm in one pass (on a failure
            // below `y` is the caller's to discard: `solve` returns an error).
            let norm = update_weighted_norm(y, &self.s, &self.weights);
            stats.push_step(norm);
            if !norm.is_finite() {
                return Err(Stop::NonFinite);
            }
            if let RateVerdict::Diverged { rate } =
                self.rate.measure(k, max_iter, norm, previous, tol)
            {
                stats.contraction_rate = Some(rate);
                return Err(Stop::Diverged(DivergenceReason::Contraction {
                    theta: rate,
                }));
            }
            if k > 0 {
                stats.contraction_rate = Some(norm / previous);
            }
            if self.rate.converged(k, norm, tol) {
                stats.converged_by = Some(ConvergedBy::Rate);
                return Ok(true);
            }
            previous = norm;
            if k + 1 == max_iter {
                break;
            }
            // A non-finite residual makes the next correction non-finite.
            system.residual(y, &mut self.g)?;
            stats.residual_evaluations += 1;
        }
        Err(Stop::MaxIterations)
    }

    /// Solves `J s = rhs` into `s` with relative tolerance `eta` (every
    /// solver overwrites `s`; iterative ones start from zero unless a guess
    /// was armed), through the system's products for a matrix-free solver.
    /// Clocked into `stats.solve_seconds` when phases are timed.
    fn timed_linear_solve<S>(
        &mut self,
        system: &mut S,
        y: &[f64],
        eta: f64,
        stats: &mut NewtonStats,
    ) -> Result<crate::LinearSolveStats, NonlinearError>
    where
        S: NonlinearSystem<Jacobian = J> + ?Sized,
    {
        if !self.timed {
            return self.linear_solve(system, y, eta);
        }
        let start = Instant::now();
        let lin = self.linear_solve(system, y, eta);
        stats.solve_seconds += start.elapsed().as_secs_f64();
        lin
    }

    /// The linear solve of one correction (see [`timed_linear_solve`](Self::timed_linear_solve)).
    fn linear_solve<S>(
        &mut self,
        system: &mut S,
        y: &[f64],
        eta: f64,
    ) -> Result<crate::LinearSolveStats, NonlinearError>
    where
        S: NonlinearSystem<Jacobian = J> + ?Sized,
    {
        if !self.linear.is_matrix_free() {
            return self
                .linear
                .solve(&self.jacobian, &self.rhs, &mut self.s, eta);
        }
        let mut product = |v: &[f64], out: &mut [f64]| {
            if system.jacobian_product(y, v, out)? {
                Ok(())
            } else {
                Err(NonlinearError::NotReady(
                    "a matrix-free linear solver needs NonlinearSystem::jacobian_product",
                ))
            }
        };
        self.linear
            .solve_with_product(&self.jacobian, &mut product, &self.rhs, &mut self.s, eta)
    }
}

/// `y += s` and the weighted RMS norm `sqrt(1/n sum (s_i / w_i)^2)` of the
/// correction in one pass (indexed on slices cut to `n`, as
/// [`negate_into`]).
#[inline]
#[allow(clippy::needless_range_loop)]
fn update_weighted_norm(y: &mut [f64], s: &[f64], w: &[f64]) -> f64 {
    let n = s.len();
    let (y, w) = (&mut y[..n], &w[..n]);
    let mut sum = 0.0;
    for i in 0..n {
        let si = s[i];
        y[i] += si;
        sum += (si / w[i]) * (si / w[i]);
    }
    (sum / n.max(1) as f64).sqrt()
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
