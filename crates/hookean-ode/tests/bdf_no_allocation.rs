//! The variable-order BDF's steps with the dense linear solver allocate
//! nothing once the first step has sized Newton's work vectors,
//! refactorisations included (`hookean-nonlinear`'s `DenseLu` factors in
//! place into storage it keeps). Two exceptions, not the solver's hot
//! path: a step whose Newton attempt failed allocates the failure's report
//! (a boxed `NewtonStats`), and a step that evaluates the Jacobian runs the
//! problem's code (the spring chain's `jacobian` allocates).
//! (The sparse path allocates when it refactors: faer's sparse LU
//! allocates its factors.)

use hookean_ode::testset::{Hires, SpringChain, TestProblem, options};
use hookean_ode::{FirstOrderIntegrator, Integrator, Method};
use hookean_testkit::alloc::{Counting, allocations};

#[global_allocator]
static GLOBAL: Counting = Counting;

fn check<P: TestProblem + Send + 'static>(p: P) {
    let t_end = p.t_end();
    let opts = options(&p, 1e-6);
    let y0 = p.y0();
    let mut s = FirstOrderIntegrator::new(p, Method::variable_bdf(), 0.0, &y0, opts).unwrap();
    s.step_to(t_end).unwrap();
    let (mut refactored, mut checked) = (0, 0);
    while s.t() < t_end {
        let before = s.stats();
        let (count, r) = allocations(|| s.step_to(t_end));
        r.unwrap();
        let after = s.stats();
        if after.num_nonlin_solv_conv_fails > before.num_nonlin_solv_conv_fails
            || after.num_jac_evals > before.num_jac_evals
        {
            continue;
        }
        refactored += usize::from(after.num_lin_solv_setups > before.num_lin_solv_setups);
        checked += 1;
        assert_eq!(count, 0, "a step allocated at t = {}", s.t());
    }
    // The claim covers steps that refactor the Newton matrix, and nearly all steps.
    assert!(refactored > 0);
    assert!(checked > 9 * s.stats().num_steps / 10, "{checked}");
}

#[test]
fn steps_do_not_allocate() {
    check(Hires);
    check(SpringChain::new(false));
}
