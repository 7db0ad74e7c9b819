//! The work of pins driven along a path (issue 37; `pin_work.rs`,
//! docs/CONTACT.md, "Energy"): the energy guard's `W_pins` against the
//! mechanics done by hand, and a gain that driven pins do not explain still
//! caught.
//!
//! The hand values: a particle of mass `m_1` hangs on a spring from a
//! particle of mass `m_0` that a hard pin moves at the constant velocity `u`
//! from `t = 0` to the path's last key `T` (then holds). The pin's force on
//! particle 0 is `R = -f_0` (no acceleration within the path; the pinned
//! particle starts and ends at rest, so its kinetic energy changes by 0), so
//! its work is `u . int -f_0 dt = m_0 g (u . e_z) T + u . int s dt` with `s`
//! the spring's pull on particle 0, and particle 1's momentum balance gives
//! `int s dt = m_1 (v_1(T) - v_1(0)) + m_1 g e_z T`: `W = (m_0 + m_1) g (u .
//! e_z) T + m_1 u . v_1(T)`, whatever the damping. Without damping (and with
//! implicit midpoint, which conserves the energy of a linear spring) it also
//! equals the energy gained, `E(t) - E(0)`, computed here from the state.

use hookean::massspring::{
    Interpolation, Keyframe, KeyframedPath, MassSpringModel, ModelOptions, PinGroup, Spring, State,
};
use hookean::ode::Method;
use hookean::prelude::*;
use hookean::scene::Scene;

const G: f64 = 9.81;
const M0: f64 = 0.05;
const M1: f64 = 0.1;
const K: f64 = 200.0;
const L0: f64 = 0.2;

fn key(t: f64, translation: [f64; 3]) -> Keyframe {
    Keyframe {
        t,
        translation,
        rotation: [0.0; 3],
    }
}

/// Particle 0 at `(0, 0, 1)` on a hard pin (weight 1) or a soft one
/// (weight < 1, stiffness `k_pin`) moved by `d` over `[0, t_move]`
/// (linear), released at `release`; particle 1 at rest on the spring below
/// it at its equilibrium stretch `m_1 g / k`.
fn hanging(
    method: Method,
    damping: f64,
    d: [f64; 3],
    t_move: f64,
    weight: f64,
    release: Option<f64>,
) -> Simulation {
    let options = ModelOptions {
        gravity: [0.0, 0.0, -G],
        ..Default::default()
    };
    let springs = vec![Spring::new(0, 1, L0, K, damping)];
    let mut model = MassSpringModel::new(vec![M0, M1], springs, options).unwrap();
    let l = L0 + M1 * G / K;
    let x = vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0 - l];
    let path = KeyframedPath::new(
        vec![key(0.0, [0.0; 3]), key(t_move, d)],
        Interpolation::Linear,
        [0.0; 3],
    )
    .unwrap();
    model
        .add_pin_group(
            PinGroup {
                particles: vec![0],
                weight,
                stiffness: 5e3,
                path: Some(path),
                release,
            },
            &x,
        )
        .unwrap();
    let mut options = SimulationOptions {
        method,
        ..Default::default()
    };
    options.solver.h = 0.005;
    // Newton to round-off: the hand values hold for the exact step.
    options.solver.newton.rtol = 1e-10;
    options.solver.newton.max_iter = 50;
    let state = State { x, v: vec![0.0; 6] };
    Simulation::new(model, state, options).unwrap()
}

