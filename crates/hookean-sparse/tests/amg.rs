//! Smoothed-aggregation AMG as a PCG preconditioner on the reference cloth
//! systems: iteration counts bounded independently of size and stiffness.

use hookean_sparse::{
    Amg, AmgOptions, AmgSmoother, CgParams, CgWorkspace, LinearOperator, PreconditionerSetup, pcg,
    vecops::norm2,
};
use hookean_testkit::cloth::{ClothParams, cloth_system};

/// PCG iterations to `|r| <= 1e-8 |b|`, after checking the true residual.
fn iterations(n: usize, k: f64, options: &AmgOptions) -> usize {
    let (a, b) = cloth_system(&ClothParams {
        n,
        k,
        ..Default::default()
    });
    let mut amg = Amg::with_options(options.clone()).unwrap();
    amg.setup(&a).unwrap();
    let mut x = vec![0.0; b.len()];
    let info = pcg(
        &a,
        &amg,
        &b,
        &mut x,
        &CgParams::default(),
        &mut CgWorkspace::new(b.len()),
        None,
    )
    .unwrap();
    let mut ax = vec![0.0; b.len()];
    a.apply(&x, &mut ax);
    let res: Vec<f64> = ax.iter().zip(&b).map(|(p, q)| p - q).collect();
    assert!(info.converged);
    assert!(norm2(&res) <= 1.01e-8 * norm2(&b));
    let stats = amg.stats();
    assert!(stats.levels.len() >= 2);
    assert!(
        stats.operator_complexity < 2.0,
        "operator complexity {}",
        stats.operator_complexity
    );
    info.iterations
}

#[test]
fn amg_pcg_iterations_on_cloth_are_bounded() {
    for smoother in [AmgSmoother::BlockJacobi, AmgSmoother::SymmetricGaussSeidel] {
        let options = AmgOptions {
            smoother,
            ..Default::default()
        };
        for k in [1e2, 1e4, 1e6] {
            let its: Vec<usize> = [24, 64]
                .iter()
                .map(|&n| iterations(n, k, &options))
                .collect();
            assert!(
                its.iter().all(|&i| i <= 30),
                "{smoother:?}, k = {k}: {its:?}"
            );
            // Multigrid: the count does not grow like an incomplete factorisation's.
            assert!(
                2 * its[1] <= 3 * its[0].max(10),
                "{smoother:?}, k = {k}: {its:?}"
            );
        }
    }
}

/// The 7-point Laplacian on an `n^3` grid with Dirichlet boundary, scalar CSR.
fn poisson3d(n: usize) -> sprs::CsMat<f64> {
    let size = n * n * n;
    let mut t = sprs::TriMat::new((size, size));
    for p in 0..size {
        let (x, y, z) = (p % n, (p / n) % n, p / (n * n));
        t.add_triplet(p, p, 6.0);
        for (d, stride) in [(x, 1), (y, n), (z, n * n)] {
            if d > 0 {
                t.add_triplet(p, p - stride, -1.0);
            }
            if d + 1 < n {
                t.add_triplet(p, p + stride, -1.0);
            }
        }
    }
    t.to_csr()
}

#[test]
fn scalar_amg_pcg_on_3d_poisson_needs_at_most_40_iterations() {
    let a = poisson3d(40);
    let n = a.rows();
    let b: Vec<f64> = (0..n).map(|i| ((i * 13 + 5) as f64 * 0.17).sin()).collect();
    let mut amg = Amg::new();
    amg.setup(&a).unwrap();
    assert!(amg.stats().levels.len() >= 3, "{:?}", amg.stats());
    let mut x = vec![0.0; n];
    let info = pcg(
        &a,
        &amg,
        &b,
        &mut x,
        &CgParams::default(),
        &mut CgWorkspace::new(n),
        None,
    )
    .unwrap();
    let mut ax = vec![0.0; n];
    a.apply(&x, &mut ax);
    let res: Vec<f64> = ax.iter().zip(&b).map(|(p, q)| p - q).collect();
    assert!(norm2(&res) <= 1.01e-8 * norm2(&b));
    assert!(info.iterations <= 40, "{} iterations", info.iterations);
}
