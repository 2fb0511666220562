//! Paper B (Zhou et al. 2007, §4–5): a scene whose media are Gaussian sums
//! ([`crate::media::gaussians`]) over an optional homogeneous part, rendered per pixel as
//! `L = La + e^{−T(v,p)}·Lp` (eq. 29), on the CPU.
//!
//! * **Homogeneous part** `β0` = the scene's homogeneous media plus every Gaussian
//!   medium's background (per channel, with its scattering `σs0`).
//! * **Airlight** of each point light: `L0 + Σᵢ Lᵢ`. The homogeneous term is paper C's
//!   airlight ([`crate::paper_c::airlight::point`], the same `K` table as [`crate::render`]) with
//!   `β0`, times `C_sv = e^{−Σᵢ Tᵢ(s, v)}` (eq. 15–17); each Gaussian the view ray passes
//!   within its cull radius adds `αᵢ·f0·f1·Tᵢ(v,p)` ([`haze_gaussians::airlight`]), its
//!   ray-independent exponent `Eᵢ` computed once per frame and light. Where the bound on
//!   that factorization's error ([`haze_gaussians::integrated::bound`], from the light's
//!   distance to the centre in radii and the Gaussian's optical depth) exceeds
//!   [`PaperBOptions::target`] — a light inside or near a Gaussian, a dense Gaussian —
//!   the pair's `Lᵢ` is integrated along the ray instead
//!   ([`haze_gaussians::integrated::integrated`]: the Gaussian's own attenuation, the
//!   light's hosts' — the Gaussians it sits inside — and the homogeneous part exact along
//!   `s → x → v` at every node, the others' through `Eᵢ`), and the homogeneous term's
//!   `C_sv` takes the hosts' attenuation along the ray
//!   ([`haze_gaussians::integrated::host_ratio`]). On the CPU both are integrated on a
//!   grid of pixels and reused between where smooth ([`reuse`], [`PaperBOptions::reuse`]).
//!   A sun is a light at
//!   infinity: Gaussians and backgrounds attenuate it, the scene's homogeneous media do
//!   not (paper C's convention, as in [`crate::march`]).
//! * **Screen optical depth** `T(v,p) = β0·dr + Σᵢ Tᵢ(v,p)` over the same Gaussians;
//!   rays that escape see the environment through it.
//! * **Surfaces** (§4.3, with paper C's tables): the optical depth `T(s,p)` from each
//!   light to the surface point is accumulated in closed form over the Gaussians whose
//!   cull sphere the path crosses (eq. 30; each other one misses at most `√π·ε/a`), plus
//!   `β0·|s − p|`; the direct light is `I·e^{−T(s,p)}·f·cos θ/d²` (shadowed by surfaces),
//!   the light the medium scatters onto the surface is paper C's `G0`/`Gn` terms with the
//!   path-averaged `β̄ = T(s,p)/d` and `σ̄s = S(s,p)/d` (the notes' "Tsp → T(s,p)").
//!   [`PaperBOptions::surface_scattering`] turns that term off (the march reference has
//!   none).
//! * **Environment** (§4.2, [`crate::paper_b::gaussian_env`]): the Gaussians scatter it towards
//!   the eye and dim it on surfaces through the average optical depth `T̄`; its light
//!   scattered onto surfaces follows [`PaperBOptions::surface_scattering`].
//! * **Noise** (§5.5): a medium's `noise` perturbs the direction along which its
//!   Gaussians' `Tᵢ(v,p)` is integrated ([`haze_gaussians::noise`]).

pub mod gaussian_env;
mod pairs;
pub mod reuse;
pub mod sky_grid;

use crate::media::HeteroMedium;
use crate::paper_c::airlight::{self, Limits, attenuated_length, effective_light, light_off_point};
use crate::render::{Analytic, Image, Model, background};
use crate::scene::{Light, Rgb, Scene};
use crate::vec3::{Vec3, axpy, dot, norm, reflect, scale, sub};
use gaussian_env::GaussianEnv;
use haze_gaussians::airlight::{GaussianSet, Source, factored};
use haze_gaussians::average::gaussian_mean_depth;
/// The optical depth below which an integrated pair's (or the homogeneous term's host
/// ratio's) listed Gaussian is dropped from a line (towards the eye or the light): at
/// most `2·MAX_EXACT·10⁻⁷` of a node's exponent.
const LIST_DELTA: f64 = 1e-7;

