//! The papers' models against closed forms: the tutorial's example 3, a
//! hanging rope, pins, colliders, and the explicit stability limit.

mod common;

use common::*;
use hookean_massspring::{
    ClothParams, ClothPins, Collider, MassSpringModel, ModelOptions, RopeParams,
    SecondOrderProblem, Spring, SpringDamping, SpringMaterial, State, cloth, rope,
    tutorial_example3,
};
use hookean_sparse::{Constraints, PowerParams};

#[test]
fn example3_force_is_the_tutorials_eq_8() {
    // d2z/dt2 = k (l0 - z)/m - d/m dz/dt + g_z, m = 0.1, k = 100, d = 1, l0 = -1, g_z = -10.
    let (model, mut s) = tutorial_example3().unwrap();
    let (m, k, d, l0, g) = (0.1, 100.0, 1.0, -1.0, -10.0);
    let mut f = vec![0.0; 6];
    for (z, vz) in [(-1.0, -5.0), (-0.3, 2.0), (-1.7, 0.4), (-1.01, 0.0)] {
        s.x[5] = z;
        s.v[5] = vz;
        model.force(0.0, &s.x, &s.v, &mut f);
        let expect = k * (l0 - z) / m - d / m * vz + g;
        assert!((f[5] / m - expect).abs() < 1e-12 * (1.0 + expect.abs()));
        assert_eq!((f[3], f[4]), (0.0, 0.0));
        assert_eq!(&f[..3], &[0.0; 3], "the anchor is pinned: no net force");
    }
}

#[test]
fn example3_energies_and_momentum_of_the_initial_state() {
    let (model, s) = tutorial_example3().unwrap();
    let e = model.energies(&s.x, &s.v).unwrap();
    // 1/2 0.1 5^2 = 1.25; -m g . x = -0.1 (-10)(-1) = -1; spring at rest length: 0.
    approx::assert_abs_diff_eq!(e.kinetic, 1.25, epsilon = 1e-15);
    assert!((e.gravitational + 1.0).abs() < 1e-15);
    assert_eq!(e.spring, 0.0);
    approx::assert_abs_diff_eq!(e.total(), 0.25, epsilon = 1e-15);
    let p = model.momentum(&s.x, &s.v).unwrap();
    assert_eq!(p.linear, [0.0, 0.0, -0.5]);
    assert_eq!(p.angular, [0.0; 3]);
}

#[test]
fn example3_comes_to_rest_at_z_star() {
    let (mut model, mut s) = tutorial_example3().unwrap();
    let mut st = Stepper::new(&model);
    for _ in 0..600 {
        st.step(&mut model, &mut s, 0.01);
        assert_eq!(&s.x[..3], &[0.0; 3], "anchor stays at the origin");
    }
    // z* = l0 + m g_z / k = -1 + 0.1 (-10) / 100 = -1.01.
    assert!((s.x[5] + 1.01).abs() < 1e-9, "z = {}", s.x[5]);
    assert!(s.v[5].abs() < 1e-8);
    assert!(s.x[3].abs() < 1e-15 && s.x[4].abs() < 1e-15);
}

/// A vertical rope of n particles of mass m hanging from a pin at the
/// origin: spring i (between particles i and i+1) carries the weight of the
/// n - 1 - i particles below it, so its extension is (n - 1 - i) m g / k.
fn hanging_rope_closed_form(n: usize, seg: f64, m: f64, g: f64, k: f64) -> Vec<f64> {
    let mut x = vec![0.0; 3 * n];
    for i in 0..n - 1 {
        let ext = (n - 1 - i) as f64 * m * g / k;
        x[3 * (i + 1) + 2] = x[3 * i + 2] - (seg + ext);
    }
    x
}

