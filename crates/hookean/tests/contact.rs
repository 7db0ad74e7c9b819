//! Contact against the physics it stands for (docs/CONTACT.md): Coulomb
//! friction on an inclined plane (rest within the cone, the acceleration
//! `g (sin theta - mu_k cos theta)` outside it), a particle resting on a
//! mesh at its thickness, the shipped contact scenes checked frame by frame
//! with independent routines (hookean-testkit's triangle-triangle test and
//! ray-parity inside test), and their determinism.
//!
//! The shipped 64 x 64 scenes run as they ship (about 17 s together in the
//! workspace's dev profile, which is optimised), next to the same scenes at
//! 24 x 24 with a thinner cloth.

use std::ops::ControlFlow;
use std::path::Path;

use hookean::massspring::{
    Collider, Friction, MassSpringModel, MeshCollider, ModelOptions, RigidMotion, State, TriMesh,
};
use hookean::prelude::*;
use hookean::scene::Scene;
use hookean_testkit::intersect::{box_triangles, inside_closed_mesh, self_intersections};

const G: f64 = 9.81;

/// Tight Newton and PCG: the analytic checks compare with the exact
/// solution of the step.
fn tight() -> SimulationOptions {
    let mut o = SimulationOptions::default();
    o.solver.h = 0.01;
    o.solver.newton.rtol = 1e-12;
    o.solver.newton.atol = 1e-14;
    o.solver.newton.linear_rtol = 1e-12;
    o.solver.newton.method = hookean::nonlinear::NewtonMethod::Exact;
    o
}

/// One particle of 0.1 kg resting on the plane through the origin inclined
/// by `theta` about the y axis (it descends towards -x), with friction.
fn particle_on_slope(theta: f64, mu_s: f64, mu_k: f64) -> Simulation {
    let mut model = MassSpringModel::new(vec![0.1], vec![], ModelOptions::default()).unwrap();
    let normal = [-theta.sin(), 0.0, theta.cos()];
    model.add_collider(
        Collider::plane([0.0; 3], normal, 1e-3)
            .unwrap()
            .with_friction(Friction::new(mu_s, mu_k).unwrap()),
    );
    let state = State {
        x: vec![0.0; 3],
        v: vec![0.0; 3],
    };
    Simulation::new(model, state, tight()).unwrap()
}

/// Velocity along the slope's downhill direction `(-cos, 0, -sin)`.
fn downhill(theta: f64, v: &[f64]) -> f64 {
    -theta.cos() * v[0] - theta.sin() * v[2]
}

#[test]
fn a_particle_on_a_slope_below_the_friction_angle_stays_at_rest() {
    // tan 20 deg = 0.364 < mu_s = 0.5 (and < mu_k = 0.4: kinetic friction
    // alone would stop it too; the static cone must hold it from the start).
    let theta = 20f64.to_radians();
    let mut sim = particle_on_slope(theta, 0.5, 0.4);
    sim.run_until(1.0).unwrap();
    assert!(sim.x().iter().all(|x| x.abs() < 1e-12), "{:?}", sim.x());
    assert!(sim.v().iter().all(|v| v.abs() < 1e-12), "{:?}", sim.v());
    assert_eq!(sim.model().contact_stats().sticking, 1);
}

#[test]
fn a_particle_on_a_slope_above_the_friction_angle_slides_at_the_coulomb_acceleration() {
    // tan 30 deg = 0.577 > mu_s = 0.5: it slides, decelerated by mu_k = 0.3.
    let theta = 30f64.to_radians();
    let mu_k = 0.3;
    let exact = G * (theta.sin() - mu_k * theta.cos());
    let mut sim = particle_on_slope(theta, 0.5, mu_k);
    let mut half = None;
    sim.run_until_with(1.0, |s, _| {
        if (s.t() - 0.5).abs() < 1e-9 {
            half = Some(downhill(theta, s.v()));
        }
        ControlFlow::Continue(())
    })
    .unwrap();
    let v1 = downhill(theta, sim.v());
    // Over the whole second (the first step starts from rest, before a step
    // size is known: within 2%) and over the last half second (exact).
    assert!((v1 / 1.0 - exact).abs() < 0.02 * exact, "{v1} vs {exact}");
    let a = (v1 - half.unwrap()) / 0.5;
    assert!((a - exact).abs() < 1e-6 * exact, "{a} vs {exact}");
    // It stays on the plane: no motion along the normal.
    let n = [-theta.sin(), 0.0, theta.cos()];
    let off: f64 = (0..3).map(|k| n[k] * sim.x()[k]).sum();
    assert!(off.abs() < 1e-12, "{off}");
    assert_eq!(sim.model().contact_stats().sliding, 1);
}

