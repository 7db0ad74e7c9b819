//! Newton variants on one implicit Euler step of the reference drape scene
//! (small N for test time; the N = 64 numbers come from the `cloth_bars`
//! example and are recorded in docs/perf/hookean-nonlinear.md).

mod common;

use common::cloth::{ClothStep, scalar_nonzeros};
use hookean_nonlinear::*;
use hookean_sparse::BlockJacobi;

const N: usize = 12;

fn run(
    method: NewtonMethod,
    rtol: f64,
    h: f64,
) -> (ClothStep, Vec<f64>, Result<NewtonStats, NonlinearError>) {
    let mut sys = ClothStep::new(N, 1e4, 0.1, h, 0.02, 7);
    let pcg = PcgSolver::new(BlockJacobi::new()).with_constraints(sys.correction_constraints());
    let options = NewtonOptions {
        method,
        rtol,
        atol: 0.0,
        max_iter: 200,
        ..Default::default()
    };
    let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
    let mut dv = vec![0.0; sys.dim()];
    let r = newton.solve(&mut sys, &mut dv);
    (sys, dv, r)
}

#[test]
fn inexact_newton_needs_fewer_cg_iterations_than_exact_newton() {
    let rtol = 1e-8;
    let (mut sys, dv_exact, exact) = run(NewtonMethod::Exact, rtol, 0.01);
    let exact = exact.unwrap();
    let (_, dv_inexact, inexact) = run(NewtonMethod::Inexact(ForcingTerm::TUTORIAL), rtol, 0.01);
    let inexact = inexact.unwrap();
    // The same final nonlinear residual bound...
    for s in [&exact, &inexact] {
        assert!(s.final_residual() <= rtol * s.initial_residual());
        assert!(s.iterations >= 2, "the step is nonlinear");
    }
    // ... with fewer CG iterations in total.
    assert!(
        inexact.linear_iterations < exact.linear_iterations,
        "inexact {} vs exact {}",
        inexact.linear_iterations,
        exact.linear_iterations
    );
    // Independent check of the answer: a fresh residual evaluation.
    let mut g = vec![0.0; sys.dim()];
    sys.residual(&dv_inexact, &mut g).unwrap();
    let gn = g.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(gn <= rtol * inexact.initial_residual());
    // The two solutions agree, and the pinned corners did not move.
    let diff = dv_exact
        .iter()
        .zip(&dv_inexact)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let scale = dv_exact.iter().map(|a| a.abs()).fold(0.0, f64::max);
    assert!(diff <= 1e-5 * scale, "{diff} vs {scale}");
    for p in [0, N - 1] {
        assert_eq!(&dv_inexact[3 * p..3 * p + 3], &[0.0; 3]);
    }
}

#[test]
fn linearised_jacobian_has_a_third_of_the_nonzeros() {
    let mut sys = ClothStep::new(N, 1e4, 0.1, 0.01, 0.02, 7);
    let dv = vec![0.0; sys.dim()];
    let mut full = sys.jacobian_storage();
    sys.jacobian(&dv, &mut full).unwrap();
    let mut lin = sys.jacobian_storage();
    assert!(sys.approximate_jacobian(&dv, &mut lin).unwrap());
    // Every spring block is a full 3x3 (9 entries) in the full Jacobian of a
    // deformed cloth and k I (3 entries) in the linearised one; diagonal
    // blocks likewise. So the count is exactly a third.
    let blocks = 2 * sys.springs.len() + N * N;
    assert_eq!(scalar_nonzeros(&full), 9 * blocks);
    assert_eq!(scalar_nonzeros(&lin), 3 * blocks);
}

#[test]
fn simplified_variants_keep_their_jacobian() {
    // Simplified Newton with exact solves converges with fewer Jacobians than iterations.
    let (_, _, s) = run(NewtonMethod::Simplified, 1e-8, 0.01);
    let s = s.unwrap();
    assert!(s.jacobian_evaluations < s.iterations, "{s:?}");

    // The linearised Jacobian of eq. (50) is evaluated once and reused by
    // the next call; it contracts slowly (h^2 k / m = 1.44 here, 4096 in
    // the reference scene, see docs/perf/hookean-nonlinear.md), so
    // ask only for the loose accuracy cloth simulators use.
    let mut sys = ClothStep::new(N, 1e4, 0.1, 0.001, 0.02, 7);
    let pcg = PcgSolver::new(BlockJacobi::new()).with_constraints(sys.correction_constraints());
    let options = NewtonOptions {
        method: NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
        rtol: 1e-3,
        atol: 0.0,
        max_iter: 200,
        ..Default::default()
    };
    let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
    let mut dv = vec![0.0; sys.dim()];
    let s1 = newton.solve(&mut sys, &mut dv).unwrap();
    assert_eq!(s1.jacobian_evaluations, 1);
    assert!(s1.final_residual() <= 1e-3 * s1.initial_residual());
    // Next step from the new state: the kept matrix is reused.
    for i in 0..dv.len() {
        sys.v0[i] += dv[i];
        sys.x0[i] += sys.h * sys.v0[i];
    }
    let mut dv = vec![0.0; sys.dim()];
    let s2 = newton.solve(&mut sys, &mut dv).unwrap();
    assert!(s2.jacobian_reused);
    assert_eq!((s2.jacobian_evaluations, s2.linear_setups), (0, 0));
}

