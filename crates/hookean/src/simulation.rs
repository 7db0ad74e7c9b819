//! [`Simulation`]: a mass-spring model, an integrator (explicit, symplectic,
//! implicit, BDF, or explicit with the velocity filter), its Newton and PCG
//! settings, run step by step or to an end time, with output sinks.

use crate::NonExhaustive;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use hookean_filter::{FilterCoupling, FilterOptions, ModelIntegrator};
use hookean_massspring::{Collider, ContactCarry, Energies, MassSpringModel, State};
use hookean_ode::{
    ForcingTerm, Method, NewtonMethod, NewtonOptions, PcgOptions, Predictor, SolverOptions, Stats,
    StepReport,
};
use hookean_sparse::{PowerParams, PrecondKind};

use crate::error::HookeanError;
use crate::pin_work::PinWork;

mod checkpoint;

/// How a [`Simulation`] integrates.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationOptions {
    /// The integration method. Default [`Method::ImplicitEuler`].
    pub method: Method,
    /// Step size, step control, Newton and PCG settings. Default: see
    /// [`SimulationOptions::drape_solver`].
    pub solver: SolverOptions,
    /// The velocity filter applied after every step of an explicit method
    /// (the filtering paper). Default `None`.
    pub filter: Option<FilterOptions>,
    /// How the filtered velocities go back into the integrator (read only
    /// with a `filter`). Default [`FilterCoupling::Increment`] (the step's
    /// velocity change is filtered); [`FilterCoupling::VelocityOnly`] is the
    /// paper's literal scheme.
    pub filter_coupling: FilterCoupling,
    /// The energy check: a run stops with [`HookeanError::BlowUp`] once
    /// its total energy (kinetic + gravitational + spring + the external
    /// forces' potential) exceeds the starting total (plus what moving
    /// colliders and driven pins can give) by more than this factor times the scene's
    /// energy scale (see [`Simulation`]). Default `1e3`; `f64::INFINITY`
    /// turns it off.
    pub blow_up_factor: f64,
    /// The energy budget: a step whose total energy, counted after the
    /// put-back of the particles it left inside a collider
    /// ([`MassSpringModel::put_back_contacts`]), exceeds the starting total
    /// (plus what moving colliders and driven pins can give) by more than this fraction of
    /// the scene's energy scale is redone as 2, 4, ..., 64
    /// substeps; if even those cannot keep it, the run stops with
    /// [`HookeanError::EnergyGain`]. Default `0.05` (the integrator's own
    /// error allowed by docs/CONTACT.md, "Energy"); `f64::INFINITY` turns it
    /// off.
    pub energy_budget: f64,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl SimulationOptions {
    /// The solver settings of the reference drape: `h = 0.01`; Newton
    /// starts from the current velocity and stops at `|G| <= 0.1 |G_0|` or
    /// when `|G|` is below 1e-8 m/s times the mean mass (at most 8
    /// iterations); inexact Newton with a constant forcing term
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
            // h: the default step, hookean_ode::DEFAULT_STEP = 0.01.
            newton: NewtonOptions {
                method: NewtonMethod::Inexact(ForcingTerm::Constant(0.01)),
                max_iter: 8,
                rtol: 0.1,
                // A velocity (m/s; the integrator multiplies it by the mean
                // mass): it ends Newton at round-off once the model is at
                // rest, where `rtol` relative to a round-off `|G_0|`
                // cannot be met.
                atol: 1e-8,
                linear_rtol: 0.1,
                ..SolverOptions::default_newton()
            },
            linear: PcgOptions {
                max_iter: Some(500),
                preconditioner: PrecondKind::Mic0 {
                    omega: PrecondKind::MIC_OMEGA,
                }
                .into(),
                ..PcgOptions::default()
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
            filter_coupling: FilterCoupling::default(),
            blow_up_factor: 1e3,
            energy_budget: 0.05,
            non_exhaustive: NonExhaustive(()),
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
    /// Called once before the first step of a run, with the starting state
    /// (e.g. to write frame 0).
    ///
    /// # Errors
    /// An output error stops the run before it starts.
    fn start(&mut self, _sim: &Simulation) -> Result<(), HookeanError> {
        Ok(())
    }

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
/// Every step is checked against the energy the run can have: it stops
/// with [`HookeanError::BlowUp`], naming the time, the step, the energy term
/// that grew and, for explicit methods, the stable step `dt_max`, as soon
/// as its total energy (kinetic + gravitational + spring + the external
/// forces' potential) exceeds the starting total plus what moving
/// colliders and the pins driven along a path can give plus
/// [`SimulationOptions::blow_up_factor`] times the
/// scene's energy scale (springs, damping, friction and static colliders
/// only take energy out, so no valid motion comes near the bound; the
/// bound is made precise in the crate's docs/RELIABILITY.md).
///
/// ```
/// use hookean::prelude::*;
///
/// // The reference drape at 16 x 16 particles, one tenth of a second.
/// let (model, state) = cloth(&ClothParams { nu: 16, nv: 16, ..Default::default() })?;
/// let mut sim = Simulation::new(model, state, SimulationOptions::default())?;
/// let summary = sim.run_until(0.1)?;
/// assert_eq!(summary.stats.num_steps, 10);
/// assert!(sim.x().iter().all(|v| v.is_finite()));
/// # Ok::<(), hookean::HookeanError>(())
/// ```
pub struct Simulation {
    integrator: ModelIntegrator,
    wall: Duration,
    guard: EnergyGuard,
    /// The energies of the current state, when the blow-up check has
    /// computed them ([`energies`](Simulation::energies) returns them instead
    /// of a second pass); `None` once the state or the model may have changed.
    current: Option<Energies>,
}

/// The energy check of a [`Simulation`].
///
/// Springs, damping, air friction, friction and static colliders only take
/// energy out, pins without a path do no work and gravity and the constant
/// external forces are counted by their potentials, so along any valid
/// motion the total `E = K + G + S + X` (kinetic, gravitational, spring and
/// the external forces' potential, [`MassSpringModel::energies`]) never
/// exceeds its start `E_0` plus the work `W_pins(t)` of the pins driven
/// along a path (counted step by step, `pin_work.rs`: hard pins by their
/// reaction `R_i = m_i a_i - f_i`, `W += sum_i [m_i (|v_i^{n+1}|^2 -
/// |v_i^n|^2) / 2 - (f_i^n + f_i^{n+1}) . (x_i^{n+1} - x_i^n) / 2]`, soft
/// pins by the stored energy their moving targets change); a moving mesh
/// collider can add at most what its surface
/// speed `U` explains: the speed it gives (`2 M U^2`, a bounce off it) and
/// the lift against the weight `W = M |g| + sum_p |F_p|` over the distance
/// it travels (`W U (t - t_0)`). The check allows
/// `E <= E_0 + 2 M U^2 + W U (t - t_0) + W_pins(t) + factor * scale` with the energy
/// scale `scale = K_0 + S_0 + W D + 1e-6 M D^2 / (1 s)^2` (`M` the total
/// mass, `D` the diagonal of the starting bounding box; the last term
/// keeps a scene at rest without gravity from tripping on round-off) and
/// `U = max (|v| + |omega| (|c - x_c| + D))` over the moving colliders (`c`
/// the pivot, `x_c` the box's centre; for a keyframed path its largest
/// rates and the pivot's farthest reach, for a deforming sequence its
/// largest vertex speed). Wind counts as such a body moving
/// at the air's fastest speed `|w_0| + A` ([`Wind::max_speed`](hookean_massspring::Wind::max_speed)):
/// in the air's frame drag and lift never do positive work, so like a
/// moving surface the air can bring the cloth up to its speed and carry
/// it against its weight over the distance it blows. An unstable integrator, a solver
/// that stopped far from the solution or a contact that stores energy
/// breaks it by orders of magnitude. It costs one
/// [`energies`](MassSpringModel::energies) per step: a pass over the
/// particles and one over the springs, no allocation (and, with driven
/// hard pins, one [`free_force`](MassSpringModel::free_force)). A step
/// redone in substeps restarts `W_pins` from its value at the step's start.
#[derive(Debug, Clone)]
struct EnergyGuard {
    factor: f64,
    /// [`SimulationOptions::energy_budget`].
    budget: f64,
    /// The state `[x; v]` at the start of the current step, to redo it.
    y0: Vec<f64>,
    /// The model's contact state at the start of the current step (the
    /// last step's size, self-collision's candidate list), to redo it.
    carry: ContactCarry,
    /// The put-back state of the energy budget's check (positions, velocities).
    landed: (Vec<f64>, Vec<f64>),
    /// The start; `None` until it is taken.
    baseline: Option<Baseline>,
    /// Positions at the baseline, for the stable-step hint.
    x0: Vec<f64>,
    /// `W_pins(t)`: the work of the pins driven along a path since the
    /// baseline (`pin_work.rs`).
    pins: PinWork,
}

/// What the energy check compares with.
#[derive(Debug, Clone, Copy)]
struct Baseline {
    t0: f64,
    start: Energies,
    /// The bound at `t0`: `E_0 + 2 M U^2 + factor * scale`.
    bound: f64,
    /// The energy budget at `t0`: `E_0 + 2 M U^2 + budget * scale`.
    budget: f64,
    /// `W U`: the power moving colliders can give (W).
    collider_power: f64,
}

impl EnergyGuard {
    /// Takes `E_0`, the scale and the colliders' allowance from the state at `t0`.
    fn baseline(
        &mut self,
        model: &MassSpringModel,
        x: &[f64],
        v: &[f64],
        t0: f64,
    ) -> Result<(), HookeanError> {
        let e = model.energies(x, v)?;
        let total_mass: f64 = model.particle_masses().iter().sum();
        let norm = |a: &[f64]| a.iter().map(|c| c * c).sum::<f64>().sqrt();
        let weight = total_mass * norm(&model.options().gravity)
            + model
                .external_forces()
                .chunks_exact(3)
                .map(norm)
                .sum::<f64>();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in x.chunks_exact(3) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let d2: f64 = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum();
        let d = d2.sqrt();
        let centre: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        // The wind is a moving body of speed |w_0| + A for the bound.
        let wind = model.wind().map_or(0.0, |w| w.max_speed());
        let u = collider_speed(model, centre, d).max(wind);
        let scale = e.kinetic + e.spring + weight * d + 1e-6 * total_mass * d2;
        self.baseline = Some(Baseline {
            t0,
            start: e,
            // An infinite factor turns its check off (also at `scale = 0`).
            bound: if self.factor.is_finite() {
                e.total() + 2.0 * total_mass * u * u + self.factor * scale
            } else {
                f64::INFINITY
            },
            budget: if self.budget.is_finite() {
                e.total() + 2.0 * total_mass * u * u + self.budget * scale
            } else {
                f64::INFINITY
            },
            collider_power: weight * u,
        });
        self.x0.clear();
        self.x0.extend_from_slice(x);
        self.pins.reset(model, x, v);
        Ok(())
    }
}

impl Baseline {
    /// The bound at time `t`.
    fn bound(&self, t: f64) -> f64 {
        self.bound + self.collider_work(t)
    }

    /// The energy budget at time `t`.
    fn budget(&self, t: f64) -> f64 {
        self.budget + self.collider_work(t)
    }

    /// `W U (t - t0)`: the most work moving colliders can do by `t`.
    fn collider_work(&self, t: f64) -> f64 {
        if self.collider_power > 0.0 {
            self.collider_power * (t - self.t0)
        } else {
            0.0
        }
    }
}

/// The most substeps the energy budget redoes a step in (docs/CONTACT.md).
pub const MAX_SUBSTEPS: usize = 64;

/// The largest surface speed of the moving mesh colliders near the cloth
/// at the start (0 without them): `|v| + |omega| (|c - centre| + d)` for a
/// rigid body (a keyframed path's largest rates, its pivot's farthest
/// reach added to the arm), the largest vertex speed of a deforming
/// sequence ([`MeshCollider::max_surface_speed`](hookean_massspring::MeshCollider::max_surface_speed)).
fn collider_speed(model: &MassSpringModel, centre: [f64; 3], d: f64) -> f64 {
    model
        .colliders()
        .iter()
        .filter_map(|c| match c {
            Collider::Mesh { mesh, .. } if !mesh.motion().is_static() => {
                Some(mesh.max_surface_speed(centre, d))
            }
            _ => None,
        })
        .fold(0.0, f64::max)
}

/// The term of `now` that grew the most from `start` (a non-finite one first).
fn grown_term(start: &Energies, now: &Energies) -> (&'static str, f64, f64) {
    let pairs = start.terms().into_iter().zip(now.terms());
    let mut best = ("kinetic", start.kinetic, now.kinetic);
    let mut growth = f64::NEG_INFINITY;
    for ((name, e0), (_, e)) in pairs {
        if !e.is_finite() {
            return (name, e0, e);
        }
        if e - e0 > growth {
            growth = e - e0;
            best = (name, e0, e);
        }
    }
    best
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
        if !(options.blow_up_factor > 0.0) {
            return Err(HookeanError::InvalidOption {
                name: "blow_up_factor".into(),
                message: format!(
                    "must be positive (f64::INFINITY turns the check off), got {:?}",
                    options.blow_up_factor
                ),
            });
        }
        if !(options.energy_budget > 0.0) {
            return Err(HookeanError::InvalidOption {
                name: "energy_budget".into(),
                message: format!(
                    "must be positive (f64::INFINITY turns the budget off), got {:?}",
                    options.energy_budget
                ),
            });
        }
        let filter = options.filter.map(|f| (f, options.filter_coupling));
        let integrator =
            ModelIntegrator::new(model, &state, options.method, options.solver, filter)?;
        Ok(Self {
            integrator,
            wall: Duration::ZERO,
            guard: EnergyGuard {
                factor: options.blow_up_factor,
                budget: options.energy_budget,
                y0: Vec::new(),
                carry: ContactCarry::default(),
                landed: (Vec::new(), Vec::new()),
                baseline: None,
                x0: Vec::new(),
                pins: PinWork::default(),
            },
            current: None,
        })
    }

    /// Advances one accepted step (and filters the velocities, if a filter is set).
    ///
    /// # Errors
    /// The integrator's typed errors (they carry the time reached).
    pub fn step(&mut self) -> Result<StepReport, HookeanError> {
        self.take_baseline()?;
        let t_start = self.begin_step();
        let clock = Instant::now();
        let report = self.integrator.step();
        self.wall += clock.elapsed();
        self.end_step(t_start, report?)
    }

    /// Before a step: keeps its starting state for the energy budget (a
    /// copy of the integrator's state and of the model's contact state, no
    /// allocation after the first step) and returns its time.
    fn begin_step(&mut self) -> f64 {
        self.current = None;
        if self.budget_applies() {
            self.guard.y0.clear();
            self.guard.y0.extend_from_slice(self.integrator.state());
            self.integrator
                .problem()
                .keep_contact_carry(&mut self.guard.carry);
        }
        self.guard.pins.checkpoint();
        self.begin_pins();
        self.t()
    }

    /// Before a (sub)step: the driven soft pins' targets move to the step's
    /// start (`pin_work.rs`).
    fn begin_pins(&mut self) {
        if self.guard.baseline.is_some() {
            let (model, t, x) = (
                self.integrator.problem(),
                self.integrator.t(),
                self.integrator.x(),
            );
            self.guard.pins.begin(model, t, x);
        }
    }

    /// After a (sub)step from `t_start`: the driven hard pins' work over it.
    fn end_pins(&mut self, t_start: f64) {
        if self.guard.baseline.is_some() {
            let (model, x, v) = (
                self.integrator.problem(),
                self.integrator.x(),
                self.integrator.v(),
            );
            self.guard.pins.end(model, t_start, x, v);
        }
    }

    /// After a step from `t_start`: the blow-up check, and the step redone
    /// in substeps if it ended above the energy budget.
    fn end_step(&mut self, t_start: f64, report: StepReport) -> Result<StepReport, HookeanError> {
        self.end_pins(t_start);
        self.check_blow_up(&report)?;
        if self.over_budget()?.is_some() {
            return self.redo_in_substeps(t_start, report);
        }
        Ok(report)
    }

    /// Whether steps are checked against the energy budget (and their
    /// start kept for a redo): with a finite budget and an implicit method.
    /// Explicit methods are not: their energy growth is instability, which
    /// the blow-up check names with the stable step (substeps would hide
    /// it).
    fn budget_applies(&self) -> bool {
        self.guard.budget.is_finite() && self.integrator.method().is_implicit()
    }

    /// The energies of the current state after the put-back of the next
    /// step's contact handling, the budget and the start's energies, if
    /// their total is above the energy budget (`None` within it, or without
    /// a baseline).
    fn over_budget(&mut self) -> Result<Option<(Energies, f64, Energies)>, HookeanError> {
        let Some(baseline) = &self.guard.baseline else {
            return Ok(None);
        };
        if !self.budget_applies() {
            return Ok(None);
        }
        let budget = baseline.budget(self.t()) + self.guard.pins.work();
        let model = self.integrator.problem();
        // Cloth self-collision is checked too: a redone step restarts from
        // the model's contact state at the step's start (`begin_step`,
        // `redo_in_substeps`), without which redone steps of the 64 x 64
        // cloth-fold ended with intersecting layers (docs/CONTACT.md,
        // "Energy").
        let landed = if model.colliders().is_empty() {
            match self.current {
                Some(e) => e,
                None => model.energies(self.integrator.x(), self.integrator.v())?,
            }
        } else {
            let (x, v) = &mut self.guard.landed;
            x.clear();
            x.extend_from_slice(self.integrator.x());
            v.clear();
            v.extend_from_slice(self.integrator.v());
            model.put_back_contacts(self.integrator.t(), x, v);
            model.energies(x, v)?
        };
        // `!(<=)` also catches a NaN energy.
        Ok((!(landed.total() <= budget)).then_some((landed, budget, baseline.start)))
    }

    /// Redoes the step from `(t_start, y0)` to the end of `first` as `m =
    /// 2, 4, ..., MAX_SUBSTEPS` substeps until every substep ends within
    /// the energy budget: the put-back of a particle that a long step
    /// carried deep into a collider is what stores contact energy in the
    /// springs, and the depth shrinks with the step (as do a loose Newton
    /// stop's errors). One report for the whole step (iterations of all
    /// attempts); [`HookeanError::EnergyGain`] if even `MAX_SUBSTEPS`
    /// substeps exceed the budget.
    fn redo_in_substeps(
        &mut self,
        t_start: f64,
        first: StepReport,
    ) -> Result<StepReport, HookeanError> {
        let t_end = first.t;
        let mut report = StepReport {
            rejected: first.rejected + 1,
            h: t_end - t_start,
            ..first
        };
        let mut m = 2;
        loop {
            let clock = Instant::now();
            self.integrator.restart(t_start, &self.guard.y0)?;
            self.integrator
                .problem_mut()
                .restore_contact_carry(&self.guard.carry)?;
            self.guard.pins.restore();
            let mut failed = None;
            'substeps: for j in 1..=m {
                let t_j = if j == m {
                    t_end
                } else {
                    t_start + (t_end - t_start) * j as f64 / m as f64
                };
                while self.t() < t_j {
                    self.current = None;
                    let t_sub = self.t();
                    self.begin_pins();
                    let r = self.integrator.step_bounded(t_j)?;
                    self.end_pins(t_sub);
                    report.rejected += r.rejected;
                    report.newton_iterations += r.newton_iterations;
                    report.linear_iterations += r.linear_iterations;
                    report.error_estimate = r.error_estimate;
                    report.h_next = r.h_next;
                    self.check_blow_up(&r)?;
                    if let Some(e) = self.over_budget()? {
                        failed = Some(e);
                        break 'substeps;
                    }
                }
            }
            self.wall += clock.elapsed();
            let Some((landed, budget, start)) = failed else {
                return Ok(report);
            };
            if m >= MAX_SUBSTEPS {
                let (term, term_start, term_now) = grown_term(&start, &landed);
                return Err(HookeanError::EnergyGain {
                    t: self.t(),
                    step: self.stats().num_steps,
                    energy: landed.total(),
                    budget,
                    fraction: self.guard.budget,
                    term,
                    term_start,
                    term_now,
                    substeps: m,
                });
            }
            report.rejected += 1;
            m *= 2;
        }
    }

    /// Takes the energy check's baseline from the current state, unless it
    /// is taken (it is dropped by [`model_mut`](Self::model_mut)).
    fn take_baseline(&mut self) -> Result<(), HookeanError> {
        if self.guard.baseline.is_none()
            && (self.guard.factor.is_finite() || self.guard.budget.is_finite())
        {
            let (model, x, v, t) = (
                self.integrator.problem(),
                self.integrator.x(),
                self.integrator.v(),
                self.integrator.t(),
            );
            self.guard.baseline(model, x, v, t)?;
        }
        Ok(())
    }

    /// [`HookeanError::BlowUp`] if the state after `report` is past the
    /// energy bound (see [`Simulation`]).
    fn check_blow_up(&mut self, report: &StepReport) -> Result<(), HookeanError> {
        let Some(baseline) = &self.guard.baseline else {
            return Ok(());
        };
        let bound = baseline.bound(self.t()) + self.guard.pins.work();
        let now = match self.model().energies(self.x(), self.v()) {
            Ok(e) => {
                self.current = Some(e);
                e
            }
            // A state that is not finite is past every bound.
            Err(hookean_massspring::MassSpringError::NonFinite { .. }) => Energies {
                kinetic: f64::NAN,
                ..Energies::default()
            },
            Err(e) => return Err(e.into()),
        };
        let energy = now.total();
        // `!(<=)` also stops a NaN energy.
        if !(energy <= bound) {
            let dt_max = if self.method().is_implicit() {
                None
            } else {
                self.model()
                    .stability(&self.guard.x0, &PowerParams::default(), None)
                    .ok()
                    .map(|s| s.dt_max)
            };
            let (term, term_start, term_now) = grown_term(&baseline.start, &now);
            return Err(HookeanError::BlowUp {
                t: self.t(),
                step: self.stats().num_steps,
                energy,
                bound,
                factor: self.guard.factor,
                term,
                term_start,
                term_now,
                h: report.h,
                dt_max,
            });
        }
        Ok(())
    }

    /// Steps until `t_end` with the integrators' landing rule (the last step
    /// is shortened to end exactly on `t_end`, see
    /// [`Integrator::step_to`](hookean_ode::Integrator::step_to)).
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn run_until(&mut self, t_end: f64) -> Result<RunSummary, HookeanError> {
        self.run_until_with(t_end, |_, _| ControlFlow::Continue(()))
    }

    /// As [`run_until`](Self::run_until), calling `on_step` after each
    /// step; `ControlFlow::Break` stops early.
    ///
    /// # Errors
    /// As [`step`](Self::step).
    pub fn run_until_with(
        &mut self,
        t_end: f64,
        mut on_step: impl FnMut(&Simulation, &StepReport) -> ControlFlow<()>,
    ) -> Result<RunSummary, HookeanError> {
        let (t_start, wall_start) = (self.t(), self.wall);
        let mut stopped = false;
        self.take_baseline()?;
        loop {
            let t_step = self.begin_step();
            let clock = Instant::now();
            let report = self.integrator.step_to(t_end);
            self.wall += clock.elapsed();
            let Some(report) = report? else { break };
            let report = self.end_step(t_step, report)?;
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

    /// As [`run_until_with`](Self::run_until_with), feeding every step to the sinks.
    ///
    /// # Errors
    /// As [`step`](Self::step), and the sinks' output errors.
    pub fn run_with_sinks(
        &mut self,
        t_end: f64,
        sinks: &mut [&mut dyn Sink],
    ) -> Result<RunSummary, HookeanError> {
        for s in sinks.iter_mut() {
            s.start(self)?;
        }
        let mut failure = None;
        let summary = self.run_until_with(t_end, |sim, report| {
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

    /// Writes the current positions to the file `path` as OBJ (the model's
    /// triangles, or its springs as lines for a rope), vertices coloured by
    /// speed (blue at rest to red at the fastest particle). An existing file
    /// at `path` is replaced.
    ///
    /// # Errors
    /// [`HookeanError::Io`] naming `path`.
    pub fn write_obj(&self, path: impl AsRef<std::path::Path>) -> Result<(), HookeanError> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| HookeanError::io(path, e))?;
        let mut w = std::io::BufWriter::new(file);
        self.write_obj_to(&mut w)
            .and_then(|()| std::io::Write::flush(&mut w).map_err(HookeanError::from))
            .map_err(|e| e.at_path(path))
    }

    /// Writes the current positions as OBJ to `w`, as [`write_obj`](Self::write_obj).
    ///
    /// # Errors
    /// [`HookeanError::MassSpring`] if writing fails.
    pub fn write_obj_to(&self, w: impl std::io::Write) -> Result<(), HookeanError> {
        let colours = hookean_massspring::speed_colours(self.v(), 0.0);
        self.model().write_obj(w, self.x(), Some(&colours))?;
        Ok(())
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
        self.integrator.problem()
    }

    /// Mutable access to the model between steps (forces, pins, colliders).
    /// A velocity filter reads the pins from the model at every step, so a
    /// particle pinned (or released) here is kept out of (or back in) the
    /// filter from the next step on.
    /// The blow-up check takes a new baseline from the state at the next
    /// step (a changed model may hold more energy).
    pub fn model_mut(&mut self) -> &mut MassSpringModel {
        self.guard.baseline = None;
        self.current = None;
        self.integrator.problem_mut()
    }

    /// Counters of everything done so far.
    pub fn stats(&self) -> Stats {
        self.integrator.stats()
    }

    /// The step size the next step will try.
    pub fn h_next(&self) -> f64 {
        self.integrator.h_next()
    }

    /// The method.
    pub fn method(&self) -> &Method {
        self.integrator.method()
    }

    /// Hands every linear system that the implicit methods' Newton gives PCG
    /// from now on, with what the solve did, to `recorder` (`None` stops
    /// it): `hookean export-system --every`. `false` when the method solves
    /// none or cannot record them
    /// ([`Integrator::record_linear_solves`](hookean_ode::Integrator::record_linear_solves)).
    pub fn record_linear_solves(
        &mut self,
        recorder: Option<hookean_nonlinear::SharedRecorder>,
    ) -> bool {
        self.integrator.record_linear_solves(recorder)
    }

    /// The work of the pins driven along a path since the energy check's
    /// baseline (the start, or the first step after
    /// [`model_mut`](Self::model_mut)), J: what the energy check adds to
    /// the start (see [`Simulation`]). Zero without such pins, or with both
    /// checks off.
    pub fn pin_work(&self) -> f64 {
        self.guard.pins.work()
    }

    /// Wall-clock time spent stepping so far.
    pub fn wall(&self) -> Duration {
        self.wall
    }

    /// Kinetic, gravitational, spring and external-force energy of the
    /// current state (computed once per step: the blow-up check's are
    /// returned when it has taken them).
    ///
    /// # Errors
    /// The model's errors (a NaN state).
    pub fn energies(&self) -> Result<Energies, HookeanError> {
        if let Some(e) = self.current {
            return Ok(e);
        }
        Ok(self.model().energies(self.x(), self.v())?)
    }
}
