//! The integrator core shared by the first- and second-order integrators:
//! one state vector, one stage equation, every method of section 2.

use crate::bdf::{BdfCoefficients, variable_bdf2, variable_bdf2_error_constant};
use crate::control::{IterationController, NewtonOutcome, PiController, StepDecision};
use crate::error::OdeError;
use crate::integrator::Engine;
use crate::method::Method;
use crate::options::{Predictor, SolverOptions, StepControl};
use crate::stats::{Stats, StepReport};
use crate::stepping::{
    Integrator, check_dense_output, check_finite, check_growth, check_time, growth_bound,
    landing_slack,
};

/// The step-size controller of the variable-step method.
enum Controller {
    Pi(PiController),
    Iterations(IterationController),
}
use crate::snapshot::StateRecord;

mod checkpoint;
use crate::stage::{StageFailure, StageInfo, System};
use crate::tableau::ButcherTableau;

/// The step sizes of the extrapolated implicit midpoint rule used to start
/// BDF(k): 2, 4 and 6 substeps, combined by Aitken-Neville in `h^2`
/// (the midpoint rule is symmetric, its error expands in even powers).
const EXTRAPOLATION_SUBSTEPS: [f64; 3] = [2.0, 4.0, 6.0];

pub(crate) struct Core<S> {
    sys: S,
    method: Method,
    opts: SolverOptions,
    t: f64,
    s: Vec<f64>,
    /// The start of the last step: its state is `y0`, the dense output
    /// interpolates between it and `s` (`t_prev = t` after a new state).
    t_prev: f64,
    /// `atol_i` of the variable-step method's error test.
    atol: Vec<f64>,
    h: f64,
    stats: Stats,
    m: usize,
    tableau: Option<ButcherTableau>,
    kd: Vec<Vec<f64>>,
    tmp: Vec<f64>,
    psi: Vec<f64>,
    kbuf: Vec<f64>,
    y0: Vec<f64>,
    pre: Vec<f64>,
    bdf: Option<BdfCoefficients>,
    hist: Vec<Vec<f64>>,
    hist_len: usize,
    hist_h: f64,
    /// The state before the last accepted implicit Euler step and its step
    /// size (NaN when invalid), for the extrapolating predictor.
    prev: Vec<f64>,
    prev_h: f64,
    f_n: Vec<f64>,
    f_nm1: Vec<f64>,
    f_new: Vec<f64>,
    f_valid: bool,
    h_prev: f64,
    ex: [Vec<f64>; 3],
    acc_valid: bool,
    /// Fixed step: `t = t_base + n_fixed h`, so that many steps do not
    /// accumulate round-off in `t`.
    t_base: f64,
    n_fixed: u64,
    controller: Option<Controller>,
    /// `max_growth * max(1, max |s0|)`: a larger state is a blow-up.
    growth_bound: f64,
}

