//! PCG against faer's sparse Cholesky on random SPD matrices (proptest), and
//! on the reference cloth systems with every preconditioner.

use hookean_sparse::{
    AnyPreconditioner, CgParams, CgWorkspace, DirectCholesky, LinearOperator, PrecondKind,
    PreconditionerSetup, SymBlockMatrix, pcg, vecops::norm2,
};
use hookean_testkit::cloth::{ClothSystemParams, cloth_system};
use hookean_testkit::random::random_spd;
use proptest::prelude::*;

fn true_relative_residual<A: LinearOperator>(a: &A, x: &[f64], b: &[f64]) -> f64 {
    let mut ax = vec![0.0; b.len()];
    a.apply(x, &mut ax);
    let r: Vec<f64> = ax.iter().zip(b).map(|(p, q)| q - p).collect();
    norm2(&r) / norm2(b)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Every preconditioner, on CSR and (for block-aligned sizes) on the
    /// block matrix, reaches the direct solution to the accuracy its
    /// residual promises: |x - x*| <= cond * |r| / |b| |x*| in the worst case;
    /// these matrices are well conditioned, so 1e-6 relative is ample at rtol 1e-10.
    #[test]
    fn pcg_matches_sparse_cholesky(nb in 2usize..40, per_row in 2usize..8, seed in any::<u64>()) {
        let n = 3 * nb;
        let a = random_spd(n, per_row, 1.2, seed);
        let b: Vec<f64> = (0..n).map(|i| ((i as f64 + seed as f64 % 7.0) * 0.7).sin()).collect();
        let mut direct = DirectCholesky::new();
        direct.factor_csr(&a).unwrap();
        let mut exact = vec![0.0; n];
        direct.solve(&b, &mut exact).unwrap();
        let block = SymBlockMatrix::from_csr(&a).unwrap();
        let params = CgParams { rtol: 1e-10, ..Default::default() };
        let mut ws = CgWorkspace::new(n);
        for kind in PrecondKind::all(1.3) {
            let mut p = AnyPreconditioner::new(kind).unwrap();
            p.setup(&a).unwrap();
            let mut x = vec![0.0; n];
            let info = pcg(&a, &p, &b, &mut x, &params, &mut ws, None).unwrap();
            prop_assert!(info.converged, "{} on CSR", kind);
            prop_assert!(true_relative_residual(&a, &x, &b) < 1e-9);
            prop_assert!(hookean_testkit::dense::rel_diff(&x, &exact) < 1e-6, "{} on CSR", kind);

            let mut p = AnyPreconditioner::new(kind).unwrap();
            p.setup(&block).unwrap();
            let mut xb = vec![0.0; n];
            let info = pcg(&block, &p, &b, &mut xb, &params, &mut ws, None).unwrap();
            prop_assert!(info.converged, "{} on blocks", kind);
            prop_assert!(hookean_testkit::dense::rel_diff(&xb, &exact) < 1e-6, "{} on blocks", kind);
        }
    }
}

#[test]
fn every_preconditioner_solves_the_reference_cloth_system() {
    let (a, b) = cloth_system(&ClothSystemParams {
        n: 16,
        ..Default::default()
    });
    let mut direct = DirectCholesky::new();
    direct.factor_block(&a).unwrap();
    let mut exact = vec![0.0; a.dim()];
    direct.solve(&b, &mut exact).unwrap();
    let mut iterations = Vec::new();
    for kind in PrecondKind::all(1.0) {
        let mut p = AnyPreconditioner::new(kind).unwrap();
        p.setup(&a).unwrap();
        let mut x = vec![0.0; a.dim()];
        let info = pcg(
            &a,
            &p,
            &b,
            &mut x,
            &CgParams::default(),
            &mut CgWorkspace::new(a.dim()),
            None,
        )
        .unwrap();
        assert!(info.converged, "{kind}");
        assert!(true_relative_residual(&a, &x, &b) < 1e-8 * 1.01, "{kind}");
        iterations.push(info.iterations);
    }
    // Stronger preconditioners need fewer iterations on this SPD M-matrix-like
    // system: IC(0) and SSOR beat the diagonal ones, all beat none, and
    // multigrid beats IC(0).
    let [none, jacobi, block_jacobi, ssor, ic0, amg] = iterations[..] else {
        unreachable!()
    };
    assert!(
        ic0 < jacobi && ssor < jacobi && block_jacobi <= jacobi && jacobi <= none && amg < ic0,
        "{iterations:?}"
    );
}

#[test]
fn refilled_matrix_reuses_the_preconditioner_pattern_and_stays_exact() {
    // Setup, refill with new values, setup again: results match a fresh setup.
    let (mut a, b) = cloth_system(&ClothSystemParams {
        n: 8,
        ..Default::default()
    });
    for kind in PrecondKind::all(1.4) {
        let mut reused = AnyPreconditioner::new(kind).unwrap();
        reused.setup(&a).unwrap();
        let mut a2 = a.clone();
        a2.scale(1.7);
        reused.setup(&a2).unwrap();
        let mut fresh = AnyPreconditioner::new(kind).unwrap();
        fresh.setup(&a2).unwrap();
        let (mut z1, mut z2) = (vec![0.0; b.len()], vec![0.0; b.len()]);
        use hookean_sparse::Preconditioner;
        reused.apply(&b, &mut z1);
        fresh.apply(&b, &mut z2);
        if kind == PrecondKind::Amg {
            // The multigrid's refill keeps the aggregates (the same here:
            // scaling keeps the strong graph) but continues its spectral
            // radius estimates from the last eigenvectors, so its weights,
            // and the result, differ slightly from a fresh set-up.
            let diff: f64 = z1.iter().zip(&z2).map(|(u, v)| (u - v) * (u - v)).sum();
            let norm: f64 = z2.iter().map(|v| v * v).sum();
            assert!(diff.sqrt() < 0.05 * norm.sqrt(), "{kind}");
        } else {
            assert_eq!(z1, z2, "{kind}");
        }
    }
    a.set_zero();
    assert!(a.values().iter().flatten().flatten().all(|&v| v == 0.0));
}
