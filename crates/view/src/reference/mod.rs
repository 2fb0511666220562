//! The reference renderer: the accuracy oracle of the fast renderer. Slow, unbiased and
//! deterministic.
//!
//! Radiance along a camera ray `o + t·d` (paper A §3, `Lout = Ld + Lm`):
//! `L = T(t₀, t₁)·L_env(d) + ∫ T(t₀, t)·σt D(x_t)·J(x_t, d) dt`, with the source radiance
//! `J = (Ω/4π)∫ p(ωᵢ·d) Lᵢ(x, ωᵢ) dωᵢ`, `p` the Henyey–Greenstein phase normalized so that
//! `(1/4π)∫p dω = 1`, and `ωᵢ` the direction the light comes from.
//!
//! - [`RefOptions::multiple`] `= false`: single scattering, `Lᵢ = T_light(x, ωᵢ)·L_env(ωᵢ)`
//!   (`single.rs`).
//! - `= true`: every order up to [`RefOptions::max_bounces`] by volumetric path tracing
//!   (`path.rs`).
//!
//! At every scattering point both estimators sample the suns and point lights explicitly
//! and, with [`RefOptions::env_sampling`], the distant environment too: a direction from
//! the map's luminance combined with the phase-sampled one by multiple importance
//! sampling (`env_sampling.rs`), so that neither a small bright region of the map nor a
//! sharp forward phase function leaves rare, huge samples.
//!
//! Transmittances are exact (`track.rs`: the optical depth of the trilinear field along a
//! ray is integrated exactly piece by piece) and collisions are sampled by inverting it, so the
//! only noise is that of the scattering events and the light directions. One ray per pixel,
//! through its center (docs/conventions.md); each pixel draws from its own generator, seeded from
//! [`RefOptions::seed`] and the pixel index, so images do not depend on the thread count.

mod env_sampling;
mod path;
mod single;
mod track;

use haze_volume::volume::ShapeError;
use haze_volume::{Bbox, Rbf, Volume};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use rayon::prelude::*;

use crate::field::ray_box;
use crate::ground::{GroundLight, sky_irradiance, sky_seen};
use crate::lights::dot;
use crate::medium::{FOUR_PI, Medium, hg, sample_hg_cos};
use crate::{Camera, Environment, Image, Rgb};
use env_sampling::{EnvSampler, power_heuristic};
use rand::RngExt;

/// Sample counts and switches of the reference renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefOptions {
    /// Samples per pixel: scattering points along the camera ray (single scattering) or
    /// paths (multiple scattering). At least 1 is used.
    pub spp: u32,
    /// Single scattering: environment directions per scattering point, each with its
    /// exact transmittance. At least 1 is used. Path tracing does not use it (a path
    /// collects the environment when it leaves the volume).
    pub light_samples: u32,
    /// Seed of the per-pixel generators.
    pub seed: u64,
    /// Every order of scattering (path tracing) instead of single scattering only.
    pub multiple: bool,
    /// Path tracing: the most scattering events of a path; paths needing more contribute
    /// nothing (the only bias, and the energy lost is the probability of such paths).
    pub max_bounces: u32,
    /// Importance-sample the distant environment at every scattering point, combined with
    /// phase sampling by MIS (`env_sampling.rs`); `false` samples the phase function only
    /// (the estimator before it, for comparisons). A map of constant luminance, and a map
    /// that brings less light than the suns, are sampled by the phase function either way
    /// (`sampler_for`).
    pub env_sampling: bool,
    /// A ground under the smoke, seen by camera rays, its shadow exact
    /// ([`crate::ground`]); none by default.
    pub ground: Option<crate::ground::Ground>,
}

impl Default for RefOptions {
    /// 256 samples per pixel, 4 light directions per single-scattering point, 256 bounces,
    /// the environment importance-sampled. Measured on a held-out plume (72 × 72 × 96,
    /// σt = 4, Ω = 0.8, g = 0.2, 120 × 90 pixels) under the built-in sky: image noise
    /// (`render_with_noise`) 1.5 % for single scattering and 2.2 % for path tracing
    /// (BENCHMARKS.md "Reference noise"); the truncation loss only matters for an albedo
    /// close to 1 at optical thickness in the tens.
    fn default() -> Self {
        RefOptions {
            spp: 256,
            light_samples: 4,
            seed: 0x6861_7a65,
            multiple: true,
            max_bounces: 256,
            env_sampling: true,
            ground: None,
        }
    }
}

/// What the estimators need to know about the scene.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scene<'a> {
    pub volume: &'a Volume,
    pub medium: &'a Medium,
    pub env: &'a Environment,
    /// The distribution the distant environment is sampled from, if it is.
    pub sampler: Option<&'a EnvSampler>,
    /// The ground camera rays see, lit.
    pub ground: Option<&'a GroundLight>,
    /// The open sky's irradiance on the ground, `E_sky` (zero without a ground).
    pub sky_irradiance: Rgb,
}

