//! Animated mesh colliders (docs/CONTACT.md, "Moving and animated
//! colliders") against the physics: a particle on a slanted body moving at
//! constant velocity, along a keyframed path or through a sequence of
//! poses, sticks within the static cone (tan(slope) < mu_s) and slips
//! outside it; the cloth of scenes/cloth-on-moving-body.toml never enters
//! the slab, checked at every step by hookean-testkit's ray-parity inside
//! test on the slab posed independently of the contact code; bad sequences
//! and paths are refused naming the file or key.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use hookean::massspring::{
    Collider, Friction, Interpolation, Keyframe, KeyframedPath, MassSpringModel, MeshCollider,
    ModelOptions, State, TriMesh,
};
use hookean::prelude::*;
use hookean::scene::Scene;
use hookean_testkit::intersect::{box_triangles, inside_closed_mesh};

/// The body's constant velocity (m/s).
const V: [f64; 3] = [0.3, -0.2, 0.1];
/// The slope of the body's top face (rad): tan 20 deg = 0.364.
const SLOPE: f64 = 20.0 * std::f64::consts::PI / 180.0;
const THICKNESS: f64 = 0.01;

/// `p` turned by `SLOPE` about the x axis.
fn tilt(p: [f64; 3]) -> [f64; 3] {
    let (s, c) = SLOPE.sin_cos();
    [p[0], p[1] * c - p[2] * s, p[1] * s + p[2] * c]
}

/// A box whose top face (at z = 0.5 before the tilt) slopes by `SLOPE`,
/// shifted by `shift`.
fn slanted_box(shift: [f64; 3]) -> TriMesh {
    let (v, t) = box_triangles([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]);
    let v = v
        .into_iter()
        .map(|p| {
            let q = tilt(p);
            [q[0] + shift[0], q[1] + shift[1], q[2] + shift[2]]
        })
        .collect();
    TriMesh::new(v, t).unwrap()
}

/// How the slanted body moves at `V`.
enum Motion {
    Path,
    Sequence,
}

/// One particle of 0.01 kg resting on the moving slanted face with
/// friction `mu_s`, moving with the body at the start; returns its
/// position relative to where a point of the body that started there is
/// after 1 s (`x(1) - x(0) - V`).
fn ride(motion: Motion, mu_s: f64) -> ([f64; 3], usize) {
    let duration = 10.0;
    let mesh = match motion {
        Motion::Path => {
            let key = |t: f64| Keyframe {
                t,
                translation: V.map(|v| v * t),
                rotation: [0.0; 3],
            };
            let path = KeyframedPath::new(
                vec![key(0.0), key(duration)],
                Interpolation::Linear,
                [0.0; 3],
            )
            .unwrap();
            MeshCollider::new(slanted_box([0.0; 3]), THICKNESS)
                .unwrap()
                .with_path(path)
        }
        Motion::Sequence => MeshCollider::sequence(
            vec![slanted_box([0.0; 3]), slanted_box(V.map(|v| v * duration))],
            duration,
            THICKNESS,
        )
        .unwrap(),
    };
    let mut model = MassSpringModel::new(vec![0.01], vec![], ModelOptions::default()).unwrap();
    model.add_collider(Collider::mesh(mesh).with_friction(Friction::new(mu_s, mu_s).unwrap()));
    // On the face's middle at the thickness along its normal.
    let x0 = tilt([0.1, 0.05, 0.5 + THICKNESS]).to_vec();
    let state = State {
        x: x0.clone(),
        v: V.to_vec(),
    };
    let mut o = SimulationOptions {
        blow_up_factor: f64::INFINITY,
        ..SimulationOptions::default()
    };
    o.solver.h = 0.01;
    o.solver.newton.rtol = 1e-12;
    o.solver.newton.atol = 1e-14;
    o.solver.newton.linear_rtol = 1e-12;
    let mut sim = Simulation::new(model, state, o).unwrap();
    sim.run_until(1.0).unwrap();
    let x = sim.x();
    let sticking = sim.model().contact_stats().sticking;
    ([0, 1, 2].map(|k| x[k] - x0[k] - V[k]), sticking)
}

