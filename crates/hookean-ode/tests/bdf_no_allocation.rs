//! The BDF solver's steps with the dense linear solver allocate nothing
//! unless they refactor the iteration matrix (faer's LU allocates its
//! factors). (The sparse path does allocate: faer's sparse triangular
//! solves take a fresh workspace per call in `hookean-nonlinear`'s `SparseLu`.)

use hookean_ode::BdfSolver;
use hookean_ode::testset::{Hires, SpringChain, TestProblem, options};
use hookean_testkit::alloc::{Counting, allocations};

#[global_allocator]
static GLOBAL: Counting = Counting;

fn check<P: TestProblem>(p: P) {
    let t_end = p.t_end();
    let opts = options(&p, 1e-6);
    let y0 = p.y0();
    let mut s = BdfSolver::new(p, 0.0, &y0, opts).unwrap();
    let mut quiet = 0;
    while s.t() < t_end {
        let setups = s.stats().num_lin_solv_setups;
        let (count, r) = allocations(|| s.step(t_end));
        r.unwrap();
        if s.stats().num_lin_solv_setups == setups {
            assert_eq!(
                count,
                0,
                "a step without factorisation allocated at t = {}",
                s.t()
            );
            quiet += 1;
        }
    }
    assert!(quiet > s.stats().num_steps / 2);
}

#[test]
fn steps_without_refactorisation_do_not_allocate() {
    check(Hires);
    check(SpringChain::new(false));
}
