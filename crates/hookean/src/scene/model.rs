//! The model tables of a scene: `[cloth]`, `[rope]`, `[jelly]`, `[mesh]`, `[contact]`, `[wind]`, `[particle]`, `[tutorial]`, `[model]`, and `[[collider]]`.

use super::*;

/// `[cloth]`: the reference drape of docs/ARCHITECTURE.md by default.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClothScene {
    /// Particles per side. Range 2 to the memory cap of [`Scene::build_within`]. Default 64.
    #[serde(default = "d_cloth_n", deserialize_with = "at_least_two")]
    pub n: usize,
    /// Side length (m). Range [1e-100, 1e100] (the squares of the spring lengths stay normal numbers). Default 1.
    #[serde(default = "one", deserialize_with = "length")]
    pub size: f64,
    /// Total mass (kg). Range [1e-100, 1e100] (smaller or larger masses
    /// make Newton's residual underflow or overflow). Default 1.
    #[serde(default = "one", deserialize_with = "mass")]
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

pub(super) fn opt_non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    non_negative(d).map(Some)
}

pub(super) fn d_cloth_n() -> usize {
    ClothParams::default().nu
}
pub(super) fn one() -> f64 {
    1.0
}
pub(super) fn d_k() -> f64 {
    ClothParams::default().structural.stiffness
}
pub(super) fn d_damping() -> f64 {
    ClothParams::default().structural.damping
}
pub(super) fn d_pins() -> PinScene {
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
    /// Particles. Range 2 to the memory cap of [`Scene::build_within`]. Default 20.
    #[serde(default = "d_rope_n", deserialize_with = "at_least_two")]
    pub n: usize,
    /// Length (m). Range [1e-100, 1e100] (the squares of the spring lengths stay normal numbers). Default 1.
    #[serde(default = "one", deserialize_with = "length")]
    pub length: f64,
    /// Total mass (kg). Range [1e-100, 1e100] (smaller or larger masses
    /// make Newton's residual underflow or overflow). Default 1.
    #[serde(default = "one", deserialize_with = "mass")]
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

pub(super) fn d_rope_n() -> usize {
    20
}
pub(super) fn d_dir() -> [f64; 3] {
    [1.0, 0.0, 0.0]
}
pub(super) fn yes() -> bool {
    true
}

/// `[jelly]`: a block lattice with edge, face- and body-diagonal springs.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JellyScene {
    /// Particles per axis, each at least 1 (at least 2 particles in all);
    /// their product is bounded by the memory cap of [`Scene::build_within`]. Default `[6, 6, 6]`.
    #[serde(default = "d_jelly_n", deserialize_with = "usize3")]
    pub n: [usize; 3],
    /// Lattice spacing (m). Range [1e-100, 1e100] (the squares of the
    /// spring lengths stay normal numbers; a spacing below the round-off of
    /// `origin` gives springs of zero length, refused naming `[jelly]`).
    /// Default 0.05.
    #[serde(default = "d_spacing", deserialize_with = "length")]
    pub spacing: f64,
    /// Total mass (kg). Range [1e-100, 1e100] (smaller or larger masses
    /// make Newton's residual underflow or overflow). Default 1.
    #[serde(default = "one", deserialize_with = "mass")]
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

pub(super) fn d_jelly_n() -> [usize; 3] {
    [6, 6, 6]
}
pub(super) fn d_spacing() -> f64 {
    0.05
}
pub(super) fn d_jelly_k() -> f64 {
    1e3
}
pub(super) fn d_jelly_origin() -> [f64; 3] {
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
    /// Factor on every coordinate of the file. Range [1e-50, 1e50] (the
    /// squared areas of the faces, products of four coordinates, stay normal
    /// numbers for coordinates of order 1). Default 1.
    #[serde(default = "one", deserialize_with = "scale")]
    pub scale: f64,
    /// Added to every (scaled) vertex (m). Default `[0, 0, 0]`.
    #[serde(default, deserialize_with = "finite3")]
    pub offset: [f64; 3],
    /// Total mass (kg), lumped uniformly over the vertices. Range [1e-100,
    /// 1e100] (smaller or larger masses make Newton's residual underflow or
    /// overflow). Default 1.
    #[serde(default = "one", deserialize_with = "mass")]
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
    /// Self-collision thickness (m): closer non-adjacent features repel. Range (0, inf), and with self_collision on below the smallest altitude of the model's triangles at the start (a cloth grid: 0.707 of its spacing, size / (n - 1)). Default 0.004.
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

pub(super) fn d_self_thickness() -> f64 {
    hookean_massspring::SelfCollision::default().thickness
}
pub(super) fn d_self_stiffness() -> f64 {
    hookean_massspring::SelfCollision::default().stiffness
}

/// `[wind]`: the air's velocity field and the aerodynamic drag and lift on
/// the model's triangles (hookean-massspring's `Wind`; docs/CONTACT.md, "Wind").
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindScene {
    /// The mean wind (m/s). Default [0, 0, 0].
    #[serde(default, deserialize_with = "finite3")]
    pub velocity: [f64; 3],
    /// Air density rho (kg/m^3). Range [0, inf). Default 1.2.
    #[serde(default = "d_air_density", deserialize_with = "non_negative")]
    pub air_density: f64,
    /// Drag coefficient C_d of a triangle (a flat plate normal to the flow: about 1.2). Range [0, inf). Default 1.
    #[serde(default = "d_drag", deserialize_with = "non_negative")]
    pub drag: f64,
    /// Lift coefficient C_l of a triangle. Range [0, inf). Default 0.
    #[serde(default, deserialize_with = "non_negative")]
    pub lift: f64,
    /// Amplitude of the gusts (m/s); 0: a constant wind. Range [0, inf). Default 0.
    #[serde(default, deserialize_with = "non_negative")]
    pub gust_amplitude: f64,
    /// Mean frequency of the gusts (Hz). Range (0, inf). Default 0.5.
    #[serde(default = "d_gust_frequency", deserialize_with = "positive")]
    pub gust_frequency: f64,
    /// Wavelength of the gusts (m). Range (0, inf). Default 4.
    #[serde(default = "d_gust_wavelength", deserialize_with = "positive")]
    pub gust_wavelength: f64,
    /// Seed of the gust field: the same seed, the same wind. Default 0.
    #[serde(default)]
    pub seed: u64,
}

pub(super) fn d_air_density() -> f64 {
    hookean_massspring::Wind::default().air_density
}
pub(super) fn d_drag() -> f64 {
    hookean_massspring::Wind::default().drag
}
pub(super) fn d_gust_frequency() -> f64 {
    hookean_massspring::Wind::default().gust_frequency
}
pub(super) fn d_gust_wavelength() -> f64 {
    hookean_massspring::Wind::default().gust_wavelength
}

impl WindScene {
    /// The library's wind.
    pub fn wind(&self) -> hookean_massspring::Wind {
        hookean_massspring::Wind {
            velocity: self.velocity,
            air_density: self.air_density,
            drag: self.drag,
            lift: self.lift,
            gust_amplitude: self.gust_amplitude,
            gust_frequency: self.gust_frequency,
            gust_wavelength: self.gust_wavelength,
            seed: self.seed,
            ..Default::default()
        }
    }
}

/// `[particle]`: the tutorial's example 3 with its parameters (no keys).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleScene {}

/// A finite number (`deserialize_with = "finite"`): the scene's check of a
/// real key with no narrower range, for a program's own tables
/// ([`SceneExtension`](super::SceneExtension)) too, so their messages read
/// like the facade's.
pub fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
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

pub(super) fn d_true() -> bool {
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

pub(super) fn d_gravity() -> [f64; 3] {
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
    /// t + R(angular_velocity t) (X - pivot)` at time `t`; or along `keys`
    /// (a keyframed path, as a `[[pin]]`'s); or deforming through the OBJ
    /// `frames` of one topology (docs/CONTACT.md, "Moving and animated
    /// colliders"). One kind of motion per collider.
    Mesh {
        /// The OBJ file; a relative path starts at the scene file's folder.
        path: std::path::PathBuf,
        /// Factor on every coordinate. Range (0, inf). Default 1.
        #[serde(default = "one")]
        scale: f64,
        /// Added to every scaled vertex (m). Default `[0, 0, 0]`.
        #[serde(default)]
        offset: [f64; 3],
        /// Particles are kept this far from the surface (m). Range [0, the diagonal of the mesh's bounding box]. Default 0.005.
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
        /// A keyframed path of the body: `{ t, translation, rotation }` keys
        /// (s, m, rad about `pivot`), times increasing, held before the first
        /// and after the last. Default: none.
        #[serde(default)]
        keys: Vec<KeyScene>,
        /// `"linear"` (default) or `"smooth"` between `keys`.
        #[serde(default)]
        interpolation: InterpolationScene,
        /// A deforming body: the OBJ files of frames 1, 2, ... (frame 0 is
        /// `path`), each with the vertices and faces of `path` in the same
        /// order, placed by the same `scale` and `offset`. Default: none.
        #[serde(default)]
        frames: Vec<std::path::PathBuf>,
        /// The time between `frames` (s). Range (0, inf). Default 0.04.
        #[serde(default = "d_frame_interval")]
        frame_interval: f64,
    },
}

pub(super) fn d_frame_interval() -> f64 {
    0.04
}

pub(super) fn d_mesh_thickness() -> f64 {
    0.005
}