fn norm(a: [f64; 3]) -> f64 {
    a.iter().map(|c| c * c).sum::<f64>().sqrt()
}

#[test]
fn a_particle_on_a_body_moving_at_constant_velocity_rides_without_slipping() {
    for motion in [Motion::Path, Motion::Sequence] {
        let name = match motion {
            Motion::Path => "path",
            Motion::Sequence => "sequence",
        };
        // tan 20 deg = 0.364 < mu_s = 0.5: it moves with the body.
        let (drift, sticking) = ride(motion, 0.5);
        assert!(
            norm(drift) < 1e-9,
            "{name}: drifted {drift:?} from the body"
        );
        assert_eq!(sticking, 1, "{name}");
    }
    // tan 20 deg > mu_s = 0.2: it slides down the face, at the Coulomb
    // acceleration g (sin - mu cos) relative to the body (0.155 m/s^2: 7.7
    // cm in 1 s, less the first step's start).
    let (drift, sticking) = ride(Motion::Path, 0.2);
    let exact = 0.5 * 9.81 * (SLOPE.sin() - 0.2 * SLOPE.cos());
    assert_eq!(sticking, 0);
    assert!(
        (norm(drift) - exact).abs() < 0.05 * exact,
        "slid {} m, Coulomb {exact} m",
        norm(drift)
    );
    let downhill = tilt([0.0, -1.0, 0.0]);
    let along: f64 = (0..3).map(|k| drift[k] * downhill[k]).sum();
    assert!(along > 0.99 * norm(drift), "{drift:?} is not downhill");
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(path)
}

/// The slab of scenes/cloth-on-moving-body.toml at time `t`, posed here
/// from the scene's numbers (smooth keys from 0.6 s to 1.8 s: 0.4 m along
/// x, a quarter turn about z through the pivot (0, 0, 0.45)).
fn slab_at(t: f64, rest: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let u = ((t - 0.6) / 1.2).clamp(0.0, 1.0);
    let s = u * u * (3.0 - 2.0 * u);
    let (sin, cos) = (s * std::f64::consts::FRAC_PI_2).sin_cos();
    let c = [0.4 * s, 0.0, 0.45];
    rest.iter()
        .map(|p| {
            let (x, y, z) = (p[0], p[1], p[2] - 0.45);
            [c[0] + cos * x - sin * y, c[1] + sin * x + cos * y, c[2] + z]
        })
        .collect()
}

#[test]
fn cloth_on_moving_body_never_enters_the_slab_and_is_carried() {
    let scene = Scene::from_file(repo("scenes/cloth-on-moving-body.toml"), &[]).unwrap();
    let obj = hookean::massspring::read_obj_file(repo("data/platform.obj")).unwrap();
    let mut sim = scene.build().unwrap();
    let (mut states, mut inside) = (0, 0);
    let mut check = |sim: &Simulation| {
        let slab = slab_at(sim.t(), &obj.positions);
        states += 1;
        inside += sim
            .x()
            .chunks_exact(3)
            .filter(|p| inside_closed_mesh(&[p[0], p[1], p[2]], &slab, &obj.triangles))
            .count();
    };
    check(&sim);
    sim.run_until_with(scene.duration, |s, _| {
        check(s);
        ControlFlow::Continue(())
    })
    .unwrap();
    assert!(states > 400, "{states} states");
    assert_eq!(
        inside, 0,
        "cloth vertices inside the slab over {states} states"
    );
    let stats = sim.stats();
    assert_eq!(stats.num_rejected_steps(), 0);
    assert!(
        stats.num_nonlin_solv_iters as f64 <= 3.0 * stats.num_steps as f64,
        "{stats:?}"
    );
    // Carried: the particles over the slab's top moved with it, 0.4 m along
    // x, within 2 cm (the cloth's centre is over the slab's centre at the
    // start).
    let x = sim.x();
    let n = x.len() / 3;
    let cx: f64 = x.chunks_exact(3).map(|p| p[0]).sum::<f64>() / n as f64;
    assert!((cx - 0.4).abs() < 0.02, "the cloth's centre is at x = {cx}");
}

