//! One step of the variable-order BDF: the start of the history with
//! Hairer-Wanner's initial step, the re-use rules of the Jacobian and the
//! Newton matrix (CVODE's), the corrector, the local error test, and the
//! choice of the next order and step size (Shampine-Reichelt).

use super::corrector::{Attempt, Corrector, CorrectorStep};
use super::engine::Bdf;
use crate::error::OdeError;
use hookean_nonlinear::weighted_rms as rms;

/// The step-size factor `err^(-1/q)` of an order whose error estimate is
/// `err`; `0` for an order out of reach (`err = inf`: `pow(inf, -1/q)` is
/// exactly `+0`, without the call).
fn step_factor(err: f64, q: f64) -> f64 {
    if err == f64::INFINITY {
        0.0
    } else {
        err.powf(-1.0 / q)
    }
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

impl<S: Corrector> Bdf<S> {
    /// Hairer-Wanner's starting step (Solving ODEs I, II.4, for order 1):
    /// `h0 = 0.01 ||y0|| / ||f0||`, then `h1 = (0.01 / max(||f0||, ||f'||))^(1/2)`
    /// with `f'` a difference quotient along `f0`; the result `min(100 h0, h1)`.
    fn initial_step(&mut self, span: f64) -> f64 {
        let rtol = self.rtol;
        let y0 = self.hist.d(0);
        for i in 0..self.n {
            self.w[i] = self.atol[i] + rtol * y0[i].abs();
        }
        // f0 is in self.f.
        let d0 = rms(y0, &self.w);
        let d1 = rms(&self.f, &self.w);
        let mut h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        h0 = h0.min(span);
        for i in 0..self.n {
            self.y_new[i] = y0[i] + h0 * self.f[i];
        }
        // f(t + h0, y0 + h0 f0) into y_pred, its difference from f0 into dcor.
        self.sys
            .derivative(self.t + h0, &self.y_new, &mut self.y_pred, &mut self.stats);
        for i in 0..self.n {
            self.dcor[i] = self.y_pred[i] - self.f[i];
        }
        let d2 = rms(&self.dcor, &self.w) / h0;
        let h1 = if d1 <= 1e-15 && d2 <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / d1.max(d2)).sqrt()
        };
        (100.0 * h0).min(h1).min(span)
    }

    /// Starts the history: `f0`, the initial step, `D_1 = h f0`.
    fn start(&mut self, t_bound: f64) -> Result<(), OdeError> {
        let span = t_bound - self.t;
        self.sys
            .derivative(self.t, self.hist.d(0), &mut self.f, &mut self.stats);
        if self.f.iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "right-hand side",
                t: self.t,
            });
        }
        let h = match self.config.initial_step {
            Some(h0) => h0.min(span),
            None => self.initial_step(span),
        };
        let h = h.min(self.opts.step.h_max).max(self.opts.step.h_min);
        if !(h > 0.0 && h.is_finite()) {
            return Err(OdeError::StepSizeUnderflow { t: self.t, h });
        }
        self.hist.start(h, &self.f);
        self.started = true;
        Ok(())
    }

    /// Evaluates the Jacobian at `(t, y^(0))`; `Ok(false)` if it is not
    /// finite (a recoverable failure: the step is retried smaller, and the
    /// next attempt evaluates the Jacobian again).
    fn eval_jacobian(&mut self, t: f64) -> Result<bool, OdeError> {
        let ok =
            self.sys
                .evaluate_jacobian(&mut self.corrector, t, &self.y_pred, &mut self.stats)?;
        self.jac_evaluated = ok;
        if ok {
            self.jac_age = 0;
            self.jac_current = true;
        }
        Ok(ok)
    }

    /// The corrector at `c`, with the re-use rules of the Jacobian and the
    /// Newton matrix: a failure with a Jacobian of an earlier step is retried
    /// once with a fresh one.
    fn correct(&mut self, t_new: f64, c: f64) -> Result<Attempt, OdeError> {
        loop {
            let mut refactor = !(self.lu_c.abs() > 0.0)
                || (c / self.lu_c - 1.0).abs() > self.config.max_gamma_change
                || self.lu_age >= self.config.steps_per_factorization;
            let jac_old = self
                .config
                .steps_per_jacobian
                .is_some_and(|n| self.jac_age >= n)
                || c > self.config.jacobian_c_growth * self.jac_c;
            let mut usable = true;
            if !self.jac_evaluated || jac_old {
                usable = self.eval_jacobian(t_new)?;
                self.jac_c = c;
                refactor = true;
            }
            // A linear problem (a constant Jacobian) is solved by the first
            // correction with the Newton matrix of this very c: set it up
            // again at every change of c and take that one correction.
            let linear = usable && S::jacobian_is_constant(&self.corrector);
            refactor |= linear && c != self.lu_c;
            let attempt = if usable {
                let step = CorrectorStep {
                    t: t_new,
                    c,
                    refactor,
                    known_rate: linear.then_some(0.0),
                    scale: if refactor || c == self.lu_c {
                        1.0
                    } else {
                        2.0 / (1.0 + c / self.lu_c)
                    },
                    y_pred: &self.y_pred,
                    psi: &self.psi,
                    weights: &self.w,
                };
                let attempt = self.sys.solve_corrector(
                    &mut self.corrector,
                    &step,
                    &mut self.dcor,
                    &mut self.stats,
                )?;

                if refactor {
                    self.lu_age = 0;
                    self.lu_c = f64::NAN;
                }
                attempt
            } else {
                Attempt::Failed {
                    iterations: 0,
                    update_norm: f64::NAN,
                    cause: None,
                }
            };
            if let Attempt::Converged(_) = attempt {
                if refactor {
                    self.lu_c = c;
                }
                return Ok(attempt);
            }
            self.stats.num_nonlin_solv_conv_fails += 1;
            self.lu_c = f64::NAN;
            if self.jac_current || !usable {
                return Ok(attempt);
            }
            // Slow convergence with an old Jacobian: a fresh one and a new
            // Newton matrix.
            if !self.eval_jacobian(t_new)? {
                return Ok(attempt);
            }
            self.jac_c = c;
        }
    }

    /// One accepted step that does not pass `t_bound`; returns its error
    /// estimate (the weighted norm, `<= 1`).
    pub(super) fn step_inner(&mut self, t_bound: f64) -> Result<f64, OdeError> {
        if !self.started {
            self.start(t_bound)?;
        }
        let t = self.t;
        let ulp = (t.abs() * f64::EPSILON).max(f64::MIN_POSITIVE);
        let h_floor = (10.0 * ulp).max(self.opts.step.h_min);
        if self.hist.h > self.opts.step.h_max {
            self.hist.rescale(self.opts.step.h_max / self.hist.h);
        } else if self.hist.h < h_floor {
            self.hist.rescale(h_floor / self.hist.h);
        }
        let mut conv_fails = 0;
        let mut err_fails = 0;
        let rtol = self.rtol;
        loop {
            if self.hist.h < h_floor {
                return Err(OdeError::StepSizeUnderflow { t, h: self.hist.h });
            }
            let mut t_new = t + self.hist.h;
            if t_new >= t_bound {
                self.hist.rescale((t_bound - t) / self.hist.h);
                t_new = t_bound;
            }
            let k = self.hist.order;
            let h = self.hist.h;
            self.hist
                .predict(&self.coef, &mut self.y_pred, &mut self.psi);
            for i in 0..self.n {
                self.w[i] = self.atol[i] + rtol * self.y_pred[i].abs();
            }
            let c = h / self.coef.alpha[k];
            let iterations = match self.correct(t_new, c)? {
                Attempt::Converged(it) => it,
                Attempt::Failed {
                    iterations,
                    update_norm,
                    cause,
                } => {
                    conv_fails += 1;
                    if conv_fails > self.opts.max_retries {
                        let retries = conv_fails - 1;
                        return Err(match cause {
                            Some(source) => OdeError::LinearSolver { t, retries, source },
                            None => OdeError::NewtonFailed {
                                t,
                                h,
                                retries,
                                iterations,
                                update_norm,
                            },
                        });
                    }
                    self.hist.rescale(0.5);
                    // The Jacobian was taken at this attempt's predictor; the
                    // smaller step predicts another point: if Newton fails
                    // again, the Jacobian is re-evaluated there first.
                    self.jac_current = false;
                    continue;
                }
            };
            let maxit = self.config.max_newton_iterations as f64;
            let safety = 0.9 * (2.0 * maxit + 1.0) / (2.0 * maxit + iterations as f64);
            for i in 0..self.n {
                self.y_new[i] = self.y_pred[i] + self.dcor[i];
                self.w[i] = self.atol[i] + rtol * self.y_new[i].abs();
            }
            let error_norm = self.coef.error_const[k] * rms(&self.dcor, &self.w);
            if !error_norm.is_finite() {
                return Err(OdeError::NonFinite {
                    what: "local error estimate",
                    t,
                });
            }
            if error_norm > 1.0 && !self.frozen {
                self.stats.num_err_test_fails += 1;
                err_fails += 1;
                if err_fails >= self.config.max_error_test_failures {
                    return Err(OdeError::ErrorTestFailed {
                        t,
                        h,
                        failures: err_fails,
                    });
                }
                let factor = (safety * error_norm.powf(-1.0 / (k as f64 + 1.0)))
                    .max(self.config.min_step_shrink);
                if err_fails < 3 {
                    self.hist.rescale(factor);
                } else {
                    // Repeated failures: the history is not to be trusted;
                    // restart at order 1 from f(t_n, y_n) with a tenth of
                    // the step at most (CVODE's MXNEF1 and ETAMIN rules).
                    let h = self.hist.h * factor.min(0.1);
                    self.sys
                        .derivative(t, self.hist.d(0), &mut self.f, &mut self.stats);
                    self.hist.start(h, &self.f);
                }
                continue;
            }
            self.accept(t_new, h, safety, error_norm)?;
            return Ok(error_norm);
        }
    }

    /// Books an accepted step, updates the differences (Shampine-Reichelt,
    /// eq. 2.4) and chooses the next order and step size.
    fn accept(&mut self, t_new: f64, h: f64, safety: f64, error_norm: f64) -> Result<(), OdeError> {
        let k = self.hist.order;
        self.t_prev = self.t;
        self.t = t_new;
        self.stats.num_steps += 1;
        self.stats.last_order = k;
        self.stats.last_step = h;
        self.lu_age += 1;
        self.jac_age += 1;
        self.jac_current = false;
        self.hist.update(&self.dcor);
        if self.hist.d(0).iter().any(|v| !v.is_finite()) {
            return Err(OdeError::NonFinite {
                what: "state after the step",
                t: t_new,
            });
        }
        let norm = max_abs(self.hist.d(0));
        if norm > self.bound {
            return Err(OdeError::StateGrowth {
                t: t_new,
                norm,
                bound: self.bound,
            });
        }
        if self.hist.n_equal_steps < k + 1 || self.frozen {
            return Ok(());
        }
        let d = |j| self.hist.d(j);
        let err_m = if k > 1 {
            self.coef.error_const[k - 1] * rms(d(k), &self.w)
        } else {
            f64::INFINITY
        };
        let err_p = if k < self.max_order() {
            self.coef.error_const[k + 1] * rms(d(k + 2), &self.w)
        } else {
            f64::INFINITY
        };
        let factors = [
            step_factor(err_m, k as f64),
            step_factor(error_norm, k as f64 + 1.0),
            step_factor(err_p, k as f64 + 2.0),
        ];
        let mut best = 1;
        for (i, f) in factors.iter().enumerate() {
            if *f > factors[best] {
                best = i;
            }
        }
        self.hist.order = k + best - 1;
        let factor = (safety * factors[best]).min(self.config.max_step_growth);
        // Hysteresis: keep the order and step unless the change is worth
        // the re-interpolation and a likely refactorisation (CVODE keeps h
        // for growth below THRESH = 1.5).
        let (keep_low, keep_high) = self.config.keep_step_band;
        if best != 1 || !(keep_low < factor && factor < keep_high) {
            self.hist.rescale(factor);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::step_factor;

    #[test]
    fn the_factor_of_an_order_out_of_reach_is_the_pow_of_infinity() {
        for q in 1..=7 {
            let q = q as f64;
            assert_eq!(
                step_factor(f64::INFINITY, q).to_bits(),
                f64::INFINITY.powf(-1.0 / q).to_bits()
            );
            assert_eq!(step_factor(0.25, q), 0.25f64.powf(-1.0 / q));
        }
    }
}
