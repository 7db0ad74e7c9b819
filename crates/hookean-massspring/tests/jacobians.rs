//! Force Jacobians against central finite differences of the force, for
//! every damping model; conservation laws; definiteness of the clamped system.

mod common;

use common::*;
use hookean_massspring::{
    DampingInDfdx, MassSpringModel, ModelOptions, SecondOrderProblem, Spring, SpringDamping, State,
};

const MODELS: [(SpringDamping, f64); 4] = [
    (SpringDamping::Projected, 0.0),
    (SpringDamping::Incorrect, 0.0),
    (SpringDamping::None, 0.0),
    (SpringDamping::None, 0.7), // air friction only
];

fn all(n: usize) -> Vec<usize> {
    (0..n).collect()
}

#[test]
fn dfdv_matches_finite_differences_for_every_damping_model() {
    for (m, &(damping, air)) in MODELS.iter().enumerate() {
        for seed in 0..5u64 {
            let (model, s) = random_model(7, damping, air, 100 * seed + m as u64);
            let (mut dfdx, mut dfdv) = model.new_jacobians();
            model
                .jacobians_checked(&s.x, &s.v, false, &mut dfdx, &mut dfdv)
                .unwrap();
            let fd = fd_jacobian(&model, &s.x, &s.v, false, &all(s.x.len()));
            let err = rel_err(&dense(&dfdv), &fd);
            assert!(err < 1e-6, "{damping:?} air {air}: df/dv rel error {err:e}");
            // Non-trivial wherever some damping is present.
            let damped = damping != SpringDamping::None || air > 0.0;
            assert_eq!(fd.iter().flatten().any(|v| v.abs() > 0.1), damped);
        }
    }
}

#[test]
fn exact_dfdx_matches_finite_differences_for_every_damping_model() {
    for (m, &(damping, air)) in MODELS.iter().enumerate() {
        for seed in 0..5u64 {
            let (model, s) = random_model(7, damping, air, 1000 + 100 * seed + m as u64);
            let exact = dense_of_csr(&model.dfdx_exact(&s.x, &s.v).unwrap());
            let fd = fd_jacobian(&model, &s.x, &s.v, true, &all(s.x.len()));
            let err = rel_err(&exact, &fd);
            assert!(
                err < 1e-6,
                "{damping:?} seed {seed}: exact df/dx rel error {err:e}"
            );
        }
    }
}

#[test]
fn symmetric_unclamped_dfdx_is_exact_when_damping_does_not_depend_on_x() {
    // Incorrect damping, air friction and no damping: f depends on x only
    // through the springs' elastic force, so the symmetric df/dx is exact.
    for (seed, &(damping, air)) in MODELS[1..].iter().enumerate() {
        let (model, s) = random_model(7, damping, air, 30 + seed as u64);
        let (mut dfdx, mut dfdv) = model.new_jacobians();
        model
            .jacobians_checked(&s.x, &s.v, false, &mut dfdx, &mut dfdv)
            .unwrap();
        let fd = fd_jacobian(&model, &s.x, &s.v, true, &all(s.x.len()));
        let err = rel_err(&dense(&dfdx), &fd);
        assert!(err < 1e-6, "{damping:?}: df/dx rel error {err:e}");
    }
}

