//! The documented ranges of the numbers a user gives: one [`Range`] per
//! kind of value, the one source of the scene keys' checks (their docs say
//! `Range (0, 1)` in the key listing, `scene::KEYS`, and `tests/ranges.rs` checks
//! every documented range at its ends against what is refused and what
//! builds) and of the command line's flags that take the same
//! quantity (`--omega` as `solver.omega`, `--amg-jacobi-weight` as
//! `solver.amg.jacobi_weight`).
//!
//! A refusal says the range and the value as the user wrote it:
//!
//! ```
//! use hookean::range::{Range, TOLERANCE};
//! assert_eq!(TOLERANCE.to_string(), "[1e-14, 1)");
//! assert_eq!(TOLERANCE.check(2.0).unwrap_err(), "must lie in [1e-14, 1), got 2");
//! assert_eq!(TOLERANCE.check(1e-300).unwrap_err(), "must lie in [1e-14, 1), got 1e-300");
//! assert!(TOLERANCE.check(1e-3).is_ok());
//! assert!(Range::POSITIVE.check(f64::NAN).is_err());
//! ```

use std::fmt;

use hookean_sparse::{AsWritten, Short};

/// An interval of `f64` values, each end open or closed; an infinite end
/// is always open (no infinity is a valid value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// The lower end.
    pub lo: f64,
    /// Whether `lo` itself is in the range.
    pub lo_closed: bool,
    /// The upper end.
    pub hi: f64,
    /// Whether `hi` itself is in the range.
    pub hi_closed: bool,
}

impl Range {
    /// `(lo, hi)`.
    pub const fn open(lo: f64, hi: f64) -> Self {
        Self {
            lo,
            lo_closed: false,
            hi,
            hi_closed: false,
        }
    }

    /// `[lo, hi]`.
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Self {
            lo,
            lo_closed: true,
            hi,
            hi_closed: true,
        }
    }

    /// `[lo, hi)`.
    pub const fn closed_open(lo: f64, hi: f64) -> Self {
        Self {
            lo,
            lo_closed: true,
            hi,
            hi_closed: false,
        }
    }

    /// `(lo, hi]`.
    pub const fn open_closed(lo: f64, hi: f64) -> Self {
        Self {
            lo,
            lo_closed: false,
            hi,
            hi_closed: true,
        }
    }

    /// `(0, inf)`: lengths, masses, stiffnesses, durations.
    pub const POSITIVE: Range = Range::open(0.0, f64::INFINITY);
    /// `[0, inf)`: damping, friction, rates that may be off.
    pub const NON_NEGATIVE: Range = Range::closed_open(0.0, f64::INFINITY);
    /// `(0, 1)`: relative tolerances of solves, forcing terms.
    pub const FRACTION: Range = Range::open(0.0, 1.0);
    /// `(-inf, inf)`: any finite number.
    pub const FINITE: Range = Range::open(f64::NEG_INFINITY, f64::INFINITY);

    /// Whether `v` lies in the range (never NaN or infinite).
    pub fn contains(&self, v: f64) -> bool {
        let above = if self.lo_closed {
            v >= self.lo
        } else {
            v > self.lo
        };
        let below = if self.hi_closed {
            v <= self.hi
        } else {
            v < self.hi
        };
        above && below && v.is_finite()
    }

    /// `v` if it lies in the range, else `must lie in (a, b), got v` with
    /// `v` as the user wrote it (the shortest form that reads back).
    ///
    /// # Errors
    /// The message above, for a value outside the range.
    pub fn check(&self, v: f64) -> Result<f64, String> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(format!("must lie in {self}, got {}", AsWritten(v)))
        }
    }
}

impl fmt::Display for Range {
    /// `(0, inf)`, `[1e-14, 1)`: the form of the keys' docs.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}{}, {}{}",
            if self.lo_closed { '[' } else { '(' },
            Short(self.lo),
            Short(self.hi),
            if self.hi_closed { ']' } else { ')' },
        )
    }
}

