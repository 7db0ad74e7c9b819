//! [`StateRecord`]: everything an integrator's next step depends on, as
//! named arrays of numbers, so that a run can be stopped and continued
//! bit for bit ([`Integrator::save_state`](crate::Integrator::save_state),
//! [`Integrator::restore_state`](crate::Integrator::restore_state)).
//!
//! A record is a flat list of named `f64` arrays: the state, the step
//! size, the counters, the step controller's and the multistep history,
//! the warm start of the linear solves, and what the preconditioner
//! reuses. Integers (counters, flags) are stored as `f64`, exact below
//! 2^53. Each layer above the integrator (the facade's simulation, the
//! command line's outputs) adds its own entries under its own prefix; the
//! record says nothing of how it is written to a file.
//!
//! ```
//! use hookean_ode::{Integrator, Method, SecondOrderIntegrator, SolverOptions, StateRecord};
//! use hookean_ode::tutorial::LinearOscillator;
//!
//! let ex3 = LinearOscillator::example3();
//! let new = || SecondOrderIntegrator::new(
//!     ex3.particle(), Method::ImplicitEuler, 0.0, &ex3.x0(), &ex3.v0_vec(), SolverOptions::with_h(1e-2),
//! );
//! let (mut a, mut b) = (new()?, new()?);
//! for _ in 0..10 { a.step()?; }
//! let mut record = StateRecord::default();
//! a.save_state(&mut record)?;
//! b.restore_state(&record)?;
//! a.step()?;
//! b.step()?;
//! assert_eq!(a.state(), b.state()); // bit for bit
//! assert_eq!(a.stats().num_steps, b.stats().num_steps);
//! # Ok::<(), hookean_ode::OdeError>(())
//! ```

use crate::error::OdeError;
use crate::stats::Stats;

/// Named arrays of numbers: the state a run continues from (see the module docs).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StateRecord {
    entries: Vec<(String, Vec<f64>)>,
}

impl StateRecord {
    /// Adds (or replaces) the array `name`.
    pub fn put(&mut self, name: &str, values: &[f64]) {
        match self.entries.iter_mut().find(|(n, _)| n == name) {
            Some((_, v)) => {
                v.clear();
                v.extend_from_slice(values);
            }
            None => self.entries.push((name.to_string(), values.to_vec())),
        }
    }

    /// Adds (or replaces) the one number `name`.
    pub fn put_scalar(&mut self, name: &str, value: f64) {
        self.put(name, &[value]);
    }