#[test]
fn projected_damping_dfdx_drop_is_the_elastic_part_and_symmetrize_its_symmetric_part() {
    let (model, s) = random_model(7, SpringDamping::Projected, 0.0, 41);
    let mut elastic = model.clone();
    elastic
        .set_options(ModelOptions {
            damping: SpringDamping::None,
            ..*model.options()
        })
        .unwrap();
    let n = s.x.len();
    let (mut dfdx, mut dfdv) = model.new_jacobians();

    // Drop (default): the stiffness Jacobian = FD of the undamped force.
    model
        .jacobians_checked(&s.x, &s.v, false, &mut dfdx, &mut dfdv)
        .unwrap();
    let fd_elastic = fd_jacobian(&elastic, &s.x, &s.v, true, &all(n));
    let err = rel_err(&dense(&dfdx), &fd_elastic);
    assert!(err < 1e-6, "drop: rel error {err:e}");

    // Symmetrize: the symmetric part of the full FD Jacobian.
    let mut sym = model.clone();
    sym.set_options(ModelOptions {
        damping_in_dfdx: DampingInDfdx::Symmetrize,
        ..*model.options()
    })
    .unwrap();
    sym.jacobians_checked(&s.x, &s.v, false, &mut dfdx, &mut dfdv)
        .unwrap();
    let fd = fd_jacobian(&model, &s.x, &s.v, true, &all(n));
    let fd_sym: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| 0.5 * (fd[i][j] + fd[j][i])).collect())
        .collect();
    let err = rel_err(&dense(&dfdx), &fd_sym);
    assert!(err < 1e-6, "symmetrize: rel error {err:e}");
    // ... and the full FD Jacobian is really not symmetric here.
    let asym = (0..n)
        .flat_map(|i| (0..n).map(move |j| (i, j)))
        .map(|(i, j)| (fd[i][j] - fd[j][i]).abs())
        .fold(0.0, f64::max);
    assert!(asym > 1e-3, "asymmetry {asym}");
}

#[test]
fn jacobians_of_a_model_with_a_pinned_particle_are_exact_on_free_motions() {
    let (mut model, mut s) = random_model(6, SpringDamping::Projected, 0.3, 51);
    let p = 2;
    model
        .pin(p, [s.x[3 * p], s.x[3 * p + 1], s.x[3 * p + 2]])
        .unwrap();
    let mut c = hookean_sparse::Constraints::new(6);
    model.begin_step(0.0, &mut s.x, &mut s.v, &mut c);
    assert_eq!(c.count(p), 3);
    let free: Vec<usize> = (0..s.x.len()).filter(|k| k / 3 != p).collect();
    let exact = dense_of_csr(&model.dfdx_exact(&s.x, &s.v).unwrap());
    let fd = fd_jacobian(&model, &s.x, &s.v, true, &free);
    // Columns of the pinned particle are never exercised (it cannot move): zero in both.
    let err = rel_err(&exact, &fd);
    assert!(err < 1e-6, "rel error {err:e}");
    let (mut dfdx, mut dfdv) = model.new_jacobians();
    model.force_jacobians(0.0, &s.x, &s.v, &mut dfdx, &mut dfdv);
    let fdv = fd_jacobian(&model, &s.x, &s.v, false, &free);
    assert!(rel_err(&dense(&dfdv), &fdv) < 1e-6);
    // The pinned particle feels no force (its support cancels it).
    let mut f = vec![0.0; s.x.len()];
    model.force(0.0, &s.x, &s.v, &mut f);
    assert_eq!(&f[3 * p..3 * p + 3], &[0.0; 3]);
}

fn internal_only(model: &MassSpringModel) -> MassSpringModel {
    let mut m = model.clone();
    m.set_options(ModelOptions {
        gravity: [0.0; 3],
        air_friction: 0.0,
        ..*model.options()
    })
    .unwrap();
    m
}

fn sums(x: &[f64], f: &[f64]) -> ([f64; 3], [f64; 3]) {
    let (mut lin, mut ang) = ([0.0; 3], [0.0; 3]);
    for p in 0..x.len() / 3 {
        let (xp, fp) = (&x[3 * p..3 * p + 3], &f[3 * p..3 * p + 3]);
        for r in 0..3 {
            lin[r] += fp[r];
        }
        ang[0] += xp[1] * fp[2] - xp[2] * fp[1];
        ang[1] += xp[2] * fp[0] - xp[0] * fp[2];
        ang[2] += xp[0] * fp[1] - xp[1] * fp[0];
    }
    (lin, ang)
}

