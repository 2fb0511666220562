//! Light a point light scatters once in the medium onto a surface point (paper C, §4 and
//! appendix B): the diffuse `G0` and Phong `Gn` functions, tabulated.
//!
//! From a surface point `p` at distance `Dsp` (optical `T = β·Dsp`) of the light, the
//! airlight arriving along a direction at angle `γ′` from the light direction is paper C's
//! airlight of an infinite ray, `σs·I/(2π Dsp sin γ′)·e^{−T}·H(T sin γ′, γ′/2)` (stable form,
//! [`crate::paper_c::hfunc`]). Integrated against a lobe `max(0, cos ψ)ⁿ` about an axis at angle
//! `θ` from the light (the normal, `n = 1`: Lambert's `cos θᵢ`; the mirror direction of the
//! view: Phong), in coordinates about the light direction the solid angle's `sin γ′`
//! cancels the `1/sin γ′`:
//!
//! `G(T, θ) = ∫₀^π e^{−T}·H(T sin γ′, γ′/2)·C_n(γ′, θ) dγ′`,
//! `C_n(γ′, θ) = ∫₀^{2π} max(0, cos γ′ cos θ + sin γ′ sin θ cos φ)ⁿ dφ`,
//!
//! so that the scattered radiance is `f·σs·I·G/(2π Dsp)` (`f` the lobe's BRDF factor) —
//! paper C's `kd·β²·I0·G0/(2π Tsp)` with the albedo, written without `0/0` at `β = 0`.
//! `C₁ = 2(Aφ₀ + B sin φ₀)` with `A = cos γ′ cos θ`, `B = sin γ′ sin θ`,
//! `φ₀ = acos(clamp(−A/B))`; other exponents integrate `φ` numerically. `θ` runs over
//! `[0, π]`: light below the surface's horizon still scatters onto it (`G0(0, π)` is 22 %
//! of `G0(0, 0)`).
//!
//! The table holds `(1 + T)·e^{T}·G(T, θ)`, which varies slowly (it grows like `ln T`),
//! on `x = T/(1 + T)` uniform over `[0, T_MAX/(1 + T_MAX)]` and `θ` uniform over `[0, π]`;
//! beyond `T_MAX = 50` the scattered light (`< e^{−50}·I/Dsp`) is 0.

use super::htable::HTable;
use super::quad::{adaptive_pieces, composite, gauss_legendre};
use super::table::Table2;
use nalgebra::DMatrix;
use std::f64::consts::PI;

/// Largest optical distance light–surface the table covers.
pub const T_MAX: f64 = 50.0;

/// Default table size: 256 values of `T` × 256 of `θ`, `f32` (256 KiB). Measured
/// largest relative errors (BENCHMARKS.md): 2.7·10⁻⁴ for `G0`, 7·10⁻⁴ for `G20`,
/// 2.3·10⁻³ for `G100` (at large `T` the scattered light takes the lobe's shape, which a
/// sharp lobe makes steep in `θ`).
pub const DEFAULT_SIZE: (usize, usize) = (256, 256);

