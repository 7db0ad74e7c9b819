//! Filtered explicit integrators: any explicit integrator of `hookean-ode`
//! followed by the velocity filter (section 4 of the filtering paper), the
//! integrator itself a black box.

use hookean_ode::{
    Integrator, Method, OdeError, SecondOrderIntegrator, SecondOrderProblem, Stats, StepReport,
};

use crate::error::FilterError;
use crate::velocity::VelocityFilter;

/// How the filtered velocities are handed back to the integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FilterCoupling {
    /// Replace the velocities only: `v_{n+1} <- F v_{n+1}`, positions as the
    /// integrator left them. For FB Euler this is the cyclic order
    /// kick-drift-filter, whose positions moved with the *unfiltered*
    /// velocity; in the linear analysis of a mode with stiffness eigenvalue
    /// `a` and filter eigenvalue `phi` it is stable for `h^2 a < 2 (1 + phi)`,
    /// i.e. *less* stable than no filter (`h^2 a < 4`) - kept to show it.
    VelocityOnly,
    /// Replace the velocities and move the positions by the change the
    /// filter made over the step: `x_{n+1} <- x_{n+1} + h (F v_{n+1} - v_{n+1})`.
    /// For FB Euler this is exactly `x_{n+1} = x_n + h F v_{n+1}`,
    /// the filter between the kick and the drift, stable for
    /// `h^2 a phi < 2 (1 + phi)`: the filter enlarges the step by about
    /// `sqrt((1 + phi) / (2 phi))`, less than the `1 / sqrt(phi)` the
    /// modified power method predicts (Algorithm 1 iterates `F A`).
    CorrectPositions,
    /// Filter the velocity *change* of the step (the force filtering the
    /// paper mentions in section 4): `dv = v_{n+1} - v_n`,
    /// `v_{n+1} <- v_n + F dv`, and the positions moved by the share of the
    /// step's acceleration they took: `x_{n+1} <- x_{n+1} + theta h (F dv - dv)`
    /// with `theta` of the method (`x_{n+1} = x_n + h v_n + theta h^2 a` for
    /// a constant acceleration `a`): 1 for FB Euler, 0 for explicit Euler,
    /// 1/2 for Verlet, the midpoint rule and RK4, `sum_i b_i c_i` for a
    /// tableau ([`position_weight`]).
    /// For FB Euler this is `v_{n+1} = v_n + h F M^-1 f_n`, stable for
    /// `h^2 a phi < 4`: exactly `dt_max = 2 / sqrt(k0)` with the `k0` of the
    /// modified power method (the largest eigenvalue of `F A`). It does not
    /// damp the velocity itself. The default: it is the coupling for which
    /// the modified power method's prediction holds for FB Euler (measured
    /// within 2-5% on the drape and the rope, see `docs/perf/filter.md`); for
    /// Verlet and RK4 the gain is small (1.03x, 1.1x).
    #[default]
    Increment,
}

impl FilterCoupling {
    /// The three couplings, in the order of their names below.
    pub const ALL: [FilterCoupling; 3] = [
        FilterCoupling::Increment,
        FilterCoupling::VelocityOnly,
        FilterCoupling::CorrectPositions,
    ];

    /// The name scenes use: `"increment"`, `"velocity"` (the paper's
    /// literal scheme, section 4.1) or `"positions"`.
    pub fn name(self) -> &'static str {
        match self {
            FilterCoupling::Increment => "increment",
            FilterCoupling::VelocityOnly => "velocity",
            FilterCoupling::CorrectPositions => "positions",
        }
    }
}

impl std::fmt::Display for FilterCoupling {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for FilterCoupling {
    type Err = FilterError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| FilterError::UnknownCoupling { name: s.into() })
    }
}

/// Counters of a filtered run, besides the integrator's own [`Stats`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FilterStats {
    /// Filter applications (one per accepted step).
    pub applications: usize,
}

/// An explicit integrator of `hookean-ode` turned into its filtered version,
/// a decorator that keeps the same stepping contract ([`Integrator`]):
/// every step ([`step_bounded`](Integrator::step_bounded), and so `step`,
/// `step_to` and the drivers) runs the integrator's step, filters the
/// velocities with a [`VelocityFilter`] and writes the state back in place
/// ([`SecondOrderIntegrator::modify_state`]). Works with forward Euler, FB
/// Euler, Verlet, RK4 and any explicit tableau; allocates nothing per step.
/// A failure of the filter inside a step is
/// [`OdeError::AfterStep`] (a non-finite position: the run has blown up).
///
/// Changing the state restarts the integrator's cached values: Verlet
/// then evaluates the force twice per step instead of once.
pub struct FilteredIntegrator<P: SecondOrderProblem> {
    inner: SecondOrderIntegrator<P>,
    filter: VelocityFilter,
    coupling: FilterCoupling,
    theta: f64,
    /// The step's velocity change (increment coupling) or the unfiltered
    /// velocities (the others): the filter's input.
    dv: Vec<f64>,
    /// `v_n`, the velocity at the start of the step (increment coupling).
    prev: Vec<f64>,
    /// Whether `prev` holds the integrator's current velocity: the filtered
    /// step writes it in its last pass; [`inner_mut`](Self::inner_mut)
    /// clears it, and the next step copies the velocity again.
    prev_valid: bool,
    stats: FilterStats,
}