/// The closed box `[lo, hi]` as 12 outward triangles.
fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> TriMesh {
    let (v, t) = box_triangles(lo, hi);
    TriMesh::new(v, t).unwrap()
}

/// Drops one particle from `z0` onto `collider`; returns the simulation
/// after `t_end`.
fn drop_particle(collider: Collider, x0: [f64; 3], t_end: f64) -> Simulation {
    let mut model = MassSpringModel::new(vec![0.01], vec![], ModelOptions::default()).unwrap();
    model.add_collider(collider);
    let state = State {
        x: x0.to_vec(),
        v: vec![0.0; 3],
    };
    // A moving platform puts energy in: no blow-up check on one particle
    // (whose energy scale has no extent).
    let options = SimulationOptions {
        blow_up_factor: f64::INFINITY,
        ..tight()
    };
    let mut sim = Simulation::new(model, state, options).unwrap();
    sim.run_until(t_end).unwrap();
    sim
}

#[test]
fn a_particle_dropped_on_a_mesh_rests_at_its_thickness() {
    let th = 0.01;
    // Onto the top face of a box (z = 0.5).
    let table = MeshCollider::new(box_mesh([-0.5, -0.5, 0.0], [0.5, 0.5, 0.5]), th).unwrap();
    let sim = drop_particle(Collider::mesh(table), [0.1, -0.2, 0.8], 1.0);
    let gap = sim.x()[2] - 0.5;
    assert!(
        (gap - th).abs() < 0.01 * th,
        "rests {gap} above, thickness {th}"
    );
    assert!(sim.v()[2].abs() < 1e-9);
    // Onto a box turned 30 degrees about x (its top face slanted), with
    // friction enough to hold the particle (tan 30 deg = 0.58 < 0.8): it
    // rests on the slanted face at the thickness.
    let turned = MeshCollider::new(box_mesh([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]), th)
        .unwrap()
        .with_motion(RigidMotion::default())
        .unwrap();
    let a = 30f64.to_radians();
    let rotate = |p: [f64; 3]| {
        [
            p[0],
            p[1] * a.cos() - p[2] * a.sin(),
            p[1] * a.sin() + p[2] * a.cos(),
        ]
    };
    let verts: Vec<[f64; 3]> = turned
        .mesh()
        .vertices()
        .iter()
        .map(|v| rotate([v.x, v.y, v.z]))
        .collect();
    let slanted = MeshCollider::new(
        TriMesh::new(verts, turned.mesh().triangles().to_vec()).unwrap(),
        th,
    )
    .unwrap();
    let sim = drop_particle(
        Collider::mesh(slanted).with_friction(Friction::new(0.8, 0.8).unwrap()),
        [0.1, 0.0, 1.0],
        1.5,
    );
    let n = rotate([0.0, 0.0, 1.0]);
    let p = sim.x();
    let dist = n[0] * p[0] + n[1] * p[1] + n[2] * p[2] - 0.5;
    assert!(
        (dist - th).abs() < 0.01 * th,
        "rests {dist} from the face, thickness {th}"
    );
    assert!(sim.v().iter().all(|v| v.abs() < 1e-9), "{:?}", sim.v());
}

