//! Cost of one integrator step: implicit methods in the reduced velocity
//! form on a 200-particle spring chain (one end pinned, k = 1e4, h = 1e-2),
//! explicit and symplectic methods on the same chain at h = 1e-4.

use criterion::{Criterion, criterion_group, criterion_main};
use hookean_ode::{Method, SecondOrderIntegrator, SolverOptions};
use hookean_testkit::springs::SpringChain;

fn chain() -> SpringChain {
    let mut c = SpringChain::new(200, 0.005, 1e4, 0.1, 0.01, 9.81);
    c.pinned = vec![0];
    c
}

fn bench_steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("step_chain200");
    group.sample_size(20);
    for (name, h) in [
        ("implicit-euler", 1e-2),
        ("implicit-midpoint", 1e-2),
        ("bdf2", 1e-2),
        ("rk4", 1e-4),
        ("verlet", 1e-4),
        ("fb-euler", 1e-4),
    ] {
        let method: Method = name.parse().expect("known method");
        let problem = chain();
        let (x0, v0) = problem.initial_state(1.0);
        let mut ode =
            SecondOrderIntegrator::new(problem, method, 0.0, &x0, &v0, SolverOptions::with_h(h))
                .expect("valid set-up");
        // Warm up past any startup phase.
        for _ in 0..5 {
            ode.step().expect("step");
        }
        group.bench_function(name, |b| b.iter(|| ode.step().expect("step")));
    }
    group.finish();
}

criterion_group!(benches, bench_steps);
criterion_main!(benches);