#[test]
fn internal_forces_conserve_linear_and_angular_momentum() {
    for damping in [SpringDamping::Projected, SpringDamping::None] {
        let (model, s) = random_model(8, damping, 0.0, 61);
        let model = internal_only(&model);
        let mut f = vec![0.0; s.x.len()];
        model.force(0.0, &s.x, &s.v, &mut f);
        let scale = f.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        assert!(scale > 1.0);
        let (lin, ang) = sums(&s.x, &f);
        for r in 0..3 {
            assert!(lin[r].abs() < 1e-12 * scale, "{damping:?} sum f = {lin:?}");
            assert!(
                ang[r].abs() < 1e-12 * scale,
                "{damping:?} sum x x f = {ang:?}"
            );
        }
    }
    // The incorrect damping still conserves linear momentum, but its forces
    // are not central: torques do not cancel.
    let (model, s) = random_model(8, SpringDamping::Incorrect, 0.0, 61);
    let model = internal_only(&model);
    let mut f = vec![0.0; s.x.len()];
    model.force(0.0, &s.x, &s.v, &mut f);
    let (lin, ang) = sums(&s.x, &f);
    assert!(lin.iter().all(|v| v.abs() < 1e-12));
    assert!(ang.iter().any(|v| v.abs() > 1e-3), "{ang:?}");
}

/// A rigid rotation `v = omega x (x - c)` of a random body.
fn rigid_rotation(x: &[f64]) -> Vec<f64> {
    let omega = [0.3, -1.1, 0.7];
    let c = [0.1, 0.2, -0.3];
    let mut v = vec![0.0; x.len()];
    for p in 0..x.len() / 3 {
        let r = [x[3 * p] - c[0], x[3 * p + 1] - c[1], x[3 * p + 2] - c[2]];
        v[3 * p] = omega[1] * r[2] - omega[2] * r[1];
        v[3 * p + 1] = omega[2] * r[0] - omega[0] * r[2];
        v[3 * p + 2] = omega[0] * r[1] - omega[1] * r[0];
    }
    v
}

#[test]
fn projected_damping_does_not_damp_rigid_rotation_but_the_incorrect_one_does() {
    for (damping, damps) in [
        (SpringDamping::Projected, false),
        (SpringDamping::Incorrect, true),
    ] {
        let (model, s) = random_model(8, damping, 0.0, 71);
        let model = internal_only(&model);
        let v = rigid_rotation(&s.x);
        // Damping force = f(x, v) - f(x, 0); its power on v.
        let (mut f, mut f0) = (vec![0.0; v.len()], vec![0.0; v.len()]);
        model.force(0.0, &s.x, &v, &mut f);
        model.force(0.0, &s.x, &vec![0.0; v.len()], &mut f0);
        let power: f64 = (0..v.len()).map(|k| (f[k] - f0[k]) * v[k]).sum();
        assert!(
            (power - model.damping_power(&s.x, &v).unwrap()).abs() < 1e-9,
            "diagnostic agrees"
        );
        if damps {
            assert!(power < -1e-2, "{damping:?}: power {power}");
        } else {
            assert!(power.abs() < 1e-12, "{damping:?}: power {power}");
            let dmax = (0..v.len())
                .map(|k| (f[k] - f0[k]).abs())
                .fold(0.0, f64::max);
            assert!(dmax < 1e-12, "projected damping force {dmax}");
        }
    }
}

/// Two particles of mass m joined by one spring compressed to 10% of its
/// rest length: with k = 1e4, h = 0.01 the exact (unclamped) transverse
/// stiffness k (1 - l0/l) = -9 k makes M - h^2 df/dx indefinite, since its
/// relative transverse eigenvalue is m - 2 h^2 9 k = 0.01 - 18 < 0.
#[test]
fn clamped_stiffness_keeps_the_implicit_matrix_spd_the_exact_one_need_not() {
    let (m, k, h) = (0.01, 1e4, 0.01);
    let model = MassSpringModel::new(
        vec![m, m],
        vec![Spring::new(0, 1, 1.0, k, 0.5)],
        ModelOptions::default(),
    )
    .unwrap();
    let s = State {
        x: vec![0.0, 0.0, 0.0, 0.1, 0.0, 0.0],
        v: vec![0.0, 0.3, 0.0, 0.2, 0.0, -0.1],
    };
    let a_of = |clamp: bool| {
        let (mut dfdx, mut dfdv) = model.new_jacobians();
        model
            .jacobians_checked(&s.x, &s.v, clamp, &mut dfdx, &mut dfdv)
            .unwrap();
        let mut a = model.new_jacobians().0;
        a.add_to_diagonal(model.mass()).unwrap();
        a.add_scaled(-h, &dfdv).unwrap();
        a.add_scaled(-h * h, &dfdx).unwrap();
        min_eigenvalue(&dense(&a))
    };
    let exact = a_of(false);
    // Closed form: m - 2 h^2 k (l0/l - 1) = 0.01 - 18.
    assert!(
        (exact - (m - 2.0 * h * h * k * 9.0)).abs() < 1e-9,
        "exact {exact}"
    );
    let clamped = a_of(true);
    // Clamped: transverse stiffness 0, smallest eigenvalue is the mass.
    assert!(
        clamped > 0.0 && (clamped - m).abs() < 1e-12,
        "clamped {clamped}"
    );
}

