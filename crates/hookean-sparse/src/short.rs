//! Numbers in messages, printed short: the one formatter of every error
//! and report line of the workspace that shows a computed number (a time,
//! a step size, a residual), so that a message never prints the 17 digits
//! of a round-off (`t = 4994.205015461171`) or the 300 of a tiny number in
//! plain decimal (`t = 0.000…0001`).
//!
//! [`Short`] prints at most six significant digits, like C's `%g`: plain
//! decimal for exponents -4 to 5, scientific notation outside, trailing
//! zeros dropped. A user's own value is quoted as they wrote it by
//! [`AsWritten`]: every digit that reads back to the same `f64`, and no
//! more, in the shorter of plain and scientific form (`1e8`, `0.05`,
//! `1e-300`, `0.1234567`).
//!
//! ```
//! use hookean_sparse::Short;
//! assert_eq!(Short(4994.205015461171).to_string(), "4994.21");
//! assert_eq!(Short(1e-300).to_string(), "1e-300");
//! assert_eq!(Short(1.5625e-4).to_string(), "0.00015625");
//! assert_eq!(Short(100000.0).to_string(), "100000");
//! assert_eq!(Short(1234567.0).to_string(), "1.23457e6");
//! assert_eq!(Short(f64::INFINITY).to_string(), "inf");
//!
//! use hookean_sparse::short::AsWritten;
//! assert_eq!(AsWritten(1e8).to_string(), "1e8");
//! assert_eq!(AsWritten(0.05).to_string(), "0.05");
//! assert_eq!(AsWritten(2.0).to_string(), "2");
//! assert_eq!(AsWritten(0.1234567).to_string(), "0.1234567");
//! assert_eq!(AsWritten(-1e-300).to_string(), "-1e-300");
//! ```

use std::fmt;

/// An `f64` that displays with at most six significant digits
/// ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Short(pub f64);

/// Significant digits of [`Short`].
const DIGITS: usize = 6;

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v.is_nan() {
            return f.write_str("NaN");
        }
        if v.is_infinite() {
            return f.write_str(if v > 0.0 { "inf" } else { "-inf" });
        }
        if v == 0.0 {
            return f.write_str(if v.is_sign_negative() { "-0" } else { "0" });
        }
        // Rounded to DIGITS significant digits first: its exponent decides
        // the form (9.999995 rounds to 1.00000e1).
        let sci = format!("{:.*e}", DIGITS - 1, v);
        let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
        let exp: i32 = exp.parse().unwrap_or(0);
        if (-4..DIGITS as i32).contains(&exp) {
            let decimals = (DIGITS as i32 - 1 - exp).max(0) as usize;
            let plain = format!("{:.*}", decimals, v);
            f.write_str(trim_zeros(&plain))
        } else {
            write!(f, "{}e{exp}", trim_zeros(mantissa))
        }
    }
}

/// An `f64` as a user wrote it: its shortest round-trip digits, in the
/// shorter of plain (`0.05`, `2`) and scientific (`1e8`) form
/// ([module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AsWritten(pub f64);

impl fmt::Display for AsWritten {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if !v.is_finite() {
            return Short(v).fmt(f);
        }
        let plain = format!("{v:?}");
        let plain = plain.strip_suffix(".0").unwrap_or(&plain);
        let sci = format!("{v:e}");
        f.write_str(if sci.len() < plain.len() { &sci } else { plain })
    }
}

/// `1.50000` -> `1.5`, `2.000` -> `2`; a number without a point is kept.
fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn at_most_six_significant_digits_and_the_value_kept_to_them() {
        for (v, text) in [
            (0.1 + 0.2, "0.3"),
            (-2.5, "-2.5"),
            (0.05, "0.05"),
            (1e-4, "0.0001"),
            (9.99e-5, "9.99e-5"),
            (999999.0, "999999"),
            (9999995.0, "1e7"),
            (9.999995, "10"),
            (1e300, "1e300"),
            (-1.234567e-300, "-1.23457e-300"),
            (f64::MIN_POSITIVE, "2.22507e-308"),
            (5e-324, "4.94066e-324"),
            (f64::MAX, "1.79769e308"),
            (f64::NEG_INFINITY, "-inf"),
            (f64::NAN, "NaN"),
            (-0.0, "-0"),
        ] {
            assert_eq!(Short(v).to_string(), text, "{v:e}");
        }
        for (v, text) in [
            (1e8, "1e8"),
            (1e-5, "1e-5"),
            (123.5, "123.5"),
            (1e16, "1e16"),
        ] {
            assert_eq!(AsWritten(v).to_string(), text);
        }
        // A user's value reads back exactly.
        for v in [0.1 + 0.2, 1.0 / 3.0, 6.02214076e23, 5e-324, f64::MAX] {
            assert_eq!(AsWritten(v).to_string().parse::<f64>().unwrap(), v);
        }
        // Every form reads back within the rounding of six digits.
        for k in -320..=308 {
            let v = 1.2345678 * 10f64.powi(k);
            let back: f64 = Short(v).to_string().parse().unwrap();
            assert!(
                ((back - v) / v).abs() <= 5e-6 || v < 1e-300,
                "{v:e} printed {}",
                Short(v)
            );
            assert!(Short(v).to_string().len() <= 13, "{}", Short(v));
        }
    }
}
