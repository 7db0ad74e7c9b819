//! Scene files (TOML): which model to build, how to integrate it, for how
//! long, and what to write.
//!
//! A scene has exactly one model table — `[cloth]`, `[rope]`, `[jelly]`,
//! `[mesh]` (a model from an OBJ file), `[particle]` (the tutorial's
//! example 3) or `[tutorial]` (its scalar examples 1 and 2, run as
//! first-order ODEs) — and optional `[integrator]`, `[solver]`, `[filter]`,
//! `[model]`, `[[collider]]`, `[contact]` and `[output]` tables.
//! Every key has a documented default (the field docs below; `scenes/drape.toml`
//! spells them all out). Unknown keys, wrong types and out-of-range values
//! are errors that name the file, line and column.
//!
//! ```
//! let scene = hookean::scene::Scene::from_toml_str("inline.toml", r#"
//!     duration = 0.05
//!     [cloth]
//!     n = 8
//! "#)?;
//! let mut sim = scene.build()?;
//! sim.run_until(scene.duration, |_, _| std::ops::ControlFlow::Continue(()))?;
//! # Ok::<(), hookean::HookeanError>(())
//! ```

// A parser of user files: no panic on any input (tests/fuzz_scene.rs).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used))]

use std::path::Path;

use hookean_filter::{FilterCoupling, FilterOptions, Form, Kernel};
use hookean_massspring::{
    BlockParams, ClothParams, ClothPins, Collider, Friction, MeshCollider, MeshParams,
    ModelOptions, RigidMotion, RopeParams, SelfCollision, SpringDamping, SpringMaterial,
};
use hookean_ode::{ForcingTerm, Method, NewtonMethod, SolverOptions, StepControl};
use hookean_sparse::{
    AmgOptions, AmgPrecision, AmgReuse, AmgSmoother, NegativeCurvature, PrecondKind,
};
use serde::Deserialize;
use serde::de::{Deserializer, Error as _};

use crate::error::HookeanError;
use crate::simulation::{Simulation, SimulationOptions};

fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must be a positive number, got {v:?}"
        )))
    }
}

fn non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v >= 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must be a non-negative number, got {v:?}"
        )))
    }
}

fn fraction<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("must lie in (0, 1), got {v:?}")))
    }
}

fn at_least_two<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if v >= 2 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "needs at least 2 particles, got {v:?}"
        )))
    }
}

fn at_least_one<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if v >= 1 {
        Ok(v)
    } else {
        Err(D::Error::custom("must be at least 1"))
    }
}

/// An integer key in its documented range `LO..=HI` (the key's doc says
/// "Range LO to HI"; a test checks every documented range at its ends).
fn int_in<'de, D: Deserializer<'de>, const LO: usize, const HI: usize>(
    d: D,
) -> Result<usize, D::Error> {
    let v = u64::deserialize(d)?;
    if (LO as u64..=HI as u64).contains(&v) {
        Ok(v as usize)
    } else {
        Err(D::Error::custom(format!(
            "must lie in {LO} to {HI}, got {v}"
        )))
    }
}

/// Exactly three numbers (a longer or shorter array is an error, not
/// truncated).
fn three<'de, D: Deserializer<'de>, T: Deserialize<'de> + Copy>(d: D) -> Result<[T; 3], D::Error> {
    let v = Vec::<T>::deserialize(d)?;
    <[T; 3]>::try_from(v.as_slice())
        .map_err(|_| D::Error::custom(format!("must be an array of 3 numbers, got {}", v.len())))
}

fn usize3<'de, D: Deserializer<'de>>(d: D) -> Result<[usize; 3], D::Error> {
    three(d)
}

/// Largest picture side, in pixels.
const MAX_PIXELS: usize = 16_384;

fn pixels<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if (1..=MAX_PIXELS).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must lie in 1..={MAX_PIXELS} pixels, got {v:?}"
        )))
    }
}

fn finite3<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v: [f64; 3] = three(d)?;
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(D::Error::custom("components must be finite numbers"))
    }
}

fn method<'de, D: Deserializer<'de>>(d: D) -> Result<Method, D::Error> {
    let s = String::deserialize(d)?;
    s.parse().map_err(|e| D::Error::custom(format!("{e}")))
}

fn precond<'de, D: Deserializer<'de>>(d: D) -> Result<Option<PrecondKind>, D::Error> {
    let s = String::deserialize(d)?;
    if s == "auto" {
        return Ok(None);
    }
    s.parse()
        .map(Some)
        .map_err(|e| D::Error::custom(format!("{e} (or \"auto\")")))
}

fn omega<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v < 2.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "SSOR relaxation must lie in (0, 2), got {v:?}"
        )))
    }
}

fn mic_omega<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "MIC(0) relaxation must lie in [0, 1], got {v:?}"
        )))
    }
}

/// From this many particles on, `preconditioner = "auto"` takes AMG
/// instead of MIC(0). With the f32 hierarchy (issue 25, docs/PERFORMANCE.md)
/// AMG is the faster from 48 x 48 on (5 s drape, MIC(0) against AMG: 32 x 32
/// 0.65 s against 1.76 s, 40 x 40 a tie, 48 x 48 1.61 s against 1.31 s,
/// 64 x 64 3.08 s against 2.56 s), but the rule stays above the 64 x 64
/// reference drape: its inexact Newton (PCG to 1%) gives a swing that
/// depends on the preconditioner, 12.7% apart in total energy at t = 5 s
/// with AMG (f32 or f64 alike), so that drape keeps MIC(0) and its figures.
pub const AUTO_AMG_PARTICLES: usize = 10_000;

/// Every scene key with its units and default, as `hookean scene-keys`
/// prints it: generated from the field docs below by
/// `scripts/scene-keys.py` (a test checks that it names every key).
pub const KEYS: &str = include_str!("scene_keys.txt");

/// A scene: one model, how to integrate it, for how long, what to write.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Simulated seconds. Range (0, inf). Default 5.
    #[serde(default = "d_duration", deserialize_with = "positive")]
    pub duration: f64,
    /// The cloth grid model.
    pub cloth: Option<ClothScene>,
    /// The rope model.
    pub rope: Option<RopeScene>,
    /// The 3D lattice ("jelly block").
    pub jelly: Option<JellyScene>,
    /// The tutorial's example 3: one particle on a spring to the origin.
    pub particle: Option<ParticleScene>,
    /// The tutorial's examples 1 and 2: scalar ODEs (not mass-spring models),
    /// integrated as first-order systems by `hookean run`.
    pub tutorial: Option<TutorialScene>,
    /// A cloth (or any surface) from a triangle mesh in an OBJ file.
    pub mesh: Option<MeshScene>,
    /// Damping model, air friction and gravity.
    #[serde(default)]
    pub model: ModelScene,
    /// The time integrator.
    #[serde(default)]
    pub integrator: IntegratorScene,
    /// Newton and PCG.
    #[serde(default)]
    pub solver: SolverScene,
    /// The velocity filter (explicit methods only).
    pub filter: Option<FilterScene>,
    /// Planes, spheres and triangle meshes.
    #[serde(default, rename = "collider")]
    pub colliders: Vec<ColliderScene>,
    /// Cloth self-collision.
    #[serde(default)]
    pub contact: ContactScene,
    /// What to write.
    #[serde(default)]
    pub output: OutputScene,
    /// Worker threads of the kernels (rayon) when `hookean run` is not
    /// given `--threads`. Range 1 to 1024. Default: `RAYON_NUM_THREADS`,
    /// else all cores.
    /// Results are bitwise reproducible for a given thread count.
    #[serde(default, deserialize_with = "threads")]
    pub threads: Option<usize>,
    /// The folder of the scene file: relative mesh paths start there
    /// (`None`: the working directory).
    #[serde(skip)]
    base: Option<std::path::PathBuf>,
}

/// The most worker threads a scene or `--threads` may ask for (a typo of
/// 10^8 threads would otherwise spawn until the system refuses).
pub const MAX_THREADS: usize = 1024;