/// A scratch folder with a scene `text` and the OBJ files `files`.
fn scratch(name: &str, files: &[(&str, String)], text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hookean-anim-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (f, body) in files {
        std::fs::write(dir.join(f), body).unwrap();
    }
    std::fs::write(dir.join("s.toml"), text).unwrap();
    dir
}

fn box_obj(lo: [f64; 3], hi: [f64; 3], extra_vertex: bool) -> String {
    let (v, t) = box_triangles(lo, hi);
    let mut s = String::new();
    for p in &v {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    if extra_vertex {
        s += "v 9 9 9\n";
    }
    for f in &t {
        s += &format!("f {} {} {}\n", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s
}

fn build_error(dir: &Path) -> String {
    match Scene::from_file(dir.join("s.toml"), &[]) {
        Ok(scene) => scene
            .build()
            .err()
            .expect("the scene must be refused")
            .to_string(),
        Err(e) => e.to_string(),
    }
}

const SEQ: &str = "[cloth]\nn = 4\norigin = [-0.5, -0.5, 1.0]\n[[collider]]\nkind = \"mesh\"\npath = \"f0.obj\"\n";

#[test]
fn bad_sequences_and_paths_are_refused_naming_the_file_or_key() {
    let a = box_obj([-0.2; 3], [0.2; 3], false);
    let b = box_obj([-0.1, -0.2, -0.2], [0.3, 0.2, 0.2], false);
    // Differing vertex counts.
    let dir = scratch(
        "count",
        &[
            ("f0.obj", a.clone()),
            ("f1.obj", box_obj([-0.2; 3], [0.2; 3], true)),
        ],
        &format!("{SEQ}frames = [\"f1.obj\"]\n"),
    );
    let e = build_error(&dir);
    assert!(e.contains("f1.obj") && e.contains("vertices"), "{e}");
    // A missing frame.
    let dir = scratch(
        "missing",
        &[("f0.obj", a.clone()), ("f1.obj", b.clone())],
        &format!("{SEQ}frames = [\"f1.obj\", \"f2.obj\"]\n"),
    );
    let e = build_error(&dir);
    assert!(e.contains("f2.obj"), "{e}");
    // A NaN in a path.
    let dir = scratch(
        "nan",
        &[("f0.obj", a.clone())],
        &format!("{SEQ}keys = [{{ t = 0.0 }}, {{ t = 1.0, translation = [nan, 0.0, 0.0] }}]\n"),
    );
    let e = build_error(&dir);
    assert!(e.contains("keys.translation"), "{e}");
    // Two motions at once.
    let dir = scratch(
        "two",
        &[("f0.obj", a.clone()), ("f1.obj", b.clone())],
        &format!("{SEQ}frames = [\"f1.obj\"]\nvelocity = [1.0, 0.0, 0.0]\n"),
    );
    let e = build_error(&dir);
    assert!(e.contains("one motion"), "{e}");
    // A good sequence builds.
    let dir = scratch(
        "good",
        &[("f0.obj", a), ("f1.obj", b)],
        &format!("{SEQ}frames = [\"f1.obj\"]\nframe_interval = 0.5\n"),
    );
    Scene::from_file(dir.join("s.toml"), &[])
        .unwrap()
        .build()
        .unwrap();
    for name in ["count", "missing", "nan", "two", "good"] {
        let _ = std::fs::remove_dir_all(
            std::env::temp_dir().join(format!("hookean-anim-{}-{name}", std::process::id())),
        );
    }
}
