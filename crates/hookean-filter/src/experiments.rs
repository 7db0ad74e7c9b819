//! The experiments of the filtering paper as plain functions returning data
//! (no plotting): bounded-energy runs, the stable step by
//! bisection on the actual integration (figure 6), the velocity-over-time
//! image (figure 4) and the spectrum of the velocity field (figure 5).

use crate::NonExhaustive;
use hookean_massspring::{ClothParams, MassSpringModel, State, cloth};
use hookean_ode::{Method, OdeError, SolverOptions};
use hookean_sparse::PowerParams;

use crate::error::FilterError;
use crate::filtered::FilterCoupling;
use crate::model_integrator::ModelIntegrator;
use crate::spectrum::{VelocityImage, power_spectrum};
use crate::stability::ExplicitScheme;
use crate::velocity::{FilterOptions, Kernel, VelocityFilter};

/// Options of [`run_bounded`].
#[derive(Debug, Clone, PartialEq)]
pub struct RunOptions {
    /// Simulated time (s). Default 1.
    pub t_end: f64,
    /// The run is bounded while the total energy stays below
    /// `E(0) + energy_bound` (J). Default 1 J (the drape releases about
    /// 5 J of potential energy; a blow-up grows without bound).
    pub energy_bound: f64,
    /// Check the energy every this many steps (it costs about one force
    /// evaluation). Default 10.
    pub check_every: usize,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            t_end: 1.0,
            energy_bound: 1.0,
            check_every: 10,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// What [`run_bounded`] saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunOutcome {
    /// The energy stayed below `E(0) + energy_bound` and the state finite up to `t_end`.
    pub bounded: bool,
    /// The time reached (the blow-up time when not bounded).
    pub t_reached: f64,
    /// Steps taken.
    pub steps: usize,
    /// `E(0)`.
    pub initial_energy: f64,
    /// The largest energy checked.
    pub max_energy: f64,
}

/// Runs `sim` to `opts.t_end`, stopping at the first energy check above
/// `E(0) + energy_bound` or at a non-finite state ("blown up").
///
/// # Errors
/// [`FilterError::InvalidParameter`] for a non-positive `t_end` or a
/// negative/NaN bound; integrator errors other than a non-finite state.
pub fn run_bounded(
    sim: &mut ModelIntegrator,
    opts: &RunOptions,
) -> Result<RunOutcome, FilterError> {
    run_observed(sim, opts, |_| {})
}

fn run_observed(
    sim: &mut ModelIntegrator,
    opts: &RunOptions,
    mut observe: impl FnMut(&ModelIntegrator),
) -> Result<RunOutcome, FilterError> {
    if !(opts.t_end > 0.0 && opts.t_end.is_finite()) {
        return Err(FilterError::InvalidParameter {
            name: "t_end",
            value: opts.t_end,
            reason: "must be positive and finite",
        });
    }
    if !(opts.energy_bound >= 0.0) {
        return Err(FilterError::InvalidParameter {
            name: "energy_bound",
            value: opts.energy_bound,
            reason: "must be non-negative",
        });
    }
    let e0 = sim.energy();
    let limit = e0 + opts.energy_bound;
    let every = opts.check_every.max(1);
    let mut out = RunOutcome {
        bounded: true,
        t_reached: sim.t(),
        steps: 0,
        initial_energy: e0,
        max_energy: e0,
    };
    let t_end = opts.t_end;
    let blown = |out: &mut RunOutcome, t: f64| {
        out.bounded = false;
        out.t_reached = t;
        out.max_energy = f64::INFINITY;
    };
    loop {
        let t = sim.t();
        match sim.step_to(t_end) {
            Ok(Some(_)) => {}
            Ok(None) => break,
            Err(OdeError::NonFinite { .. }) => {
                blown(&mut out, t);
                return Ok(out);
            }
            Err(OdeError::LinearSolver { .. }) => {
                blown(&mut out, t);
                return Ok(out);
            }
            Err(e) => return Err(e.into()),
        }
        out.steps += 1;
        out.t_reached = sim.t();
        observe(sim);
        if out.steps.is_multiple_of(every) || sim.t() >= t_end {
            let e = sim.energy();
            if !(e <= limit) {
                out.bounded = false;
                out.max_energy = e;
                return Ok(out);
            }
            out.max_energy = out.max_energy.max(e);
        }
    }
    Ok(out)
}

