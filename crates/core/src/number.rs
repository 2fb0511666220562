//! Numbers in messages: a value the user gave, shown as they would have typed it.
//!
//! Rust's `{}` writes an `f64` in full positional notation, so a mistyped `1e300` in an
//! error message would come back as 301 digits. [`shown`] writes everyday magnitudes as
//! `{}` does (`0.25`, `1.5`, `1000000000`) and the others in scientific notation (`1e300`,
//! `2.5e-9`).

/// `x` for a message: `{}` for `0` and magnitudes in `[10⁻⁴, 10¹⁶)` (at most 16 digits
/// before the point), `{:e}` otherwise
/// (NaN and infinities as `{}` writes them).
pub fn shown(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e16).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A computed `x` for a message, `decimals` after the point: fixed for magnitudes below
/// 10⁴, in scientific notation with as many decimals above (an optical depth of 10³⁰⁰
/// would otherwise print 300 digits).
pub fn rounded(x: f64, decimals: usize) -> String {
    if x.abs() < 1e4 || !x.is_finite() {
        format!("{x:.decimals$}")
    } else {
        format!("{x:.decimals$e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_as_typed_or_rounded_and_extremes_in_scientific_notation() {
        for (x, want) in [
            (0.0, "0"),
            (0.25, "0.25"),
            (-1.5, "-1.5"),
            (4000.0, "4000"),
            (1e-4, "0.0001"),
            (1e9, "1000000000"),
            (9_999_999_999_999_998.0, "9999999999999998"),
            (1e16, "1e16"),
            (1e300, "1e300"),
            (-2.5e-9, "-2.5e-9"),
            (f64::MAX, "1.7976931348623157e308"),
            (f64::MIN_POSITIVE, "2.2250738585072014e-308"),
            (f64::INFINITY, "inf"),
            (f64::NEG_INFINITY, "-inf"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(shown(x), want, "{x:?}");
        }
        for (x, d, want) in [
            (4.04, 1, "4.0"),
            (9999.94, 1, "9999.9"),
            (1e4, 1, "1.0e4"),
            (6.267e298, 1, "6.3e298"),
            (-0.125, 2, "-0.12"),
            (f64::INFINITY, 2, "inf"),
        ] {
            assert_eq!(rounded(x, d), want, "{x:?}");
        }
        // Never longer than a round-tripping scientific form.
        for x in [1e300, 6.267e297, 1.234e-200] {
            assert!(shown(x).len() <= 25, "{}", shown(x));
        }
    }
}