#[test]
fn clamped_implicit_matrix_is_spd_on_random_compressed_and_stretched_states() {
    for (seed, &(damping, air)) in MODELS.iter().enumerate() {
        let (model, s) = random_model(8, damping, air, 80 + seed as u64);
        let compressed = model
            .springs()
            .iter()
            .filter(|sp| dist(&s.x, sp.i, sp.j) < sp.rest_length)
            .count();
        assert!(compressed > 0 && compressed < model.springs().len());
        let mut sys = model.implicit_system();
        // A large step makes the stiffness dominate the mass.
        model
            .assemble_implicit_euler(0.5, &s.x, &s.v, &mut sys)
            .unwrap();
        let lmin = min_eigenvalue(&dense(&sys.a));
        let mmin = model.mass().iter().copied().fold(f64::INFINITY, f64::min);
        // A = M + (positive semidefinite): eigenvalues >= min mass.
        assert!(lmin >= mmin * (1.0 - 1e-9), "{damping:?}: {lmin} < {mmin}");
    }
}

#[test]
fn linearized_jacobians_are_the_isotropic_blocks_of_eq_50() {
    let (mut model, s) = random_model(5, SpringDamping::Projected, 0.2, 91);
    let (mut dfdx, mut dfdv) = model.new_jacobians();
    assert!(model.linearized_jacobians(&mut dfdx, &mut dfdv));
    // The material revision tells when to rebuild it.
    let rev = model.material_revision();
    let mut c = hookean_sparse::Constraints::new(5);
    let (mut x, mut v) = (s.x.clone(), s.v.clone());
    model.begin_step(0.0, &mut x, &mut v, &mut c);
    assert_eq!(
        model.material_revision(),
        rev,
        "a step does not change the material"
    );
    let mut m2 = model.clone();
    m2.set_options(*model.options()).unwrap();
    assert!(m2.material_revision() > rev);
    // Eq. 50: f_lin_i = sum_j k_ij (x_j - x_i) + d_ij (v_j - v_i) (and - c v_i):
    // its Jacobians applied to (x, v) must equal the linear force.
    let n = model.n_particles();
    let mut expect_x = vec![0.0; 3 * n];
    let mut expect_v = vec![0.0; 3 * n];
    for sp in model.springs() {
        for r in 0..3 {
            let dx = s.x[3 * sp.j + r] - s.x[3 * sp.i + r];
            let dv = s.v[3 * sp.j + r] - s.v[3 * sp.i + r];
            expect_x[3 * sp.i + r] += sp.stiffness * dx;
            expect_x[3 * sp.j + r] -= sp.stiffness * dx;
            expect_v[3 * sp.i + r] += sp.damping * dv;
            expect_v[3 * sp.j + r] -= sp.damping * dv;
        }
    }
    for k in 0..3 * n {
        expect_v[k] -= 0.2 * s.v[k];
    }
    let mut y = vec![0.0; 3 * n];
    dfdx.mul_vec(&s.x, &mut y).unwrap();
    for k in 0..3 * n {
        assert!((y[k] - expect_x[k]).abs() < 1e-10 * (1.0 + expect_x[k].abs()));
    }
    dfdv.mul_vec(&s.v, &mut y).unwrap();
    for k in 0..3 * n {
        assert!((y[k] - expect_v[k]).abs() < 1e-10 * (1.0 + expect_v[k].abs()));
    }
}