impl<P: SecondOrderProblem> FilteredIntegrator<P> {
    /// Wraps `inner` (an explicit method) with `filter`.
    ///
    /// # Errors
    /// [`FilterError::ImplicitMethod`] for an implicit method (they filter by
    /// themselves, the paper's section 3.3), [`FilterError::DimensionMismatch`]
    /// if the filter's particle count does not match the problem.
    pub fn new(
        inner: SecondOrderIntegrator<P>,
        filter: VelocityFilter,
        coupling: FilterCoupling,
    ) -> Result<Self, FilterError> {
        if inner.method().is_implicit() {
            return Err(FilterError::ImplicitMethod {
                method: inner.method().to_string(),
            });
        }
        let n = inner.x().len();
        if 3 * filter.n_particles() != n {
            return Err(FilterError::DimensionMismatch {
                what: "filter (3 x particles) against the problem dimension",
                expected: n,
                found: 3 * filter.n_particles(),
            });
        }
        let theta = position_weight(inner.method());
        Ok(Self {
            inner,
            filter,
            coupling,
            theta,
            dv: vec![0.0; n],
            prev: vec![0.0; n],
            prev_valid: false,
            stats: FilterStats::default(),
        })
    }

    /// Keeps `v_n` for the increment coupling (unless the last filtered
    /// step left it in `prev` already).
    fn remember_velocity(&mut self) {
        if self.coupling == FilterCoupling::Increment && !self.prev_valid {
            self.prev.copy_from_slice(self.inner.v());
        }
        self.prev_valid = false;
    }

    /// Filters, in place, the state the integrator's step `report` reached
    /// (section 4.1): one pass to form the filter's input, the filter, one
    /// pass to write velocities and positions back.
    fn filter_step(&mut self, report: StepReport) -> Result<StepReport, FilterError> {
        self.filter_state(report.h)?;
        self.prev_valid = self.coupling == FilterCoupling::Increment;
        self.stats.applications += 1;
        Ok(report)
    }

    /// The filter's pass over the state after a step of size `h`.
    fn filter_state(&mut self, step_h: f64) -> Result<(), FilterError> {
        // Particles the step held in all directions (the model's pins) keep
        // their velocity.
        self.filter
            .pin_fully_constrained(self.inner.constraints())?;
        // Time-dependent weights (if asked for): the distances of x_{n+1}.
        self.filter.update_distances(self.inner.x())?;
        let coupling = self.coupling;
        let h = match coupling {
            FilterCoupling::VelocityOnly => 0.0,
            FilterCoupling::CorrectPositions => step_h,
            FilterCoupling::Increment => self.theta * step_h,
        };
        let (filter, dv, prev) = (&self.filter, &mut self.dv, &mut self.prev);
        // The filter is a convex combination (normalised non-negative
        // weights), so a finite step (which the integrator checked) stays
        // finite; the next step checks the state again.
        self.inner.modify_state(|x, v| -> Result<(), FilterError> {
            if coupling == FilterCoupling::Increment {
                // Filter the increment dv = v_{n+1} - v_n: v = v_n + F dv and
                // x = x_{n+1} + h (F dv - dv), since v - v_{n+1} = F dv - dv.
                filter.apply_increment(v, x, prev, dv, h)?;
            } else {
                dv.copy_from_slice(v);
                filter.apply_to(dv, v)?;
                if h != 0.0 {
                    for ((v, x), r) in v.iter().zip(x.iter_mut()).zip(dv.iter()) {
                        *x += h * (v - r);
                    }
                }
            }
            Ok(())
        })
    }

    /// The current (filtered) positions.
    pub fn x(&self) -> &[f64] {
        self.inner.x()
    }

    /// The current (filtered) velocities.
    pub fn v(&self) -> &[f64] {
        self.inner.v()
    }

    /// The filter's counters.
    pub fn filter_stats(&self) -> FilterStats {
        self.stats
    }

    /// The wrapped integrator.
    pub fn inner(&self) -> &SecondOrderIntegrator<P> {
        &self.inner
    }

    /// The wrapped integrator, mutably (e.g. to reset its state).
    pub fn inner_mut(&mut self) -> &mut SecondOrderIntegrator<P> {
        self.prev_valid = false;
        &mut self.inner
    }

