//! [`Bdf`]: the variable-order BDF on any problem kind with a
//! [`Corrector`]: its state, construction and the stepping contract
//! ([`Integrator`]: the bounded step, dense output, restart); the step
//! itself is `step.rs`.

use super::corrector::Corrector;
use super::history::{Coefficients, History};
use crate::bdf_config::{BdfConfig, MAX_ORDER};
use crate::error::OdeError;
use crate::integrator::Engine;
use crate::options::SolverOptions;
use crate::stats::{Stats, StepReport};
use crate::stepping::{Integrator, check_dense_output, check_time, growth_bound};

/// The variable-order, variable-step BDF/NDF on a problem kind `S` (see
/// the module docs).
pub(crate) struct Bdf<S: Corrector> {
    pub(super) sys: S,
    pub(super) corrector: S::Data,
    pub(super) opts: SolverOptions,
    /// The method's own settings ([`Method::VariableBdf`](crate::Method::VariableBdf)'s value).
    pub(super) config: BdfConfig,
    pub(super) n: usize,
    /// The mapped `atol_i` and `rtol` of the local error test (`rtol^p`, see
    /// [`BdfConfig::exponent`](super::BdfConfig::exponent)).
    pub(super) atol: Vec<f64>,
    pub(super) rtol: f64,
    pub(super) coef: Coefficients,
    /// `max_growth * max(1, max |y0|)`: a larger state is a blow-up.
    pub(super) bound: f64,
    pub(super) t: f64,
    pub(super) t_prev: f64,
    /// False until the history is started (first step, or after a restart).
    pub(super) started: bool,
    pub(super) hist: History,
    /// `c` of the kept Newton matrix (NaN: none).
    pub(super) lu_c: f64,
    pub(super) lu_age: usize,
    pub(super) jac_age: usize,
    pub(super) jac_evaluated: bool,
    pub(super) jac_current: bool,
    /// `c` of the step at which the kept Jacobian was evaluated.
    pub(super) jac_c: f64,

    /// Fixed order and step (no error test, no order or step change): for
    /// the tests of each formula's order.
    pub(super) frozen: bool,
    pub(super) stats: Stats,
    pub(super) y_pred: Vec<f64>,
    /// `psi = sum_j gamma_j D_j / alpha_k`.
    pub(super) psi: Vec<f64>,
    pub(super) y_new: Vec<f64>,
    pub(super) dcor: Vec<f64>,
    pub(super) f: Vec<f64>,
    pub(super) w: Vec<f64>,
    pub(super) scratch: Vec<f64>,
    /// The state after a step, for the model's end-of-step correction.
    pub(super) end_state: Vec<f64>,
}

impl<S: Corrector> Bdf<S> {
    /// The solver with the settings `config` for the system `sys` from `(t0, y0)`.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] / [`OdeError::DimensionMismatch`] for
    /// bad options or sizes; [`OdeError::NonFinite`] for a non-finite `t0`
    /// or `y0`.
    pub fn new(
        sys: S,
        t0: f64,
        y0: &[f64],
        opts: SolverOptions,
        config: BdfConfig,
    ) -> Result<Self, OdeError> {
        let n = sys.state_len();
        let mut atol = opts.check(n)?;
        config.check()?;
        if !(opts.rtol > 0.0 && opts.rtol < 1.0) {
            return Err(OdeError::InvalidParameter {
                name: "rtol",
                value: opts.rtol,
                reason: "must be in (0, 1)",
            });
        }
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
        let rtol = opts.rtol.powf(config.exponent());
        let atol_scale = rtol / opts.rtol;
        for a in &mut atol {
            *a *= atol_scale;
        }
        let newton_tol = (10.0 * f64::EPSILON / rtol).max(config.newton_tol);
        let corrector = sys.corrector(&opts, &config, newton_tol, &atol, rtol)?;
        Ok(Self {
            sys,
            corrector,
            coef: Coefficients::new(config.formula),
            bound: growth_bound(opts.max_growth, y0),
            opts,
            config,
            n,
            atol,
            rtol,
            t: t0,
            t_prev: t0,
            started: false,
            hist: History::new(y0),
            lu_c: f64::NAN,
            lu_age: 0,
            jac_age: 0,
            jac_evaluated: false,
            jac_current: false,
            jac_c: f64::NAN,

            frozen: false,
            stats: Stats::default(),
            y_pred: vec![0.0; n],
            psi: vec![0.0; n],
            y_new: vec![0.0; n],
            dcor: vec![0.0; n],
            f: vec![0.0; n],
            w: vec![0.0; n],
            scratch: vec![0.0; n],
            end_state: vec![0.0; n],
        })
    }