#[test]
fn hanging_rope_static_equilibrium_matches_its_closed_form() {
    let (n, length, mass, k) = (6, 1.0, 0.6, 1000.0);
    let (mut model, mut s) = rope(&RopeParams {
        n,
        length,
        total_mass: mass,
        material: SpringMaterial::new(k, 0.5),
        direction: [0.0, 0.0, -1.0],
        ..Default::default()
    })
    .unwrap();
    let m = mass / n as f64;
    let xstar = hanging_rope_closed_form(n, length / (n - 1) as f64, m, 9.81, k);
    // f(x*) = 0 at the analytic equilibrium.
    let mut f = vec![0.0; 3 * n];
    model.force(0.0, &xstar, &vec![0.0; 3 * n], &mut f);
    let fmax = f.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    assert!(fmax < 1e-12 * m * 9.81 * n as f64, "|f(x*)| = {fmax}");
    // A damped relaxation from the unstretched rope reaches it.
    let mut st = Stepper::new(&model);
    for _ in 0..1500 {
        st.step(&mut model, &mut s, 0.01);
    }
    let err =
        s.x.iter()
            .zip(&xstar)
            .fold(0.0_f64, |a, (p, q)| a.max((p - q).abs()));
    assert!(err < 1e-9, "max |x - x*| = {err}");
}

#[test]
fn pinned_particles_never_move_under_implicit_and_explicit_steps() {
    let params = ClothParams {
        nu: 6,
        nv: 6,
        pins: ClothPins::TwoCorners,
        ..Default::default()
    };
    let (model0, s0) = cloth(&params).unwrap();
    let pins = [30usize, 35];
    for &p in &pins {
        assert!(matches!(
            model0.constraint(p).unwrap(),
            hookean_massspring::ParticleConstraint::Pinned { .. }
        ));
    }
    // Implicit.
    let (mut model, mut s) = (model0.clone(), s0.clone());
    let mut st = Stepper::new(&model);
    for _ in 0..50 {
        st.step(&mut model, &mut s, 0.01);
        for &p in &pins {
            assert_eq!(&s.x[3 * p..3 * p + 3], &s0.x[3 * p..3 * p + 3]);
        }
    }
    assert!(s.x[2] < -0.05, "the free corner fell: z = {}", s.x[2]);
    // Explicit (symplectic Euler at half the stability limit).
    let (mut model, mut s) = (model0.clone(), s0.clone());
    let h = 0.5
        * model
            .stability(&s.x, &PowerParams::default(), None)
            .unwrap()
            .dt_max;
    let mut c = Constraints::new(model.n_particles());
    let mut f = vec![0.0; model.dim()];
    for _ in 0..400 {
        symplectic_euler_step(&mut model, &mut s, h, &mut c, &mut f);
        for &p in &pins {
            assert_eq!(&s.x[3 * p..3 * p + 3], &s0.x[3 * p..3 * p + 3]);
        }
    }
    assert!(s.x[2] < -1e-3, "the free corner fell: z = {}", s.x[2]);
}

#[test]
fn a_sliding_particle_stays_in_its_plane() {
    let mut model = MassSpringModel::new(vec![1.0], vec![], ModelOptions::default()).unwrap();
    // Slides in the plane x + z = 1 (normal (1, 0, 1)).
    model
        .constrain_direction(0, [1.0, 0.0, 1.0], [1.0, 0.0, 0.0])
        .unwrap();
    let mut s = State {
        x: vec![1.0, 0.0, 0.0],
        v: vec![0.0, 0.5, 0.0],
    };
    let mut st = Stepper::new(&model);
    for _ in 0..100 {
        st.step(&mut model, &mut s, 0.01);
        approx::assert_abs_diff_eq!(s.x[0] + s.x[2], 1.0, epsilon = 1e-12);
    }
    // It slides down the incline: tangential gravity g / sqrt(2) along (-1, 0, 1)/sqrt(2)... (z decreasing).
    assert!(s.x[2] < -0.5 && s.x[0] > 1.5);
    approx::assert_abs_diff_eq!(s.x[1], 0.5, epsilon = 1e-12);
}