/// Options of [`measure_stable_step`].
#[derive(Debug, Clone, PartialEq)]
pub struct BisectionOptions {
    /// The run each trial step must survive.
    pub run: RunOptions,
    /// Stop when `hi / lo - 1 < rel_tol`. Default 0.02.
    pub rel_tol: f64,
    /// At most this many trial runs. Default 40.
    pub max_runs: usize,
    /// Build with `..Default::default()` (see [`NonExhaustive`]).
    #[doc(hidden)]
    pub non_exhaustive: NonExhaustive,
}

impl Default for BisectionOptions {
    fn default() -> Self {
        Self {
            run: RunOptions::default(),
            rel_tol: 0.02,
            max_runs: 40,
            non_exhaustive: NonExhaustive(()),
        }
    }
}

/// A measured stable step: the largest step found bounded and the smallest
/// found unbounded (`lo < limit <= hi` if stability is monotone in `h`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableStep {
    /// Largest bounded step.
    pub lo: f64,
    /// Smallest unbounded step.
    pub hi: f64,
    /// Trial runs.
    pub runs: usize,
}

/// The stable step of `method` (filtered or not) on the scene `build`
/// makes, by bisection on the actual integration: a step is stable when
/// [`run_bounded`] stays bounded. `guess` starts the bracket search
/// (e.g. the predicted `dt_max`), which grows or shrinks it by 1.5.
///
/// # Errors
/// [`FilterError::InvalidParameter`] for a bad guess or tolerance,
/// [`FilterError::NoStabilityBracket`] when no bracket is found within
/// `max_runs`; the errors of the runs.
pub fn measure_stable_step(
    build: &dyn Fn() -> Result<(MassSpringModel, State), FilterError>,
    method: &Method,
    filter: Option<(FilterOptions, FilterCoupling)>,
    guess: f64,
    opts: &BisectionOptions,
) -> Result<StableStep, FilterError> {
    if !(guess > 0.0 && guess.is_finite()) {
        return Err(FilterError::InvalidParameter {
            name: "guess",
            value: guess,
            reason: "must be positive and finite",
        });
    }
    if !(opts.rel_tol > 0.0) {
        return Err(FilterError::InvalidParameter {
            name: "rel_tol",
            value: opts.rel_tol,
            reason: "must be positive",
        });
    }
    if opts.max_runs == 0 {
        return Err(FilterError::InvalidParameter {
            name: "max_runs",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    let mut runs = 0;
    let trial = |h: f64| -> Result<bool, FilterError> {
        let (model, state) = build()?;
        let mut sim = ModelIntegrator::new(
            model,
            &state,
            method.clone(),
            SolverOptions::with_h(h),
            filter.clone(),
        )?;
        Ok(run_bounded(&mut sim, &opts.run)?.bounded)
    };
    let (mut lo, mut hi) = (f64::NAN, f64::NAN);
    let mut h = guess;
    let mut last = guess;
    while lo.is_nan() || hi.is_nan() {
        if runs >= opts.max_runs {
            return Err(FilterError::NoStabilityBracket {
                runs,
                from: guess,
                to: last,
                stable: !lo.is_nan(),
            });
        }
        runs += 1;
        last = h;
        if trial(h)? {
            lo = h;
            if hi.is_nan() {
                h *= 1.5;
            }
        } else {
            hi = h;
            if lo.is_nan() {
                h /= 1.5;
            }
        }
    }
    while hi / lo - 1.0 > opts.rel_tol && runs < opts.max_runs {
        let mid = (lo * hi).sqrt();
        runs += 1;
        if trial(mid)? {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(StableStep { lo, hi, runs })
}

/// The predicted stable step: `k0` of `M^-1 K` at `x` by the modified power
/// method (Algorithm 1, the filter applied between iterations; `None`: the
/// plain power method) and `dt_max = c / sqrt(k0)` for the scheme (eq. 11).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The (filtered) dominant eigenvalue.
    pub k0: f64,
    /// `c / sqrt(k0)`.
    pub dt_max: f64,
    /// Power-method iterations.
    pub iterations: usize,
}

/// [`Prediction`] of the stable step of `scheme` on `model` at positions `x`.
///
/// # Errors
/// The filter's construction errors; the model's state and power-method
/// errors as [`FilterError::MassSpring`].
pub fn predict_dt_max(
    model: &MassSpringModel,
    x: &[f64],
    filter: Option<&FilterOptions>,
    scheme: ExplicitScheme,
    params: &PowerParams,
) -> Result<Prediction, FilterError> {
    let info = match filter {
        None => model.stability(x, params, None)?,
        Some(o) => {
            let mut f = VelocityFilter::from_model(model, o.clone())?;
            let mut hook = |v: &mut [f64]| f.apply_unchecked(v);
            model.stability(x, params, Some(&mut hook))?
        }
    };
    // `M^-1 K` is positive semidefinite, but Algorithm 1 normalises by the
    // entry of largest magnitude, whose sign can flip when the eigenvector
    // has two entries of equal magnitude and opposite sign (symmetric
    // bodies such as the jelly block): the magnitude is the eigenvalue.
    let k0 = info.k0.abs();
    Ok(Prediction {
        k0,
        dt_max: crate::stability::dt_max(k0, scheme),
        iterations: info.iterations,
    })
}

/// The step [`auto_step`] picks and where it comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoStep {
    /// The step: `safety * bound * dt_max`.
    pub h: f64,
    /// The prediction at the starting state (filtered when the filter's
    /// prediction holds for the method and coupling, else unfiltered).
    pub prediction: Prediction,
    /// Whether `prediction` is the filtered one.
    pub filtered: bool,
    /// The factor of the coupling on top of `dt_max`: `1 / sqrt 2` for
    /// [`FilterCoupling::VelocityOnly`], 1 otherwise.
    pub coupling_factor: f64,
}

/// The largest stable step of an explicit `method` on `model` from
/// positions `x` (at rest or starting), times `safety` (`integrator.h =
/// "auto"` of scenes): `dt_max = c / sqrt(k0)` (eq. 11, `c` of
/// [`ExplicitScheme::stability_constant`]) with `k0` from the modified
/// power method (Algorithm 1) where its prediction holds:
///
/// - FB Euler with the increment coupling: the filtered `k0`
///   (`h^2 a phi < 4` in the linear analysis: eq. 11 with the filtered `k0`
///   is exact; measured within 2-5%, docs/perf/filter.md);
/// - every other filtered method or coupling: the unfiltered `k0`, since a
///   post-step filter hardly enlarges Verlet's and RK4's steps (1.03x,
///   1.1x measured) and the position coupling at least keeps FB Euler's;
///   the paper's literal velocity coupling is stable only for `h^2 a < 2
///   (1 + phi)` (less than without a filter), so its step is divided by
///   `sqrt 2` (the bound for filter eigenvalues `phi >= 0`).
///
/// The state's stiffness grows as the model stretches (a falling cloth:
/// up to 1.5x `k0`), so `safety` < 1 leaves the margin.
///
/// # Errors
/// [`FilterError::NoStableStep`] for a method eq. 11 does not cover
/// (implicit methods, the explicit midpoint rule, tableaus);
/// [`FilterError::InvalidParameter`] for `safety` outside (0, 1]; the
/// prediction's errors.
pub fn auto_step(
    model: &MassSpringModel,
    x: &[f64],
    method: &Method,
    filter: Option<(&FilterOptions, FilterCoupling)>,
    safety: f64,
) -> Result<AutoStep, FilterError> {
    if !(safety > 0.0 && safety <= 1.0) {
        return Err(FilterError::InvalidParameter {
            name: "safety",
            value: safety,
            reason: "must be in (0, 1]",
        });
    }
    let scheme = ExplicitScheme::from_method(method).ok_or_else(|| FilterError::NoStableStep {
        method: method.to_string(),
    })?;
    let filtered = matches!(
        (filter, scheme),
        (
            Some((_, FilterCoupling::Increment)),
            ExplicitScheme::ForwardBackwardEuler
        )
    );
    let prediction = predict_dt_max(
        model,
        x,
        filter.filter(|_| filtered).map(|(o, _)| o),
        scheme,
        &PowerParams::default(),
    )?;
    let coupling_factor = match filter {
        Some((_, FilterCoupling::VelocityOnly)) => std::f64::consts::FRAC_1_SQRT_2,
        _ => 1.0,
    };
    Ok(AutoStep {
        h: safety * coupling_factor * prediction.dt_max,
        prediction,
        filtered,
        coupling_factor,
    })
}

/// One row of figure 6: the stable step against the filter parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StableStepRow {
    /// The filter's lambda (`None`: unfiltered).
    pub lambda: Option<f64>,
    /// The measured stable step (largest bounded step of the bisection).
    pub measured_dt: f64,
    /// `dt_max` of the (modified) power method at the initial state.
    pub predicted_dt: f64,
    /// The (filtered) `k0`.
    pub k0: f64,
}

/// Figure 6: for each lambda (and first without a filter), the stable step
/// of `method` measured by bisection and the one predicted by the modified
/// power method, with the exponential kernel, the symmetric form and the
/// 1-ring (the defaults of [`FilterOptions`]) and the default coupling.
///
/// # Errors
/// As [`measure_stable_step`] and [`predict_dt_max`];
/// [`FilterError::InvalidParameter`] for a method outside eq. 11.
pub fn stable_step_against_lambda(
    build: &dyn Fn() -> Result<(MassSpringModel, State), FilterError>,
    method: &Method,
    lambdas: &[f64],
    opts: &BisectionOptions,
) -> Result<Vec<StableStepRow>, FilterError> {
    let scheme = ExplicitScheme::from_method(method).ok_or(FilterError::InvalidParameter {
        name: "method",
        value: f64::NAN,
        reason: "the stability criterion covers explicit Euler, FB Euler, Verlet and RK4",
    })?;
    let (model, state) = build()?;
    let params = PowerParams {
        rtol: 1e-6,
        ..Default::default()
    };
    let mut rows = Vec::with_capacity(lambdas.len() + 1);
    let settings = std::iter::once(None).chain(lambdas.iter().map(|&l| Some(l)));
    for lambda in settings {
        let options = lambda.map(|lambda| FilterOptions {
            kernel: Kernel::Exponential { lambda },
            ..Default::default()
        });
        let p = predict_dt_max(&model, &state.x, options.as_ref(), scheme, &params)?;
        let filter = options.map(|o| (o, FilterCoupling::default()));
        let m = measure_stable_step(build, method, filter, p.dt_max, opts)?;
        rows.push(StableStepRow {
            lambda,
            measured_dt: m.lo,
            predicted_dt: p.dt_max,
            k0: p.k0,
        });
    }
    Ok(rows)
}

/// The three runs of figures 4 and 5.
#[derive(Debug, Clone, PartialEq)]
pub enum DrapeMethod {
    /// Forward-backward Euler.
    FbEuler,
    /// Backward (implicit) Euler with PCG.
    BackwardEuler,
    /// FB Euler followed by the velocity filter.
    FilteredFbEuler(FilterOptions),
}

/// The data of figures 4 and 5 for one drape run.
#[derive(Debug, Clone)]
pub struct VelocityRun {
    /// Figure 4: one row per step, one pixel per particle.
    pub image: VelocityImage,
    /// The final velocity field.
    pub final_v: Vec<f64>,
    /// Figure 5: the power spectrum of the final velocity field (unshifted; see [`crate::fftshift`]).
    pub spectrum: Vec<f64>,
    /// High-frequency fraction of the final velocity field.
    pub final_high_frequency_fraction: f64,
    /// High-frequency share of the velocity energy summed over every step:
    /// `sum_steps high / sum_steps (all but the mean)`.
    pub mean_high_frequency_fraction: f64,
    /// Whether the run stayed bounded.
    pub outcome: RunOutcome,
}

/// Runs the (square) cloth `scene` for `t_end` seconds with step `h` and `method`, recording
/// the velocity image (velocities scaled by `scale` m/s) and the spectra
/// (frequency radius `> cutoff` of Nyquist counts as high).
///
/// # Errors
/// As [`run_bounded`]; [`FilterError::InvalidParameter`] for a cutoff outside `(0, sqrt 2)`.
pub fn drape_velocity_run(
    scene: &ClothParams,
    method: &DrapeMethod,
    h: f64,
    t_end: f64,
    scale: f64,
    cutoff: f64,
) -> Result<VelocityRun, FilterError> {
    if !(cutoff > 0.0 && cutoff < std::f64::consts::SQRT_2) {
        return Err(FilterError::InvalidParameter {
            name: "cutoff",
            value: cutoff,
            reason: "must lie in (0, sqrt 2)",
        });
    }
    if scene.nu != scene.nv {
        return Err(FilterError::InvalidParameter {
            name: "cloth (nv)",
            value: scene.nv as f64,
            reason: "the velocity image needs a square cloth (nu = nv)",
        });
    }
    let (model, state) = cloth(scene)?;
    let n = scene.nu;
    let (m, filter) = match method {
        DrapeMethod::FbEuler => (Method::FbEuler, None),
        DrapeMethod::BackwardEuler => (Method::ImplicitEuler, None),
        DrapeMethod::FilteredFbEuler(o) => (
            Method::FbEuler,
            Some((o.clone(), FilterCoupling::default())),
        ),
    };
    let mut sim = ModelIntegrator::new(model, &state, m, SolverOptions::with_h(h), filter)?;
    let mut image = VelocityImage::new(n * n);
    let (mut high, mut total) = (0.0, 0.0);
    let mut err = None;
    let outcome = run_observed(
        &mut sim,
        &RunOptions {
            t_end,
            energy_bound: f64::MAX,
            check_every: 1,
            ..Default::default()
        },
        |s| {
            if err.is_some() {
                return;
            }
            if let Err(e) = image.push(s.v(), scale) {
                err = Some(e);
                return;
            }
            match band_energies(s.v(), n, cutoff) {
                Ok((hi, all)) => {
                    high += hi;
                    total += all;
                }
                Err(e) => err = Some(e),
            }
        },
    )?;
    if let Some(e) = err {
        return Err(e);
    }
    let final_v = sim.v().to_vec();
    let spectrum = power_spectrum(&final_v, n, n)?;
    let (hi, all) = band_energies(&final_v, n, cutoff)?;
    Ok(VelocityRun {
        image,
        final_high_frequency_fraction: if all > 0.0 { hi / all } else { 0.0 },
        mean_high_frequency_fraction: if total > 0.0 { high / total } else { 0.0 },
        final_v,
        spectrum,
        outcome,
    })
}

/// (High-band energy, energy without the mean) of an `n x n` velocity field.
fn band_energies(v: &[f64], n: usize, cutoff: f64) -> Result<(f64, f64), FilterError> {
    let p = power_spectrum(v, n, n)?;
    let signed = |k: usize| {
        if k <= n / 2 {
            k as f64
        } else {
            k as f64 - n as f64
        }
    };
    let half = (n as f64 / 2.0).max(1.0);
    let (mut high, mut all) = (0.0, 0.0);
    for ky in 0..n {
        for kx in 0..n {
            if kx == 0 && ky == 0 {
                continue;
            }
            let (rx, ry) = (signed(kx) / half, signed(ky) / half);
            let e = p[ky * n + kx];
            all += e;
            if (rx * rx + ry * ry).sqrt() > cutoff {
                high += e;
            }
        }
    }
    Ok((high, all))
}
