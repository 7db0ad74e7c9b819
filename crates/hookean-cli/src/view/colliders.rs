//! Colliders as the viewers draw them ([`ViewCollider`]: `final.png` and
//! `view.html`), with the motion of a mesh collider replayed at any time
//! (rigid at constant velocity, along a keyframed path, or deforming
//! through a sequence of poses), and as `summary.json` records them
//! ([`SummaryCollider`]: a mesh by its OBJ files, read again by `hookean
//! view`).

use std::path::PathBuf;

use hookean::massspring::{
    Collider, ColliderMotion, Interpolation, Keyframe, KeyframedPath, MeshCollider, MeshSequence,
    RigidMotion, TriMesh,
};
use serde::{Deserialize, Serialize};

/// A collider as the page draws it (the contact margin is not drawn).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ViewCollider {
    /// The plane through `point` with outward unit `normal`.
    Plane {
        /// A point of the plane.
        point: [f64; 3],
        /// Unit outward normal.
        normal: [f64; 3],
    },
    /// A ball.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius (m).
        radius: f64,
    },
    /// A triangle mesh in its pose at time 0. Without `animation` it moves
    /// rigidly: at time `t` a vertex at `X` is at `pivot + velocity t +
    /// R(angular_velocity t) (X - pivot)` (`R(w)` the rotation by `|w|`
    /// radians about `w`); with one, as [`MeshAnimation`] says.
    Mesh {
        /// Vertices at time 0.
        vertices: Vec<[f64; 3]>,
        /// Triangles (counter-clockwise seen from outside).
        triangles: Vec<[usize; 3]>,
        /// Linear velocity (m/s).
        velocity: [f64; 3],
        /// Angular velocity (rad/s).
        angular_velocity: [f64; 3],
        /// The pivot at time 0.
        pivot: [f64; 3],
        /// A keyframed path or a sequence of poses, replacing the constant
        /// velocities.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        animation: Option<MeshAnimation>,
    },
}

/// One key of a keyframed path, as [`Keyframe`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewKey {
    /// Time (s).
    pub t: f64,
    /// Translation of the pivot (m).
    pub translation: [f64; 3],
    /// Rotation vector about the pivot (rad).
    pub rotation: [f64; 3],
}

/// How an animated mesh collider moves (docs/CONTACT.md, "Moving and
/// animated colliders").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum MeshAnimation {
    /// Rigidly along keyframes about the mesh's `pivot`
    /// ([`KeyframedPath`]): `s(u) = 3u^2 - 2u^3` between keys when
    /// `smooth`, `s(u) = u` otherwise.
    Path {
        /// The keys, times increasing.
        keys: Vec<ViewKey>,
        /// Smooth (or linear) interpolation.
        smooth: bool,
    },
    /// Deforming through poses of the mesh's vertices ([`MeshSequence`]):
    /// frame 0 is `vertices`, frame `k >= 1` is `frames[k - 1]`, at time
    /// `k frame_interval`, linear between, held after the last.
    Sequence {
        /// The time between frames (s).
        frame_interval: f64,
        /// The vertices of frames 1, 2, ...
        frames: Vec<Vec<[f64; 3]>>,
    },
}

impl From<&Collider> for ViewCollider {
    fn from(c: &Collider) -> Self {
        match c {
            Collider::Plane { point, normal, .. } => ViewCollider::Plane {
                point: *point,
                normal: *normal,
            },
            Collider::Sphere { center, radius, .. } => ViewCollider::Sphere {
                center: *center,
                radius: *radius,
            },
            Collider::Mesh { mesh, .. } => ViewCollider::of_mesh_collider(mesh),
        }
    }
}

/// The constant rigid motion of a mesh collider (the default, at rest, for
/// a keyframed or deforming body, whose [`MeshAnimation`] says how it moves).
pub fn rigid_motion_of(mesh: &MeshCollider) -> RigidMotion {
    match mesh.motion() {
        ColliderMotion::Rigid(m) => *m,
        ColliderMotion::Path(p) => RigidMotion {
            pivot: p.pivot(),
            ..RigidMotion::default()
        },
        ColliderMotion::Sequence(_) => RigidMotion::default(),
    }
}

/// The keys of `path` as the page replays them, and whether they are
/// smooth.
pub fn path_keys(path: &KeyframedPath) -> (Vec<ViewKey>, bool) {
    let keys = path
        .keys()
        .iter()
        .map(|k| ViewKey {
            t: k.t,
            translation: k.translation,
            rotation: k.rotation,
        })
        .collect();
    (keys, path.interpolation() == Interpolation::Smooth)
}

