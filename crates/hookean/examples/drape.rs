//! Drapes the reference cloth and prints what it cost:
//!
//! ```text
//! [PREVIOUS=1] [COLD=1] [SYM=1] cargo run --release -p hookean --example drape -- \
//!     [N] [SECONDS] [NEWTON_RTOL] [PRECOND] [ETA] [H] [ATOL]
//! ```
//!
//! Defaults: the drape scene's settings ([`SimulationOptions::default`]),
//! except the Newton start: `PREVIOUS=1` starts from the current velocity
//! (as the scene does), without it from the extrapolated one
//! (`Predictor::Extrapolate`); `COLD=1` starts every PCG solve from zero
//! (no warm start); `SYM=1`
//! keeps the symmetric part of the damping term in `df/dx`. The tables of
//! docs/PERFORMANCE.md that chose the scene's settings come from this program.

use hookean::prelude::*;

fn main() -> Result<(), HookeanError> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(64);
    let seconds: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let mut params = ClothParams {
        nu: n,
        nv: n,
        ..Default::default()
    };
    if std::env::var("SYM").is_ok() {
        params.options.damping_in_dfdx = hookean::massspring::DampingInDfdx::Symmetrize;
    }
    let (model, state) = cloth(&params)?;
    let mut options = SimulationOptions::default();
    if let Some(r) = args.next().and_then(|s| s.parse().ok()) {
        options.solver.newton.rtol = r;
    }
    if let Some(p) = args.next().and_then(|s| s.parse::<PrecondKind>().ok()) {
        options.solver.linear.preconditioner = p.into();
    }
    if let Some(f) = args.next().and_then(|s| s.parse().ok()) {
        options.solver.newton.method =
            hookean::ode::NewtonMethod::Inexact(hookean::ode::ForcingTerm::Constant(f));
    }
    if let Some(h) = args.next().and_then(|s| s.parse().ok()) {
        options.solver.h = h;
    }
    if let Some(a) = args.next().and_then(|s| s.parse().ok()) {
        options.solver.newton.atol = a;
    }
    if std::env::var("COLD").is_ok() {
        options.solver.warm_start = false;
    }
    options.solver.predictor = if std::env::var("PREVIOUS").is_ok() {
        hookean::ode::Predictor::Previous
    } else {
        hookean::ode::Predictor::Extrapolate
    };
    let mut sim = Simulation::new(model, state, options)?;
    let summary = sim.run_until(seconds)?;
    let s = summary.stats;
    println!(
        "{n}x{n} drape, {seconds} s: {} steps, {} Newton, {} CG iterations, wall {:.2} s, {:.2} simulated s per wall s",
        s.num_steps,
        s.num_nonlin_solv_iters,
        s.num_lin_iters,
        summary.wall.as_secs_f64(),
        summary.speed()
    );
    let lowest = sim
        .x()
        .chunks(3)
        .map(|p| p[2])
        .fold(f64::INFINITY, f64::min);
    let mean = sim.x().chunks(3).map(|p| p[2]).sum::<f64>() / (n * n) as f64;
    let e = sim.energies()?;
    println!(
        "lowest point z = {lowest:.4} m, mean z = {mean:.4} m, kinetic {:.3} J, total {:.3} J",
        e.kinetic,
        e.total()
    );
    Ok(())
}
