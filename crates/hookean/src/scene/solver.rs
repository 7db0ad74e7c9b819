//! The method tables of a scene: `[integrator]`, `[solver]` with `[solver.amg]`, and `[filter]`.

use super::*;

/// `[integrator]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorScene {
    /// A method name of `hookean-ode` (`implicit-euler`, `implicit-midpoint`,
    /// `bdf1`..`bdf6`, `bdf2-variable`, `bdf` (variable-order BDF with error
    /// control, its first step from `rtol`/`atol`), `explicit-euler`,
    /// `midpoint`, `rk4`, `fb-euler`, `verlet`). Default `implicit-euler`.
    #[serde(default = "d_method", deserialize_with = "method")]
    pub method: Method,
    /// (Initial) step size (s), or `"auto"` for an explicit method: the
    /// largest stable step of the model at its starting state, from the
    /// (filtered) modified power method and eq. 11, times `h_safety`.
    /// Range (0, inf). Default 0.01.
    #[serde(default)]
    pub h: StepScene,
    /// The safety factor of `h = "auto"`, in (0, 1]: the cloth stiffens as
    /// it stretches, so the stable step of the starting state is an upper
    /// bound. Range (0, 1]. Default 0.8.
    #[serde(default = "d_h_safety", deserialize_with = "safety")]
    pub h_safety: f64,
    /// Step control of `bdf2-variable`: `"error"` (default) or `"newton"` (Newton iterations).
    #[serde(default)]
    pub control: ControlScene,
    /// Relative error tolerance of `bdf2-variable` and `bdf`. Range [1e-14,
    /// 1): below, the error test asks for less than a step's round-off; at 1
    /// it accepts any step. Default 1e-3.
    #[serde(default = "d_rtol", deserialize_with = "tolerance")]
    pub rtol: f64,
    /// Absolute error tolerance of `bdf2-variable` and `bdf` (m for
    /// positions, m/s for velocities). Range [1e-15, inf): below, the steps
    /// shrink to the round-off of the time. Default 1e-4.
    #[serde(default = "d_atol", deserialize_with = "absolute_tolerance")]
    pub atol: f64,
    /// Largest step (s) of `bdf2-variable` and `bdf`. Range (0, inf). Default 0.05.
    #[serde(default = "d_hmax", deserialize_with = "positive")]
    pub h_max: f64,
    /// Highest order of `bdf`. Range 1 to 5. Default 2: the orders above 2 are not
    /// A-stable (stability angles 86, 73 and 52 degrees for BDF3-5, less for
    /// the NDFs), and the lightly damped springs of a cloth have eigenvalues
    /// within a few degrees of the imaginary axis, so orders 3-5 hold the
    /// step to the springs' periods (docs/PERFORMANCE.md: the drape at
    /// order 5 takes 14 000-20 000 steps per simulated second at any `rtol`).
    #[serde(default = "d_max_order", deserialize_with = "int_in::<_, 1, 5>")]
    pub max_order: usize,
    /// Most steps of `bdf2-variable` and `bdf`: a scene whose `duration /
    /// h_max` is above it is refused (it cannot finish), a run that takes
    /// this many steps without reaching `duration` fails, and a run's work
    /// estimate counts this many steps. Range 1 to 1000000000. Default
    /// 100000.
    #[serde(
        default = "d_max_steps",
        deserialize_with = "int_in::<_, 1, 1000000000>"
    )]
    pub max_steps: usize,
    /// The energy budget ([`SimulationOptions::energy_budget`](crate::SimulationOptions::energy_budget)):
    /// a step whose total energy exceeds the start (plus what moving
    /// colliders, the wind and pins driven along a path can give) by more than this fraction of the
    /// scene's energy scale is redone in 2 to 64 substeps, and the run fails
    /// if even those exceed it; `"off"` turns the check off. Range (0, inf)
    /// or `"off"`. Default 0.05.
    #[serde(default = "d_energy_budget", deserialize_with = "energy_budget")]
    pub energy_budget: f64,
}

/// `integrator.h`: a step size in seconds or `"auto"`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepScene {
    /// A fixed (or initial) step size (s), positive and finite.
    Value(f64),
    /// The largest stable step of an explicit method times `h_safety`
    /// (resolved when the scene is built:
    /// [`auto_step`](hookean_filter::auto_step)).
    Auto,
}

impl Default for StepScene {
    fn default() -> Self {
        StepScene::Value(hookean_ode::DEFAULT_STEP)
    }
}