    /// The filter.
    pub fn filter(&self) -> &VelocityFilter {
        &self.filter
    }

    /// The filter, mutably (e.g. to follow pins made after construction
    /// with [`VelocityFilter::set_pinned`]).
    pub fn filter_mut(&mut self) -> &mut VelocityFilter {
        &mut self.filter
    }

    /// The coupling.
    pub fn coupling(&self) -> FilterCoupling {
        self.coupling
    }

    /// Unwraps the integrator.
    pub fn into_inner(self) -> SecondOrderIntegrator<P> {
        self.inner
    }
}

impl<P: SecondOrderProblem + 'static> Integrator for FilteredIntegrator<P> {
    type Problem = P;

    fn t(&self) -> f64 {
        self.inner.t()
    }

    fn t_prev(&self) -> f64 {
        self.inner.t_prev()
    }

    fn state(&self) -> &[f64] {
        self.inner.state()
    }

    fn stats(&self) -> Stats {
        self.inner.stats()
    }

    fn h_next(&self) -> f64 {
        self.inner.h_next()
    }

    fn problem(&self) -> &P {
        self.inner.problem()
    }

    fn problem_mut(&mut self) -> &mut P {
        self.prev_valid = false;
        self.inner.problem_mut()
    }

    /// The integrator's bounded step, then the filter (section 4.1).
    fn step_bounded(&mut self, t_bound: f64) -> Result<StepReport, OdeError> {
        self.remember_velocity();
        let report = self.inner.step_bounded(t_bound)?;
        self.filter_step(report).map_err(|e| match e {
            FilterError::Ode(e) => e,
            e => OdeError::AfterStep {
                t: self.inner.t(),
                source: Box::new(e),
            },
        })
    }

    fn land_on(&mut self, t_end: f64) {
        self.inner.land_on(t_end);
    }

    /// The straight line between the ends of the last (filtered) step.
    fn interpolate(&self, t: f64, out: &mut [f64]) -> Result<(), OdeError> {
        self.inner.interpolate(t, out)
    }

    fn restart(&mut self, t: f64, y: &[f64]) -> Result<(), OdeError> {
        self.prev_valid = false;
        self.inner.restart(t, y)
    }

    fn count_event_evaluations(&mut self, n: usize) {
        self.inner.count_event_evaluations(n);
    }

    /// The wrapped integrator's state and the filter's counter
    /// (`filter.applications`). Nothing else of the filter carries over:
    /// its pins and (time-dependent) weights are set again from the step's
    /// constraints and positions before every application, and `v_n` of
    /// the increment coupling is the velocity the last filtered step left
    /// (it writes both in one pass), copied again at the next step.
    fn save_state(&self, record: &mut hookean_ode::StateRecord) -> Result<(), OdeError> {
        self.inner.save_state(record)?;
        record.put_scalar("filter.applications", self.stats.applications as f64);
        Ok(())
    }

    fn restore_state(&mut self, record: &hookean_ode::StateRecord) -> Result<(), OdeError> {
        let applications = record.count("filter.applications")?;
        self.inner.restore_state(record)?;
        self.stats.applications = applications;
        self.prev_valid = false;
        Ok(())
    }
}

/// `theta` of an explicit method: the weight of the step's acceleration in
/// its position update, `x_{n+1} = x_n + h v_n + theta h^2 a` for a constant
/// acceleration `a` (`sum_i b_i c_i` of the tableau run on the first-order
/// form): 1 for FB Euler, 0 for explicit Euler, 1/2 for Verlet, the
/// midpoint rule and RK4. Implicit methods get 1/2 (they are not wrapped).
pub fn position_weight(method: &Method) -> f64 {
    match method {
        Method::FbEuler => 1.0,
        Method::ExplicitEuler => 0.0,
        Method::ExplicitRk(t) => t.b().iter().zip(t.c()).map(|(b, c)| b * c).sum(),
        _ => 0.5,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hookean_ode::ButcherTableau;

    #[test]
    fn position_weight_is_sum_b_c_of_the_tableau() {
        // RK4: b = (1/6, 1/3, 1/3, 1/6), c = (0, 1/2, 1/2, 1): sum b c = 1/2.
        let rk4 = position_weight(&Method::ExplicitRk(ButcherTableau::rk4()));
        assert!((rk4 - 0.5).abs() < 1e-15);
        assert_eq!(
            position_weight(&Method::ExplicitRk(ButcherTableau::explicit_euler())),
            0.0
        );
        let mid = position_weight(&Method::ExplicitRk(ButcherTableau::explicit_midpoint()));
        assert!((mid - 0.5).abs() < 1e-15);
        assert_eq!(position_weight(&Method::FbEuler), 1.0);
        assert_eq!(position_weight(&Method::Rk4), 0.5);
    }
}