/// `C_n(γ′, θ)`: the integral over the azimuth about the light of the lobe
/// `max(0, cos ψ)ⁿ` about an axis `θ` away from the light.
///
/// `2∫₀^{φ₀} (A + B cos φ)ⁿ dφ` ([module docs](self)): `n = 1` in closed form; `n ≥ 2` by the
/// trapezoidal rule on `⌈2φ₀√n⌉` equal panels (at least [`LOBE_MIN_PANELS`]), whose
/// Euler–Maclaurin error terms vanish at both ends — the integrand is even about `φ = 0`
/// and its first `n − 1` derivatives are 0 at `φ₀ < π` (or it is even about `φ₀ = π`
/// too) — so it converges far faster than its `h²` (the panels follow the lobe's width
/// `1/√n`); the nodes' cosines by rotation, one `sin_cos` a lobe. Measured against
/// composite Gauss–Legendre (test `lobe_matches_quadrature`): within `2·10⁻⁷` of the
/// lobe's peak for `n ≥ 2`, `10⁻¹³` from `n = 8`. Other `n` (the integrand's end not
/// smooth enough) by 2 × 24-point Gauss–Legendre.
pub fn lobe(gamma: f64, theta: f64, n: f64) -> f64 {
    let a = gamma.cos() * theta.cos();
    let b = gamma.sin() * theta.sin();
    if b <= 1e-12 {
        return 2.0 * PI * a.max(0.0).powf(n);
    }
    let phi0 = (-a / b).clamp(-1.0, 1.0).acos();
    if phi0 <= 0.0 {
        return 0.0;
    }
    if n == 1.0 {
        return 2.0 * (a * phi0 + b * phi0.sin());
    }
    let pow: Box<dyn Fn(f64) -> f64> = if n.fract() == 0.0 && n <= 4096.0 {
        let k = n as i32;
        Box::new(move |c: f64| c.powi(k))
    } else {
        Box::new(move |c: f64| c.powf(n))
    };
    let f = |cos: f64| pow((a + b * cos).max(0.0));
    if n >= 2.0 {
        let panels = ((2.0 * phi0 * n.sqrt()).ceil() as usize).clamp(LOBE_MIN_PANELS, 1 << 16);
        let h = phi0 / panels as f64;
        let (s1, c1) = h.sin_cos();
        let (mut c, mut s) = (1.0, 0.0);
        let mut sum = 0.5 * f(1.0);
        for _ in 1..panels {
            (c, s) = (c * c1 - s * s1, s * c1 + c * s1);
            sum += f(c);
        }
        sum += 0.5 * f(phi0.cos());
        return 2.0 * h * sum;
    }
    // 2∫₀^{φ₀} (A + B cos φ)ⁿ dφ: smooth on [0, φ₀], zero at φ₀ when φ₀ < π.
    thread_local! {
        static RULE: Vec<(f64, f64)> = gauss_legendre(24);
    }
    RULE.with(|rule| 2.0 * composite(|p| f(p.cos()), 0.0, phi0, rule, 2))
}

/// The fewest trapezoidal panels of [`lobe`] (an exponent near 2 needs them: `5·10⁻⁸` of
/// the peak at 24).
pub const LOBE_MIN_PANELS: usize = 24;

/// `G(T, θ)` by adaptive quadrature over `γ′`, with `H` from `h(u, w)`.
pub fn g_quadrature(h: impl Fn(f64, f64) -> f64, t: f64, theta: f64, n: f64, tol: f64) -> f64 {
    // Breakpoints: the lobe's edges (γ′ = |π/2 − θ|, π/2 + θ, θ for a sharp lobe) and the
    // scale 1/T of H's fall near the light direction.
    let mut pts = vec![0.0, PI];
    for p in [
        (0.5 * PI - theta).abs(),
        0.5 * PI + theta,
        theta,
        1.0 / (1.0 + t),
        4.0 / (1.0 + t),
    ] {
        if p > 1e-9 && p < PI - 1e-9 {
            pts.push(p);
        }
    }
    if n > 1.0 {
        let w = 3.0 / n.sqrt();
        pts.extend(
            [theta - w, theta + w]
                .into_iter()
                .filter(|&p| p > 1e-9 && p < PI - 1e-9),
        );
    }
    pts.sort_by(f64::total_cmp);
    pts.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    let f = |g: f64| {
        let c = lobe(g, theta, n);
        if c == 0.0 {
            0.0
        } else {
            h(t * g.sin(), 0.5 * g) * c
        }
    };
    (-t).exp() * adaptive_pieces(f, &pts, tol)
}

/// A tabulated `G` for one lobe exponent.
#[derive(Clone, Debug, PartialEq)]
pub struct GTable {
    pub exponent: f64,
    pub table: Table2,
}

