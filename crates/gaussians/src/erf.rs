//! The error function as paper B's line integral needs it (appendix A, eq. 31).
//!
//! * [`erf_diff`]: `erf(x1) − erf(x0)` without cancellation, from the platform C math
//!   library's `erf`/`erfc` ([`erf`], [`erfc`]: glibc, musl, Apple's libm and the UCRT all
//!   give them to about 1 ulp). This is what the CPU renderer uses; [`erf_diff_from`]
//!   takes the start's tail `erfc(|x0|)` from the caller, so a line integral whose start
//!   is fixed (the depth along one ray up to many ends) costs one `erfc` an end.
//! * [`erf_paper`]: the paper's "fast Chebyshev approximation" `erf(x) ≈ x·P(z)`,
//!   `z = 0.289226x² − 1` for `|x| ≤ 2.629639`, `±1` beyond. The coefficients of `P` are
//!   lost in the text; these are a degree-6 least-squares re-fit on `z ∈ [−1, 1]`. Measured
//!   against libm (test `paper_erf_error`): `1.03·10⁻⁴` inside the range, `2.001·10⁻⁴`
//!   overall — the clamp alone sets the bound (`erfc(2.629639) = 2.0012·10⁻⁴`), so the
//!   paper's "< 2·10⁻⁴" is not quite met.
//! * [`erf_as`]: Abramowitz & Stegun 7.1.26, `1 − (a₁t + … + a₅t⁵)e^{−x²}`,
//!   `t = 1/(1 + px)`: absolute error `≤ 1.5·10⁻⁷`, what the WGSL shader can afford in `f32`.
//!
//! The C library's `erf` is kept on the CPU (eleven orders of magnitude better than the
//! paper's; an absolute `2·10⁻⁴` error is large relative to the line integral of a thin
//! or short crossing, 2 % at `a·dr = 0.01`). It is also the fastest measured: the pure-Rust
//! `libm` crate's `erfc`, with its own software `exp`, was a third of a 5000-Gaussian frame
//! (BENCHMARKS "Paper B: many Gaussians").

use std::f64::consts::PI;

/// The re-fitted coefficients of the paper's `P(z)`, lowest degree first.
const PAPER_P: [f64; 7] = [
    0.5332235, -0.249209, 0.1554527, -0.0908981, 0.052731, -0.0336514, 0.0125944,
];

/// Where the paper's approximation saturates to `±1`.
pub const PAPER_LIMIT: f64 = 2.629639;

/// Paper B's erf approximation (module docs).
pub fn erf_paper(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x.abs() > PAPER_LIMIT {
        return x.signum();
    }
    let z = 0.289226 * x * x - 1.0;
    x * PAPER_P.iter().rev().fold(0.0, |acc, &c| acc * z + c)
}

/// Abramowitz & Stegun 7.1.26 (module docs), odd in `x`.
pub fn erf_as(x: f64) -> f64 {
    const P: f64 = 0.3275911;
    const A: [f64; 5] = [
        0.254829592,
        -0.284496736,
        1.421413741,
        -1.453152027,
        1.061405429,
    ];
    let ax = x.abs();
    let t = 1.0 / (1.0 + P * ax);
    let poly = A.iter().rev().fold(0.0, |acc, &c| acc * t + c) * t;
    let y = 1.0 - poly * (-ax * ax).exp();
    if x < 0.0 { -y } else { y }
}

unsafe extern "C" {
    /// The platform C math library's error function (C99 `erf`, about 1 ulp).
    pub safe fn erf(x: f64) -> f64;
    /// The platform C math library's complementary error function (C99 `erfc`, about
    /// 1 ulp, relative in the upper tail down to its underflow near `x = 27`).
    pub safe fn erfc(x: f64) -> f64;
}

/// `erf(x1) − erf(x0)` for `x0 ≤ x1` (either may be infinite), without cancellation:
/// through `erfc` of the tail when both lie on one side of 0, by the midpoint expansion
/// `(2/√π)e^{−m²}Δ·(1 + (2m² − 1)Δ²/12)` (`m` the midpoint, `Δ = x1 − x0`) when the
/// interval is so short that `Δ·max(1, |m|) < 10⁻³` (the next term is `O(Δ⁴m⁴) < 10⁻¹²`
/// relative).
pub fn erf_diff(x0: f64, x1: f64) -> f64 {
    short_interval(x0, x1).unwrap_or_else(|| {
        if x0 >= 0.0 {
            erfc(x0) - erfc(x1)
        } else if x1 <= 0.0 {
            erfc(-x1) - erfc(-x0)
        } else {
            // Across 0 each `erf` is cheap past |x| = 6, where it is 1 to the last bit.
            erf(x1) - erf(x0)
        }
    })
}

/// [`erf_diff`] with the start's tail `tail0 = erfc(|x0|)` given (module docs), one error
/// function fewer: the same value in the tails, and within `10⁻¹²` of it relative across
/// 0, where it takes `erf(|x0|)` as `1 − tail0` (test
/// `a_given_start_tail_gives_the_same_difference`).
pub fn erf_diff_from(x0: f64, tail0: f64, x1: f64) -> f64 {
    short_interval(x0, x1).unwrap_or_else(|| {
        if x0 >= 0.0 {
            tail0 - erfc(x1)
        } else if x1 <= 0.0 {
            erfc(-x1) - tail0
        } else {
            erf(x1) + (1.0 - tail0)
        }
    })
}