#[test]
fn a_particle_rides_a_rising_platform_at_its_thickness() {
    let th = 0.005;
    let platform = MeshCollider::new(box_mesh([-1.0, -1.0, -0.1], [1.0, 1.0, 0.0]), th)
        .unwrap()
        .with_motion(RigidMotion {
            velocity: [0.0, 0.0, 0.2],
            ..RigidMotion::default()
        })
        .unwrap();
    let sim = drop_particle(Collider::mesh(platform), [0.0, 0.0, 0.1], 1.0);
    // The platform's top is at 0.2 m at t = 1 s; the particle rides on it.
    let gap = sim.x()[2] - 0.2;
    assert!((gap - th).abs() < 0.01 * th, "{gap}");
    assert!((sim.v()[2] - 0.2).abs() < 1e-6, "{:?}", sim.v());
}

fn scene(name: &str, overrides: &[&str]) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name);
    Scene::from_file(&path, overrides).unwrap()
}

/// Runs `scene` on `threads` threads, calling `check(sim)` after every step;
/// returns the final positions and the integrator's statistics.
fn run_checked(
    scene: &Scene,
    threads: usize,
    mut check: impl FnMut(&Simulation) + Send,
) -> (Vec<f64>, hookean::ode::Stats) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut sim = scene.build().unwrap();
        check(&sim);
        sim.run_until_with(scene.duration, |s, _| {
            check(s);
            ControlFlow::Continue(())
        })
        .unwrap();
        (sim.x().to_vec(), sim.stats())
    })
}

/// The table of scenes/cloth-table.toml, read independently of the
/// simulation (vertices, triangles of the OBJ file).
fn table() -> (Vec<[f64; 3]>, Vec<[usize; 3]>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/table.obj");
    let m = hookean::massspring::read_obj_file(path).unwrap();
    (m.positions, m.triangles)
}

fn cloth_table(overrides: &[&str], rests: bool) {
    let s = scene("cloth-table.toml", overrides);
    let (tv, tt) = table();
    let mut inside = 0;
    let mut steps = 0;
    let (x1, stats) = run_checked(&s, 2, |sim| {
        steps += 1;
        inside += sim
            .x()
            .chunks_exact(3)
            .filter(|p| inside_closed_mesh(&[p[0], p[1], p[2]], &tv, &tt))
            .count();
    });
    assert_eq!(inside, 0, "particles inside the table over {steps} states");
    assert_eq!(stats.num_rejected_steps(), 0);
    assert!(
        stats.num_nonlin_solv_iters as f64 <= 3.0 * stats.num_steps as f64,
        "{stats:?}"
    );
    // Over the middle of the top, the cloth is above the top (and below
    // 6 cm over it); the 64 x 64 cloth lies on it: a good part of its
    // particles there rest at the top plus the thickness (0.5 + 0.005 m),
    // the others on wrinkles. (The 24 x 24 one, with bend springs four
    // times as long, arches 2 cm over the top, held by the edges.)
    let z: Vec<f64> = x1
        .chunks_exact(3)
        .filter(|p| p[0].abs() < 0.25 && p[1].abs() < 0.25)
        .map(|p| p[2])
        .collect();
    assert!(z.iter().all(|&z| z > 0.5 && z < 0.56), "{z:?}");
    if rests {
        let resting = z.iter().filter(|&&z| (z - 0.505).abs() < 1e-3).count();
        assert!(
            4 * resting >= z.len(),
            "{resting} of {} at the thickness",
            z.len()
        );
    }
    // Same thread count, same bits.
    let (again, _) = run_checked(&s, 2, |_| {});
    assert!(x1 == again, "two runs on 2 threads differ");
}

#[test]
fn cloth_table_no_particle_inside_the_table_and_deterministic() {
    cloth_table(&["cloth.n=24"], false);
}

#[test]
fn cloth_table_64_no_particle_inside_the_table_and_deterministic() {
    cloth_table(&[], true);
}

