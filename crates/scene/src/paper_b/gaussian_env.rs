//! The environment's light on Gaussian media and on surfaces inside them (paper B §4.2,
//! eq. 26–27), through the average optical depth `T̄(p) = β_bg·D + Σᵢ cᵢ𝒯(aᵢ|p − bᵢ|)/aᵢ`
//! ([`haze_gaussians::average`]), the sum over the Gaussians taken by a Barnes–Hut tree
//! ([`haze_gaussians::mean_tree`]: far groups by their moments, within 1 % of their share,
//! measured ≤ 10⁻⁴ over a cloud): light from a distant environment `L(ω)` reaches `p`
//! attenuated by `e^{−T̄(p)}` whatever its direction.
//!
//! * **Surfaces** (eq. 27 shaded by eq. 20): the environment's SH lighting of paper C
//!   ([`EnvGlow::surface`]: Lambert and Phong lobes, the scene's homogeneous fog with its
//!   glow, unshadowed by surfaces as in paper C §6.4) times `e^{−T̄(p)}`. The light the
//!   Gaussians scatter onto the surface is eq. 27's `T̄e^{−T̄}(L∗NPSF)`; with the
//!   environment's sources at infinity and isotropic scattering only the band `l = 0`
//!   of the PSF survives, `L∗NPSF → Ē = (1/4π)∫L dω`, and with the albedos,
//!   `S̄(p)·e^{−T̄(p)}·Ē`, `S̄ = Σᵢ αᵢT̄ᵢ(p)`, reflected by the lobes integrated over the
//!   hemisphere, `ρd + ks(m + 2)/(m + 1)` (as a sun's in-scattering in [`crate::render`]).
//! * **Airlight of the Gaussians**, single scattering (isotropic phase): a point `x`
//!   scatters `σs(x)·e^{−T̄(x)}·Ē(x)` towards the eye, `Ē(x) = (1/4π)∫L(ω)·V(x, ω) dω`
//!   with `V` the surfaces' visibility and the scene fog's `e^{−σt·D}` (as
//!   [`crate::march::env_smoke`]). As the point lights' `f0·f1` ([`haze_gaussians::airlight`]),
//!   everything but Gaussian `i`'s own density is sampled once per frame at its centre:
//!   `Lᵢ ≈ αᵢ·Ēᵢ·e^{Eᵢ}·e^{−Tᵢ(v,bᵢʳ) − T̄ᵢ(bᵢʳ)}·Tᵢ(v,p)` with
//!   `Eᵢ = −Σ_{j≠i}[Tⱼ(v,bᵢ) + T̄ⱼ(bᵢ)] − β0·|v − bᵢ| − β_bg·D` and `Ēᵢ = Ē(bᵢ)` by the
//!   product rule of [`ENV_THETA`] nodes ([`crate::march::env_smoke::directions`]). The
//!   homogeneous part's own airlight of the environment is left out, as in the march
//!   ([`crate::march::env_smoke`]).
//!
//! Errors (measured against the march with the environment integrated over directions,
//! BENCHMARKS.md "Paper B"): `e^{−T̄}` for the average of `e^{−T(x,ω)}` over `L(ω)`
//! (Jensen: darker, by ~`Var(T)/2`), `Ē` and `T̄ⱼ` sampled at the centres.

use crate::march::env_smoke::directions;
use crate::paper_c::envglow::{self, EnvGlow};
use crate::scene::{Environment, Material, Rgb, Scene};
use crate::vec3::{Vec3, norm, sub};
use haze_gaussians::airlight::GaussianSet;
use haze_gaussians::mean_tree::MeanDepthTree;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Gauss–Legendre nodes in `cos θ` of the rule for `Ēᵢ` (`2·12²` directions).
pub const ENV_THETA: usize = 12;

/// The environment prepared for a frame of paper B.
#[derive(Debug)]
pub struct GaussianEnv {
    /// Paper C's environment in SH (the surfaces' lighting).
    pub glow: EnvGlow,
    /// `Ē` unshadowed, times the fog's `e^{−σt·D}`: the scattered term's radiance.
    pub mean: Rgb,
    /// Per Gaussian and channel `αᵢ·Ēᵢ·e^{Eᵢ}` (module docs).
    pub center: Vec<Rgb>,
    /// `β_bg·D`, the Gaussian media's backgrounds out to the environment.
    pub background_depth: f64,
    /// The Gaussians' `T̄ⱼ` and `αⱼT̄ⱼ` summed by a Barnes–Hut tree.
    tree: MeanDepthTree,
}

