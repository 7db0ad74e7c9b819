#![doc = include_str!("../README.md")]
//!
//! # The crate's map
//!
//! The facade re-exports five crates of the workspace, each as a module
//! behind a feature of its own (all on by default):
//!
//! | module | crate | what |
//! |---|---|---|
//! | [`sparse`] | `hookean-sparse` | 3x3 block matrices, PCG and filtered PCG, GMRES, the preconditioners (Jacobi / block-Jacobi / SSOR / IC(0) / MIC(0) / multigrid), Matrix Market I/O |
//! | [`nonlinear`] | `hookean-nonlinear` | Newton, inexact Newton (forcing terms), simplified Newton; PCG, GMRES and LU for the correction |
//! | [`ode`] | `hookean-ode` | explicit, symplectic, implicit, IMEX and BDF integrators (the variable-order BDF), step-size controllers, stability regions |
//! | [`massspring`] | `hookean-massspring` | particles, springs, damping, pins, colliders, contact and self-collision, builders, OBJ |
//! | [`filter`] | `hookean-filter` | velocity filtering of explicit schemes, `dt_max` |
//!
//! and adds [`Simulation`] (a model, an integrator and its solvers, run
//! step-wise or to an end time, with output [`Sink`]s: the per-step CSV, OBJ
//! frames and progress of [`sinks`]), scene files ([`scene`]) and point
//! caches of a run's frames for other tools ([`cache`]: PC2, MDD).
//!
//! # Drape a cloth
//!
//! ```
//! use hookean::prelude::*;
//!
//! let (model, state) = cloth(&ClothParams { nu: 24, nv: 24, ..Default::default() })?;
//! let mut sim = Simulation::new(model, state, SimulationOptions::default())?; // implicit Euler, h = 0.01
//! let summary = sim.run_until(0.5)?;
//! let lowest = sim.x().chunks(3).map(|p| p[2]).fold(f64::INFINITY, f64::min);
//! assert!(lowest < -0.1, "the free corners fall");
//! println!("{} steps, {} CG iterations", summary.stats.num_steps, summary.stats.num_lin_iters);
//! # Ok::<(), hookean::HookeanError>(())
//! ```
//!
//! # Options structs
//!
//! [`SimulationOptions`] (and the options structs of the crates it
//! re-exports) have a `Default`:
//! construct them with `..Default::default()`. Each has a hidden field, so
//! that a later version may add an option without breaking your code; a
//! literal naming every field does not compile outside this crate.
//!
//! ```
//! use hookean::prelude::*;
//! let options = SimulationOptions { method: Method::FbEuler, ..Default::default() };
//! let (model, state) = rope(&RopeParams { n: 5, ..Default::default() })?;
//! let sim = Simulation::new(model, state, options)?;
//! assert!(matches!(sim.method(), Method::FbEuler));
//! # Ok::<(), hookean::HookeanError>(())
//! ```
//!
//! ```compile_fail
//! use hookean::prelude::*;
//! use hookean::filter::FilterCoupling;
//! // Every field named, none left to the default: refused outside the crate.
//! let options = SimulationOptions {
//!     method: Method::FbEuler,
//!     solver: SolverOptions::default(),
//!     filter: None,
//!     filter_coupling: FilterCoupling::Increment,
//!     blow_up_factor: 1e6,
//! };
//! ```

#[cfg(feature = "filter")]
pub use hookean_filter as filter;
#[cfg(feature = "massspring")]
pub use hookean_massspring as massspring;
#[cfg(feature = "nonlinear")]
pub use hookean_nonlinear as nonlinear;
#[cfg(feature = "ode")]
pub use hookean_ode as ode;
#[cfg(feature = "sparse")]
pub use hookean_sparse as sparse;

// The seal of the options structs (`SimulationOptions`), which all need the
// `filter` feature.
#[cfg(feature = "filter")]
hookean_sparse::non_exhaustive_seal!();

#[cfg(feature = "filter")]
pub mod cache;
#[cfg(feature = "filter")]
mod error;
#[cfg(feature = "filter")]
mod pin_work;
#[cfg(feature = "sparse")]
pub mod range;
#[cfg(feature = "filter")]
pub mod scene;
#[cfg(feature = "filter")]
mod simulation;
#[cfg(feature = "filter")]
pub mod sinks;

#[cfg(feature = "filter")]
pub use error::HookeanError;
#[cfg(feature = "filter")]
pub use hookean_ode::StateRecord;
#[cfg(feature = "filter")]
pub use simulation::{RunSummary, Simulation, SimulationOptions, Sink};

/// The names most programs need.
pub mod prelude {
    #[cfg(feature = "filter")]
    pub use crate::{HookeanError, RunSummary, Simulation, SimulationOptions, Sink};
    #[cfg(feature = "filter")]
    pub use hookean_filter::{FilterOptions, Kernel, VelocityFilter};
    #[cfg(feature = "massspring")]
    pub use hookean_massspring::{
        ClothParams, ClothPins, Collider, MassSpringModel, RopeParams, SpringMaterial, State,
        cloth, jelly_block, rope,
    };
    #[cfg(feature = "ode")]
    pub use hookean_ode::{ForcingTerm, Method, NewtonMethod, SolverOptions};
    #[cfg(feature = "sparse")]
    pub use hookean_sparse::PrecondKind;
}

/// The repository's README and the user's guide (`docs/guide`), whose Rust
/// blocks run as doctests of this crate (`cargo test -p hookean --doc`). Only
/// under `cfg(doctest)`: a normal or packaged build never reads these files,
/// which lie outside the crate.
#[cfg(doctest)]
mod guide {
    macro_rules! pages {
        ($($name:ident = $path:literal;)*) => {
            $(#[doc = include_str!(concat!("../../../", $path))] pub struct $name;)*
        };
    }
    pages! {
        Readme = "README.md";
        GettingStarted = "docs/guide/src/getting-started.md";
        Preconditioners = "docs/guide/src/preconditioners.md";
        Multigrid = "docs/guide/src/multigrid.md";
        StiffOdes = "docs/guide/src/stiff-odes.md";
        Newton = "docs/guide/src/newton.md";
        Scenes = "docs/guide/src/scenes.md";
        Contact = "docs/guide/src/contact.md";
        Filter = "docs/guide/src/filter.md";
        Reliability = "docs/guide/src/reliability.md";
    }
}
