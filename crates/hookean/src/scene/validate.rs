//! The validators of scene values (ranges, finite numbers, arrays of exactly three): serde `deserialize_with` functions whose messages name the key.

use super::*;

pub(super) fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must be a positive number, got {v:?}"
        )))
    }
}

pub(super) fn non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v >= 0.0 && v.is_finite() {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must be a non-negative number, got {v:?}"
        )))
    }
}

pub(super) fn fraction<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v > 0.0 && v < 1.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("must lie in (0, 1), got {v:?}")))
    }
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
    let v = f64::deserialize(d)?;
    if v > 0.0 && v < 2.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "SSOR relaxation must lie in (0, 2), got {v:?}"
        )))
    }
}

pub(super) fn mic_omega<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "MIC(0) relaxation must lie in [0, 1], got {v:?}"
        )))
    }
}