impl StepScene {
    /// The step size, `None` for `"auto"` (known once the model is built:
    /// [`Simulation::h_next`]).
    pub fn value(self) -> Option<f64> {
        match self {
            StepScene::Value(h) => Some(h),
            StepScene::Auto => None,
        }
    }
}

impl std::fmt::Display for StepScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StepScene::Value(h) => write!(f, "{h:?} s"),
            StepScene::Auto => f.write_str("\"auto\""),
        }
    }
}

impl<'de> Deserialize<'de> for StepScene {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Name(String),
        }
        match Raw::deserialize(d)? {
            Raw::Number(h) if h > 0.0 && h.is_finite() => Ok(StepScene::Value(h)),
            Raw::Number(h) => Err(D::Error::custom(format!(
                "must lie in {} or be \"auto\", got {}",
                crate::range::Range::POSITIVE,
                hookean_sparse::AsWritten(h)
            ))),
            Raw::Name(s) if s == "auto" => Ok(StepScene::Auto),
            Raw::Name(s) => Err(D::Error::custom(format!(
                "must lie in {} or be \"auto\", got \"{s}\"",
                crate::range::Range::POSITIVE
            ))),
        }
    }
}

pub(super) fn safety<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, crate::range::STEP_SAFETY)
}

pub(super) fn d_h_safety() -> f64 {
    0.8
}

impl Default for IntegratorScene {
    fn default() -> Self {
        Self {
            method: d_method(),
            h: StepScene::default(),
            h_safety: d_h_safety(),
            control: ControlScene::Error,
            rtol: d_rtol(),
            atol: d_atol(),
            h_max: d_hmax(),
            max_order: d_max_order(),
            max_steps: d_max_steps(),
            energy_budget: d_energy_budget(),
        }
    }
}

pub(super) fn d_method() -> Method {
    Method::ImplicitEuler
}
pub(super) fn d_rtol() -> f64 {
    1e-3
}
pub(super) fn d_atol() -> f64 {
    1e-4
}
pub(super) fn d_hmax() -> f64 {
    0.05
}
pub(super) fn d_max_order() -> usize {
    2
}
pub(super) fn d_max_steps() -> usize {
    100_000
}
pub(super) fn d_energy_budget() -> f64 {
    crate::SimulationOptions::default().energy_budget
}

/// `integrator.energy_budget`: a number in (0, inf), or `"off"` (infinity).
pub(super) fn energy_budget<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Raw {
        Number(f64),
        Name(String),
    }
    let range = crate::range::Range::POSITIVE;
    match Raw::deserialize(d)? {
        Raw::Number(b) => range
            .check(b)
            .map_err(|e| D::Error::custom(format!("{e} (or \"off\")"))),
        Raw::Name(s) if s == "off" => Ok(f64::INFINITY),
        Raw::Name(s) => Err(D::Error::custom(format!(
            "must lie in {range} or be \"off\", got \"{s}\""
        ))),
    }
}

/// Step-size control of variable-step methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ControlScene {
    /// Error-based PI control.
    #[default]
    Error,
    /// Newton-iteration control (tutorial 3.4).
    Newton,
}

