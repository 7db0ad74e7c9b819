//! Fused assembly (`force_and_jacobians`) and one SpMV of the 128 x 128 cloth,
//! interleaved 1000 times, minimum of each and their ratio: both see the same
//! machine state, for A/B comparisons of builds on a shared machine (see
//! docs/perf/hookean-massspring.md):
//! `cargo run --release -p hookean-massspring --example assembly_interleaved [N]`
//! (an N x N cloth, default 128).
mod common;

use hookean_massspring::SecondOrderProblem;
use hookean_sparse::LinearOperator;
fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .map_or(128, |a| a.parse().expect("cloth size N"));
    let (model, s) = common::deformed_cloth(n);
    let (mut a, mut b) = model.new_jacobians();
    let mut f = vec![0.0; model.dim()];
    let mut y = vec![0.0; model.dim()];
    let (mut best, mut bs) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..1000 {
        let t = std::time::Instant::now();
        model.force_and_jacobians(&s.x, &s.v, &mut f, &mut a, &mut b);
        best = best.min(t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        a.apply(&s.v, &mut y);
        bs = bs.min(t.elapsed().as_secs_f64());
    }
    println!(
        "fused {:.3} ms spmv {:.3} ms ratio {:.2}",
        best * 1e3,
        bs * 1e3,
        best / bs
    );
}
