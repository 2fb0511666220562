//! The average optical depth around a point (paper B §4.2, eq. 26): what the environment's
//! light loses on its way to `p`, averaged over all directions,
//!
//! `T̄(p) = (1/4π)∫_S T(p + Dω, p) dω = β0·D + Σᵢ T̄ᵢ(p)`,  `T̄ᵢ(p) = cᵢ·𝒯(aᵢ|p − bᵢ|)/aᵢ`,
//!
//! for `D` large beside the Gaussians, with the paper's 1D table
//! `𝒯(ρ) = (1/4π)∫_S∫₀^∞ e^{−|u + tω|²} dt dω`, `|u| = ρ`, in closed form:
//! by symmetry `𝒯(ρ) = ½∫₋₁¹ e^{−ρ²(1−μ²)}·(√π/2)·erfc(ρμ) dμ`, and integrating in `μ`
//! gives `𝒯(ρ) = √π·F(ρ)/(2ρ)`, `F` Dawson's integral `F(x) = e^{−x²}∫₀^x e^{t²} dt`
//! (`𝒯(0) = √π/2`, `𝒯(ρ) ~ √π/(4ρ²)` far away). The paper tabulates `𝒯`; so does
//! [`mean_depth`] for `ρ ≤ 32` — values and slopes from that closed form at [`NODES`]
//! points, cubic Hermite between them (within `5·10⁻¹²` of it relative, test
//! `the_table_matches_the_closed_form`; a renderer asks it once per Gaussian a view ray
//! meets, where Dawson's sum cost 14 divisions) — and evaluates the asymptotic series
//! beyond; the closed form is checked against the quadrature in `μ`.

use haze_core::vec3::{Vec3, norm, sub};
use std::f64::consts::PI;

/// Rybicki's step `h`: the sum's error is `~e^{−(π/2h)²}` (`e^{−39}` at 0.25).
const H: f64 = 0.25;
/// Terms of the sum: `e^{−((2k+1)h)²}` is below `10⁻¹⁹` past `k = 13`.
const TERMS: usize = 14;

/// `e^{−((2k+1)h)²}`, `k < TERMS`, computed once.
fn rybicki_weights() -> &'static [f64; TERMS] {
    static W: std::sync::OnceLock<[f64; TERMS]> = std::sync::OnceLock::new();
    W.get_or_init(|| std::array::from_fn(|k| (-(((2 * k + 1) as f64) * H).powi(2)).exp()))
}

/// Dawson's integral `F(x) = e^{−x²}∫₀^x e^{t²} dt`, relative error ~`10⁻¹⁴`: its Taylor
/// series `Σ (−2)ᵏx^{2k+1}/(2k+1)!!` for `|x| < 1` (terms fall at least 3× each), else
/// Rybicki's sum `F(x) ≈ π^{−½}Σ_{n odd} e^{−(x′−nh)²}/(n + x₀/h)`, `x₀` the even multiple
/// of `h` nearest `x` and `x′ = x − x₀` (Numerical Recipes §6.10, there with `h = 0.4`).
pub fn dawson(x: f64) -> f64 {
    let ax = x.abs();
    if !ax.is_finite() {
        return if ax.is_nan() { f64::NAN } else { 0.0 };
    }
    if ax < 1.0 {
        let x2 = x * x;
        let (mut term, mut sum) = (x, x);
        for k in 1..40 {
            term *= -2.0 * x2 / (2 * k + 1) as f64;
            sum += term;
            if term.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        return sum;
    }
    let n0 = 2.0 * (0.5 * ax / H).round();
    let xp = ax - n0 * H;
    let e2 = (2.0 * xp * H).exp().powi(2);
    let mut e1 = (2.0 * xp * H).exp();
    let (mut d1, mut d2) = (n0 + 1.0, n0 - 1.0);
    let mut sum = 0.0;
    for c in rybicki_weights() {
        sum += c * (e1 / d1 + 1.0 / (d2 * e1));
        d1 += 2.0;
        d2 -= 2.0;
        e1 *= e2;
    }
    (-xp * xp).exp() * sum / PI.sqrt() * x.signum()
}

/// Intervals of [`mean_depth`]'s table over `ρ ∈ [0, TABLE_END]`.
pub const NODES: usize = 8192;
/// Where the table ends and the asymptotic series takes over (the Barnes–Hut sum asks
/// `𝒯` of every Gaussian it opens, many beyond 8 radii, where the series took 12 terms).
const TABLE_END: f64 = 32.0;

/// `(𝒯(ρₖ), 𝒯′(ρₖ))` at `ρₖ = k·TABLE_END/NODES`, from the closed form: with `F′ = 1 − 2ρF`,
/// `𝒯′(ρ) = (√π/2)·(ρF′(ρ) − F(ρ))/ρ²` (0 at `ρ = 0`, where `𝒯` is even).
fn mean_depth_table() -> &'static [(f64, f64)] {
    static TABLE: std::sync::OnceLock<Vec<(f64, f64)>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        (0..=NODES)
            .map(|k| {
                let rho = k as f64 * TABLE_END / NODES as f64;
                if k == 0 {
                    return (0.5 * PI.sqrt(), 0.0);
                }
                let f = dawson(rho);
                let slope = 0.5 * PI.sqrt() * (rho * (1.0 - 2.0 * rho * f) - f) / (rho * rho);
                (mean_depth_direct(rho), slope)
            })
            .collect()
    })
}

