//! Robertson's stiff kinetics with the variable-order BDF: the solution at
//! requested times and the solver's statistics. `cargo run --example robertson`

use hookean::ode::{FirstOrderIntegrator, FirstOrderProblem, Integrator, Method, OdeError};
use hookean::ode::{SolverOptions, Tolerance};

/// y1' = -0.04 y1 + 1e4 y2 y3, y2' = 0.04 y1 - 1e4 y2 y3 - 3e7 y2^2, y3' = 3e7 y2^2.
struct Robertson;

impl FirstOrderProblem for Robertson {
    fn dim(&self) -> usize {
        3
    }
    fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) {
        let (a, b) = (0.04 * y[0] - 1e4 * y[1] * y[2], 3e7 * y[1] * y[1]);
        dy.copy_from_slice(&[-a, a - b, b]);
    }
    fn jacobian(&self, _t: f64, y: &[f64], j: &mut [f64]) -> bool {
        let (p, q, r) = (1e4 * y[2], 1e4 * y[1], 6e7 * y[1]);
        j.copy_from_slice(&[-0.04, p, q, 0.04, -p - r, -q, 0.0, r, 0.0]);
        true
    }
}

fn main() -> Result<(), OdeError> {
    // y2 is about 1e-5: it needs its own absolute tolerance (as in CVODE's example).
    let options = SolverOptions::with_tolerances(1e-4, Tolerance::Vector(vec![1e-8, 1e-14, 1e-6]));
    let y0 = [1.0, 0.0, 0.0];
    let mut solver =
        FirstOrderIntegrator::new(Robertson, Method::variable_bdf(), 0.0, &y0, options)?;
    let times = [0.4, 4.0, 40.0, 400.0, 4e3, 4e4, 4e5];
    let solution = solver.solve_at(&times)?;
    for (t, y) in solution.t.iter().zip(solution.values.chunks(3)) {
        println!("t = {t:8.1e}  y = {:.6e} {:.6e} {:.6e}", y[0], y[1], y[2]);
    }
    let s = solution.stats;
    let (steps, newton, lus) = (s.num_steps, s.num_nonlin_solv_iters, s.num_lin_solv_setups);
    println!("{steps} steps, {newton} Newton iterations, {lus} LU factorisations");
    Ok(())
}