impl<S: System> Core<S> {
    pub fn new(
        sys: S,
        method: Method,
        t0: f64,
        s0: Vec<f64>,
        opts: SolverOptions,
    ) -> Result<Self, OdeError> {
        method.check()?;
        let m = sys.state_len();
        let atol = opts.check(m)?;
        if !t0.is_finite() {
            return Err(OdeError::InvalidParameter {
                name: "t0",
                value: t0,
                reason: "must be finite",
            });
        }
        if s0.len() != m {
            return Err(OdeError::DimensionMismatch {
                what: "initial state",
                expected: m,
                found: s0.len(),
            });
        }
        check_finite(&s0, "initial state", t0)?;
        if method.is_second_order_only() && !sys.is_second_order() {
            return Err(OdeError::UnsupportedMethod {
                method: method.to_string(),
                problem: "first-order",
            });
        }
        let tableau = match &method {
            Method::ExplicitEuler | Method::Midpoint | Method::Rk4 | Method::ExplicitRk(_) => {
                method.tableau()
            }
            _ => None,
        };
        let stages = tableau.as_ref().map_or(0, |t| t.stages());
        let bdf = match method {
            Method::Bdf(k) if k >= 2 => Some(BdfCoefficients::new(k)?),
            _ => None,
        };
        let hist_n = match method {
            Method::Bdf(k) => k.max(2),
            Method::Bdf2Variable => 2,
            _ => 1,
        };
        let controller = if method.is_variable_step() {
            Some(match &opts.step.control {
                StepControl::ErrorBased(o) => Controller::Pi(PiController::new(o.clone())?),
                StepControl::NewtonIterations(o) => {
                    Controller::Iterations(IterationController::new(o.clone())?)
                }
            })
        } else {
            None
        };
        let max_growth = opts.max_growth;
        let mut hist = vec![vec![0.0; m]; hist_n];
        hist[0].copy_from_slice(&s0);
        Ok(Self {
            sys,
            h: opts.h,
            method,
            opts,
            t: t0,
            t_prev: t0,
            atol,
            stats: Stats::default(),
            m,
            tableau,
            kd: vec![vec![0.0; m]; stages],
            tmp: vec![0.0; m],
            psi: vec![0.0; m],
            kbuf: vec![0.0; m],
            y0: vec![0.0; m],
            pre: vec![0.0; m],
            bdf,
            hist,
            hist_len: 1,
            hist_h: f64::NAN,
            prev: vec![0.0; m],
            prev_h: f64::NAN,
            f_n: vec![0.0; m],
            f_nm1: vec![0.0; m],
            f_new: vec![0.0; m],
            f_valid: false,
            h_prev: f64::NAN,
            ex: [vec![0.0; m], vec![0.0; m], vec![0.0; m]],
            acc_valid: false,
            t_base: t0,
            n_fixed: 0,
            controller,
            growth_bound: growth_bound(max_growth, &s0),
            s: s0,
        })
    }

    /// The step size the next `step()` will try.
    fn nominal_h(&self) -> f64 {
        if self.method.is_variable_step() {
            self.h
        } else {
            self.opts.h
        }
    }

    /// Forgets multistep history and cached forces (the state changed
    /// outside the method, or the problem did).
    fn reset_history(&mut self) {
        // Only the multistep methods read the history (a copy of the whole
        // state is measurable next to an explicit step).
        if matches!(self.method, Method::Bdf(_) | Method::Bdf2Variable) {
            self.hist[0].copy_from_slice(&self.s);
        }
        self.hist_len = 1;
        self.f_valid = false;
        self.acc_valid = false;
        self.prev_h = f64::NAN;
    }

    /// Invalidates values that depend on the problem (cached forces).
    fn problem_changed(&mut self) {
        self.f_valid = false;
        self.acc_valid = false;
    }

    /// A new state from the user ([`Integrator::restart`]): a new scale of
    /// the growth bound, fresh history.
    fn new_state(&mut self, t: f64, s: &[f64]) -> Result<(), OdeError> {
        if s.len() != self.m {
            return Err(OdeError::DimensionMismatch {
                what: "state",
                expected: self.m,
                found: s.len(),
            });
        }
        check_time(t)?;
        check_finite(s, "state", t)?;
        self.s.copy_from_slice(s);
        // A new state from the user sets a new scale; the per-step
        // `set_state_parts` of post-processing wrappers keeps the old one.
        self.growth_bound = growth_bound(self.opts.max_growth, s);
        self.restart_at(t);
        Ok(())
    }

    /// [`Integrator::restart`] from the two halves `[x; v]` of a
    /// second-order state, without allocating (used after every step by
    /// post-processing wrappers such as velocity filters).
    fn set_parts(&mut self, t: f64, x: &[f64], v: &[f64]) -> Result<(), OdeError> {
        let n = self.m / 2;
        if x.len() != n || v.len() != n || 2 * n != self.m {
            return Err(OdeError::DimensionMismatch {
                what: "state",
                expected: n,
                found: if x.len() != n { x.len() } else { v.len() },
            });
        }
        check_time(t)?;
        check_finite(x, "state", t)?;
        check_finite(v, "state", t)?;
        self.s[..n].copy_from_slice(x);
        self.s[n..].copy_from_slice(v);
        self.restart_at(t);
        Ok(())
    }

