//! `∫ dt / (a t² + 2b t + c)`, the integral behind every equipotential ("blob") function
//! of paper D §3.2.3 in its density reading (see [`crate::blob`]), in forms that stay
//! accurate at the extremes: a ray grazing or crossing the blob's center, a ray nearly
//! parallel to a line blob (`a → 0`), very long rays far from the blob.

/// `∫_{t0}^{t1} dt / (a t² + 2b t + c)` for `a > 0`, given the discriminant
/// `disc = a c − b²` computed by the caller without cancellation (a sum of squares for
/// the blobs), and assuming the denominator has no zero on `[t0, t1]`.
///
/// With `v = a t + b` the integral is `∫ dv / (v² + disc)`:
/// - `disc > 0`: `[atan(v/√disc)]/√disc`, written `atan2((v1 − v0)√disc, disc + v0 v1)/√disc`
///   (the difference of two arctangents, exact for any `v0, v1`, no cancellation near
///   `±π/2` on long rays);
/// - `disc < 0`, `κ = √−disc`: `[ln|(v − κ)/(v + κ)|]/(2κ)`, written
///   `ln(1 + 2κ(v1 − v0)/((v1 + κ)(v0 − κ)))/(2κ)` (valid when `v0, v1` lie on one side of
///   both roots, which the caller guarantees);
/// - `disc = 0`: the common limit `(v1 − v0)/(v0 v1)`.
pub fn inv_quadratic(a: f64, b: f64, disc: f64, t0: f64, t1: f64) -> f64 {
    if t1 <= t0 {
        return 0.0;
    }
    let (v0, v1) = (a * t0 + b, a * t1 + b);
    let dv = a * (t1 - t0);
    if disc > 0.0 {
        let s = disc.sqrt();
        (dv * s).atan2(disc + v0 * v1) / s
    } else if disc < 0.0 {
        let k = (-disc).sqrt();
        (2.0 * k * dv / ((v1 + k) * (v0 - k))).ln_1p() / (2.0 * k)
    } else {
        dv / (v0 * v1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Composite Simpson on `n` (even) intervals.
    fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
        let h = (b - a) / n as f64;
        let mut s = f(a) + f(b);
        for i in 1..n {
            s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(a + i as f64 * h);
        }
        s * h / 3.0
    }

    #[test]
    fn every_branch_matches_simpson() {
        // (a, b, c, t0, t1): complex roots, real roots with the interval beside them on
        // either side, a double root beside the interval.
        let cases = [
            (1.0, 0.3, 2.0, -3.0, 5.0),
            (0.5, -1.0, 0.1, -2.0, 0.0),
            (1.0, 0.0, -1.0, 1.5, 6.0),
            (1.0, 0.0, -1.0, -6.0, -1.5),
            (2.0, 2.0, 2.0, 0.0, 3.0),
        ];
        for (a, b, c, t0, t1) in cases {
            let disc: f64 = a * c - b * b;
            let want = simpson(|t| 1.0 / (a * t * t + 2.0 * b * t + c), t0, t1, 200_000);
            let got = inv_quadratic(a, b, disc, t0, t1);
            assert!(
                (got - want).abs() < 1e-9 * want.abs(),
                "{a} {b} {c}: {got} vs {want}"
            );
        }
    }
}