fn threads<'de, D: Deserializer<'de>>(d: D) -> Result<Option<usize>, D::Error> {
    let n = at_least_one(d)?;
    if n > MAX_THREADS {
        return Err(D::Error::custom(format!(
            "at most {MAX_THREADS} threads, got {n}"
        )));
    }
    Ok(Some(n))
}

fn d_duration() -> f64 {
    5.0
}

/// `[cloth]`: the reference drape of docs/ARCHITECTURE.md by default.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClothScene {
    /// Particles per side. Range 2 to the `--max-memory` cap. Default 64.
    #[serde(default = "d_cloth_n", deserialize_with = "at_least_two")]
    pub n: usize,
    /// Side length (m). Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub size: f64,
    /// Total mass (kg). Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub mass: f64,
    /// Structural and shear stiffness (N/m). Range (0, inf). Default 1e4.
    #[serde(default = "d_k", deserialize_with = "positive")]
    pub stiffness: f64,
    /// Bend stiffness (N/m); 0 leaves bend springs out. Range [0, inf). Default stiffness / 10.
    #[serde(default, deserialize_with = "opt_non_negative")]
    pub bend_stiffness: Option<f64>,
    /// Spring damping (N s/m). Range [0, inf). Default 0.1.
    #[serde(default = "d_damping", deserialize_with = "non_negative")]
    pub damping: f64,
    /// `"two-corners"` (default), `"four-corners"`, `"edge"` or `"none"`.
    #[serde(default = "d_pins")]
    pub pins: PinScene,
    /// `"horizontal"` (default: the xy plane) or `"vertical"` (the xz plane).
    #[serde(default)]
    pub plane: PlaneScene,
    /// Turns the cloth's plane about the x axis by this many degrees (right-hand rule: a horizontal cloth tilts its far edge up). Range: any finite number. Default 0.
    #[serde(default, deserialize_with = "finite")]
    pub tilt: f64,
    /// Position of the first particle. Default `[0, 0, 0]`.
    #[serde(default, deserialize_with = "finite3")]
    pub origin: [f64; 3],
}

fn opt_non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    non_negative(d).map(Some)
}

fn d_cloth_n() -> usize {
    ClothParams::default().nu
}
fn one() -> f64 {
    1.0
}
fn d_k() -> f64 {
    ClothParams::default().structural.stiffness
}
fn d_damping() -> f64 {
    ClothParams::default().structural.damping
}
fn d_pins() -> PinScene {
    PinScene::TwoCorners
}

/// Which cloth particles are pinned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PinScene {
    /// The two corners of one edge.
    TwoCorners,
    /// All four corners.
    FourCorners,
    /// A whole edge.
    Edge,
    /// None.
    None,
}

/// The cloth's plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PlaneScene {
    /// The xy plane (gravity along -z).
    #[default]
    Horizontal,
    /// The xz plane.
    Vertical,
}

/// `[rope]`: the filtering paper's figure 1.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RopeScene {
    /// Particles. Range 2 to the `--max-memory` cap. Default 20.
    #[serde(default = "d_rope_n", deserialize_with = "at_least_two")]
    pub n: usize,
    /// Length (m). Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub length: f64,
    /// Total mass (kg). Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub mass: f64,
    /// Stiffness (N/m). Range (0, inf). Default 1e4.
    #[serde(default = "d_k", deserialize_with = "positive")]
    pub stiffness: f64,
    /// Damping (N s/m). Range [0, inf). Default 0.1.
    #[serde(default = "d_damping", deserialize_with = "non_negative")]
    pub damping: f64,
    /// Direction from the first to the last particle. Default `[1, 0, 0]` (horizontal).
    #[serde(default = "d_dir", deserialize_with = "finite3")]
    pub direction: [f64; 3],
    /// Pin the first particle. Default true.
    #[serde(default = "yes")]
    pub pin_start: bool,
    /// Pin the last particle. Default false.
    #[serde(default)]
    pub pin_end: bool,
}

fn d_rope_n() -> usize {
    20
}
fn d_dir() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}
fn yes() -> bool {
    true
}

/// `[jelly]`: a block lattice with edge, face- and body-diagonal springs.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JellyScene {
    /// Particles per axis, each at least 1 (at least 2 particles in all);
    /// their product is bounded by `--max-memory`. Default `[6, 6, 6]`.
    #[serde(default = "d_jelly_n", deserialize_with = "usize3")]
    pub n: [usize; 3],
    /// Lattice spacing (m). Range (0, inf). Default 0.05.
    #[serde(default = "d_spacing", deserialize_with = "positive")]
    pub spacing: f64,
    /// Total mass (kg). Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub mass: f64,
    /// Stiffness of every spring (N/m). Range (0, inf). Default 1e3.
    #[serde(default = "d_jelly_k", deserialize_with = "positive")]
    pub stiffness: f64,
    /// Damping (N s/m). Range [0, inf). Default 0.1.
    #[serde(default = "d_damping", deserialize_with = "non_negative")]
    pub damping: f64,
    /// Minimum corner. Default `[0, 0, 0.5]`.
    #[serde(default = "d_jelly_origin", deserialize_with = "finite3")]
    pub origin: [f64; 3],
}

fn d_jelly_n() -> [usize; 3] {
    [6, 6, 6]
}
fn d_spacing() -> f64 {
    0.05
}
fn d_jelly_k() -> f64 {
    1e3
}
fn d_jelly_origin() -> [f64; 3] {
    [0.0, 0.0, 0.5]
}

/// `[mesh]`: a model from a triangle mesh in an OBJ file (a garment, a
/// flag): one particle per vertex, one spring per edge, bend springs across
/// every edge shared by two triangles, rest lengths from the file. The mesh
/// must be manifold and consistently oriented, with finite coordinates and
/// no degenerate triangle (errors name the file and line).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshScene {
    /// The OBJ file; a relative path starts at the scene file's folder.
    pub path: std::path::PathBuf,
    /// Factor on every coordinate of the file. Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub scale: f64,
    /// Added to every (scaled) vertex (m). Default `[0, 0, 0]`.
    #[serde(default, deserialize_with = "finite3")]
    pub offset: [f64; 3],
    /// Total mass (kg), lumped uniformly over the vertices. Range (0, inf). Default 1.
    #[serde(default = "one", deserialize_with = "positive")]
    pub mass: f64,
    /// Edge spring stiffness (N/m). Range (0, inf). Default 1e4.
    #[serde(default = "d_k", deserialize_with = "positive")]
    pub stiffness: f64,
    /// Bend stiffness (N/m) across shared edges; 0 leaves bend springs out. Range [0, inf). Default stiffness / 10.
    #[serde(default, deserialize_with = "opt_non_negative")]
    pub bend_stiffness: Option<f64>,
    /// Spring damping (N s/m). Range [0, inf). Default 0.1.
    #[serde(default = "d_damping", deserialize_with = "non_negative")]
    pub damping: f64,
    /// Pinned vertices, 0-based in the order of the file's `v` lines. Default none.
    #[serde(default)]
    pub pins: Vec<usize>,
    /// Pins every vertex inside the box `[[x0, y0, z0], [x1, y1, z1]]` (m, after scale and offset). Default none.
    #[serde(default)]
    pub pin_box: Option<[[f64; 3]; 2]>,
}

/// `[contact]`: cloth self-collision after Bridson, Fedkiw and Anderson
/// (2002): repulsion of close non-adjacent features inside the implicit
/// step, then a continuous collision pass with impact zones after it
/// (docs/CONTACT.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactScene {
    /// Cloth self-collision on the model's triangles. Default false.
    #[serde(default)]
    pub self_collision: bool,
    /// Self-collision thickness (m): closer non-adjacent features repel; keep it below 0.7 of the cloth's grid spacing. Range (0, inf). Default 0.004.
    #[serde(default = "d_self_thickness", deserialize_with = "positive")]
    pub self_thickness: f64,
    /// Repulsion stiffness of one self-contact pair (N/m). Range [0, inf). Default 50.
    #[serde(default = "d_self_stiffness", deserialize_with = "non_negative")]
    pub self_stiffness: f64,
}

