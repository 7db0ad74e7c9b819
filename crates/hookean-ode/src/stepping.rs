//! The stepping contract every engine keeps ([`Integrator`]): one bounded
//! step and dense output on the last step, required of each engine, and
//! the drivers built on them once for all: one step that lands on an end
//! time (the one landing rule, [`step_to`](Integrator::step_to)),
//! [`integrate`](Integrator::integrate), [`solve_at`](Integrator::solve_at)
//! and event location ([`integrate_with_events`](Integrator::integrate_with_events),
//! [`solve_at_with_events`](Integrator::solve_at_with_events)).

use std::ops::ControlFlow;

use crate::error::OdeError;
use crate::events::{EventHit, Events};
use crate::stats::{IntegrateInfo, Stats, StepReport};

/// One method on one problem, stepped through time: the stepping contract
/// of every engine (the one-step, fixed-step multistep and variable-step
/// methods of [`Method`](crate::Method), and the variable-order BDF), of the integrators
/// that choose an engine by [`Method`](crate::Method)
/// ([`FirstOrderIntegrator`](crate::FirstOrderIntegrator),
/// [`SecondOrderIntegrator`](crate::SecondOrderIntegrator)) and of wrappers
/// such as the velocity filter. As in diffsol's `OdeSolverMethod`, each
/// engine implements the few required methods, above all one bounded step
/// ([`step_bounded`](Self::step_bounded)); the drivers are the default
/// methods written once here: [`step`](Self::step),
/// [`step_to`](Self::step_to) (the one landing rule),
/// [`integrate`](Self::integrate), [`integrate_with`](Self::integrate_with),
/// [`solve_at`](Self::solve_at) (dense-output sampling) and
/// [`solve_at_with_events`](Self::solve_at_with_events).
///
/// ```
/// use hookean_ode::{FirstOrderIntegrator, FirstOrderProblem, Integrator, Method, OdeError, SolverOptions};
///
/// /// y' = -y, y(0) = 1.
/// struct Decay;
/// impl FirstOrderProblem for Decay {
///     fn dim(&self) -> usize { 1 }
///     fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) { dy[0] = -y[0]; }
/// }
///
/// // The same driver for a fixed-step method and the stiff solver.
/// fn y_at_one(mut ode: impl Integrator) -> Result<f64, OdeError> {
///     let sol = ode.solve_at(&[0.5, 1.0])?;
///     Ok(sol.y(1)[0])
/// }
/// let opts = SolverOptions { rtol: 1e-8, ..SolverOptions::with_h(1e-3) };
/// let rk4 = FirstOrderIntegrator::new(Decay, Method::Rk4, 0.0, &[1.0], opts.clone())?;
/// let bdf = FirstOrderIntegrator::new(Decay, Method::variable_bdf(), 0.0, &[1.0], opts)?;
/// let exact = (-1.0f64).exp();
/// assert!((y_at_one(rk4)? - exact).abs() < 1e-12);
/// assert!((y_at_one(bdf)? - exact).abs() < 1e-6);
/// # Ok::<(), OdeError>(())
/// ```
pub trait Integrator {
    /// The problem the engine integrates.
    type Problem;

    /// The current time (the end of the last accepted step).
    fn t(&self) -> f64;

    /// The start of the last step: [`interpolate`](Self::interpolate)
    /// covers `[t_prev, t]` (`t_prev = t` before the first step and after a
    /// new state).
    fn t_prev(&self) -> f64;

    /// The current state (`y`, or `[x; v]` for second-order problems).
    fn state(&self) -> &[f64];

    /// The counters so far.
    fn stats(&self) -> Stats;

    /// The step size the next step will try (NaN before the variable-order
    /// BDF's first step).
    fn h_next(&self) -> f64;

    /// The problem.
    fn problem(&self) -> &Self::Problem;

    /// The problem, mutably, between steps (values cached from it are
    /// dropped: forces, and the variable-order BDF's Jacobian).
    fn problem_mut(&mut self) -> &mut Self::Problem;

