//! Colliders: planes, spheres and triangle meshes (static, moving rigidly
//! at constant velocity or along a [`KeyframedPath`], or deforming through
//! a sequence of poses of one topology), each with Coulomb friction
//! coefficients. What contact does with them per step is in `contact.rs`.

use std::sync::Arc;

use hookean_geometry::TriMesh;
use nalgebra::{Rotation3, Vector3};

use crate::error::MassSpringError;
use crate::path::KeyframedPath;

/// Coulomb friction of a collider: a particle in contact sticks while the
/// tangential force stays within `mu_s` times the normal force, and slides
/// against a friction force of `mu_k` times the normal force otherwise
/// (docs/CONTACT.md). Both 0 by default (frictionless).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Friction {
    /// Static coefficient `mu_s >= 0`.
    pub mu_s: f64,
    /// Kinetic coefficient `mu_k >= 0`.
    pub mu_k: f64,
}

impl Friction {
    /// No friction.
    pub const NONE: Friction = Friction {
        mu_s: 0.0,
        mu_k: 0.0,
    };

    /// Static and kinetic coefficients.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `static_friction` or
    /// `kinetic_friction` for a negative or non-finite coefficient.
    pub fn new(mu_s: f64, mu_k: f64) -> Result<Self, MassSpringError> {
        for (name, mu) in [("static_friction", mu_s), ("kinetic_friction", mu_k)] {
            if !(mu >= 0.0 && mu.is_finite()) {
                return Err(MassSpringError::InvalidParameter {
                    name,
                    message: format!("{mu:?} must be non-negative and finite"),
                });
            }
        }
        Ok(Self { mu_s, mu_k })
    }

    /// True when both coefficients are zero.
    pub fn is_none(&self) -> bool {
        self.mu_s == 0.0 && self.mu_k == 0.0
    }
}

/// A rigid motion along a prescribed path: constant linear velocity `v`
/// and constant angular velocity `omega` about a pivot `c` that moves with
/// the body, so a point at `X` at time 0 is at
/// `c + v t + R(omega t) (X - c)` at time `t` (`R(w)` the rotation by
/// `|w|` radians about `w`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RigidMotion {
    /// Linear velocity (m/s).
    pub velocity: [f64; 3],
    /// Angular velocity (rad/s).
    pub angular_velocity: [f64; 3],
    /// The pivot at time 0 (m).
    pub pivot: [f64; 3],
}

impl RigidMotion {
    /// True for a body at rest.
    pub fn is_static(&self) -> bool {
        self.velocity == [0.0; 3] && self.angular_velocity == [0.0; 3]
    }

    fn check(&self) -> Result<(), MassSpringError> {
        for (name, v) in [
            ("velocity", self.velocity),
            ("angular_velocity", self.angular_velocity),
            ("pivot", self.pivot),
        ] {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(MassSpringError::InvalidParameter {
                    name,
                    message: format!("{v:?} must be finite"),
                });
            }
        }
        Ok(())
    }

    /// The rotation `R(omega t)` and the pivot's position at time `t`.
    fn pose(&self, t: f64) -> (Rotation3<f64>, Vector3<f64>) {
        let w = Vector3::from(self.angular_velocity) * t;
        (
            Rotation3::from_scaled_axis(w),
            Vector3::from(self.pivot) + Vector3::from(self.velocity) * t,
        )
    }

    /// Where the point of the body that is at `x_rest` at time 0 is at `t`.
    pub fn to_world(&self, t: f64, x_rest: &Vector3<f64>) -> Vector3<f64> {
        let (r, c) = self.pose(t);
        c + r * (x_rest - Vector3::from(self.pivot))
    }

    /// [`to_world`](Self::to_world) on plain arrays.
    pub fn point_at(&self, t: f64, x_rest: [f64; 3]) -> [f64; 3] {
        let w = self.to_world(t, &Vector3::from(x_rest));
        [w.x, w.y, w.z]
    }

    /// The body point at `x` at time `t`, where it was at time 0.
    pub fn to_rest(&self, t: f64, x: &Vector3<f64>) -> Vector3<f64> {
        let (r, c) = self.pose(t);
        Vector3::from(self.pivot) + r.inverse() * (x - c)
    }

    /// The velocity of the body point at `x` at time `t`: `v + omega x (x - c(t))`.
    pub fn velocity_at(&self, t: f64, x: &Vector3<f64>) -> Vector3<f64> {
        let (_, c) = self.pose(t);
        Vector3::from(self.velocity) + Vector3::from(self.angular_velocity).cross(&(x - c))
    }
}

