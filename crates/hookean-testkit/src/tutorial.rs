//! The ODE examples of Hauth's tutorial (section 2) with exact solutions.
//!
//! They live in [`hookean_ode::tutorial`] (the `hookean workprecision`
//! command needs them and must not depend on this unpublished crate); this
//! module re-exports them so existing users keep compiling.

pub use hookean_ode::tutorial::*;