/// The most Gaussians an integrated pair (and the homogeneous term) takes exactly per node.
pub use haze_gaussians::integrated::MAX_EXACT;
use haze_gaussians::integrated::{SUPPORT, bound, host_ratio, integrated, unattenuated};
use haze_gaussians::light_view::LightView;
use haze_gaussians::line;
use haze_gaussians::noise::Noise;
pub use pairs::LeftAtCentres;
use pairs::{PairTerms, pair_terms};
use rayon::prelude::*;
use reuse::PairMode;
use std::f64::consts::PI;

/// Switches of the renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperBOptions {
    /// Include the light the medium scatters onto surfaces (paper C's `G` terms).
    pub surface_scattering: bool,
    /// The relative error the one-point factorization may make on a (light, Gaussian)
    /// pair (by [`haze_gaussians::integrated::bound`]); pairs above it are integrated.
    /// `∞`: the paper's closed form everywhere.
    pub target: f64,
    /// The most Gaussians an integrated pair (and the homogeneous term) takes exactly per
    /// node, at most [`MAX_EXACT`]; fewer on a device that limits a shader's loops
    /// (`crate::gpu::paper_b::options`).
    pub max_exact: usize,
    /// The CPU's screen-space reuse of the integrated pairs ([`reuse`]): their ratio to the
    /// unattenuated chord integral integrated every `reuse` pixels and interpolated
    /// between where it varies smoothly, through grids of half the stride down to every
    /// pixel ([`reuse::strides`]); 1: every pixel integrates.
    pub reuse: usize,
    /// The others' shadow on the sky at the surfaces taken over exact directions where
    /// `e^{−T̄(p)}`'s bound exceeds [`PaperBOptions::target`]
    /// ([`gaussian_env::GaussianEnv::surface_sky`]), on the grid of
    /// [`PaperBOptions::sky_stride`] pixels ([`sky_grid`]); off: `e^{−T̄(p)}` alone. The
    /// GPU reads the same table.
    pub surface_sky: bool,
    /// The stride of the grid of pixels that take the surfaces' shadow on the sky exactly
    /// ([`sky_grid`]); 1: every pixel.
    pub sky_stride: usize,
}

/// The default [`PaperBOptions::target`]: 2 %, inside the 3 % goal with room for
/// the other Gaussians' attenuation, taken through the centre either way.
pub const DEFAULT_TARGET: f64 = 0.02;

impl Default for PaperBOptions {
    fn default() -> Self {
        PaperBOptions {
            surface_scattering: true,
            target: DEFAULT_TARGET,
            max_exact: MAX_EXACT,
            reuse: reuse::DEFAULT_STRIDE,
            surface_sky: true,
            sky_stride: reuse::DEFAULT_STRIDE,
        }
    }
}

/// One light, prepared for a frame.
#[derive(Debug)]
pub(crate) struct Lit {
    pub(crate) source: Source,
    /// Point: radiant intensity; sun: irradiance.
    pub(crate) power: Rgb,
    /// `e^{Eᵢ}` per Gaussian and channel.
    pub(crate) center: Vec<Rgb>,
    /// The integrated path's terms: pairs, their lists, `C_sv`.
    pub(crate) pairs: PairTerms,
    /// A point light's view of the Gaussians: the segments that end at it (shadow rays
    /// from surfaces and centres) find their Gaussians from it.
    pub(crate) view: Option<LightView>,
}

/// A scene prepared for paper B: the Gaussians merged, the homogeneous part summed, the
/// per-frame exponents of every light.
#[derive(Debug)]
pub struct Prepared<'a> {
    pub(crate) scene: &'a Scene,
    analytic: &'a Analytic,
    pub(crate) options: PaperBOptions,
    pub(crate) set: GaussianSet,
    /// Per Gaussian: the noise of its medium and its radius.
    pub(crate) noise: Vec<Option<&'a Noise>>,
    pub(crate) radius: Vec<f64>,
    pub(crate) beta0: Rgb,
    pub(crate) sigma_s0: Rgb,
    /// Whether a Gaussian medium's background fills space (it hides every sun).
    pub(crate) background: bool,
    pub(crate) lights: Vec<Lit>,
    /// The environment's terms (none for a black environment).
    pub(crate) env: Option<GaussianEnv>,
}