/// How a mesh collider moves (docs/CONTACT.md, "Moving and animated
/// colliders").
#[derive(Debug, Clone, PartialEq)]
pub enum ColliderMotion {
    /// Rigidly at constant linear and angular velocity (static when both
    /// are zero).
    Rigid(RigidMotion),
    /// Rigidly along keyframes: the one owner of prescribed rigid motion,
    /// shared with the pins' targets.
    Path(KeyframedPath),
    /// Deforming through the poses of a [`MeshSequence`].
    Sequence(Arc<MeshSequence>),
}

impl Default for ColliderMotion {
    fn default() -> Self {
        ColliderMotion::Rigid(RigidMotion::default())
    }
}

impl ColliderMotion {
    /// True for a body at rest.
    pub fn is_static(&self) -> bool {
        match self {
            ColliderMotion::Rigid(m) => m.is_static(),
            ColliderMotion::Path(p) => p.max_rates() == (0.0, 0.0),
            ColliderMotion::Sequence(s) => s.max_speed == 0.0,
        }
    }

    /// The rigid pose at `t` (rotation, moved pivot) and the pivot at rest;
    /// `None` for a sequence.
    fn rigid_pose(&self, t: f64) -> Option<(Rotation3<f64>, Vector3<f64>, Vector3<f64>)> {
        match self {
            ColliderMotion::Rigid(m) => {
                let (r, c) = m.pose(t);
                Some((r, c, Vector3::from(m.pivot)))
            }
            ColliderMotion::Path(p) => {
                let (r, c) = p.pose(t);
                Some((r, c, Vector3::from(p.pivot())))
            }
            ColliderMotion::Sequence(_) => None,
        }
    }

    /// The body point at world `x` at time `t`, in the rest frame (`x`
    /// itself for a sequence, whose mesh is posed in world coordinates).
    fn to_rest(&self, t: f64, x: &Vector3<f64>) -> Vector3<f64> {
        match self.rigid_pose(t) {
            Some((r, c, c0)) => c0 + r.inverse() * (x - c),
            None => *x,
        }
    }

    /// A rest-frame point in world coordinates at `t`.
    fn to_world(&self, t: f64, x: &Vector3<f64>) -> Vector3<f64> {
        match self.rigid_pose(t) {
            Some((r, c, c0)) => c + r * (x - c0),
            None => *x,
        }
    }

    /// A rest-frame direction in world coordinates at `t`.
    fn rotate(&self, t: f64, d: &Vector3<f64>) -> Vector3<f64> {
        match self.rigid_pose(t) {
            Some((r, _, _)) => r * d,
            None => *d,
        }
    }

    /// The velocity of the rigid body point at world `x` at `t`: `v +
    /// omega x (x - c(t))` (zero for a sequence: its surface velocity is
    /// per triangle, [`MeshCollider::surface_velocity`]).
    fn rigid_velocity(&self, t: f64, x: &Vector3<f64>) -> Vector3<f64> {
        match self {
            ColliderMotion::Rigid(m) => m.velocity_at(t, x),
            ColliderMotion::Path(p) => p.velocity_of_world_point(t, x),
            ColliderMotion::Sequence(_) => Vector3::zeros(),
        }
    }
}

/// The poses of a deforming mesh: one vertex array per frame, all of one
/// topology, frame `k` at time `k dt`, interpolated linearly in time and
/// held after the last, `X(t) = X_k + u (X_{k+1} - X_k)`, `u = t / dt - k`.
/// The velocity of a vertex is the finite difference `(X_{k+1} - X_k) /
/// dt`, the exact derivative of the interpolation.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSequence {
    frames: Vec<Vec<Vector3<f64>>>,
    frame_interval: f64,
    /// The largest vertex speed (m/s).
    max_speed: f64,
}

impl MeshSequence {
    /// The frame and the weight of the next one at `t`, and whether the
    /// sequence moves at `t` (inside its time span).
    fn segment(&self, t: f64) -> (usize, f64, bool) {
        Self::segment_of(t, self.frames.len(), self.frame_interval)
    }