/// `[solver]`: Newton and PCG.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverScene {
    /// `"inexact"` (default), `"exact"`, `"simplified"` or `"inexact-simplified"`.
    #[serde(default)]
    pub newton: NewtonScene,
    /// Forcing term of the inexact variants: a number, Range (0, 1)
    /// (default 0.01, the drape's; the tutorial uses 0.02), or `"ew1"` or
    /// `"ew2"` (Eisenstat-Walker).
    #[serde(default)]
    pub forcing: ForcingScene,
    /// Nonlinear tolerance `|G| <= rtol |G_0|`. Range (0, 1). Default 0.1 (the drape's).
    #[serde(default = "d_newton_rtol", deserialize_with = "fraction")]
    pub newton_rtol: f64,
    /// Newton iteration limit. Range 1 to 1000. Default 8.
    #[serde(default = "d_newton_max", deserialize_with = "int_in::<_, 1, 1000>")]
    pub max_newton: usize,
    /// PCG tolerance of exact Newton solves. Range (0, 1). Default 1e-8.
    #[serde(default = "d_cg_rtol", deserialize_with = "fraction")]
    pub cg_rtol: f64,
    /// PCG iteration limit. Range 1 to 100000. Default 500.
    #[serde(default = "d_cg_max", deserialize_with = "int_in::<_, 1, 100000>")]
    pub max_cg: usize,
    /// `none`, `jacobi`, `block-jacobi`, `ssor`, `ic0`, `mic0`, `amg`
    /// (smoothed-aggregation multigrid with default options) or `auto`
    /// (default, `None` here): `amg` from [`AUTO_AMG_PARTICLES`] particles
    /// on, `mic0` below (measured on the drape, docs/PERFORMANCE.md).
    #[serde(default, deserialize_with = "precond")]
    pub preconditioner: Option<PrecondKind>,
    /// SSOR relaxation. Range (0, 2). Default 1.
    #[serde(default = "one", deserialize_with = "omega")]
    pub omega: f64,
    /// MIC(0) relaxation. Range [0, 1]. Default 0.99.
    #[serde(default = "d_mic_omega", deserialize_with = "mic_omega")]
    pub mic_omega: f64,
    /// Start each step's first PCG solve from the previous step's velocity
    /// change. Default true.
    #[serde(default = "yes")]
    pub warm_start: bool,
    /// Run PCG on, and set the preconditioner up from, the Newton matrix
    /// filtered by the step's constraints (contacts, pins): the constrained
    /// particles become a Dirichlet boundary for the preconditioner (exact
    /// and inexact Newton only). Default (`None` here): true for scenes with
    /// a mesh collider or self-collision, where MIC(0) then needs a third of
    /// the PCG iterations (docs/PERFORMANCE.md), false otherwise.
    #[serde(default)]
    pub filter_matrix: Option<bool>,
    /// `[solver.amg]`: the multigrid's options (only with
    /// `preconditioner = "amg"`).
    pub amg: Option<AmgScene>,
}

/// `[solver.amg]`: options of the smoothed-aggregation multigrid
/// (`hookean_sparse::AmgOptions`, whose defaults these are).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AmgScene {
    /// `"block-jacobi"` (default), `"gauss-seidel"` (symmetric) or `"ic0"`.
    #[serde(default)]
    pub smoother: AmgSmootherScene,
    /// Pre- and post-smoothing steps per level. Range 1 to 100. Default 1.
    #[serde(
        default = "one_usize",
        deserialize_with = "int_in::<_, 1, { hookean_sparse::AMG_MAX_SWEEPS }>"
    )]
    pub sweeps: usize,
    /// Strength threshold on the finest level. Range [0, 1). Default 0.08.
    #[serde(default = "d_amg_theta", deserialize_with = "strength")]
    pub strength_threshold: f64,
    /// Unknowns of the coarsest level (solved directly, a dense factor).
    /// Range 1 to 4096. Default 500.
    #[serde(
        default = "d_amg_coarse",
        deserialize_with = "int_in::<_, 1, { hookean_sparse::AMG_MAX_COARSE_SIZE }>"
    )]
    pub coarse_size: usize,
    /// At most this many levels. Range 1 to 64. Default 10.
    #[serde(
        default = "d_amg_levels",
        deserialize_with = "int_in::<_, 1, { hookean_sparse::AMG_MAX_LEVELS }>"
    )]
    pub max_levels: usize,
    /// Block-Jacobi weight times rho(D^-1 A). Range (0, 2). Default 4/3.
    #[serde(default = "d_amg_weight", deserialize_with = "amg_weight")]
    pub jacobi_weight: f64,
    /// Prolongator-smoothing weight times rho(D^-1 A). Range (0, 2). Default 4/3.
    #[serde(default = "d_amg_weight", deserialize_with = "amg_weight")]
    pub prolongation_weight: f64,
    /// Power-method steps of the spectral radius estimates (0: Gershgorin).
    /// Range 0 to 100. Default 5.
    #[serde(
        default = "d_amg_power",
        deserialize_with = "int_in::<_, 0, { hookean_sparse::AMG_MAX_SWEEPS }>"
    )]
    pub power_iterations: usize,
    /// Power steps at a refill (0: keep the last estimates). Range 0 to 100.
    /// Default 0.
    #[serde(
        default = "d_amg_refill_power",
        deserialize_with = "int_in::<_, 0, { hookean_sparse::AMG_MAX_SWEEPS }>"
    )]
    pub refill_power_iterations: usize,
    /// A refill keeps the prolongators. Default false.
    #[serde(default)]
    pub keep_prolongators: bool,
    /// What a new Jacobian (same pattern) does to the hierarchy: `"refill"`
    /// (default), `"rebuild"` or `"keep"` (for `keep_updates` Newton
    /// iterations, then refill).
    #[serde(default)]
    pub reuse: AmgReuseScene,
    /// Set-ups that keep the hierarchy with `reuse = "keep"`. Range 1 to
    /// 1000. Default 4.
    #[serde(default = "d_amg_keep", deserialize_with = "int_in::<_, 1, 1000>")]
    pub keep_updates: usize,
    /// Storage of the hierarchy's matrices: `"single"` (default: f32, half
    /// the memory traffic of a V-cycle) or `"double"` (f64, as before issue
    /// 25); the arithmetic is f64 either way.
    #[serde(default)]
    pub precision: AmgPrecisionScene,
}