    /// The array `name`.
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] if the record has no such entry.
    pub fn get(&self, name: &str) -> Result<&[f64], OdeError> {
        self.entries
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
            .ok_or_else(|| OdeError::Checkpoint {
                reason: format!("it has no entry `{name}`"),
            })
    }

    /// The array `name`, which must have `len` numbers.
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] if it is missing or of another length.
    pub fn get_len(&self, name: &str, len: usize) -> Result<&[f64], OdeError> {
        let v = self.get(name)?;
        if v.len() != len {
            return Err(OdeError::Checkpoint {
                reason: format!(
                    "entry `{name}` has {} numbers, this run needs {len}",
                    v.len()
                ),
            });
        }
        Ok(v)
    }

    /// The one number `name`.
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] if it is missing or not one number.
    pub fn scalar(&self, name: &str) -> Result<f64, OdeError> {
        Ok(self.get_len(name, 1)?[0])
    }

    /// The one number `name` as a count (a non-negative integer).
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] if it is missing or not a count.
    pub fn count(&self, name: &str) -> Result<usize, OdeError> {
        let v = self.scalar(name)?;
        if !(v >= 0.0 && v.fract() == 0.0 && v < 9.007_199_254_740_992e15) {
            return Err(OdeError::Checkpoint {
                reason: format!("entry `{name}` = {v} is not a count"),
            });
        }
        Ok(v as usize)
    }

    /// The one number `name` as a flag (0 or 1).
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] if it is missing or not 0 or 1.
    pub fn flag(&self, name: &str) -> Result<bool, OdeError> {
        let v = self.scalar(name)?;
        if v == 0.0 || v == 1.0 {
            Ok(v == 1.0)
        } else {
            Err(OdeError::Checkpoint {
                reason: format!("entry `{name}` = {v} is not a flag (0 or 1)"),
            })
        }
    }

    /// Copies the array `name` into `out` (of its length).
    ///
    /// # Errors
    /// As [`get_len`](Self::get_len).
    pub fn copy_into(&self, name: &str, out: &mut [f64]) -> Result<(), OdeError> {
        out.copy_from_slice(self.get_len(name, out.len())?);
        Ok(())
    }

    /// The entries, in the order they were put.
    pub fn entries(&self) -> impl Iterator<Item = (&str, &[f64])> {
        self.entries.iter().map(|(n, v)| (n.as_str(), v.as_slice()))
    }

    /// Whether the record has the entry `name`.
    pub fn contains(&self, name: &str) -> bool {
        self.entries.iter().any(|(n, _)| n == name)
    }

    /// Keeps only the entries whose name `keep` accepts.
    pub fn retain(&mut self, mut keep: impl FnMut(&str) -> bool) {
        self.entries.retain(|(n, _)| keep(n));
    }

    /// Puts the counters of `stats` under `prefix` (the phases' wall times
    /// in seconds, as the nearest nanosecond).
    pub fn put_stats(&mut self, prefix: &str, s: &Stats) {
        let values = [
            s.num_steps as f64,
            s.num_rhs_evals as f64,
            s.num_lin_rhs_evals as f64,
            s.num_jac_evals as f64,
            s.num_lin_solv_setups as f64,
            s.num_nonlin_solv_iters as f64,
            s.num_nonlin_solv_conv_fails as f64,
            s.num_err_test_fails as f64,
            s.num_g_evals as f64,
            s.last_order as f64,
            s.last_step,
            s.num_lin_iters as f64,
            s.num_lin_conv_fails as f64,
            s.num_jtimes_evals as f64,
            s.num_prec_evals as f64,
            s.num_prec_solves as f64,
            s.phases.assembly.as_nanos() as f64,
            s.phases.setup.as_nanos() as f64,
            s.phases.solve.as_nanos() as f64,
        ];
        self.put(prefix, &values);
    }

    /// The counters [`put_stats`](Self::put_stats) put under `prefix`.
    ///
    /// # Errors
    /// [`OdeError::Checkpoint`] if the entry is missing or malformed.
    pub fn stats(&self, prefix: &str) -> Result<Stats, OdeError> {
        let v = self.get_len(prefix, 19)?;
        let count = |k: usize| -> Result<usize, OdeError> {
            let x = v[k];
            if !(x >= 0.0 && x.fract() == 0.0 && x < 9.007_199_254_740_992e15) {
                return Err(OdeError::Checkpoint {
                    reason: format!("counter {k} of `{prefix}` = {x} is not a count"),
                });
            }
            Ok(x as usize)
        };
        let nanos = |k: usize| -> Result<std::time::Duration, OdeError> {
            Ok(std::time::Duration::from_nanos(count(k)? as u64))
        };
        Ok(Stats {
            num_steps: count(0)?,
            num_rhs_evals: count(1)?,
            num_lin_rhs_evals: count(2)?,
            num_jac_evals: count(3)?,
            num_lin_solv_setups: count(4)?,
            num_nonlin_solv_iters: count(5)?,
            num_nonlin_solv_conv_fails: count(6)?,
            num_err_test_fails: count(7)?,
            num_g_evals: count(8)?,
            last_order: count(9)?,
            last_step: v[10],
            num_lin_iters: count(11)?,
            num_lin_conv_fails: count(12)?,
            num_jtimes_evals: count(13)?,
            num_prec_evals: count(14)?,
            num_prec_solves: count(15)?,
            phases: crate::phases::PhaseTimes {
                assembly: nanos(16)?,
                setup: nanos(17)?,
                solve: nanos(18)?,
            },
        })
    }
}

/// The error of an integrator (or a part of it) that cannot save its state.
pub(crate) fn not_covered(what: &str) -> OdeError {
    OdeError::NoCheckpoint {
        what: what.to_string(),
    }
}