    /// One accepted step that does not pass `t_bound` (`t_bound > t`;
    /// `f64::INFINITY` for none): a step that would pass it is shortened to
    /// end on it, and a step that ends within [`landing_slack`] of it ends
    /// exactly on it. The one step each engine writes.
    ///
    /// # Errors
    /// The method's failures, each carrying the time reached:
    /// [`OdeError::NonFinite`], [`OdeError::StepSizeUnderflow`],
    /// [`OdeError::NewtonFailed`], [`OdeError::SingularMatrix`],
    /// [`OdeError::LinearSolver`] after the allowed retries,
    /// [`OdeError::StateGrowth`], and the variable-order BDF's
    /// [`OdeError::TooManySteps`] and [`OdeError::ErrorTestFailed`].
    fn step_bounded(&mut self, t_bound: f64) -> Result<StepReport, OdeError>;

    /// Sets the time to `t_end`, within [`landing_slack`] above the
    /// current time, without a step ([`step_to`](Self::step_to)'s landing).
    #[doc(hidden)]
    fn land_on(&mut self, t_end: f64);

    /// The dense output at `t` in the last step `[t_prev, t]`, written into
    /// `out`: the variable-order BDF's interpolating polynomial (of the
    /// step's order), the straight line between the step's ends for the
    /// other methods.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] for `t` outside the last step,
    /// [`OdeError::DimensionMismatch`] for a wrong `out`.
    fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError>;

    /// Restarts at the new state `(t, y)`: multistep history and dense
    /// output start again, and the blow-up bound
    /// ([`SolverOptions::max_growth`](crate::SolverOptions::max_growth)) is
    /// taken from `y` (e.g. at a terminal event, or a state set by the user).
    ///
    /// # Errors
    /// [`OdeError::DimensionMismatch`], [`OdeError::NonFinite`],
    /// [`OdeError::InvalidParameter`].
    fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError>;

    /// Adds `n` event-function evaluations to the counters (the drivers'
    /// bookkeeping of [`Stats::num_g_evals`]).
    #[doc(hidden)]
    fn count_event_evaluations(&mut self, n: usize);

    /// Adds to `record` everything the next step depends on (state, step
    /// size, counters, history, the linear solves' warm start, what the
    /// preconditioner reuses), so that [`restore_state`](Self::restore_state)
    /// on an integrator built alike continues bit for bit
    /// ([`crate::snapshot`]). The problem's own state is the caller's.
    ///
    /// # Errors
    /// [`OdeError::NoCheckpoint`] for an integrator (or an option) whose
    /// state is not covered (the default).
    fn save_state(&self, record: &mut crate::StateRecord) -> Result<(), OdeError> {
        let _ = record;
        Err(crate::snapshot::not_covered("this integrator"))
    }

    /// Continues from a [`save_state`](Self::save_state) record of an
    /// integrator built with the same problem, method and options.
    ///
    /// # Errors
    /// [`OdeError::NoCheckpoint`] as [`save_state`](Self::save_state);
    /// [`OdeError::Checkpoint`] for a record that does not fit (a missing
    /// entry, another size).
    fn restore_state(&mut self, record: &crate::StateRecord) -> Result<(), OdeError> {
        let _ = record;
        Err(crate::snapshot::not_covered("this integrator"))
    }

    /// Hands every linear system that Newton gives PCG from now on to
    /// `recorder` ([`PcgSolver::set_recorder`](hookean_nonlinear::PcgSolver::set_recorder);
    /// `None` stops it); `false` (the default) when this integrator solves
    /// no such systems or cannot record them: explicit methods, IMEX, the
    /// variable-order BDF and inexact simplified Newton's eq. 50 path.
    fn record_linear_solves(
        &mut self,
        recorder: Option<hookean_nonlinear::SharedRecorder>,
    ) -> bool {
        let _ = recorder;
        false
    }