#[test]
fn isotropic_storage_of_the_linearised_jacobian_gives_the_same_iteration() {
    use common::cloth::LinearizedCloth;
    let options = NewtonOptions {
        method: NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
        rtol: 1e-3,
        atol: 0.0,
        max_iter: 200,
        ..Default::default()
    };
    // 3x3-block storage.
    let mut sys = ClothStep::new(N, 1e4, 0.1, 0.001, 0.02, 7);
    let pcg = PcgSolver::new(BlockJacobi::new()).with_constraints(sys.correction_constraints());
    let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
    let mut dv1 = vec![0.0; sys.dim()];
    let s1 = newton.solve(&mut sys, &mut dv1).unwrap();
    // Isotropic storage: one scalar per block, a third of the nonzeros.
    let mut step = ClothStep::new(N, 1e4, 0.1, 0.001, 0.02, 7);
    let pcg = PcgSolver::new(BlockJacobi::new()).with_constraints(step.correction_constraints());
    let mut iso = LinearizedCloth(&mut step);
    let mut newton = Newton::new(options, iso.jacobian_storage(), pcg).unwrap();
    let mut dv2 = vec![0.0; iso.dim()];
    let s2 = newton.solve(&mut iso, &mut dv2).unwrap();
    let blocks = 2 * iso.0.springs.len() + N * N;
    assert_eq!(newton.jacobian().full_nnz(), 3 * blocks);
    assert_eq!(s1.iterations, s2.iterations);
    assert!(s1.linear_iterations.abs_diff(s2.linear_iterations) <= s1.iterations);
    let diff = dv1
        .iter()
        .zip(&dv2)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let scale = dv1.iter().map(|a| a.abs()).fold(0.0, f64::max);
    assert!(diff <= 1e-8 * scale, "{diff} vs {scale}");
}

/// The exact (unclamped) Jacobian of a cloth with compressed springs is
/// indefinite: PCG fails on it, unless it truncates at the negative
/// curvature (Newton-CG) and Newton backtracks the truncated step until the
/// residual falls. That reaches the root the clamped Newton reaches.
#[test]
fn an_indefinite_exact_jacobian_is_solved_by_truncating_cg() {
    let (n, k, h, jitter) = (10, 1e4, 0.01, 0.03);
    let newton = |negative_curvature| {
        let step = ClothStep::new(n, k, 0.1, h, jitter, 3);
        // MIC(0) stays positive definite on an indefinite matrix (its
        // shift), so truncated CG has a usable first direction.
        let mic = hookean_sparse::IncompleteCholesky::modified(0.99).unwrap();
        let pcg = PcgSolver::new(mic)
            .with_negative_curvature(negative_curvature)
            .with_constraints(step.correction_constraints());
        let options = NewtonOptions {
            method: NewtonMethod::Inexact(ForcingTerm::Constant(1e-3)),
            rtol: 1e-9,
            atol: 0.0,
            max_iter: 200,
            ..Default::default()
        };
        let storage = step.jacobian_storage();
        (step, Newton::new(options, storage, pcg).unwrap())
    };
    let residual = |sys: &mut ClothStep, dv: &[f64]| {
        let mut g = vec![0.0; dv.len()];
        sys.residual(dv, &mut g).unwrap();
        g.iter().map(|x| x * x).sum::<f64>().sqrt()
    };
    let dim = 3 * n * n;

    // The clamped Jacobian: SPD.
    let (mut clamped, mut solver) = newton(NegativeCurvature::Error);
    let mut dv_clamped = vec![0.0; dim];
    let s_clamped = solver.solve(&mut clamped, &mut dv_clamped).unwrap();
    assert_eq!(s_clamped.truncated_solves, 0);

    // The exact Jacobian with PCG that fails on negative curvature.
    let (mut exact, mut solver) = newton(NegativeCurvature::Error);
    exact.clamp = false;
    let mut dv = vec![0.0; dim];
    match solver.solve(&mut exact, &mut dv) {
        Err(NonlinearError::Linear(hookean_sparse::SparseError::NotPositiveDefinite {
            ..
        })) => {}
        other => panic!("expected a negative curvature failure, got {other:?}"),
    }

    // Truncated PCG and the line search.
    let (mut exact, mut solver) = newton(NegativeCurvature::Truncate);
    exact.clamp = false;
    let mut dv_exact = vec![0.0; dim];
    let s_exact = solver.solve(&mut exact, &mut dv_exact).unwrap();
    assert!(s_exact.truncated_solves >= 1, "{s_exact:?}");
    assert!(residual(&mut exact, &dv_exact) <= 1e-9 * s_exact.initial_residual());

    // One root: the answers agree to what the tolerance allows. Near the
    // root G changes like J = M + h^2 K (the clamped stiffness only adds),
    // so |dv - dv*| <= |G(dv)| / m with m the particle mass; each answer is
    // within 1e-9 |G_0| / m, two of them within twice that.
    let m = 1.0 / (n * n) as f64;
    let bound = 2.0 * 1e-9 * s_clamped.initial_residual() / m;
    let diff = dv_exact
        .iter()
        .zip(&dv_clamped)
        .fold(0.0_f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(diff <= bound, "{diff} vs {bound}");
    eprintln!(
        "Newton iterations: clamped {}, exact with truncated PCG {} ({} truncated)",
        s_clamped.iterations, s_exact.iterations, s_exact.truncated_solves
    );
}