/// The paper's `𝒯(ρ) = √π·F(ρ)/(2ρ)` (module docs), `√π/2` at `ρ = 0`: from the table up
/// to `ρ = 32`, beyond by the asymptotic series of `F`.
pub fn mean_depth(rho: f64) -> f64 {
    let rho = rho.abs();
    if rho >= TABLE_END || rho.is_nan() {
        return mean_depth_direct(rho);
    }
    let table = mean_depth_table();
    let x = rho * (NODES as f64 / TABLE_END);
    let k = (x as usize).min(NODES - 1);
    let (u, h) = (x - k as f64, TABLE_END / NODES as f64);
    let ((f0, d0), (f1, d1)) = (table[k], table[k + 1]);
    // Cubic Hermite on [ρₖ, ρₖ₊₁].
    let (u2, u3) = (u * u, u * u * u);
    (2.0 * u3 - 3.0 * u2 + 1.0) * f0
        + (u3 - 2.0 * u2 + u) * h * d0
        + (-2.0 * u3 + 3.0 * u2) * f1
        + (u3 - u2) * h * d1
}

/// [`mean_depth`] from Dawson's integral (and its asymptotic series beyond `ρ = 32`).
fn mean_depth_direct(rho: f64) -> f64 {
    let rho = rho.abs();
    if rho < 1e-8 {
        // F(ρ)/ρ = 1 − 2ρ²/3 + …
        return 0.5 * PI.sqrt();
    }
    if rho > TABLE_END {
        // Dawson's asymptotic series F(ρ)/ρ ~ Σ_k (2k−1)!!/(2ρ²)^{k+1}, summed until a
        // term falls below 10⁻¹⁶ of the sum (at ρ = 32 the sixth is 1.4·10⁻¹⁶ of it, and
        // the terms still fall): no exponentials.
        let u = 0.5 / (rho * rho);
        let mut term = u;
        let mut sum = u;
        for k in 1..14 {
            term *= (2 * k - 1) as f64 * u;
            sum += term;
            if term < 1e-16 * sum {
                break;
            }
        }
        return 0.5 * PI.sqrt() * sum;
    }
    0.5 * PI.sqrt() * dawson(rho) / rho
}

