//! Assembly bar of issue 5: assembling `f`, `df/dx` and `df/dv` of a
//! 128 x 128 cloth must take at most 3x one SpMV of the resulting matrix
//! (one thread). Both are measured in one run; the ratio goes to
//! `docs/perf/hookean-massspring.md`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use hookean_massspring::{ClothParams, SecondOrderProblem, cloth};
use hookean_sparse::LinearOperator;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// A deterministic deformed state: every coordinate moved by up to `amp`
/// (a few percent of the grid spacing), velocities up to 0.1 m/s.
fn deformed(x: &mut [f64], v: &mut [f64], amp: f64) {
    let mut rng = SmallRng::seed_from_u64(0x9E37_79B9_7F4A_7C15);
    for xi in x.iter_mut() {
        *xi += amp * rng.random_range(-0.5..0.5);
    }
    for vi in v.iter_mut() {
        *vi = rng.random_range(-0.1..0.1);
    }
}

fn assembly(c: &mut Criterion) {
    for n in [64usize, 128] {
        let (model, mut state) = cloth(&ClothParams {
            nu: n,
            nv: n,
            ..Default::default()
        })
        .expect("valid cloth");
        let spacing = 1.0 / (n - 1) as f64;
        deformed(&mut state.x, &mut state.v, 0.1 * spacing);
        let (mut dfdx, mut dfdv) = model.new_jacobians();
        let mut f = vec![0.0; model.dim()];
        let mut y = vec![0.0; model.dim()];
        let mut group = c.benchmark_group(format!("cloth{n}x{n}"));
        group.sample_size(30);
        group.warm_up_time(std::time::Duration::from_secs(1));
        group.measurement_time(std::time::Duration::from_secs(3));
        group.bench_function(
            "assemble f + df/dx + df/dv (trait: force, force_jacobians)",
            |b| {
                b.iter(|| {
                    model.force(0.0, black_box(&state.x), black_box(&state.v), &mut f);
                    model.force_jacobians(0.0, &state.x, &state.v, &mut dfdx, &mut dfdv);
                    black_box((&f, &dfdx, &dfdv));
                })
            },
        );
        group.bench_function(
            "assemble f + df/dx + df/dv (fused force_and_jacobians)",
            |b| {
                b.iter(|| {
                    model.force_and_jacobians(
                        black_box(&state.x),
                        black_box(&state.v),
                        &mut f,
                        &mut dfdx,
                        &mut dfdv,
                    );
                    black_box((&f, &dfdx, &dfdv));
                })
            },
        );
        group.bench_function("df/dx + df/dv only", |b| {
            b.iter(|| {
                model.force_jacobians(0.0, black_box(&state.x), &state.v, &mut dfdx, &mut dfdv);
                black_box((&dfdx, &dfdv));
            })
        });
        group.bench_function("force f only", |b| {
            b.iter(|| {
                model.force(0.0, black_box(&state.x), black_box(&state.v), &mut f);
                black_box(&f);
            })
        });
        group.bench_function("spmv df/dx", |b| {
            b.iter(|| {
                dfdx.apply(black_box(&state.v), &mut y);
                black_box(&y);
            })
        });
        group.finish();
    }
}

criterion_group!(benches, assembly);
criterion_main!(benches);