    /// The halves `[x; v]` of a second-order state, edited in place by `f`
    /// between steps (post-processing such as a velocity filter): the time
    /// stays, cached forces and multistep history are dropped as by
    /// [`set_parts`](Self::set_parts). Nothing is copied or
    /// checked here; the next step checks the state is finite.
    fn modify_parts(&mut self, f: &mut dyn FnMut(&mut [f64], &mut [f64])) {
        let n = self.m / 2;
        let (x, v) = self.s.split_at_mut(n);
        f(x, v);
        self.reset_history();
    }

    /// After a new state was written: time `t`, a fresh fixed-step count and
    /// multistep history.
    fn restart_at(&mut self, t: f64) {
        self.t = t;
        self.t_prev = t;
        self.t_base = t;
        self.n_fixed = 0;
        self.reset_history();
    }

    fn begin_step(&mut self) {
        self.pre.copy_from_slice(&self.s);
        self.sys.begin_step(self.t, &mut self.s);
        if self.s != self.pre {
            self.reset_history();
        }
    }

    /// One step; `limit` caps the step size (the driver's last step).
    fn advance(&mut self, limit: Option<f64>) -> Result<StepReport, OdeError> {
        let before = self.stats;
        check_finite(&self.s, "state", self.t)?;
        self.begin_step();
        check_finite(&self.s, "state", self.t)?;
        let t = self.t;
        let first_of_bdf2 = self.hist_len < 2;
        let (h, err) = if self.method.is_variable_step() {
            // The step cap of the variable-step methods (SolverOptions::max_steps,
            // which the variable-order BDF's engine checks alike).
            if self.stats.num_steps >= self.opts.max_steps {
                return Err(OdeError::TooManySteps {
                    t: self.t,
                    max_steps: self.opts.max_steps,
                });
            }
            self.variable_step(limit)?
        } else {
            let h = limit.map_or(self.opts.h, |l| l.min(self.opts.h));
            self.fixed_step(h)?;
            (h, None)
        };
        // `y0` still holds the state the accepted step started from.
        if self.sys.end_step(t, h, &self.y0, &mut self.s) {
            self.reset_history();
            check_finite(&self.s, "state after the step", self.t)?;
        }
        self.t_prev = t;
        self.stats.last_step = h;
        self.stats.last_order = match self.method {
            // Variable-step BDF2 starts with implicit Euler.
            Method::Bdf2Variable if first_of_bdf2 => 1,
            _ => self.method.order(),
        };
        Ok(StepReport::between(
            &before,
            &self.stats,
            self.t,
            h,
            err,
            self.nominal_h(),
        ))
    }

    /// The dense output of the last step: the straight line between its
    /// start `(t_prev, y0)` and its end `(t, s)`, first-order accurate for
    /// every method (exact at both ends).
    fn dense_output(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        check_dense_output(t, self.t_prev, self.t, out.len(), self.m)?;
        if t == self.t || self.t_prev == self.t {
            out.copy_from_slice(&self.s);
            return Ok(());
        }
        let theta = (t - self.t_prev) / (self.t - self.t_prev);
        for ((o, a), b) in out.iter_mut().zip(&self.y0).zip(&self.s) {
            *o = a + theta * (b - a);
        }
        Ok(())
    }

    fn failure_error(&self, fail: StageFailure, h: f64, retries: usize) -> OdeError {
        match fail {
            StageFailure::NoConvergence {
                iterations,
                update_norm,
            } => OdeError::NewtonFailed {
                t: self.t,
                h,
                retries,
                iterations,
                update_norm,
            },
            StageFailure::Linear(source) => OdeError::LinearSolver {
                t: self.t,
                retries,
                source,
            },
            StageFailure::Singular { pivot } => OdeError::SingularMatrix { t: self.t, pivot },
            StageFailure::NoLinearPart => OdeError::UnsupportedMethod {
                method: self.method.to_string(),
                problem: "second-order without a linear part (SecondOrderProblem::linearized_jacobians_iso, eq. 50)",
            },
            StageFailure::Other(source) => OdeError::NewtonSolver { t: self.t, source },
        }
    }