/// `T̄ᵢ(p) = c·𝒯(a|p − b|)/a`: the average optical depth from `p` of the Gaussian
/// `c·e^{−a²|x − b|²}` along rays to infinity.
pub fn gaussian_mean_depth(c: f64, a: f64, b: Vec3, p: Vec3) -> f64 {
    if c == 0.0 {
        return 0.0;
    }
    c * mean_depth(a * norm(sub(p, b))) / a
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `∫_lo^hi f` by composite 8-point Gauss–Legendre on `n` panels.
    fn integrate(f: impl Fn(f64) -> f64, lo: f64, hi: f64, n: usize) -> f64 {
        const X: [f64; 4] = [
            0.183_434_642_495_649_8,
            0.525_532_409_916_329,
            0.796_666_477_413_626_7,
            0.960_289_856_497_536_3,
        ];
        const W: [f64; 4] = [
            0.362_683_783_378_362,
            0.313_706_645_877_887_3,
            0.222_381_034_453_374_5,
            0.101_228_536_290_376_3,
        ];
        let h = (hi - lo) / n as f64;
        let mut s = 0.0;
        for k in 0..n {
            let c = lo + (k as f64 + 0.5) * h;
            for (x, w) in X.iter().zip(W) {
                s += w * (f(c + 0.5 * h * x) + f(c - 0.5 * h * x));
            }
        }
        0.5 * h * s
    }

    #[test]
    fn dawson_matches_its_integral() {
        // F(x) = ∫₀^x e^{−u(2x − u)} du (u = x − t) by quadrature, cut where
        // u(2x − u) ≥ u·x passes 50.
        for &x in &[0.0f64, 0.1, 0.5, 0.99, 1.0, 1.3, 2.0, 3.7, 6.0, 12.5, 40.0] {
            let top = if x > 0.0 { x.min(50.0 / x) } else { 0.0 };
            let q = integrate(|u| (-u * (2.0 * x - u)).exp(), 0.0, top, 400);
            let f = dawson(x);
            assert!(
                (f - q).abs() <= 1e-13 * q.max(1e-300),
                "F({x}) = {f} vs {q}"
            );
            assert_eq!(dawson(-x), -f);
        }
        assert_eq!(dawson(f64::INFINITY), 0.0);
        assert!(dawson(f64::NAN).is_nan());
        // Far away F(x) ~ 1/(2x) + 1/(4x³).
        let x = 1e6;
        assert!((dawson(x) * 2.0 * x - 1.0).abs() < 1e-11);
    }

    #[test]
    fn the_table_matches_the_closed_form() {
        // Between and at the nodes, near 0 and the table's end, against Dawson's sum.
        let mut worst: f64 = 0.0;
        for i in 0..=800_000 {
            let rho = 32.0 * i as f64 / 800_000.0 + 1.3e-6 * (i % 7) as f64;
            let (t, d) = (mean_depth(rho), mean_depth_direct(rho));
            worst = worst.max((t - d).abs() / d);
        }
        assert!(worst < 1e-11, "{worst:e}");
        assert_eq!(mean_depth(0.0), 0.5 * PI.sqrt());
        assert_eq!(mean_depth(-2.0), mean_depth(2.0));
        assert!(mean_depth(f64::NAN).is_nan());
        assert_eq!(mean_depth(f64::INFINITY), 0.0);
    }

    #[test]
    fn mean_depth_matches_the_sphere_quadrature() {
        // 𝒯(ρ) = ½∫₋₁¹ e^{−ρ²(1−μ²)}·(√π/2)·erfc(ρμ) dμ (module docs), and the notes'
        // values 𝒯(0) = .8862269, 𝒯(1) = .4768605, 𝒯(2) = .1335280.
        for &rho in &[0.0, 1e-9, 0.3, 1.0, 2.0, 4.5, 9.0] {
            let q = 0.5
                * integrate(
                    |mu| {
                        (-rho * rho * (1.0 - mu * mu)).exp()
                            * 0.5
                            * PI.sqrt()
                            * libm::erfc(rho * mu)
                    },
                    -1.0,
                    1.0,
                    200,
                );
            assert!((mean_depth(rho) - q).abs() < 1e-10, "𝒯({rho}) vs {q}");
        }
        // Far away (the asymptotic series) against Dawson's integral, itself checked
        // against quadrature above.
        for rho in [8.000001, 9.5, 25.0, 60.0, 1e4] {
            let want = 0.5 * PI.sqrt() * dawson(rho) / rho;
            assert!((mean_depth(rho) / want - 1.0).abs() < 1e-11, "𝒯({rho})");
        }
        for (rho, want) in [(0.0, 0.8862269), (1.0, 0.4768605), (2.0, 0.1335280)] {
            assert!((mean_depth(rho) - want).abs() < 1e-7);
        }
        // A Gaussian of radius r = 1/a: its depth scales as c/a, its argument as a.
        let (c, a) = (3.0, 2.0);
        let t = gaussian_mean_depth(c, a, [1.0, 0.0, 0.0], [1.0, 0.5, 0.0]);
        assert!((t - c / a * mean_depth(1.0)).abs() < 1e-15);
    }
}