    /// One accepted step ([`step_bounded`](Self::step_bounded) without a bound).
    ///
    /// # Errors
    /// As [`step_bounded`](Self::step_bounded).
    fn step(&mut self) -> Result<StepReport, OdeError> {
        self.step_bounded(f64::INFINITY)
    }

    /// One step that does not pass `t_end`, or `None` once `t_end` is
    /// reached: the one landing rule of every driver. Within
    /// [`landing_slack`] below `t_end` the time is set to `t_end` without a
    /// step (no sliver of a step is left); otherwise one
    /// [`step_bounded`](Self::step_bounded) to `t_end`.
    ///
    /// # Errors
    /// As [`step_bounded`](Self::step_bounded); [`OdeError::InvalidParameter`] for a
    /// non-finite `t_end` or one before the current time.
    fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, OdeError> {
        let t = self.t();
        if !t_end.is_finite() || t_end < t {
            return Err(OdeError::InvalidParameter {
                name: "t_end",
                value: t_end,
                reason: "must be finite and not before the current time",
            });
        }
        if t_end - t <= landing_slack(t, t_end, self.h_next()) {
            self.land_on(t_end);
            return Ok(None);
        }
        self.step_bounded(t_end).map(Some)
    }

    /// [`step_to`](Self::step_to) until `t_end`.
    ///
    /// # Errors
    /// As [`step_to`](Self::step_to).
    fn integrate(&mut self, t_end: f64) -> Result<IntegrateInfo, OdeError>
    where
        Self: Sized,
    {
        self.integrate_with(t_end, |_, _| ControlFlow::Continue(()))
    }

    /// [`step_to`](Self::step_to) until `t_end`, calling
    /// `callback(report, state)` after every step; `ControlFlow::Break(())`
    /// stops the run.
    ///
    /// # Errors
    /// As [`step_to`](Self::step_to).
    fn integrate_with<F>(&mut self, t_end: f64, mut callback: F) -> Result<IntegrateInfo, OdeError>
    where
        F: FnMut(&StepReport, &[f64]) -> ControlFlow<()>,
        Self: Sized,
    {
        while let Some(report) = self.step_to(t_end)? {
            if callback(&report, self.state()).is_break() {
                return Ok(IntegrateInfo {
                    t: self.t(),
                    stopped_by_callback: true,
                    stats: self.stats(),
                });
            }
        }
        Ok(IntegrateInfo {
            t: self.t(),
            stopped_by_callback: false,
            stats: self.stats(),
        })
    }

    /// [`integrate_with`](Self::integrate_with) with event location (the
    /// one event driver, under [`solve_at_with_events`](Self::solve_at_with_events)
    /// too): [`step_to`](Self::step_to) until `t_end`; after every step the
    /// event functions are compared at both ends and the roots are located
    /// on the dense output (as in [`solve_at_with_events`](Self::solve_at_with_events)),
    /// then `callback(self, (t_prev, t_stop), hits)` runs with `t_stop` the
    /// step's end, or the root of a terminal event, and `hits` the events
    /// of this step; [`interpolate`](Self::interpolate) covers
    /// `[t_prev, t_stop]` during the callback. A terminal event ends the run
    /// after the callback: the integrator restarts at the root
    /// ([`restart`](Self::restart)). `ControlFlow::Break(())` stops the run.
    /// `events = None` locates none.
    ///
    /// # Errors
    /// As [`step_to`](Self::step_to); [`OdeError::DimensionMismatch`] for
    /// events of another size.
    fn integrate_with_events<F>(
        &mut self,
        t_end: f64,
        mut events: Option<&mut Events<'_>>,
        mut callback: F,
    ) -> Result<EventRun, OdeError>
    where
        F: FnMut(&Self, (f64, f64), &[EventHit]) -> ControlFlow<()>,
        Self: Sized,
    {
        if let Some(ev) = events.as_deref_mut() {
            ev.start(self.t(), self.state())?;
            self.count_event_evaluations(1);
        }
        let mut run = EventRun {
            t: self.t(),
            events: Vec::new(),
            terminal: false,
            stopped_by_callback: false,
            stats: self.stats(),
        };
        while self.step_to(t_end)?.is_some() {
            let first = run.events.len();
            let mut t_stop = self.t();
            if let Some(ev) = events.as_deref_mut() {
                let (terminal, evaluations) = ev.locate(
                    (self.t_prev(), self.t()),
                    self.state(),
                    |t, out| self.interpolate(t, out),
                    &mut run.events,
                )?;
                self.count_event_evaluations(evaluations);
                if terminal {
                    run.terminal = true;
                    t_stop = run.events.last().map_or(t_stop, |e| e.t);
                }
            }
            let flow = callback(self, (self.t_prev(), t_stop), &run.events[first..]);
            if run.terminal {
                let hit = run.events.last().expect("a terminal event was recorded");
                let (t_root, y_root) = (hit.t, hit.y.clone());
                self.restart(t_root, &y_root)?;
                break;
            }
            if flow.is_break() {
                run.stopped_by_callback = true;
                break;
            }
        }
        run.t = self.t();
        run.stats = self.stats();
        Ok(run)
    }

