//! [`ModelIntegrator`]: the one integrator path of a mass-spring model,
//! with or without the velocity filter. The facade's `Simulation` and the
//! paper's experiments both step through it.

use std::ops::{Deref, DerefMut};

use hookean_massspring::{MassSpringModel, State};
use hookean_ode::{Integrator, Method, SecondOrderIntegrator, SolverOptions};

use crate::error::FilterError;
use crate::filtered::{FilterCoupling, FilteredIntegrator};
use crate::velocity::{FilterOptions, VelocityFilter};

/// A mass-spring model integrated by a plain integrator (explicit,
/// symplectic, implicit, BDF) or by an explicit one whose velocities are
/// filtered after every step (section 4.1 of the filtering paper).
///
/// It is the stepping contract ([`Integrator`], reached through `Deref`:
/// `step`, `step_to`, `t`, `stats`, `problem_mut`, ...) of the one or the
/// other, chosen at construction, plus the state's halves and the energy.
/// The filter reads the pinned particles from the model through the step's
/// constraints, so pins changed with
/// [`problem_mut`](Integrator::problem_mut) take effect at the next step.
///
/// ```
/// use hookean_filter::{FilterOptions, FilterCoupling, ModelIntegrator};
/// use hookean_massspring::{ClothParams, cloth};
/// use hookean_ode::{Integrator, Method, SolverOptions};
///
/// let (model, state) = cloth(&ClothParams { nu: 8, nv: 8, ..Default::default() })?;
/// let filter = Some((FilterOptions::default(), FilterCoupling::default()));
/// let mut run = ModelIntegrator::new(model, &state, Method::FbEuler, SolverOptions::with_h(1e-4), filter)?;
/// while run.step_to(0.01)?.is_some() {}
/// assert_eq!(run.t(), 0.01);
/// # Ok::<(), hookean_filter::FilterError>(())
/// ```
pub struct ModelIntegrator {
    ode: Box<dyn Integrator<Problem = MassSpringModel> + Send>,
    method: Method,
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
        let inner =
            SecondOrderIntegrator::new(model, method.clone(), 0.0, &state.x, &state.v, options)?;
        let ode: Box<dyn Integrator<Problem = MassSpringModel> + Send> = match (vf, filter) {
            (Some(f), Some((_, c))) => Box::new(FilteredIntegrator::new(inner, f, c)?),
            _ => Box::new(inner),
        };
        Ok(Self { ode, method })
    }

    /// The method.
    pub fn method(&self) -> &Method {
        &self.method
    }

    /// Current positions.
    pub fn x(&self) -> &[f64] {
        let s = self.ode.state();
        &s[..s.len() / 2]
    }

    /// Current velocities.
    pub fn v(&self) -> &[f64] {
        let s = self.ode.state();
        &s[s.len() / 2..]
    }

    /// Total energy (kinetic + gravitational + spring) of the current state;
    /// infinite for a non-finite state.
    pub fn energy(&self) -> f64 {
        match self.ode.problem().energies(self.x(), self.v()) {
            Ok(e) if e.total().is_finite() => e.total(),
            _ => f64::INFINITY,
        }
    }
}

impl Deref for ModelIntegrator {
    type Target = dyn Integrator<Problem = MassSpringModel> + Send;

    fn deref(&self) -> &Self::Target {
        &*self.ode
    }
}

impl DerefMut for ModelIntegrator {
    fn deref_mut(&mut self) -> &mut Self::Target {
        &mut *self.ode
    }
}