    /// The interpolation of `n_frames` poses `frame_interval` apart at `t`:
    /// the frame `k`, the weight `u` of frame `k + 1` (`X(t) = X_k + u
    /// (X_{k+1} - X_k)`; frame `k` alone when it is the only one), and
    /// whether the sequence moves at `t` (inside its time span). For
    /// viewers that replay a sequence from its frames.
    pub fn segment_of(t: f64, n_frames: usize, frame_interval: f64) -> (usize, f64, bool) {
        let last = n_frames.saturating_sub(1);
        // At frame 0 the rates of the first interval (the right derivative).
        if last == 0 || !(t >= 0.0) {
            return (0, 0.0, false);
        }
        let u = t / frame_interval;
        if u >= last as f64 {
            return (last - 1, 1.0, false);
        }
        let k = (u.floor() as usize).min(last - 1);
        (k, u - k as f64, true)
    }

    /// Vertex `i` at time `t`.
    pub fn vertex_at(&self, t: f64, i: usize) -> Vector3<f64> {
        let (k, u, _) = self.segment(t);
        let a = self.frames[k][i];
        match self.frames.get(k + 1) {
            Some(b) => a + (b[i] - a) * u,
            None => a,
        }
    }

    /// The velocity of vertex `i` at time `t` (m/s).
    pub fn vertex_velocity(&self, t: f64, i: usize) -> Vector3<f64> {
        let (k, _, moving) = self.segment(t);
        if !moving {
            return Vector3::zeros();
        }
        (self.frames[k + 1][i] - self.frames[k][i]) / self.frame_interval
    }

    /// Vertex `i` of frame `k`.
    pub fn frame_vertex(&self, k: usize, i: usize) -> Vector3<f64> {
        self.frames[k][i]
    }

    /// Frames.
    pub fn n_frames(&self) -> usize {
        self.frames.len()
    }

    /// The time between frames (s).
    pub fn frame_interval(&self) -> f64 {
        self.frame_interval
    }

    /// The largest vertex speed of the sequence (m/s).
    pub fn max_vertex_speed(&self) -> f64 {
        self.max_speed
    }

    fn compute_max_speed(&self) -> f64 {
        self.frames
            .windows(2)
            .flat_map(|w| w[0].iter().zip(&w[1]).map(|(a, b)| (b - a).norm()))
            .fold(0.0, f64::max)
            / self.frame_interval
    }
}

/// A triangle mesh obstacle with a thickness, at rest, moving rigidly or
/// deforming ([`ColliderMotion`]). Particles are kept at least `thickness`
/// away from its surface, on its outer side (the side its counter-clockwise
/// triangles face).
#[derive(Debug, Clone)]
pub struct MeshCollider {
    /// The rest pose of a rigid body; a sequence's pose at `posed_at`.
    mesh: TriMesh,
    thickness: f64,
    motion: ColliderMotion,
    /// Slack of the contact band, `1e-9` of the mesh's size: a particle
    /// put at the thickness stays in contact despite round-off.
    slack: f64,
    /// The time of a sequence's current pose.
    posed_at: f64,
    /// The vertices of the next pose (a sequence's scratch).
    scratch: Vec<Vector3<f64>>,
}

/// A surface point in contact, in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Touch {
    /// Signed distance (negative inside or behind).
    pub phi: f64,
    /// Unit outward normal.
    pub normal: Vector3<f64>,
    /// Velocity of the surface point.
    pub velocity: Vector3<f64>,
}

impl MeshCollider {
    /// The mesh `mesh` (its rest pose, at time 0) with `thickness` (m), in
    /// `[0, D]`, `D` the diagonal of the mesh's bounding box: a thicker
    /// layer is no longer the mesh's shape (every particle near it is in
    /// contact with a blob about the mesh), and its squares must stay
    /// finite.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `thickness` for a
    /// thickness outside `[0, D]` (or not a number).
    pub fn new(mesh: TriMesh, thickness: f64) -> Result<Self, MassSpringError> {
        let size = mesh.aabb().extent().norm();
        if !(thickness >= 0.0 && thickness <= size) {
            return Err(MassSpringError::InvalidParameter {
                name: "thickness",
                message: format!(
                    "{thickness:?} m is outside [0, {size:.6}] m (0 to the diagonal of the mesh's bounding box)"
                ),
            });
        }
        Ok(Self {
            mesh,
            thickness,
            motion: ColliderMotion::default(),
            slack: 1e-9 * size,
            posed_at: 0.0,
            scratch: Vec::new(),
        })
    }

