//! Pin groups as handles (hookean-massspring's `handles.rs`): analytic
//! checks through the facade's simulation.

use hookean::massspring::{
    Interpolation, Keyframe, KeyframedPath, MassSpringModel, ModelOptions, PinGroup, State,
};
use hookean::prelude::*;

/// A soft pin of stiffness `w k` holding a particle of mass `m` under
/// gravity `g` comes to rest `m g / (w k)` below its target (Hooke's law
/// at equilibrium: `w k d = m g`).
#[test]
fn a_soft_pin_sags_by_m_g_over_k() {
    let (m, g, k, w) = (0.2, 9.81, 150.0, 0.5);
    let options = ModelOptions {
        gravity: [0.0, 0.0, -g],
        // Air friction damps the bounce; it does not act at rest.
        air_friction: 0.5,
        ..Default::default()
    };
    let mut model = MassSpringModel::new(vec![m], vec![], options).unwrap();
    let x0 = vec![0.3, -0.1, 1.0];
    model
        .add_pin_group(
            PinGroup {
                particles: vec![0],
                weight: w,
                stiffness: k,
                path: None,
                release: None,
            },
            &x0,
        )
        .unwrap();
    let state = State {
        x: x0.clone(),
        v: vec![0.0; 3],
    };
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    sim.run_until(30.0).unwrap();
    let sag = x0[2] - sim.x()[2];
    let expected = m * g / (w * k);
    assert!(
        (sag - expected).abs() <= 0.01 * expected,
        "sag {sag} m, m g / k = {expected} m"
    );
    assert!((sim.x()[0] - x0[0]).abs() < 1e-12 && (sim.x()[1] - x0[1]).abs() < 1e-12);
}

/// A stiff soft pin (`h^2 w k / m` = 500 at h = 0.01 s) with inexact
/// simplified Newton: eq. 50's matrix carries the pin's exact `-w k I`, so
/// each step converges in one or two iterations and the particle rests
/// `m g / (w k)` below its target. Without the pin in that matrix the
/// iteration is a fixed point on the pin force, multiplying its error by
/// about 500 each time: every step fails.
#[test]
fn a_stiff_soft_pin_with_inexact_simplified_newton() {
    use hookean::nonlinear::{ForcingTerm, NewtonMethod};
    let (m, g, k, w) = (0.01, 9.81, 1.0e5, 0.5);
    let options = ModelOptions {
        gravity: [0.0, 0.0, -g],
        air_friction: 0.5,
        ..Default::default()
    };
    let mut model = MassSpringModel::new(vec![m], vec![], options).unwrap();
    let x0 = vec![0.3, -0.1, 1.0];
    let group = PinGroup {
        particles: vec![0],
        weight: w,
        stiffness: k,
        path: None,
        release: None,
    };
    model.add_pin_group(group, &x0).unwrap();
    let state = State {
        x: x0.clone(),
        v: vec![0.0; 3],
    };
    let mut o = SimulationOptions::default();
    o.solver.newton.method = NewtonMethod::InexactSimplified(ForcingTerm::Constant(0.01));
    assert!((o.solver.h * o.solver.h * w * k / m - 500.0).abs() < 1e-9);
    let mut sim = Simulation::new(model, state, o).unwrap();
    sim.run_until(2.0).unwrap();
    let stats = sim.stats();
    assert_eq!(stats.num_rejected_steps(), 0, "{stats:?}");
    assert!(
        stats.num_nonlin_solv_iters <= 2 * stats.num_steps,
        "{stats:?}"
    );
    let sag = x0[2] - sim.x()[2];
    let expected = m * g / (w * k);
    assert!(
        (sag - expected).abs() <= 0.01 * expected,
        "sag {sag} m, m g / k = {expected} m"
    );
}

fn key(t: f64, translation: [f64; 3], rotation: [f64; 3]) -> Keyframe {
    Keyframe {
        t,
        translation,
        rotation,
    }
}

