//! [`Simulation`]: a mass-spring model, an integrator (explicit, symplectic,
//! implicit, BDF, or explicit with the velocity filter), its Newton and PCG
//! settings, run step by step or to an end time, with output sinks.

use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use hookean_filter::{FilterCoupling, FilterOptions, ModelIntegrator};
use hookean_massspring::{Energies, MassSpringModel, State};
use hookean_ode::{
    ForcingTerm, Method, NewtonMethod, NewtonOptions, Predictor, SolverOptions, Stats, StepReport,
};
use hookean_sparse::PrecondKind;

use crate::error::HookeanError;

/// How a [`Simulation`] integrates.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// The integration method. Default [`Method::ImplicitEuler`].
    pub method: Method,
    /// Step size, step control, Newton and PCG settings. Default: see
    /// [`SimulationOptions::drape_solver`].
    pub solver: SolverOptions,
    /// The velocity filter applied after every step of an explicit method
    /// (the filtering paper), with `hookean-filter`'s default coupling (the
    /// step's velocity change is filtered). Default `None`.
    pub filter: Option<FilterOptions>,
}

impl SimulationOptions {
    /// The solver settings of the reference drape: `h = 0.01`; Newton
    /// starts from the current velocity and stops at `|G| <= 0.1 |G_0|` (at
    /// most 8 iterations); inexact Newton with a constant forcing term
    /// `eta = 0.01` (PCG stops at `|r| <= 0.01 |G|`); PCG with MIC(0)
    /// (`omega = 0.99`), warm-started from the previous step's velocity
    /// change.
    ///
    /// Why these (measured on the 64 x 64 drape against a tightly converged
    /// run, docs/PERFORMANCE.md): with the clamped Jacobian Newton converges
    /// only linearly, so a tight nonlinear tolerance costs over 100 Newton
    /// and 10 000 PCG iterations per step. A tight linear solve and a loose
    /// nonlinear stop make almost every step one Newton iteration (the
    /// linearly implicit step of Baraff and Witkin, checked against the
    /// nonlinear residual) with about 14 PCG iterations: MIC(0) halves
    /// IC(0)'s iterations on these systems, and the warm start halves them
    /// again. Over 5 s the cloth's mean height stays within 3 cm of the
    /// tight run (RMS), closer than the earlier block-Jacobi settings (eta
    /// = 0.1, 7 cm). Looser settings let the swinging cloth gain energy;
    /// so do these on a cloth ten times stiffer (k = 1e5), where
    /// `newton_rtol` must be tightened. The extrapolating predictor
    /// ([`Predictor::Extrapolate`]) with a relative tolerance gains energy
    /// too (the tolerance is relative to a residual that is sometimes large).
    pub fn drape_solver() -> SolverOptions {
        SolverOptions {
            h: 0.01,
            newton: NewtonOptions {
                method: NewtonMethod::Inexact(ForcingTerm::Constant(0.01)),
                max_iter: 8,
                rtol: 0.1,
                atol: 1e-12,
                linear_rtol: 0.1,
                linear_max_iter: Some(500),
                preconditioner: PrecondKind::Mic0 {
                    omega: PrecondKind::MIC_OMEGA,
                },
                ..SolverOptions::default_newton()
            },
            predictor: Predictor::Previous,
            warm_start: true,
            ..SolverOptions::default()
        }
    }
}

impl Default for SimulationOptions {
    fn default() -> Self {
        Self {
            method: Method::ImplicitEuler,
            solver: Self::drape_solver(),
            filter: None,
        }
    }
}

/// What a run did: the integrator's counters and the clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSummary {
    /// Simulated time reached.
    pub t: f64,
    /// Simulated seconds covered by this run.
    pub simulated: f64,
    /// Wall-clock time of the steps (outputs excluded).
    pub wall: Duration,
    /// Steps, rejections, f and Jacobian evaluations, Newton and CG iterations.
    pub stats: Stats,
    /// Whether a callback stopped the run early.
    pub stopped: bool,
}

impl RunSummary {
    /// Simulated seconds per wall-clock second.
    pub fn speed(&self) -> f64 {
        self.simulated / self.wall.as_secs_f64().max(1e-12)
    }
}

/// A consumer of simulation output (frames, statistics, pictures).
pub trait Sink {
    /// Called after every accepted step.
    ///
    /// # Errors
    /// An output error stops the run.
    fn step(&mut self, sim: &Simulation, report: &StepReport) -> Result<(), HookeanError>;

    /// Called once at the end of a run.
    ///
    /// # Errors
    /// An output error.
    fn finish(&mut self, _sim: &Simulation, _summary: &RunSummary) -> Result<(), HookeanError> {
        Ok(())
    }
}

