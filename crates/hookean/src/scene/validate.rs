//! The validators of scene values (ranges, finite numbers, arrays of exactly three): serde `deserialize_with` functions whose messages name the key.

use super::*;
use crate::range::{self, Range};

/// A number in its documented range `range` (the key's doc says
/// "Range (0, inf)"; `tests/ranges.rs` checks every documented range at
/// its ends): the one check of every real-valued key.
pub(super) fn in_range<'de, D: Deserializer<'de>>(d: D, range: Range) -> Result<f64, D::Error> {
    range.check(f64::deserialize(d)?).map_err(D::Error::custom)
}

pub(super) fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, Range::POSITIVE)
}

pub(super) fn non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, Range::NON_NEGATIVE)
}

pub(super) fn fraction<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, Range::FRACTION)
}

/// `integrator.rtol` ([`range::TOLERANCE`]).
pub(super) fn tolerance<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::TOLERANCE)
}

/// `integrator.atol` ([`range::ABSOLUTE_TOLERANCE`]).
pub(super) fn absolute_tolerance<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::ABSOLUTE_TOLERANCE)
}

/// The models' lengths (`cloth.size`, `rope.length`, `jelly.spacing`;
/// [`range::LENGTH`]).
pub(super) fn length<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::LENGTH)
}

/// `mesh.scale` ([`range::SCALE`]).
pub(super) fn scale<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::SCALE)
}

/// The models' `mass` keys ([`range::MASS`]).
pub(super) fn mass<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::MASS)
}

pub(super) fn at_least_two<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if v >= 2 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "needs at least 2 particles, got {v:?}"
        )))
    }
}

pub(super) fn at_least_one<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
    let v = usize::deserialize(d)?;
    if v >= 1 {
        Ok(v)
    } else {
        Err(D::Error::custom("must be at least 1"))
    }
}

/// An integer key in its documented range `LO..=HI` (the key's doc says
/// "Range LO to HI"; a test checks every documented range at its ends).
pub(super) fn int_in<'de, D: Deserializer<'de>, const LO: usize, const HI: usize>(
    d: D,
) -> Result<usize, D::Error> {
    let v = u64::deserialize(d)?;
    if (LO as u64..=HI as u64).contains(&v) {
        Ok(v as usize)
    } else {
        Err(D::Error::custom(format!(
            "must lie in {LO} to {HI}, got {v}"
        )))
    }
}

/// Exactly three numbers (a longer or shorter array is an error, not
/// truncated).
pub(super) fn three<'de, D: Deserializer<'de>, T: Deserialize<'de> + Copy>(
    d: D,
) -> Result<[T; 3], D::Error> {
    let v = Vec::<T>::deserialize(d)?;
    <[T; 3]>::try_from(v.as_slice())
        .map_err(|_| D::Error::custom(format!("must be an array of 3 numbers, got {}", v.len())))
}

pub(super) fn usize3<'de, D: Deserializer<'de>>(d: D) -> Result<[usize; 3], D::Error> {
    three(d)
}

pub(super) fn finite3<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 3], D::Error> {
    let v: [f64; 3] = three(d)?;
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(D::Error::custom("components must be finite numbers"))
    }
}

pub(super) fn method<'de, D: Deserializer<'de>>(d: D) -> Result<Method, D::Error> {
    let s = String::deserialize(d)?;
    s.parse().map_err(|e| D::Error::custom(format!("{e}")))
}

pub(super) fn precond<'de, D: Deserializer<'de>>(d: D) -> Result<Option<PrecondKind>, D::Error> {
    let s = String::deserialize(d)?;
    if s == "auto" {
        return Ok(None);
    }
    s.parse()
        .map(Some)
        .map_err(|e| D::Error::custom(format!("{e} (or \"auto\")")))
}

pub(super) fn omega<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::SSOR_OMEGA)
}

pub(super) fn mic_omega<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    in_range(d, range::MIC_OMEGA)
}