/// The storage precision of the multigrid's matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AmgPrecisionScene {
    /// f32 entries.
    #[default]
    Single,
    /// f64 entries.
    Double,
}

/// The multigrid's smoother.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AmgSmootherScene {
    /// Block damped Jacobi.
    #[default]
    BlockJacobi,
    /// Symmetric block Gauss-Seidel.
    GaussSeidel,
    /// Block IC(0).
    Ic0,
}

/// The multigrid's re-use of its hierarchy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum AmgReuseScene {
    /// Refill the numbers, keep aggregates and patterns.
    #[default]
    Refill,
    /// A full set-up every time.
    Rebuild,
    /// Keep the whole hierarchy for `keep_updates` set-ups.
    Keep,
}

impl AmgScene {
    /// The library's options.
    pub fn options(&self) -> AmgOptions {
        AmgOptions {
            strength_threshold: self.strength_threshold,
            coarse_size: self.coarse_size,
            max_levels: self.max_levels,
            smoother: match self.smoother {
                AmgSmootherScene::BlockJacobi => AmgSmoother::BlockJacobi,
                AmgSmootherScene::GaussSeidel => AmgSmoother::SymmetricGaussSeidel,
                AmgSmootherScene::Ic0 => AmgSmoother::BlockIc0,
            },
            sweeps: self.sweeps,
            jacobi_weight: self.jacobi_weight,
            prolongation_weight: self.prolongation_weight,
            power_iterations: self.power_iterations,
            refill_power_iterations: self.refill_power_iterations,
            keep_prolongators: self.keep_prolongators,
            reuse: match self.reuse {
                AmgReuseScene::Refill => AmgReuse::Refill,
                AmgReuseScene::Rebuild => AmgReuse::Rebuild,
                AmgReuseScene::Keep => AmgReuse::Keep {
                    updates: self.keep_updates,
                },
            },
            precision: match self.precision {
                AmgPrecisionScene::Single => AmgPrecision::Single,
                AmgPrecisionScene::Double => AmgPrecision::Double,
            },
            ..AmgOptions::default()
        }
    }
}

pub(super) fn one_usize() -> usize {
    1
}
pub(super) fn d_amg_theta() -> f64 {
    AmgOptions::default().strength_threshold
}
pub(super) fn d_amg_coarse() -> usize {
    AmgOptions::default().coarse_size
}
pub(super) fn d_amg_levels() -> usize {
    AmgOptions::default().max_levels
}
pub(super) fn d_amg_weight() -> f64 {
    AmgOptions::default().jacobi_weight
}
pub(super) fn d_amg_power() -> usize {
    AmgOptions::default().power_iterations
}
pub(super) fn d_amg_refill_power() -> usize {
    AmgOptions::default().refill_power_iterations
}
pub(super) fn d_amg_keep() -> usize {
    4
}

pub(super) fn strength<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, crate::range::AMG_STRENGTH)
}

pub(super) fn amg_weight<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, crate::range::AMG_WEIGHT)
}

impl Default for SolverScene {
    fn default() -> Self {
        Self {
            newton: NewtonScene::Inexact,
            forcing: ForcingScene::default(),
            newton_rtol: d_newton_rtol(),
            max_newton: d_newton_max(),
            cg_rtol: d_cg_rtol(),
            max_cg: d_cg_max(),
            preconditioner: None,
            omega: 1.0,
            mic_omega: d_mic_omega(),
            warm_start: true,
            filter_matrix: None,
            amg: None,
        }
    }
}