impl Default for ContactScene {
    fn default() -> Self {
        Self {
            self_collision: false,
            self_thickness: d_self_thickness(),
            self_stiffness: d_self_stiffness(),
        }
    }
}

fn d_self_thickness() -> f64 {
    hookean_massspring::SelfCollision::default().thickness
}
fn d_self_stiffness() -> f64 {
    hookean_massspring::SelfCollision::default().stiffness
}

/// `[particle]`: the tutorial's example 3 with its parameters (no keys).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleScene {}

/// `[tutorial]`: the tutorial's example 1 (`y' = lambda y`, `y(0) = 1`) or
/// example 2 (`y'' = lambda/2 y + lambda y'` with `lambda = -5`, `y(0) = 0`,
/// `y'(0) = 1`).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TutorialScene {
    /// 1 or 2. Range 1 to 2.
    #[serde(deserialize_with = "example_number")]
    pub example: u8,
    /// `lambda` of example 1 (example 2 has its own). Range: any finite number. Default -15.
    #[serde(default = "d_lambda", deserialize_with = "finite")]
    pub lambda: f64,
}

fn d_lambda() -> f64 {
    -15.0
}

fn example_number<'de, D: Deserializer<'de>>(d: D) -> Result<u8, D::Error> {
    let v = u8::deserialize(d)?;
    if v == 1 || v == 2 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "the tutorial scenes are examples 1 and 2 (example 3 is [particle]), got {v:?}"
        )))
    }
}

fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(D::Error::custom("must be a finite number"))
    }
}

/// `[model]`: force model options shared by all builders.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelScene {
    /// `"projected"` (default), `"incorrect"` (d (v_j - v_i), damps rotation) or `"none"`.
    #[serde(default)]
    pub damping: DampingScene,
    /// Air friction c in `-c v` (N s/m). Range [0, inf). Default 0.
    #[serde(default, deserialize_with = "non_negative")]
    pub air_friction: f64,
    /// Gravity (m/s^2). Default `[0, 0, -9.81]`.
    #[serde(default = "d_gravity", deserialize_with = "finite3")]
    pub gravity: [f64; 3],
    /// Clamp compressed springs' stiffness blocks (`max(0, 1 - l0/l)`) so the
    /// step's matrix is SPD. Default `true`; `false` gives Newton the exact
    /// stiffness Jacobian, which may be indefinite where springs are
    /// compressed: PCG then stops at a direction of negative curvature and
    /// Newton takes the iterate so far (truncated CG, Newton-CG).
    #[serde(default = "d_true")]
    pub clamp_stiffness: bool,
}

fn d_true() -> bool {
    true
}

impl Default for ModelScene {
    fn default() -> Self {
        Self {
            damping: DampingScene::Projected,
            air_friction: 0.0,
            gravity: d_gravity(),
            clamp_stiffness: true,
        }
    }
}

fn d_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

/// The spring damping model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DampingScene {
    /// Along the spring.
    #[default]
    Projected,
    /// `d (v_j - v_i)`.
    Incorrect,
    /// None.
    None,
}

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
    /// Relative error tolerance of `bdf2-variable` and `bdf`. Range (0, inf). Default 1e-3.
    #[serde(default = "d_rtol", deserialize_with = "positive")]
    pub rtol: f64,
    /// Absolute error tolerance of `bdf2-variable` and `bdf` (m for
    /// positions, m/s for velocities). Range (0, inf). Default 1e-4.
    #[serde(default = "d_atol", deserialize_with = "positive")]
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
        StepScene::Value(d_h())
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
                "must be a positive number or \"auto\", got {h:?}"
            ))),
            Raw::Name(s) if s == "auto" => Ok(StepScene::Auto),
            Raw::Name(s) => Err(D::Error::custom(format!(
                "must be a positive number or \"auto\", got \"{s}\""
            ))),
        }
    }
}

fn safety<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v <= 1.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("must be in (0, 1], got {v:?}")))
    }
}

fn d_h_safety() -> f64 {
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
        }
    }
}

fn d_method() -> Method {
    Method::ImplicitEuler
}
fn d_h() -> f64 {
    0.01
}
fn d_rtol() -> f64 {
    1e-3
}
fn d_atol() -> f64 {
    1e-4
}
fn d_hmax() -> f64 {
    0.05
}
fn d_max_order() -> usize {
    2
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
    #[serde(default = "one_usize", deserialize_with = "int_in::<_, 1, 100>")]
    pub sweeps: usize,
    /// Strength threshold on the finest level. Range [0, 1). Default 0.08.
    #[serde(default = "d_amg_theta", deserialize_with = "strength")]
    pub strength_threshold: f64,
    /// Unknowns of the coarsest level (solved directly, a dense factor).
    /// Range 1 to 4096. Default 500.
    #[serde(default = "d_amg_coarse", deserialize_with = "int_in::<_, 1, 4096>")]
    pub coarse_size: usize,
    /// At most this many levels. Range 1 to 64. Default 10.
    #[serde(default = "d_amg_levels", deserialize_with = "int_in::<_, 1, 64>")]
    pub max_levels: usize,
    /// Block-Jacobi weight times rho(D^-1 A). Range (0, 2). Default 4/3.
    #[serde(default = "d_amg_weight", deserialize_with = "amg_weight")]
    pub jacobi_weight: f64,
    /// Prolongator-smoothing weight times rho(D^-1 A). Range (0, 2). Default 4/3.
    #[serde(default = "d_amg_weight", deserialize_with = "amg_weight")]
    pub prolongation_weight: f64,
    /// Power-method steps of the spectral radius estimates (0: Gershgorin).
    /// Range 0 to 100. Default 5.
    #[serde(default = "d_amg_power", deserialize_with = "int_in::<_, 0, 100>")]
    pub power_iterations: usize,
    /// Power steps at a refill (0: keep the last estimates). Range 0 to 100.
    /// Default 0.
    #[serde(
        default = "d_amg_refill_power",
        deserialize_with = "int_in::<_, 0, 100>"
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

fn one_usize() -> usize {
    1
}
fn d_amg_theta() -> f64 {
    AmgOptions::default().strength_threshold
}
fn d_amg_coarse() -> usize {
    AmgOptions::default().coarse_size
}
fn d_amg_levels() -> usize {
    AmgOptions::default().max_levels
}
fn d_amg_weight() -> f64 {
    AmgOptions::default().jacobi_weight
}
fn d_amg_power() -> usize {
    AmgOptions::default().power_iterations
}
fn d_amg_refill_power() -> usize {
    AmgOptions::default().refill_power_iterations
}
fn d_amg_keep() -> usize {
    4
}

fn strength<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if (0.0..1.0).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("must lie in [0, 1), got {v}")))
    }
}

fn amg_weight<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v < 2.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("must lie in (0, 2), got {v}")))
    }
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
            amg: None,
        }
    }
}