impl<'a> Scene<'a> {
    fn new(
        volume: &'a Volume,
        medium: &'a Medium,
        env: &'a Environment,
        sampler: Option<&'a EnvSampler>,
        ground: Option<&'a GroundLight>,
    ) -> Scene<'a> {
        Scene {
            volume,
            medium,
            env,
            sampler,
            ground,
            sky_irradiance: ground.map_or([0.0; 3], |_| sky_irradiance(&env.distant)),
        }
    }

    fn track(&self, o: [f64; 3], d: [f64; 3]) -> track::Track<'a> {
        track::Track::new(self.volume, self.medium.sigma_t, o, d)
    }

    /// What the camera ray from `o` along the unit `d` sees behind the smoke: the ground
    /// where it meets it, the lights' shadows exact and the sky's share estimated with
    /// `spp` directions or more drawn from `rng` ([`sky_seen::sampled`]), else the
    /// environment.
    fn background(&self, o: [f64; 3], d: [f64; 3], spp: u32, rng: &mut Pcg64) -> Rgb {
        match self.ground.and_then(|g| Some((g, g.hit(o, d)?))) {
            Some((g, x)) => {
                let shadow = |x, w, len| self.transmittance(x, w, len);
                let mut uniform = || rng.random::<f64>();
                let seen = sky_seen::sampled(
                    &self.env.distant,
                    self.sky_irradiance,
                    x,
                    spp as usize,
                    &mut uniform,
                    shadow,
                );
                g.radiance_seeing(x, seen, shadow)
            }
            None => self.env.radiance(d),
        }
    }

    /// `exp(−τ)` from `x` along the unit `w` over the distance `len` (∞: to the box's exit).
    fn transmittance(&self, x: [f64; 3], w: [f64; 3], len: f64) -> f64 {
        match ray_box(x, w, self.volume.bbox()) {
            Some((a, b)) if a < len => (-self.track(x, w).depth(a, b.min(len))).exp(),
            _ => 1.0,
        }
    }
}

/// The sampler of `env`'s distant radiance the estimators use under `opts`: none without
/// [`RefOptions::env_sampling`], for a map without light, for one of constant luminance,
/// or when the suns bring more light than the map (`Σ Y(E_sun) ≥ ∫ Y dω`). There phase
/// sampling alone finds the map as well: measured on held-out plume-b with a sun split
/// off carrying 75 % and 85 % of the light, sampling the map changed single scattering's
/// noise by −5 % and 0 % and the path tracer's by +14 % and +11 %, for 1.5–2.4× the time;
/// on the sky alone it halves the noise (BENCHMARKS.md, "Reference noise").
fn sampler_for(env: &Environment, opts: &RefOptions) -> Option<EnvSampler> {
    if !opts.env_sampling {
        return None;
    }
    let suns: f64 = env
        .suns
        .iter()
        .map(|s| env_sampling::luminance(s.irradiance))
        .filter(|y| y.is_finite())
        .sum();
    EnvSampler::for_distant(&env.distant).filter(|s| !s.is_uniform() && suns < s.power())
}

/// Renders `volume` lit by `env`, one ray per pixel center, `opts.spp` samples each, in
/// parallel over rows. The result depends on the inputs and `opts` only.
pub fn render(
    volume: &Volume,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    opts: &RefOptions,
) -> Image {
    let sampler = sampler_for(env, opts);
    let ground = opts.ground.map(|g| g.lit(env));
    let scene = Scene::new(volume, medium, env, sampler.as_ref(), ground.as_ref());
    render_scene(&scene, camera, opts, &|| {})
}

/// [`render`] of a scene whose sampler is built; `on_row` is called as each row of pixels
/// is done (from the worker threads).
fn render_scene(
    scene: &Scene<'_>,
    camera: &Camera,
    opts: &RefOptions,
    on_row: &(dyn Fn() + Sync),
) -> Image {
    let (w, h) = (camera.width, camera.height);
    let mut image = Image::new(w, h);
    image
        .pixels
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let mut rng = pixel_rng(opts.seed, (y * w + x) as u64);
                let d = camera.pixel_ray(x, y);
                let l = if opts.multiple {
                    path::radiance(scene, camera.eye, d, opts, &mut rng)
                } else {
                    single::radiance(scene, camera.eye, d, opts, &mut rng)
                };
                *px = l.map(|c| c as f32);
            }
            on_row();
        });
    image
}

