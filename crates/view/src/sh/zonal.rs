//! Zonal harmonics (ZH): functions symmetric about an axis, their rotation, convolution
//! with them, and the Henyey–Greenstein phase function (paper A §5.3, appendix).
//!
//! A function `h(cos θ)` symmetric about +Z has only `m = 0` coefficients; its zonal
//! vector is `zh[l] = ∫ h·Y_l0 dω = 2π·√((2l+1)/4π)·∫₋₁¹ h(μ) P_l(μ) dμ`, one per band.

use std::f64::consts::PI;

use super::basis::{band_of, eval_into, index, order_of};
use super::quad::gauss_legendre;
use crate::distant::direction;

/// `√(4π/(2l+1))`, the factor of rotation and convolution.
fn band_factor(l: usize) -> f64 {
    (4.0 * PI / (2 * l + 1) as f64).sqrt()
}

/// SH coefficients (order `zh.len()`) of the zonal function `zh` rotated so that its
/// symmetry axis, +Z, becomes `axis`: `f_lm = √(4π/(2l+1))·zh_l·Y_lm(axis)` (addition
/// theorem). `axis` need not be normalized; the zero vector keeps +Z.
pub fn zh_rotate(zh: &[f64], axis: [f64; 3]) -> Vec<f64> {
    let order = zh.len();
    let mut out = vec![0.0; order * order];
    eval_into(order, axis, &mut out);
    for (i, v) in out.iter_mut().enumerate() {
        let l = band_of(i);
        *v *= band_factor(l) * zh[l];
    }
    out
}

/// Zonal coefficients (one per band, `l < order`) of `f(cos θ)`, integrated in θ by
/// 128 panels of 8-point Gauss–Legendre: accurate to rounding for integrands smooth on
/// the scale of π/128 (e.g. HG up to |g| = 0.95, whose forward peak is ~0.05 rad wide).
pub fn zh_project(order: usize, f: impl Fn(f64) -> f64) -> Vec<f64> {
    let rule = gauss_legendre(8);
    let mut zh = vec![0.0; order];
    let mut y = vec![0.0; order * order];
    let panels = 128;
    let h = PI / panels as f64;
    for p in 0..panels {
        let mid = (p as f64 + 0.5) * h;
        for &(x, w) in &rule {
            let t = mid + 0.5 * h * x;
            eval_into(order, direction(t, 0.0), &mut y);
            let v = 2.0 * PI * 0.5 * h * w * f(t.cos()) * t.sin();
            for (l, z) in zh.iter_mut().enumerate() {
                *z += v * y[index(l, 0)];
            }
        }
    }
    zh
}

/// Convolution with a circularly symmetric kernel `h` given by its zonal vector
/// (`kernel_zh.len() ≥` the order of `f`):
/// `(f ∗ h)(s) = ∫ f(t)·h(s·t) dt`, i.e. `(f ∗ h)_lm = √(4π/(2l+1))·h_l·f_lm`
/// (Funk–Hecke). The delta kernel `h_l = √((2l+1)/4π)` is the identity; with the phase
/// function as `h`, `(1/4π)(L ∗ p)` is the in-scattered radiance of paper A eq. 11.
pub fn convolve(f: &[f64], kernel_zh: &[f64]) -> Vec<f64> {
    let order = order_of(f.len());
    assert!(
        kernel_zh.len() >= order,
        "kernel of {} bands for an order-{order} function",
        kernel_zh.len()
    );
    f.iter()
        .enumerate()
        .map(|(i, v)| {
            let l = band_of(i);
            band_factor(l) * kernel_zh[l] * v
        })
        .collect()
}

/// Zonal coefficients of the Henyey–Greenstein phase function as `medium::hg` normalizes
/// it (`(1/4π)∫p dω = 1`): `p = Σ_l (2l+1)·g^l·P_l(μ)`, hence `p_l = √(4π(2l+1))·g^l`.
pub fn hg_zh(g: f64, order: usize) -> Vec<f64> {
    (0..order)
        .map(|l| (4.0 * PI * (2 * l + 1) as f64).sqrt() * g.powi(l as i32))
        .collect()
}