    fn check_h(&self, h: f64) -> Result<(), OdeError> {
        let t = self.t;
        if h.is_nan() || h < self.opts.step.h_min || t + h <= t {
            return Err(OdeError::StepSizeUnderflow { t, h });
        }
        Ok(())
    }

    fn fixed_step(&mut self, h: f64) -> Result<(), OdeError> {
        self.check_h(h)?;
        let t = self.t;
        self.y0.copy_from_slice(&self.s);
        let mut retries = 0;
        loop {
            let res = if retries == 0 {
                self.one_step(t, h).map(|_| ())
            } else {
                self.substeps(t, h, 1usize << retries)
            };
            match res {
                Ok(_) => break,
                Err(fail) => {
                    self.stats.num_nonlin_solv_conv_fails += 1;
                    retries += 1;
                    let hs = h / (1usize << retries.min(60)) as f64;
                    if retries > self.opts.max_retries {
                        return Err(self.failure_error(fail, hs * 2.0, retries - 1));
                    }
                    self.check_h(hs)?;
                    self.s.copy_from_slice(&self.y0);
                    self.reset_history();
                    self.sys.begin_step(t, &mut self.s);
                }
            }
        }
        check_finite(&self.s, "state after the step", t)?;
        // Explicit methods are left to grow: their instability outside the
        // stability region is what the tutorial demonstrates.
        if self.method.is_implicit() {
            check_growth(&self.s, self.growth_bound, t + h)?;
        }
        if h == self.opts.h {
            self.n_fixed += 1;
            self.t = self.t_base + self.n_fixed as f64 * h;
        } else {
            self.t = t + h;
            self.t_base = self.t;
            self.n_fixed = 0;
        }
        self.stats.num_steps += 1;
        Ok(())
    }

    /// A failed step retried as `m` substeps of the method's one-step form;
    /// BDF(k) retries with implicit Euler substeps (L-stable and one stage
    /// solve each: robustness first, the retried step is first order) and
    /// its history restarts.
    fn substeps(&mut self, t: f64, h: f64, m: usize) -> Result<(), StageFailure> {
        let hs = h / m as f64;
        for j in 0..m {
            let tj = t + j as f64 * hs;
            if j > 0 {
                self.sys.begin_step(tj, &mut self.s);
            }
            match self.method {
                Method::Bdf(k) if k >= 2 => {
                    self.implicit_euler(tj, hs)?;
                }
                _ => {
                    self.one_step(tj, hs)?;
                }
            }
        }
        if matches!(self.method, Method::Bdf(_)) {
            self.reset_history();
        }
        Ok(())
    }

    /// Implicit Euler (24) on the state: `K = y + h f(t + h, K)`.
    fn implicit_euler(&mut self, t: f64, h: f64) -> Result<StageInfo, StageFailure> {
        self.psi.copy_from_slice(&self.s);
        self.kbuf.copy_from_slice(&self.s);
        if self.opts.predictor == Predictor::Extrapolate && self.prev_h == h {
            for ((k, s), p) in self.kbuf.iter_mut().zip(&self.s).zip(&self.prev) {
                *k += s - p;
            }
        }
        let info = self.sys.solve_stage(
            t + h,
            h,
            &self.psi,
            &mut self.kbuf,
            &self.opts,
            &mut self.stats,
        )?;
        self.prev.copy_from_slice(&self.s);
        self.prev_h = h;
        self.s.copy_from_slice(&self.kbuf);
        Ok(info)
    }

