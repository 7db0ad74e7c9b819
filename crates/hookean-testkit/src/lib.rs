//! Test support for the Hookean crates (not published): generators of the
//! reference cloth systems, random SPD matrices, small dense helpers and
//! the tutorial's ODE examples 1-3 with exact solutions, and a counting
//! global allocator for "allocates nothing" tests.
//!
//! Everything here is deterministic: the same arguments give the same bits.

pub mod alloc;
pub mod cloth;
pub mod dense;
pub mod random;
pub mod springs;
pub mod tutorial;
