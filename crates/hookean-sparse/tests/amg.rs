//! Smoothed-aggregation AMG as a PCG preconditioner on the reference cloth
//! systems: iteration counts bounded independently of size and stiffness.

use hookean_sparse::{
    Amg, AmgOptions, AmgSmoother, CgParams, CgWorkspace, Constraints, LinearOperator,
    PreconditionerSetup, filtered_pcg, pcg, vecops::norm2,
};
use hookean_testkit::cloth::{ClothSystemParams, cloth_system};

/// PCG iterations to `|r| <= 1e-8 |b|`, after checking the true residual.
fn iterations(n: usize, k: f64, options: &AmgOptions) -> usize {
    let (a, b) = cloth_system(&ClothSystemParams {
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
    for smoother in [
        AmgSmoother::BlockJacobi,
        AmgSmoother::SymmetricGaussSeidel,
        AmgSmoother::BlockIc0,
    ] {
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

#[test]
fn filtered_pcg_with_amg_honours_constraints_in_few_iterations() {
    // The V-cycle is SPD, so Baraff-Witkin's filtered PCG stays valid.
    let n = 48;
    let (a, b) = cloth_system(&ClothSystemParams {
        n,
        ..Default::default()
    });
    let mut constraints = Constraints::new(a.n_blocks());
    constraints.pin(n * (n - 1), [0.0; 3]).unwrap();
    constraints.pin(n * n - 1, [0.0; 3]).unwrap();
    constraints.constrain(n / 2, [0.0, 0.0, 1.0], 1e-3).unwrap();
    let mut amg = Amg::new();
    amg.setup(&a).unwrap();
    assert!(amg.stats().levels.len() >= 2);
    let mut x = vec![0.0; b.len()];
    let info = filtered_pcg(
        &a,
        &amg,
        &b,
        &mut x,
        &constraints,
        &CgParams::default(),
        &mut CgWorkspace::new(b.len()),
        None,
    )
    .unwrap();
    assert!(info.converged);
    assert!(constraints.violation(&x) < 1e-12);
    // The filtered residual P (b - A x) meets the tolerance.
    let mut r = vec![0.0; b.len()];
    a.apply(&x, &mut r);
    r.iter_mut().zip(&b).for_each(|(r, b)| *r = b - *r);
    constraints.project(&mut r);
    let mut pb = b.clone();
    constraints.project(&mut pb);
    assert!(norm2(&r) <= 1.01e-8 * norm2(&pb));
    // The V-cycle does not know the constraints (filtered PCG applies
    // P M^-1 P), so a few more iterations than unconstrained PCG, not many.
    let free = iterations(n, 1e4, &AmgOptions::default());
    assert!(
        info.iterations <= 2 * free,
        "{} filtered against {free} unconstrained",
        info.iterations
    );
}

/// Every kernel of the set-up, the refill and the V-cycle writes only its
/// own rows with the same sequential arithmetic whatever the split: on a
/// cloth of 72 x 72 particles (5 184 block rows, more than one rayon task's
/// 1 024) one, two and three threads give the same bits.
#[test]
fn amg_gives_the_same_bits_for_one_two_and_three_threads() {
    let (mut a, b) = cloth_system(&ClothSystemParams {
        n: 72,
        k: 1e4,
        ..Default::default()
    });
    let run = |threads: usize, a: &hookean_sparse::SymBlockMatrix, amg: &mut Amg| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                amg.setup(a).unwrap();
                let mut z = vec![0.0; b.len()];
                hookean_sparse::Preconditioner::apply(&*amg, &b, &mut z);
                z
            })
    };
    let (mut one, mut two, mut three) = (Amg::new(), Amg::new(), Amg::new());
    let z1 = run(1, &a, &mut one);
    let z2 = run(2, &a, &mut two);
    let z3 = run(3, &a, &mut three);
    assert!(z1.iter().all(|v| v.is_finite()) && norm2(&z1) > 0.0);
    assert_eq!(z1, z2, "full set-up, 2 threads");
    assert_eq!(z1, z3, "full set-up, 3 threads");
    // A refill with new values (same pattern).
    a.scale(1.5);
    let z1 = run(1, &a, &mut one);
    let z2 = run(2, &a, &mut two);
    let z3 = run(3, &a, &mut three);
    assert_eq!(one.stats().refills, 1, "{:?}", one.stats());
    assert_eq!(z1, z2, "refill, 2 threads");
    assert_eq!(z1, z3, "refill, 3 threads");
}
