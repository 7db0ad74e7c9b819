//! Cost of one integrator step: implicit methods in the reduced velocity
//! form on a 200-particle spring chain (one end pinned, k = 1e4, h = 1e-2,
//! Newton to a relative residual of 1e-6, PCG with block-Jacobi to 1e-8),
//! explicit and symplectic methods on the same chain at h = 1e-4.
//! Prints the Newton and PCG iterations per step of the warm-up to stderr.

use criterion::{Criterion, criterion_group, criterion_main};
use hookean_ode::Integrator;
use hookean_ode::{Method, NewtonOptions, SecondOrderIntegrator, SolverOptions};
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
        let opts = SolverOptions {
            h,
            newton: NewtonOptions {
                rtol: 1e-6,
                atol: 1e-10,
                max_iter: 20,
                linear_rtol: 1e-8,
                ..SolverOptions::default_newton()
            },
            ..SolverOptions::default()
        };
        let mut ode =
            SecondOrderIntegrator::new(problem, method, 0.0, &x0, &v0, opts).expect("valid set-up");
        // Warm up past any startup phase.
        for _ in 0..20 {
            ode.step().expect("step");
        }
        let s = ode.stats();
        eprintln!(
            "{name}: per step {:.1} Newton iterations, {:.1} PCG iterations, {:.1} force evaluations",
            s.num_nonlin_solv_iters as f64 / s.num_steps as f64,
            s.num_lin_iters as f64 / s.num_steps as f64,
            s.num_rhs_evals_total() as f64 / s.num_steps as f64
        );
        group.bench_function(name, |b| b.iter(|| ode.step().expect("step")));
    }
    group.finish();
}

criterion_group!(benches, bench_steps);
criterion_main!(benches);
