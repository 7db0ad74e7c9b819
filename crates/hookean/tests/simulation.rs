//! The facade composes the crates: implicit and filtered explicit runs,
//! option errors, sinks.

use std::ops::ControlFlow;

use hookean::prelude::*;
use hookean::sparse::PowerParams;
use hookean::{RunSummary, Sink};

fn small_cloth(n: usize) -> (MassSpringModel, State) {
    cloth(&ClothParams {
        nu: n,
        nv: n,
        ..Default::default()
    })
    .unwrap()
}

#[test]
fn pinned_corners_stay_put_and_the_cloth_falls() {
    let (model, state) = small_cloth(10);
    let pinned = [90usize, 99];
    let x0: Vec<f64> = pinned
        .iter()
        .flat_map(|&p| state.x[3 * p..3 * p + 3].to_vec())
        .collect();
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    let summary = sim.run_until(0.3).unwrap();
    assert_eq!(summary.stats.num_steps, 30);
    let x1: Vec<f64> = pinned
        .iter()
        .flat_map(|&p| sim.x()[3 * p..3 * p + 3].to_vec())
        .collect();
    assert_eq!(x0, x1, "pinned corners moved");
    // The far edge fell by a visible amount: free fall would give g t^2 / 2 = 0.44 m.
    let lowest = sim
        .x()
        .chunks(3)
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    assert!(lowest < -0.1 && lowest > -0.5, "{lowest}");
    assert!(summary.stats.num_nonlin_solv_iters > 0 && summary.stats.num_lin_iters > 0);
}

#[test]
fn filtered_fb_euler_runs_and_a_filter_on_an_implicit_method_is_refused() {
    let (model, state) = small_cloth(6);
    let options = SimulationOptions {
        method: Method::FbEuler,
        solver: SolverOptions::with_h(1e-4),
        filter: Some(FilterOptions::default()),
        ..Default::default()
    };
    let mut sim = Simulation::new(model, state, options).unwrap();
    sim.run_until(0.01).unwrap();
    assert!(sim.v().iter().all(|v| v.is_finite() && v.abs() < 10.0));
    assert_eq!(sim.stats().num_nonlin_solv_iters, 0);

    let (model, state) = small_cloth(6);
    let bad = SimulationOptions {
        filter: Some(FilterOptions::default()),
        ..Default::default()
    };
    assert!(matches!(
        Simulation::new(model, state, bad),
        Err(HookeanError::InvalidOption { .. })
    ));
}

#[test]
fn a_particle_pinned_through_model_mut_stays_put_in_a_filtered_run() {
    // The filter keeps pinned particles out; one pinned after the
    // simulation was built must be kept out too, or the filter would give it
    // its neighbours' velocity and it would drift.
    let (model, state) = small_cloth(6);
    let options = SimulationOptions {
        method: Method::FbEuler,
        solver: SolverOptions::with_h(1e-4),
        filter: Some(FilterOptions::default()),
        ..Default::default()
    };
    let mut sim = Simulation::new(model, state, options).unwrap();
    sim.run_until(0.005).unwrap();
    let p = 14; // an inner particle, moving by now
    assert!(sim.v()[3 * p + 2].abs() > 1e-4);
    let at: [f64; 3] = sim.x()[3 * p..3 * p + 3].try_into().unwrap();
    sim.model_mut().pin(p, at).unwrap();
    sim.run_until(0.01).unwrap();
    assert_eq!(
        &sim.x()[3 * p..3 * p + 3],
        &at,
        "the newly pinned particle moved"
    );
    assert_eq!(&sim.v()[3 * p..3 * p + 3], &[0.0; 3]);
}

#[test]
fn sinks_see_every_step_and_the_end() {
    struct Count {
        steps: usize,
        finished: bool,
    }
    impl Sink for Count {
        fn step(
            &mut self,
            _: &Simulation,
            _: &hookean::ode::StepReport,
        ) -> Result<(), HookeanError> {
            self.steps += 1;
            Ok(())
        }
        fn finish(&mut self, _: &Simulation, s: &RunSummary) -> Result<(), HookeanError> {
            self.finished = s.stats.num_steps == self.steps;
            Ok(())
        }
    }
    let (model, state) = small_cloth(5);
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    let mut count = Count {
        steps: 0,
        finished: false,
    };
    sim.run_with_sinks(0.05, &mut [&mut count]).unwrap();
    assert_eq!(count.steps, 5);
    assert!(count.finished);
}