impl<'a> Prepared<'a> {
    /// Prepares the scene; an error when a medium is not a Gaussian sum.
    pub fn new(
        scene: &'a Scene,
        analytic: &'a Analytic,
        options: PaperBOptions,
    ) -> Result<Prepared<'a>, String> {
        let mut media = Vec::new();
        for m in &scene.hetero {
            let HeteroMedium::Gaussians(g) = m else {
                return Err(format!(
                    "paper B's renderer lights Gaussian media only, not {} (use --reference)",
                    m.name()
                ));
            };
            media.push(&**g);
        }
        let mut beta0 = scene.medium.sigma_t;
        let mut sigma_s0 = scene.medium.sigma_s();
        let mut bg = 0.0;
        for m in &media {
            let b = m.medium.beta0();
            bg += b;
            for c in 0..3 {
                beta0[c] += b;
                sigma_s0[c] += m.medium.albedo * b;
            }
        }
        let plain: Vec<_> = media.iter().map(|m| &m.medium).collect();
        let set = GaussianSet::new(&plain);
        let (mut noise, mut radius) = (Vec::new(), Vec::new());
        for m in &media {
            for g in m.medium.gaussians() {
                if m.medium.sigma_t * g.weight > 0.0 {
                    noise.push(m.noise.as_ref());
                    radius.push(g.radius);
                }
            }
        }
        let eye = scene.camera.eye;
        // Each centre's depth towards the eye, shared by every light and the environment.
        let n = set.blobs().len();
        let to_eye: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|i| set.depth_to_point(i, eye))
            .collect();
        let lights: Vec<Lit> = scene
            .lights
            .iter()
            .map(|l| {
                let (source, power) = match l {
                    Light::Point {
                        position,
                        intensity,
                    } => (Source::Point(*position), *intensity),
                    Light::Sun {
                        direction,
                        radiance,
                        angle,
                    } => (
                        Source::Sun(*direction),
                        Light::sun_irradiance(*radiance, *angle),
                    ),
                };
                let view = match source {
                    Source::Point(s) => Some(LightView::new(set.blobs(), s)),
                    Source::Sun(_) => None,
                };
                // GaussianSet::center_exponents, in parallel and sharing `to_eye`.
                let g: Vec<f64> = (0..n)
                    .into_par_iter()
                    .map(|i| {
                        let to_light = match (&view, source.path(set.blobs()[i].center)) {
                            (Some(v), Some((d, len))) => {
                                v.cull_depth(set.blobs(), set.blobs()[i].center, d, len, Some(i))
                                    .0
                            }
                            _ => set.depth_to_light(i, source),
                        };
                        -(to_light + to_eye[i])
                    })
                    .collect();
                let center = center_factors(&set, source, eye, &g, beta0, bg > 0.0);
                let fog = sigma_s0.iter().any(|&x| x > 0.0);
                let pairs = pair_terms(&set, source, eye, &g, bg > 0.0, fog, &options);
                Lit {
                    source,
                    power,
                    center,
                    pairs,
                    view,
                }
            })
            .collect();
        let lit = lit_at_centres(&set, &lights);
        let env = GaussianEnv::new(
            scene,
            analytic,
            &set,
            &to_eye,
            beta0,
            bg,
            &analytic.exponents(),
            &lit,
            options.target,
        );
        Ok(Prepared {
            scene,
            analytic,
            options,
            set,
            noise,
            radius,
            beta0,
            sigma_s0,
            background: bg > 0.0,
            lights,
            env,
        })
    }

    /// The number of Gaussians lit.
    pub fn gaussian_count(&self) -> usize {
        self.set.blobs().len()
    }

    /// How many (light, Gaussian) pairs are integrated along the ray, of how many.
    pub fn integrated_pairs(&self) -> (usize, usize) {
        let n = self.lights.iter().map(|l| l.pairs.integrated.len()).sum();
        let k = self
            .lights
            .iter()
            .flat_map(|l| &l.pairs.integrated)
            .filter(|e| e.is_some())
            .count();
        (k, n)
    }

    /// How many Gaussians took the others' shadow on the sky exactly (0 without an
    /// environment; [`gaussian_env`]).
    pub fn exact_sky(&self) -> usize {
        self.env.as_ref().map_or(0, |e| e.exact_sky)
    }

    /// With an environment, the mean over the Gaussians of the others' average depth
    /// around each, to hold against [`gaussian_env::VALID_MEAN_DEPTH`].
    pub fn env_mean_depth(&self) -> Option<f64> {
        self.env.as_ref().map(|e| e.mean_depth_around)
    }

    /// Where this frame's picture may be wrong, one line each (the CLI logs them, the
    /// viewer shows them): pairs whose lists had no room for every Gaussian whose shadow
    /// crosses them, and Gaussians too dense for the environment's terms
    /// ([`gaussian_env::VALID_MEAN_DEPTH`]).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let left = self.left_at_centres();
        if left.shadows > 0 {
            out.push(format!(
                "paper B: {} Gaussian shadows across {} integrated pairs taken at the pairs' \
                 centres (more than {MAX_EXACT} a pair; the largest errs by {:.1} % there): \
                 the picture may be off where they fall partly across a lit Gaussian; \
                 --reference renders it exactly",
                left.shadows,
                left.pairs,
                100.0 * left.largest
            ));
        }
        if let Some(m) = self.env_mean_depth()
            && m > gaussian_env::VALID_MEAN_DEPTH
        {
            out.push(format!(
                "paper B: the Gaussians are dense for the environment's light (the others' \
                 average optical depth around each is {}, above {}): such clouds \
                 measured 2–5 % off under a sky (5–6 % with --sky-shadow mean and on the \
                 GPU), their own glow 14–44 % where each Gaussian's peak depth is 0.2–1; \
                 --reference renders it exactly",
                haze_core::number::rounded(m, 2),
                gaussian_env::VALID_MEAN_DEPTH
            ));
        }
        out
    }

    /// The shadowers the integrated pairs' lists had no room for, over every light.
    pub fn left_at_centres(&self) -> LeftAtCentres {
        let mut all = LeftAtCentres::default();
        for l in &self.lights {
            all.pairs += l.pairs.left.pairs;
            all.shadows += l.pairs.left.shadows;
            all.largest = all.largest.max(l.pairs.left.largest);
        }
        all
    }

    /// The integrated pairs: `(light index, Gaussian index, bound)`.
    pub fn integrated_list(&self) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for (l, lit) in self.lights.iter().enumerate() {
            for (i, e) in lit.pairs.integrated.iter().enumerate() {
                if e.is_some() {
                    out.push((l, i, bound(&self.set.blobs()[i], lit.source)));
                }
            }
        }
        out
    }

    /// Gaussian `i`'s airlight of light `l` integrated along the ray
    /// ([`haze_gaussians::integrated::integrated`], the hosts per node) times the pair's
    /// exponent `e`, per unit power, without noise (the caller scales it).
    fn integrated_pair(
        &self,
        lim: &Limits,
        l: &Lit,
        i: usize,
        e: f64,
        dir: Vec3,
        t_end: f64,
    ) -> Rgb {
        let eye = self.scene.camera.eye;
        let b = &self.set.blobs()[i];
        let exact = &l.pairs.pair_exact[i];
        debug_assert!(exact.len() <= MAX_EXACT, "pair_terms caps the lists");
        // Each listed Gaussian's depth along the camera ray, its ray-constant parts once;
        // lines where it adds less than LIST_DELTA skipped.
        let mut along = [line::AlongRay::default(); MAX_EXACT];
        let mut far = [0.0; MAX_EXACT];
        for ((a, f), &k) in along.iter_mut().zip(&mut far).zip(exact) {
            let h = &self.set.blobs()[k];
            *f = line::far_for(h.c, h.a, LIST_DELTA);
            *a = line::AlongRay::within(h.c, h.a, h.center, eye, dir, *f);
        }
        let others = |t: f64| match l.source {
            Source::Point(sp) if !exact.is_empty() => {
                let x = axpy(eye, t, dir);
                let ls = sub(sp, x);
                let d = norm(ls);
                let mut depth = 0.0;
                for ((&k, a), &f) in exact.iter().zip(&along).zip(&far) {
                    let h = &self.set.blobs()[k];
                    depth += a.to(t);
                    if d > 0.0 {
                        let u = ls.map(|c| c / d);
                        depth += line::gaussian_within(h.c, h.a, h.center, x, u, d, f);
                    }
                }
                -depth
            }
            _ => 0.0,
        };
        let li = integrated(b, eye, dir, t_end, l.source, lim.r_min, self.beta0, &others);
        li.map(|x| e * x)
    }

    /// Radiance along the camera ray of unit direction `dir` (a surface's shadow on the sky
    /// taken exactly at the ray's end).
    pub fn radiance(&self, lim: &Limits, dir: Vec3) -> Rgb {
        self.radiance_with(lim, dir, &mut PairMode::Exact, None)
    }

    /// [`Prepared::radiance`], the integrated pairs and the homogeneous term's hosts taken
    /// as `mode` says ([`reuse`]), and the surface's shadow on the sky from `table` (its
    /// pixel's entry, where the ray ends on that entry's surface; [`sky_grid`]) or exactly.
    pub(crate) fn radiance_with(
        &self,
        lim: &Limits,
        dir: Vec3,
        mode: &mut PairMode<'_>,
        table: Option<(&sky_grid::SkyTable, usize, usize)>,
    ) -> Rgb {
        let scene = self.scene;
        let cam = &scene.camera;
        let eye = cam.eye;
        let frame = [cam.right(), cam.up(), cam.forward()];
        let hit = scene.intersect(eye, dir, 0.0, scene.environment_distance);
        let t_end = hit.map_or(scene.environment_distance, |h| h.t);
        mode.hit(hit.map(|h| h.surface), t_end);
        let n = self.set.blobs().len();
        let mut out = [0.0; 3];
        // The Gaussians along the ray: Tᵢ(v,p) and their airlight.
        let mut tau = 0.0;
        self.set.on_segment(eye, dir, t_end, |i| {
            let b = &self.set.blobs()[i];
            // Tᵢ(v, bᵢʳ) and, without noise, Tᵢ(v, p) from one line's constant parts.
            let line = line::AlongRay::new(b.c, b.a, b.center, eye, dir);
            let t_r = dot(sub(b.center, eye), dir).clamp(0.0, t_end);
            let proj = (t_r, line.to(t_r));
            let along = match self.noise[i] {
                Some(n) => n.perturb(
                    dir,
                    axpy(eye, proj.0, dir),
                    self.radius[i],
                    norm(sub(b.center, eye)),
                    frame,
                ),
                None => dir,
            };
            let vp = if along == dir {
                line.to(t_end)
            } else {
                line::gaussian(b.c, b.a, b.center, eye, along, t_end)
            };
            tau += vp;
            // An integrated pair with noise is scaled as `Tᵢ(v,p) = vp` is.
            let noise = if along == dir {
                1.0
            } else {
                let straight = line.to(t_end);
                if straight > 0.0 { vp / straight } else { 0.0 }
            };
            for (k, l) in self.lights.iter().enumerate() {
                if let Some(e) = l.pairs.integrated[i] {
                    let id = reuse::pair_id(n, k, i);
                    // The unattenuated integral, once a pair and ray whoever asks first.
                    let u = std::cell::OnceCell::new();
                    let unatt =
                        || *u.get_or_init(|| unattenuated(b, eye, dir, t_end, l.source, lim.r_min));
                    let base = || [unatt(); 3];
                    let scale = || [0, 1, 2].map(|c| noise * l.power[c] * unatt());
                    // The far end of the pair's support on any ray.
                    let reach = norm(sub(b.center, eye)) + SUPPORT / b.a;
                    let li = match mode.ratio(id, k, reach, scale) {
                        Some(r) => {
                            let f = base();
                            let li = [0, 1, 2].map(|c| f[c] * r[c]);
                            let add = [0, 1, 2].map(|c| noise * l.power[c] * li[c]);
                            mode.record_reused(id, r, add);
                            li
                        }
                        None => {
                            let li = self.integrated_pair(lim, l, i, e, dir, t_end);
                            let add = [0, 1, 2].map(|c| noise * l.power[c] * li[c]);
                            mode.record(id, li, base, add);
                            li
                        }
                    };
                    for (c, o) in out.iter_mut().enumerate() {
                        *o += noise * l.power[c] * li[c];
                    }
                    continue;
                }
                let base = factored(b, eye, dir, proj, vp, l.source, lim.r_min, 0.0);
                for (c, o) in out.iter_mut().enumerate() {
                    *o += l.power[c] * base * l.center[i][c];
                }
            }
            if let Some(env) = &self.env
                && vp > 0.0
            {
                let own = proj.1 + gaussian_mean_depth(b.c, b.a, b.center, axpy(eye, proj.0, dir));
                let f = (-own).exp() * vp;
                for (c, o) in out.iter_mut().enumerate() {
                    *o += env.center[i][c] * f;
                }
            }
        });
        let homogeneous = self.homogeneous_terms(lim, mode, dir, t_end);
        for (o, a) in out.iter_mut().zip(homogeneous) {
            *o += a;
        }
        let behind = match hit {
            Some(h) => {
                let sky = table.and_then(|(t, x, y)| t.at(x, y, h.surface));
                self.surface(lim, dir, h, sky)
            }
            None if t_end.is_infinite() && self.beta0.iter().all(|&b| b > 0.0) => [0.0; 3],
            None => background(scene, dir),
        };
        for c in 0..3 {
            if behind[c] != 0.0 {
                let t = if self.beta0[c] > 0.0 {
                    self.beta0[c] * t_end
                } else {
                    0.0
                } + tau;
                out[c] += (-t).exp() * behind[c];
            }
        }
        out
    }

    /// The homogeneous term of every light along the ray to `t_end`.
    fn homogeneous_terms(
        &self,
        lim: &Limits,
        mode: &mut PairMode<'_>,
        dir: Vec3,
        t_end: f64,
    ) -> Rgb {
        let mut out = [0.0; 3];
        for (k, l) in self.lights.iter().enumerate() {
            match l.source {
                Source::Point(s) => {
                    let add = self.homogeneous(lim, mode, k, dir, t_end, s);
                    for (o, a) in out.iter_mut().zip(add) {
                        *o += a;
                    }
                }
                Source::Sun(_) if !self.background => {
                    let ss = self.scene.medium.sigma_s();
                    for c in 0..3 {
                        out[c] +=
                            l.pairs.c_sv * airlight::sun(t_end, l.power[c], self.beta0[c], ss[c]);
                    }
                }
                Source::Sun(_) => {}
            }
        }
        out
    }

    /// Point light `k`'s homogeneous term along the ray (paper C's airlight times `C_sv`,
    /// the hosts' share of it per ray as `mode` says).
    fn homogeneous(
        &self,
        lim: &Limits,
        mode: &mut PairMode<'_>,
        k: usize,
        dir: Vec3,
        t_end: f64,
        s: Vec3,
    ) -> Rgb {
        let l = &self.lights[k];
        let eye = self.scene.camera.eye;
        // The term's key and ratio, and whether it was integrated here.
        let mut taken = None;
        let c_sv = if l.pairs.exact.is_empty() {
            l.pairs.c_sv
        } else {
            let id = reuse::host_id(self.set.blobs().len(), self.lights.len(), k);
            let (ratio, exact) = match mode.ratio(id, k, f64::INFINITY, || [f64::INFINITY; 3]) {
                Some(r) => (r[0], false),
                None => {
                    let hosts = &l.pairs.exact_blobs;
                    let b0 = self.beta0.iter().sum::<f64>() / 3.0;
                    (
                        host_ratio(hosts, eye, dir, t_end, s, lim.r_min, b0, LIST_DELTA),
                        true,
                    )
                }
            };
            taken = Some((id, ratio, exact));
            l.pairs.c_sv_rest * ratio
        };
        let s = effective_light(eye, dir, s, lim);
        let add = [0, 1, 2].map(|c| {
            if l.power[c] > 0.0 && self.sigma_s0[c] > 0.0 {
                let h = &self.analytic.h;
                let a =
                    airlight::point(h, eye, dir, t_end, s, 1.0, self.beta0[c], self.sigma_s0[c]);
                l.power[c] * c_sv * a
            } else {
                0.0
            }
        });
        match taken {
            Some((id, r, true)) => mode.record(id, [r; 3], || [1.0; 3], add),
            Some((id, r, false)) => mode.record_reused(id, [r; 3], add),
            None => {}
        }
        add
    }

    /// Radiance leaving the surface hit towards the eye (module docs), `sky` its shadow on
    /// the sky from the table (`None`: taken here).
    fn surface(&self, lim: &Limits, dir: Vec3, hit: crate::scene::Hit, sky: Option<Rgb>) -> Rgb {
        let scene = self.scene;
        let m = &scene.surfaces[hit.surface].material;
        let (p, n) = (hit.point, hit.normal);
        let r = reflect(scale(dir, -1.0), n);
        let p_off = axpy(p, 1e-9 * (1.0 + norm(p)), n);
        let mut out = match &self.env {
            Some(env) => {
                let sky = match sky {
                    Some(r) => r,
                    None if self.options.surface_sky => {
                        env.surface_sky(scene, &self.set, p, n, self.options.target)
                    }
                    None => [1.0; 3],
                };
                env.surface(p, n, r, m, self.options.surface_scattering, sky)
            }
            None => [0.0; 3],
        };
        for l in &self.lights {
            match l.source {
                Source::Point(position) => {
                    let s = light_off_point(p, n, position, lim.r_min);
                    let v = sub(s, p);
                    let d = norm(v);
                    let u = scale(v, 1.0 / d);
                    let lit = dot(n, u) > 0.0 && scene.visible(p_off, s);
                    let (tg, sg) = match &l.view {
                        Some(view) if s == position => {
                            view.cull_depth(self.set.blobs(), p, u, d, None)
                        }
                        _ => self.set.cull_depth(p, u, d, None),
                    };
                    for (c, o) in out.iter_mut().enumerate() {
                        if l.power[c] <= 0.0 {
                            continue;
                        }
                        let beta = self.beta0[c] + tg / d;
                        let mut v = 0.0;
                        if lit {
                            v += (-beta * d).exp() / (d * d) * m.brdf(n, r, u, c);
                        }
                        let ss = self.sigma_s0[c] + sg / d;
                        if self.options.surface_scattering && ss > 0.0 {
                            v += self.analytic.surface(p, n, r, s, beta, ss, m, c);
                        }
                        *o += l.power[c] * v;
                    }
                }
                Source::Sun(sun) => {
                    let lit = dot(n, sun) > 0.0
                        && scene.intersect(p_off, sun, 0.0, f64::INFINITY).is_none()
                        && !self.background;
                    let t = if lit {
                        self.set.cull_depth(p, sun, f64::INFINITY, None).0
                    } else {
                        0.0
                    };
                    let ss = scene.medium.sigma_s();
                    for c in 0..3 {
                        if lit {
                            out[c] += l.power[c] * (-t).exp() * m.brdf(n, r, sun, c);
                        }
                        // Paper C's in-scattering of the homogeneous media onto the
                        // surface, as in [`crate::render`].
                        if self.options.surface_scattering && ss[c] > 0.0 {
                            let lobes = m.diffuse[c]
                                + m.specular[c] * (m.shininess + 2.0) / (m.shininess + 1.0);
                            let st = scene.medium.sigma_t[c];
                            let path = st * attenuated_length(st, f64::INFINITY);
                            out[c] +=
                                scene.medium.albedo[c] * l.power[c] / (4.0 * PI) * path * lobes;
                        }
                    }
                }
            }
        }
        out
    }

    /// What it is, for summaries.
    pub fn name(&self) -> String {
        let (k, n) = self.integrated_pairs();
        let sky = match &self.env {
            Some(env) => format!(
                ", {} of {} gaussians' shadows on the sky taken exactly{}",
                env.exact_sky,
                self.gaussian_count(),
                if self.options.surface_sky && !self.scene.surfaces.is_empty() {
                    ", the surfaces' where their bound asks"
                } else {
                    ""
                }
            ),
            None => String::new(),
        };
        let reuse = if self.options.reuse > 1 && k > 0 {
            format!(
                ", reused from a {}-pixel grid where smooth",
                self.options.reuse
            )
        } else {
            String::new()
        };
        format!(
            "paper B, {} gaussians, {k} of {n} light–gaussian pairs integrated along the ray \
             (at most {} gaussians exact a pair{reuse}){sky} ({})",
            self.gaussian_count(),
            self.options.max_exact.min(MAX_EXACT),
            self.analytic.name()
        )
    }
}