/// The radiance through each of `pixels` (`(x, y)`) by `opts.spp` independent samples,
/// with the variance of that mean per channel (the samples' variance over their count):
/// a few pixels' reference, with the noise to discount, for a render's estimate of its
/// own error. Each pixel draws from the generator [`render`] gives it.
pub fn render_pixels(
    volume: &Volume,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    pixels: &[(usize, usize)],
    opts: &RefOptions,
) -> Vec<(Rgb, Rgb)> {
    let sampler = sampler_for(env, opts);
    let ground = opts.ground.map(|g| g.lit(env));
    let scene = Scene::new(volume, medium, env, sampler.as_ref(), ground.as_ref());
    let one = RefOptions { spp: 1, ..*opts };
    let n = opts.spp.max(1);
    pixels
        .par_iter()
        .map(|&(x, y)| {
            let mut rng = pixel_rng(opts.seed, (y * camera.width + x) as u64);
            let d = camera.pixel_ray(x, y);
            let (mut sum, mut sq) = ([0.0f64; 3], [0.0f64; 3]);
            for _ in 0..n {
                let l = if opts.multiple {
                    path::radiance(&scene, camera.eye, d, &one, &mut rng)
                } else {
                    single::radiance(&scene, camera.eye, d, &one, &mut rng)
                };
                for c in 0..3 {
                    sum[c] += l[c];
                    sq[c] += l[c] * l[c];
                }
            }
            let nf = f64::from(n);
            let mean = sum.map(|v| v / nf);
            let var = if n > 1 {
                [0, 1, 2].map(|c| ((sq[c] - nf * mean[c] * mean[c]) / (nf - 1.0)).max(0.0) / nf)
            } else {
                [0.0; 3]
            };
            (mean, var)
        })
        .collect()
}

/// [`render`] with its own noise estimate: two half-runs of `opts.spp / 2` samples (rounded
/// up) from different seeds, averaged into the image, whose noise is then
/// `rel_rms(A, B)/2` (the mean of two independent estimates has half the variance of
/// one, and `A − B` twice it) over the pixels where the smoke changes the environment by
/// more than 1 % (docs/conventions.md's mask). `None` for a single sample per pixel, or when no
/// pixel shows smoke.
pub fn render_with_noise(
    volume: &Volume,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    opts: &RefOptions,
) -> (Image, Option<f64>) {
    render_with_noise_rows(volume, medium, env, camera, opts, &|| {})
}

/// The rows [`render_with_noise`] renders for `camera` at `spp` samples: the height,
/// twice over for its two half-runs.
pub fn rows_to_render(camera: &Camera, spp: u32) -> usize {
    camera.height * if spp > 1 { 2 } else { 1 }
}

/// [`render_with_noise`], calling `on_row` as each of its [`rows_to_render`] rows is done
/// (from the worker threads): for a progress bar.
pub fn render_with_noise_rows(
    volume: &Volume,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    opts: &RefOptions,
    on_row: &(dyn Fn() + Sync),
) -> (Image, Option<f64>) {
    let sampler = sampler_for(env, opts);
    let ground = opts.ground.map(|g| g.lit(env));
    let scene = Scene::new(volume, medium, env, sampler.as_ref(), ground.as_ref());
    if opts.spp <= 1 {
        return (render_scene(&scene, camera, opts, on_row), None);
    }
    let half = RefOptions {
        spp: opts.spp.div_ceil(2),
        ..*opts
    };
    let a = render_scene(&scene, camera, &half, on_row);
    let b = render_scene(
        &scene,
        camera,
        &RefOptions {
            seed: opts.seed ^ 0x5eed_0001,
            ..half
        },
        on_row,
    );
    let mut image = Image::new(camera.width, camera.height);
    for ((p, q), o) in a.pixels.iter().zip(&b.pixels).zip(&mut image.pixels) {
        *o = [0, 1, 2].map(|c| 0.5 * (p[c] + q[c]));
    }
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (i, smoke) in smoke_pixels(&image, env, camera).into_iter().enumerate() {
        if smoke {
            for c in 0..3 {
                let (x, y) = (f64::from(a.pixels[i][c]), f64::from(b.pixels[i][c]));
                diff += (x - y) * (x - y);
                norm += f64::from(image.pixels[i][c]).powi(2);
            }
        }
    }
    let noise = (norm > 0.0).then(|| 0.5 * (diff / norm).sqrt());
    (image, noise)
}

/// The pixels of `image` where the smoke changes the environment seen through
/// `camera` by more than 1 % (summed over the channels): docs/conventions.md's error mask.
pub fn smoke_pixels(image: &Image, env: &Environment, camera: &Camera) -> Vec<bool> {
    image
        .pixels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let bg = env.radiance(camera.pixel_ray(i % camera.width, i / camera.width));
            let change: f64 = (0..3).map(|c| (f64::from(p[c]) - bg[c]).abs()).sum();
            change > 0.01 * bg.iter().map(|c| c.abs()).sum::<f64>()
        })
        .collect()
}

