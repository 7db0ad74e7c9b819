//! The filtered integrator against hand-written steps.

use hookean_filter::{
    FilterCoupling, FilterError, FilterOptions, FilteredIntegrator, VelocityFilter,
};
use hookean_massspring::{ModelOptions, RopeParams, SecondOrderProblem, rope};
use hookean_ode::Integrator;
use hookean_ode::{Method, SecondOrderIntegrator, SolverOptions};

fn rope5() -> (
    hookean_massspring::MassSpringModel,
    hookean_massspring::State,
) {
    let (model, mut state) = rope(&RopeParams {
        n: 5,
        pin_start: false,
        options: ModelOptions {
            gravity: [0.0; 3],
            ..Default::default()
        },
        ..Default::default()
    })
    .unwrap();
    // Stretch the middle particle sideways and give it a velocity.
    state.x[3 * 2 + 1] = 0.05;
    state.v[3 * 3 + 2] = 1.0;
    (model, state)
}

#[test]
fn one_filtered_fb_euler_step_filters_the_velocity_increment() {
    let (model, state) = rope5();
    let h = 1e-3;
    let mut f = vec![0.0; 15];
    model.force(0.0, &state.x, &state.v, &mut f);
    let mut filter = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    // Expected: v1 = v0 + F(h M^-1 f0), x1 = x0 + h v1.
    let mut dv: Vec<f64> = f
        .iter()
        .zip(model.mass())
        .map(|(fi, m)| h * fi / m)
        .collect();
    filter.apply(&mut dv).unwrap();
    let v1: Vec<f64> = state.v.iter().zip(&dv).map(|(v, d)| v + d).collect();
    let x1: Vec<f64> = state.x.iter().zip(&v1).map(|(x, v)| x + h * v).collect();

    let inner = SecondOrderIntegrator::new(
        model.clone(),
        Method::FbEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::with_h(h),
    )
    .unwrap();
    let vf = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    let mut fi = FilteredIntegrator::new(inner, vf, FilterCoupling::Increment).unwrap();
    fi.step().unwrap();
    for k in 0..15 {
        assert!((fi.v()[k] - v1[k]).abs() < 1e-12, "v[{k}]");
        assert!((fi.x()[k] - x1[k]).abs() < 1e-14, "x[{k}]");
    }
    assert_eq!(fi.filter_stats().applications, 1);
    assert!((fi.t() - h).abs() < 1e-18);

    // Velocity filtering with corrected positions: v1 = F(v0 + h a0), x1 = x0 + h v1.
    let mut raw: Vec<f64> = f
        .iter()
        .zip(model.mass())
        .zip(&state.v)
        .map(|((fi, m), v)| v + h * fi / m)
        .collect();
    filter.apply(&mut raw).unwrap();
    let inner = SecondOrderIntegrator::new(
        model.clone(),
        Method::FbEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::with_h(h),
    )
    .unwrap();
    let vf = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    let mut fc = FilteredIntegrator::new(inner, vf, FilterCoupling::CorrectPositions).unwrap();
    fc.step().unwrap();
    for k in 0..15 {
        assert!((fc.v()[k] - raw[k]).abs() < 1e-12);
        assert!((fc.x()[k] - (state.x[k] + h * raw[k])).abs() < 1e-14);
    }
}

