//! Drapes the reference cloth and prints what it cost:
//!
//! ```text
//! cargo run --release -p hookean --example drape -- [N] [SECONDS]
//! ```

use std::ops::ControlFlow;

use hookean::prelude::*;

fn main() -> Result<(), HookeanError> {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(64);
    let seconds: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let (model, state) = cloth(&ClothParams {
        nu: n,
        nv: n,
        ..Default::default()
    })?;
    let mut sim = Simulation::new(model, state, SimulationOptions::default())?;
    let summary = sim.run_until(seconds, |_, _| ControlFlow::Continue(()))?;
    let s = summary.stats;
    println!(
        "{n}x{n} drape, {seconds} s: {} steps, {} Newton, {} CG iterations, wall {:.2} s, {:.2} simulated s per wall s",
        s.steps,
        s.newton_iterations,
        s.linear_iterations,
        summary.wall.as_secs_f64(),
        summary.speed()
    );
    let lowest = sim.x().chunks(3).map(|p| p[2]).fold(f64::INFINITY, f64::min);
    println!("lowest point z = {lowest:.3} m");
    Ok(())
}
