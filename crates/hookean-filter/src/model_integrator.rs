//! [`ModelIntegrator`]: the one integrator path of a mass-spring model,
//! with or without the velocity filter. The facade's `Simulation` and the
//! paper's experiments both step through it.

use hookean_massspring::{MassSpringModel, State};
use hookean_ode::{Method, SecondOrderIntegrator, SolverOptions, Stats, StepReport};

use crate::error::FilterError;
use crate::filtered::{FilterCoupling, FilteredIntegrator};
use crate::velocity::{FilterOptions, VelocityFilter};

/// A mass-spring model integrated by a plain integrator (explicit,
/// symplectic, implicit, BDF) or by an explicit one whose velocities are
/// filtered after every step (section 4.1 of the filtering paper).
///
/// One `match` per call, outside the inner loops. The filter reads the
/// pinned particles from the model through the step's constraints, so pins
/// changed with [`model_mut`](Self::model_mut) take effect at the next step.
///
/// ```
/// use hookean_filter::{FilterOptions, FilterCoupling, ModelIntegrator};
/// use hookean_massspring::{ClothParams, cloth};
/// use hookean_ode::{Method, SolverOptions};
///
/// let (model, state) = cloth(&ClothParams { nu: 8, nv: 8, ..Default::default() })?;
/// let filter = Some((FilterOptions::default(), FilterCoupling::default()));
/// let mut run = ModelIntegrator::new(model, &state, Method::FbEuler, SolverOptions::with_h(1e-4), filter)?;
/// while run.step_to(0.01)?.is_some() {}
/// assert_eq!(run.t(), 0.01);
/// # Ok::<(), hookean_filter::FilterError>(())
/// ```
pub enum ModelIntegrator {
    /// A plain integrator, boxed (it is large).
    Plain(Box<SecondOrderIntegrator<MassSpringModel>>),
    /// An explicit integrator followed by the velocity filter, boxed.
    Filtered(Box<FilteredIntegrator<MassSpringModel>>),
}

impl ModelIntegrator {
    /// Integrates `model` from `state` at `t = 0` with `method` and
    /// `options`; `filter` (explicit methods only) wraps the integrator in a
    /// [`FilteredIntegrator`] with the given coupling.
    ///
    /// # Errors
    /// [`FilterError::ImplicitMethod`] for a filter with an implicit method
    /// (from [`FilteredIntegrator::new`]);
    /// the integrator's and the filter's construction errors.
    pub fn new(
        model: MassSpringModel,
        state: &State,
        method: Method,
        options: SolverOptions,
        filter: Option<(FilterOptions, FilterCoupling)>,
    ) -> Result<Self, FilterError> {
        model.check_state(&state.x, &state.v)?;
        let vf = match &filter {
            Some((o, _)) => Some(VelocityFilter::from_model(&model, o.clone())?),
            None => None,
        };
        let inner = SecondOrderIntegrator::new(model, method, 0.0, &state.x, &state.v, options)?;
        Ok(match (vf, filter) {
            (Some(f), Some((_, c))) => {
                ModelIntegrator::Filtered(Box::new(FilteredIntegrator::new(inner, f, c)?))
            }
            _ => ModelIntegrator::Plain(Box::new(inner)),
        })
    }

    /// One step (filtered if a filter is set).
    ///
    /// # Errors
    /// The integrator's errors (they carry the time reached).
    pub fn step(&mut self) -> Result<StepReport, FilterError> {
        match self {
            ModelIntegrator::Plain(i) => Ok(i.step()?),
            ModelIntegrator::Filtered(f) => f.step(),
        }
    }

    /// One step that does not pass `t_end`, or `None` once `t_end` is
    /// reached: the landing rule of
    /// [`SecondOrderIntegrator::step_to`].
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn step_to(&mut self, t_end: f64) -> Result<Option<StepReport>, FilterError> {
        match self {
            ModelIntegrator::Plain(i) => Ok(i.step_to(t_end)?),
            ModelIntegrator::Filtered(f) => f.step_to(t_end),
        }
    }

    /// The integrator (inside the filter, if any).
    pub fn inner(&self) -> &SecondOrderIntegrator<MassSpringModel> {
        match self {
            ModelIntegrator::Plain(i) => i,
            ModelIntegrator::Filtered(f) => f.inner(),
        }
    }

    /// The model, mutably (forces, pins, colliders), between steps.
    pub fn model_mut(&mut self) -> &mut MassSpringModel {
        match self {
            ModelIntegrator::Plain(i) => i.problem_mut(),
            ModelIntegrator::Filtered(f) => f.inner_mut().problem_mut(),
        }
    }

    /// Current time.
    pub fn t(&self) -> f64 {
        self.inner().t()
    }

    /// Current positions.
    pub fn x(&self) -> &[f64] {
        self.inner().x()
    }

    /// Current velocities.
    pub fn v(&self) -> &[f64] {
        self.inner().v()
    }

    /// The model.
    pub fn model(&self) -> &MassSpringModel {
        self.inner().problem()
    }

    /// The integrator's counters.
    pub fn stats(&self) -> Stats {
        self.inner().stats()
    }

    /// Total energy (kinetic + gravitational + spring) of the current state;
    /// infinite for a non-finite state.
    pub fn energy(&self) -> f64 {
        match self.model().energies(self.x(), self.v()) {
            Ok(e) if e.total().is_finite() => e.total(),
            _ => f64::INFINITY,
        }
    }
}