/// A mass-spring model in motion.
///
/// ```
/// use hookean::prelude::*;
///
/// // The reference drape at 16 x 16 particles, one tenth of a second.
/// let (model, state) = cloth(&ClothParams { nu: 16, nv: 16, ..Default::default() })?;
/// let mut sim = Simulation::new(model, state, SimulationOptions::default())?;
/// let summary = sim.run_until(0.1, |_, _| std::ops::ControlFlow::Continue(()))?;
/// assert_eq!(summary.stats.steps, 10);
/// assert!(sim.x().iter().all(|v| v.is_finite()));
/// # Ok::<(), hookean::HookeanError>(())
/// ```
pub struct Simulation {
    integrator: ModelIntegrator,
    wall: Duration,
}

impl Simulation {
    /// A simulation of `model` from `state` at `t = 0`.
    ///
    /// # Errors
    /// [`HookeanError::InvalidOption`] for a filter with an implicit method;
    /// the integrator's and the filter's errors for bad options or states.
    pub fn new(
        model: MassSpringModel,
        state: State,
        options: SimulationOptions,
    ) -> Result<Self, HookeanError> {
        if options.filter.is_some() && options.method.is_implicit() {
            return Err(HookeanError::InvalidOption {
                name: "filter".into(),
                message: format!(
                    "the velocity filter is for explicit methods; {} is implicit (it filters by itself)",
                    options.method
                ),
            });
        }
        let filter = options.filter.map(|f| (f, FilterCoupling::default()));
        let integrator =
            ModelIntegrator::new(model, &state, options.method, options.solver, filter)?;
        Ok(Self {
            integrator,
            wall: Duration::ZERO,
        })
    }

    /// Advances one accepted step (and filters the velocities, if a filter is set).
    ///
    /// # Errors
    /// The integrator's typed errors (they carry the time reached).
    pub fn step(&mut self) -> Result<StepReport, HookeanError> {
        let t0 = Instant::now();
        let report = self.integrator.step()?;
        self.wall += t0.elapsed();
        Ok(report)
    }

    /// Steps until `t_end` with the integrators' landing rule (the last step
    /// is shortened to end exactly on `t_end`, see
    /// [`SecondOrderIntegrator::step_to`](hookean_ode::SecondOrderIntegrator::step_to)),
    /// calling `on_step` after each; `ControlFlow::Break` stops early.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn run_until(
        &mut self,
        t_end: f64,
        mut on_step: impl FnMut(&Simulation, &StepReport) -> ControlFlow<()>,
    ) -> Result<RunSummary, HookeanError> {
        let (t_start, wall_start) = (self.t(), self.wall);
        let mut stopped = false;
        loop {
            let t0 = Instant::now();
            let report = self.integrator.step_to(t_end)?;
            self.wall += t0.elapsed();
            let Some(report) = report else { break };
            if on_step(self, &report).is_break() {
                stopped = true;
                break;
            }
        }
        Ok(RunSummary {
            t: self.t(),
            simulated: self.t() - t_start,
            wall: self.wall - wall_start,
            stats: self.stats(),
            stopped,
        })
    }

    /// As [`run_until`](Self::run_until), feeding every step to the sinks.
    ///
    /// # Errors
    /// As [`step`](Self::step), and the sinks' output errors.
    pub fn run_with_sinks(
        &mut self,
        t_end: f64,
        sinks: &mut [&mut dyn Sink],
    ) -> Result<RunSummary, HookeanError> {
        let mut failure = None;
        let summary = self.run_until(t_end, |sim, report| {
            for s in sinks.iter_mut() {
                if let Err(e) = s.step(sim, report) {
                    failure = Some(e);
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(())
        })?;
        if let Some(e) = failure {
            return Err(e);
        }
        for s in sinks.iter_mut() {
            s.finish(self, &summary)?;
        }
        Ok(summary)
    }

    /// Simulated time.
    pub fn t(&self) -> f64 {
        self.integrator.t()
    }

    /// Positions.
    pub fn x(&self) -> &[f64] {
        self.integrator.x()
    }

    /// Velocities.
    pub fn v(&self) -> &[f64] {
        self.integrator.v()
    }

    /// The model.
    pub fn model(&self) -> &MassSpringModel {
        self.integrator.model()
    }

    /// Mutable access to the model between steps (forces, pins, colliders).
    /// A velocity filter reads the pins from the model at every step, so a
    /// particle pinned (or released) here is kept out of (or back in) the
    /// filter from the next step on.
    pub fn model_mut(&mut self) -> &mut MassSpringModel {
        self.integrator.model_mut()
    }

    /// Counters of everything done so far.
    pub fn stats(&self) -> Stats {
        self.integrator.stats()
    }

    /// The step size the next step will try.
    pub fn h_next(&self) -> f64 {
        self.integrator.inner().h_next()
    }

    /// The method.
    pub fn method(&self) -> &Method {
        self.integrator.inner().method()
    }

    /// Wall-clock time spent stepping so far.
    pub fn wall(&self) -> Duration {
        self.wall
    }

    /// Kinetic, gravitational and spring energy of the current state.
    ///
    /// # Errors
    /// The model's errors (a NaN state).
    pub fn energies(&self) -> Result<Energies, HookeanError> {
        Ok(self.model().energies(self.x(), self.v())?)
    }
}
