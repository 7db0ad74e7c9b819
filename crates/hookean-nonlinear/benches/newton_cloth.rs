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

criterion_group!(benches, bench);
criterion_main!(benches);
