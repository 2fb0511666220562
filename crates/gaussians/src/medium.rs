//! The medium: `σt(x) = σt·(background + Σᵢ wᵢ·exp(−|x − cᵢ|²/rᵢ²))` (docs/formats.md
//! "Scene file", `"type": "gaussians"`), i.e. paper B's `β0 + Σ cᵢe^{−aᵢ²|x−bᵢ|²}` with
//! `β0 = σt·background`, `cᵢ = σt·wᵢ`, `aᵢ = 1/rᵢ`, `bᵢ = cᵢ`'s centre.
//!
//! Optical depths are the sum of every Gaussian's closed-form line integral
//! ([`crate::line::gaussian`]) plus `β0·len`. To stay linear in the Gaussians a segment
//! actually meets, each Gaussian is looked up in a [`SphereBvh`] at its *negligible
//! radius* for `δ = 10⁻¹⁰` ([`crate::line::negligible_radius`]): a line passing farther
//! from the centre picks up less than `10⁻¹⁰` of optical depth from it, so a depth is
//! exact to `n·10⁻¹⁰` absolute and the extinction at a point to `n·δ·a/√π`.

use crate::bvh::SphereBvh;
use crate::line;
use haze_core::number::shown;
use haze_core::vec3::{Vec3, dot, sub};

/// Optical depth below which a Gaussian's contribution to a line is dropped.
pub const DEPTH_EPSILON: f64 = 1e-10;

/// The widest Gaussian, in world units (10⁹, as far as the CLI's coordinates reach): its
/// depth `σt·w·√π·r` and the powers of `r` in paper B's integrals stay within `f64` for
/// any weight a scene would hold (a radius of 10³⁰⁰ made NaN pictures); a wider one is a
/// constant background (`background`).
pub const MAX_RADIUS: f64 = 1e9;

/// One Gaussian of the scene file: `weight·exp(−|x − center|²/radius²)`, times `σt`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gaussian {
    pub center: Vec3,
    pub radius: f64,
    pub weight: f64,
}

/// A validated Gaussian medium with its lookup hierarchy.
#[derive(Clone, Debug)]
pub struct GaussianMedium {
    /// Extinction scale `σt` (world units⁻¹).
    pub sigma_t: f64,
    /// Single-scattering albedo in `[0, 1]`.
    pub albedo: f64,
    /// The constant part of the density (multiplied by `σt`), `≥ 0`.
    pub background: f64,
    gaussians: Vec<Gaussian>,
    bvh: SphereBvh,
}

impl GaussianMedium {
    /// Checks the parameters: `σt ≥ 0`, albedo in `[0, 1]`, background `≥ 0`, every
    /// centre finite, radius `> 0` and weight `≥ 0`, all finite. The error names the
    /// offending key (and Gaussian).
    pub fn new(
        sigma_t: f64,
        albedo: f64,
        background: f64,
        gaussians: Vec<Gaussian>,
    ) -> Result<GaussianMedium, String> {
        if !(sigma_t.is_finite() && sigma_t >= 0.0) {
            return Err(format!(
                "sigma_t {} must be finite and not negative",
                shown(sigma_t)
            ));
        }
        if !(0.0..=1.0).contains(&albedo) {
            return Err(format!("albedo {} must be in [0, 1]", shown(albedo)));
        }
        if !(background.is_finite() && background >= 0.0) {
            return Err(format!(
                "background {} must be finite and not negative",
                shown(background)
            ));
        }
        for (i, g) in gaussians.iter().enumerate() {
            if !g.center.iter().all(|x| x.is_finite()) {
                return Err(format!("gaussians[{i}].center must be finite"));
            }
            if !(g.radius > 0.0 && g.radius <= MAX_RADIUS) {
                return Err(format!(
                    "gaussians[{i}].radius {} must be positive and at most {MAX_RADIUS:e}",
                    shown(g.radius)
                ));
            }
            if !(g.weight >= 0.0 && g.weight.is_finite()) {
                return Err(format!(
                    "gaussians[{i}].weight {} must be finite and not negative",
                    shown(g.weight)
                ));
            }
        }
        let radii = gaussians
            .iter()
            .map(|g| line::negligible_radius(sigma_t * g.weight, 1.0 / g.radius, DEPTH_EPSILON))
            .collect();
        let bvh = SphereBvh::new(gaussians.iter().map(|g| g.center).collect(), radii);
        Ok(GaussianMedium {
            sigma_t,
            albedo,
            background,
            gaussians,
            bvh,
        })
    }

    pub fn gaussians(&self) -> &[Gaussian] {
        &self.gaussians
    }

    /// `β0 = σt·background`.
    pub fn beta0(&self) -> f64 {
        self.sigma_t * self.background
    }

    /// Gaussian `i`'s peak extinction `cᵢ = σt·wᵢ` and inverse radius `aᵢ`.
    pub fn peak(&self, i: usize) -> (f64, f64) {
        let g = &self.gaussians[i];
        (self.sigma_t * g.weight, 1.0 / g.radius)
    }

    /// The extinction at `x` (world units⁻¹).
    pub fn extinction(&self, x: Vec3) -> f64 {
        let mut s = self.beta0();
        self.bvh.point(x, |i| {
            let (c, a) = self.peak(i);
            let v = sub(x, self.gaussians[i].center);
            s += c * (-a * a * dot(v, v)).exp();
        });
        s
    }