/// `integrator.rtol`: the variable-step methods' relative tolerance. Below
/// 1e-14 the error test asks for less than the round-off of a step (the
/// variable-order BDF's tolerance `rtol^p` with `p` up to 2 underflows to
/// 0 near 1e-154); at 1 and above the error control accepts any step.
pub const TOLERANCE: Range = Range::closed_open(1e-14, 1.0);
/// `integrator.atol`: the variable-step methods' absolute tolerance (m,
/// m/s). Below 1e-15 the steps shrink to the round-off of the time (1e-20
/// stopped the 4 x 4 cloth's first step at h = 3e-17 s).
pub const ABSOLUTE_TOLERANCE: Range = Range::closed_open(1e-15, f64::INFINITY);
/// `integrator.h_safety`.
pub const STEP_SAFETY: Range = Range::open_closed(0.0, 1.0);
/// `solver.omega` and `hookean solve --omega`: SSOR's relaxation.
pub const SSOR_OMEGA: Range = Range::open(0.0, 2.0);
/// `solver.mic_omega`: MIC(0)'s relaxation.
pub const MIC_OMEGA: Range = Range::closed(0.0, 1.0);
/// `solver.amg.strength_threshold` and `--amg-strength`.
pub const AMG_STRENGTH: Range = Range::closed_open(0.0, 1.0);
/// `solver.amg.jacobi_weight`, `solver.amg.prolongation_weight` and their
/// flags `--amg-jacobi-weight`, `--amg-prolongation-weight`: times
/// `rho(D^-1 A)`.
pub const AMG_WEIGHT: Range = Range::open(0.0, 2.0);
/// The masses of a model (`cloth.mass`, `rope.mass`, `jelly.mass`,
/// `mesh.mass`, kg). Newton's residual norm sums squares of
/// `m_i dv_i` (about the particle's mass times g h): with a cloth of
/// 1e-200 kg they underflow to 0, the first step counts as converged and
/// the model stays frozen; above 1e100 kg they overflow alike. Within
/// [1e-100, 1e100] the squares stay normal numbers for any particle count
/// the memory cap allows.
pub const MASS: Range = Range::closed(1e-100, 1e100);

/// The lengths of a model (`cloth.size`, `rope.length`, `jelly.spacing`,
/// m): a spring's length is the square root of a sum of
/// squares, which overflows to infinity at 1e300 m and underflows to a
/// zero-length spring at 5e-324 m. Within [1e-100, 1e100] the squares stay
/// normal numbers for any grid the memory cap allows.
pub const LENGTH: Range = Range::closed(1e-100, 1e100);
/// A `[[pin]]` group's `weight`: 1 a hard pin, below 1 a soft pin of
/// stiffness `weight * stiffness`, 0 no pull.
pub const PIN_WEIGHT: Range = Range::closed(0.0, 1.0);
/// `mesh.scale`, the factor on an OBJ file's coordinates: the mesh checks
/// its faces' squared areas (products of four coordinates), which
/// underflow to a "degenerate face" at a scale of 1e-100 on coordinates of
/// order 1.
pub const SCALE: Range = Range::closed(1e-50, 1e50);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ends_are_in_or_out_as_the_brackets_say() {
        let r = Range::closed_open(1.0, 2.0);
        assert!(r.contains(1.0) && !r.contains(2.0));
        assert!(r.contains(2f64.next_down()) && !r.contains(1f64.next_down()));
        let r = Range::open_closed(1.0, 2.0);
        assert!(!r.contains(1.0) && r.contains(2.0));
        assert!(!Range::POSITIVE.contains(f64::INFINITY));
        assert!(!Range::FINITE.contains(f64::NEG_INFINITY));
        assert!(Range::FINITE.contains(-1e308));
        assert!(!Range::FINITE.contains(f64::NAN));
        assert_eq!(Range::NON_NEGATIVE.to_string(), "[0, inf)");
        assert_eq!(Range::FINITE.to_string(), "(-inf, inf)");
        assert_eq!(MASS.to_string(), "[1e-100, 1e100]");
    }
}
