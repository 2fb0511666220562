//! Optical properties of the smoke: extinction `κt = σt·D(x)`, albedo `Ω = σs/σt`, and the
//! Henyey–Greenstein phase function, normalized so that `(1/4π)∫p dω = 1` (docs/conventions.md).

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
            return Err(format!("extinction σt = {sigma_t} must be finite and ≥ 0"));
        }
        if !(0.0..=1.0).contains(&albedo) {
            return Err(format!("albedo {albedo} must be in [0, 1]"));
        }
        if !(g > -1.0 && g < 1.0) {
            return Err(format!("phase asymmetry g = {g} must be in (−1, 1)"));
        }
        Ok(Medium { sigma_t, albedo, g })
    }
}

/// Henyey–Greenstein phase `p(cos θ) = (1 − g²) / (1 + g² − 2g cos θ)^{3/2}`, with
/// `(1/4π)∫p dω = 1`; `cos θ` is between the propagation directions (θ = 0: forward).
pub fn hg(g: f64, cos_theta: f64) -> f64 {
    let denom = (1.0 + g * g - 2.0 * g * cos_theta.clamp(-1.0, 1.0)).max(1e-300);
    (1.0 - g * g) / (denom * denom.sqrt())
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
    fn bad_media_are_refused() {
        assert!(Medium::new(-1.0, 0.5, 0.0).is_err());
        assert!(Medium::new(f64::INFINITY, 0.5, 0.0).is_err());
        assert!(Medium::new(1.0, 1.5, 0.0).is_err());
        assert!(Medium::new(1.0, 0.5, 1.0).is_err());
        assert!(Medium::new(0.0, 0.0, 0.95).is_ok());
    }
}