/// Zonal vector of the optical depth `∫₀^∞ B(tω) dt` through a Gaussian
/// `B(x) = exp(−|x − c|²/r²)` (paper A's RBF without its 3r cut-off) seen from the
/// origin, with `c` at distance `d` on +Z: by completing the square,
/// `T(μ) = r·(√π/2)·exp(−(d/r)²(1 − μ²))·(1 + erf((d/r)·μ))`.
pub fn gaussian_optical_depth_zh(order: usize, d: f64, r: f64) -> Vec<f64> {
    let k = d / r;
    zh_project(order, |mu| {
        r * 0.5 * PI.sqrt() * (-(k * k) * (1.0 - mu * mu)).exp() * (1.0 + libm::erf(k * mu))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::hg;
    use crate::sh::basis::{count, reconstruct};
    use crate::sh::project::project_fn;

    fn unit(v: [f64; 3]) -> [f64; 3] {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|c| c / n)
    }

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    #[test]
    fn rotated_zh_matches_direct_projection_of_the_rotated_function() {
        // A band-limited zonal function (degree 5 in μ) rotated to `axis` is the
        // degree-5 polynomial h(ω·axis); 6 × 11 nodes project h·Y (degree ≤ 10) exactly,
        // so both routes agree to rounding.
        let h = |mu: f64| 0.3 + mu - 0.7 * mu * mu * mu + 0.2 * mu.powi(5);
        let zh = zh_project(6, h);
        for axis in [
            [0.0, 0.0, 1.0],
            [1.0, 2.0, -0.5],
            [0.0, 0.0, -3.0],
            [0.3, -0.1, 0.0],
        ] {
            let a = unit(axis);
            let rotated = zh_rotate(&zh, axis);
            let direct = project_fn(6, |d| h(dot(d, a)), 6, 11);
            for (i, (r, d)) in rotated.iter().zip(&direct).enumerate() {
                assert!((r - d).abs() < 1e-12, "{axis:?} {i}: {r} vs {d}");
            }
        }
        // The zero axis keeps +Z: only m = 0 survives, equal to zh.
        let up = zh_rotate(&zh, [0.0; 3]);
        for l in 0..6 {
            assert!((up[index(l, 0)] - zh[l]).abs() < 1e-12);
        }
    }

    #[test]
    fn band_energy_is_rotation_invariant() {
        let zh = gaussian_optical_depth_zh(6, 2.0, 0.7);
        let energy = |f: &[f64]| -> Vec<f64> {
            (0..6)
                .map(|l| (l * l..(l + 1) * (l + 1)).map(|i| f[i] * f[i]).sum())
                .collect()
        };
        let z = energy(&zh_rotate(&zh, [0.0, 0.0, 1.0]));
        for axis in [[1.0, 0.0, 0.0], [0.4, -2.0, 0.9], [-1.0, -1.0, -1.0]] {
            let e = energy(&zh_rotate(&zh, axis));
            for l in 0..6 {
                // Σ_m Y_lm(a)² = (2l+1)/4π for every unit a: equality to rounding.
                assert!((e[l] - z[l]).abs() < 1e-12 * (1.0 + z[l]), "{axis:?} l {l}");
                assert!((z[l] - zh[l] * zh[l]).abs() < 1e-12 * (1.0 + z[l]));
            }
        }
    }

    #[test]
    fn hg_closed_form_matches_numerical_projection() {
        for g in [-0.95, 0.0, 0.5, 0.95] {
            let closed = hg_zh(g, 6);
            // Independent route: the full SH projection of p(ω·Z) on a fine grid (the
            // g = ±0.95 lobe is ~0.05 rad wide: 400 latitudes resolve it to < 1e-6).
            let numeric = project_fn(6, |d| hg(g, d[2]), 400, 13);
            let via_zh = zh_project(6, |mu| hg(g, mu));
            for l in 0..6 {
                let scale = closed[0];
                let i = index(l, 0);
                assert!(
                    (numeric[i] - closed[l]).abs() < 1e-6 * scale,
                    "g {g} l {l}: {} vs {}",
                    numeric[i],
                    closed[l]
                );
                assert!(
                    (via_zh[l] - closed[l]).abs() < 1e-9 * scale,
                    "g {g} l {l}: {} vs {}",
                    via_zh[l],
                    closed[l]
                );
            }
        }
    }

    #[test]
    fn convolution_identities_and_funk_hecke() {
        let f: Vec<f64> = (0..count(5))
            .map(|i| ((i * 5 % 7) as f64 - 3.0) * 0.3)
            .collect();
        let delta: Vec<f64> = (0..5)
            .map(|l| ((2 * l + 1) as f64 / (4.0 * PI)).sqrt())
            .collect();
        let same = convolve(&f, &delta);
        for (a, b) in same.iter().zip(&f) {
            assert!((a - b).abs() < 1e-14);
        }
        // A constant kernel h ≡ 2 has h_0 = 2√(4π) only: keeps band 0, scaled by 8π.
        let constant = zh_project(5, |_| 2.0);
        let c = convolve(&f, &constant);
        assert!((c[0] - 8.0 * PI * f[0]).abs() < 1e-11, "{}", c[0]);
        assert!(c[1..].iter().all(|v| v.abs() < 1e-12), "{c:?}");
        // Direct ∫ f(t) h(s·t) dt with HG g = 0.6 truncated to order 5 (a polynomial of
        // degree 4 in s·t: 5 × 9 nodes integrate f·h exactly).
        let kernel = hg_zh(0.6, 5);
        let conv = convolve(&f, &kernel);
        for s in [[0.0, 0.0, 1.0], unit([1.0, -2.0, 0.3])] {
            let kh = zh_rotate(&kernel, s);
            let direct = project_fn(1, |t| reconstruct(&f, t) * reconstruct(&kh, t), 5, 9)[0]
                * (4.0 * PI).sqrt();
            let got = reconstruct(&conv, s);
            assert!(
                (got - direct).abs() < 1e-11 * (1.0 + direct.abs()),
                "{s:?}: {got} vs {direct}"
            );
        }
        // Eq. 11 sanity: p ≡ 1 gives Ω·mean, i.e. (1/4π)(L ∗ p) keeps the mean.
        let iso = convolve(&f, &hg_zh(0.0, 5));
        assert!((iso[0] / (4.0 * PI) - f[0]).abs() < 1e-14);
    }
}
