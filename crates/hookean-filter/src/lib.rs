//! Velocity filtering of explicit mass-spring integrators, after Ahmad,
//! Adly, Terraz and Ghazanfarpour, "Stability Analysis of Filtered
//! Mass-Spring Systems" (TPCG 2007).
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

mod error;
pub mod experiments;
mod filtered;
mod spectrum;
mod stability;
mod velocity;

pub use error::FilterError;
pub use experiments::{
    BisectionOptions, DrapeMethod, DrapeScene, Prediction, RunOptions, RunOutcome, Simulation,
    StableStep, StableStepRow, VelocityRun, drape_velocity_run, measure_stable_step,
    predict_dt_max, run_bounded, stable_step_against_lambda,
};
pub use filtered::{FilterCoupling, FilterStats, FilteredIntegrator};
pub use spectrum::{VelocityImage, fftshift, high_frequency_fraction, power_spectrum};
pub use stability::{ExplicitScheme, dt_max, filtered_k0};
pub use velocity::{Edge, FilterOptions, Form, Kernel, VelocityFilter};
