//! Optical properties of the smoke: extinction `κt = σt·D(x)`, albedo `Ω = σs/σt`, and the
//! Henyey–Greenstein phase function, normalized so that `(1/4π)∫p dω = 1` (docs/conventions.md).

use haze_core::number::shown;
use std::f64::consts::PI;

/// Scattering parameters, changeable at run time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Extinction cross-section: `κt = σt·D`.
    pub sigma_t: f64,
    /// Single-scattering albedo `Ω ∈ [0, 1]`.
    pub albedo: f64,
    /// Henyey–Greenstein asymmetry `g ∈ (−1, 1)`.
    pub g: f64,
}

impl Medium {
    /// Refuses negative or non-finite extinction, albedo outside [0, 1] and |g| ≥ 1.
    pub fn new(sigma_t: f64, albedo: f64, g: f64) -> Result<Medium, String> {
        if !(sigma_t >= 0.0 && sigma_t.is_finite()) {
            return Err(format!(
                "extinction σt = {} must be finite and ≥ 0",
                shown(sigma_t)
            ));
        }
        if !(0.0..=1.0).contains(&albedo) {
            return Err(format!("albedo {} must be in [0, 1]", shown(albedo)));
        }
        if !(g > -1.0 && g < 1.0) {
            return Err(format!(
                "phase asymmetry g = {} must be in (−1, 1)",
                shown(g)
            ));
        }
        Ok(Medium { sigma_t, albedo, g })
    }

    /// The delta-Eddington transport medium of the multiple scattering and the factor of
    /// its first source. HG's forward peak is split off as a fraction `f = max(g, 0)²` of
    /// the scattering that goes straight on, `p = f δ + (1 − f) p'`, which turns the
    /// transport equation into one of a medium with
    ///
    /// ```text
    /// σt' = σt (1 − Ωf),   Ω' = Ω (1 − f) / (1 − Ωf),   g' = (g − f) / (1 − f) = g / (1 + g)
    /// ```
    ///
    /// (the first two moments of `p` kept). Light scattered once from the direct light
    /// keeps the full phase function (its forward peak included): its emission per unit
    /// length `σt J` stays, so its source per unit of the new optical depth is
    /// `J / (1 − Ωf)`, the returned factor. Bands 0–1 of HG with g ≳ 0.5 represent its
    /// peak badly, and the later orders' sources are bands 0–1: with the peak counted as
    /// unscattered they no longer smear it sideways. `g ≤ 0` (no forward peak) returns
    /// the medium unchanged and 1. `1 − Ωf` is kept ≥ 1e-6 for media built without
    /// [`Medium::new`]'s checks.
    pub fn delta_eddington(&self) -> (Medium, f64) {
        let f = if self.g > 0.0 && self.g.is_finite() {
            (self.g * self.g).min(1.0)
        } else {
            return (*self, 1.0);
        };
        let kept = (1.0 - self.albedo * f).max(1e-6);
        let transport = Medium {
            sigma_t: self.sigma_t * kept,
            albedo: (self.albedo * (1.0 - f) / kept).clamp(0.0, 1.0),
            g: self.g / (1.0 + self.g),
        };
        (transport, 1.0 / kept)
    }
}

/// Henyey–Greenstein phase `p(cos θ) = (1 − g²) / (1 + g² − 2g cos θ)^{3/2}`, with
/// `(1/4π)∫p dω = 1`; `cos θ` is between the propagation directions (θ = 0: forward).
pub fn hg(g: f64, cos_theta: f64) -> f64 {
    let denom = (1.0 + g * g - 2.0 * g * cos_theta.clamp(-1.0, 1.0)).max(1e-300);
    (1.0 - g * g) / (denom * denom.sqrt())
}

/// The angle `ψ` from the forward direction at which HG of asymmetry `g` falls to half
/// its peak `p(1) = (1 + g)/(1 − g)²`: `(1 + g² − 2g cos ψ)^{3/2} = 2(1 − g)³`, so
///
/// ```text
/// cos ψ = (1 + g² − 2^{2/3} (1 − g)²) / 2g
/// ```
///
/// `None` where HG never falls to half its peak (its forward-to-backward ratio
/// `((1 + g)/(1 − g))³` under 2: `g` below `(2^{1/3} − 1)/(2^{1/3} + 1) ≈ 0.115`, `g ≤ 0`
/// or NaN); `g ≥ 1` is taken as `1 − 10⁻⁶` (a width near 0, not 0).
pub fn hg_half_width(g: f64) -> Option<f64> {
    if g.is_nan() || g <= 0.0 {
        return None;
    }
    let g = g.min(1.0 - 1e-6);
    let cos = (1.0 + g * g - 2f64.powf(2.0 / 3.0) * (1.0 - g).powi(2)) / (2.0 * g);
    (cos >= -1.0).then(|| cos.min(1.0).acos())
}

/// Samples `cos θ` from HG for a uniform `u ∈ [0, 1)` (inverse CDF; isotropic for tiny |g|).
pub fn sample_hg_cos(g: f64, u: f64) -> f64 {
    if g.abs() < 1e-4 {
        return 2.0 * u - 1.0;
    }
    let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
}