/// Hard pins (weight 1) lie exactly on their path after every step, and
/// fall once released.
#[test]
fn hard_pins_follow_their_path_exactly_then_let_go() {
    let (mut model, state) = cloth(&ClothParams {
        nu: 8,
        nv: 8,
        pins: ClothPins::None,
        ..Default::default()
    })
    .unwrap();
    // The edge y = 0 (the first row of the grid).
    let edge: Vec<usize> = (0..model.n_particles())
        .filter(|&p| state.x[3 * p + 1] == 0.0)
        .collect();
    assert_eq!(edge.len(), 8);
    let path = KeyframedPath::new(
        vec![
            key(0.0, [0.0; 3], [0.0; 3]),
            key(0.3, [0.2, 0.0, 0.1], [0.0, 0.0, 0.4]),
            key(0.5, [0.3, -0.1, 0.0], [0.2, 0.0, 0.3]),
        ],
        Interpolation::Smooth,
        [0.5, 0.0, 0.0],
    )
    .unwrap();
    let release = 0.6;
    model
        .add_pin_group(
            PinGroup {
                particles: edge.clone(),
                weight: 1.0,
                stiffness: 0.0,
                path: Some(path.clone()),
                release: Some(release),
            },
            &state.x,
        )
        .unwrap();
    let rest: Vec<[f64; 3]> = edge
        .iter()
        .map(|&p| [state.x[3 * p], state.x[3 * p + 1], state.x[3 * p + 2]])
        .collect();
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    let mut steps = 0;
    while sim.t() < release - 1e-9 {
        // The model sets the pins at the step's end t + h (the integrator
        // counts its time as t_0 + n h, which may differ in the last bit).
        let t_start = sim.t();
        let r = sim.step().unwrap();
        steps += 1;
        let t = t_start + r.h;
        assert!((t - sim.t()).abs() <= 1e-15);
        for (k, &p) in edge.iter().enumerate() {
            let y = path.point_at(t, rest[k]);
            assert_eq!(&sim.x()[3 * p..3 * p + 3], &y[..], "t = {t}, particle {p}");
        }
    }
    assert!(steps >= 50);
    // The energy budget is on (the default) and counts the moving edge's
    // work (docs/CONTACT.md, "Energy"): no step above failed with EnergyGain.
    assert!(sim.pin_work().abs() > 0.0);
    // Released: the edge falls below the path's last pose.
    let held = path.point_at(release, rest[0]);
    sim.run_until(release + 0.3).unwrap();
    assert!(sim.x()[3 * edge[0] + 2] < held[2] - 0.1);
}

/// Bad groups are refused, naming the value.
#[test]
fn bad_groups_are_refused() {
    let (mut model, state) = cloth(&ClothParams {
        nu: 4,
        nv: 4,
        ..Default::default()
    })
    .unwrap();
    let group = |particles: Vec<usize>, weight: f64, stiffness: f64| PinGroup {
        particles,
        weight,
        stiffness,
        path: None,
        release: None,
    };
    let e = model
        .add_pin_group(group(vec![16], 1.0, 0.0), &state.x)
        .unwrap_err();
    assert!(e.to_string().contains("16"), "{e}");
    let e = model
        .add_pin_group(group(vec![0], 1.5, 0.0), &state.x)
        .unwrap_err();
    assert!(e.to_string().contains("weight"), "{e}");
    let e = model
        .add_pin_group(group(vec![0], 0.5, -1.0), &state.x)
        .unwrap_err();
    assert!(e.to_string().contains("stiffness"), "{e}");
}

/// A `[[pin]]` scene: the box picks the cloth's edge y = 0, the smooth
/// translation-only path moves it by `d s(u)` with `s(u) = 3u^2 - 2u^3`
/// (computed here by hand), and the soft group of the far corner holds it
/// near its start against gravity.
#[test]
fn a_pin_scene_moves_its_box_along_the_smooth_path() {
    let text = "duration = 0.4\n[cloth]\nn = 6\npins = \"none\"\n\
                [[pin]]\nbox = [[-0.01, -0.01, -1.0], [1.01, 0.01, 1.0]]\ninterpolation = \"smooth\"\n\
                keys = [{ t = 0.0 }, { t = 0.4, translation = [0.0, 0.3, 0.1] }]\n\
                [[pin]]\nvertices = [35]\nweight = 0.5\nstiffness = 400\n";
    let scene = hookean::scene::Scene::from_toml_str("s.toml", text).unwrap();
    let mut sim = scene.build().unwrap();
    let x0 = sim.x().to_vec();
    let edge: Vec<usize> = (0..36).filter(|&p| x0[3 * p + 1] == 0.0).collect();
    assert_eq!(edge.len(), 6);
    while sim.t() < 0.4 - 1e-9 {
        let t0 = sim.t();
        let r = sim.step().unwrap();
        let u = (t0 + r.h) / 0.4;
        let s = u * u * (3.0 - 2.0 * u);
        for &p in &edge {
            let expected = [x0[3 * p], x0[3 * p + 1] + 0.3 * s, x0[3 * p + 2] + 0.1 * s];
            for c in 0..3 {
                assert!(
                    (sim.x()[3 * p + c] - expected[c]).abs() < 1e-14,
                    "t = {}",
                    t0 + r.h
                );
            }
        }
    }
    // The soft pin holds the far corner: it drops far less than without it.
    let corner_drop = x0[3 * 35 + 2] - sim.x()[3 * 35 + 2];
    let free_text = text.replace(
        "vertices = [35]\nweight = 0.5",
        "vertices = [35]\nweight = 0.0",
    );
    let mut free = hookean::scene::Scene::from_toml_str("s.toml", &free_text)
        .unwrap()
        .build()
        .unwrap();
    free.run_until(0.4).unwrap();
    let free_drop = x0[3 * 35 + 2] - free.x()[3 * 35 + 2];
    assert!(
        corner_drop < 0.5 * free_drop,
        "held {corner_drop} m, free {free_drop} m"
    );
}