/// A collider as `summary.json` records it: a plane or a sphere as the
/// page draws it, a triangle mesh by the OBJ file the scene named (with its
/// placement and motion), which `hookean view` reads again. A mesh is never
/// embedded, so `summary.json` stays small whatever the mesh's size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SummaryCollider {
    /// A mesh collider, by its file.
    File(MeshFile),
    /// A plane or a sphere (or, in summaries written before the mesh files,
    /// a mesh with its vertices and triangles).
    Drawn(ViewCollider),
}

/// The tag of [`MeshFile`] in `summary.json` (`"kind": "mesh-file"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MeshFileKind {
    /// The only value.
    #[serde(rename = "mesh-file")]
    MeshFile,
}

/// A mesh collider in `summary.json`: its OBJ file, how it was placed and
/// how it moves.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// Always [`MeshFileKind::MeshFile`].
    pub kind: MeshFileKind,
    /// The `path` key of the scene's `[[collider]]`, as written there.
    pub path: PathBuf,
    /// The file the run read (absolute).
    pub file: PathBuf,
    /// The scene's `scale`.
    pub scale: f64,
    /// The scene's `offset` (m).
    pub offset: [f64; 3],
    /// Vertices of the mesh the run used.
    pub vertices: usize,
    /// Triangles of the mesh the run used.
    pub triangles: usize,
    /// Linear velocity (m/s).
    pub velocity: [f64; 3],
    /// Angular velocity (rad/s).
    pub angular_velocity: [f64; 3],
    /// The pivot at time 0.
    pub pivot: [f64; 3],
    /// The keys of a keyframed path (the scene's `keys`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub keys: Vec<ViewKey>,
    /// Smooth interpolation between `keys`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub smooth: bool,
    /// The files of a deforming body's frames 1, 2, ... (absolute; the
    /// scene's `frames`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub frames: Vec<PathBuf>,
    /// The time between `frames` (s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_interval: Option<f64>,
}

impl MeshFile {
    /// The collider as the page draws it: the files read again, scaled and
    /// moved as the run did; an error if one cannot be read or is no longer
    /// the mesh of the run.
    pub fn load(&self) -> Result<ViewCollider, String> {
        let read = |file: &PathBuf| -> Result<TriMesh, String> {
            let (_, mesh) = hookean::massspring::read_surface(file, self.scale, self.offset)
                .map_err(|e| e.to_string())?;
            let (v, t) = (mesh.vertices().len(), mesh.triangles().len());
            if (v, t) != (self.vertices, self.triangles) {
                return Err(format!(
                    "{}: {v} vertices and {t} triangles, the run's mesh had {} and {}: the file changed since the run",
                    file.display(),
                    self.vertices,
                    self.triangles
                ));
            }
            Ok(mesh)
        };
        let mesh = read(&self.file)?;
        let animation = if !self.frames.is_empty() {
            let frames = self
                .frames
                .iter()
                .map(|f| {
                    Ok(read(f)?
                        .vertices()
                        .iter()
                        .map(|v| [v.x, v.y, v.z])
                        .collect())
                })
                .collect::<Result<_, String>>()?;
            Some(MeshAnimation::Sequence {
                frame_interval: self.frame_interval.unwrap_or(0.04),
                frames,
            })
        } else if !self.keys.is_empty() {
            Some(MeshAnimation::Path {
                keys: self.keys.clone(),
                smooth: self.smooth,
            })
        } else {
            None
        };
        let motion = RigidMotion {
            velocity: self.velocity,
            angular_velocity: self.angular_velocity,
            pivot: self.pivot,
        };
        let mut drawn = ViewCollider::mesh(&mesh, motion);
        if let ViewCollider::Mesh { animation: a, .. } = &mut drawn {
            *a = animation;
        }
        Ok(drawn)
    }
}

impl ViewCollider {
    /// A mesh collider of `mesh` (its pose at time 0) moving rigidly by `motion`.
    pub fn mesh(mesh: &TriMesh, motion: RigidMotion) -> Self {
        ViewCollider::Mesh {
            vertices: mesh.vertices().iter().map(|v| [v.x, v.y, v.z]).collect(),
            triangles: mesh.triangles().to_vec(),
            velocity: motion.velocity,
            angular_velocity: motion.angular_velocity,
            pivot: motion.pivot,
            animation: None,
        }
    }

    /// A mesh collider as drawn: its pose at time 0 and its motion (a
    /// sequence's frames in full).
    fn of_mesh_collider(c: &MeshCollider) -> Self {
        let mut drawn = ViewCollider::mesh(c.mesh(), rigid_motion_of(c));
        if let ViewCollider::Mesh {
            vertices,
            animation,
            ..
        } = &mut drawn
        {
            match c.motion() {
                ColliderMotion::Rigid(_) => {}
                ColliderMotion::Path(p) => {
                    let (keys, smooth) = path_keys(p);
                    *animation = Some(MeshAnimation::Path { keys, smooth });
                }
                ColliderMotion::Sequence(seq) => {
                    let n = vertices.len();
                    let mut poses = (0..seq.n_frames()).map(|k| -> Vec<[f64; 3]> {
                        (0..n).map(|i| seq.frame_vertex(k, i).into()).collect()
                    });
                    // The collider's mesh is its current pose: frame 0 from the sequence.
                    if let Some(first) = poses.next() {
                        *vertices = first;
                    }
                    *animation = Some(MeshAnimation::Sequence {
                        frame_interval: seq.frame_interval(),
                        frames: poses.collect(),
                    });
                }
            }
        }
        drawn
    }

