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
//! * **The others' shadow on the sky** ([`sky_attenuation`]). The paper attenuates `Ēᵢ`
//!   by `e^{−Σ_{j≠i}T̄ⱼ(bᵢ)}`, the others' depth averaged over all directions. What reaches
//!   the centre is the sky-weighted mean `A = Σ_ω p(ω)e^{−T(bᵢ,ω)}`, `p ∝ L(ω)V(ω)`: by
//!   Jensen `e^{−T̄}` is darker than the uniform mean, and a bright part of the sky behind
//!   a thick neighbour is darker still. Both `A` and `e^{−T̄}` lie in `[1 − κT̄, 1]`, with
//!   `κ = max_ω p(ω)·4π ≥ 1` the sky's peak over its mean, so `e^{−T̄}` is off by at most
//!   `κT̄/(1 − κT̄)` of `A` ([`shadow_bound`]). Where that bound, times the environment's
//!   share of the Gaussian's light (against the point lights' and suns', at its centre),
//!   exceeds the target ([`super::PaperBOptions::target`]), `A` is taken on [`SKY_THETA`]'s
//!   `2·4²` directions with the others' exact depths towards each (counted in
//!   [`GaussianEnv::exact_sky`]).
//! * **The surfaces' shadow on the sky** ([`GaussianEnv::surface_sky`]). Likewise a
//!   surface point `p` under the Gaussians receives the cosine-weighted visible sky
//!   through the depths towards each direction, `A = Σ_ω p(ω)e^{−T(p,ω)}` with
//!   `p ∝ L(ω)V(ω)(n·ω)⁺`, not `e^{−T̄(p)}`: under a dense cloud the floor sees the
//!   cloud's shadow where the sky is bright and none below the horizon. Where
//!   [`shadow_bound`]`(κ, T̄(p))` exceeds the target, `A/e^{−T̄(p)}` is taken on
//!   [`SURFACE_THETA`]'s rule; the renderers (CPU and GPU) do so on a grid of pixels
//!   ([`super::sky_grid`]) and interpolate the ratio between grid pixels on the same
//!   surface (`PaperBOptions::surface_sky`).
//!
//! Errors (measured against the march with the environment integrated over directions,
//! BENCHMARKS.md "Paper B: the environment's airlight on dense clouds"): `Ē` and the
//! others' depth towards the eye sampled at the centres, the own Gaussian's attenuation at
//! the ray's closest point, and, below the target, `e^{−T̄}` for `A`.

use crate::march::env_smoke::directions;
use crate::paper_c::envglow::{self, EnvGlow};
use crate::scene::{Environment, Material, Rgb, Scene};
use crate::vec3::{Vec3, axpy, dot, norm, sub};
use haze_gaussians::airlight::GaussianSet;
use haze_gaussians::mean_tree::MeanDepthTree;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Gauss–Legendre nodes in `cos θ` of the rule for `Ēᵢ` (`2·12²` directions).
pub const ENV_THETA: usize = 12;

/// Gauss–Legendre nodes in `cos θ` of the rule for the others' exact shadow on the sky
/// (`2·4²` directions; 18 and 288 directions give the same figures within 0.5 points).
pub const SKY_THETA: usize = 3;

/// The product rule of the surfaces' exact shadow on the sky
/// ([`GaussianEnv::surface_sky`]): `2·6²` directions, 36 above a floor (18 left the
/// dense cloud's floor 3.7 % off the march, 36 1.6 %: BENCHMARKS "Paper B: the
/// environment's airlight on dense clouds").
pub const SURFACE_THETA: usize = 6;