impl GTable {
    /// Tabulates `G` for the exponent `n` (1: Lambert's `G0`) on `nx` values of `T` and
    /// `ny` of `θ`, integrating `H` from the table `h`.
    ///
    /// Every entry uses the same `γ′` nodes (Gauss–Legendre, 4 per panel, 512 equal
    /// panels over `[0, π]`: panels of 6·10⁻³ rad resolve `H`'s fall on the scale `1/T ≥
    /// 0.02` and a Phong lobe of width `1/√n`), so the table is a matrix product
    /// `[H(T_i, γ′_k)]·[w_k·C_n(γ′_k, θ_j)]` (nalgebra's, blocked and vectorized). The
    /// rule converges as `h²` (the lobe's edges and `H`'s bilinear table are not smooth
    /// between nodes); against 8192 panels
    /// every entry of a 256 × 256 table is within `1.4·10⁻⁵` (`G0`), `2.7·10⁻⁵` (`G100`),
    /// `4.6·10⁻⁵` (`G1000`) — 10–50× below the table's interpolation error
    /// ([`DEFAULT_SIZE`]); 1024 panels cost twice the time for nothing visible.
    pub fn new(h: &HTable, n: f64, (nx, ny): (usize, usize)) -> GTable {
        use rayon::prelude::*;
        let rule = gauss_legendre(4);
        let panels = 512;
        let step = PI / panels as f64;
        let nodes: Vec<(f64, f64)> = (0..panels)
            .flat_map(|p| {
                let c = (p as f64 + 0.5) * step;
                rule.iter()
                    .map(move |&(x, w)| (c + 0.5 * step * x, 0.5 * step * w))
            })
            .collect();
        let xmax = T_MAX / (1.0 + T_MAX);
        let t_of = |i: usize| {
            let xx = xmax * i as f64 / (nx - 1) as f64;
            xx / (1.0 - xx)
        };
        let sines: Vec<f64> = nodes.iter().map(|&(g, _)| g.sin()).collect();
        // L = [w_k·C_n(γ′_k, θ_j)], a column per θ.
        let lobes: Vec<f64> = (0..ny)
            .into_par_iter()
            .flat_map_iter(|j| {
                let theta = PI * j as f64 / (ny - 1) as f64;
                nodes.iter().map(move |&(g, w)| w * lobe(g, theta, n))
            })
            .collect();
        // H = [H(T_i sin γ′_k, γ′_k/2)], a row per T.
        let hs: Vec<f64> = (0..nx)
            .into_par_iter()
            .flat_map_iter(|i| {
                let t = t_of(i);
                nodes
                    .iter()
                    .zip(&sines)
                    .map(move |(&(g, _), &sin)| h.h(t * sin, 0.5 * g))
            })
            .collect();
        let k = nodes.len();
        let product =
            DMatrix::from_row_slice(nx, k, &hs) * DMatrix::from_column_slice(k, ny, &lobes);
        // (1 + T)·e^T·G = (1 + T)·Σ_k H_k·w_k·C_k; the product is column-major, as the table.
        let data: Vec<f32> = product
            .as_slice()
            .iter()
            .enumerate()
            .map(|(e, &v)| ((1.0 + t_of(e % nx)) * v) as f32)
            .collect();
        GTable {
            exponent: n,
            table: Table2 { nx, ny, data },
        }
    }

    /// `G(T, θ)` for `T ≥ 0`, `θ ∈ [0, π]`.
    pub fn g(&self, t: f64, theta: f64) -> f64 {
        if t.is_nan() || t > T_MAX {
            return 0.0;
        }
        let xmax = T_MAX / (1.0 + T_MAX);
        let q = self.table.at(t / (1.0 + t) / xmax, theta / PI);
        (-t).exp() * q / (1.0 + t)
    }