/// A density volume of `dims` voxels over `bbox`: the sum of `rbfs` at the voxel centers
/// (each cut off at 3r, `haze_volume::rbf::evaluate_on_grid`), for test scenes and
/// accuracy comparisons against the RBF-based renderer.
pub fn rbf_volume(rbfs: &[Rbf], dims: [usize; 3], bbox: Bbox) -> Result<Volume, ShapeError> {
    let data = haze_volume::rbf::evaluate_on_grid(dims, &bbox, rbfs)
        .into_iter()
        .map(|d| d as f32)
        .collect();
    Volume::new(dims, bbox, data)
}

/// The generator of pixel `index`: splitmix64 of the seed and index, so neighbouring
/// pixels and seeds get unrelated streams.
fn pixel_rng(seed: u64, index: u64) -> Pcg64 {
    let mut z = seed ^ index.wrapping_add(1).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    Pcg64::seed_from_u64(z ^ (z >> 31))
}

/// A direction `ω` with `ω·d = cos θ` drawn from HG(`g`) for `u1` and a uniform azimuth
/// `2π·u2` about the unit vector `d`: its density is `p(ω·d)/4π` per steradian.
fn hg_direction(d: [f64; 3], g: f64, u1: f64, u2: f64) -> [f64; 3] {
    let c = sample_hg_cos(g, u1);
    let s = (1.0 - c * c).max(0.0).sqrt();
    let phi = 2.0 * std::f64::consts::PI * u2;
    let (t1, t2) = crate::lights::basis(d);
    let (cp, sp) = (phi.cos(), phi.sin());
    [0, 1, 2].map(|k| c * d[k] + s * (cp * t1[k] + sp * t2[k]))
}

/// The light of `scene`'s suns and point lights scattered at `x` towards a viewer looking
/// along `d`, divided by the albedo: `Σ E·T_light·p(s·d)/4π`, one direction drawn
/// uniformly in each sun's disk (an unbiased estimate of the disk's integral), the exact
/// `1/r²` of each point light.
fn direct_light(scene: &Scene<'_>, x: [f64; 3], d: [f64; 3], rng: &mut Pcg64) -> Rgb {
    let g = scene.medium.g;
    let mut out = [0.0f64; 3];
    for sun in &scene.env.suns {
        let w = sun.sample_direction(rng.random(), rng.random());
        let k = scene.transmittance(x, w, f64::INFINITY) * hg(g, dot(w, d)) / FOUR_PI;
        for (o, e) in out.iter_mut().zip(sun.irradiance) {
            *o += e * k;
        }
    }
    for light in &scene.env.points {
        let v = [0, 1, 2].map(|a| light.position[a] - x[a]);
        let r2 = dot(v, v);
        if r2.is_nan() || r2 <= 0.0 {
            continue;
        }
        let r = r2.sqrt();
        let w = v.map(|c| c / r);
        let k = scene.transmittance(x, w, r) * hg(g, dot(w, d)) / (FOUR_PI * r2);
        for (o, i) in out.iter_mut().zip(light.intensity) {
            *o += i * k;
        }
    }
    out
}

/// One estimate of the distant environment's light scattered at `x` towards a viewer
/// looking along `d`, divided by the albedo:
/// `(1/4π)∫ p(ω·d)·T(x, ω)·L_distant(ω) dω`. With a sampler, one phase-sampled and one
/// map-sampled direction combined by the power heuristic (`env_sampling.rs`); without,
/// the phase-sampled direction alone (its density cancels the phase function).
fn distant_light(scene: &Scene<'_>, x: [f64; 3], d: [f64; 3], rng: &mut Pcg64) -> Rgb {
    let g = scene.medium.g;
    let w = hg_direction(d, g, rng.random(), rng.random());
    let Some(sampler) = scene.sampler else {
        let k = scene.transmittance(x, w, f64::INFINITY);
        return scene.env.distant.radiance(w).map(|c| c * k);
    };
    // Phase sample: f/q_p = T·L, weighted against the map's density there.
    let q_p = hg(g, dot(w, d)) / FOUR_PI;
    let k = power_heuristic(q_p, sampler.pdf(w)) * scene.transmittance(x, w, f64::INFINITY);
    let mut out = scene.env.distant.radiance(w).map(|c| c * k);
    // Map sample: f/q_e = p/4π·T·L/q_e, weighted against the phase density there.
    let (w, q_e) = sampler.sample(rng.random(), rng.random());
    let l = scene.env.distant.radiance(w);
    if l.iter().any(|c| *c > 0.0) {
        let q_p = hg(g, dot(w, d)) / FOUR_PI;
        let k = power_heuristic(q_e, q_p) * q_p / q_e * scene.transmittance(x, w, f64::INFINITY);
        for c in 0..3 {
            out[c] += l[c] * k;
        }
    }
    out
}

#[cfg(test)]
mod mis_tests;
#[cfg(test)]
mod tests;