fn d_newton_rtol() -> f64 {
    0.1
}
fn d_newton_max() -> usize {
    8
}
fn d_cg_rtol() -> f64 {
    1e-8
}
fn d_mic_omega() -> f64 {
    PrecondKind::MIC_OMEGA
}
fn d_cg_max() -> usize {
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
    /// `--max-memory` cap (the neighbourhoods are counted). Default 1.
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

fn d_rings() -> usize {
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

/// `[[collider]]`: a plane, a sphere or a triangle mesh. Its values are
/// checked when the scene is built (errors name the collider: `[collider 2]:
/// ...`), since the `kind`-tagged table loses the position of a bad value.
/// Friction (every kind): `static_friction` (`mu_s`, default 0) and
/// `kinetic_friction` (`mu_k`, default `mu_s`), non-negative.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, tag = "kind", rename_all = "kebab-case")]
pub enum ColliderScene {
    /// The half-space above a plane.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// Its outward normal (normalised on use).
        normal: [f64; 3],
        /// Contact margin (m). Default 0.
        #[serde(default)]
        margin: f64,
        /// Static friction coefficient. Range [0, inf). Default 0.
        #[serde(default)]
        static_friction: f64,
        /// Kinetic friction coefficient. Range [0, inf). Default: the static one.
        #[serde(default)]
        kinetic_friction: Option<f64>,
    },
    /// The outside of a ball.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius (m).
        radius: f64,
        /// Contact margin (m). Default 0.
        #[serde(default)]
        margin: f64,
        /// Static friction coefficient. Range [0, inf). Default 0.
        #[serde(default)]
        static_friction: f64,
        /// Kinetic friction coefficient. Range [0, inf). Default: the static one.
        #[serde(default)]
        kinetic_friction: Option<f64>,
    },
    /// The outside of a triangle mesh read from OBJ (an open mesh: the side
    /// its counter-clockwise faces look to), kept at its thickness, at rest
    /// or moving rigidly: a vertex at `X` at time 0 is at `pivot + velocity
    /// t + R(angular_velocity t) (X - pivot)` at time `t`.
    Mesh {
        /// The OBJ file; a relative path starts at the scene file's folder.
        path: std::path::PathBuf,
        /// Factor on every coordinate. Range (0, inf). Default 1.
        #[serde(default = "one")]
        scale: f64,
        /// Added to every scaled vertex (m). Default `[0, 0, 0]`.
        #[serde(default)]
        offset: [f64; 3],
        /// Particles are kept this far from the surface (m). Range [0, inf). Default 0.005.
        #[serde(default = "d_mesh_thickness")]
        thickness: f64,
        /// Static friction coefficient. Range [0, inf). Default 0.
        #[serde(default)]
        static_friction: f64,
        /// Kinetic friction coefficient. Range [0, inf). Default: the static one.
        #[serde(default)]
        kinetic_friction: Option<f64>,
        /// Linear velocity (m/s). Default `[0, 0, 0]`.
        #[serde(default)]
        velocity: [f64; 3],
        /// Angular velocity (rad/s). Default `[0, 0, 0]`.
        #[serde(default)]
        angular_velocity: [f64; 3],
        /// The centre of rotation at time 0. Default: the centre of the
        /// mesh's bounding box.
        #[serde(default)]
        pivot: Option<[f64; 3]>,
    },
}

fn d_mesh_thickness() -> f64 {
    0.005
}

/// `[output]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputScene {
    /// OBJ frames per simulated second (0: none). Range [0, inf). Default 10.
    #[serde(default = "d_frame_rate", deserialize_with = "non_negative")]
    pub frame_rate: f64,
    /// Width of `final.png` in pixels. Range 1 to 16384. Default 800.
    #[serde(default = "d_width", deserialize_with = "pixels")]
    pub width: usize,
    /// Height of `final.png` in pixels. Range 1 to 16384. Default 600.
    #[serde(default = "d_height", deserialize_with = "pixels")]
    pub height: usize,
}

impl Default for OutputScene {
    fn default() -> Self {
        Self {
            frame_rate: d_frame_rate(),
            width: d_width(),
            height: d_height(),
        }
    }
}

/// The number of `v` records of an OBJ file, counted in fixed-size chunks
/// (no line is held in memory, so a huge file costs no memory here); 0 for
/// a file that cannot be read (building the scene then names the error).
fn obj_vertex_count(path: &Path) -> u64 {
    use std::io::Read;
    let Ok(mut file) = std::fs::File::open(path) else {
        return 0;
    };
    let mut buf = [0u8; 1 << 16];
    // 0: at a line start, 1: after a leading 'v', 2: elsewhere in a line.
    let (mut state, mut count) = (0u8, 0u64);
    loop {
        let Ok(k) = file.read(&mut buf) else {
            return count;
        };
        if k == 0 {
            return count;
        }
        for &b in &buf[..k] {
            state = match (state, b) {
                (_, b'\n') => 0,
                (0, b'v') => 1,
                (0, b' ' | b'\t') => 0,
                (1, b' ' | b'\t') => {
                    count += 1;
                    2
                }
                _ => 2,
            };
        }
    }
}

fn d_frame_rate() -> f64 {
    10.0
}
fn d_width() -> usize {
    800
}
fn d_height() -> usize {
    600
}

/// 1-based line and column of a byte offset.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

/// Sets `key` (dotted) of `table` to `value` for the override `key=value`.
fn apply_override(table: &mut toml::Table, o: &str) -> Result<(), String> {
    let (key, value) = o
        .split_once('=')
        .ok_or_else(|| "not key=value".to_string())?;
    let value: toml::Value = match toml::from_str::<toml::Table>(&format!("v = {value}")) {
        Ok(mut t) => t
            .remove("v")
            .unwrap_or_else(|| toml::Value::String(value.trim().to_string())),
        Err(_) => toml::Value::String(value.trim().to_string()),
    };
    let parts: Vec<&str> = key.trim().split('.').map(str::trim).collect();
    if parts.iter().any(|p| p.is_empty()) {
        return Err(format!("'{key}' is not a key (e.g. cloth.n)"));
    }
    let (last, tables) = parts.split_last().ok_or("empty key")?;
    let mut cursor = table;
    for part in tables {
        let entry = cursor
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cursor = entry
            .as_table_mut()
            .ok_or_else(|| format!("'{part}' is a value, not a table"))?;
    }
    cursor.insert(last.to_string(), value);
    Ok(())
}

fn scene_error(file: &str, text: &str, e: &toml::de::Error) -> HookeanError {
    let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
    HookeanError::Scene {
        file: file.to_string(),
        line,
        column,
        message: e.message().trim().to_string(),
    }
}

impl Scene {
    /// Parses a scene from TOML text; `file` names it in error messages.
    ///
    /// # Errors
    /// [`HookeanError::Scene`] with the line and column of the offending
    /// key or value.
    pub fn from_toml_str(file: &str, text: &str) -> Result<Self, HookeanError> {
        Self::with_overrides(file, text, &[])
    }

    /// Reads a scene file and applies `key=value` overrides as
    /// [`with_overrides`](Self::with_overrides) does.
    ///
    /// ```
    /// use hookean::scene::Scene;
    /// let scene = Scene::from_file(
    ///     concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/drape.toml"),
    ///     &["cloth.n=16", "duration=0.1"],
    /// )?;
    /// let mut sim = scene.build()?;
    /// sim.run_until(scene.duration, |_, _| std::ops::ControlFlow::Continue(()))?;
    /// # Ok::<(), hookean::HookeanError>(())
    /// ```
    ///
    /// # Errors
    /// [`HookeanError::Io`] if it cannot be read; as [`with_overrides`](Self::with_overrides).
    pub fn from_file(path: impl AsRef<Path>, overrides: &[&str]) -> Result<Self, HookeanError> {
        let path = path.as_ref();
        // A scene is a few kilobytes: 16 MiB is far beyond any, and /dev/zero stops there.
        let text = std::fs::File::open(path)
            .map_err(|e| HookeanError::io(path, e))
            .and_then(|f| {
                hookean_sparse::text::read_capped(f, Self::MAX_FILE_BYTES).map_err(|e| match e {
                    hookean_sparse::text::TextError::Io(e) => HookeanError::io(path, e),
                    e => HookeanError::Scene {
                        file: path.display().to_string(),
                        line: e.line().unwrap_or(1),
                        column: 1,
                        message: e.to_string(),
                    },
                })
            })?;
        let mut scene = Self::with_overrides(&path.display().to_string(), &text, overrides)?;
        scene.base = path.parent().map(Path::to_path_buf);
        Ok(scene)
    }

