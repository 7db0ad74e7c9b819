//! Test support for the Hookean crates (not published): generators of the
//! reference cloth systems, random SPD matrices, a jump-coefficient
//! diffusion system, small dense helpers, a
//! spring chain as a second-order problem, and a counting global allocator
//! for "allocates nothing" tests. (The tutorial's ODE examples with exact
//! solutions live in `hookean_ode::tutorial`.)
//!
//! Everything here is deterministic: the same arguments give the same bits.

pub mod alloc;
pub mod cloth;
pub mod dense;
pub mod diffusion;
pub mod fuzz;
pub mod intersect;
pub mod random;
#[cfg(unix)]
pub mod special;
pub mod springs;
