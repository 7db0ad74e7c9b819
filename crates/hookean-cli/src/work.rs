//! The cap on a command's work. Every command that simulates estimates its
//! work before it starts, in particle-steps (particles times time steps),
//! and refuses an absurd estimate (`duration = 1e300`, `--at 1e9`,
//! `--n0 1000000000`) with a message naming what sets it, instead of
//! running until it is killed. The implicit 64 x 64 drape costs about 2 us
//! per particle-step on one core (docs/PERFORMANCE.md), so the default cap
//! of 1e10 is hours of work; `--max-work` raises it.

use clap::Args;

use crate::CliError;

/// The largest `--max-work`: about a year of the drape's step.
pub const MAX_WORK: f64 = 1e15;

/// `--max-work`: the largest estimated work a command starts.
#[derive(Debug, Clone, Copy, Args)]
pub struct WorkCap {
    /// Refuse work estimated above this many particle-steps (particles x time steps; 1e10 is
    /// hours), in (0, 1e15].
    #[arg(
        long,
        value_name = "PARTICLE_STEPS",
        default_value_t = 1e10,
        allow_negative_numbers = true
    )]
    pub max_work: f64,
}

impl WorkCap {
    /// Refuses `steps` time steps of `particles` particles (or unknowns)
    /// above the cap; `cause` says what sets the number of steps
    /// (`duration = 1e300 s at integrator.h = 0.01 s`).
    ///
    /// # Errors
    /// [`CliError::Input`] for a cap that is not a positive number, a
    /// non-finite estimate or one above the cap.
    pub fn check(&self, steps: f64, particles: f64, cause: &str) -> Result<(), CliError> {
        if !(self.max_work > 0.0 && self.max_work <= MAX_WORK) {
            return Err(CliError::Input(format!(
                "--max-work must lie in (0, {MAX_WORK:e}] particle-steps, got {:?}",
                self.max_work
            )));
        }
        let work = steps * particles;
        if work.is_finite() && work <= self.max_work {
            return Ok(());
        }
        Err(CliError::Input(format!(
            "{cause} is about {steps:.3e} steps of {particles} particles ({work:.3e} particle-steps), \
             more than --max-work = {:e} allows; shorten the run or raise --max-work",
            self.max_work
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_at_the_cap_runs_and_above_it_is_refused_naming_the_cause() {
        let cap = WorkCap { max_work: 1e6 };
        assert!(cap.check(1e3, 1e3, "x").is_ok());
        for (steps, particles) in [(1e3, 1001.0), (f64::INFINITY, 1.0), (f64::NAN, 1.0)] {
            match cap.check(steps, particles, "duration = 1e300 s") {
                Err(CliError::Input(m)) => {
                    assert!(m.starts_with("duration = 1e300 s is about"), "{m}");
                    assert!(m.contains("--max-work"), "{m}");
                }
                _ => panic!("{steps} x {particles} ran"),
            }
        }
        assert!(WorkCap { max_work: -1.0 }.check(1.0, 1.0, "x").is_err());
    }
}