fn single_particle(z: f64) -> (MassSpringModel, State) {
    let model = MassSpringModel::new(vec![0.1], vec![], ModelOptions::default()).unwrap();
    (
        model,
        State {
            x: vec![0.2, -0.1, z],
            v: vec![0.3, 0.0, 0.0],
        },
    )
}

#[test]
fn a_particle_dropped_on_the_plane_stays_above_it() {
    for implicit in [true, false] {
        let (mut model, mut s) = single_particle(1.0);
        model.add_collider(Collider::plane([0.0; 3], [0.0, 0.0, 1.0], 0.05).unwrap());
        let h = 0.01;
        let mut st = Stepper::new(&model);
        let mut c = Constraints::new(1);
        let mut f = vec![0.0; 3];
        let mut contacts = 0;
        for _ in 0..300 {
            if implicit {
                st.step(&mut model, &mut s, h);
            } else {
                symplectic_euler_step(&mut model, &mut s, h, &mut c, &mut f);
            }
            contacts += model.contact_count();
            assert!(s.x[2] >= 0.0, "implicit {implicit}: z = {}", s.x[2]);
        }
        assert!(contacts > 100, "it came to rest on the plane");
        assert!(s.x[2] <= 0.05 && s.v[2].abs() < 1e-12);
        // Frictionless: the tangential velocity is kept.
        approx::assert_abs_diff_eq!(s.v[0], 0.3, epsilon = 1e-12);
    }
}

#[test]
fn a_penetrating_particle_is_projected_back_and_released_when_pulled_away() {
    let (mut model, mut s) = single_particle(-0.2);
    model.add_collider(Collider::plane([0.0; 3], [0.0, 0.0, 1.0], 0.0).unwrap());
    s.v[2] = -1.0;
    let mut c = Constraints::new(1);
    model.begin_step(0.0, &mut s.x, &mut s.v, &mut c);
    assert_eq!(s.x[2], 0.0);
    assert_eq!(s.v[2], 0.0);
    assert_eq!(c.count(0), 1);
    assert_eq!(model.contact_count(), 1);
    // An upward external force larger than the weight: the contact is released.
    model
        .set_external_force(0, [0.0, 0.0, 2.0 * 0.1 * 9.81])
        .unwrap();
    model.begin_step(0.0, &mut s.x, &mut s.v, &mut c);
    assert_eq!(c.count(0), 0);
    let mut st = Stepper::new(&model);
    for _ in 0..10 {
        st.step(&mut model, &mut s, 0.01);
    }
    assert!(s.x[2] > 0.0 && s.v[2] > 0.0);
}

