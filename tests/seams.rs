//! Workspace integration tests that cut across crates: the contracts that
//! hold the crates together (docs/ARCHITECTURE.md, "one owner for each
//! idea"), checked through every layer that relies on them.

use hookean::ode::Integrator;
use std::ops::ControlFlow;

use hookean::filter::{FilterCoupling, FilterOptions, ModelIntegrator};
use hookean::massspring::{ClothParams, MassSpringModel, State, cloth};
use hookean::nonlinear::{NewtonOptions, NonlinearError, PcgSolver};
use hookean::ode::{Method, OdeError, SecondOrderIntegrator, SolverOptions};
use hookean::sparse::{BlockPattern, Constraints, Identity, SymBlockMatrix, block};
use hookean::{Simulation, SimulationOptions};

fn small_cloth() -> (MassSpringModel, State) {
    cloth(&ClothParams {
        nu: 6,
        nv: 6,
        ..Default::default()
    })
    .unwrap()
}

/// One landing rule for every driver: with h = 0.1 and t_end = 0.25 the
/// steps end at 0.1, 0.2 and exactly 0.25 (the last one shortened to
/// 0.05), whether the run goes through the integrator, the filtered
/// integrator or the facade.
#[test]
fn every_driver_lands_exactly_on_an_end_time_that_is_not_a_multiple_of_h() {
    let (t_end, h) = (0.25, 0.1);
    let expected_t = [0.1, 0.2, 0.25];

    let (model, state) = small_cloth();
    let mut ode = SecondOrderIntegrator::new(
        model.clone(),
        Method::ImplicitEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::with_h(h),
    )
    .unwrap();
    let mut times = Vec::new();
    let info = ode
        .integrate_with(t_end, |r, _| {
            times.push((r.t, r.h));
            ControlFlow::Continue(())
        })
        .unwrap();
    assert_eq!(info.t, t_end);
    assert_eq!(times.len(), 3);
    for ((t, _), e) in times.iter().zip(expected_t) {
        assert!((t - e).abs() < 1e-15, "{t} vs {e}");
    }
    assert!(
        (times[2].1 - 0.05).abs() < 1e-15,
        "last step {}",
        times[2].1
    );

    // A stable explicit step for the filtered run: 1e-4 s, end 0.00025 s.
    let (t_end_f, h_f) = (2.5e-4, 1e-4);
    let filter = Some((FilterOptions::default(), FilterCoupling::default()));
    let mut filtered = ModelIntegrator::new(
        model.clone(),
        &state,
        Method::FbEuler,
        SolverOptions::with_h(h_f),
        filter,
    )
    .unwrap();
    let mut steps = 0;
    while filtered.step_to(t_end_f).unwrap().is_some() {
        steps += 1;
    }
    assert_eq!((steps, filtered.t()), (3, t_end_f));

    let options = SimulationOptions {
        solver: SolverOptions {
            h,
            ..SimulationOptions::drape_solver()
        },
        ..SimulationOptions::default()
    };
    let mut sim = Simulation::new(model, state, options).unwrap();
    let summary = sim.run_until(t_end).unwrap();
    assert_eq!((summary.stats.num_steps, summary.t), (3, t_end));
    // Nothing left to do: a second call takes no step.
    let again = sim.run_until(t_end).unwrap();
    assert_eq!(again.stats.num_steps, 3);
}

/// A nominal step far longer than the run (h = 1e300 s for a 0.02 s run)
/// is shortened to the run, not taken for a sliver to skip: one step of
/// 0.02 s, then nothing left.
#[test]
fn a_step_longer_than_the_run_is_shortened_not_skipped() {
    let (model, state) = small_cloth();
    let mut ode = SecondOrderIntegrator::new(
        model,
        Method::ImplicitEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::with_h(1e300),
    )
    .unwrap();
    let report = ode.step_to(0.02).unwrap().expect("one step");
    assert_eq!((report.t, report.h), (0.02, 0.02));
    assert!(ode.step_to(0.02).unwrap().is_none());
    assert_eq!(ode.stats().num_steps, 1);
}

/// The Newton options are one type with one validation, whichever layer
/// receives them: a linear tolerance of 1 is refused by hookean-nonlinear,
/// by the integrator and by the facade, each naming the field.
#[test]
fn newton_options_are_validated_once_for_every_layer() {
    let bad = NewtonOptions {
        linear_rtol: 1.0,
        ..SolverOptions::default_newton()
    };
    let direct = bad.validate().unwrap_err();
    assert!(
        matches!(
            direct,
            NonlinearError::InvalidParameter {
                name: "linear_rtol",
                ..
            }
        ),
        "{direct:?}"
    );
    let (model, state) = small_cloth();
    let solver = SolverOptions {
        newton: bad,
        ..SolverOptions::default()
    };
    let err = SecondOrderIntegrator::new(
        model.clone(),
        Method::ImplicitEuler,
        0.0,
        &state.x,
        &state.v,
        solver.clone(),
    )
    .err()
    .unwrap();
    assert!(err.to_string().contains("linear_rtol"), "{err}");
    assert!(matches!(err, OdeError::Nonlinear(_)), "{err:?}");
    let options = SimulationOptions {
        solver,
        ..SimulationOptions::default()
    };
    let err = Simulation::new(model, state, options).err().unwrap();
    assert!(err.to_string().contains("linear_rtol"), "{err}");
}

/// The one Krylov adapter keeps prescribed components of a Newton
/// correction at zero even when the constraints prescribe non-zero values:
/// on `A = 4 I + (coupling)` with particle 0 held at velocity (1, 2, 3), the
/// correction s solves the free rows of `A s = rhs` with `s_0 = 0`.
#[test]
fn the_krylov_adapter_solves_for_corrections_that_keep_the_constraints() {
    use hookean::nonlinear::LinearSolver;
    // Two particles, one coupling block: A = [[4I, -I], [-I, 4I]].
    let pattern = std::sync::Arc::new(BlockPattern::new(2, [(0, 1)]).unwrap());
    let mut a = SymBlockMatrix::new(pattern);
    let scaled = |s: f64| block::IDENTITY.map(|row| row.map(|v| s * v));
    a.add_to_block(0, 0, &scaled(4.0)).unwrap();
    a.add_to_block(1, 1, &scaled(4.0)).unwrap();
    a.add_to_block(0, 1, &scaled(-1.0)).unwrap();
    let mut c = Constraints::new(2);
    c.pin(0, [1.0, 2.0, 3.0]).unwrap();
    let mut pcg = PcgSolver::new(Identity)
        .with_max_iter(Some(50))
        .with_constraints(c);
    pcg.setup(&a).unwrap();
    let rhs = [0.5, -1.0, 2.0, 8.0, 4.0, -4.0];
    let mut s = [0.0; 6];
    let stats = pcg.solve(&a, &rhs, &mut s, 1e-14).unwrap();
    assert!(stats.converged);
    // Constrained components of the correction are zero ...
    assert_eq!(&s[..3], &[0.0; 3]);
    // ... and the free rows hold: 4 s_1 - s_0 = rhs_1 with s_0 = 0.
    for k in 0..3 {
        assert!((4.0 * s[3 + k] - rhs[3 + k]).abs() < 1e-12, "{s:?}");
    }
}
