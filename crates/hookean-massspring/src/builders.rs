//! Builders for the models of both papers: the tutorial's example 3, the
//! filtering paper's rope (figure 1), cloth (figures 4 and 7), 3D body
//! (figure 9, a block lattice) and models from triangle meshes.

use crate::NonExhaustive;
use std::collections::BTreeMap;

use nalgebra::Vector3;

use crate::error::MassSpringError;
use crate::model::{MassSpringModel, ModelOptions, Spring};
use crate::obj::ObjMesh;

/// A state: positions and velocities, 3 entries per particle (xyz interleaved).
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Positions (m).
    pub x: Vec<f64>,
    /// Velocities (m/s).
    pub v: Vec<f64>,
}

impl State {
    /// Positions from points, zero velocities.
    pub fn at_rest(points: &[[f64; 3]]) -> Self {
        let x: Vec<f64> = points.iter().flatten().copied().collect();
        let v = vec![0.0; x.len()];
        Self { x, v }
    }
}

/// Stiffness and damping of one family of springs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpringMaterial {
    /// Stiffness `k` (N/m).
    pub stiffness: f64,
    /// Damping `d` (N s/m).
    pub damping: f64,
}

impl SpringMaterial {
    /// `(k, d)`.
    pub fn new(stiffness: f64, damping: f64) -> Self {
        Self { stiffness, damping }
    }
}

/// Springs joining particles whose rest length is their current distance.
fn spring_at_rest(
    points: &[[f64; 3]],
    index: usize,
    i: usize,
    j: usize,
    m: SpringMaterial,
) -> Result<Spring, MassSpringError> {
    let l = (Vector3::from(points[j]) - Vector3::from(points[i])).norm();
    if l == 0.0 {
        return Err(MassSpringError::ZeroLengthSpring {
            spring: index,
            i,
            j,
        });
    }
    Ok(Spring::new(i, j, l, m.stiffness, m.damping))
}

fn check_positive(name: &'static str, value: f64) -> Result<(), MassSpringError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(MassSpringError::InvalidParameter {
            name,
            message: format!("{value} must be positive and finite"),
        })
    }
}

/// The most particles a builder makes: 2^32 (a count past it overflows
/// the index arithmetic of the grids, or is a typo).
pub const MAX_PARTICLES: usize = 1 << 32;

/// The product of the `counts` of a grid, refused above [`MAX_PARTICLES`]
/// (checked, never wrapped).
fn particle_count(counts: &[usize]) -> Result<usize, MassSpringError> {
    counts
        .iter()
        .try_fold(1usize, |acc, &c| acc.checked_mul(c))
        .filter(|&n| n <= MAX_PARTICLES)
        .ok_or_else(|| MassSpringError::InvalidParameter {
            name: "particle count",
            message: format!("{counts:?} makes more than {MAX_PARTICLES} particles"),
        })
}

fn check_count(name: &'static str, value: usize, min: usize) -> Result<(), MassSpringError> {
    if value >= min {
        Ok(())
    } else {
        Err(MassSpringError::InvalidParameter {
            name,
            message: format!("{value} must be at least {min}"),
        })
    }
}

/// The tutorial's example 3 (its eq. 8): a particle of mass `m = 0.1` hangs
/// from the origin on a spring with `k = 100`, `d = 1` and rest length
/// `|l0| = 1`, under gravity `g_z = -10`; it starts at `z0 = -1` with
/// `v0 = -5`. Particle 0 is the anchor, pinned at the origin; particle 1 is
/// the moving one. Along z the force on it is `k (l0 - z) - d z' + m g_z`
/// with `l0 = -1`, so its equilibrium is `z* = l0 + m g_z / k = -1.01`.
///
/// # Errors
/// None in practice (the parameters are valid); the signature matches the other builders.
pub fn tutorial_example3() -> Result<(MassSpringModel, State), MassSpringError> {
    let (m, k, d, l0) = (0.1, 100.0, 1.0, 1.0);
    let options = ModelOptions {
        gravity: [0.0, 0.0, -10.0],
        ..ModelOptions::default()
    };
    // The anchor's mass is irrelevant (it is pinned); give it the same.
    let mut model = MassSpringModel::new(vec![m, m], vec![Spring::new(0, 1, l0, k, d)], options)?;
    model.pin(0, [0.0; 3])?;
    let state = State {
        x: vec![0.0, 0.0, 0.0, 0.0, 0.0, -1.0],
        v: vec![0.0, 0.0, 0.0, 0.0, 0.0, -5.0],
    };
    Ok((model, state))
}

