#![doc = include_str!("../README.md")]
//!
//! # The crate's map
//!
//! Implicit solves low-pass filter the forces (the paper's eq. 9: the
//! forward substitution of a Cholesky solve is a recursive exponential
//! filter). This crate reproduces that filter after explicit steps, as a
//! post-processing unit that leaves the integrator a black box, and gives
//! the matching stability criterion:
//!
//! - [`VelocityFilter`]: the exponential filter `beta(d) = lambda exp(-lambda |d|)`
//!   (eq. 10) or a Gaussian, in the paper's symmetric form, on k-ring
//!   neighbourhoods of the spring graph, precomputed once (O(n) per
//!   application, no allocation). Pinned particles keep their velocity.
//! - [`filtered_k0`] and [`dt_max`]: the modified power method (Algorithm 1)
//!   and `dt_max = 2 / sqrt(k0)` (eq. 11; `sqrt(8.75) / sqrt(k0)` for RK4).
//! - [`power_spectrum`], [`high_frequency_fraction`], [`VelocityImage`]: the
//!   frequency analysis of section 5 (figures 4 and 5).
//! - [`FilteredIntegrator`]: any explicit integrator of `hookean-ode`
//!   (forward Euler, FB Euler, Verlet, RK4) followed by the filter, the
//!   integrator a black box, itself an `hookean_ode::Integrator` (a
//!   decorator of the one stepping contract); [`FilterCoupling`] says how the filtered
//!   velocities go back (default: the velocity change of the step is
//!   filtered, for which `dt_max = 2 / sqrt(k0)` with the filtered `k0` is
//!   exact in the linear analysis of FB Euler). Measured (docs/perf/filter.md):
//!   the filter enlarges FB Euler's stable step as the paper says, but a
//!   post-step filter barely helps Verlet (1.03x) and RK4 (1.1x), whose
//!   stages it cannot reach.
//! - [`experiments`]: the drape scene, bounded-energy runs, the stable step
//!   by bisection and the data of figures 4, 5 and 6 ([`drape_velocity_run`],
//!   [`stable_step_against_lambda`]).
//!
//! # Which distance unit the numbers hold for
//!
//! `d` in `beta(d)` is the spring-graph distance in units of the model's
//! shortest rest length (a structural neighbour of a cloth grid is at
//! `d = 1`, a shear neighbour at `sqrt 2`). With this unit and the 1-ring,
//! the symmetric form and `lambda = 1` enlarge FB Euler's stable step on the
//! 12x12 reference drape by 1.32x (the plain form: 2.06x, the paper's
//! "doubled"), and `lambda = 10` leaves it unchanged (tests/paper.rs). In
//! metres the same `lambda` would filter a fine mesh much more strongly.
//!
//! # Example
//!
//! ```
//! use hookean_filter::{Edge, FilterOptions, Kernel, VelocityFilter};
//! // A rope of 5 particles, springs of rest length 0.1 m.
//! let edges: Vec<Edge> = (1..5).map(|i| Edge { i: i - 1, j: i, rest_length: 0.1 }).collect();
//! let mut filter = VelocityFilter::new(5, &edges, None, FilterOptions {
//!     kernel: Kernel::Exponential { lambda: 1.0 },
//!     ..Default::default()
//! })?;
//! // A velocity spike on the middle particle is spread to its neighbours.
//! let mut v = vec![0.0; 15];
//! v[3 * 2 + 1] = 1.0;
//! filter.apply(&mut v)?;
//! assert!(v[3 * 2 + 1] < 1.0 && v[3 * 1 + 1] > 0.0 && v[3 * 3 + 1] > 0.0);
//! # Ok::<(), hookean_filter::FilterError>(())
//! ```
//!
//! # Example: filtered FB Euler on the drape at 1.25 times the unfiltered limit
//!
//! ```
//! use hookean_filter::{ExplicitScheme, FilterCoupling, FilterOptions,
//!                      FilteredIntegrator, VelocityFilter, predict_dt_max};
//! use hookean_massspring::{ClothParams, cloth};
//! use hookean_ode::{Integrator, Method, SecondOrderIntegrator, SolverOptions};
//!
//! let (model, state) = cloth(&ClothParams::drape(8))?;
//! let plain = predict_dt_max(&model, &state.x, None, ExplicitScheme::ForwardBackwardEuler,
//!                            &Default::default())?;
//! let filtered = predict_dt_max(&model, &state.x, Some(&FilterOptions::default()),
//!                               ExplicitScheme::ForwardBackwardEuler, &Default::default())?;
//! assert!(filtered.dt_max > 1.25 * plain.dt_max);
//!
//! let h = 1.25 * plain.dt_max;
//! let filter = VelocityFilter::from_model(&model, FilterOptions::default())?;
//! let inner = SecondOrderIntegrator::new(model, Method::FbEuler, 0.0, &state.x, &state.v,
//!                                        SolverOptions::with_h(h))?;
//! let mut sim = FilteredIntegrator::new(inner, filter, FilterCoupling::default())?;
//! sim.integrate(0.1)?;
//! assert!(sim.v().iter().all(|v| v.abs() < 10.0));
//! # Ok::<(), hookean_filter::FilterError>(())
//! ```
//!
//! # Options structs
//!
//! [`FilterOptions`], [`RunOptions`] and [`BisectionOptions`] have a `Default`:
//! construct them with `..Default::default()`. Each has a hidden field, so
//! that a later version may add an option without breaking your code; a
//! literal naming every field does not compile outside this crate.
//!
//! ```
//! use hookean_filter::{BisectionOptions, FilterOptions, RunOptions};
//! let bisection = BisectionOptions {
//!     run: RunOptions { t_end: 0.5, ..Default::default() },
//!     ..Default::default()
//! };
//! let filter = FilterOptions { rings: 2, ..Default::default() };
//! assert_eq!((bisection.run.t_end, filter.rings), (0.5, 2));
//! assert_eq!(bisection.max_runs, BisectionOptions::default().max_runs);
//! ```
//!
//! ```compile_fail
//! use hookean_filter::{BisectionOptions, RunOptions};
//! // Every field named, none left to the default: refused outside the crate.
//! let bisection = BisectionOptions { run: RunOptions::default(), rel_tol: 0.02, max_runs: 40 };
//! ```

hookean_sparse::non_exhaustive_seal!();

mod error;
pub mod experiments;
mod figure8;
mod filtered;
mod model_integrator;
mod spectrum;
mod stability;
mod velocity;

pub use error::FilterError;
pub use experiments::{
    AutoStep, BisectionOptions, DrapeMethod, Prediction, RunOptions, RunOutcome, StableStep,
    StableStepRow, VelocityRun, auto_step, drape_velocity_run, measure_stable_step, predict_dt_max,
    run_bounded, stable_step_against_lambda,
};
pub use figure8::{Figure8Method, Figure8Row, figure8_runs};
pub use filtered::{FilterCoupling, FilterStats, FilteredIntegrator, position_weight};
pub use model_integrator::ModelIntegrator;
pub use spectrum::{VelocityImage, fftshift, high_frequency_fraction, power_spectrum};
pub use stability::{ExplicitScheme, dt_max, filtered_k0};
pub use velocity::{
    Edge, FilterOptions, Form, Kernel, PlanStats, STENCIL_WEIGHT_RTOL, VelocityFilter,
};
