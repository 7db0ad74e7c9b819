//! The checkpoint of the one-step and fixed-step multistep engine
//! ([`Integrator::save_state`](crate::Integrator::save_state)): every field
//! a step reads that an earlier step wrote, then the stage system's.

use super::{Controller, Core};
use crate::error::OdeError;
use crate::method::Method;
use crate::options::Predictor;
use crate::snapshot::StateRecord;
use crate::stage::System;
use crate::stepping::{check_finite, check_time};

impl<S: System> Core<S> {
    /// Whether the method reads the history of past states.
    fn multistep(&self) -> bool {
        matches!(self.method, Method::Bdf(_) | Method::Bdf2Variable)
    }

    /// Every field a step reads that an earlier step wrote, then the
    /// system's. The scratch vectors are written before they are read and
    /// are not saved: the stage work, `pre`, the variable-step BDF2's new
    /// slope `f_new` (computed, then swapped into `f_n`) and the extrapolated
    /// midpoint rule's three substep states `ex` (copied from the state
    /// first); nor is what the method does not read: the history (read by
    /// the multistep methods only), the last state of the extrapolating
    /// predictor (`Predictor::Extrapolate` only), the slopes `f_n`,
    /// `f_nm1` (variable-step BDF2 only).
    pub(super) fn save(&self, r: &mut StateRecord) -> Result<(), OdeError> {
        let flag = |b: bool| f64::from(u8::from(b));
        r.put_scalar("core.t", self.t);
        r.put_scalar("core.t_prev", self.t_prev);
        r.put("core.s", &self.s);
        r.put("core.y0", &self.y0);
        r.put_scalar("core.h", self.h);
        r.put_stats("core.stats", &self.stats);
        r.put_scalar("core.hist.len", self.hist_len as f64);
        r.put_scalar("core.hist.h", self.hist_h);
        // What only some methods read is saved only for them.
        if self.multistep() {
            for (k, h) in self.hist.iter().enumerate() {
                r.put(&format!("core.hist.{k}"), h);
            }
        }
        let extrapolates = self.opts.predictor == Predictor::Extrapolate;
        r.put("core.prev", if extrapolates { &self.prev } else { &[] });
        r.put_scalar("core.prev_h", self.prev_h);
        let variable = self.method == Method::Bdf2Variable;
        r.put("core.f_n", if variable { &self.f_n } else { &[] });
        r.put("core.f_nm1", if variable { &self.f_nm1 } else { &[] });
        r.put_scalar("core.f_valid", flag(self.f_valid));
        r.put_scalar("core.h_prev", self.h_prev);
        r.put_scalar("core.acc_valid", flag(self.acc_valid));
        // Verlet's acceleration at the state, reused by its next step.
        let n = self.m / 2;
        r.put(
            "core.acc",
            if self.acc_valid { &self.tmp[..n] } else { &[] },
        );
        r.put_scalar("core.t_base", self.t_base);
        r.put_scalar("core.n_fixed", self.n_fixed as f64);
        r.put_scalar("core.growth_bound", self.growth_bound);
        match &self.controller {
            Some(Controller::Pi(c)) => r.put("core.controller", &c.memory()),
            Some(Controller::Iterations(c)) => r.put("core.controller", &c.memory()),
            None => r.put("core.controller", &[]),
        }
        self.sys.save_state(r)
    }

    pub(super) fn restore(&mut self, r: &StateRecord) -> Result<(), OdeError> {
        let m = self.m;
        // Checked before anything changes: a bad record leaves `self` as it was.
        let extrapolates = self.opts.predictor == Predictor::Extrapolate;
        let variable = self.method == Method::Bdf2Variable;
        for (name, saved) in [
            ("core.s", true),
            ("core.y0", true),
            ("core.prev", extrapolates),
            ("core.f_n", variable),
            ("core.f_nm1", variable),
        ] {
            r.get_len(name, if saved { m } else { 0 })?;
        }
        if self.multistep() {
            for k in 0..self.hist.len() {
                r.get_len(&format!("core.hist.{k}"), m)?;
            }
        }
        let hist_len = r.count("core.hist.len")?;
        if hist_len > self.hist.len() {
            return Err(OdeError::Checkpoint {
                reason: format!(
                    "its history has {hist_len} states, this method keeps {}",
                    self.hist.len()
                ),
            });
        }
        let stats = r.stats("core.stats")?;
        let t = r.scalar("core.t")?;
        check_time(t)?;
        let s = r.get_len("core.s", m)?;
        check_finite(s, "checkpoint state", t)?;
        let controller = r.get("core.controller")?.to_vec();
        let scalars = [
            r.scalar("core.t_prev")?,
            r.scalar("core.h")?,
            r.scalar("core.hist.h")?,
            r.scalar("core.prev_h")?,
            r.scalar("core.h_prev")?,
            r.scalar("core.t_base")?,
            r.scalar("core.growth_bound")?,
        ];
        let (f_valid, acc_valid, n_fixed) = (
            r.flag("core.f_valid")?,
            r.flag("core.acc_valid")?,
            r.count("core.n_fixed")?,
        );
        if acc_valid {
            r.get_len("core.acc", m / 2)?;
        }
        self.sys.restore_state(r, &self.opts)?;
        self.t = t;
        [
            self.t_prev,
            self.h,
            self.hist_h,
            self.prev_h,
            self.h_prev,
            self.t_base,
            self.growth_bound,
        ] = scalars;
        self.s.copy_from_slice(s);
        r.copy_into("core.y0", &mut self.y0)?;
        self.stats = stats;
        self.hist_len = hist_len;
        if self.multistep() {
            for (k, h) in self.hist.iter_mut().enumerate() {
                r.copy_into(&format!("core.hist.{k}"), h)?;
            }
        }
        if extrapolates {
            r.copy_into("core.prev", &mut self.prev)?;
        }
        if variable {
            r.copy_into("core.f_n", &mut self.f_n)?;
            r.copy_into("core.f_nm1", &mut self.f_nm1)?;
        }
        if acc_valid {
            r.copy_into("core.acc", &mut self.tmp[..m / 2])?;
        }
        self.f_valid = f_valid;
        self.acc_valid = acc_valid;
        self.n_fixed = n_fixed as u64;
        match &mut self.controller {
            Some(Controller::Pi(c)) => c.set_memory(&controller),
            Some(Controller::Iterations(c)) => c.set_memory(&controller),
            None => {}
        }
        Ok(())
    }
}