#[test]
fn cloth_dropped_on_a_sphere_stays_outside() {
    let (mut model, mut s) = cloth(&ClothParams {
        nu: 7,
        nv: 7,
        origin: [-0.5, -0.5, 0.3],
        pins: ClothPins::None,
        ..Default::default()
    })
    .unwrap();
    let (center, radius) = ([0.0, 0.0, 0.0], 0.25);
    model.add_collider(Collider::sphere(center, radius, 0.0).unwrap());
    let mut st = Stepper::new(&model);
    let mut touched = 0;
    for _ in 0..60 {
        st.step(&mut model, &mut s, 0.005);
        // After the step's begin_step every particle is outside; the step
        // itself keeps contacting particles on the tangent plane (outside).
        touched = touched.max(model.contact_count());
        for p in 0..model.n_particles() {
            let r = (0..3)
                .map(|c| (s.x[3 * p + c] - center[c]).powi(2))
                .sum::<f64>()
                .sqrt();
            let was_contact = model.active_constraint_count(p) > 0;
            if was_contact {
                assert!(r >= radius - 1e-12, "particle {p} inside: r = {r}");
            }
        }
    }
    assert!(touched > 0, "the cloth reached the sphere");
    // One more begin_step projects any particle that arrived during the last step.
    let mut c = Constraints::new(model.n_particles());
    model.begin_step(0.0, &mut s.x, &mut s.v, &mut c);
    for p in 0..model.n_particles() {
        let r = (0..3)
            .map(|c| (s.x[3 * p + c] - center[c]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(r >= radius - 1e-12);
    }
}

#[test]
fn k0_of_a_two_particle_spring_at_rest_is_2k_over_m() {
    let (m, k) = (0.25, 400.0);
    let model = MassSpringModel::new(
        vec![m, m],
        vec![Spring::new(0, 1, 1.0, k, 0.0)],
        ModelOptions::default(),
    )
    .unwrap();
    let x = [0.0, 0.0, 0.0, 0.6, 0.8, 0.0];
    let params = PowerParams {
        rtol: 1e-13,
        ..Default::default()
    };
    let info = model.stability(&x, &params, None).unwrap();
    assert!(
        (info.k0 - 2.0 * k / m).abs() < 1e-9 * info.k0,
        "{}",
        info.k0
    );
    approx::assert_abs_diff_eq!(info.dt_max, 2.0 / (2.0 * k / m).sqrt(), epsilon = 1e-9);
}

fn chain(n: usize, k: f64, m: f64, pin_start: bool) -> (MassSpringModel, State) {
    rope(&RopeParams {
        n,
        length: (n - 1) as f64,
        total_mass: m * n as f64,
        material: SpringMaterial::new(k, 0.0),
        direction: [1.0, 1.0, 0.0],
        pin_start,
        options: ModelOptions {
            gravity: [0.0; 3],
            damping: SpringDamping::None,
            ..ModelOptions::default()
        },
        ..Default::default()
    })
    .unwrap()
}

#[test]
fn k0_of_a_chain_is_the_largest_path_laplacian_eigenvalue() {
    let (n, k, m) = (6, 50.0, 0.5);
    let params = PowerParams {
        rtol: 1e-14,
        max_iter: 100_000,
        ..Default::default()
    };
    // Free chain: eigenvalues (k/m)(2 - 2 cos(pi j / n)), j = 0..n-1.
    let (model, s) = chain(n, k, m, false);
    let k0 = model.stability(&s.x, &params, None).unwrap().k0;
    let exact = k / m * (2.0 + 2.0 * (std::f64::consts::PI / n as f64).cos());
    assert!((k0 - exact).abs() < 1e-8 * exact, "{k0} vs {exact}");
    // One end pinned: a fixed-free chain of n - 1 particles,
    // eigenvalues (k/m)(2 - 2 cos((2j - 1) pi / (2(n - 1) + 1))), j = 1..n-1.
    let (mut model, mut s) = chain(n, k, m, true);
    let mut c = Constraints::new(n);
    model.begin_step(0.0, &mut s.x, &mut s.v, &mut c);
    let k0 = model.stability(&s.x, &params, None).unwrap().k0;
    let j = (n - 1) as f64;
    let exact =
        k / m * (2.0 - 2.0 * ((2.0 * j - 1.0) * std::f64::consts::PI / (2.0 * j + 1.0)).cos());
    assert!((k0 - exact).abs() < 1e-8 * exact, "{k0} vs {exact}");
}

#[test]
fn dt_max_separates_stable_from_unstable_symplectic_euler() {
    // For undamped linear oscillations symplectic Euler is stable iff
    // h omega_max <= 2, i.e. h <= 2 / sqrt(k0) (the filtering paper's eq. 11).
    let (n, k, m) = (6, 50.0, 0.5);
    let (model0, s0) = chain(n, k, m, false);
    let dt_max = model0
        .stability(&s0.x, &PowerParams::default(), None)
        .unwrap()
        .dt_max;
    let run = |h: f64| {
        let (mut model, mut s) = (model0.clone(), s0.clone());
        // A small kick along the chain excites every longitudinal mode.
        for p in 0..n {
            s.v[3 * p] = 1e-3 * if p % 2 == 0 { 1.0 } else { -1.0 };
        }
        let mut c = Constraints::new(n);
        let mut f = vec![0.0; 3 * n];
        let mut worst = 0.0_f64;
        for _ in 0..3000 {
            symplectic_euler_step(&mut model, &mut s, h, &mut c, &mut f);
            worst = worst.max(s.v.iter().fold(0.0_f64, |a, v| a.max(v.abs())));
        }
        worst
    };
    assert!(run(0.95 * dt_max) < 1e-1);
    assert!(run(1.05 * dt_max) > 1e3);
}

/// One linearised implicit-Euler step written against the trait only, as
/// hookean-ode's integrators use the model.
fn generic_step<P: SecondOrderProblem>(p: &mut P, s: &mut State, h: f64, c: &mut Constraints) {
    use hookean_sparse::{
        BlockJacobi, CgParams, CgWorkspace, PreconditionerSetup, SymBlockMatrix, filtered_pcg,
    };
    p.begin_step(0.0, &mut s.x, &mut s.v, c);
    let pattern = p.jacobian_pattern();
    let (mut dfdx, mut dfdv) = (
        SymBlockMatrix::new(pattern.clone()),
        SymBlockMatrix::new(pattern.clone()),
    );
    p.force_jacobians(0.0, &s.x, &s.v, &mut dfdx, &mut dfdv);
    let n = p.dim();
    let mut f = vec![0.0; n];
    p.force(0.0, &s.x, &s.v, &mut f);
    let mut kv = vec![0.0; n];
    dfdx.mul_vec(&s.v, &mut kv).unwrap();
    let b: Vec<f64> = (0..n).map(|k| h * (f[k] + h * kv[k])).collect();
    let mut a = SymBlockMatrix::new(pattern);
    a.add_to_diagonal(p.mass()).unwrap();
    a.add_scaled(-h, &dfdv).unwrap();
    a.add_scaled(-h * h, &dfdx).unwrap();
    let mut pre = BlockJacobi::new();
    pre.setup(&a).unwrap();
    let mut dv = vec![0.0; n];
    let params = CgParams {
        rtol: 1e-12,
        ..CgParams::default()
    };
    filtered_pcg(
        &a,
        &pre,
        &b,
        &mut dv,
        c,
        &params,
        &mut CgWorkspace::new(n),
        None,
    )
    .unwrap()
    .ensure_converged()
    .unwrap();
    for k in 0..n {
        s.v[k] += dv[k];
        s.x[k] += h * s.v[k];
    }
}

#[test]
fn the_trait_alone_drives_an_implicit_step_like_the_model_helpers() {
    let (model0, s0) = cloth(&ClothParams {
        nu: 5,
        nv: 5,
        ..Default::default()
    })
    .unwrap();
    let (mut m1, mut s1) = (model0.clone(), s0.clone());
    let (mut m2, mut s2) = (model0, s0);
    m1.add_collider(Collider::plane([0.0, 0.0, -0.1], [0.0, 0.0, 1.0], 0.0).unwrap());
    m2.add_collider(Collider::plane([0.0, 0.0, -0.1], [0.0, 0.0, 1.0], 0.0).unwrap());
    let mut st = Stepper::new(&m1);
    let mut c = Constraints::new(m2.n_particles());
    for _ in 0..40 {
        st.step(&mut m1, &mut s1, 0.01);
        generic_step(&mut m2, &mut s2, 0.01, &mut c);
    }
    assert!(m2.contact_count() > 0, "the cloth reached the floor");
    let diff =
        s1.x.iter()
            .zip(&s2.x)
            .fold(0.0_f64, |a, (p, q)| a.max((p - q).abs()));
    assert!(diff < 1e-10, "{diff}");
    // After the next begin_step every particle is on or above the floor.
    m2.begin_step(0.0, &mut s2.x, &mut s2.v, &mut c);
    for p in 0..m2.n_particles() {
        assert!(
            s2.x[3 * p + 2] >= -0.1,
            "particle {p}: z = {}",
            s2.x[3 * p + 2]
        );
    }
}