    fn one_step(&mut self, t: f64, h: f64) -> Result<StageInfo, StageFailure> {
        match self.method {
            Method::ExplicitEuler | Method::Midpoint | Method::Rk4 | Method::ExplicitRk(_) => {
                self.rk_step(t, h);
                Ok(StageInfo::default())
            }
            Method::FbEuler => {
                self.fb_euler(t, h);
                Ok(StageInfo::default())
            }
            Method::Verlet => {
                self.verlet(t, h);
                Ok(StageInfo::default())
            }
            Method::ImplicitEuler | Method::Bdf(1) => self.implicit_euler(t, h),
            Method::ImplicitMidpoint => {
                let mut s = std::mem::take(&mut self.s);
                let r = self.midpoint_on(t, h, &mut s);
                self.s = s;
                r
            }
            Method::Bdf(k) => self.bdf_step(t, h, k),
            Method::Imex => self.sys.imex_step(t, h, &mut self.s, &mut self.stats),
            Method::Bdf2Variable => unreachable!("variable-step method in fixed_step"),
            Method::VariableBdf(_) => unreachable!("the variable-order BDF is not run by the core"),
        }
    }

    /// Explicit Runge-Kutta step (eq. 19) on the whole state.
    fn rk_step(&mut self, t: f64, h: f64) {
        let tab = self
            .tableau
            .as_ref()
            .expect("explicit method has a tableau");
        let st = tab.stages();
        for i in 0..st {
            self.tmp.copy_from_slice(&self.s);
            for j in 0..i {
                let a = tab.a(i, j);
                if a != 0.0 {
                    for (y, k) in self.tmp.iter_mut().zip(&self.kd[j]) {
                        *y += h * a * k;
                    }
                }
            }
            self.sys.derivative(
                t + tab.c()[i] * h,
                &self.tmp,
                &mut self.kd[i],
                &mut self.stats,
            );
        }
        for i in 0..st {
            let b = tab.b()[i];
            if b != 0.0 {
                for (y, k) in self.s.iter_mut().zip(&self.kd[i]) {
                    *y += h * b * k;
                }
            }
        }
        self.sys.impose(&mut self.s);
    }

    /// Forward-backward Euler: `v1 = v0 + h M^{-1} f(x0, v0)`, `x1 = x0 + h v1`.
    fn fb_euler(&mut self, t: f64, h: f64) {
        let n = self.m / 2;
        let (x, v) = self.s.split_at_mut(n);
        let acc = &mut self.tmp[..n];
        self.sys.acceleration(t, x, v, acc, &mut self.stats);
        for i in 0..n {
            v[i] += h * acc[i];
        }
        self.sys.impose(&mut self.s);
        let (x, v) = self.s.split_at_mut(n);
        for i in 0..n {
            x[i] += h * v[i];
        }
    }

    /// Stoermer-Verlet in the velocity form (44)-(45), written as
    /// kick-drift-kick so that `v` is available at the integer times:
    /// `v_{n+1/2} = v_n + h/2 a_n`, `x_{n+1} = x_n + h v_{n+1/2}`,
    /// `a_{n+1} = M^{-1} f(x_{n+1}, v_{n+1/2})`, `v_{n+1} = v_{n+1/2} + h/2 a_{n+1}`;
    /// two half kicks make eq. (44) with `f(x_n, v_{n-1/2})`, one force
    /// evaluation per step (`a_{n+1}` is reused by the next step).
    fn verlet(&mut self, t: f64, h: f64) {
        let n = self.m / 2;
        if !self.acc_valid {
            let (x, v) = self.s.split_at(n);
            self.sys
                .acceleration(t, x, v, &mut self.tmp[..n], &mut self.stats);
            self.acc_valid = true;
        }
        {
            let v = &mut self.s[n..];
            for i in 0..n {
                v[i] += 0.5 * h * self.tmp[i];
            }
        }
        self.sys.impose(&mut self.s);
        {
            let (x, v) = self.s.split_at_mut(n);
            for i in 0..n {
                x[i] += h * v[i];
            }
            self.sys
                .acceleration(t + h, x, v, &mut self.tmp[..n], &mut self.stats);
            for i in 0..n {
                v[i] += 0.5 * h * self.tmp[i];
            }
        }
        self.sys.impose(&mut self.s);
    }