/// The mean over the Gaussians of the others' average depth around each centre,
/// `Σ_{j≠i}T̄ⱼ(bᵢ)`, above which paper B's environment terms are no longer within 3 % of
/// the exact integral. Measured against the march (`paper_b_figures environment`, the
/// built-in sky over a floor): mean 0.07–0.09 → pictures 1.2–1.4 % off; 0.52 (2000
/// Gaussians of peak depth 0.05) → 5.2 %; 0.69, 0.86, 1.23 (peak depths 0.2, 0.5, 1) →
/// 5.3, 5.2, 6.2 %, the Gaussians' own glow 14, 21, 44 %. Each Gaussian's glow is dimmed
/// through the others in front at its centre for every ray, and (before the surfaces'
/// exact shadow on the sky) the floor under such a cloud was dimmed by `e^{−T̄}` for its
/// real shadow. Between the two, 3 % fell near 0.25.
pub const VALID_MEAN_DEPTH: f64 = 0.25;

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
    /// How many Gaussians took the others' shadow on the sky exactly (module docs).
    pub exact_sky: usize,
    /// The mean over the Gaussians of `Σ_{j≠i}T̄ⱼ(bᵢ)` ([`VALID_MEAN_DEPTH`]).
    pub mean_depth_around: f64,
    /// The Gaussians' `T̄ⱼ` and `αⱼT̄ⱼ` summed by a Barnes–Hut tree.
    tree: MeanDepthTree,
    /// The directions of the surfaces' exact shadow on the sky ([`SURFACE_THETA`]).
    surface_rule: Vec<(Vec3, f64)>,
}

/// `e^{−σt·D}` of the scene's fog per channel (1 without fog, 0 for `D = ∞`).
fn fog_factor(scene: &Scene) -> Rgb {
    let d = scene.environment_distance;
    scene
        .medium
        .sigma_t
        .map(|s| if s > 0.0 { (-s * d).exp() } else { 1.0 })
}

/// An upper bound on the relative error of `e^{−T̄}` for the sky-weighted mean
/// transmittance `A = Σ_ω p(ω)e^{−T(ω)}` of depths `T ≥ 0` whose uniform mean over the
/// sphere is `T̄ = tbar`, with `p ≤ κ/4π` (`kappa ≥ 1`): both lie in `[1 − κT̄, 1]`
/// (`e^{−T} ≥ 1 − T`, `Σ pT ≤ κT̄`), so they differ by at most `κT̄`, and `A ≥ 1 − κT̄`;
/// `∞` once `κT̄ ≥ 1`.
pub fn shadow_bound(kappa: f64, tbar: f64) -> f64 {
    let k = kappa.max(1.0) * tbar.max(0.0);
    if k < 1.0 {
        k / (1.0 - k)
    } else {
        f64::INFINITY
    }
}

/// The others' shadow on the sky seen from Gaussian `i`'s centre per channel,
/// `Σ_ω w·L(ω)V(ω)e^{−Σ_{j≠i}Tⱼ(bᵢ,ω)} / Σ_ω w·L(ω)V(ω)` over `rule` (module docs), the
/// depths to infinity by [`GaussianSet::cull_depth`]; 1 where the sky is dark.
fn sky_attenuation(
    scene: &Scene,
    set: &GaussianSet,
    i: usize,
    rule: &[(Vec3, f64)],
    visible: &(impl Fn(Vec3, Vec3) -> bool + Sync),
) -> Rgb {
    let x = set.blobs()[i].center;
    let (mut num, mut den) = ([0.0; 3], [0.0; 3]);
    for (w, wt) in rule {
        if visible(x, *w) {
            let l = scene.environment.radiance(*w);
            let t = (-set.cull_depth(x, *w, f64::INFINITY, Some(i)).0).exp();
            for c in 0..3 {
                num[c] += wt * l[c] * t;
                den[c] += wt * l[c];
            }
        }
    }
    [0, 1, 2].map(|c| if den[c] > 0.0 { num[c] / den[c] } else { 1.0 })
}

