//! Time integration for soft-object simulation (section 2 of Hauth's
//! tutorial): the problem traits that models implement and integrators consume.
//!
//! (The integrators themselves land with issue 4; this first version holds
//! the problem contracts that `hookean-massspring` implements.)

pub mod problem;

pub use problem::{FirstOrderProblem, SecondOrderProblem};