    /// Parses a scene and applies `key=value` overrides (`cloth.n=32`,
    /// `integrator.method="fb-euler"`; the value is TOML, a bare word is
    /// taken as a string) in order, each replacing the key's value in the
    /// file. An error an override causes names that override (`--set
    /// cloth.k=1: unknown field ...`), not a position in the merged text.
    ///
    /// # Errors
    /// As [`from_toml_str`](Self::from_toml_str) for the file itself;
    /// [`HookeanError::Override`] for an override that is not `key=value`,
    /// names a key below a value, or makes the scene invalid (the first
    /// override after which the scene no longer parses is named).
    pub fn with_overrides(
        file: &str,
        text: &str,
        overrides: &[&str],
    ) -> Result<Self, HookeanError> {
        let scene: Scene = toml::from_str(text).map_err(|e| scene_error(file, text, &e))?;
        if overrides.is_empty() {
            scene.check().map_err(|message| HookeanError::Scene {
                file: file.to_string(),
                line: 1,
                column: 1,
                message,
            })?;
            return Ok(scene);
        }
        let mut table: toml::Table =
            toml::from_str(text).map_err(|e| scene_error(file, text, &e))?;
        let mut scene = scene;
        for o in overrides {
            let blame = |message: String| HookeanError::Override {
                file: file.to_string(),
                arg: o.to_string(),
                message,
            };
            apply_override(&mut table, o).map_err(blame)?;
            // Parsing after each override names the one that breaks the scene.
            scene = toml::Value::Table(table.clone())
                .try_into()
                .map_err(|e: toml::de::Error| blame(e.message().trim().to_string()))?;
        }
        // The model-table rule holds for the result, not each intermediate:
        // the scene after the last override breaks it.
        scene.check().map_err(|message| HookeanError::Override {
            file: file.to_string(),
            arg: overrides.last().map_or_else(String::new, |o| o.to_string()),
            message,
        })?;
        Ok(scene)
    }

    /// Whole-scene rules serde cannot express: exactly one model table, and
    /// `[solver.amg]` only with the multigrid preconditioner (`"amg"`, or
    /// `"auto"`, which picks it for large models).
    fn check(&self) -> Result<(), String> {
        let models = [
            self.cloth.is_some(),
            self.rope.is_some(),
            self.jelly.is_some(),
            self.particle.is_some(),
            self.tutorial.is_some(),
            self.mesh.is_some(),
        ]
        .iter()
        .filter(|&&b| b)
        .count();
        if let (Some(_), Some(p)) = (&self.solver.amg, self.solver.preconditioner)
            && p != PrecondKind::Amg
        {
            return Err(format!(
                "solver.amg: [solver.amg] is given but solver.preconditioner is \"{p}\", not \"amg\" or \"auto\""
            ));
        }
        if self.integrator.h == StepScene::Auto && self.tutorial.is_some() {
            return Err(
                "integrator.h: \"auto\" is the stable step of a mass-spring model; a [tutorial] scene needs a number"
                    .into(),
            );
        }
        if models != 1 {
            return Err(format!(
                "a scene needs exactly one model table ([cloth], [rope], [jelly], [mesh], [particle] or [tutorial]), found {models}"
            ));
        }
        Ok(())
    }

    /// The model options of the scene.
    fn model_options(&self) -> ModelOptions {
        ModelOptions {
            damping: match self.model.damping {
                DampingScene::Projected => SpringDamping::Projected,
                DampingScene::Incorrect => SpringDamping::Incorrect,
                DampingScene::None => SpringDamping::None,
            },
            air_friction: self.model.air_friction,
            gravity: self.model.gravity,
            clamp_stiffness: self.model.clamp_stiffness,
            ..ModelOptions::default()
        }
    }

    /// The scene's preconditioner: `auto` resolved by the model's size,
    /// SSOR's and MIC(0)'s relaxations from `omega` and `mic_omega`.
    pub fn preconditioner(&self) -> PrecondKind {
        let s = &self.solver;
        let auto_amg = self
            .particle_count()
            .0
            .is_some_and(|p| p >= AUTO_AMG_PARTICLES as u64);
        match s.preconditioner {
            None if auto_amg => PrecondKind::Amg,
            None | Some(PrecondKind::Mic0 { .. }) => PrecondKind::Mic0 { omega: s.mic_omega },
            Some(PrecondKind::Ssor { .. }) => PrecondKind::Ssor { omega: s.omega },
            Some(other) => other,
        }
    }

    /// The integrator, Newton and PCG options of the scene.
    pub fn simulation_options(&self) -> SimulationOptions {
        let s = &self.solver;
        let forcing = match s.forcing {
            ForcingScene::Constant(eta) => ForcingTerm::Constant(eta),
            ForcingScene::Ew1 => ForcingTerm::EisenstatWalker1,
            ForcingScene::Ew2 => ForcingTerm::EW2_DEFAULT,
        };
        let mut solver: SolverOptions = SimulationOptions::drape_solver();
        // "auto" needs the model: `build` replaces this placeholder.
        solver.h = self.integrator.h.value().unwrap_or_else(d_h);
        solver.rtol = self.integrator.rtol;
        solver.atol = self.integrator.atol.into();
        solver.step.h_max = self.integrator.h_max;
        solver.bdf.max_order = self.integrator.max_order;
        solver.step.control = match self.integrator.control {
            ControlScene::Error => StepControl::error_based(),
            ControlScene::Newton => StepControl::newton_iterations(),
        };
        solver.newton.method = match s.newton {
            NewtonScene::Exact => NewtonMethod::Exact,
            NewtonScene::Inexact => NewtonMethod::Inexact(forcing),
            NewtonScene::Simplified => NewtonMethod::Simplified,
            NewtonScene::InexactSimplified => NewtonMethod::InexactSimplified(forcing),
        };
        solver.newton.rtol = s.newton_rtol;
        solver.newton.max_iter = s.max_newton;
        solver.newton.linear_rtol = match s.newton {
            NewtonScene::Exact | NewtonScene::Simplified => s.cg_rtol,
            _ => solver.newton.linear_rtol,
        };
        solver.linear.max_iter = Some(s.max_cg);
        solver.warm_start = s.warm_start;
        solver.linear.preconditioner = self.preconditioner();
        solver.linear.amg = s.amg.as_ref().map(AmgScene::options).unwrap_or_default();
        // The exact stiffness Jacobian may be indefinite where springs are
        // compressed: PCG then truncates (Newton-CG) instead of failing.
        solver.linear.negative_curvature = if self.model.clamp_stiffness {
            NegativeCurvature::Error
        } else {
            NegativeCurvature::Truncate
        };
        SimulationOptions {
            method: self.integrator.method.clone(),
            solver,
            filter: self.filter.as_ref().map(|f| FilterOptions {
                kernel: match f.kernel {
                    KernelScene::Exponential => Kernel::Exponential { lambda: f.lambda },
                    KernelScene::Gaussian => Kernel::Gaussian { lambda: f.lambda },
                },
                form: match f.form {
                    FormScene::Symmetric => Form::Symmetric,
                    FormScene::Plain => Form::Plain,
                },
                rings: f.rings,
                current_distances: f.distances == DistancesScene::Current,
            }),
            filter_coupling: match self.filter.as_ref().map(|f| f.coupling) {
                Some(CouplingScene::Velocity) => FilterCoupling::VelocityOnly,
                Some(CouplingScene::Positions) => FilterCoupling::CorrectPositions,
                Some(CouplingScene::Increment) | None => FilterCoupling::Increment,
            },
            ..SimulationOptions::default()
        }
    }

