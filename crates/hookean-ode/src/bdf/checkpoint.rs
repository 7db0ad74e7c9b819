//! The checkpoint of the variable-order BDF
//! ([`Integrator::save_state`](crate::Integrator::save_state)): time, the
//! history (differences, spacing, order, equal steps), the re-use
//! bookkeeping of the Jacobian and the Newton matrix, the counters, the
//! growth bound, then the corrector's (its Newton solver, the kept
//! Jacobian and Newton matrix: [`Corrector::save_corrector`]). The
//! predictor, `psi`, the weights, the correction and the other work
//! vectors are written before they are read at every step.

use super::corrector::Corrector;
use super::engine::Bdf;
use crate::error::OdeError;
use crate::snapshot::StateRecord;
use crate::stepping::{check_finite, check_time};

fn flag(b: bool) -> f64 {
    f64::from(u8::from(b))
}

impl<S: Corrector> Bdf<S> {
    pub(super) fn save(&self, r: &mut StateRecord) -> Result<(), OdeError> {
        r.put_scalar("bdf.t", self.t);
        r.put_scalar("bdf.t_prev", self.t_prev);
        r.put_scalar("bdf.started", flag(self.started));
        r.put_scalar("bdf.bound", self.bound);
        r.put("bdf.hist", &self.hist.carried());
        r.put(
            "bdf.reuse",
            &[
                self.lu_c,
                self.lu_age as f64,
                self.jac_age as f64,
                flag(self.jac_evaluated),
                flag(self.jac_current),
                self.jac_c,
            ],
        );
        r.put_stats("bdf.stats", &self.stats);
        self.sys.save_corrector(&self.corrector, r)
    }

    pub(super) fn restore(&mut self, r: &StateRecord) -> Result<(), OdeError> {
        let misfit = |reason: &str| OdeError::Checkpoint {
            reason: reason.into(),
        };
        let t = r.scalar("bdf.t")?;
        check_time(t)?;
        let t_prev = r.scalar("bdf.t_prev")?;
        let started = r.flag("bdf.started")?;
        let bound = r.scalar("bdf.bound")?;
        let stats = r.stats("bdf.stats")?;
        let reuse = r.get_len("bdf.reuse", 6)?;
        let count = |v: f64| v >= 0.0 && v.fract() == 0.0 && v < 9.007_199_254_740_992e15;
        if !(count(reuse[1]) && count(reuse[2]))
            || [reuse[3], reuse[4]].iter().any(|&f| f != 0.0 && f != 1.0)
        {
            return Err(misfit("entry `bdf.reuse` is malformed"));
        }
        let carried = r.get("bdf.hist")?;
        let mut hist = self.hist.clone();
        if hist.restore(carried).is_none() {
            return Err(misfit("entry `bdf.hist` does not fit this run's history"));
        }
        check_finite(hist.d(0), "checkpoint state", t)?;
        self.sys.restore_corrector(&mut self.corrector, r)?;
        self.t = t;
        self.t_prev = t_prev;
        self.started = started;
        self.bound = bound;
        self.hist = hist;
        self.lu_c = reuse[0];
        self.lu_age = reuse[1] as usize;
        self.jac_age = reuse[2] as usize;
        self.jac_evaluated = reuse[3] == 1.0;
        self.jac_current = reuse[4] == 1.0;
        self.jac_c = reuse[5];
        self.stats = stats;
        Ok(())
    }
}