impl GaussianEnv {
    /// The frame's environment terms; `None` for a black environment. `to_eye` is each
    /// centre's [`GaussianSet::depth_to_point`] towards the eye, `beta0` the homogeneous
    /// part per channel, `background` the Gaussian media's share of it, `exponents` the
    /// scene's Phong exponents, `lit` each centre's light from the point lights and suns
    /// (summed over the channels, as [`GaussianEnv::center`]), `target` the relative error
    /// the others' mean shadow on the sky may make (module docs); the glow is
    /// `analytic`'s, kept between frames ([`envglow::Cache`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        scene: &Scene,
        analytic: &crate::render::Analytic,
        set: &GaussianSet,
        to_eye: &[f64],
        beta0: Rgb,
        background: f64,
        exponents: &[f64],
        lit: &[f64],
        target: f64,
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
        let sky_rule = directions(SKY_THETA);
        let eye = scene.camera.eye;
        let blobs = set.blobs();
        let tree = MeanDepthTree::new(blobs);
        let lum = |v: Rgb| v[0] + v[1] + v[2];
        let visible = |x: Vec3, w: Vec3| {
            let eps = 1e-9 * (1.0 + norm(x));
            scene.intersect(x, w, eps, f64::INFINITY).is_none()
        };
        let per_gaussian: Vec<(Rgb, bool, f64)> = (0..blobs.len())
            .into_par_iter()
            .map(|i| {
                let b = &blobs[i];
                let x = b.center;
                let (mut e, mut peak) = ([0.0; 3], 0.0f64);
                for (w, wt) in &rule {
                    if visible(x, *w) {
                        let l = scene.environment.radiance(*w);
                        peak = peak.max(lum(l));
                        for c in 0..3 {
                            e[c] += wt * l[c];
                        }
                    }
                }
                let lv = norm(sub(eye, x));
                let unshadowed = [0, 1, 2].map(|c| {
                    let path = if beta0[c] > 0.0 { beta0[c] * lv } else { 0.0 };
                    b.albedo * e[c] / (4.0 * PI)
                        * fog[c]
                        * (-(to_eye[i] + path + background_depth)).exp()
                });
                let others = tree.at(x, Some(i)).0;
                let kappa = if lum(e) > 0.0 {
                    4.0 * PI * peak / lum(e)
                } else {
                    1.0
                };
                let env = lum(unshadowed);
                let share = if env > 0.0 {
                    env / (env + lit.get(i).copied().unwrap_or(0.0))
                } else {
                    0.0
                };
                let exact = share * shadow_bound(kappa, others) > target;
                let att = if exact {
                    sky_attenuation(scene, set, i, &sky_rule, &visible)
                } else {
                    [(-others).exp(); 3]
                };
                ([0, 1, 2].map(|c| unshadowed[c] * att[c]), exact, others)
            })
            .collect();
        let exact_sky = per_gaussian.iter().filter(|g| g.1).count();
        let mean_depth_around =
            per_gaussian.iter().map(|g| g.2).sum::<f64>() / per_gaussian.len().max(1) as f64;
        let center = per_gaussian.into_iter().map(|g| g.0).collect();
        Some(GaussianEnv {
            glow,
            mean,
            center,
            background_depth,
            exact_sky,
            mean_depth_around,
            tree,
            surface_rule: directions(SURFACE_THETA),
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
    pub fn surface(
        &self,
        p: Vec3,
        n: Vec3,
        r: Vec3,
        m: &Material,
        scattering: bool,
        sky: Rgb,
    ) -> Rgb {
        let (t, s) = self.mean_depth(p);
        let direct = self.glow.surface(n, r, m);
        [0, 1, 2].map(|c| {
            let att = (-t).exp() * sky[c];
            let mut v = att * direct[c];
            if scattering && s > 0.0 {
                let lobes =
                    m.diffuse[c] + m.specular[c] * (m.shininess + 2.0) / (m.shininess + 1.0);
                v += s * att * self.mean[c] * lobes;
            }
            v
        })
    }

    /// The others' exact shadow on the sky at the surface point `p` of unit normal `n`,
    /// relative to `e^{−T̄(p)}`, per channel: `A/e^{−T̄}` with
    /// `A = Σ_ω w·L(ω)V(ω)(n·ω)⁺e^{−T(p,ω)} / Σ_ω w·L(ω)V(ω)(n·ω)⁺` over [`SURFACE_THETA`]'s
    /// rule (`T` the Gaussians' depth to infinity over their cull spheres, `V` the
    /// surfaces' visibility), where [`shadow_bound`]`(κ, T̄)` exceeds `target` (`κ` the
    /// cosine-weighted visible sky's peak over its mean); 1 elsewhere and where no sky is
    /// seen. The ratio is kept within `e^{±700}`.
    pub fn surface_sky(
        &self,
        scene: &Scene,
        set: &GaussianSet,
        p: Vec3,
        n: Vec3,
        target: f64,
    ) -> Rgb {
        let lum = |v: Rgb| v[0] + v[1] + v[2];
        let x = axpy(p, 1e-9 * (1.0 + norm(p)), n);
        let (mut den, mut peak) = ([0.0; 3], 0.0f64);
        let mut seen = Vec::with_capacity(self.surface_rule.len());
        for (w, wt) in &self.surface_rule {
            let cos = dot(n, *w);
            if cos <= 0.0 || scene.intersect(x, *w, 0.0, f64::INFINITY).is_some() {
                continue;
            }
            let l = scene.environment.radiance(*w);
            peak = peak.max(lum(l) * cos);
            let q = l.map(|c| wt * c * cos);
            for c in 0..3 {
                den[c] += q[c];
            }
            seen.push((*w, q));
        }
        let tbar = self.tree.at(p, None).0;
        if lum(den) <= 0.0 || shadow_bound(4.0 * PI * peak / lum(den), tbar) <= target {
            return [1.0; 3];
        }
        let mut num = [0.0; 3];
        for (w, q) in seen {
            let t = (-set.cull_depth(p, w, f64::INFINITY, None).0).exp();
            for c in 0..3 {
                num[c] += q[c] * t;
            }
        }
        [0, 1, 2].map(|c| {
            if den[c] > 0.0 && num[c] > 0.0 {
                ((num[c] / den[c]).ln() + tbar).clamp(-700.0, 700.0).exp()
            } else if den[c] > 0.0 {
                0.0
            } else {
                1.0
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{SURFACE_THETA, directions, shadow_bound};
    use crate::paper_b::{PaperBOptions, Prepared};
    use crate::render::Analytic;
    use crate::vec3::{dot, normalize};

    /// A floor under the built-in sky and one Gaussian of peak depth `tau` (radius 0.4,
    /// centre 1.2 above the origin), no lights.
    fn one_over_a_floor(tau: f64) -> crate::Scene {
        // Peak depth τ = c·r√π for a Gaussian c·e^{−|x−b|²/r²}: weight c/σt = τ/(σt r√π).
        let weight = tau / (2.0 * 0.4 * std::f64::consts::PI.sqrt());
        let text = format!(
            r#"{{"camera": {{"eye": [0, -6, 1.6], "target": [0, 0, 1.0], "fov": 45, "width": 8, "height": 6}},
            "environment": "sky", "lights": [],
            "media": [{{"type": "gaussians", "sigma_t": 2, "albedo": 0.9, "gaussians": [
                {{"center": [0, 0, 1.2], "radius": 0.4, "weight": {weight}}}]}}],
            "surfaces": [{{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                "material": {{"diffuse": [0.6, 0.6, 0.6]}}}}]}}"#
        );
        crate::file::parse(&text).unwrap()
    }

    #[test]
    fn the_surfaces_shadow_on_the_sky_follows_a_fine_quadrature_or_its_bound() {
        let (thick, faint) = (one_over_a_floor(3.0), one_over_a_floor(1e-4));
        let up = [0.0, 0.0, 1.0];
        for (scene, p) in [(&thick, [0.0, 0.0, 0.0]), (&thick, [0.3, 0.2, 0.0])] {
            let analytic = Analytic::new(scene);
            let prep = Prepared::new(scene, &analytic, PaperBOptions::default()).unwrap();
            let env = prep.env.as_ref().unwrap();
            let got = env.surface_sky(scene, &prep.set, p, up, 0.02);
            // Independently: the cosine-weighted sky over a rule of 8× the directions,
            // each through the Gaussian's exact line depth, over `e^{−T̄}` in closed form.
            let b = &prep.set.blobs()[0];
            let (mut num, mut den) = ([0.0; 3], [0.0; 3]);
            for (w, wt) in directions(3 * SURFACE_THETA) {
                let cos = dot(up, w);
                if cos <= 0.0 {
                    continue;
                }
                let l = scene.environment.radiance(w);
                let t = haze_gaussians::line::gaussian(b.c, b.a, b.center, p, w, f64::INFINITY);
                for c in 0..3 {
                    num[c] += wt * l[c] * cos * (-t).exp();
                    den[c] += wt * l[c] * cos;
                }
            }
            let tbar = haze_gaussians::average::gaussian_mean_depth(b.c, b.a, b.center, p);
            assert_ne!(got, [1.0; 3], "the bound takes the exact shadow here");
            for c in 0..3 {
                let want = num[c] / den[c] / (-tbar).exp();
                // 72 directions against 648: the shadow of one Gaussian of radius 0.4
                // at 1.2 (about 40° across) covers a few of the coarse rule's 30° cells;
                // measured within 2.7 %.
                assert!(
                    (got[c] - want).abs() <= 0.04 * want,
                    "{p:?} {c}: {} vs {want}",
                    got[c]
                );
            }
        }
        // Where the bound holds (a faint Gaussian, or the point far from it): exactly 1.
        let analytic = Analytic::new(&faint);
        let prep = Prepared::new(&faint, &analytic, PaperBOptions::default()).unwrap();
        let env = prep.env.as_ref().unwrap();
        assert_eq!(
            env.surface_sky(&faint, &prep.set, [0.0; 3], up, 0.02),
            [1.0; 3]
        );
        // Extremes: inside the thick Gaussian, facing every way: finite and not negative.
        let analytic = Analytic::new(&thick);
        let prep = Prepared::new(&thick, &analytic, PaperBOptions::default()).unwrap();
        let env = prep.env.as_ref().unwrap();
        for n in [
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            normalize([1.0, 1.0, 1.0]).unwrap(),
        ] {
            let r = env.surface_sky(&thick, &prep.set, [0.0, 0.0, 1.2], n, 0.02);
            assert!(r.iter().all(|v| v.is_finite() && *v >= 0.0), "{n:?}: {r:?}");
        }
    }
    use haze_gaussians::cloud::Uniform;

    #[test]
    fn the_shadow_bound_holds_on_any_sky_and_depths() {
        // Brute force: random depths on 200 equal-area directions, a random sky (some
        // directions dark, a few very bright), the exact sky-weighted mean transmittance
        // against e^{−T̄}; the bound must cover every draw.
        let mut u = Uniform::new(7);
        let mut tightest = f64::INFINITY;
        for draw in 0..2000 {
            let n = 200;
            let scale = [0.01, 0.1, 0.5, 2.0][draw % 4];
            let t: Vec<f64> = (0..n)
                .map(|_| scale * (-u.sample().max(1e-12).ln()).powi(2))
                .collect();
            let l: Vec<f64> = (0..n)
                .map(|_| {
                    let x = u.sample();
                    if x < 0.3 {
                        0.0
                    } else if x < 0.32 {
                        50.0 * u.sample()
                    } else {
                        u.sample()
                    }
                })
                .collect();
            let sum_l: f64 = l.iter().sum();
            if sum_l <= 0.0 {
                continue;
            }
            let tbar = t.iter().sum::<f64>() / n as f64;
            let kappa = l.iter().cloned().fold(0.0, f64::max) * n as f64 / sum_l;
            let a: f64 = l.iter().zip(&t).map(|(l, t)| l * (-t).exp()).sum::<f64>() / sum_l;
            let err = ((-tbar).exp() - a).abs() / a;
            let bound = shadow_bound(kappa, tbar);
            assert!(err <= bound * (1.0 + 1e-12), "draw {draw}: {err} > {bound}");
            if bound.is_finite() && err > 0.0 {
                tightest = tightest.min(bound / err);
            }
        }
        // Loose (a sky's peak may sit on the deepest shadow, or on none), but not without
        // limit: within 10.3× of the error on the tightest draw.
        assert!(
            tightest < 15.0,
            "the bound is never within 15× of the error: {tightest}"
        );
    }

    #[test]
    fn the_shadow_bound_at_its_extremes() {
        assert_eq!(shadow_bound(1.0, 0.0), 0.0);
        assert_eq!(shadow_bound(0.5, 0.1), shadow_bound(1.0, 0.1)); // κ ≥ 1 always
        assert_eq!(shadow_bound(1.0, -1.0), 0.0);
        assert_eq!(shadow_bound(2.0, 0.5), f64::INFINITY);
        assert_eq!(shadow_bound(f64::INFINITY, 1e-3), f64::INFINITY);
        assert!((shadow_bound(2.0, 0.1) - 0.25).abs() < 1e-15);
        assert!(shadow_bound(1e6, 1e-9).is_finite());
    }
}
