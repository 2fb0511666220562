//! The real, orthonormal SH basis and its evaluation (paper A, appendix).
//!
//! `Y_lm(θ, φ)` for `m > 0` is `√2·K_lm·P_l^m(cos θ)·cos(mφ)`, for `m < 0`
//! `√2·K_l|m|·P_l^|m|(cos θ)·sin(|m|φ)`, and `K_l0·P_l(cos θ)` for `m = 0`, with
//! `K_lm = √((2l+1)/(4π)·(l−m)!/(l+m)!)` and **no Condon–Shortley phase**: the associated
//! Legendre functions are `P_m^m = (2m−1)!!·sin^m θ` (positive). Band 1 is therefore
//! `√(3/4π)·(y, z, x)`, all signs positive. Paper A's appendix (like the D3DX tables of
//! Sloan's "Stupid SH tricks") includes the phase, `y_1 = −√(3/4π)·y`, `y_3 = −√(3/4π)·x`:
//! multiply a coefficient by `(−1)^|m|` to convert either way.

use std::f64::consts::PI;

/// Number of coefficients of an order-`order` projection (bands `0..order`).
pub fn count(order: usize) -> usize {
    order * order
}

/// Index of `Y_lm` in a coefficient vector: `l·(l+1) + m`, `m ∈ [−l, l]`.
pub fn index(l: usize, m: i64) -> usize {
    assert!(m.unsigned_abs() as usize <= l, "m = {m} outside band {l}");
    ((l * (l + 1)) as i64 + m) as usize
}

/// The SH basis of order `order` at direction `dir` (need not be normalized; the zero
/// or a non-finite vector evaluates at +Z, as `distant::angles` does).
pub fn eval(order: usize, dir: [f64; 3]) -> Vec<f64> {
    let mut out = vec![0.0; count(order)];
    eval_into(order, dir, &mut out);
    out
}

/// [`eval`] into `out` (length ≥ `order²`; only the first `order²` entries are written).
///
/// Uses the fully normalized recurrences on `Q̄_l^m = K_lm·P_l^m / sin^m θ` (polynomials
/// in `z = cos θ`), stable for every direction including the poles:
/// `Q̄_0^0 = 1/√(4π)`, `Q̄_m^m = √((2m+1)/(2m))·Q̄_{m−1}^{m−1}`,
/// `Q̄_{m+1}^m = √(2m+3)·z·Q̄_m^m`,
/// `Q̄_l^m = a_lm·(z·Q̄_{l−1}^m − b_lm·Q̄_{l−2}^m)` with `a_lm = √((4l²−1)/(l²−m²))`,
/// `b_lm = √(((l−1)²−m²)/(4(l−1)²−1))`. The azimuthal factors `sin^m θ·cos(mφ)` and
/// `sin^m θ·sin(mφ)` are the real and imaginary parts of `(x + iy)^m`, so no angle is
/// ever computed.
pub fn eval_into(order: usize, dir: [f64; 3], out: &mut [f64]) {
    assert!(
        out.len() >= count(order),
        "SH output of {} for order {order}",
        out.len()
    );
    if order == 0 {
        return;
    }
    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
    let (x, y, z) = if n > 0.0 && n.is_finite() {
        (dir[0] / n, dir[1] / n, dir[2] / n)
    } else {
        (0.0, 0.0, 1.0)
    };
    let z = z.clamp(-1.0, 1.0);
    let table = (order <= TABLED).then(recurrence_table);
    // (cm, sm) = Re, Im of (x + iy)^m.
    let (mut cm, mut sm) = (1.0, 0.0);
    let mut qmm = 1.0 / (4.0 * PI).sqrt();
    for m in 0..order {
        let factors = |l: usize| match table {
            Some(t) => t[m * TABLED + l],
            None => recurrence_factors(l, m),
        };
        if m > 0 {
            qmm *= factors(m).0;
            (cm, sm) = (cm * x - sm * y, cm * y + sm * x);
        }
        let (ca, sa) = if m == 0 {
            (1.0, 0.0)
        } else {
            (std::f64::consts::SQRT_2 * cm, std::f64::consts::SQRT_2 * sm)
        };
        let put = |out: &mut [f64], l: usize, q: f64| {
            let base = l * (l + 1);
            out[base + m] = q * ca;
            if m > 0 {
                out[base - m] = q * sa;
            }
        };
        put(out, m, qmm);
        if m + 1 >= order {
            continue;
        }
        let mut q_prev = qmm;
        let mut q = factors(m + 1).0 * z * qmm;
        put(out, m + 1, q);
        for l in m + 2..order {
            let (a, b) = factors(l);
            let next = a * (z * q - b * q_prev);
            q_prev = q;
            q = next;
            put(out, l, q);
        }
    }
}

/// The orders whose recurrence factors [`eval_into`] reads from a table (computed once);
/// higher orders compute them per call.
const TABLED: usize = 32;

/// [`recurrence_factors`] of every `(l, m)` with `l, m < TABLED`, at `m·TABLED + l`.
fn recurrence_table() -> &'static [(f64, f64)] {
    static TABLE: std::sync::OnceLock<Vec<(f64, f64)>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        (0..TABLED * TABLED)
            .map(|i| recurrence_factors(i % TABLED, i / TABLED))
            .collect()
    })
}

