//! The costs of re-using a multigrid hierarchy on the testkit's cloth
//! (N = 128, k = 1e4, h = 0.01, 49 152 unknowns), next to MIC(0):
//! a full AMG set-up (`rebuild`), a refill of the values on the same
//! pattern (`setup` again; also keeping the prolongators, or the spectral
//! radius estimates), one V-cycle, and PCG to `|r| <= 1e-8 |b|` with
//! each preconditioner. Re-using the hierarchy for several steps costs
//! nothing at set-up (only the extra PCG iterations of a lagged preconditioner).
//!
//! `cargo bench -p hookean-sparse --bench amg`

use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use hookean_sparse::{
    Amg, AmgOptions, CgParams, CgWorkspace, IncompleteCholesky, PrecondKind, Preconditioner,
    PreconditionerSetup, pcg,
};
use hookean_testkit::cloth::{ClothSystemParams, cloth_system};

fn bench(c: &mut Criterion) {
    let (a, b) = cloth_system(&ClothSystemParams {
        n: 128,
        k: 1e4,
        ..Default::default()
    });
    let n = b.len();
    let mut group = c.benchmark_group("cloth128_k1e4");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    group.measurement_time(Duration::from_secs(4));

    let mut amg = Amg::new();
    amg.setup(&a).unwrap();
    group.bench_function("amg_rebuild", |bench| {
        bench.iter(|| amg.rebuild(&a).unwrap())
    });
    group.bench_function("amg_refill", |bench| bench.iter(|| amg.setup(&a).unwrap()));
    let mut keep = Amg::with_options(AmgOptions {
        keep_prolongators: true,
        ..Default::default()
    })
    .unwrap();
    keep.setup(&a).unwrap();
    group.bench_function("amg_refill_keep_prolongators", |bench| {
        bench.iter(|| keep.setup(&a).unwrap())
    });
    let mut keep_rho = Amg::with_options(AmgOptions {
        refill_power_iterations: 0,
        ..Default::default()
    })
    .unwrap();
    keep_rho.setup(&a).unwrap();
    group.bench_function("amg_refill_no_power_steps", |bench| {
        bench.iter(|| keep_rho.setup(&a).unwrap())
    });
    let mut z = vec![0.0; n];
    group.bench_function("amg_vcycle", |bench| bench.iter(|| amg.apply(&b, &mut z)));
    let mut mic = IncompleteCholesky::modified(PrecondKind::MIC_OMEGA).unwrap();
    group.bench_function("mic0_setup", |bench| bench.iter(|| mic.setup(&a).unwrap()));
    let mut ws = CgWorkspace::new(n);
    let mut x = vec![0.0; n];
    let params = CgParams::default();
    group.bench_function("amg_pcg", |bench| {
        bench.iter(|| pcg(&a, &amg, &b, &mut x, &params, &mut ws, None).unwrap())
    });
    group.bench_function("mic0_pcg", |bench| {
        bench.iter(|| pcg(&a, &mic, &b, &mut x, &params, &mut ws, None).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