    /// The order the next step will use.
    #[cfg(test)]
    pub fn order(&self) -> usize {
        self.hist.order
    }

    /// The problem changed between steps: the kept Jacobian and Newton
    /// matrix are evaluated again at the next step.
    fn problem_changed(&mut self) {
        self.jac_evaluated = false;
        self.lu_c = f64::NAN;
    }

    /// Restarts the method at `(t, y)` (order 1, a new initial step; the
    /// Jacobian and the Newton matrix are kept; the growth bound too): a
    /// state the model moved at the start or the end of a step.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`].
    fn restart_keeping_bound(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        if y.len() != self.n {
            return Err(OdeError::DimensionMismatch {
                what: "state",
                expected: self.n,
                found: y.len(),
            });
        }
        check_time(t)?;
        if y.iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "restart time or state",
                t,
            });
        }
        self.hist.d_mut(0).copy_from_slice(y);
        self.t = t;
        self.restart_here();
        Ok(())
    }

    /// A new state from its halves `[x; v]` (second-order problems), copied
    /// in place; a restart that keeps the growth bound.
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`],
    /// [`OdeError::InvalidParameter`].
    fn set_parts(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError> {
        let n = self.n / 2;
        if x.len() != n || v.len() != n {
            return Err(OdeError::DimensionMismatch {
                what: "state",
                expected: n,
                found: if x.len() != n { x.len() } else { v.len() },
            });
        }
        check_time(t)?;
        if x.iter().chain(v).any(|a| !a.is_finite()) {
            return Err(OdeError::NonFinite { what: "state", t });
        }
        let (dx, dv) = self.hist.d_mut(0).split_at_mut(n);
        dx.copy_from_slice(x);
        dv.copy_from_slice(v);
        self.t = t;
        self.restart_here();
        Ok(())
    }

    /// Edits the halves `[x; v]` of the state in place between steps; the
    /// history restarts there (the next step checks the state is finite).
    fn modify_parts(&mut self, f: &mut dyn FnMut(&mut [f64], &mut [f64])) {
        let n = self.n / 2;
        let (x, v) = self.hist.d_mut(0).split_at_mut(n);
        f(x, v);
        self.restart_here();
    }

    /// Restarts the method at the current `(t, D_0)`.
    fn restart_here(&mut self) {
        self.t_prev = self.t;
        self.started = false;
        self.hist.order = 1;
        self.hist.n_equal_steps = 0;
    }

    /// The dense output: the interpolating polynomial of the history,
    /// `p(t) = D_0 + sum_{j=1..k} D_j prod_{m=0..j-1} (t - t_n + m h) / ((m + 1) h)`,
    /// at `t` in the last step `[t_prev, t_n]`, written into `out`.
    ///
    fn dense_output(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        check_dense_output(t, self.t_prev, self.t, out.len(), self.n)?;
        if !self.started {
            out.copy_from_slice(self.hist.d(0));
            return Ok(());
        }
        self.hist.interpolate(t, self.t, out);
        Ok(())
    }

    /// One accepted step that does not pass `t_bound` (`t_bound > t`): a
    /// step that would pass it is shortened (the history re-interpolated)
    /// to end on it exactly.
    fn bounded_step(&mut self, t_bound: f64) -> Result<StepReport, OdeError> {
        if self.stats.num_steps >= self.opts.max_steps {
            return Err(OdeError::TooManySteps {
                t: self.t,
                max_steps: self.opts.max_steps,
            });
        }
        let before = self.stats;
        let t = self.t;
        self.begin_step()?;
        let err = self.step_inner(t_bound)?;
        self.end_step(t)?;
        Ok(StepReport::between(
            &before,
            &self.stats,
            self.t,
            self.t - t,
            Some(err),
            self.hist.h,
        ))
    }

    /// Lets the model set the step's constraints (second-order problems);
    /// a state it moved (a collision) restarts the history there.
    fn begin_step(&mut self) -> Result<(), OdeError> {
        if !self.sys.is_second_order() {
            return Ok(());
        }
        self.scratch.copy_from_slice(self.hist.d(0));
        self.sys.begin_step(self.t, &mut self.scratch);
        if self.scratch != self.hist.d(0) {
            let y = std::mem::take(&mut self.scratch);
            let result = self.restart_keeping_bound(self.t, &y);
            self.scratch = y;
            result?;
        }
        Ok(())
    }

    /// Lets the model correct the state after the step from `t_start`
    /// (second-order problems: the collision pass of contact); a state it
    /// moved restarts the history there. `scratch` still holds the state
    /// the step started from ([`begin_step`](Self::begin_step)).
    fn end_step(&mut self, t_start: f64) -> Result<(), OdeError> {
        if !self.sys.is_second_order() {
            return Ok(());
        }
        self.end_state.copy_from_slice(self.hist.d(0));
        let h = self.t - t_start;
        if self
            .sys
            .end_step(t_start, h, &self.scratch, &mut self.end_state)
        {
            let y = std::mem::take(&mut self.end_state);
            let result = self.restart_keeping_bound(self.t, &y);
            self.end_state = y;
            result?;
        }
        Ok(())
    }

    /// The highest order the history may use.
    pub(super) fn max_order(&self) -> usize {
        self.config.max_order.min(MAX_ORDER)
    }
}

impl<S: Corrector> Integrator for Bdf<S> {
    type Problem = S::Problem;

    fn t(&self) -> f64 {
        self.t
    }

    fn t_prev(&self) -> f64 {
        self.t_prev
    }

    fn state(&self) -> &[f64] {
        self.hist.d(0)
    }

    fn stats(&self) -> Stats {
        self.stats
    }

    /// NaN before the first step.
    fn h_next(&self) -> f64 {
        self.hist.h
    }

    fn problem(&self) -> &S::Problem {
        self.sys.problem()
    }

    fn problem_mut(&mut self) -> &mut S::Problem {
        self.problem_changed();
        self.sys.problem_mut()
    }

    fn step_bounded(&mut self, t_bound: f64) -> Result<StepReport, OdeError> {
        self.bounded_step(t_bound)
    }

    fn land_on(&mut self, t_end: f64) {
        self.t = t_end;
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        self.dense_output(t, out)
    }

    /// Order 1 and a new initial step at `(t, y)`; the Jacobian and the
    /// Newton matrix are kept.
    fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        self.restart_keeping_bound(t, y)?;
        self.bound = growth_bound(self.opts.max_growth, y);
        Ok(())
    }

    fn count_event_evaluations(&mut self, n: usize) {
        self.stats.num_g_evals += n;
    }

    fn save_state(&self, r: &mut crate::StateRecord) -> Result<(), OdeError> {
        self.save(r)
    }

    fn restore_state(&mut self, r: &crate::StateRecord) -> Result<(), OdeError> {
        self.restore(r)
    }
}

impl<S: Corrector> Engine<S::Problem> for Bdf<S> {
    fn constraints(&self) -> Option<&hookean_sparse::Constraints> {
        self.sys.constraints()
    }

    fn options(&self) -> &SolverOptions {
        &self.opts
    }

    fn set_state_parts(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError> {
        self.set_parts(t, x, v)
    }

    fn modify_state_parts(&mut self, f: &mut dyn FnMut(&mut [f64], &mut [f64])) {
        self.modify_parts(f);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bdf::Formula;
    use crate::stage::FirstSys;
    use hookean_problem::FirstOrderProblem;

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

    /// Sets the history of a scalar problem to the backward differences of
    /// the exact values `y(t0 - i h)`, `i = 0..=k`, with order `k` and step
    /// `h` kept fixed (no error test, no order or step change).
    fn freeze_on_exact_history<S: Corrector>(
        s: &mut Bdf<S>,
        y: impl Fn(f64) -> f64,
        t0: f64,
        h: f64,
        k: usize,
    ) {
        let mut diff: Vec<f64> = (0..=k).map(|i| y(t0 - i as f64 * h)).collect();
        for j in 0..=k {
            s.hist.d_mut(j)[0] = diff[0];
            for i in 0..k - j {
                diff[i] -= diff[i + 1];
            }
        }
        s.hist.h = h;
        s.hist.order = k;
        s.started = true;
        s.frozen = true;
    }

    /// `N` steps of order `k` and step `h = 1/N` from `t0 = 1` with the
    /// exact history `D_j = nabla^j y(t0)`; returns the errors at `t0 + 1`
    /// and of the dense output at the middle of the last step.
    fn frozen_run(formula: Formula, k: usize, n: usize) -> (f64, f64) {
        let (t0, h) = (1.0f64, 1.0 / n as f64);
        let opts = SolverOptions::with_tolerances(1e-12, 1e-12);
        let config = BdfConfig {
            formula,
            max_order: k,
            max_newton_iterations: 20,
            ..Default::default()
        };
        let sys = FirstSys::new(Sine, &opts).unwrap();
        let mut s = Bdf::new(sys, t0, &[t0.sin()], opts, config).unwrap();
        freeze_on_exact_history(&mut s, f64::sin, t0, h, k);
        let t_end = t0 + 1.0;
        while s.t() < t_end - 0.5 * h {
            s.step_to(t_end + 1.0).unwrap();
        }
        assert!((s.t() - t_end).abs() < 1e-12 && s.order() == k);
        assert_eq!(s.stats().num_nonlin_solv_conv_fails, 0);
        let mut mid = [0.0];
        let tm = s.t() - 0.5 * h;
        s.interpolate(tm, &mut mid).unwrap();
        (
            (s.state()[0] - t_end.sin()).abs(),
            (mid[0] - tm.sin()).abs(),
        )
    }

    /// `y' = (k + 1) t^k`, exact solution `y = t^(k+1)`: the lowest degree
    /// on which the order-`k` formula errs.
    struct Monomial(usize);
    impl FirstOrderProblem for Monomial {
        fn dim(&self) -> usize {
            1
        }
        fn rhs(&self, t: f64, _y: &[f64], dy: &mut [f64]) {
            dy[0] = (self.0 + 1) as f64 * t.powi(self.0 as i32);
        }
        fn jacobian(&self, _t: f64, _y: &[f64], j: &mut [f64]) -> bool {
            j[0] = 0.0;
            true
        }
    }

    #[test]
    fn one_step_errs_by_the_error_constant_of_shampine_reichelt() {
        // The NDF `sum_{m=1..k} nabla^m y_{n+1} / m - kappa_k gamma_k nabla^{k+1} y_{n+1} = h f_{n+1}`
        // (Shampine-Reichelt, eq. 2.2, kappa of their table 1; BDF: kappa = 0).
        // The exact solution satisfies `sum_{m>=1} nabla^m y / m = h y'`, so on
        // `y = t^(k+1)` (`nabla^{k+2} y = 0`, `nabla^{k+1} y = (k+1)! h^(k+1)`) its
        // residual is `-C_k (k+1)! h^(k+1)` with `C_k = kappa_k gamma_k + 1/(k+1)`,
        // and one step from the exact history errs by
        // `y_{n+1} - y(t_{n+1}) = C_k (k+1)! h^(k+1) / ((1 - kappa_k) gamma_k)`.
        let paper_kappa = [-0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0];
        for formula in [Formula::Ndf, Formula::Bdf] {
            for k in 1..=MAX_ORDER {
                let kappa = match formula {
                    Formula::Ndf => paper_kappa[k - 1],
                    Formula::Bdf => 0.0,
                };
                let gamma: f64 = (1..=k).map(|m| 1.0 / m as f64).sum();
                let c_k = kappa * gamma + 1.0 / (k + 1) as f64;
                let (t0, h) = (1.0f64, 0.1);
                let y = |t: f64| t.powi(k as i32 + 1);
                let opts = SolverOptions::with_tolerances(1e-12, 1e-12);
                let config = BdfConfig {
                    formula,
                    max_order: k,
                    ..Default::default()
                };
                let sys = FirstSys::new(Monomial(k), &opts).unwrap();
                let mut s = Bdf::new(sys, t0, &[y(t0)], opts, config).unwrap();
                freeze_on_exact_history(&mut s, y, t0, h, k);
                s.step().unwrap();
                let factorial: f64 = (1..=k + 1).map(|m| m as f64).product();
                let expected = c_k * factorial * h.powi(k as i32 + 1) / ((1.0 - kappa) * gamma);
                let error = s.state()[0] - y(t0 + h);
                assert!(
                    (error - expected).abs() <= 1e-9 * expected.abs(),
                    "{formula:?} order {k}: error {error:e}, expected {expected:e}"
                );
            }
        }
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
}