/// The factors of [`eval_into`]'s recurrences at `(l, m)`: for `l = m`,
/// `(√((2m+1)/(2m)), 0)` (`Q̄_m^m` from `Q̄_{m−1}^{m−1}`); for `l = m + 1`, `(√(2m+3), 0)`;
/// above, `(a_lm, b_lm)`. `(0, 0)` where none applies (`l < m`, or `l = m = 0`).
fn recurrence_factors(l: usize, m: usize) -> (f64, f64) {
    let (lf, mf) = (l as f64, m as f64);
    if l < m || l == 0 {
        (0.0, 0.0)
    } else if l == m {
        (((2.0 * mf + 1.0) / (2.0 * mf)).sqrt(), 0.0)
    } else if l == m + 1 {
        ((2.0 * mf + 3.0).sqrt(), 0.0)
    } else {
        let a = ((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf)).sqrt();
        let b =
            (((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0)).sqrt();
        (a, b)
    }
}

/// Value at `dir` of the function with SH coefficients `coeffs` (order `√len`).
pub fn reconstruct(coeffs: &[f64], dir: [f64; 3]) -> f64 {
    let order = order_of(coeffs.len());
    let y = eval(order, dir);
    coeffs.iter().zip(&y).map(|(c, y)| c * y).sum()
}

/// The order `n` of a coefficient vector of length `n²`; panics on other lengths.
pub fn order_of(len: usize) -> usize {
    let n = (len as f64).sqrt().round() as usize;
    assert_eq!(
        n * n,
        len,
        "{len} is not a square number of SH coefficients"
    );
    n
}

/// Band `l` of coefficient index `i` (`i = l(l+1) + m`).
pub fn band_of(i: usize) -> usize {
    (i as f64).sqrt().floor() as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distant::direction;
    use crate::sh::quad::SphereGrid;

    #[test]
    fn orthonormal_by_quadrature_for_orders_1_to_6() {
        for order in 1..=6 {
            // Products Y_i·Y_j have degree ≤ 2(order−1) in (x, y, z); a Gauss–Legendre ×
            // uniform-φ grid with `order + 1` latitudes and `2·order + 1` longitudes
            // integrates them exactly, so only rounding (~1e-15) remains.
            let grid = SphereGrid::new(order + 1, 2 * order + 1);
            let n = count(order);
            let mut gram = vec![0.0; n * n];
            for (d, w) in grid.points() {
                let y = eval(order, d);
                for i in 0..n {
                    for j in 0..n {
                        gram[i * n + j] += w * y[i] * y[j];
                    }
                }
            }
            for i in 0..n {
                for j in 0..n {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!(
                        (gram[i * n + j] - want).abs() < 1e-12,
                        "order {order} ({i},{j}): {}",
                        gram[i * n + j]
                    );
                }
            }
        }
    }

    #[test]
    fn bands_0_to_2_match_the_closed_forms() {
        let c0 = 0.5 / PI.sqrt();
        let c1 = (3.0 / (4.0 * PI)).sqrt();
        let c2 = 0.5 * (15.0 / PI).sqrt();
        let c20 = 0.25 * (5.0 / PI).sqrt();
        for &(t, p) in &[(0.0, 0.0), (0.4, 1.0), (1.3, 2.5), (2.2, 4.0), (PI, 0.3)] {
            let [x, y, z] = direction(t, p);
            let want = [
                c0,
                c1 * y,
                c1 * z,
                c1 * x,
                c2 * x * y,
                c2 * y * z,
                c20 * (3.0 * z * z - 1.0),
                c2 * x * z,
                0.5 * c2 * (x * x - y * y),
            ];
            // Scaled input must not matter either.
            let got = eval(3, [3.0 * x, 3.0 * y, 3.0 * z]);
            for (i, (g, w)) in got.iter().zip(want).enumerate() {
                assert!((g - w).abs() < 1e-14, "θ {t} φ {p} index {i}: {g} vs {w}");
            }
        }
    }

    #[test]
    fn poles_and_degenerate_directions_are_finite() {
        let up = eval(6, [0.0, 0.0, 1.0]);
        for d in [[0.0; 3], [f64::NAN, 0.0, 0.0], [0.0, 0.0, f64::INFINITY]] {
            assert_eq!(eval(6, d), up, "{d:?}");
        }
        for d in [[0.0, 0.0, -2.0], [1e-300, 0.0, 1.0], [0.0, 1e-300, 0.0]] {
            assert!(eval(6, d).iter().all(|v| v.is_finite()), "{d:?}");
        }
        // At the poles only the zonal (m = 0) functions are non-zero, with value
        // Y_l0(±Z) = (±1)^l·√((2l+1)/4π).
        let down = eval(6, [0.0, 0.0, -1.0]);
        for l in 0..6 {
            for m in -(l as i64)..=l as i64 {
                let i = index(l, m);
                let want = if m == 0 {
                    ((2 * l + 1) as f64 / (4.0 * PI)).sqrt()
                } else {
                    0.0
                };
                let sign = if l % 2 == 0 { 1.0 } else { -1.0 };
                assert!((up[i] - want).abs() < 1e-14 && (down[i] - sign * want).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn tabled_and_computed_factors_agree_to_the_bit() {
        // Order TABLED reads the table, TABLED + 2 computes the factors per call: the
        // bands they share must be the same numbers (the same expressions).
        for dir in [[0.3, -0.5, 0.8], [1.0, 0.0, 0.0], [-0.2, 0.9, -0.4]] {
            let tabled = eval(TABLED, dir);
            let computed = eval(TABLED + 2, dir);
            assert_eq!(tabled[..], computed[..count(TABLED)]);
            assert!(computed.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn index_order_and_band_bookkeeping() {
        assert_eq!(index(0, 0), 0);
        assert_eq!(index(1, -1), 1);
        assert_eq!(index(2, 2), 8);
        assert_eq!(index(5, -5), 25);
        assert_eq!(order_of(36), 6);
        assert_eq!(
            (0..9).map(band_of).collect::<Vec<_>>(),
            [0, 1, 1, 1, 2, 2, 2, 2, 2]
        );
        assert_eq!(band_of(35), 5);
        assert_eq!(band_of(36), 6);
    }
}