    /// The same mesh moving along `motion`.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a non-finite velocity,
    /// angular velocity or pivot.
    pub fn with_motion(mut self, motion: RigidMotion) -> Result<Self, MassSpringError> {
        motion.check()?;
        self.motion = ColliderMotion::Rigid(motion);
        Ok(self)
    }

    /// The same mesh moving rigidly along `path` (its pivot in the mesh's
    /// rest frame).
    pub fn with_path(mut self, path: KeyframedPath) -> Self {
        self.motion = ColliderMotion::Path(path);
        self
    }

    /// A deforming mesh collider: `frames[0]` is the mesh at time 0 and
    /// every later frame a pose of the same vertices and triangles, frame
    /// `k` at time `k frame_interval` ([`MeshSequence`]).
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] naming `thickness` as
    /// [`MeshCollider::new`], `frame_interval` for one not positive and
    /// finite, and `sequence` for no frames or a frame whose vertex count or
    /// triangles differ from frame 0's (naming the frame, from 0).
    pub fn sequence(
        frames: Vec<TriMesh>,
        frame_interval: f64,
        thickness: f64,
    ) -> Result<Self, MassSpringError> {
        if !(frame_interval > 0.0 && frame_interval.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "frame_interval",
                message: format!("{frame_interval:?} s must be positive and finite"),
            });
        }
        let Some(first) = frames.first() else {
            return Err(MassSpringError::InvalidParameter {
                name: "sequence",
                message: "a sequence needs at least one frame".into(),
            });
        };
        for (k, f) in frames.iter().enumerate().skip(1) {
            if f.vertices().len() != first.vertices().len() {
                return Err(MassSpringError::InvalidParameter {
                    name: "sequence",
                    message: format!(
                        "frame {k} has {} vertices, frame 0 has {}: the frames must be one topology",
                        f.vertices().len(),
                        first.vertices().len()
                    ),
                });
            }
            if f.triangles() != first.triangles() {
                return Err(MassSpringError::InvalidParameter {
                    name: "sequence",
                    message: format!(
                        "frame {k} has other triangles than frame 0: the frames must be one topology"
                    ),
                });
            }
        }
        let mut sequence = MeshSequence {
            frames: frames.iter().map(|f| f.vertices().to_vec()).collect(),
            frame_interval,
            max_speed: 0.0,
        };
        sequence.max_speed = sequence.compute_max_speed();
        let mut collider = Self::new(
            frames.into_iter().next().unwrap_or_else(|| unreachable!()),
            thickness,
        )?;
        let n = collider.mesh.vertices().len();
        collider.scratch = Vec::with_capacity(n);
        collider.posed_at = 0.0;
        collider.motion = ColliderMotion::Sequence(Arc::new(sequence));
        Ok(collider)
    }

    /// Poses a sequence's mesh at time `t` (nothing for a rigid body). An
    /// interpolated pose with a collapsed triangle keeps the pose before.
    /// No allocation.
    pub(crate) fn pose_at(&mut self, t: f64) {
        let ColliderMotion::Sequence(seq) = &self.motion else {
            return;
        };
        if self.posed_at == t {
            return;
        }
        self.scratch.clear();
        let n = self.mesh.vertices().len();
        self.scratch.extend((0..n).map(|i| seq.vertex_at(t, i)));
        if self.mesh.set_vertices(&self.scratch).is_ok() {
            self.posed_at = t;
        }
    }

    /// The mesh: a rigid body's rest pose, a sequence's current pose.
    pub fn mesh(&self) -> &TriMesh {
        &self.mesh
    }

    /// Vertex `i` of the body at time `t`, whatever its motion (the pose
    /// viewers draw): `c(t) + R(t) (X_i - c0)` for a rigid body, the
    /// interpolated pose of a sequence.
    pub fn vertex_at(&self, t: f64, i: usize) -> Vector3<f64> {
        match &self.motion {
            ColliderMotion::Sequence(seq) => seq.vertex_at(t, i),
            m => m.to_world(t, &self.mesh.vertices()[i]),
        }
    }

    /// The thickness (m).
    pub fn thickness(&self) -> f64 {
        self.thickness
    }

    /// The motion.
    pub fn motion(&self) -> &ColliderMotion {
        &self.motion
    }

    /// The velocity at time `t` of the surface point at world `y` (on the
    /// surface or pushed out from it): `v + omega x r` for a rigid body;
    /// for a sequence, the vertex velocities of the triangle closest to `y`
    /// weighted by the barycentric coordinates of its closest point.
    pub fn surface_velocity(&self, t: f64, y: &Vector3<f64>) -> Vector3<f64> {
        match &self.motion {
            ColliderMotion::Sequence(seq) => {
                let c = self.mesh.closest(y);
                self.sequence_velocity(seq, t, c.triangle, &c.point)
            }
            m => m.rigid_velocity(t, y),
        }
    }

    fn sequence_velocity(
        &self,
        seq: &MeshSequence,
        t: f64,
        triangle: usize,
        point: &Vector3<f64>,
    ) -> Vector3<f64> {
        let w = self.mesh.barycentric(triangle, point);
        let tri = self.mesh.triangles()[triangle];
        (0..3).map(|k| seq.vertex_velocity(t, tri[k]) * w[k]).sum()
    }

    /// The contact of a particle at `x` at time `t` with the closest
    /// feature of the surface (a sequence: of its current pose, which the
    /// model sets at every step's start and end).
    pub(crate) fn touch(&self, t: f64, x: &Vector3<f64>) -> Touch {
        match &self.motion {
            ColliderMotion::Sequence(seq) => {
                let c = self.mesh.closest(x);
                let velocity = if c.distance.is_nan() {
                    Vector3::zeros()
                } else {
                    self.sequence_velocity(seq, t, c.triangle, &c.point)
                };
                return Touch {
                    phi: c.distance,
                    normal: c.normal,
                    velocity,
                };
            }
            m if m.is_static() => {
                let c = self.mesh.closest(x);
                return Touch {
                    phi: c.distance,
                    normal: c.normal,
                    velocity: Vector3::zeros(),
                };
            }
            _ => {}
        }
        let c = self.mesh.closest(&self.motion.to_rest(t, x));
        Touch {
            phi: c.distance,
            normal: self.motion.rotate(t, &c.normal),
            velocity: self.motion.rigid_velocity(t, x),
        }
    }

    /// The largest surface speed near a box of centre `centre` and
    /// half-diagonal `d` (m/s): `|v| + |omega| (|c - centre| + d)` for a
    /// rigid body (the path's largest rates), the largest vertex speed of a
    /// sequence. The energy budget's bound of the work the body can do.
    pub fn max_surface_speed(&self, centre: [f64; 3], d: f64) -> f64 {
        let arm = |pivot: [f64; 3]| (Vector3::from(pivot) - Vector3::from(centre)).norm() + d;
        match &self.motion {
            ColliderMotion::Rigid(m) => {
                Vector3::from(m.velocity).norm()
                    + Vector3::from(m.angular_velocity).norm() * arm(m.pivot)
            }
            ColliderMotion::Path(p) => {
                let (v, w) = p.max_rates();
                // The pivot moves: its farthest is within the path's
                // translations, bounded by the sum of the keys' extents.
                let reach = p
                    .keys()
                    .iter()
                    .map(|k| Vector3::from(k.translation).norm())
                    .fold(0.0, f64::max);
                v + w * (arm(p.pivot()) + reach)
            }
            ColliderMotion::Sequence(s) => s.max_vertex_speed(),
        }
    }

    /// Where a particle moving straight from `a` (at `t`) to `b` (at `t +
    /// h`) first meets the surface, moving with it, if it does: the world
    /// position at `t + h` of the contact point pushed out by the
    /// thickness, and the outward normal there. The path is straight in
    /// the body's frame (exact for translations; for rotations the body's
    /// motion within the step is taken as linear). A particle that ends
    /// inside a closed mesh without crossing (it started inside) is pushed
    /// out along the closest feature's normal; one that ends behind an open
    /// mesh without crossing it came round its boundary and is left there.
    pub(crate) fn correct_path(
        &self,
        t: f64,
        h: f64,
        a: &Vector3<f64>,
        b: &Vector3<f64>,
    ) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let (ra, rb) = match &self.motion {
            // The pose is at t + h: the start carried by the surface's
            // displacement over the step at its closest point (exact for a
            // translating patch, first order otherwise).
            ColliderMotion::Sequence(seq) => {
                let mut boxed = hookean_geometry::Aabb::point(a);
                boxed.add_point(b);
                let reach = seq.max_speed * h + self.thickness + self.slack;
                if !boxed.overlaps(&self.mesh.aabb().inflated(reach)) {
                    return None;
                }
                let c = self.mesh.closest(a);
                if c.distance.is_nan() {
                    return None;
                }
                let w = self.mesh.barycentric(c.triangle, &c.point);
                let tri = self.mesh.triangles()[c.triangle];
                let before: Vector3<f64> = (0..3).map(|k| seq.vertex_at(t, tri[k]) * w[k]).sum();
                (a + (c.point - before), *b)
            }
            m if m.is_static() => (*a, *b),
            m => (m.to_rest(t, a), m.to_rest(t + h, b)),
        };
        let mut boxed = hookean_geometry::Aabb::point(&ra);
        boxed.add_point(&rb);
        if !boxed.overlaps(&self.mesh.aabb()) {
            return None;
        }
        let end = self.mesh.closest(&rb);
        let (y, n) = match self.mesh.first_hit(&ra, &rb) {
            Some((s, tri)) if self.mesh.closest(&ra).distance >= 0.0 => {
                let mut n = self.mesh.face_normal(tri);
                if n.dot(&(ra - rb)) < 0.0 {
                    n = -n; // the side the particle came from
                }
                let hit = ra + (rb - ra) * s;
                if end.distance >= 0.0 && (rb - hit).dot(&n) >= 0.0 {
                    return None; // touched and left on the same side
                }
                (hit + n * self.thickness, n)
            }
            // An end behind without a crossing: inside a closed mesh it
            // started inside; behind an open one it came round the
            // boundary, where nothing stops it, and stays.
            _ if end.distance < 0.0 && self.mesh.is_closed() => {
                (end.point + end.normal * self.thickness, end.normal)
            }
            _ => return None,
        };
        if self.motion.is_static() {
            Some((y, n))
        } else {
            Some((
                self.motion.to_world(t + h, &y),
                self.motion.rotate(t + h, &n),
            ))
        }
    }
}