/// `E = K + G + S` of the two particles, by hand (no soft pin energy).
fn energy(x: &[f64], v: &[f64]) -> f64 {
    let kinetic = 0.5 * M0 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        + 0.5 * M1 * (v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
    let l = ((x[3] - x[0]).powi(2) + (x[4] - x[1]).powi(2) + (x[5] - x[2]).powi(2)).sqrt();
    kinetic + G * (M0 * x[2] + M1 * x[5]) + 0.5 * K * (l - L0).powi(2)
}

/// `W = (m_0 + m_1) g u_z T + m_1 u . v_1(T)` (module docs).
fn hand_work(u: [f64; 3], t_move: f64, v1: &[f64]) -> f64 {
    (M0 + M1) * G * u[2] * t_move + M1 * (u[0] * v1[0] + u[1] * v1[1] + u[2] * v1[2])
}

fn run_to(sim: &mut Simulation, t: f64) {
    while sim.t() < t - 1e-9 {
        sim.step().unwrap();
    }
}

#[test]
fn a_pin_lifting_a_hanging_particle_does_the_work_the_particles_gain() {
    // u = 0.1 m/s up for 1 s: W = m g u T (0.147 J) plus m_1 u v_1(T).
    let (u, t_move) = ([0.0, 0.0, 0.1], 1.0);
    let mut sim = hanging(
        Method::ImplicitMidpoint,
        0.0,
        [0.0, 0.0, 0.1],
        t_move,
        1.0,
        None,
    );
    let e0 = energy(sim.x(), sim.v());
    run_to(&mut sim, t_move);
    let w = sim.pin_work();
    let expected = hand_work(u, t_move, &sim.v()[3..6]);
    assert!(
        (w - expected).abs() <= 0.01 * expected,
        "W_pins = {w} J, by hand {expected} J"
    );
    let gained = energy(sim.x(), sim.v()) - e0;
    eprintln!("lift: W_pins {w} J, by hand {expected} J, gained {gained} J");
    assert!(
        (w - gained).abs() <= 0.01 * expected,
        "W_pins = {w} J, energy gained {gained} J"
    );
    // And it is mostly the lift m g u T.
    let lift = (M0 + M1) * G * 0.1 * t_move;
    assert!(
        (gained - lift).abs() <= 0.05 * lift,
        "{gained} J, m g u T = {lift} J"
    );
}

#[test]
fn with_damping_the_pin_work_still_follows_the_momentum_and_exceeds_the_gain() {
    // Implicit Euler and a damped spring dissipate: the energy gained is
    // below the work, which the momentum balance still gives exactly.
    let (u, t_move) = ([0.0, 0.0, 0.1], 1.0);
    let mut sim = hanging(
        Method::ImplicitEuler,
        0.5,
        [0.0, 0.0, 0.1],
        t_move,
        1.0,
        None,
    );
    let e0 = energy(sim.x(), sim.v());
    run_to(&mut sim, t_move);
    let w = sim.pin_work();
    let expected = hand_work(u, t_move, &sim.v()[3..6]);
    assert!(
        (w - expected).abs() <= 0.01 * expected,
        "W_pins = {w} J, by hand {expected} J"
    );
    let gained = energy(sim.x(), sim.v()) - e0;
    eprintln!("damped lift: W_pins {w} J, by hand {expected} J, gained {gained} J");
    assert!(gained < w && gained > 0.9 * w, "gained {gained} J, W {w} J");
}

#[test]
fn a_pin_moved_sideways_and_stopped_did_the_work_of_the_swing() {
    // 0.2 m along x in 0.5 s, then held: the particle swings; the work is
    // done while the pin moves (m_1 u v_1x at the stop) and not after.
    let (u, t_move) = ([0.4, 0.0, 0.0], 0.5);
    let mut sim = hanging(
        Method::ImplicitMidpoint,
        0.0,
        [0.2, 0.0, 0.0],
        t_move,
        1.0,
        None,
    );
    let e0 = energy(sim.x(), sim.v());
    run_to(&mut sim, t_move);
    let w_stop = sim.pin_work();
    let expected = hand_work(u, t_move, &sim.v()[3..6]);
    assert!(expected > 1e-3, "{expected} J: the particle swings");
    assert!(
        (w_stop - expected).abs() <= 0.02 * expected,
        "W_pins = {w_stop} J, by hand {expected} J"
    );
    run_to(&mut sim, 2.0);
    assert_eq!(sim.pin_work(), w_stop, "a pin at rest does no work");
    let gained = energy(sim.x(), sim.v()) - e0;
    eprintln!("sideways: W_pins {w_stop} J, by hand {expected} J, gained {gained} J");
    assert!(
        (w_stop - gained).abs() <= 0.02 * expected,
        "W_pins = {w_stop} J, energy gained {gained} J"
    );
}

#[test]
fn a_released_pin_stops_working_at_its_release() {
    let mut sim = hanging(
        Method::ImplicitEuler,
        0.5,
        [0.0, 0.0, 0.5],
        1.0,
        1.0,
        Some(0.3),
    );
    run_to(&mut sim, 0.3);
    let w = sim.pin_work();
    assert!(w > 0.0);
    run_to(&mut sim, 0.6);
    assert_eq!(sim.pin_work(), w);
    // Both particles fall freely after the release: the run's energy stays
    // within E_0 + W (the budget passed every step: no error above).
}

#[test]
fn a_soft_pin_lifting_a_particle_does_the_work_of_its_target() {
    // The soft pin's spring w k |x_0 - y|^2 / 2 pulls particle 0 towards
    // the moving target: the target's work int w k (y - x_0) . y' dt is
    // u . int s_pin dt = u_z ((m_0 + m_1) g T + m_0 v_0z(T) + m_1 v_1z(T))
    // (both particles' momentum; gravity and the pin the only outer
    // forces). The model holds the target of a step's start over the step:
    // at each start it jumps u h ahead of a particle that follows at u, so
    // each jump stores w k (u h)^2 / 2 more than the continuous pull (the
    // midpoint rule of the jump against implicit Euler's momentum at the
    // step's end): W = u_z (...) + w k u^2 h T / 2 (0.0625 J here, -> 0
    // with h).
    let (u, t_move) = (0.1, 1.0);
    let mut sim = hanging(
        Method::ImplicitEuler,
        0.5,
        [0.0, 0.0, 0.1],
        t_move,
        0.5,
        None,
    );
    run_to(&mut sim, t_move);
    let v = sim.v();
    let (wk, h) = (0.5 * 5e3, 0.005);
    let expected =
        u * ((M0 + M1) * G * t_move + M0 * v[2] + M1 * v[5]) + 0.5 * wk * u * u * h * t_move;
    let w = sim.pin_work();
    eprintln!("soft: W_pins {w} J, by hand {expected} J");
    assert!(
        (w - expected).abs() <= 0.02 * expected,
        "W_pins = {w} J, by hand {expected} J"
    );
}

/// scenes/cloth-slope.toml at h = 0.05 (the long-step landing of
/// contact_energy.rs, whose put-back stores energy in the springs) with one
/// corner on a hard pin lifted 1 cm over the run: the pin's work is small
/// (about `M g` times 1 cm), the put-back's gain is not. Returns the error,
/// the largest `E - W_pins` seen, the start and the steps redone.
fn pinned_landing(extra: &[&str]) -> (Option<hookean::HookeanError>, f64, f64, usize) {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cloth-slope.toml");
    let text = std::fs::read_to_string(&path).unwrap()
        + "\n[[pin]]\nvertices = [0]\nkeys = [{ t = 0.0 }, { t = 1.0, translation = [0.0, 0.0, 0.01] }]\n";
    let mut overrides = vec![
        "integrator.h=0.05",
        "integrator.method=implicit-euler",
        "duration=1.0",
    ];
    overrides.extend_from_slice(extra);
    let scene = Scene::from_text(&path, &text, &overrides).unwrap();
    let mut sim = scene.build().unwrap();
    let e0 = sim.energies().unwrap().total();
    let (mut e_max, mut redone, mut error) = (e0, 0, None);
    while sim.t() < 1.0 - 1e-9 {
        match sim.step() {
            Ok(r) => redone += r.rejected,
            Err(e) => {
                error = Some(e);
                break;
            }
        }
        e_max = e_max.max(sim.energies().unwrap().total() - sim.pin_work());
    }
    (error, e_max, e0, redone)
}

#[test]
fn a_driven_pin_does_not_hide_the_energy_a_landing_puts_back() {
    // The budget by hand (contact_energy.rs's land_on_slope): 5% of M g D
    // with M = 1 kg, D = 0.6 sqrt 2 m.
    let allowance = 0.05 * G * 0.6 * 2f64.sqrt();
    let (error, e_max, e0, redone) = pinned_landing(&[]);
    assert!(error.is_none(), "{error:?}");
    assert!(redone > 0, "the landing step was not redone");
    eprintln!("budget on: E - W_pins peaks at {e_max} J from {e0} J ({redone} redone)");
    assert!(
        e_max <= e0 + allowance,
        "E - W = {e_max} J > {e0} + {allowance} J"
    );
    // Off, the put-back's energy stays: far above what the pin did.
    let (error, e_max, e0, redone) = pinned_landing(&["integrator.energy_budget=\"off\""]);
    assert!(error.is_none(), "{error:?}");
    eprintln!("budget off: E - W_pins peaks at {e_max} J from {e0} J ({redone} retries)");
    assert!(
        e_max > e0 + 5.0 * allowance,
        "E - W = {e_max} J, start {e0} J"
    );
}