    /// The cloth of a `[cloth]` scene as builder parameters (with the
    /// scene's `[model]` options), or `None` for other scenes.
    pub fn cloth_params(&self) -> Option<ClothParams> {
        let c = self.cloth.as_ref()?;
        let axis_v = match c.plane {
            PlaneScene::Horizontal => [0.0, 1.0, 0.0],
            PlaneScene::Vertical => [0.0, 0.0, 1.0],
        };
        // About +x: (y, z) -> (y cos - z sin, y sin + z cos).
        let axis_v = if c.tilt == 0.0 {
            axis_v
        } else {
            let (s, co) = c.tilt.to_radians().sin_cos();
            [
                0.0,
                axis_v[1] * co - axis_v[2] * s,
                axis_v[1] * s + axis_v[2] * co,
            ]
        };
        Some(ClothParams {
            nu: c.n,
            nv: c.n,
            width: c.size,
            height: c.size,
            origin: c.origin,
            axis_u: [1.0, 0.0, 0.0],
            axis_v,
            total_mass: c.mass,
            structural: SpringMaterial::new(c.stiffness, c.damping),
            shear: SpringMaterial::new(c.stiffness, c.damping),
            bend: SpringMaterial::new(c.bend_stiffness.unwrap_or(c.stiffness / 10.0), c.damping),
            pins: match c.pins {
                PinScene::TwoCorners => ClothPins::TwoCorners,
                PinScene::FourCorners => ClothPins::FourCorners,
                PinScene::Edge => ClothPins::Edge,
                PinScene::None => ClothPins::None,
            },
            options: self.model_options(),
        })
    }

    /// The number of particles (unknowns for a `[tutorial]` scene) the
    /// scene's model has, and the key that sets it; `None` for a count that
    /// overflows 64 bits.
    pub fn particle_count(&self) -> (Option<u64>, &'static str) {
        if let Some(c) = &self.cloth {
            ((c.n as u64).checked_mul(c.n as u64), "cloth.n")
        } else if let Some(r) = &self.rope {
            (Some(r.n as u64), "rope.n")
        } else if let Some(j) = &self.jelly {
            let [a, b, c] = j.n.map(|k| k as u64);
            (a.checked_mul(b).and_then(|ab| ab.checked_mul(c)), "jelly.n")
        } else if self.particle.is_some() {
            (Some(1), "particle")
        } else if let Some(m) = &self.mesh {
            (Some(obj_vertex_count(&self.resolve(&m.path))), "mesh.path")
        } else {
            (Some(1), "tutorial")
        }
    }

    /// A path of the scene: relative paths start at the scene file's folder.
    fn resolve(&self, path: &Path) -> std::path::PathBuf {
        match &self.base {
            Some(base) if path.is_relative() => base.join(path),
            _ => path.to_path_buf(),
        }
    }

    /// An upper estimate of the memory the scene's model and its implicit
    /// solver need, in bytes, and the key that sets the size: about
    /// 1 KiB per particle (state, forces, solver vectors) and 0.5 KiB per
    /// spring (its Jacobian blocks in `df/dx`, `df/dv`, the system matrix
    /// and its preconditioner), plus, with a `[filter]`, 32 bytes per
    /// neighbour of every particle's `rings`-ring neighbourhood (at most
    /// `(2 rings + 1)^d` particles on a `d`-dimensional lattice, and never
    /// more than the model has; the key is then `filter.rings` if the
    /// neighbourhoods are the larger part). `None` for a size that
    /// overflows 64 bits.
    pub fn memory_estimate(&self) -> (Option<u64>, &'static str) {
        let (bytes, key) = self.model_memory_estimate();
        let Some(filter) = &self.filter else {
            return (bytes, key);
        };
        const PER_NEIGHBOUR: u64 = 32;
        let dimension = if self.cloth.is_some() {
            2
        } else if self.jelly.is_some() {
            3
        } else {
            1
        };
        let (particles, _) = self.particle_count();
        let neighbours = particles.and_then(|p| {
            let side = (filter.rings as u64).checked_mul(2)?.checked_add(1)?;
            let ring = side.checked_pow(dimension).unwrap_or(u64::MAX).min(p);
            p.checked_mul(ring)?.checked_mul(PER_NEIGHBOUR)
        });
        match (bytes, neighbours) {
            (Some(b), Some(f)) if f > b => (b.checked_add(f), "filter.rings"),
            (Some(b), Some(f)) => (b.checked_add(f), key),
            (Some(_), None) => (None, "filter.rings"),
            (None, _) => (None, key),
        }
    }

    /// [`memory_estimate`](Self::memory_estimate) without the filter.
    fn model_memory_estimate(&self) -> (Option<u64>, &'static str) {
        const PER_PARTICLE: u64 = 1 << 10;
        const PER_SPRING: u64 = 1 << 9;
        // Springs per particle: cloth 6 (structural, shear, bend), rope 2,
        // 3D lattice at most 13 (half of the 26 neighbours).
        let springs_per = if self.cloth.is_some() || self.mesh.is_some() {
            6
        } else if self.rope.is_some() {
            2
        } else if self.jelly.is_some() {
            13
        } else {
            1
        };
        let (particles, key) = self.particle_count();
        let bytes = particles.and_then(|p| {
            p.checked_mul(PER_PARTICLE)?
                .checked_add(p.checked_mul(springs_per)?.checked_mul(PER_SPRING)?)
        });
        (bytes, key)
    }

    /// The largest scene file [`from_file`](Self::from_file) reads: 16 MiB.
    pub const MAX_FILE_BYTES: u64 = 16 << 20;

    /// The memory cap of [`build`](Self::build): 8 GiB.
    pub const DEFAULT_MAX_BYTES: u64 = 8 << 30;

    /// Builds the model and the simulation the scene describes, refusing a
    /// scene larger than [`DEFAULT_MAX_BYTES`](Self::DEFAULT_MAX_BYTES).
    ///
    /// # Errors
    /// As [`build_within`](Self::build_within).
    pub fn build(&self) -> Result<Simulation, HookeanError> {
        self.build_within(Self::DEFAULT_MAX_BYTES)
    }

