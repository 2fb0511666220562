//! Media whose extinction varies in space, one kind each — a smoke asset on a voxel grid
//! (paper A, [`asset`], [`voxel_grid`]), a sum of Gaussians (paper B, [`gaussians`]),
//! analytic fog functions (paper D, [`analytic`]) — held by a scene as a
//! [`HeteroMedium`]. What every renderer needs of any of them is [`Heterogeneous`]: the
//! extinction at a point, the optical depth along a segment (in closed form where the
//! model has one), the albedo and the phase function; a renderer of one kind only matches
//! on the [`HeteroMedium`]. The scene's homogeneous media stay in [`crate::Medium`] (paper
//! C's analytic model); these add their extinction where they overlap it.

pub mod analytic;
pub mod asset;
pub mod gaussians;
pub mod voxel_grid;

use crate::vec3::Vec3;
use analytic::AnalyticMedium;
use asset::AssetMedium;
use gaussians::GaussianMediumOf;
use haze_core::Rgb;
use std::fmt;
use std::sync::Arc;

/// An axis-aligned box `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// The parameter interval `[t0, t1] ∩ [t_min, t_max]` in which the ray `o + t·d`
    /// (any non-zero `d`) lies inside the box, by the slab method; `None` when it misses.
    /// A zero component of `d` gives `±∞` slab ends, which the comparisons handle
    /// (a ray in a slab's plane is inside when its origin is).
    pub fn clip(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
        let (mut t0, mut t1) = (t_min, t_max);
        for k in 0..3 {
            if d[k] == 0.0 {
                if o[k] < self.min[k] || o[k] > self.max[k] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d[k];
            let (a, b) = ((self.min[k] - o[k]) * inv, (self.max[k] - o[k]) * inv);
            let (a, b) = if a <= b { (a, b) } else { (b, a) };
            t0 = t0.max(a);
            t1 = t1.min(b);
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

/// What the renderers need from a medium with varying extinction.
pub trait Heterogeneous: Send + Sync + fmt::Debug {
    /// A short name for messages (`"asset plume.haze"`, `"12 gaussians"`).
    fn name(&self) -> String;
    /// The extinction coefficient `σt(x)` per channel (world units⁻¹), `≥ 0`.
    fn sigma_t(&self, x: Vec3) -> Rgb;
    /// The optical depth `∫₀^len σt(o + t·d) dt` per channel for a unit `d` — exact where
    /// the model has a closed form, by quadrature otherwise. `len` may be `+∞`; `0` for a
    /// zero-length segment.
    fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb;
    /// The single-scattering albedo `σs/σt` per channel, in `[0, 1]`.
    fn albedo(&self) -> Rgb;
    /// The Henyey–Greenstein asymmetry `g ∈ (−1, 1)` of the phase function.
    fn g(&self) -> f64 {
        0.0
    }
    /// A box outside which `σt = 0`, or `None` when the medium fills space.
    fn bounds(&self) -> Option<Aabb>;
    /// Whether `σt` may be non-zero somewhere in the closed box `b`: `false` only where it
    /// is 0 everywhere in it (work there can be skipped); `true` when unknown.
    fn occupies(&self, b: &Aabb) -> bool {
        let _ = b;
        true
    }
}

/// A heterogeneous medium of a scene, by kind, shared: two are equal when they hold the
/// same object. It dereferences to its [`Heterogeneous`] self.
#[derive(Clone)]
pub enum HeteroMedium {
    /// A baked smoke asset resampled on a voxel grid (paper A).
    Asset(Arc<AssetMedium>),
    /// A sum of Gaussians (paper B).
    Gaussians(Arc<GaussianMediumOf>),
    /// Analytic fog functions carried by a wind (paper D).
    Analytic(Arc<AnalyticMedium>),
    /// Any other medium: the march, which needs nothing but [`Heterogeneous`], renders it;
    /// the renderers of one kind refuse it.
    Other(Arc<dyn Heterogeneous>),
}

impl HeteroMedium {
    /// Whether it is a sum of Gaussians, the only kind paper B's renderer takes.
    pub fn is_gaussians(&self) -> bool {
        matches!(self, HeteroMedium::Gaussians(_))
    }

    /// Whether it is analytic fog, the only kind paper D's composite takes.
    pub fn is_analytic(&self) -> bool {
        matches!(self, HeteroMedium::Analytic(_))
    }
}

impl PartialEq for HeteroMedium {
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (HeteroMedium::Asset(a), HeteroMedium::Asset(b)) => Arc::ptr_eq(a, b),
            (HeteroMedium::Gaussians(a), HeteroMedium::Gaussians(b)) => Arc::ptr_eq(a, b),
            (HeteroMedium::Analytic(a), HeteroMedium::Analytic(b)) => Arc::ptr_eq(a, b),
            (HeteroMedium::Other(a), HeteroMedium::Other(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

impl fmt::Debug for HeteroMedium {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (**self).fmt(f)
    }
}

impl std::ops::Deref for HeteroMedium {
    type Target = dyn Heterogeneous;
    fn deref(&self) -> &Self::Target {
        match self {
            HeteroMedium::Asset(m) => &**m,
            HeteroMedium::Gaussians(m) => &**m,
            HeteroMedium::Analytic(m) => &**m,
            HeteroMedium::Other(m) => &**m,
        }
    }
}

/// The Henyey–Greenstein phase function per steradian, `p(cos θ) = (1 − g²)/(4π(1 + g² −
/// 2g·cos θ)^{3/2})` (`∫p dω = 1`), `cos θ` between the direction of travel before and
/// after scattering (forward: `+1`): the smoke renderer's [`haze_view::medium::hg`]
/// (normalized to `4π`) over `4π`.
pub fn henyey_greenstein(g: f64, cos_theta: f64) -> f64 {
    haze_view::medium::hg(g, cos_theta) / haze_view::medium::FOUR_PI
}

/// The largest extinction coefficient a scene file may give (per world unit). A medium
/// this dense is opaque within a micron of a metre-sized scene; beyond it optical
/// depths overflow `f32` on the GPU (`e^-τ` of an infinite τ times zero radiance is NaN)
/// and every picture would be black or NaN.
pub const MAX_SIGMA_T: f64 = 1e6;

/// Refuses an extinction outside `[0, MAX_SIGMA_T]`, the range in the message.
pub fn check_sigma_t(v: &[f64]) -> Result<(), String> {
    if v.iter().all(|x| (0.0..=MAX_SIGMA_T).contains(x)) {
        Ok(())
    } else {
        // One number when the channels agree; large and tiny ones as 1e308.
        let same = v.windows(2).all(|w| w[0] == w[1]);
        let shown: Vec<String> = v[..if same { v.len().min(1) } else { v.len() }]
            .iter()
            .map(|&x| haze_core::number::shown(x))
            .collect();
        Err(format!(
            "sigma_t {} must be in [0, {MAX_SIGMA_T:e}] per world unit",
            shown.join(", ")
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The range's ends are in, everything past them (NaN and infinity too) is out, and
    /// the message shows the value and the range.
    #[test]
    fn extinction_is_checked_at_its_extremes() {
        for ok in [[0.0; 3], [MAX_SIGMA_T; 3], [-0.0, 1e-300, 5.0]] {
            assert!(check_sigma_t(&ok).is_ok(), "{ok:?}");
        }
        for bad in [
            1e308,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            MAX_SIGMA_T * (1.0 + 1e-15),
        ] {
            let e = check_sigma_t(&[bad; 3]).unwrap_err();
            assert!(e.ends_with("must be in [0, 1e6] per world unit"), "{e}");
        }
        assert_eq!(
            check_sigma_t(&[1e308; 3]).unwrap_err(),
            "sigma_t 1e308 must be in [0, 1e6] per world unit"
        );
        assert!(
            check_sigma_t(&[1.0, -2.0, 3.0])
                .unwrap_err()
                .starts_with("sigma_t 1, -2, 3 ")
        );
    }

    #[test]
    fn clip_matches_point_sampling() {
        let b = Aabb {
            min: [-1.0, -2.0, 0.0],
            max: [1.0, 2.0, 3.0],
        };
        let inside = |p: Vec3| (0..3).all(|k| p[k] >= b.min[k] && p[k] <= b.max[k]);
        let rays: [(Vec3, Vec3); 5] = [
            ([-5.0, 0.5, 1.0], [1.0, 0.0, 0.0]),
            ([-5.0, -5.0, -5.0], [0.6, 0.48, 0.64]),
            ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]),
            ([0.0, 3.0, 1.0], [1.0, 0.0, 0.0]),
            ([2.0, 2.0, 2.0], [0.0, 0.6, 0.8]),
        ];
        for (o, d) in rays {
            let clip = b.clip(o, d, 0.0, 100.0);
            // Brute force: the first and last of 200001 samples inside.
            let ts: Vec<f64> = (0..=200_000)
                .map(|i| i as f64 * 100.0 / 200_000.0)
                .filter(|&t| inside(crate::vec3::axpy(o, t, d)))
                .collect();
            match clip {
                None => assert!(ts.is_empty(), "{o:?} {d:?}: {ts:?}"),
                Some((t0, t1)) => {
                    let (a, z) = (ts[0], *ts.last().unwrap());
                    assert!(
                        (t0 - a).abs() < 1e-3 && (t1 - z).abs() < 1e-3,
                        "{t0} {t1} vs {a} {z}"
                    );
                }
            }
        }
    }

    #[test]
    fn henyey_greenstein_integrates_to_one() {
        // ∫ p dω = 2π∫₋₁¹ p(μ) dμ by composite Simpson on a fine grid (error ≪ 1e-6 for
        // |g| ≤ 0.9, whose peak width is ~(1 − g)).
        for g in [-0.9, -0.3, 0.0, 0.5, 0.9] {
            let n = 200_000;
            let h = 2.0 / n as f64;
            let mut s = 0.0;
            for i in 0..=n {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                s += w * henyey_greenstein(g, -1.0 + i as f64 * h);
            }
            let total = 2.0 * std::f64::consts::PI * s * h / 3.0;
            assert!((total - 1.0).abs() < 1e-6, "g {g}: {total}");
        }
    }
}