/// A static or moving obstacle: particles stay on its outer side.
#[derive(Debug, Clone, PartialEq)]
pub enum Collider {
    /// The half-space above a plane: signed distance `(x - point) . normal`.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// The unit outward normal.
        normal: [f64; 3],
        /// Contact margin (thickness) `>= 0`: particles closer than this count as touching.
        margin: f64,
        /// Coulomb friction.
        friction: Friction,
    },
    /// The outside of a ball: signed distance `|x - center| - radius`.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius `> 0`.
        radius: f64,
        /// Contact margin (thickness) `>= 0`.
        margin: f64,
        /// Coulomb friction.
        friction: Friction,
    },
    /// The outside of a triangle mesh (or, for an open mesh, the side its
    /// triangles face), kept at its thickness.
    Mesh {
        /// The mesh, its thickness and motion (shared: cloning the model
        /// does not copy the mesh).
        mesh: Arc<MeshCollider>,
        /// Coulomb friction.
        friction: Friction,
    },
}

impl PartialEq for MeshCollider {
    /// Two mesh colliders are equal when they are the same object.
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

impl Collider {
    /// The plane through `point` with outward `normal` (normalised here),
    /// frictionless.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a zero or non-finite normal,
    /// non-finite point, or a negative / non-finite margin.
    pub fn plane(point: [f64; 3], normal: [f64; 3], margin: f64) -> Result<Self, MassSpringError> {
        let n = Vector3::from(normal);
        let len = n.norm();
        if !(len > 0.0 && len.is_finite()) || point.iter().any(|p| !p.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "plane",
                message: format!(
                    "point {point:?} and normal {normal:?} must be finite, normal non-zero"
                ),
            });
        }
        check_margin(margin)?;
        let n = n / len;
        Ok(Collider::Plane {
            point,
            normal: [n.x, n.y, n.z],
            margin,
            friction: Friction::NONE,
        })
    }

    /// The ball of `radius` around `center`, frictionless.
    ///
    /// # Errors
    /// [`MassSpringError::InvalidParameter`] for a non-positive radius, a
    /// non-finite centre, or a negative / non-finite margin.
    pub fn sphere(center: [f64; 3], radius: f64, margin: f64) -> Result<Self, MassSpringError> {
        if !(radius > 0.0 && radius.is_finite()) || center.iter().any(|p| !p.is_finite()) {
            return Err(MassSpringError::InvalidParameter {
                name: "sphere",
                message: format!("center {center:?} must be finite, radius {radius:?} positive"),
            });
        }
        check_margin(margin)?;
        Ok(Collider::Sphere {
            center,
            radius,
            margin,
            friction: Friction::NONE,
        })
    }

    /// A frictionless mesh collider.
    pub fn mesh(mesh: MeshCollider) -> Self {
        Collider::Mesh {
            mesh: Arc::new(mesh),
            friction: Friction::NONE,
        }
    }

    /// The same collider with `friction`.
    pub fn with_friction(mut self, f: Friction) -> Self {
        match &mut self {
            Collider::Plane { friction, .. }
            | Collider::Sphere { friction, .. }
            | Collider::Mesh { friction, .. } => *friction = f,
        }
        self
    }

    /// The friction coefficients.
    pub fn friction(&self) -> Friction {
        match self {
            Collider::Plane { friction, .. }
            | Collider::Sphere { friction, .. }
            | Collider::Mesh { friction, .. } => *friction,
        }
    }

    /// Signed distance of `x` to the surface (negative inside) and the unit
    /// outward normal at the closest surface point (a mesh: in its pose at
    /// time 0).
    pub fn signed_distance(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>) {
        match *self {
            Collider::Plane { point, normal, .. } => {
                let n = Vector3::from(normal);
                ((x - Vector3::from(point)).dot(&n), n)
            }
            Collider::Sphere { center, radius, .. } => {
                let r = x - Vector3::from(center);
                let len = r.norm();
                // At the centre every direction is a normal: take +z.
                let n = if len > 0.0 { r / len } else { Vector3::z() };
                (len - radius, n)
            }
            Collider::Mesh { ref mesh, .. } => {
                let t = mesh.touch(0.0, x);
                (t.phi, t.normal)
            }
        }
    }

    /// The contact margin: particles this close count as touching (for a
    /// mesh, its thickness).
    pub fn margin(&self) -> f64 {
        match *self {
            Collider::Plane { margin, .. } | Collider::Sphere { margin, .. } => margin,
            Collider::Mesh { ref mesh, .. } => mesh.thickness,
        }
    }
}