    /// Builds the model and the simulation the scene describes, refusing
    /// (before anything is allocated) a scene whose
    /// [`memory_estimate`](Self::memory_estimate) exceeds `max_bytes`.
    ///
    /// # Errors
    /// [`HookeanError::TooLarge`] naming the key that sets the size; the
    /// builders' and the integrator's typed errors.
    pub fn build_within(&self, max_bytes: u64) -> Result<Simulation, HookeanError> {
        let (bytes, key) = self.memory_estimate();
        if bytes.is_none_or(|b| b > max_bytes) {
            return Err(HookeanError::TooLarge {
                key,
                bytes,
                max_bytes,
            });
        }
        if self.tutorial.is_some() {
            return Err(HookeanError::InvalidOption {
                name: "tutorial".into(),
                message: "a [tutorial] scene is a scalar ODE, not a mass-spring model: \
                          integrate it with hookean-ode's FirstOrderIntegrator (as `hookean run` does)"
                    .into(),
            });
        }
        let options = self.model_options();
        let in_table = |table: &str| {
            let table = table.to_string();
            move |e: hookean_massspring::MassSpringError| HookeanError::Build {
                table: table.clone(),
                message: e.to_string(),
            }
        };
        let (mut model, state) = if let Some(params) = self.cloth_params() {
            hookean_massspring::cloth(&params).map_err(in_table("cloth"))?
        } else if let Some(r) = &self.rope {
            hookean_massspring::rope(&RopeParams {
                n: r.n,
                length: r.length,
                total_mass: r.mass,
                material: SpringMaterial::new(r.stiffness, r.damping),
                direction: r.direction,
                pin_start: r.pin_start,
                pin_end: r.pin_end,
                options,
                ..RopeParams::default()
            })
            .map_err(in_table("rope"))?
        } else if let Some(j) = &self.jelly {
            let m = SpringMaterial::new(j.stiffness, j.damping);
            hookean_massspring::jelly_block(&BlockParams {
                n: j.n,
                spacing: j.spacing,
                origin: j.origin,
                total_mass: j.mass,
                edge: m,
                face: m,
                body: m,
                options,
            })
            .map_err(in_table("jelly"))?
        } else if let Some(m) = &self.mesh {
            let (obj, _) =
                hookean_massspring::read_surface(self.resolve(&m.path), m.scale, m.offset)
                    .map_err(in_table("mesh"))?;
            let bend = m.bend_stiffness.unwrap_or(m.stiffness / 10.0);
            let (mut model, state) = hookean_massspring::from_mesh(
                &obj,
                &MeshParams {
                    total_mass: m.mass,
                    edge: SpringMaterial::new(m.stiffness, m.damping),
                    bend: (bend > 0.0).then(|| SpringMaterial::new(bend, m.damping)),
                    options,
                },
            )
            .map_err(in_table("mesh"))?;
            let n = model.n_particles();
            let mut pins = m.pins.clone();
            if let Some(&bad) = pins.iter().find(|&&p| p >= n) {
                return Err(HookeanError::Build {
                    table: "mesh".into(),
                    message: format!(
                        "pins: vertex {bad} does not exist ({n} vertices, numbered from 0)"
                    ),
                });
            }
            if let Some([lo, hi]) = m.pin_box {
                pins.extend((0..n).filter(|&p| {
                    (0..3).all(|c| lo[c] <= state.x[3 * p + c] && state.x[3 * p + c] <= hi[c])
                }));
            }
            for p in pins {
                let at = [state.x[3 * p], state.x[3 * p + 1], state.x[3 * p + 2]];
                model.pin(p, at).map_err(in_table("mesh"))?;
            }
            (model, state)
        } else {
            let (mut model, state) =
                hookean_massspring::tutorial_example3().map_err(in_table("particle"))?;
            if self.model.damping != DampingScene::Projected
                || self.model.air_friction != 0.0
                || self.model.gravity != d_gravity()
            {
                model.set_options(options).map_err(in_table("model"))?;
            }
            (model, state)
        };
        for (i, c) in self.colliders.iter().enumerate() {
            let collider = in_table(&format!("collider {}", i + 1));
            let friction = |mu_s: f64, mu_k: Option<f64>| {
                Friction::new(mu_s, mu_k.unwrap_or(mu_s)).map_err(&collider)
            };
            model.add_collider(match c {
                ColliderScene::Plane {
                    point,
                    normal,
                    margin,
                    static_friction,
                    kinetic_friction,
                } => Collider::plane(*point, *normal, *margin)
                    .map_err(&collider)?
                    .with_friction(friction(*static_friction, *kinetic_friction)?),
                ColliderScene::Sphere {
                    center,
                    radius,
                    margin,
                    static_friction,
                    kinetic_friction,
                } => Collider::sphere(*center, *radius, *margin)
                    .map_err(&collider)?
                    .with_friction(friction(*static_friction, *kinetic_friction)?),
                ColliderScene::Mesh {
                    path,
                    scale,
                    offset,
                    thickness,
                    static_friction,
                    kinetic_friction,
                    velocity,
                    angular_velocity,
                    pivot,
                } => {
                    let (_, surface) =
                        hookean_massspring::read_surface(self.resolve(path), *scale, *offset)
                            .map_err(&collider)?;
                    let centre = surface.aabb().center();
                    let motion = RigidMotion {
                        velocity: *velocity,
                        angular_velocity: *angular_velocity,
                        pivot: pivot.unwrap_or([centre.x, centre.y, centre.z]),
                    };
                    let mesh = MeshCollider::new(surface, *thickness)
                        .and_then(|m| m.with_motion(motion))
                        .map_err(&collider)?;
                    Collider::mesh(mesh)
                        .with_friction(friction(*static_friction, *kinetic_friction)?)
                }
            });
        }
        if self.contact.self_collision {
            model
                .set_self_collision(Some(SelfCollision {
                    thickness: self.contact.self_thickness,
                    stiffness: self.contact.self_stiffness,
                }))
                .map_err(in_table("contact"))?;
        }
        let mut options = self.simulation_options();
        if self.integrator.h == StepScene::Auto {
            let filter = options
                .filter
                .as_ref()
                .map(|f| (f, options.filter_coupling));
            options.solver.h = hookean_filter::auto_step(
                &model,
                &state.x,
                &options.method,
                filter,
                self.integrator.h_safety,
            )
            .map_err(|e| HookeanError::InvalidOption {
                name: "integrator.h".into(),
                message: format!("\"auto\": {e}"),
            })?
            .h;
        }
        Simulation::new(model, state, options).map_err(|e| match e {
            HookeanError::InvalidOption { name, message } if name == "filter" => {
                HookeanError::Build {
                    table: name,
                    message,
                }
            }
            e => e,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `KEYS` (scene_keys.txt) names every field of every scene table, as
    /// the source declares them: rerun scripts/scene-keys.py after adding one.
    #[test]
    fn the_key_listing_names_every_key() {
        let src = include_str!("scene.rs");
        let tables = [
            ("Scene", ""),
            ("ClothScene", "cloth."),
            ("RopeScene", "rope."),
            ("JellyScene", "jelly."),
            ("TutorialScene", "tutorial."),
            ("ModelScene", "model."),
            ("IntegratorScene", "integrator."),
            ("SolverScene", "solver."),
            ("AmgScene", "solver.amg."),
            ("FilterScene", "filter."),
            ("OutputScene", "output."),
            ("MeshScene", "mesh."),
            ("ContactScene", "contact."),
        ];
        let mut count = 0;
        for (name, prefix) in tables {
            let start = src.find(&format!("pub struct {name} {{")).unwrap();
            let body = &src[start..start + src[start..].find("\n}").unwrap()];
            let mut rename = None;
            for line in body.lines().skip(1).map(str::trim) {
                if line.starts_with("#[serde(") && line.contains("rename = \"") {
                    let r = line.split("rename = \"").nth(1).unwrap();
                    rename = Some(r[..r.find('"').unwrap()].to_string());
                } else if let Some(field) = line.strip_prefix("pub ") {
                    let field = rename
                        .take()
                        .unwrap_or_else(|| field[..field.find(':').unwrap()].to_string());
                    let key = format!("  {prefix}{field}\n");
                    assert!(
                        KEYS.contains(&key),
                        "scene_keys.txt lacks {key:?}: run scripts/scene-keys.py"
                    );
                    count += 1;
                }
            }
        }
        assert!(count > 60, "{count} keys");
    }

    #[test]
    fn auto_preconditioner_follows_the_particle_count_and_names_win() {
        let kind = |text: &str| {
            Scene::from_toml_str("s.toml", text)
                .unwrap()
                .preconditioner()
        };
        let side = (AUTO_AMG_PARTICLES as f64).sqrt().ceil() as usize;
        let below = format!("[cloth]\nn = {}\n", side - 1);
        let above = format!("[cloth]\nn = {side}\n");
        assert!(matches!(kind(&below), PrecondKind::Mic0 { .. }));
        assert_eq!(kind(&above), PrecondKind::Amg);
        let named = format!("{above}[solver]\npreconditioner = \"mic0\"\nmic_omega = 0.5\n");
        assert_eq!(kind(&named), PrecondKind::Mic0 { omega: 0.5 });
        let auto = format!("{below}[solver]\npreconditioner = \"auto\"\n");
        assert!(matches!(kind(&auto), PrecondKind::Mic0 { .. }));
    }

    fn err(text: &str) -> (usize, usize, String) {
        match Scene::from_toml_str("s.toml", text) {
            Err(HookeanError::Scene {
                line,
                column,
                message,
                ..
            }) => (line, column, message),
            other => panic!("expected a scene error, got {other:?}"),
        }
    }

    #[test]
    fn defaults_are_the_reference_drape() {
        let s = Scene::from_toml_str("s.toml", "[cloth]\n").unwrap();
        let c = s.cloth.as_ref().unwrap();
        assert_eq!(
            (c.n, c.size, c.mass, c.stiffness, c.damping),
            (64, 1.0, 1.0, 1e4, 0.1)
        );
        assert_eq!(c.pins, PinScene::TwoCorners);
        assert_eq!(s.duration, 5.0);
        assert_eq!(s.integrator.method, Method::ImplicitEuler);
        assert_eq!(s.integrator.h, StepScene::Value(0.01));
    }

    #[test]
    fn solver_defaults_are_the_drape_solver_and_drape_toml_spells_them_out() {
        // A bare scene solves its steps like `SimulationOptions::default()`
        // (the variable-step tolerances are the scene's own), and the
        // shipped drape.toml, which claims to spell out every default,
        // builds exactly the same options.
        let bare = Scene::from_toml_str("s.toml", "[cloth]\n").unwrap();
        let (opts, default) = (bare.simulation_options(), SimulationOptions::default());
        assert_eq!(opts.method, default.method);
        assert_eq!(opts.solver.h, default.solver.h);
        assert_eq!(opts.solver.newton, default.solver.newton);
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/drape.toml");
        let shipped = Scene::from_file(path, &[]).unwrap();
        assert_eq!(shipped.simulation_options(), bare.simulation_options());
        assert_eq!(shipped.duration, bare.duration);
    }

    #[test]
    fn unknown_keys_wrong_types_and_bad_values_name_line_and_column() {
        let (l, c, m) = err("duration = 1.0\n[cloth]\nn = 8\nstifness = 3\n");
        assert_eq!((l, c), (4, 1), "{m}");
        assert!(m.contains("stifness"), "{m}");
        let (l, c, m) = err("[cloth]\nn = \"many\"\n");
        assert_eq!((l, c), (2, 5), "{m}");
        let (l, c, m) = err("[cloth]\n  damping = -1.0\n");
        assert_eq!((l, c), (2, 13), "{m}");
        assert!(m.contains("non-negative"), "{m}");
        let (l, _, m) = err("[cloth]\n[integrator]\nmethod = \"rk5\"\n");
        assert_eq!(l, 3, "{m}");
        let (l, _, m) = err("[rope]\n[solver]\nforcing = 1.5\n");
        assert_eq!(l, 3, "{m}");
        let (_, _, m) = err("[rope]\n[cloth]\n");
        assert!(m.contains("exactly one model"), "{m}");
        let (l, _, _) = err("[cloth]\n[[collider]]\nkind = \"cube\"\n");
        assert!(l >= 2);
    }

    #[test]
    fn solver_amg_table_sets_the_multigrid_options_and_bad_values_name_the_key() {
        let s = Scene::from_toml_str(
            "s.toml",
            "[cloth]\n[solver]\npreconditioner = \"amg\"\n[solver.amg]\nsmoother = \"ic0\"\n\
             sweeps = 2\nreuse = \"keep\"\nkeep_updates = 3\n",
        )
        .unwrap();
        let linear = s.simulation_options().solver.linear;
        assert_eq!(linear.preconditioner, PrecondKind::Amg);
        assert_eq!(linear.amg.smoother, AmgSmoother::BlockIc0);
        assert_eq!(linear.amg.sweeps, 2);
        assert_eq!(linear.amg.reuse, AmgReuse::Keep { updates: 3 });
        assert_eq!(linear.amg.coarse_size, AmgOptions::default().coarse_size);
        // Without the table: the library's defaults.
        let s = Scene::from_toml_str("s.toml", "[cloth]\n[solver]\npreconditioner = \"amg\"\n")
            .unwrap();
        assert_eq!(
            s.simulation_options().solver.linear.amg,
            AmgOptions::default()
        );
        let text = "[cloth]\n[solver]\npreconditioner = \"amg\"\n[solver.amg]\n";
        for (bad, key) in [
            ("strength_threshold = 1.5", "[0, 1)"),
            ("jacobi_weight = 2.0", "(0, 2)"),
            ("sweeps = 0", "1 to 100"),
            ("smoother = \"sor\"", "sor"),
            ("reuse = \"sometimes\"", "sometimes"),
            ("levels = 3", "levels"),
        ] {
            let (l, _, m) = err(&format!("{text}{bad}\n"));
            assert_eq!(l, 5, "{bad}: {m}");
            assert!(m.contains(key), "{bad}: {m}");
        }
        // The table needs the preconditioner it configures (or "auto",
        // the default, which picks it for large models).
        let (_, _, m) =
            err("[cloth]\n[solver]\npreconditioner = \"mic0\"\n[solver.amg]\nsweeps = 2\n");
        assert!(m.starts_with("solver.amg:"), "{m}");
        assert!(Scene::from_toml_str("s.toml", "[cloth]\n[solver.amg]\nsweeps = 2\n").is_ok());
    }

    #[test]
    fn step_auto_and_filter_coupling_are_scene_keys() {
        let s = Scene::from_toml_str(
            "s.toml",
            "[cloth]\nn = 6\n[integrator]\nmethod = \"fb-euler\"\nh = \"auto\"\n[filter]\ncoupling = \"velocity\"\n",
        )
        .unwrap();
        assert_eq!(s.integrator.h, StepScene::Auto);
        assert_eq!(s.integrator.h_safety, 0.8);
        let o = s.simulation_options();
        assert_eq!(o.filter_coupling, FilterCoupling::VelocityOnly);
        // The built step: 0.8 / sqrt 2 of the unfiltered eq. 11 limit for
        // the literal velocity coupling.
        let sim = s.build().unwrap();
        let (model, state) = hookean_massspring::cloth(&s.cloth_params().unwrap()).unwrap();
        let dt = model
            .stability(&state.x, &Default::default(), None)
            .unwrap()
            .dt_max;
        assert!((sim.h_next() - 0.8 * dt / 2f64.sqrt()).abs() < 1e-12 * dt);
        let d = Scene::from_toml_str("s.toml", "[cloth]\n[filter]\n").unwrap();
        assert_eq!(
            d.simulation_options().filter_coupling,
            FilterCoupling::Increment
        );

        let (l, c, m) = err("[cloth]\n[integrator]\nh = \"fast\"\n");
        assert_eq!((l, c), (3, 5), "{m}");
        assert!(m.contains("positive number or \"auto\""), "{m}");
        let (l, _, m) = err("[cloth]\n[integrator]\nh = -1.0\n");
        assert_eq!(l, 3, "{m}");
        let (l, _, m) = err("[cloth]\n[integrator]\nh_safety = 1.5\n");
        assert_eq!(l, 3, "{m}");
        let (l, _, m) = err("[cloth]\n[filter]\ncoupling = \"force\"\n");
        assert_eq!(l, 3, "{m}");
        assert!(m.contains("increment"), "{m}");
        // An implicit method has no explicit stable step.
        let implicit =
            Scene::from_toml_str("s.toml", "[cloth]\nn = 4\n[integrator]\nh = \"auto\"\n").unwrap();
        match implicit.build() {
            Err(e @ HookeanError::InvalidOption { .. }) => {
                let m = e.to_string();
                assert!(
                    m.contains("integrator.h") && m.contains("implicit-euler"),
                    "{m}"
                );
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("auto with implicit Euler was accepted"),
        }
        assert!(
            Scene::from_toml_str(
                "s.toml",
                "[tutorial]\nexample = 1\n[integrator]\nh = \"auto\"\n"
            )
            .is_err()
        );
    }

    #[test]
    fn overrides_change_values_and_are_checked() {
        let s = Scene::with_overrides(
            "s.toml",
            "[cloth]\nn = 8\n",
            &["cloth.n=5", "integrator.method=fb-euler"],
        )
        .unwrap();
        assert_eq!(s.cloth.unwrap().n, 5);
        assert_eq!(s.integrator.method, Method::FbEuler);
        // The error names the override that broke the scene, not a
        // position in a merged text.
        let overrides = ["cloth.n=4", "cloth.n=1", "cloth.n=3"];
        match Scene::with_overrides("s.toml", "[cloth]\n", &overrides) {
            Err(e @ HookeanError::Override { .. }) => {
                let m = e.to_string();
                assert!(m.starts_with("s.toml: override cloth.n=1: "), "{m}");
                assert!(m.contains("at least 2"), "{m}");
            }
            other => panic!("{other:?}"),
        }
        match Scene::with_overrides("s.toml", "[cloth]\n", &["cloth.n"]) {
            Err(HookeanError::Override { arg, message, .. }) => {
                assert_eq!(arg, "cloth.n");
                assert!(message.contains("key=value"), "{message}");
            }
            other => panic!("{other:?}"),
        }
    }
}