pub(super) fn d_newton_rtol() -> f64 {
    0.1
}
pub(super) fn d_newton_max() -> usize {
    8
}
pub(super) fn d_cg_rtol() -> f64 {
    1e-8
}
pub(super) fn d_mic_omega() -> f64 {
    PrecondKind::MIC_OMEGA
}
pub(super) fn d_cg_max() -> usize {
    500
}

/// The Newton variant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NewtonScene {
    /// Inexact Newton (Algorithm 2).
    #[default]
    Inexact,
    /// Newton with tight linear solves (Algorithm 1).
    Exact,
    /// Simplified Newton.
    Simplified,
    /// Inexact simplified Newton with the linearised Jacobian (Algorithm 3).
    InexactSimplified,
}

/// A forcing term: a constant or an Eisenstat-Walker choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ForcingScene {
    /// A constant in (0, 1).
    Constant(f64),
    /// Eisenstat-Walker choice 1.
    Ew1,
    /// Eisenstat-Walker choice 2 (gamma 0.9, alpha 2).
    Ew2,
}

impl Default for ForcingScene {
    fn default() -> Self {
        ForcingScene::Constant(0.01)
    }
}

impl<'de> Deserialize<'de> for ForcingScene {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Number(f64),
            Name(String),
        }
        match Raw::deserialize(d)? {
            Raw::Number(v) if v > 0.0 && v < 1.0 => Ok(ForcingScene::Constant(v)),
            Raw::Number(v) => Err(D::Error::custom(format!(
                "a constant forcing term must lie in (0, 1), got {v:?}"
            ))),
            Raw::Name(s) if s == "ew1" => Ok(ForcingScene::Ew1),
            Raw::Name(s) if s == "ew2" => Ok(ForcingScene::Ew2),
            Raw::Name(s) => Err(D::Error::custom(format!(
                "unknown forcing term '{s}' (a number in (0, 1), \"ew1\" or \"ew2\")"
            ))),
        }
    }
}

/// `[filter]`: the velocity filter after explicit steps.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterScene {
    /// Filter sharpness lambda. Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub lambda: f64,
    /// `"exponential"` (default) or `"gaussian"`.
    #[serde(default)]
    pub kernel: KernelScene,
    /// `"symmetric"` (default) or `"plain"`.
    #[serde(default)]
    pub form: FormScene,
    /// Neighbourhood radius in rings of the spring graph. Range 1 to the
    /// memory cap of [`Scene::build_within`] (the neighbourhoods are counted). Default 1.
    #[serde(default = "d_rings", deserialize_with = "at_least_one")]
    pub rings: usize,
    /// How the filtered velocities go back into the step: `"increment"`
    /// (default: the step's velocity change is filtered and the positions
    /// follow; FB Euler's stable step is then `2 / sqrt(k0)` with the
    /// filtered k0), `"velocity"` (the paper's section 4.1 literally: the
    /// new velocities are replaced, the positions are left; measured less
    /// stable than no filter, docs/perf/filter.md) or `"positions"` (the
    /// velocities are replaced and the positions moved by the change).
    #[serde(default)]
    pub coupling: CouplingScene,
    /// The distances of the weights: `"rest"` (default: path lengths of the
    /// rest state, weights computed once) or `"current"` (the particles'
    /// distances after each step, the paper's time-dependent weights;
    /// slower, docs/perf/filter.md).
    #[serde(default)]
    pub distances: DistancesScene,
}

/// `filter.distances`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DistancesScene {
    /// Rest lengths, weights computed once.
    #[default]
    Rest,
    /// Current distances, weights recomputed every step.
    Current,
}

/// How the filtered velocities go back into the step
/// ([`FilterCoupling`](hookean_filter::FilterCoupling)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CouplingScene {
    /// [`FilterCoupling::Increment`](hookean_filter::FilterCoupling::Increment).
    #[default]
    Increment,
    /// [`FilterCoupling::VelocityOnly`](hookean_filter::FilterCoupling::VelocityOnly).
    Velocity,
    /// [`FilterCoupling::CorrectPositions`](hookean_filter::FilterCoupling::CorrectPositions).
    Positions,
}

pub(super) fn d_rings() -> usize {
    1
}

/// The filter kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KernelScene {
    /// `lambda exp(-lambda d)`.
    #[default]
    Exponential,
    /// `exp(-(lambda d)^2 / 2)`.
    Gaussian,
}

/// The filter form.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FormScene {
    /// `(v_i + sum beta v_j) / 2`.
    #[default]
    Symmetric,
    /// `sum beta v_j`.
    Plain,
}
