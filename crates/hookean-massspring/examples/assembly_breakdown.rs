//! Breakdown of the 128 x 128 cloth assembly (force, Jacobians, fused sweep, a pure
//! store floor, one SpMV), best of 100 runs each, for docs/perf/hookean-massspring.md:
//! `cargo run --release -p hookean-massspring --example assembly_breakdown`.
mod common;

use hookean_massspring::SecondOrderProblem;
use hookean_sparse::LinearOperator;
use std::time::Instant;
fn main() {
    let (model, s) = common::deformed_cloth(128);
    let (mut a, mut b) = model.new_jacobians();
    let mut f = vec![0.0; model.dim()];
    let mut y = vec![0.0; model.dim()];
    let reps = 100;
    let time = |name: &str, g: &mut dyn FnMut()| {
        g();
        let mut best = f64::INFINITY;
        for _ in 0..reps {
            let t = Instant::now();
            g();
            best = best.min(t.elapsed().as_secs_f64());
        }
        println!("{name}: {:.3} ms (min of {reps})", best * 1e3);
    };
    time("set_zero x2", &mut || {
        a.set_zero();
        b.set_zero();
    });
    time("force", &mut || model.force(0.0, &s.x, &s.v, &mut f));
    time("jacobians", &mut || {
        model.force_jacobians(0.0, &s.x, &s.v, &mut a, &mut b)
    });
    time("fused f+jacobians", &mut || {
        model.force_and_jacobians(&s.x, &s.v, &mut f, &mut a, &mut b)
    });
    time(
        "write floor: store every block of both matrices",
        &mut || {
            for (k, blk) in a.values_mut().iter_mut().enumerate() {
                let t = k as f64;
                *blk = [[t, 1.0, 2.0], [3.0, t, 4.0], [5.0, 6.0, t]];
            }
            for (k, blk) in b.values_mut().iter_mut().enumerate() {
                let t = k as f64;
                *blk = [[t, 1.0, 2.0], [3.0, t, 4.0], [5.0, 6.0, t]];
            }
        },
    );
    time("spmv", &mut || a.apply(&s.v, &mut y));
    println!("springs {}", model.springs().len());
    let mut m2 = model.clone();
    m2.set_options(hookean_massspring::ModelOptions {
        damping: hookean_massspring::SpringDamping::None,
        ..*model.options()
    })
    .unwrap();
    time("jacobians (no damping: dfdv zero only)", &mut || {
        m2.force_jacobians(0.0, &s.x, &s.v, &mut a, &mut b)
    });
}