/// Parameters of [`rope`] (the filtering paper's figure 1).
#[derive(Debug, Clone, PartialEq)]
pub struct RopeParams {
    /// Number of particles (at least 2). Default 10.
    pub n: usize,
    /// Rest length of the whole rope (m). Default 1.
    pub length: f64,
    /// Total mass (kg), split equally. Default 0.1.
    pub total_mass: f64,
    /// Spring material. Default `k = 1e3`, `d = 0.1`.
    pub material: SpringMaterial,
    /// First particle's position. Default origin.
    pub start: [f64; 3],
    /// Direction of the rope (normalised). Default `+x` (horizontal).
    pub direction: [f64; 3],
    /// Pin the first particle. Default true.
    pub pin_start: bool,
    /// Pin the last particle. Default false.
    pub pin_end: bool,
    /// Model options. Default [`ModelOptions::default`].
    pub options: ModelOptions,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for RopeParams {
    fn default() -> Self {
        Self {
            n: 10,
            length: 1.0,
            total_mass: 0.1,
            material: SpringMaterial::new(1e3, 0.1),
            start: [0.0; 3],
            direction: [1.0, 0.0, 0.0],
            pin_start: true,
            pin_end: false,
            options: ModelOptions::default(),
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// A rope (chain) of `n` particles on a straight line at rest length, with
/// `n - 1` springs `(p, p + 1)`; either end pinnable.
///
/// # Errors
/// [`MassSpringError::InvalidParameter`] for `n < 2`, a non-positive length
/// or mass, or a zero direction; model errors otherwise.
pub fn rope(p: &RopeParams) -> Result<(MassSpringModel, State), MassSpringError> {
    check_count("n", p.n, 2)?;
    particle_count(&[p.n])?;
    check_positive("length", p.length)?;
    check_positive("total_mass", p.total_mass)?;
    let dir = Vector3::from(p.direction);
    let len = dir.norm();
    check_positive("direction length", len)?;
    let dir = dir / len;
    let seg = p.length / (p.n - 1) as f64;
    let start = Vector3::from(p.start);
    let points: Vec<[f64; 3]> = (0..p.n)
        .map(|k| {
            let y = start + dir * (seg * k as f64);
            [y.x, y.y, y.z]
        })
        .collect();
    let springs = (0..p.n - 1)
        .map(|k| spring_at_rest(&points, k, k, k + 1, p.material))
        .collect::<Result<Vec<_>, _>>()?;
    let masses = vec![p.total_mass / p.n as f64; p.n];
    let mut model = MassSpringModel::new(masses, springs, p.options)?;
    if p.pin_start {
        model.pin(0, points[0])?;
    }
    if p.pin_end {
        model.pin(p.n - 1, points[p.n - 1])?;
    }
    Ok((model, State::at_rest(&points)))
}

/// Which cloth particles are pinned (grid index `a + nu * b`, `a` along
/// the first axis, `b` along the second).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum ClothPins {
    /// None.
    None,
    /// The two corners of the first edge (`b = nv - 1`): particles
    /// `nu (nv - 1)` and `nu nv - 1` (the drape scene).
    #[default]
    TwoCorners,
    /// All four corners.
    FourCorners,
    /// The whole edge `b = nv - 1`.
    Edge,
    /// An explicit list of particles.
    Particles(Vec<usize>),
}

/// Parameters of [`cloth`]. The default is the reference drape of
/// docs/ARCHITECTURE.md (64 x 64 particles, 1 m, 1 kg, k = 1e4, bend k/10,
/// d = 0.1, two corners pinned): the one definition that scene files, the
/// filtering paper's experiments and the benchmarks take and scale with
/// [`drape`](Self::drape) and [`with_stiffness`](Self::with_stiffness).
#[derive(Debug, Clone, PartialEq)]
pub struct ClothParams {
    /// Particles along the first axis (at least 2). Default 64.
    pub nu: usize,
    /// Particles along the second axis (at least 2). Default 64.
    pub nv: usize,
    /// Side length along the first axis (m). Default 1.
    pub width: f64,
    /// Side length along the second axis (m). Default 1.
    pub height: f64,
    /// Position of particle 0. Default origin.
    pub origin: [f64; 3],
    /// First axis of the cloth's plane. Default `+x`.
    pub axis_u: [f64; 3],
    /// Second axis (orthogonalised against the first). Default `+y` (horizontal cloth).
    pub axis_v: [f64; 3],
    /// Total mass (kg), lumped uniformly. Default 1.
    pub total_mass: f64,
    /// Structural springs (grid neighbours). Default `k = 1e4`, `d = 0.1`.
    pub structural: SpringMaterial,
    /// Shear springs (both diagonals of each cell). Default `k = 1e4`, `d = 0.1`.
    pub shear: SpringMaterial,
    /// Bend springs (two apart along each axis); `stiffness = 0` leaves them out.
    /// Default `k = 1e3`, `d = 0.1`.
    pub bend: SpringMaterial,
    /// Pinned particles. Default [`ClothPins::TwoCorners`].
    pub pins: ClothPins,
    /// Model options. Default [`ModelOptions::default`].
    pub options: ModelOptions,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl ClothParams {
    /// The reference drape at `n x n` particles (the rest as the default).
    pub fn drape(n: usize) -> Self {
        Self {
            nu: n,
            nv: n,
            ..Self::default()
        }
    }

    /// The same cloth with structural and shear springs `(k, d)` and bend
    /// springs `(k / 10, d)`, the reference drape's ratio.
    pub fn with_stiffness(self, k: f64, d: f64) -> Self {
        Self {
            structural: SpringMaterial::new(k, d),
            shear: SpringMaterial::new(k, d),
            bend: SpringMaterial::new(k / 10.0, d),
            ..self
        }
    }
}

impl Default for ClothParams {
    fn default() -> Self {
        Self {
            nu: 64,
            nv: 64,
            width: 1.0,
            height: 1.0,
            origin: [0.0; 3],
            axis_u: [1.0, 0.0, 0.0],
            axis_v: [0.0, 1.0, 0.0],
            total_mass: 1.0,
            structural: SpringMaterial::new(1e4, 0.1),
            shear: SpringMaterial::new(1e4, 0.1),
            bend: SpringMaterial::new(1e3, 0.1),
            pins: ClothPins::TwoCorners,
            options: ModelOptions::default(),
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// A cloth grid of `nu x nv` particles in the plane spanned by the two axes,
/// with structural, shear and bend springs at rest length and two triangles
/// per cell (for OBJ export).
///
/// # Errors
/// [`MassSpringError::InvalidParameter`] for fewer than 2 particles per
/// side, non-positive sizes or mass, or degenerate axes;
/// [`MassSpringError::NoSuchParticle`] for a pin out of range.
pub fn cloth(p: &ClothParams) -> Result<(MassSpringModel, State), MassSpringError> {
    check_count("nu", p.nu, 2)?;
    check_count("nv", p.nv, 2)?;
    particle_count(&[p.nu, p.nv])?;
    check_positive("width", p.width)?;
    check_positive("height", p.height)?;
    check_positive("total_mass", p.total_mass)?;
    let eu = Vector3::from(p.axis_u);
    check_positive("axis_u length", eu.norm())?;
    let eu = eu / eu.norm();
    let ev = Vector3::from(p.axis_v);
    let ev = ev - eu * eu.dot(&ev);
    check_positive("axis_v length (orthogonal to axis_u)", ev.norm())?;
    let ev = ev / ev.norm();
    let (nu, nv) = (p.nu, p.nv);
    let o = Vector3::from(p.origin);
    let (du, dv) = (p.width / (nu - 1) as f64, p.height / (nv - 1) as f64);
    let id = |a: usize, b: usize| a + nu * b;
    let mut points = Vec::with_capacity(nu * nv);
    for b in 0..nv {
        for a in 0..nu {
            let y = o + eu * (du * a as f64) + ev * (dv * b as f64);
            points.push([y.x, y.y, y.z]);
        }
    }
    let mut pairs: Vec<(usize, usize, SpringMaterial)> = Vec::new();
    for b in 0..nv {
        for a in 0..nu {
            if a + 1 < nu {
                pairs.push((id(a, b), id(a + 1, b), p.structural));
            }
            if b + 1 < nv {
                pairs.push((id(a, b), id(a, b + 1), p.structural));
            }
            if p.shear.stiffness > 0.0 && a + 1 < nu && b + 1 < nv {
                pairs.push((id(a, b), id(a + 1, b + 1), p.shear));
                pairs.push((id(a + 1, b), id(a, b + 1), p.shear));
            }
            if p.bend.stiffness > 0.0 {
                if a + 2 < nu {
                    pairs.push((id(a, b), id(a + 2, b), p.bend));
                }
                if b + 2 < nv {
                    pairs.push((id(a, b), id(a, b + 2), p.bend));
                }
            }
        }
    }
    let springs = pairs
        .iter()
        .enumerate()
        .map(|(s, &(i, j, m))| spring_at_rest(&points, s, i, j, m))
        .collect::<Result<Vec<_>, _>>()?;
    let masses = vec![p.total_mass / (nu * nv) as f64; nu * nv];
    let mut model = MassSpringModel::new(masses, springs, p.options)?;
    let pins: Vec<usize> = match &p.pins {
        ClothPins::None => vec![],
        ClothPins::TwoCorners => vec![id(0, nv - 1), id(nu - 1, nv - 1)],
        ClothPins::FourCorners => vec![id(0, 0), id(nu - 1, 0), id(0, nv - 1), id(nu - 1, nv - 1)],
        ClothPins::Edge => (0..nu).map(|a| id(a, nv - 1)).collect(),
        ClothPins::Particles(list) => list.clone(),
    };
    for q in pins {
        model.check_particle(q)?;
        model.pin(q, points[q])?;
    }
    let mut faces = Vec::with_capacity(2 * (nu - 1) * (nv - 1));
    for b in 0..nv - 1 {
        for a in 0..nu - 1 {
            faces.push([id(a, b), id(a + 1, b), id(a + 1, b + 1)]);
            faces.push([id(a, b), id(a + 1, b + 1), id(a, b + 1)]);
        }
    }
    model.set_faces(faces)?;
    Ok((model, State::at_rest(&points)))
}

/// Parameters of [`jelly_block`] (the filtering paper's 3D body, figure 9).
#[derive(Debug, Clone, PartialEq)]
pub struct BlockParams {
    /// Particles along x, y, z (each at least 2). Default `[5, 5, 5]`.
    pub n: [usize; 3],
    /// Lattice spacing (m). Default 0.05.
    pub spacing: f64,
    /// Position of particle 0 (the minimum corner). Default origin.
    pub origin: [f64; 3],
    /// Total mass (kg). Default 1.
    pub total_mass: f64,
    /// Edge springs (lattice neighbours). Default `k = 1e3`, `d = 0.1`.
    pub edge: SpringMaterial,
    /// Face-diagonal springs. Default `k = 1e3`, `d = 0.1`.
    pub face: SpringMaterial,
    /// Body-diagonal springs. Default `k = 1e3`, `d = 0.1`.
    pub body: SpringMaterial,
    /// Model options. Default [`ModelOptions::default`].
    pub options: ModelOptions,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for BlockParams {
    fn default() -> Self {
        Self {
            n: [5, 5, 5],
            spacing: 0.05,
            origin: [0.0; 3],
            total_mass: 1.0,
            edge: SpringMaterial::new(1e3, 0.1),
            face: SpringMaterial::new(1e3, 0.1),
            body: SpringMaterial::new(1e3, 0.1),
            options: ModelOptions::default(),
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// The "jelly block": an `nx x ny x nz` particle lattice with edge,
/// face-diagonal (both diagonals of every cell face) and body-diagonal (all
/// four of every cell) springs, and its boundary triangulated for OBJ export.
/// Particle `(a, b, c)` has index `a + nx (b + ny c)`.
///
/// # Errors
/// [`MassSpringError::InvalidParameter`] for fewer than 2 particles along an
/// axis or non-positive spacing / mass.
pub fn jelly_block(p: &BlockParams) -> Result<(MassSpringModel, State), MassSpringError> {
    let [nx, ny, nz] = p.n;
    for (name, v) in [("nx", nx), ("ny", ny), ("nz", nz)] {
        check_count(name, v, 2)?;
    }
    particle_count(&p.n)?;
    check_positive("spacing", p.spacing)?;
    check_positive("total_mass", p.total_mass)?;
    let id = |a: usize, b: usize, c: usize| a + nx * (b + ny * c);
    let mut points = Vec::with_capacity(nx * ny * nz);
    for c in 0..nz {
        for b in 0..ny {
            for a in 0..nx {
                points.push([
                    p.origin[0] + p.spacing * a as f64,
                    p.origin[1] + p.spacing * b as f64,
                    p.origin[2] + p.spacing * c as f64,
                ]);
            }
        }
    }
    let mut pairs: Vec<(usize, usize, SpringMaterial)> = Vec::new();
    let n = [nx, ny, nz];
    // Every lattice offset in {0, 1}^3 \ {0} from a corner, plus the face and
    // body diagonals that go "down" in some coordinate.
    for c in 0..nz {
        for b in 0..ny {
            for a in 0..nx {
                let here = [a, b, c];
                for off in offsets() {
                    let mut other = [0usize; 3];
                    let mut ok = true;
                    for r in 0..3 {
                        let t = here[r] as i64 + off[r];
                        if t < 0 || t >= n[r] as i64 {
                            ok = false;
                            break;
                        }
                        other[r] = t as usize;
                    }
                    if !ok {
                        continue;
                    }
                    let nonzero = off.iter().filter(|&&o| o != 0).count();
                    let m = match nonzero {
                        1 => p.edge,
                        2 => p.face,
                        _ => p.body,
                    };
                    if m.stiffness > 0.0 {
                        pairs.push((id(a, b, c), id(other[0], other[1], other[2]), m));
                    }
                }
            }
        }
    }
    let springs = pairs
        .iter()
        .enumerate()
        .map(|(s, &(i, j, m))| spring_at_rest(&points, s, i, j, m))
        .collect::<Result<Vec<_>, _>>()?;
    let masses = vec![p.total_mass / points.len() as f64; points.len()];
    let mut model = MassSpringModel::new(masses, springs, p.options)?;
    model.set_faces(block_surface(nx, ny, nz))?;
    Ok((model, State::at_rest(&points)))
}

/// The 13 lattice offsets that pair each neighbour once: 3 edges, 6 face
/// diagonals, 4 body diagonals (each with its first non-zero entry positive).
fn offsets() -> Vec<[i64; 3]> {
    let mut out = Vec::with_capacity(13);
    for dz in -1..=1i64 {
        for dy in -1..=1i64 {
            for dx in -1..=1i64 {
                let o = [dx, dy, dz];
                let first = o.iter().copied().find(|&t| t != 0);
                if first == Some(1) {
                    out.push(o);
                }
            }
        }
    }
    out
}

/// Outward-facing boundary triangles of an `nx x ny x nz` lattice.
fn block_surface(nx: usize, ny: usize, nz: usize) -> Vec<[usize; 3]> {
    let id = |a: usize, b: usize, c: usize| a + nx * (b + ny * c);
    let mut faces = Vec::new();
    // A grid of quads on one face: corner(s, t) -> particle; `flip` reverses winding.
    let mut quad_grid =
        |ns: usize, nt: usize, corner: &dyn Fn(usize, usize) -> usize, flip: bool| {
            for t in 0..nt - 1 {
                for s in 0..ns - 1 {
                    let (p00, p10, p11, p01) = (
                        corner(s, t),
                        corner(s + 1, t),
                        corner(s + 1, t + 1),
                        corner(s, t + 1),
                    );
                    if flip {
                        faces.push([p00, p11, p10]);
                        faces.push([p00, p01, p11]);
                    } else {
                        faces.push([p00, p10, p11]);
                        faces.push([p00, p11, p01]);
                    }
                }
            }
        };
    quad_grid(nx, ny, &|s, t| id(s, t, 0), true);
    quad_grid(nx, ny, &|s, t| id(s, t, nz - 1), false);
    quad_grid(nx, nz, &|s, t| id(s, 0, t), false);
    quad_grid(nx, nz, &|s, t| id(s, ny - 1, t), true);
    quad_grid(ny, nz, &|s, t| id(0, s, t), true);
    quad_grid(ny, nz, &|s, t| id(nx - 1, s, t), false);
    faces
}

/// Parameters of [`from_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct MeshParams {
    /// Total mass (kg), lumped uniformly over the vertices. Default 1.
    pub total_mass: f64,
    /// Material of the edge springs. Default `k = 1e4`, `d = 0.1`.
    pub edge: SpringMaterial,
    /// Bend springs across every edge shared by two triangles (joining the
    /// two opposite vertices), or `None`. Default `Some(k = 1e3, d = 0.1)`.
    pub bend: Option<SpringMaterial>,
    /// Model options. Default [`ModelOptions::default`].
    pub options: ModelOptions,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for MeshParams {
    fn default() -> Self {
        Self {
            total_mass: 1.0,
            edge: SpringMaterial::new(1e4, 0.1),
            bend: Some(SpringMaterial::new(1e3, 0.1)),
            options: ModelOptions::default(),
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// A model from a triangle mesh: one particle per vertex, one spring per
/// (undirected) edge, optional bend springs across shared edges, rest
/// lengths from the mesh; the triangles are kept for OBJ export.
///
/// # Errors
/// [`MassSpringError::InvalidParameter`] for an empty mesh or non-positive
/// mass; [`MassSpringError::NoSuchParticle`] for a triangle index out of
/// range; [`MassSpringError::ZeroLengthSpring`] if an edge or bend pair has
/// coincident endpoints (a degenerate triangle).
pub fn from_mesh(
    mesh: &ObjMesh,
    p: &MeshParams,
) -> Result<(MassSpringModel, State), MassSpringError> {
    let n = mesh.positions.len();
    check_count("vertex count", n, 1)?;
    check_positive("total_mass", p.total_mass)?;
    for t in &mesh.triangles {
        for &q in t {
            if q >= n {
                return Err(MassSpringError::NoSuchParticle {
                    particle: q,
                    n_particles: n,
                });
            }
        }
    }
    // Edge -> opposite vertices of the triangles sharing it (ordered map: deterministic).
    let mut edges: BTreeMap<(usize, usize), Vec<usize>> = BTreeMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b, opposite) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            if a == b {
                continue; // degenerate triangle edge: no spring
            }
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(opposite);
        }
    }
    let mut pairs: Vec<(usize, usize, SpringMaterial)> =
        edges.keys().map(|&(a, b)| (a, b, p.edge)).collect();
    if let Some(bend) = p.bend {
        let mut seen = std::collections::BTreeSet::new();
        for (&(a, b), opp) in &edges {
            for x in 0..opp.len() {
                for y in x + 1..opp.len() {
                    let (c, d) = (opp[x].min(opp[y]), opp[x].max(opp[y]));
                    if c != d
                        && !edges.contains_key(&(c, d))
                        && c != a
                        && c != b
                        && d != a
                        && d != b
                        && seen.insert((c, d))
                    {
                        pairs.push((c, d, bend));
                    }
                }
            }
        }
    }
    let springs = pairs
        .iter()
        .enumerate()
        .map(|(s, &(i, j, m))| spring_at_rest(&mesh.positions, s, i, j, m))
        .collect::<Result<Vec<_>, _>>()?;
    let masses = vec![p.total_mass / n as f64; n];
    let mut model = MassSpringModel::new(masses, springs, p.options)?;
    model.set_faces(mesh.triangles.clone())?;
    Ok((model, State::at_rest(&mesh.positions)))
}
