//! The cap on a command's work. Every command that simulates estimates its
//! work before it starts, in particle-steps (particles times time steps),
//! and refuses an absurd estimate (`duration = 1e300`, `--at 1e9`,
//! `--n0 1000000000`) with a message naming what sets it, instead of
//! running until it is killed. The implicit 64 x 64 drape costs about 2 us
//! per particle-step on one core (docs/PERFORMANCE.md), so the default cap
//! of 1e10 is hours of work; `--max-work` raises it.

use clap::Args;
use hookean::ode::Method;
use hookean::scene::Scene;
use hookean::sparse::{AsWritten, Short};

use crate::CliError;

/// The largest `--max-work`: about a year of the drape's step.
pub const MAX_WORK: f64 = 1e15;

/// The least work one time step of `hookean run` counts, in particle-steps,
/// whatever the model's size: a step writes its line of `steps.csv` (about
/// 100 bytes) and pays its fixed costs, so a scalar `[tutorial]` scene of
/// 1e10 steps (a terabyte of `steps.csv`) is refused like 1e10 steps of a
/// 100-particle cloth.
pub const MIN_STEP_WORK: f64 = 100.0;

/// The steps a run of `scene` to `t_end` (`name` says what sets it:
/// `duration`, `--at`) counts, and the words that say why: a fixed-step
/// method takes `t_end / h` steps at its step `h`; a variable-step one
/// (`bdf2-variable`, `bdf`) at most `integrator.max_steps`, its bound
/// (error control may take steps far below `h_max`; the run fails at the
/// cap).
///
/// # Errors
/// [`CliError::Input`] for a variable-step run that cannot finish: its
/// fewest steps, `t_end / h_max`, are more than `integrator.max_steps`.
pub fn scene_steps(
    scene: &Scene,
    file: &std::path::Path,
    t_end: f64,
    name: &str,
    h: f64,
) -> Result<(f64, String), CliError> {
    let t = AsWritten(t_end);
    let i = &scene.integrator;
    let method = &i.method;
    if !(method.is_variable_step() || matches!(method, Method::VariableBdf(_))) {
        let auto = if i.h.value().is_none() {
            " (\"auto\")"
        } else {
            ""
        };
        return Ok((
            t_end / h,
            format!(
                "{}: {name} = {t} s at integrator.h = {} s{auto}",
                file.display(),
                Short(h)
            ),
        ));
    }
    if t_end == 0.0 {
        return Ok((0.0, format!("{}: {name} = 0 s", file.display())));
    }
    let fewest = t_end / i.h_max;
    if !(fewest <= i.max_steps as f64) {
        return Err(CliError::Input(format!(
            "{}: {name} = {t} s at integrator.h_max = {} s takes at least {} steps of {method}, \
             more than integrator.max_steps = {} allows (range 1 to 1000000000); \
             raise integrator.max_steps or integrator.h_max",
            file.display(),
            AsWritten(i.h_max),
            Short(fewest.ceil()),
            i.max_steps
        )));
    }
    Ok((
        i.max_steps as f64,
        format!(
            "{}: integrator.max_steps = {} (the most steps of {method}, for {name} = {t} s)",
            file.display(),
            i.max_steps
        ),
    ))
}

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
            "{cause} is about {} steps of {} particles ({} particle-steps), \
             more than --max-work = {:e} allows; shorten the run or raise --max-work",
            Short(steps),
            Short(particles),
            Short(work),
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

    fn scene(text: &str) -> Scene {
        Scene::from_toml_str("s.toml", text).unwrap()
    }

    #[test]
    fn variable_step_methods_count_their_step_cap_and_refuse_what_cannot_finish() {
        let file = std::path::Path::new("s.toml");
        // Fixed step: duration / h = 1 / 0.01 = 100 steps.
        let fixed = scene("duration = 1\n[cloth]\nn = 2\n");
        let (steps, cause) = scene_steps(&fixed, file, 1.0, "duration", 0.01).unwrap();
        assert!((steps - 100.0).abs() < 1e-9, "{steps}");
        assert!(cause.contains("integrator.h = 0.01 s"), "{cause}");
        for method in ["bdf", "bdf2-variable"] {
            // At least 1 / 0.05 = 20 steps; 30 allowed: the cap is counted.
            let text = format!(
                "duration = 1\n[cloth]\nn = 2\n[integrator]\nmethod = \"{method}\"\nmax_steps = 30\n"
            );
            let (steps, cause) =
                scene_steps(&scene(&text), file, 1.0, "duration", f64::NAN).unwrap();
            assert_eq!(steps, 30.0, "{method}");
            assert!(cause.contains("integrator.max_steps = 30"), "{cause}");
            // 19 allowed: fewer than the 20 it needs at h_max.
            let text = text.replace("max_steps = 30", "max_steps = 19");
            match scene_steps(&scene(&text), file, 1.0, "duration", f64::NAN) {
                Err(CliError::Input(m)) => {
                    assert!(m.contains("takes at least 20 steps"), "{m}");
                    assert!(m.contains("integrator.max_steps = 19"), "{m}");
                    assert!(
                        m.starts_with("s.toml: duration = 1 s at integrator.h_max = 0.05 s"),
                        "{m}"
                    );
                }
                other => panic!("{method}: {:?}", other.map(|o| o.0)),
            }
            // Nothing to simulate: no steps.
            assert_eq!(
                scene_steps(&scene(&text), file, 0.0, "--at", f64::NAN)
                    .unwrap()
                    .0,
                0.0
            );
        }
    }
}