    /// The vertices of a mesh collider at time `t` (empty for other kinds):
    /// the rigid motion, the keyframed path ([`KeyframedPath::point_at`])
    /// or the sequence's interpolated pose ([`MeshSequence::segment_of`]).
    /// A path whose keys are not valid (an edited `summary.json`) is drawn
    /// at its pose at time 0.
    pub fn mesh_vertices_at(&self, t: f64) -> Vec<[f64; 3]> {
        let ViewCollider::Mesh {
            vertices,
            velocity,
            angular_velocity,
            pivot,
            animation,
            ..
        } = self
        else {
            return Vec::new();
        };
        match animation {
            None => {
                let motion = RigidMotion {
                    velocity: *velocity,
                    angular_velocity: *angular_velocity,
                    pivot: *pivot,
                };
                vertices.iter().map(|&v| motion.point_at(t, v)).collect()
            }
            Some(MeshAnimation::Path { keys, smooth }) => {
                let keys = keys
                    .iter()
                    .map(|k| Keyframe {
                        t: k.t,
                        translation: k.translation,
                        rotation: k.rotation,
                    })
                    .collect();
                let interpolation = if *smooth {
                    Interpolation::Smooth
                } else {
                    Interpolation::Linear
                };
                match KeyframedPath::new(keys, interpolation, *pivot) {
                    Ok(path) => vertices.iter().map(|&v| path.point_at(t, v)).collect(),
                    Err(_) => vertices.clone(),
                }
            }
            Some(MeshAnimation::Sequence {
                frame_interval,
                frames,
            }) => {
                let (k, u, _) = MeshSequence::segment_of(t, 1 + frames.len(), *frame_interval);
                let pose = |k: usize| if k == 0 { vertices } else { &frames[k - 1] };
                let a = pose(k);
                let b = if k < frames.len() { pose(k + 1) } else { a };
                a.iter()
                    .zip(b)
                    .map(|(p, q)| std::array::from_fn(|c| p[c] + (q[c] - p[c]) * u))
                    .collect()
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle() -> Vec<[f64; 3]> {
        vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    }

    fn mesh(animation: MeshAnimation) -> ViewCollider {
        ViewCollider::Mesh {
            vertices: triangle(),
            triangles: vec![[0, 1, 2]],
            velocity: [0.0; 3],
            angular_velocity: [0.0; 3],
            pivot: [0.0; 3],
            animation: Some(animation),
        }
    }

    /// A quarter turn about z between t = 1 and t = 3, linear: at t = 2
    /// the vertex (1, 0, 0) has turned by 45 degrees and moved by half the
    /// translation (2, 0, 0).
    #[test]
    fn a_path_collider_is_drawn_at_its_pose_at_the_time() {
        let c = mesh(MeshAnimation::Path {
            keys: vec![
                ViewKey {
                    t: 1.0,
                    translation: [0.0; 3],
                    rotation: [0.0; 3],
                },
                ViewKey {
                    t: 3.0,
                    translation: [2.0, 0.0, 0.0],
                    rotation: [0.0, 0.0, std::f64::consts::FRAC_PI_2],
                },
            ],
            smooth: false,
        });
        let s = 0.5f64.sqrt();
        let p = c.mesh_vertices_at(2.0)[0];
        for (got, want) in p.iter().zip([1.0 + s, s, 0.0]) {
            assert!((got - want).abs() < 1e-12, "{p:?}");
        }
        assert_eq!(c.mesh_vertices_at(0.0), triangle()); // held before the first key
    }

    /// Frames 0.1 s apart, the second moved by (0, 0, 1): a quarter of the
    /// way at t = 0.025, held after the last frame.
    #[test]
    fn a_sequence_collider_interpolates_its_poses() {
        let lifted: Vec<[f64; 3]> = triangle()
            .iter()
            .map(|p| [p[0], p[1], p[2] + 1.0])
            .collect();
        let c = mesh(MeshAnimation::Sequence {
            frame_interval: 0.1,
            frames: vec![lifted.clone()],
        });
        let v = c.mesh_vertices_at(0.025);
        assert!((v[1][2] - 0.25).abs() < 1e-12, "{v:?}");
        assert_eq!(c.mesh_vertices_at(5.0), lifted);
    }
}