/// The contact of a particle at `x` at time `t` with a collider: the touch,
/// the distance particles are pushed out to (0 for planes and spheres, the
/// thickness for meshes) and the band within which they count as touching;
/// `None` for a particle certainly outside a mesh's band (its bounding box
/// grown by the band does not hold it, or it is deeper behind an open mesh
/// than the band).
pub(crate) fn touch(c: &Collider, t: f64, x: &Vector3<f64>) -> Option<(Touch, f64, f64)> {
    match c {
        Collider::Mesh { mesh, .. } => {
            let band = mesh.thickness + mesh.slack;
            let rest = if mesh.motion.is_static() {
                *x
            } else {
                mesh.motion.to_rest(t, x)
            };
            if mesh.mesh.aabb().distance_squared(&rest) > band * band {
                return None;
            }
            let touch = mesh.touch(t, x);
            if !mesh.mesh.is_closed() && touch.phi < -band {
                // Deeper behind an open sheet than its band: it came round
                // the boundary (a crossing is caught by the continuous
                // pass), and is not in contact.
                return None;
            }
            Some((touch, mesh.thickness, band))
        }
        _ => {
            let (phi, normal) = c.signed_distance(x);
            Some((
                Touch {
                    phi,
                    normal,
                    velocity: Vector3::zeros(),
                },
                0.0,
                c.margin(),
            ))
        }
    }
}

fn check_margin(margin: f64) -> Result<(), MassSpringError> {
    if margin >= 0.0 && margin.is_finite() {
        Ok(())
    } else {
        Err(MassSpringError::InvalidParameter {
            name: "margin",
            message: format!("{margin:?} must be non-negative and finite"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rigid_motion_maps_there_and_back_and_its_velocity_is_the_derivative() {
        let m = RigidMotion {
            velocity: [0.1, -0.2, 0.3],
            angular_velocity: [0.5, 1.0, -0.7],
            pivot: [1.0, 2.0, 3.0],
        };
        let x0 = Vector3::new(0.3, -0.4, 2.0);
        let t = 0.7;
        let x = m.to_world(t, &x0);
        assert!((m.to_rest(t, &x) - x0).norm() < 1e-14);
        let dt = 1e-6;
        let fd = (m.to_world(t + dt, &x0) - m.to_world(t - dt, &x0)) / (2.0 * dt);
        assert!((fd - m.velocity_at(t, &x)).norm() < 1e-8);
    }
}