/// Each centre's single-scattered light from the point lights and suns, summed over the
/// channels: `αᵢ·Σₗ Φₗ·e^{Eᵢ}/(4πd²)` (a sun: `1/4π` for `1/4πd²`), `d` the light's
/// distance from the centre, at least the Gaussian's radius `1/a`. What the environment's
/// share of a Gaussian's light is weighed against ([`GaussianEnv::new`]).
fn lit_at_centres(set: &GaussianSet, lights: &[Lit]) -> Vec<f64> {
    set.blobs()
        .iter()
        .enumerate()
        .map(|(i, b)| {
            lights
                .iter()
                .map(|l| {
                    let r2 = match l.source {
                        Source::Point(s) => {
                            let d = norm(sub(s, b.center)).max(1.0 / b.a);
                            d * d
                        }
                        Source::Sun(_) => 1.0,
                    };
                    let e: f64 = (0..3).map(|c| l.power[c] * l.center[i][c]).sum();
                    b.albedo * e / (4.0 * PI * r2)
                })
                .sum()
        })
        .collect()
}

/// `e^{Eᵢ}` per Gaussian and channel: the Gaussians' exponents `g` plus the homogeneous
/// part `β0` along `s → bᵢ → v` (a sun: along `bᵢ → v`, and hidden by a `background`).
fn center_factors(
    set: &GaussianSet,
    source: Source,
    eye: Vec3,
    g: &[f64],
    beta0: Rgb,
    background: bool,
) -> Vec<Rgb> {
    set.blobs()
        .iter()
        .zip(g)
        .map(|(b, e)| {
            let to_eye = norm(sub(eye, b.center));
            [0, 1, 2].map(|c| {
                let path = match source {
                    Source::Point(s) => beta0[c] * (norm(sub(s, b.center)) + to_eye),
                    Source::Sun(_) if background => f64::INFINITY,
                    Source::Sun(_) => beta0[c] * to_eye,
                };
                (e - path).exp()
            })
        })
        .collect()
}