/// `e^{−σt·D}` of the scene's fog per channel (1 without fog, 0 for `D = ∞`).
fn fog_factor(scene: &Scene) -> Rgb {
    let d = scene.environment_distance;
    scene
        .medium
        .sigma_t
        .map(|s| if s > 0.0 { (-s * d).exp() } else { 1.0 })
}

impl GaussianEnv {
    /// The frame's environment terms; `None` for a black environment. `to_eye` is each
    /// centre's [`GaussianSet::depth_to_point`] towards the eye, `beta0` the homogeneous
    /// part per channel, `background` the Gaussian media's share of it, `exponents` the
    /// scene's Phong exponents; the glow is `analytic`'s, kept between frames
    /// ([`envglow::Cache`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &Scene,
        analytic: &crate::render::Analytic,
        set: &GaussianSet,
        to_eye: &[f64],
        beta0: Rgb,
        background: f64,
        exponents: &[f64],
    ) -> Option<GaussianEnv> {
        if matches!(scene.environment, Environment::Black) {
            return None;
        }
        let glow = analytic
            .glow
            .glow(scene, &analytic.h, envglow::DEFAULT_ORDER, exponents)?;
        let fog = fog_factor(scene);
        // Y_00 = 1/(2√π): (1/4π)∫L = L_00·Y_00.
        let y00 = 0.5 / PI.sqrt();
        let mean = [0, 1, 2].map(|c| glow.radiance[0][c] * y00 * fog[c]);
        let background_depth = if background > 0.0 {
            background * scene.environment_distance
        } else {
            0.0
        };
        let rule = directions(ENV_THETA);
        let eye = scene.camera.eye;
        let blobs = set.blobs();
        let tree = MeanDepthTree::new(blobs);
        let center = (0..blobs.len())
            .into_par_iter()
            .map(|i| {
                let b = &blobs[i];
                let x = b.center;
                let eps = 1e-9 * (1.0 + norm(x));
                let mut e = [0.0; 3];
                for (w, wt) in &rule {
                    if scene.intersect(x, *w, eps, f64::INFINITY).is_none() {
                        let l = scene.environment.radiance(*w);
                        for c in 0..3 {
                            e[c] += wt * l[c];
                        }
                    }
                }
                let others = tree.at(x, Some(i)).0;
                let lv = norm(sub(eye, x));
                let to_eye = to_eye[i];
                [0, 1, 2].map(|c| {
                    let path = if beta0[c] > 0.0 { beta0[c] * lv } else { 0.0 };
                    b.albedo * e[c] / (4.0 * PI)
                        * fog[c]
                        * (-(others + to_eye + path + background_depth)).exp()
                })
            })
            .collect();
        Some(GaussianEnv {
            glow,
            mean,
            center,
            background_depth,
            tree,
        })
    }

    /// `(T̄(p), S̄(p))`: the average optical depth around `p` and its scattering part.
    pub fn mean_depth(&self, p: Vec3) -> (f64, f64) {
        let (t, s) = self.tree.at(p, None);
        (self.background_depth + t, s)
    }

    /// The environment's light reflected towards the viewer by the surface point `p` of
    /// unit normal `n` (`r` the view's mirror direction), with the light the Gaussians
    /// scatter onto it when `scattering` (module docs).
    pub fn surface(&self, p: Vec3, n: Vec3, r: Vec3, m: &Material, scattering: bool) -> Rgb {
        let (t, s) = self.mean_depth(p);
        let att = (-t).exp();
        let direct = self.glow.surface(n, r, m);
        [0, 1, 2].map(|c| {
            let mut v = att * direct[c];
            if scattering && s > 0.0 {
                let lobes =
                    m.diffuse[c] + m.specular[c] * (m.shininess + 2.0) / (m.shininess + 1.0);
                v += s * att * self.mean[c] * lobes;
            }
            v
        })
    }
}