    /// The solution at the non-decreasing `times` (none before the current
    /// time), stepping to the last one and interpolating the others.
    ///
    /// # Errors
    /// [`OdeError::InvalidParameter`] for bad times; run failures as
    /// [`step_to`](Self::step_to).
    fn solve_at(&mut self, times: &[f64]) -> Result<Solution, OdeError>
    where
        Self: Sized,
    {
        solve_at(self, times, None)
    }

    /// [`solve_at`](Self::solve_at) with event location: after every step the
    /// event functions are compared at both ends; a sign change in an
    /// event's direction is located on the dense output by the Illinois
    /// variant of regula falsi, to `4 eps max(|t|, |h|)`. A terminal event
    /// ends the run there: the integrator restarts at the root
    /// ([`restart`](Self::restart)) and the output times after it are not
    /// reached.
    ///
    /// # Errors
    /// As [`solve_at`](Self::solve_at); [`OdeError::DimensionMismatch`] for
    /// events of another size.
    fn solve_at_with_events(
        &mut self,
        times: &[f64],
        events: &mut Events<'_>,
    ) -> Result<Solution, OdeError>
    where
        Self: Sized,
    {
        solve_at(self, times, Some(events))
    }
}

/// The result of [`Integrator::integrate_with_events`].
#[derive(Debug, Clone, PartialEq)]
pub struct EventRun {
    /// The time reached (the root of a terminal event, if one ended the run).
    pub t: f64,
    /// The events located, in time order.
    pub events: Vec<EventHit>,
    /// True when a terminal event ended the run.
    pub terminal: bool,
    /// True when the callback stopped the run.
    pub stopped_by_callback: bool,
    /// The integrator's counters after the run.
    pub stats: Stats,
}

/// The result of [`Integrator::solve_at`].
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The output times reached (all requested ones unless a terminal event stopped the run).
    pub t: Vec<f64>,
    /// The states at `t`, one after the other (`dim` values each).
    pub values: Vec<f64>,
    /// The events located, in time order.
    pub events: Vec<EventHit>,
    /// The statistics after the run.
    pub stats: Stats,
    dim: usize,
}

impl Solution {
    /// The state at `t[i]`.
    pub fn y(&self, i: usize) -> &[f64] {
        &self.values[i * self.dim..(i + 1) * self.dim]
    }
}

