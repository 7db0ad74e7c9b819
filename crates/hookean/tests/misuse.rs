//! API misuse of the facade (issue 28): states of the wrong size, end times
//! that are not numbers, options out of range, scene files that are not
//! scenes are typed errors, never a panic or a run without end.

use hookean::massspring::{ClothParams, State, cloth};
use hookean::scene::Scene;
use hookean::{Simulation, SimulationOptions};

fn small() -> (hookean::massspring::MassSpringModel, State) {
    cloth(&ClothParams::drape(4)).unwrap()
}

#[test]
fn a_state_of_the_wrong_size_or_with_nan_is_refused() {
    let (model, mut state) = small();
    state.x.pop();
    assert!(Simulation::new(model, state, SimulationOptions::default()).is_err());
    let (model, mut state) = small();
    state.v[4] = f64::NAN;
    assert!(Simulation::new(model, state, SimulationOptions::default()).is_err());
}

#[test]
fn end_times_that_are_not_numbers_or_past_are_errors_that_change_nothing() {
    let (model, state) = small();
    let x0 = state.x.clone();
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    for t in [f64::NAN, f64::INFINITY, -1.0] {
        assert!(sim.run_until(t).is_err(), "{t}");
    }
    assert_eq!(sim.t(), 0.0);
    assert_eq!(sim.x(), x0.as_slice());
}

#[test]
fn options_out_of_range_are_errors() {
    for h in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        let (model, state) = small();
        let mut o = SimulationOptions::default();
        o.solver.h = h;
        assert!(Simulation::new(model, state, o).is_err(), "h = {h}");
    }
    let (model, state) = small();
    let o = SimulationOptions {
        blow_up_factor: f64::NAN,
        ..SimulationOptions::default()
    };
    assert!(Simulation::new(model, state, o).is_err());
}

#[test]
fn files_that_are_not_scenes_are_errors() {
    assert!(Scene::from_file("/dev/zero", &[]).is_err());
    assert!(Scene::from_file("/", &[]).is_err());
    assert!(Scene::from_file("/nonexistent/s.toml", &[]).is_err());
    let scene = Scene::from_toml_str("s.toml", "[cloth]\nn = 4\n").unwrap();
    assert!(scene.build_within(0).is_err());
    for o in ["cloth.n", "=", "cloth..n=3", "cloth.n.x=3", "cloth.n=1e400"] {
        assert!(
            Scene::with_overrides("s.toml", "[cloth]\n", &[o]).is_err(),
            "{o}"
        );
    }
}