#[test]
fn a_callback_can_stop_the_run() {
    let (model, state) = small_cloth(5);
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    let summary = sim
        .run_until_with(1.0, |s, _| {
            if s.t() >= 0.03 - 1e-12 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .unwrap();
    assert!(summary.stopped);
    assert_eq!(summary.stats.num_steps, 3);
}

/// An explicit step above the stability limit blows up; the run stops with
/// a typed error naming the time, the step and the stable step, well before
/// the state turns non-finite. Half the stable step runs to the end: the
/// bound does not trip on valid motion (the cloth falls and swings, its
/// kinetic energy rising from zero).
#[test]
fn an_unstable_explicit_run_stops_with_a_blow_up_error_and_a_stable_one_does_not() {
    let (model, state) = small_cloth(8);
    let dt_max = model
        .stability(&state.x, &PowerParams::default(), None)
        .unwrap()
        .dt_max;
    let run = |h: f64, t_end: f64| {
        let (model, state) = small_cloth(8);
        let options = SimulationOptions {
            method: Method::FbEuler,
            solver: SolverOptions::with_h(h),
            ..Default::default()
        };
        let mut sim = Simulation::new(model, state, options).unwrap();
        let result = sim.run_until(t_end);
        (result, sim)
    };
    let (result, sim) = run(3.0 * dt_max, 0.5);
    match result {
        Err(HookeanError::BlowUp {
            t,
            step,
            h,
            dt_max: Some(d),
            energy,
            bound,
            ..
        }) => {
            assert!(energy > bound && energy.is_finite());
            assert_eq!(step, sim.stats().num_steps);
            assert!((t - sim.t()).abs() < 1e-15 && t < 0.5);
            assert!((d - dt_max).abs() <= 1e-6 * dt_max, "{d} vs {dt_max}");
            assert!(h > d);
            assert!(sim.x().iter().all(|x| x.is_finite()), "caught before NaN");
        }
        other => panic!("expected a blow-up, got {:?}", other.map(|s| s.stats)),
    }
    let (result, sim) = run(0.5 * dt_max, 0.5);
    result.unwrap();
    assert!(sim.energies().unwrap().kinetic > 0.0);
}

#[test]
fn a_blow_up_factor_that_is_not_positive_is_refused() {
    let (model, state) = small_cloth(4);
    let options = SimulationOptions {
        blow_up_factor: 0.0,
        ..Default::default()
    };
    match Simulation::new(model, state, options) {
        Err(HookeanError::InvalidOption { name, .. }) => assert_eq!(name, "blow_up_factor"),
        other => panic!("{:?}", other.err()),
    }
}

/// The same `k/m` moves alike in any mass unit: a cloth with masses,
/// stiffnesses and damping all scaled by 2^-40 (a power of two, so every
/// product is exact) follows bit for bit the path of the unscaled one. The
/// Newton test once used an absolute residual tolerance that froze such a
/// cloth with zero iterations.
#[test]
fn the_motion_does_not_depend_on_the_mass_unit() {
    let run = |scale: f64| {
        let base = ClothParams {
            nu: 8,
            nv: 8,
            ..Default::default()
        };
        let k = base.structural.stiffness;
        let d = base.structural.damping;
        let params = ClothParams {
            total_mass: base.total_mass * scale,
            ..base.with_stiffness(k * scale, d * scale)
        };
        let (model, state) = cloth(&params).unwrap();
        let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
        sim.run_until(0.2).unwrap();
        (sim.x().to_vec(), sim.stats())
    };
    let (x1, s1) = run(1.0);
    // 2^-332 and 2^332 lie just inside the scenes' mass range [1e-100,
    // 1e100] (hookean::range::MASS): the whole range moves alike.
    for e in [-40, -332, 332] {
        let (x2, s2) = run(2f64.powi(e));
        assert!(s2.num_nonlin_solv_iters >= s2.num_steps, "2^{e}: {s2:?}");
        assert_eq!(s1.num_nonlin_solv_iters, s2.num_nonlin_solv_iters, "2^{e}");
        assert_eq!(s1.num_lin_iters, s2.num_lin_iters, "2^{e}");
        assert_eq!(x1, x2, "2^{e}");
    }
    // Outside it (1e-200 kg, 2^-664) the squares of Newton's residual
    // underflow: the cloth froze with no iteration, why the range ends.
    let (x3, s3) = run(2f64.powi(-664));
    assert!(
        x3 != x1 || s3.num_nonlin_solv_iters < s3.num_steps,
        "{s3:?}"
    );
}

/// A simulation (and so its integrator, engine and model) can move to
/// another thread: a parameter sweep over a thread pool, or a binding that
/// releases an interpreter lock while it steps.
#[test]
fn a_simulation_is_send() {
    fn assert_send<T: Send>(_: &T) {}
    let (model, state) = small_cloth(4);
    let sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    assert_send(&sim);
    let handle = std::thread::spawn(move || {
        let mut sim = sim;
        sim.run_until(0.02).map(|_| sim.t())
    });
    let t = handle.join().unwrap().unwrap();
    assert!((t - 0.02).abs() < 1e-12, "t = {t}");
}

/// The energies a simulation reports are those of its current state: after
/// a step they are the model's own sum over that state (the blow-up check's
/// pass, not a second one), and a change to the model through `model_mut`
/// is seen at once: a force F on particle p adds the potential -F . x_p.
#[test]
fn energies_follow_the_state_and_the_model() {
    let (model, state) = small_cloth(6);
    let mut sim = Simulation::new(model, state, SimulationOptions::default()).unwrap();
    for _ in 0..3 {
        sim.step().unwrap();
        let fresh = sim.model().energies(sim.x(), sim.v()).unwrap();
        assert_eq!(sim.energies().unwrap(), fresh);
    }
    let before = sim.energies().unwrap();
    assert_eq!(before.external, 0.0);
    let (p, force) = (7usize, [0.0, 0.0, 2.5]);
    sim.model_mut().set_external_force(p, force).unwrap();
    let after = sim.energies().unwrap();
    let expected = -force[2] * sim.x()[3 * p + 2];
    assert!(expected != 0.0);
    assert!(
        (after.external - expected).abs() <= 1e-12 * expected.abs(),
        "{} vs {expected}",
        after.external
    );
    assert_eq!(after.kinetic, before.kinetic);
}
