//! Test support for the Hookean crates (not published): generators of the
//! reference cloth systems, random SPD matrices and small dense helpers.
//!
//! Everything here is deterministic: the same arguments give the same bits.

pub mod cloth;
pub mod dense;
pub mod random;