#[test]
fn spring_energy_gradient_is_minus_the_elastic_force() {
    let (model, s) = random_model(6, SpringDamping::None, 0.0, 101);
    let model = internal_only(&model);
    let mut f = vec![0.0; s.x.len()];
    model.force(0.0, &s.x, &s.v, &mut f);
    let eps = 1e-6;
    for k in 0..s.x.len() {
        let (mut xp, mut xm) = (s.x.clone(), s.x.clone());
        xp[k] += eps;
        xm[k] -= eps;
        let ep = model.energies(&xp, &s.v).unwrap().spring;
        let em = model.energies(&xm, &s.v).unwrap().spring;
        let grad = (ep - em) / (2.0 * eps);
        assert!(
            (grad + f[k]).abs() < 1e-6 * (1.0 + f[k].abs()),
            "{k}: {grad} vs {}",
            -f[k]
        );
    }
}

/// The spring term is `sum_s k_s (l_s - l0_s)^2 / 2`, summed here spring by
/// spring in the model's order (the model sums by chunks of its assembly
/// table); springs of length 0 and non-finite states are refused by name.
#[test]
fn spring_energy_is_the_sum_over_springs_and_refuses_coincident_ends() {
    for n in [2, 5, 9, 13] {
        let (model, s) = random_model(n, SpringDamping::Projected, 0.0, 7 + n as u64);
        let expected: f64 = model
            .springs()
            .iter()
            .map(|sp| {
                let l = dist(&s.x, sp.i, sp.j);
                0.5 * sp.stiffness * (l - sp.rest_length).powi(2)
            })
            .sum();
        let got = model.energies(&s.x, &s.v).unwrap().spring;
        assert!(
            (got - expected).abs() <= 1e-13 * expected,
            "n = {n}: {got} vs {expected} ({} springs)",
            model.springs().len()
        );
    }
    let (model, s) = random_model(9, SpringDamping::Projected, 0.0, 3);
    let springs = model.springs();
    // Particles 7 and 8 moved onto 6: springs (6, 7), (6, 8) and (7, 8)
    // have length 0, and the first of them in the model's order is named.
    let mut x = s.x.clone();
    for p in [7, 8] {
        for r in 0..3 {
            x[3 * p + r] = x[3 * 6 + r];
        }
    }
    let zero: Vec<usize> = (0..springs.len())
        .filter(|&k| dist(&x, springs[k].i, springs[k].j) == 0.0)
        .collect();
    assert!(zero.len() >= 2, "{zero:?}");
    let first = zero[0];
    match model.energies(&x, &s.v) {
        Err(hookean_massspring::MassSpringError::ZeroLengthSpring { spring, i, j }) => {
            assert_eq!((spring, i, j), (first, springs[first].i, springs[first].j));
        }
        other => panic!("expected ZeroLengthSpring, got {other:?}"),
    }
    let mut v = s.v.clone();
    v[4] = f64::NAN;
    match model.energies(&s.x, &v) {
        Err(hookean_massspring::MassSpringError::NonFinite { what, index }) => {
            assert_eq!((what, index), ("v", 4));
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

/// Directional finite difference `(f(x + eps w) - f(x - eps w)) / (2 eps)`
/// (in `x` or in `v`).
fn fd_dir(model: &MassSpringModel, s: &State, w: &[f64], wrt_x: bool) -> Vec<f64> {
    let eps = 1e-6;
    let n = w.len();
    let (mut fp, mut fm) = (vec![0.0; n], vec![0.0; n]);
    let shift = |base: &[f64], sign: f64| -> Vec<f64> {
        base.iter()
            .zip(w)
            .map(|(b, d)| b + sign * eps * d)
            .collect()
    };
    if wrt_x {
        model.force(0.0, &shift(&s.x, 1.0), &s.v, &mut fp);
        model.force(0.0, &shift(&s.x, -1.0), &s.v, &mut fm);
    } else {
        model.force(0.0, &s.x, &shift(&s.v, 1.0), &mut fp);
        model.force(0.0, &s.x, &shift(&s.v, -1.0), &mut fm);
    }
    (0..n).map(|k| (fp[k] - fm[k]) / (2.0 * eps)).collect()
}

#[test]
fn jacobians_with_sliding_particles_and_reversed_springs_are_exact_on_admissible_motions() {
    // Random springs, half of them given as (j, i), so that stored blocks
    // are transposed; particle 1 slides in a plane, particle 4 along a line.
    let (base, s) = random_model(6, SpringDamping::Incorrect, 0.4, 111);
    let springs: Vec<Spring> = base
        .springs()
        .iter()
        .enumerate()
        .map(|(k, sp)| {
            if k % 2 == 0 {
                Spring::new(sp.j, sp.i, sp.rest_length, sp.stiffness, sp.damping)
            } else {
                *sp
            }
        })
        .collect();
    // A duplicated spring: its block is shared by two springs.
    let mut springs = springs;
    springs.push(Spring::new(3, 2, 0.7, 25.0, 0.3));
    springs.push(Spring::new(2, 3, 0.9, 15.0, 0.6));
    let mut model =
        MassSpringModel::new(base.particle_masses().to_vec(), springs, *base.options()).unwrap();
    let p1 = [s.x[3], s.x[4], s.x[5]];
    let p4 = [s.x[12], s.x[13], s.x[14]];
    model.constrain_direction(1, [0.3, -1.0, 0.5], p1).unwrap();
    model.constrain_direction(4, [1.0, 1.0, 0.0], p4).unwrap();
    model.constrain_direction(4, [0.0, 0.2, 1.0], p4).unwrap();
    let mut s = s;
    let mut c = hookean_sparse::Constraints::new(6);
    model.begin_step(0.0, &mut s.x, &mut s.v, &mut c);
    assert_eq!((c.count(1), c.count(4)), (1, 2));
    let (mut dfdx, mut dfdv) = model.new_jacobians();
    model
        .jacobians_checked(&s.x, &s.v, false, &mut dfdx, &mut dfdv)
        .unwrap();
    let exact = model.dfdx_exact(&s.x, &s.v).unwrap();
    let n = s.x.len();
    for trial in 0..4 {
        // A random admissible direction: w <- P w.
        let mut w: Vec<f64> = (0..n)
            .map(|k| (((k + 3 * trial) * 7919 % 23) as f64 / 11.0) - 1.0)
            .collect();
        c.project(&mut w);
        for (wrt_x, mat) in [(true, &dfdx), (false, &dfdv)] {
            let fd = fd_dir(&model, &s, &w, wrt_x);
            let mut y = vec![0.0; n];
            mat.mul_vec(&w, &mut y).unwrap();
            let scale = fd.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            let err = y
                .iter()
                .zip(&fd)
                .fold(0.0_f64, |a, (p, q)| a.max((p - q).abs()));
            assert!(
                scale > 1e-3 && err < 1e-6 * scale,
                "wrt_x {wrt_x}: {err:e} / {scale:e}"
            );
        }
        let fd = fd_dir(&model, &s, &w, true);
        let mut y = vec![0.0; n];
        hookean_sparse::LinearOperator::apply(&exact, &w, &mut y);
        let err = y
            .iter()
            .zip(&fd)
            .fold(0.0_f64, |a, (p, q)| a.max((p - q).abs()));
        assert!(err < 1e-6 * fd.iter().fold(0.0_f64, |a, v| a.max(v.abs())));
    }
    // The fused sweep gives the same bits as the separate calls.
    let mut f1 = vec![0.0; n];
    let mut f2 = vec![0.0; n];
    model.force(0.0, &s.x, &s.v, &mut f1);
    let (mut a, mut b) = model.new_jacobians();
    model.force_jacobians(0.0, &s.x, &s.v, &mut a, &mut b);
    let (mut a2, mut b2) = model.new_jacobians();
    model.force_and_jacobians(&s.x, &s.v, &mut f2, &mut a2, &mut b2);
    assert_eq!(f1, f2);
    assert_eq!(a.values(), a2.values());
    assert_eq!(b.values(), b2.values());
}