/// The driver of [`Integrator::solve_at`] and
/// [`Integrator::solve_at_with_events`].
fn solve_at<I: Integrator>(
    ode: &mut I,
    times: &[f64],
    events: Option<&mut Events<'_>>,
) -> Result<Solution, OdeError> {
    for (i, &t) in times.iter().enumerate() {
        if !t.is_finite() || t < ode.t() || (i > 0 && t < times[i - 1]) {
            return Err(OdeError::InvalidParameter {
                name: "times",
                value: t,
                reason: "must be finite, non-decreasing and not before the current time",
            });
        }
    }
    let n = ode.state().len();
    let mut sol = Solution {
        t: Vec::with_capacity(times.len()),
        values: Vec::with_capacity(times.len() * n),
        events: Vec::new(),
        stats: ode.stats(),
        dim: n,
    };
    let Some(&t_end) = times.last() else {
        return Ok(sol);
    };
    let mut next = 0;
    while next < times.len() && times[next] <= ode.t() {
        sol.t.push(times[next]);
        sol.values.extend_from_slice(ode.state());
        next += 1;
    }
    let mut y = vec![0.0; n];
    let mut failed = None;
    let run = ode.integrate_with_events(t_end, events, |ode, (_, t_stop), _| {
        while next < times.len() && times[next] <= t_stop {
            if let Err(e) = ode.interpolate(times[next], &mut y) {
                failed = Some(e);
                return ControlFlow::Break(());
            }
            sol.t.push(times[next]);
            sol.values.extend_from_slice(&y);
            next += 1;
        }
        ControlFlow::Continue(())
    })?;
    if let Some(e) = failed {
        return Err(e);
    }
    sol.events = run.events;
    sol.stats = run.stats;
    Ok(sol)
}

/// How close below `t_end` counts as on it: `max(1e-9 h, 8 eps |t_end|)`
/// with `h` the next nominal step, capped at `h <= max(|t_end|, t_end - t)`
/// so that a step far longer than the whole run (h = 1e300 for a 0.02 s
/// run) does not make the run a sliver to skip.
pub fn landing_slack(t: f64, t_end: f64, h_next: f64) -> f64 {
    let h = h_next.min(t_end.abs().max(t_end - t));
    let h = if h.is_nan() { 0.0 } else { h };
    (1e-9 * h).max(8.0 * f64::EPSILON * t_end.abs())
}

/// Checks the arguments of a dense output on `[t_prev, t]` of a state of
/// length `n`.
pub(crate) fn check_dense_output(
    t: f64,
    t_prev: f64,
    t_end: f64,
    len: usize,
    n: usize,
) -> Result<(), OdeError> {
    if len != n {
        return Err(OdeError::DimensionMismatch {
            what: "interpolation output",
            expected: n,
            found: len,
        });
    }
    let slack = 8.0 * f64::EPSILON * t_end.abs().max(t.abs());
    if !(t >= t_prev - slack && t <= t_end + slack) {
        return Err(OdeError::InvalidParameter {
            name: "t",
            value: t,
            reason: "dense output is available in the last step only",
        });
    }
    Ok(())
}

/// `max_growth * max(1, max_i |s_i|)`: a larger state is a blow-up.
pub(crate) fn growth_bound(max_growth: f64, s: &[f64]) -> f64 {
    max_growth * s.iter().fold(1.0f64, |m, x| m.max(x.abs()))
}

/// A blown-up state is an error: `max_i |s_i| > bound`.
pub(crate) fn check_growth(s: &[f64], bound: f64, t: f64) -> Result<(), OdeError> {
    let norm = s.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if norm > bound {
        return Err(OdeError::StateGrowth { t, norm, bound });
    }
    Ok(())
}

/// NaN or infinity in `v` is an error.
pub(crate) fn check_finite(v: &[f64], what: &'static str, t: f64) -> Result<(), OdeError> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(OdeError::NonFinite { what, t })
    }
}

/// A new state's time must be finite.
pub(crate) fn check_time(t: f64) -> Result<(), OdeError> {
    if t.is_finite() {
        Ok(())
    } else {
        Err(OdeError::InvalidParameter {
            name: "t",
            value: t,
            reason: "must be finite",
        })
    }
}