/// The march step that resolves every Gaussian medium of the scene: a fifth of the
/// smallest radius (midpoint error `~(h/r)²/24 < 2·10⁻³` across a Gaussian), at most the
/// march's default 0.02.
pub fn march_step(scene: &Scene) -> f64 {
    let mut step = crate::march::MarchOptions::default().step;
    for g in scene.gaussian_media() {
        for x in g.medium.gaussians() {
            step = step.min(0.2 * x.radius);
        }
    }
    step
}

/// Gauss–Legendre nodes in `cos θ` of the reference's environment rule
/// ([`crate::march::env_smoke::Direct`], `2·8²` directions per march sample and surface point).
pub const REFERENCE_THETA: usize = 8;

/// The reference's march for a scene of Gaussian media: steps from the Gaussians' radii,
/// the lights' distances and the homogeneous extinction
/// ([`crate::march::steps::GaussianSteps`]; [`march_step`] where another medium is
/// present), the environment integrated over `2θ²` directions at every sample and surface point
/// ([`crate::march::env_smoke::Direct`]; none for a black environment).
pub fn reference_options(scene: &Scene, theta: usize) -> crate::march::MarchOptions {
    use crate::march::env_smoke::{Direct, EnvLight};
    let mut opt = crate::march::MarchOptions {
        step: march_step(scene),
        steps: crate::march::steps::GaussianSteps::new(scene).map(std::sync::Arc::new),
        ..Default::default()
    };
    if !matches!(scene.environment, crate::scene::Environment::Black) {
        let d = std::sync::Arc::new(Direct::new(theta));
        opt.env = EnvLight::Direct(d.clone());
        opt.env_surfaces = Some(d);
    }
    opt
}

/// Renders the scene's camera image with paper B; `progress` hears the rows finished.
/// With [`PaperBOptions::reuse`] above 1 and pairs to integrate, through [`reuse::render`];
/// the surfaces' shadow on the sky from [`sky_grid::sky_table`].
pub fn render(prep: &Prepared<'_>, lim: &Limits, progress: &(dyn Fn(usize) + Sync)) -> Image {
    let cam = &prep.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let lim = Limits {
        gamma_min: lim.gamma_min.max(0.5 * cam.pixel_radius()),
        ..*lim
    };
    let sky = sky_grid::sky_table(prep, &lim, prep.options.sky_stride);
    if prep.options.reuse > 1 && prep.integrated_pairs().0 > 0 {
        return reuse::render(prep, &lim, sky.as_ref(), progress);
    }
    Image::by_rows(w, h, progress, |x, y| {
        let table = sky.as_ref().map(|t| (t, x, y));
        prep.radiance_with(&lim, cam.pixel_ray(x, y), &mut PairMode::Exact, table)
    })
}