/// [`erf_diff`]'s empty and short intervals; `None` for the rest.
fn short_interval(x0: f64, x1: f64) -> Option<f64> {
    let delta = x1 - x0;
    if delta <= 0.0 || delta.is_nan() {
        return Some(0.0);
    }
    let mid = 0.5 * (x0 + x1);
    (delta.is_finite() && delta * mid.abs().max(1.0) < 1e-3).then(|| {
        2.0 / PI.sqrt()
            * (-mid * mid).exp()
            * delta
            * (1.0 + (2.0 * mid * mid - 1.0) * delta * delta / 12.0)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest `|f(x) − erf(x)|` over `x ∈ [lo, hi]` on a fine grid (libm's erf as the
    /// truth).
    fn max_error(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
        let n = 200_000;
        (0..=n)
            .map(|i| {
                let x = lo + (hi - lo) * i as f64 / n as f64;
                (f(x) - libm::erf(x)).abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn paper_erf_error() {
        let inside = max_error(erf_paper, -PAPER_LIMIT, PAPER_LIMIT);
        let overall = max_error(erf_paper, -6.0, 6.0);
        println!("paper erf: max error {inside:.3e} inside, {overall:.4e} overall");
        assert!(inside < 1.1e-4, "{inside}");
        // The clamp sets the bound: erfc(2.629639) = 2.0012e-4.
        assert!(
            (overall - libm::erfc(PAPER_LIMIT)).abs() < 1e-7,
            "{overall}"
        );
        assert_eq!(erf_paper(-7.0), -1.0);
        assert!(erf_paper(f64::NAN).is_nan());
    }

    #[test]
    fn abramowitz_stegun_error() {
        let e = max_error(erf_as, -8.0, 8.0);
        println!("A&S 7.1.26: max error {e:.3e}");
        assert!(e < 1.5e-7, "{e}");
    }

    /// `erf(x1) − erf(x0) = (2/√π)∫ e^{−t²} dt` by composite Simpson (2000 panels: error
    /// ~ h⁴ ≪ 1e-13 relative on these intervals).
    fn simpson(x0: f64, x1: f64) -> f64 {
        let n = 2000;
        let h = (x1 - x0) / n as f64;
        let f = |t: f64| (-t * t).exp();
        let mut s = f(x0) + f(x1);
        for i in 1..n {
            s += f(x0 + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        2.0 / PI.sqrt() * s * h / 3.0
    }

    #[test]
    fn erf_diff_matches_quadrature_in_the_tails_and_for_short_intervals() {
        for (x0, x1) in [
            (-1.0, 2.0),
            // Across 0 with one end near it, and far on both sides.
            (-0.01, 2.0),
            (-3.0, 0.05),
            (-5.5, 4.0),
            (3.0, 3.5),
            (6.0, 7.0),
            (-9.0, -8.0),
            (20.0, 20.5),
            (0.5, 0.5 + 1e-5),
            (-7.0, -7.0 + 1e-5),
            (12.0, 12.0 + 5e-5),
        ] {
            let want = simpson(x0, x1);
            let got = erf_diff(x0, x1);
            let rel = (got - want).abs() / want;
            assert!(rel < 1e-9, "[{x0}, {x1}]: {got:e} vs {want:e} ({rel:e})");
        }
        // The naive difference is all rounding in a far tail; erf_diff is not.
        let naive = libm::erf(7.0) - libm::erf(6.0);
        assert_eq!(naive, 0.0);
        assert!(erf_diff(6.0, 7.0) > 0.0);
        assert_eq!(erf_diff(1.0, 1.0), 0.0);
        assert_eq!(erf_diff(2.0, 1.0), 0.0);
        assert_eq!(erf_diff(f64::NEG_INFINITY, f64::INFINITY), 2.0);
        assert!((erf_diff(-1.0, f64::INFINITY) - libm::erfc(-1.0)).abs() < 4.5e-16);
    }

    #[test]
    fn a_given_start_tail_gives_the_same_difference() {
        // erf_diff_from's `1 − erfc(|x0|)` across 0 against erf_diff's `erf(x1) − erf(x0)`,
        // and its tails, over starts and ends on both sides, near 0 and far out.
        let xs: [f64; 13] = [
            -30.0, -6.5, -2.0, -1.0, -0.3, -1e-3, 0.0, 2e-3, 0.3, 1.0, 2.0, 6.5, 27.5,
        ];
        for &x0 in &xs {
            let tail0 = erfc(x0.abs());
            for &x1 in &xs {
                for x1 in [x1, x1 + 5e-4, x1 + 0.7, f64::INFINITY] {
                    let (want, got) = (erf_diff(x0, x1), erf_diff_from(x0, tail0, x1));
                    // Across 0, `1 − erfc(|x0|)` is exact to 2.2e-16 absolute; past the
                    // short intervals such a difference is at least (2/√π)e⁻¹·10⁻³ ≈ 4e-4,
                    // so 1e-12 relative.
                    assert!(
                        (got - want).abs() <= 1e-12 * want,
                        "[{x0}, {x1}]: {got:e} vs {want:e}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_platform_erf_matches_libm() {
        // Two independent implementations (the C library's and the libm crate's).
        for i in -3000..=3000 {
            let x = f64::from(i) / 250.0;
            assert!(
                (erf(x) - libm::erf(x)).abs() <= 4.0 * f64::EPSILON,
                "erf {x}"
            );
            let (a, b) = (erfc(x), libm::erfc(x));
            assert!(
                (a - b).abs() <= 4.0 * f64::EPSILON * b,
                "erfc {x}: {a:e} {b:e}"
            );
        }
        assert!(erf(f64::NAN).is_nan() && erfc(f64::NAN).is_nan());
        assert_eq!((erf(f64::INFINITY), erfc(f64::INFINITY)), (1.0, 0.0));
        assert_eq!(erfc(30.0), 0.0);
    }
}
