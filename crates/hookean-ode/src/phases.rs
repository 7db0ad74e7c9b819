//! Where the implicit step's time goes: [`PhaseTimes`], summed over the
//! Newton solves of a run (wall clock, so never compared in tests).

use std::time::Duration;

/// Wall time spent in the phases of the Newton solves of implicit steps,
/// cumulative since the integrator was built. What a run's wall time has
/// besides these (force evaluations, vector updates, output) is the rest.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PhaseTimes {
    /// Forming the Newton matrices (e.g. `A = M - h df/dv - h^2 df/dx`).
    pub assembly: Duration,
    /// Setting up the linear solver for each new matrix (preconditioner
    /// set-up or refill, factorisation).
    pub setup: Duration,
    /// The linear solves (PCG iterations with their preconditioner applications).
    pub solve: Duration,
}

impl PhaseTimes {
    /// Adds the times of one Newton solve (seconds, as
    /// [`hookean_nonlinear::NewtonStats`] records them).
    pub fn add_seconds(&mut self, assembly: f64, setup: f64, solve: f64) {
        let d = |s: f64| Duration::from_secs_f64(s.max(0.0));
        self.assembly += d(assembly);
        self.setup += d(setup);
        self.solve += d(solve);
    }

    /// The sum of the three phases.
    pub fn total(&self) -> Duration {
        self.assembly + self.setup + self.solve
    }
}