    pub fn bytes(&self) -> usize {
        self.table.bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper_c::hfunc::h_exact;
    use std::f64::consts::FRAC_PI_2;

    /// The values of docs/papers-bcd (§1.8), and the closed forms at T = 0:
    /// G0(0, 0) = π²/2 + π, G0(0, π/2) = π, G0(0, π) = π²/2 − π.
    const Q: [f64; 5] = [0.0, PI / 4.0, FRAC_PI_2, 3.0 * PI / 4.0, PI];
    const G0_1: [f64; 5] = [1.766677, 1.344686, 0.4665124, 0.2324983, 0.1938054];
    const G0_5: [f64; 5] = [
        1.659129e-2,
        1.229525e-2,
        3.130500e-3,
        1.336527e-3,
        1.093311e-3,
    ];
    const G20_0: [f64; 5] = [2.579658, 0.5330639, 0.2406506, 0.1690187, 0.1519497];
    const G20_1: [f64; 5] = [
        0.7340793,
        9.413855e-2,
        3.009514e-2,
        1.815321e-2,
        1.560345e-2,
    ];

    #[test]
    fn quadrature_matches_known_values() {
        let exact = |t, th, n| g_quadrature(h_exact, t, th, n, 1e-9);
        let p2 = PI * PI / 2.0;
        for (th, v) in [(0.0, p2 + PI), (FRAC_PI_2, PI), (PI, p2 - PI)] {
            assert!((exact(0.0, th, 1.0) / v - 1.0).abs() < 1e-7, "G0(0, {th})");
        }
        for (t, n, vals) in [
            (1.0, 1.0, G0_1),
            (5.0, 1.0, G0_5),
            (0.0, 20.0, G20_0),
            (1.0, 20.0, G20_1),
        ] {
            for (th, v) in Q.iter().zip(vals) {
                let g = exact(t, *th, n);
                assert!((g / v - 1.0).abs() < 2e-6, "G{n}({t}, {th}) = {g} vs {v}");
            }
        }
    }

    #[test]
    fn lobe_matches_quadrature() {
        // Against 400 × 32-point Gauss–Legendre panels over [0, φ₀] (each panel a fraction
        // of a degree: exact to rounding for every exponent here), over γ′, θ between
        // grid nodes; the error relative to the lobe's peak (2π at θ = γ′ = 0). Bounds:
        // the doc's, with head room over the measured values (trapezoids: 1.9·10⁻⁷ at
        // n = 2.5, 7·10⁻¹¹ at n = 4, 10⁻¹⁴ from 8 on).
        let reference = |gamma: f64, theta: f64, n: f64| {
            let a = gamma.cos() * theta.cos();
            let b = gamma.sin() * theta.sin();
            if b <= 1e-12 {
                return 2.0 * PI * a.max(0.0).powf(n);
            }
            let phi0 = (-a / b).clamp(-1.0, 1.0).acos();
            let rule = gauss_legendre(32);
            2.0 * composite(
                |p| (a + b * p.cos()).max(0.0).powf(n),
                0.0,
                phi0,
                &rule,
                400,
            )
        };
        for (n, bound) in [
            (0.0, 1e-12),
            // Gauss–Legendre, the integrand's root at φ₀ a square root: 1.8·10⁻⁶.
            (0.5, 1e-5),
            (1.0, 1e-12),
            (1.5, 1e-6),
            (2.0, 1e-6),
            (2.5, 1e-6),
            (4.0, 1e-9),
            (20.0, 1e-12),
            (30.0, 1e-12),
            (1000.0, 1e-12),
            (4096.0, 1e-12),
            (1e5, 1e-12),
        ] {
            let mut worst = 0.0f64;
            for i in 0..41 {
                for j in 0..37 {
                    let g = PI * (i as f64 + 0.37) / 41.0;
                    let th = PI * (j as f64 + 0.61) / 37.0;
                    worst = worst.max((lobe(g, th, n) - reference(g, th, n)).abs());
                }
            }
            assert!(worst / (2.0 * PI) < bound, "n {n}: {worst}");
        }
        // Along the light (B = 0): the closed form.
        assert_eq!(lobe(0.0, 0.3, 20.0), 2.0 * PI * 0.3f64.cos().powf(20.0));
        // A = 0, B = 1 (γ′ = θ = π/2): 2∫₀^{π/2} cosⁿφ dφ = π/2 (n = 2), 3π/8 (n = 4).
        assert!((lobe(PI / 2.0, PI / 2.0, 2.0) - PI / 2.0).abs() < 1e-12);
        assert!((lobe(PI / 2.0, PI / 2.0, 4.0) - 3.0 * PI / 8.0).abs() < 1e-12);
    }

    #[test]
    fn tables_are_within_a_thousandth_of_quadrature() {
        let h = HTable::default();
        // G0 at the default size (BENCHMARKS.md: 2.7e-4); G20 on an eighth of it (the
        // test's time), where the measurement has 3.2e-3 at 128².
        for (n, size, bound) in [(1.0, DEFAULT_SIZE, 5e-4), (20.0, (64, 128), 5e-3)] {
            let table = GTable::new(&h, n, size);
            let mut worst = 0.0f64;
            // Between the nodes, over T ∈ [0, 20] and every θ.
            for i in 0..9 {
                let t = 20.0 * (i as f64 / 8.0).powi(2) + 0.013;
                for j in 0..11 {
                    let th = PI * (j as f64 + 0.31) / 11.0;
                    let exact = g_quadrature(h_exact, t, th, n, 1e-9);
                    let e = (table.g(t, th) - exact).abs() / exact;
                    worst = worst.max(e);
                }
            }
            assert!(worst < bound, "G{n}: max relative error {worst}");
            assert!(table.g(T_MAX * 1.01, 0.3) == 0.0 && table.g(f64::NAN, 0.3) == 0.0);
        }
    }
}