    /// The implicit midpoint rule (32) on `y`: `K = y + h/2 f(t + h/2, K)`,
    /// `y <- 2 K - y`.
    fn midpoint_on(&mut self, t: f64, h: f64, y: &mut [f64]) -> Result<StageInfo, StageFailure> {
        self.psi.copy_from_slice(y);
        self.kbuf.copy_from_slice(y);
        let info = self.sys.solve_stage(
            t + 0.5 * h,
            0.5 * h,
            &self.psi,
            &mut self.kbuf,
            &self.opts,
            &mut self.stats,
        )?;
        for (yi, ki) in y.iter_mut().zip(&self.kbuf) {
            *yi = 2.0 * ki - *yi;
        }
        Ok(info)
    }

    /// One step of size `h` by the implicit midpoint rule extrapolated
    /// (Aitken-Neville in `h^2`) from 2, 4 and 6 substeps: local error
    /// `O(h^7)`, accurate enough to start BDF(k) for every k <= 6.
    fn extrapolated_midpoint(&mut self, t: f64, h: f64) -> Result<(), StageFailure> {
        let mut ex = std::mem::take(&mut self.ex);
        let mut res = Ok(());
        'outer: for (e, &n) in ex.iter_mut().zip(&EXTRAPOLATION_SUBSTEPS) {
            e.copy_from_slice(&self.s);
            let hs = h / n;
            for j in 0..n as usize {
                if let Err(f) = self.midpoint_on(t + j as f64 * hs, hs, e) {
                    res = Err(f);
                    break 'outer;
                }
            }
        }
        if res.is_ok() {
            let [n0, n1, n2] = EXTRAPOLATION_SUBSTEPS;
            let r10 = (n1 / n0).powi(2) - 1.0;
            let r21 = (n2 / n1).powi(2) - 1.0;
            let r20 = (n2 / n0).powi(2) - 1.0;
            for i in 0..self.m {
                let (t0, t1, t2) = (ex[0][i], ex[1][i], ex[2][i]);
                let t11 = t1 + (t1 - t0) / r10;
                let t21 = t2 + (t2 - t1) / r21;
                self.s[i] = t21 + (t21 - t11) / r20;
            }
        }
        self.ex = ex;
        res
    }

    fn push_history(&mut self, h: f64) {
        if !(self.hist_h == h) {
            // A new step size: only the current point is on the new grid.
            self.hist_len = 1;
            self.hist_h = h;
        }
        self.hist.rotate_right(1);
        self.hist[0].copy_from_slice(&self.s);
        self.hist_len = (self.hist_len + 1).min(self.hist.len());
    }

    /// Fixed-step BDF(k) (eq. 36), started by the extrapolated midpoint rule
    /// until `k` equidistant points are known.
    fn bdf_step(&mut self, t: f64, h: f64, k: usize) -> Result<StageInfo, StageFailure> {
        let same_h = (self.hist_h - h).abs() <= 1e-12 * h;
        if !same_h {
            self.hist[0].copy_from_slice(&self.s);
            self.hist_len = 1;
            self.hist_h = h;
        }
        if self.hist_len < k {
            self.extrapolated_midpoint(t, h)?;
            self.push_history(h);
            return Ok(StageInfo::default());
        }
        let bdf = self.bdf.as_ref().expect("BDF(k>=2) has coefficients");
        self.psi.fill(0.0);
        for i in 1..=k {
            let a = bdf.alpha[i];
            for (p, y) in self.psi.iter_mut().zip(&self.hist[i - 1]) {
                *p -= a * y;
            }
        }
        // Predictor: linear extrapolation of the last two points.
        for i in 0..self.m {
            self.kbuf[i] = 2.0 * self.hist[0][i] - self.hist[1][i];
        }
        let gh = bdf.beta * h;
        let info = self.sys.solve_stage(
            t + h,
            gh,
            &self.psi,
            &mut self.kbuf,
            &self.opts,
            &mut self.stats,
        )?;
        self.s.copy_from_slice(&self.kbuf);
        self.push_history(h);
        Ok(info)
    }

    /// Variable-step BDF2 with a local error estimate; the first step (and
    /// the first after a reset) is implicit Euler.
    fn variable_step(&mut self, limit: Option<f64>) -> Result<(f64, Option<f64>), OdeError> {
        let t = self.t;
        if !self.f_valid {
            self.sys
                .derivative(t, &self.s, &mut self.f_n, &mut self.stats);
            check_finite(&self.f_n, "right-hand side", t)?;
            self.f_valid = true;
        }
        let mut h = self.h.min(self.opts.step.h_max);
        if let Some(l) = limit {
            h = h.min(l);
        }
        self.y0.copy_from_slice(&self.s);
        let mut retries = 0;
        loop {
            self.check_h(h)?;
            let first = self.hist_len < 2;
            let (gh, omega) = if first {
                self.psi.copy_from_slice(&self.y0);
                self.kbuf.copy_from_slice(&self.y0);
                (h, 1.0)
            } else {
                let omega = h / self.h_prev;
                let (a1, a2, beta) = variable_bdf2(omega);
                for i in 0..self.m {
                    let (yn, ynm1) = (self.hist[0][i], self.hist[1][i]);
                    self.psi[i] = -a1 * yn - a2 * ynm1;
                    self.kbuf[i] = yn + omega * (yn - ynm1);
                }
                (beta * h, omega)
            };
            let info = match self.sys.solve_stage(
                t + h,
                gh,
                &self.psi,
                &mut self.kbuf,
                &self.opts,
                &mut self.stats,
            ) {
                Ok(info) => info,
                Err(fail) => {
                    self.stats.num_nonlin_solv_conv_fails += 1;
                    retries += 1;
                    if retries > self.opts.max_retries {
                        return Err(self.failure_error(fail, h, retries - 1));
                    }
                    let decision = match self
                        .controller
                        .as_mut()
                        .expect("variable step has a controller")
                    {
                        Controller::Pi(c) => c.newton_failed(h),
                        Controller::Iterations(c) => c.decide(h, NewtonOutcome::Failed),
                    };
                    h = self.controller_step(decision, h)?;
                    self.s.copy_from_slice(&self.y0);
                    self.sys.begin_step(t, &mut self.s);
                    continue;
                }
            };
            self.sys
                .derivative(t + h, &self.kbuf, &mut self.f_new, &mut self.stats);
            // Local error estimate: implicit Euler h^2/2 y'', BDF2 C(omega) h^3 y'''
            // with y'' and y''' from divided differences of f.
            let c = if first {
                0.5 * h
            } else {
                variable_bdf2_error_constant(omega) * h.powi(3) * 2.0 / (h + self.h_prev)
            };
            let mut sum = 0.0;
            for i in 0..self.m {
                let e = if first {
                    c * (self.f_new[i] - self.f_n[i])
                } else {
                    c * ((self.f_new[i] - self.f_n[i]) / h
                        - (self.f_n[i] - self.f_nm1[i]) / self.h_prev)
                };
                let sc = self.atol[i] + self.opts.rtol * self.y0[i].abs().max(self.kbuf[i].abs());
                sum += (e / sc).powi(2);
            }
            let err = (sum / self.m.max(1) as f64).sqrt();
            if !err.is_finite() {
                return Err(OdeError::NonFinite {
                    what: "local error estimate",
                    t,
                });
            }
            let decision = match self
                .controller
                .as_mut()
                .expect("variable step has a controller")
            {
                Controller::Pi(c) => c.decide(h, err, info.iterations),
                Controller::Iterations(c) => c.decide(
                    h,
                    NewtonOutcome::Converged {
                        iterations: info.iterations,
                    },
                ),
            };
            let h_next = match decision {
                Ok(StepDecision::Accept { h_next }) => h_next,
                other => {
                    self.stats.num_err_test_fails += 1;
                    h = self.controller_step(other, h)?;
                    self.s.copy_from_slice(&self.y0);
                    self.sys.begin_step(t, &mut self.s);
                    continue;
                }
            };
            // Accept.
            self.s.copy_from_slice(&self.kbuf);
            check_finite(&self.s, "state after the step", t)?;
            check_growth(&self.s, self.growth_bound, t + h)?;
            self.hist.rotate_right(1);
            self.hist[0].copy_from_slice(&self.s);
            self.hist_len = (self.hist_len + 1).min(2);
            std::mem::swap(&mut self.f_nm1, &mut self.f_n);
            std::mem::swap(&mut self.f_n, &mut self.f_new);
            self.h_prev = h;
            self.t = t + h;
            let policy = &self.opts.step;
            self.h = h_next.clamp(policy.h_min, policy.h_max);
            self.stats.num_steps += 1;
            return Ok((h, Some(err)));
        }
    }

    /// The step size a controller's decision asks for, within the policy's
    /// bounds: a retry is floored at `h_min`, and one asked for at `h_min`
    /// already is [`OdeError::StepSizeUnderflow`].
    fn controller_step(
        &self,
        decision: Result<StepDecision, OdeError>,
        h: f64,
    ) -> Result<f64, OdeError> {
        let h_min = self.opts.step.h_min;
        match decision? {
            StepDecision::Accept { h_next } => Ok(h_next),
            StepDecision::Retry { h: h_new } if h <= h_min => Err(OdeError::StepSizeUnderflow {
                t: self.t,
                h: h_new.min(h),
            }),
            StepDecision::Retry { h: h_new } => Ok(h_new.max(h_min)),
        }
    }
}