fn cloth_fold(overrides: &[&str]) {
    let s = scene("cloth-fold.toml", overrides);
    let mut faces = Vec::new();
    let mut crossings = Vec::new();
    let mut states = 0;
    let mut pairs = 0;
    let (x1, stats) = run_checked(&s, 2, |sim| {
        if faces.is_empty() {
            faces = sim.model().faces().to_vec();
        }
        states += 1;
        pairs += sim.model().contact_stats().proximity_pairs;
        let bad = self_intersections(sim.x(), &faces);
        if !bad.is_empty() {
            crossings.push((sim.t(), bad.len()));
        }
    });
    assert!(
        crossings.is_empty(),
        "non-adjacent triangles intersect at (t, pairs) {crossings:?} of {states} states"
    );
    // The cloth did fold onto itself: layers came within the thickness.
    assert!(pairs > 100, "{pairs} proximity pairs in all");
    assert_eq!(stats.num_rejected_steps(), 0);
    assert!(
        stats.num_nonlin_solv_iters as f64 <= 3.0 * stats.num_steps as f64,
        "{stats:?}"
    );
    let (again, _) = run_checked(&s, 2, |_| {});
    assert!(x1 == again, "two runs on 2 threads differ");
}

#[test]
fn cloth_fold_has_no_self_intersection_in_any_step_and_is_deterministic() {
    // 24 x 24 with the grid spacing of the 64 x 64 scene's thickness ratio.
    cloth_fold(&["cloth.n=24", "contact.self_thickness=0.01", "duration=1.5"]);
}

#[test]
fn cloth_fold_64_has_no_self_intersection_in_any_step_and_is_deterministic() {
    cloth_fold(&[]);
}

/// Cloth self-collision's carried state (the candidate list, the shape
/// of the tree) is in the checkpoint: a folding cloth saved mid-fold,
/// while layers are within the thickness, and restored into a simulation
/// built anew from the scene continues bit for bit. Restored without it (a
/// fresh list and tree, as a model built at the checkpoint's time has),
/// the continuation differs.
#[test]
fn cloth_fold_resumed_mid_fold_continues_bit_for_bit() {
    let s = scene(
        "cloth-fold.toml",
        &["cloth.n=24", "contact.self_thickness=0.01", "duration=1.5"],
    );
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    pool.install(|| {
        let mut a = s.build().unwrap();
        // The checkpoint at the first step whose start has layers within
        // the thickness (a candidate list in use).
        let first = a
            .run_until_with(s.duration, |sim, _| {
                if sim.model().contact_stats().proximity_pairs > 0 {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })
            .unwrap();
        assert!(first.stopped && first.t < 1.2, "no fold by {}", first.t);
        let mut record = hookean::StateRecord::default();
        a.save_state(&mut record).unwrap();
        let mut b = s.build().unwrap();
        b.restore_state(&record).unwrap();
        // The same record, the self-collision part as a new model has it.
        let fresh = s.build().unwrap();
        let mut carried = record.get("model.carried").unwrap()[..2].to_vec();
        carried.extend_from_slice(&fresh.model().carried_state().unwrap()[2..]);
        let mut without = record.clone();
        without.put("model.carried", &carried);
        let mut c = s.build().unwrap();
        c.restore_state(&without).unwrap();
        for sim in [&mut a, &mut b, &mut c] {
            sim.run_until(s.duration).unwrap();
        }
        assert!(a.x() == b.x() && a.v() == b.v(), "resumed differs");
        assert!(
            a.x() != c.x(),
            "the self-collision state made no difference"
        );
    });
}

#[test]
fn cloth_slope_rests_on_its_slope() {
    let s = scene("cloth-slope.toml", &[]);
    let (x1, stats) = run_checked(&s, 2, |_| {});
    assert_eq!(stats.num_rejected_steps(), 0);
    // After landing (by 0.5 s) the cloth does not move down the slope: its
    // centroid moves less than 1 mm over the last 1.5 s.
    let short = scene("cloth-slope.toml", &["duration=0.5"]);
    let (x_half, _) = run_checked(&short, 2, |_| {});
    let centroid = |x: &[f64]| {
        let n = x.len() / 3;
        [0, 1, 2].map(|k| x.iter().skip(k).step_by(3).sum::<f64>() / n as f64)
    };
    let (a, b) = (centroid(&x_half), centroid(&x1));
    let moved = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
    assert!(moved < 1e-3, "moved {moved} m");
}
