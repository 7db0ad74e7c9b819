//! Bad input gets typed errors, and the coupling analysis of `FilterCoupling`.

use hookean_filter::{
    BisectionOptions, DrapeMethod, ExplicitScheme, FilterCoupling, FilterError, FilterOptions,
    Kernel, ModelIntegrator, RunOptions, drape_velocity_run, measure_stable_step, predict_dt_max,
    run_bounded, stable_step_against_lambda,
};
use hookean_massspring::{ClothParams, RopeParams, cloth, rope};
use hookean_ode::{Method, SolverOptions};

fn small() -> Result<
    (
        hookean_massspring::MassSpringModel,
        hookean_massspring::State,
    ),
    FilterError,
> {
    Ok(cloth(&ClothParams::drape(6))?)
}

#[test]
fn experiment_parameters_are_checked() {
    let (model, state) = small().unwrap();
    let mut sim = ModelIntegrator::new(
        model,
        &state,
        Method::FbEuler,
        SolverOptions::with_h(1e-4),
        None,
    )
    .unwrap();
    for t_end in [0.0, -1.0, f64::NAN] {
        assert!(matches!(
            run_bounded(
                &mut sim,
                &RunOptions {
                    t_end,
                    ..Default::default()
                }
            ),
            Err(FilterError::InvalidParameter { name: "t_end", .. })
        ));
    }
    for guess in [0.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            measure_stable_step(&small, &Method::FbEuler, None, guess, &Default::default()),
            Err(FilterError::InvalidParameter { name: "guess", .. })
        ));
    }
    assert!(matches!(
        stable_step_against_lambda(&small, &Method::ImplicitEuler, &[1.0], &Default::default()),
        Err(FilterError::InvalidParameter { name: "method", .. })
    ));
    assert!(matches!(
        drape_velocity_run(
            &ClothParams::drape(4),
            &DrapeMethod::FbEuler,
            1e-4,
            1e-3,
            1.0,
            0.0
        ),
        Err(FilterError::InvalidParameter { name: "cutoff", .. })
    ));
    // A filter with lambda = NaN or a zero radius cannot be built into a simulation.
    let (model, state) = small().unwrap();
    let bad = FilterOptions {
        kernel: Kernel::Gaussian { lambda: f64::NAN },
        ..Default::default()
    };
    assert!(matches!(
        ModelIntegrator::new(
            model.clone(),
            &state,
            Method::FbEuler,
            SolverOptions::with_h(1e-4),
            Some((bad, FilterCoupling::default()))
        ),
        Err(FilterError::InvalidLambda { .. })
    ));
    let bad = FilterOptions {
        rings: 0,
        ..Default::default()
    };
    assert!(matches!(
        ModelIntegrator::new(
            model,
            &state,
            Method::FbEuler,
            SolverOptions::with_h(1e-4),
            Some((bad, FilterCoupling::default()))
        ),
        Err(FilterError::InvalidRadius { rings: 0 })
    ));
}

#[test]
fn a_step_that_blows_up_is_reported_as_unbounded_not_as_an_error() {
    let (model, state) = small().unwrap();
    // Ten times the stability limit.
    let dt = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .unwrap()
    .dt_max;
    let mut sim = ModelIntegrator::new(
        model,
        &state,
        Method::FbEuler,
        SolverOptions::with_h(10.0 * dt),
        None,
    )
    .unwrap();
    let out = run_bounded(&mut sim, &RunOptions::default()).unwrap();
    assert!(!out.bounded && out.t_reached < 1.0);
}

#[test]
fn the_gaussian_kernel_also_enlarges_the_predicted_step() {
    let (model, state) = rope(&RopeParams {
        n: 20,
        ..Default::default()
    })
    .unwrap();
    let p = |o: Option<&FilterOptions>| {
        predict_dt_max(
            &model,
            &state.x,
            o,
            ExplicitScheme::Rk4,
            &Default::default(),
        )
        .unwrap()
        .dt_max
    };
    let plain = p(None);
    let gauss = p(Some(&FilterOptions {
        kernel: Kernel::Gaussian { lambda: 1.0 },
        ..Default::default()
    }));
    assert!(gauss > 1.2 * plain, "{gauss} vs {plain}");
    // sqrt(8.75) / 2 times the FB Euler prediction.
    let fb = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .unwrap()
    .dt_max;
    assert!((plain / fb - 8.75f64.sqrt() / 2.0).abs() < 1e-6);
}

#[test]
fn filtering_velocities_without_moving_positions_shrinks_the_step() {
    // The linear analysis of FilterCoupling::VelocityOnly: the FB Euler step
    // is kick-drift-filter, stable for h^2 a < 2 (1 + phi) < 4: the measured
    // limit is below the unfiltered one, while the default coupling's is above.
    let opts = BisectionOptions {
        run: RunOptions {
            t_end: 0.5,
            ..Default::default()
        },
        ..Default::default()
    };
    let build = || Ok(cloth(&ClothParams::drape(10))?);
    let (model, state) = build().unwrap();
    let guess = predict_dt_max(
        &model,
        &state.x,
        None,
        ExplicitScheme::ForwardBackwardEuler,
        &Default::default(),
    )
    .unwrap()
    .dt_max;
    let m = |c: Option<FilterCoupling>| {
        measure_stable_step(
            &build,
            &Method::FbEuler,
            c.map(|c| (FilterOptions::default(), c)),
            guess,
            &opts,
        )
        .unwrap()
        .lo
    };
    let plain = m(None);
    let velocity_only = m(Some(FilterCoupling::VelocityOnly));
    let corrected = m(Some(FilterCoupling::CorrectPositions));
    let increment = m(Some(FilterCoupling::Increment));
    assert!(velocity_only < 0.97 * plain, "{velocity_only} vs {plain}");
    assert!(corrected > 1.05 * plain && increment > corrected);
}

/// A radius past the spring graph's diameter gives every particle its whole
/// connected component, at no more cost: `rings = usize::MAX` on a chain of
/// 30 particles builds at once (the ring search stops when no particle is
/// left to reach) and equals `rings = 29`, the chain's diameter.
#[test]
fn rings_past_the_diameter_stop_at_the_component() {
    use hookean_filter::{Edge, VelocityFilter};
    let n = 30;
    let edges: Vec<Edge> = (0..n - 1)
        .map(|i| Edge {
            i,
            j: i + 1,
            rest_length: 0.1,
        })
        .collect();
    let build = |rings| {
        VelocityFilter::new(
            n,
            &edges,
            None,
            FilterOptions {
                rings,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let huge = build(usize::MAX);
    let diameter = build(n - 1);
    for i in 0..n {
        assert_eq!(huge.neighbourhood(i), diameter.neighbourhood(i));
        assert_eq!(huge.neighbourhood(i).0.len(), n);
    }
}