/// `4π`, the normalization of phase integrals.
pub const FOUR_PI: f64 = 4.0 * PI;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hg_is_normalized_and_its_mean_cosine_is_g() {
        for g in [-0.95, -0.5, 0.0, 0.3, 0.95] {
            // (1/4π)∫p dω = ½∫₋₁¹ p(μ) dμ, by Gauss–Legendre on a fine split.
            let n = 20000;
            let (mut s, mut m) = (0.0, 0.0);
            for i in 0..n {
                let mu = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
                let p = hg(g, mu) * 2.0 / n as f64;
                s += 0.5 * p;
                m += 0.5 * p * mu;
            }
            assert!((s - 1.0).abs() < 2e-3, "g {g}: {s}");
            assert!((m - g).abs() < 2e-3, "g {g}: {m}");
        }
    }

    #[test]
    fn hg_half_width_is_where_the_phase_halves() {
        // Against bisection on `hg` itself.
        for g in [0.12, 0.2, 0.5, 0.7, 0.8, 0.9, 0.99] {
            let half = 0.5 * hg(g, 1.0);
            let (mut lo, mut hi) = (0.0f64, std::f64::consts::PI);
            for _ in 0..100 {
                let mid = 0.5 * (lo + hi);
                if hg(g, mid.cos()) > half {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let psi = hg_half_width(g).unwrap();
            assert!((psi - lo).abs() < 1e-9, "g {g}: {psi} vs {lo}");
        }
        // No half maximum: HG's forward-to-backward ratio under 2.
        let g_min = (2f64.cbrt() - 1.0) / (2f64.cbrt() + 1.0);
        assert!(hg_half_width(g_min - 1e-6).is_none());
        assert!((hg_half_width(g_min + 1e-9).unwrap() - std::f64::consts::PI).abs() < 1e-3);
        for g in [0.0, -0.5, f64::NAN, f64::NEG_INFINITY] {
            assert!(hg_half_width(g).is_none(), "{g}");
        }
        for g in [1.0, 2.0, f64::INFINITY] {
            let psi = hg_half_width(g).unwrap();
            assert!(psi > 0.0 && psi < 1e-3, "{g}: {psi}");
        }
    }

    #[test]
    fn hg_sampling_follows_the_cdf() {
        for g in [-0.7, 0.0, 0.5, 0.9] {
            // P(cos θ ≤ c) = ∫₋₁ᶜ ½p dμ; compare with the inverse-CDF sample at u.
            for u in [0.1, 0.5, 0.9] {
                let c = sample_hg_cos(g, u);
                let n = 20000;
                let cdf: f64 = (0..n)
                    .map(|i| {
                        let mu = -1.0 + (i as f64 + 0.5) * (c + 1.0) / n as f64;
                        0.5 * hg(g, mu) * (c + 1.0) / n as f64
                    })
                    .sum();
                assert!((cdf - u).abs() < 2e-3, "g {g} u {u}: {cdf}");
            }
        }
    }

    #[test]
    fn delta_eddington_keeps_absorption_transport_and_the_mean_cosine() {
        for (albedo, g) in [(0.9, 0.8), (0.5, 0.3), (1.0, 0.6), (0.0, 0.7)] {
            let m = Medium::new(2.0, albedo, g).unwrap();
            let (t, scale) = m.delta_eddington();
            let f = g * g;
            // Absorption σt(1 − Ω) and the diffusion's transport σt Ω (1 − g) unchanged.
            let absorb = |m: &Medium| m.sigma_t * (1.0 - m.albedo);
            let transport = |m: &Medium| m.sigma_t * m.albedo * (1.0 - m.g);
            assert!((absorb(&t) - absorb(&m)).abs() < 1e-12, "{m:?} {t:?}");
            assert!((transport(&t) - transport(&m)).abs() < 1e-12, "{m:?} {t:?}");
            // The mixture f δ + (1 − f) HG(g') has HG(g)'s mean cosine, by quadrature.
            let n = 20000;
            let mean: f64 = (0..n)
                .map(|i| {
                    let mu = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
                    0.5 * hg(t.g, mu) * mu * 2.0 / n as f64
                })
                .sum();
            assert!((f + (1.0 - f) * mean - g).abs() < 2e-3, "g {g}: {mean}");
            // The first source's emission per unit length σt J is kept.
            assert!((t.sigma_t * scale - m.sigma_t).abs() < 1e-12);
        }
        // No forward peak: unchanged.
        for g in [0.0, -0.5] {
            let m = Medium::new(3.0, 0.8, g).unwrap();
            assert_eq!(m.delta_eddington(), (m, 1.0));
        }
        // The ends: g → 1 with Ω = 1 leaves a finite factor; a medium built by hand with
        // g = 1 is held at the floor.
        let (t, scale) = Medium::new(1.0, 1.0, 0.999).unwrap().delta_eddington();
        assert!(t.sigma_t > 0.0 && scale.is_finite() && (0.0..=1.0).contains(&t.albedo));
        let hand = Medium {
            sigma_t: 1.0,
            albedo: 1.0,
            g: 1.0,
        };
        let (t, scale) = hand.delta_eddington();
        assert_eq!(scale, 1e6);
        assert!(t.sigma_t > 0.0 && t.albedo == 0.0 && t.g == 0.5);
    }

    #[test]
    fn bad_media_are_refused() {
        assert!(Medium::new(-1.0, 0.5, 0.0).is_err());
        assert!(Medium::new(f64::INFINITY, 0.5, 0.0).is_err());
        assert!(Medium::new(1.0, 1.5, 0.0).is_err());
        assert!(Medium::new(1.0, 0.5, 1.0).is_err());
        assert!(Medium::new(0.0, 0.0, 0.95).is_ok());
    }
}