    /// `∫₀^len Σᵢ cᵢe^{−aᵢ²|o+td−bᵢ|²} dt` (the Gaussians alone) for unit `d`, leaving out
    /// Gaussian `skip` if given.
    pub fn gaussian_depth(&self, o: Vec3, d: Vec3, len: f64, skip: Option<usize>) -> f64 {
        let mut s = 0.0;
        if len <= 0.0 {
            return s;
        }
        self.bvh.segment(o, d, len, |i| {
            if Some(i) != skip {
                let (c, a) = self.peak(i);
                s += line::gaussian(c, a, self.gaussians[i].center, o, d, len);
            }
        });
        s
    }

    /// The whole medium's optical depth along `o + t·d`, `t ∈ [0, len]` (`∞` allowed;
    /// `β0·∞ = ∞` only when `β0 > 0`).
    pub fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let b0 = self.beta0();
        let homogeneous = if b0 > 0.0 { b0 * len } else { 0.0 };
        homogeneous + self.gaussian_depth(o, d, len, None)
    }

    /// The box outside which the extinction is negligible (see the module docs), `None`
    /// when the background fills space. An empty medium has an empty box at the origin.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        if self.beta0() > 0.0 {
            return None;
        }
        let (mut min, mut max) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for (i, g) in self.gaussians.iter().enumerate() {
            let (c, a) = self.peak(i);
            let r = line::negligible_radius(c, a, DEPTH_EPSILON);
            for k in 0..3 {
                min[k] = min[k].min(g.center[k] - r);
                max[k] = max[k].max(g.center[k] + r);
            }
        }
        if min[0] > max[0] {
            return Some(([0.0; 3], [0.0; 3]));
        }
        Some((min, max))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_core::vec3::{axpy, normalize};

    fn medium() -> GaussianMedium {
        let gs = (0..40)
            .map(|i| {
                let t = i as f64 * 0.7;
                Gaussian {
                    center: [t.sin() * 2.0, t.cos() * 1.5, 0.1 * i as f64 - 2.0],
                    radius: 0.2 + 0.05 * (i % 7) as f64,
                    weight: 0.5 + 0.1 * (i % 5) as f64,
                }
            })
            .collect();
        GaussianMedium::new(1.7, 0.8, 0.05, gs).unwrap()
    }

    #[test]
    fn optical_depth_matches_a_sum_over_every_gaussian_and_quadrature() {
        let m = medium();
        let o = [-4.0, -3.0, -2.5];
        let d = normalize([1.0, 0.8, 0.6]).unwrap();
        let len = 9.0;
        // Brute force: every Gaussian, no hierarchy.
        let brute: f64 = (0..m.gaussians().len())
            .map(|i| {
                let (c, a) = m.peak(i);
                line::gaussian(c, a, m.gaussians()[i].center, o, d, len)
            })
            .sum::<f64>()
            + m.beta0() * len;
        let got = m.optical_depth(o, d, len);
        assert!(
            (got - brute).abs() < 40.0 * DEPTH_EPSILON,
            "{got} vs {brute}"
        );
        // Quadrature of the extinction itself (midpoint, 200000 steps: ~1e-9 relative).
        let n = 200_000;
        let h = len / n as f64;
        let quad: f64 = (0..n)
            .map(|k| m.extinction(axpy(o, (k as f64 + 0.5) * h, d)))
            .sum::<f64>()
            * h;
        assert!((got - quad).abs() < 1e-7 * quad, "{got} vs {quad}");
        // Leaving one Gaussian out removes exactly its integral.
        let (c, a) = m.peak(3);
        let own = line::gaussian(c, a, m.gaussians()[3].center, o, d, len);
        let rest = m.gaussian_depth(o, d, len, Some(3));
        assert!((rest + own + m.beta0() * len - got).abs() < 1e-12 * got);
    }

    #[test]
    fn bounds_and_validation() {
        let m = GaussianMedium::new(
            2.0,
            1.0,
            0.0,
            vec![Gaussian {
                center: [1.0, 2.0, 3.0],
                radius: 0.5,
                weight: 1.0,
            }],
        )
        .unwrap();
        let (lo, hi) = m.bounds().unwrap();
        let r = line::negligible_radius(2.0, 2.0, DEPTH_EPSILON);
        assert!((hi[0] - 1.0 - r).abs() < 1e-12 && (lo[2] - 3.0 + r).abs() < 1e-12);
        assert!(medium().bounds().is_none());
        assert_eq!(m.optical_depth([0.0; 3], [1.0, 0.0, 0.0], 0.0), 0.0);
        // Infinite segments: finite without a background.
        assert!(
            m.optical_depth([1.0, 2.0, -10.0], [0.0, 0.0, 1.0], f64::INFINITY)
                .is_finite()
        );
        let g = |radius, weight| Gaussian {
            center: [0.0; 3],
            radius,
            weight,
        };
        for (st, al, bg, gs, key) in [
            (-1.0, 0.5, 0.0, vec![], "sigma_t"),
            (1.0, 1.5, 0.0, vec![], "albedo"),
            (1.0, 0.5, -0.1, vec![], "background"),
            (1.0, 0.5, 0.0, vec![g(0.0, 1.0)], "gaussians[0].radius"),
            (
                1.0,
                0.5,
                0.0,
                vec![g(1.0, 1.0), g(1.0, -2.0)],
                "gaussians[1].weight",
            ),
            (1.0, 0.5, 0.0, vec![g(f64::NAN, 1.0)], "gaussians[0].radius"),
        ] {
            let e = GaussianMedium::new(st, al, bg, gs).unwrap_err();
            assert!(e.starts_with(key), "{e}");
        }
    }
}