impl<S: System> Integrator for Core<S> {
    type Problem = S::Problem;

    fn t(&self) -> f64 {
        self.t
    }

    fn t_prev(&self) -> f64 {
        self.t_prev
    }

    fn state(&self) -> &[f64] {
        &self.s
    }

    fn stats(&self) -> Stats {
        self.stats
    }

    fn h_next(&self) -> f64 {
        self.nominal_h()
    }

    fn problem(&self) -> &S::Problem {
        self.sys.problem()
    }

    fn problem_mut(&mut self) -> &mut S::Problem {
        self.problem_changed();
        self.sys.problem_mut()
    }

    /// The landing rule's step: a nominal step that lands within the slack
    /// ([`landing_slack`]) of `t_bound` is taken as it is (no step is
    /// shortened by round-off alone); one that would pass `t_bound` by more
    /// is shortened to end on it; a step that ends within the slack of
    /// `t_bound` ends exactly on it.
    fn step_bounded(&mut self, t_bound: f64) -> Result<StepReport, OdeError> {
        if t_bound == f64::INFINITY {
            return self.advance(None);
        }
        let remaining = t_bound - self.t;
        let slack = landing_slack(self.t, t_bound, self.nominal_h());
        let limit = (remaining < self.nominal_h() - slack).then_some(remaining);
        let mut report = self.advance(limit)?;
        if (self.t - t_bound).abs() <= slack {
            self.t = t_bound;
            self.t_base = t_bound;
            self.n_fixed = 0;
            report.t = t_bound;
        }
        Ok(report)
    }

    fn land_on(&mut self, t_end: f64) {
        self.t = t_end;
    }

    fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        self.dense_output(t, out)
    }

    fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        self.new_state(t, y)
    }

    fn count_event_evaluations(&mut self, n: usize) {
        self.stats.num_g_evals += n;
    }

    fn save_state(&self, r: &mut StateRecord) -> Result<(), OdeError> {
        self.save(r)
    }

    fn restore_state(&mut self, r: &StateRecord) -> Result<(), OdeError> {
        self.restore(r)
    }

    /// Implicit methods through their stage system; explicit ones and IMEX
    /// solve no PCG systems.
    fn record_linear_solves(
        &mut self,
        recorder: Option<hookean_nonlinear::SharedRecorder>,
    ) -> bool {
        self.method.is_implicit()
            && !matches!(self.method, Method::Imex)
            && self.sys.record_linear_solves(recorder)
    }
}

impl<S: System> Engine<S::Problem> for Core<S> {
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
