//! Time per solved implicit Euler step of the reference drape scene
//! (N = 64, k = 1e4, d = 0.1, h = 0.01, at rest from a grid jittered by
//! 0.02 spacings, two corners pinned) for each Newton variant, block-Jacobi
//! PCG, Newton stopping at `|G| <= 1e-3 |G_0|` (the loose accuracy cloth
//! simulators use; Eisenstat-Walker choice 1 diverges on this step and is
//! left out).
//!
//! `cargo bench -p hookean-nonlinear --bench newton_cloth`

#[path = "../tests/common/cloth.rs"]
mod cloth;

use std::time::Duration;

use cloth::{ClothStep, LinearizedCloth};
use criterion::{Criterion, criterion_group, criterion_main};
use hookean_nonlinear::*;
use hookean_sparse::BlockJacobi;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("drape64_step");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(5));
    let variants: [(&str, NewtonMethod, bool); 6] = [
        ("exact", NewtonMethod::Exact, false),
        (
            "inexact_eta0.02",
            NewtonMethod::Inexact(ForcingTerm::TUTORIAL),
            false,
        ),
        (
            "inexact_ew2",
            NewtonMethod::Inexact(ForcingTerm::EW2_DEFAULT),
            false,
        ),
        ("simplified", NewtonMethod::Simplified, false),
        (
            "inexact_simplified_eq50",
            NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
            false,
        ),
        (
            "inexact_simplified_eq50_kept",
            NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
            true,
        ),
    ];
    for (name, method, keep) in variants {
        let mut sys = ClothStep::new(64, 1e4, 0.1, 0.01, 0.02, 7);
        let pcg = PcgSolver::new(BlockJacobi::new()).with_constraints(sys.correction_constraints());
        let options = NewtonOptions {
            method,
            rtol: 1e-3,
            atol: 0.0,
            max_iter: 200,
            ..Default::default()
        };
        let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
        let mut dv = vec![0.0; sys.dim()];
        newton
            .solve(&mut sys, &mut dv)
            .expect("the variant converges on this step");
        group.bench_function(name, |b| {
            b.iter(|| {
                dv.fill(0.0);
                if !keep {
                    newton.invalidate_jacobian();
                }
                newton.solve(&mut sys, &mut dv).unwrap()
            })
        });
    }
    {
        // eq. (50) in isotropic-block storage, Jacobian kept across solves.
        let mut step = ClothStep::new(64, 1e4, 0.1, 0.01, 0.02, 7);
        let pcg =
            PcgSolver::new(BlockJacobi::new()).with_constraints(step.correction_constraints());
        let mut sys = LinearizedCloth(&mut step);
        let options = NewtonOptions {
            method: NewtonMethod::InexactSimplified(ForcingTerm::TUTORIAL),
            rtol: 1e-3,
            atol: 0.0,
            max_iter: 200,
            ..Default::default()
        };
        let mut newton = Newton::new(options, sys.jacobian_storage(), pcg).unwrap();
        let mut dv = vec![0.0; sys.dim()];
        newton
            .solve(&mut sys, &mut dv)
            .expect("the variant converges on this step");
        group.bench_function("inexact_simplified_eq50_iso_kept", |b| {
            b.iter(|| {
                dv.fill(0.0);
                newton.solve(&mut sys, &mut dv).unwrap()
            })
        });
    }
    group.finish();
}

/// The tutorial's claim for eq. (50): a CG iteration on the linearised
/// Jacobian costs a third when only its nonzeros are stored. 50 PCG
/// iterations (block-Jacobi, tolerance 0 so all 50 run) on the same matrix
/// in 3x3-block and in isotropic storage, and on the full Jacobian.
fn cg_iterations(c: &mut Criterion) {
    use hookean_sparse::{CgParams, CgWorkspace, PreconditionerSetup, pcg};
    let mut group = c.benchmark_group("drape64_50_pcg_iterations");
    group.sample_size(20);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(3));
    let mut step = ClothStep::new(64, 1e4, 0.1, 0.01, 0.02, 7);
    let n = step.dim();
    let dv = vec![0.0; n];
    let mut full = step.jacobian_storage();
    step.jacobian(&dv, &mut full).unwrap();
    let mut lin_block = step.jacobian_storage();
    step.approximate_jacobian(&dv, &mut lin_block).unwrap();
    let mut lin_iso = LinearizedCloth(&mut step).jacobian_storage();
    LinearizedCloth(&mut step)
        .jacobian(&dv, &mut lin_iso)
        .unwrap();
    let b: Vec<f64> = (0..n).map(|i| ((i % 7) as f64 - 3.0) * 1e-3).collect();
    let params = CgParams {
        rtol: 0.0,
        max_iter: Some(50),
        ..Default::default()
    };
    let mut ws = CgWorkspace::new(n);
    let mut x = vec![0.0; n];
    let mut p_full = BlockJacobi::new();
    p_full.setup(&full).unwrap();
    group.bench_function("full_jacobian_block_storage", |bch| {
        bch.iter(|| pcg(&full, &p_full, &b, &mut x, &params, &mut ws, None).unwrap())
    });
    let mut p_lb = BlockJacobi::new();
    p_lb.setup(&lin_block).unwrap();
    group.bench_function("eq50_block_storage", |bch| {
        bch.iter(|| pcg(&lin_block, &p_lb, &b, &mut x, &params, &mut ws, None).unwrap())
    });
    let mut p_li = BlockJacobi::new();
    p_li.setup(&lin_iso).unwrap();
    group.bench_function("eq50_isotropic_storage", |bch| {
        bch.iter(|| pcg(&lin_iso, &p_li, &b, &mut x, &params, &mut ws, None).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench, cg_iterations);
criterion_main!(benches);