#[test]
fn a_rigid_translation_is_left_alone_by_every_coupling() {
    // A rope at rest length, no gravity, translating uniformly: no force,
    // and the normalised filter maps a uniform field to itself.
    let (model, mut state) = rope5();
    state.x = rope(&RopeParams {
        n: 5,
        ..Default::default()
    })
    .unwrap()
    .1
    .x;
    state.v = [0.3, -0.2, 0.1].repeat(5);
    for method in [
        Method::FbEuler,
        Method::Rk4,
        Method::Verlet,
        Method::ExplicitEuler,
    ] {
        for c in [
            FilterCoupling::VelocityOnly,
            FilterCoupling::CorrectPositions,
            FilterCoupling::Increment,
        ] {
            let inner = SecondOrderIntegrator::new(
                model.clone(),
                method.clone(),
                0.0,
                &state.x,
                &state.v,
                SolverOptions::with_h(1e-3),
            )
            .unwrap();
            let vf = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
            let mut fi = FilteredIntegrator::new(inner, vf, c).unwrap();
            fi.integrate(0.01).unwrap();
            for (k, v) in fi.v().iter().enumerate() {
                assert!((v - state.v[k]).abs() < 1e-12, "{method} {c:?}");
            }
            for (k, x) in fi.x().iter().enumerate() {
                assert!((x - (state.x[k] + 0.01 * state.v[k])).abs() < 1e-12);
            }
        }
    }
}

#[test]
fn implicit_methods_and_wrong_sizes_are_typed_errors() {
    let (model, state) = rope5();
    let inner = SecondOrderIntegrator::new(
        model.clone(),
        Method::ImplicitEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::default(),
    )
    .unwrap();
    let vf = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    assert!(matches!(
        FilteredIntegrator::new(inner, vf, FilterCoupling::default()),
        Err(FilterError::ImplicitMethod { .. })
    ));
    let inner = SecondOrderIntegrator::new(
        model,
        Method::FbEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::default(),
    )
    .unwrap();
    let (small, _) = rope(&RopeParams {
        n: 3,
        ..Default::default()
    })
    .unwrap();
    let vf = VelocityFilter::from_model(&small, FilterOptions::default()).unwrap();
    assert!(matches!(
        FilteredIntegrator::new(inner, vf, FilterCoupling::default()),
        Err(FilterError::DimensionMismatch { .. })
    ));
}

#[test]
fn pinned_particles_of_the_model_are_not_filtered() {
    let (model, _) = rope(&RopeParams::default()).unwrap();
    let f = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    assert!(f.is_pinned(0) && !f.is_pinned(1));
    assert_eq!(f.n_particles(), 10);
}

/// Two filtered steps of FB Euler with the increment coupling, the state
/// replaced in between through `inner_mut`: the second step filters
/// `v_2 - v_1` of the new state (the kept `v_n` is dropped), as the
/// hand-written `v_2 = v_1 + F (h M^-1 f(x_1))`, `x_2 = x_1 + h v_2` says.
#[test]
fn a_state_replaced_between_steps_is_the_next_increments_start() {
    let (model, state) = rope5();
    let h = 1e-3;
    let inner = SecondOrderIntegrator::new(
        model.clone(),
        Method::FbEuler,
        0.0,
        &state.x,
        &state.v,
        SolverOptions::with_h(h),
    )
    .unwrap();
    let vf = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    let mut fi = FilteredIntegrator::new(inner, vf, FilterCoupling::Increment).unwrap();
    fi.step().unwrap();
    // A new state: the rope's start with a different velocity.
    let v_new: Vec<f64> = (0..15).map(|k| 0.1 * (k as f64).cos()).collect();
    fi.inner_mut().set_state(h, &state.x, &v_new).unwrap();
    fi.step().unwrap();

    let mut f = vec![0.0; 15];
    model.force(h, &state.x, &v_new, &mut f);
    let mut filter = VelocityFilter::from_model(&model, FilterOptions::default()).unwrap();
    let mut dv: Vec<f64> = f
        .iter()
        .zip(model.mass())
        .map(|(fi, m)| h * fi / m)
        .collect();
    filter.apply(&mut dv).unwrap();
    for k in 0..15 {
        let v2 = v_new[k] + dv[k];
        assert!((fi.v()[k] - v2).abs() < 1e-12, "v[{k}]");
        assert!((fi.x()[k] - (state.x[k] + h * v2)).abs() < 1e-14, "x[{k}]");
    }
}
