//! The integrated pairs reused across the screen (CPU).
//!
//! An integrated pair's airlight `Lᵢ` ([`crate::paper_b`]'s module docs) costs every ray
//! that crosses the Gaussian a dozen quadrature nodes, each with the pair's list of
//! Gaussians exact: 15–40× the closed form's frame where every pair is flagged. Most of
//! that cost buys the attenuation along the light's and the eye's paths, which varies on
//! the scale of the Gaussians involved — the pair's own and its list's — not of a pixel.
//!
//! So the renderer integrates exactly on a coarse grid of pixels, every [`DEFAULT_STRIDE`]
//! pixels (and the last row and column), and records each crossed pair's ratio `ρ = Lᵢ/Uᵢ`
//! per channel, where `Uᵢ` is the same chord integral without any attenuation
//! ([`haze_gaussians::integrated::unattenuated`]: one Faddeeva function in closed form
//! where the ray holds the whole chord).
//! `ρ` is then the attenuation of the pair's light averaged along the ray, weighted by
//! `βᵢ/d²`, while `Uᵢ`, computed at every pixel, carries the light's `1/d²` and the
//! Gaussian's footprint. (Against paper B's closed form `L̂ᵢ` instead, `ρ` changed by
//! 5–20 % from one grid pixel to the next: the closed form samples the light's `1/d²` at
//! one point, which moves across the Gaussian.) The homogeneous term's ratio
//! `C_sv(ray)/C_sv,rest` ([`haze_gaussians::integrated::host_ratio`]) is recorded and
//! reused likewise.
//!
//! The grids are nested ([`strides`]): each finer grid, of half the stride, takes a
//! term's `ρ` at its new pixels from the coarser one where that is safe (below), integrates
//! it elsewhere, and records both, until the last pass, which covers every pixel. Where
//! the attenuation is smooth over a coarse block the term is integrated only at its
//! corners; where a shadow's edge or a small Gaussian crosses it, the finer grids close
//! in on it, so only the pixels within a block of the finest grid around such a feature
//! integrate everything. (Bilinear interpolation reproduces a bilinear function, so a
//! ratio taken from the coarse grid and interpolated again at a finer one is the same as
//! taken once.)
//!
//! A pixel off a grid takes a term's `ρ` bilinearly from the four grid pixels around it
//! where that is safe, and integrates the term itself elsewhere:
//!
//! * all four corners recorded the term (a corner outside the Gaussian's support, or
//!   with `Uᵢ = 0`, records nothing) — or, at a Gaussian's edge where some did not, the
//!   term is faint: the pixel's `Uᵢ` times the largest present ratio is at most
//!   [`PIXEL_TOLERANCE`] of the darkest corner's radiance, and the present corners'
//!   mean ratio serves;
//! * the interpolation's error, estimated from the grid's second differences beside the
//!   block (`Δ²ρ = h²ρ''`; bilinear interpolation errs by up to `h²|ρ''|/8` along each
//!   axis, taken twice, [`CURVATURE`], because `ρ''` at the grid pixels underestimates
//!   it between them — for a Gaussian bump of radius `h` centred between two grid pixels
//!   by 2.6×), or the corners' range where the grid has no neighbour, is at most
//!   [`MAX_RATIO_ERROR`] of `ρ`, and times the term's share of the corners' radiance at
//!   most [`PIXEL_TOLERANCE`] — a term that adds little to a pixel may be reused where
//!   its ratio bends more;
//! * the term's Gaussians — the pair's own and its list's — each subtend at least
//!   [`MIN_SCALE`] blocks of radius seen from the eye, so that a shadow or a Gaussian
//!   narrower than the grid cannot pass between the corners unseen;
//! * no point light's image lies within a block of it: there the integral's `∫dt/d²` has
//!   its `1/h` peak, which no corner sees (every term of that light is integrated);
//! * the pixel's ray ends on the same surface as all four corners' (or on none), or the
//!   term's Gaussian lies wholly nearer than every one of their ends (its distance from
//!   the eye plus [`SUPPORT`](haze_gaussians::integrated::SUPPORT) radii): a surface's silhouette cuts the ray's chord. The
//!   homogeneous term runs to the ray's end, so it is integrated there.
//!
//! The surfaces' exact shadow on the sky comes from its own grid ([`super::sky_grid`]).
//!
//! The constants were chosen on the lamp scenes and checked on the bundled noisy scene
//! (BENCHMARKS "The integrated pairs reused across the screen"). Suns have no image; a pair of a sun reuses the same
//! way. The GPU integrates every pixel (`crate::gpu::paper_b::options` sets a stride of 1).

use super::Prepared;
use super::sky_grid::SkyTable;
use crate::paper_c::airlight::Limits;
use crate::render::Image;
use crate::scene::{Light, Rgb};
use crate::vec3::{norm, sub};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The default stride of the grid integrated exactly, in pixels.
pub const DEFAULT_STRIDE: usize = 4;

/// The most a reused term's estimated interpolation error, times its share of the pixel,
/// may be (relative).
pub const PIXEL_TOLERANCE: f64 = 0.005;

/// The interpolation's error per second difference along an axis (bilinear
/// interpolation's `1/8`, doubled: module docs).
pub const CURVATURE: f64 = 0.25;

/// The largest interpolation error of a ratio, relative, whatever its share of the pixel.
pub const MAX_RATIO_ERROR: f64 = 0.2;

/// The smallest radius, in blocks seen from the eye, of a Gaussian that a reused pair
/// involves.
pub const MIN_SCALE: f64 = 0.75;

/// Pair `(light, i)`'s key among `n` Gaussians.
pub(crate) fn pair_id(n: usize, light: usize, i: usize) -> usize {
    light * n + i
}

/// The homogeneous term's key of `light` of `lights`, after every pair's.
pub(crate) fn host_id(n: usize, lights: usize, light: usize) -> usize {
    lights * n + light
}

/// What a grid pixel recorded: its radiance, the surface its ray ends on and each
/// integrated term's ratio (module docs), sorted by key.
#[derive(Clone, Debug, Default)]
pub(crate) struct Sample {
    radiance: [f32; 3],
    surface: Option<usize>,
    /// Where its ray ends.
    t_end: f64,
    ratios: Vec<Entry>,
}

/// A term's record at a grid pixel.
#[derive(Clone, Copy, Debug)]
struct Entry {
    id: usize,
    /// The integrated value over its unattenuated one (a pair) or the host ratio (the
    /// homogeneous term), per channel.
    ratio: [f32; 3],
    /// What the term added to the pixel's radiance, per channel.
    added: [f32; 3],
}

/// The grid pixels around a pixel and what it may take from them.
pub(crate) struct Corners<'r> {
    /// The grid's samples, `nx` a row.
    grid: &'r [Sample],
    nx: usize,
    /// The block: grid pixels `(kx, ky)` to `(kx1, ky1)`.
    k: (usize, usize),
    k1: (usize, usize),
    /// Bilinear weights of the block's corners, in [`Corners::corners`]' order.
    weights: [f64; 4],
    /// Per key: whether the pair's Gaussians are large enough to reuse ([`reusable`]).
    reusable: &'r [bool],
    /// Bit `l`: light `l`'s image lies near this block (its terms integrated here); lights
    /// past 63 are always integrated.
    near_light: u64,
}

/// How [`Prepared::radiance_with`] takes the integrated terms.
pub(crate) enum PairMode<'r> {
    /// Integrated at every pixel.
    Exact,
    /// Integrated, and each term's ratio recorded.
    Record(&'r mut Sample),
    /// Interpolated from the corners where safe (`cut`: where the ray ends on another
    /// surface than a corner's, the nearest of their ends, ∞ where they all end on the
    /// same; a term whose support may reach it is integrated), counted; with `record`,
    /// every term's ratio — integrated or interpolated — recorded for the next finer grid.
    Reuse {
        corners: &'r Corners<'r>,
        cut: f64,
        count: &'r mut ReuseCount,
        record: Option<&'r mut Sample>,
    },
}

impl PairMode<'_> {
    /// The surface the pixel's ray ends on, and where.
    pub(crate) fn hit(&mut self, surface: Option<usize>, t_end: f64) {
        match self {
            PairMode::Exact => {}
            PairMode::Record(s) => (s.surface, s.t_end) = (surface, t_end),
            PairMode::Reuse {
                corners,
                cut,
                record,
                ..
            } => {
                let ends = corners.corners();
                *cut = if ends.iter().any(|s| s.surface != surface) {
                    ends.iter().map(|s| s.t_end).fold(t_end, f64::min)
                } else {
                    f64::INFINITY
                };
                if let Some(s) = record {
                    (s.surface, s.t_end) = (surface, t_end);
                }
            }
        }
    }

    /// Term `id`'s (of light `light`) ratio (module docs), interpolated; `None`: integrate
    /// it. `reach`: how far along the ray the term's support may extend (∞: to the ray's
    /// end).
    pub(crate) fn ratio(
        &mut self,
        id: usize,
        light: usize,
        reach: f64,
        scale: impl FnOnce() -> Rgb,
    ) -> Option<[f64; 3]> {
        match self {
            PairMode::Reuse {
                corners,
                cut,
                count,
                ..
            } => {
                count.terms += 1;
                let r = if reach > *cut {
                    None
                } else {
                    corners.ratio(id, light, scale)
                };
                count.reused += usize::from(r.is_some());
                r
            }
            _ => None,
        }
    }

    /// The sample this pixel records into, if it records.
    fn recording(&mut self) -> Option<&mut Sample> {
        match self {
            PairMode::Record(s) => Some(s),
            PairMode::Reuse {
                record: Some(s), ..
            } => Some(s),
            _ => None,
        }
    }

    /// Records term `id`'s integrated value `exact` over `base` (its unattenuated value;
    /// 1 for a ratio already) and what it `added` to the pixel (when recording; a term
    /// whose base is 0 in a channel records nothing).
    pub(crate) fn record(&mut self, id: usize, exact: Rgb, base: impl FnOnce() -> Rgb, added: Rgb) {
        if let Some(s) = self.recording() {
            let f = base();
            let mut r = [0.0f32; 3];
            for c in 0..3 {
                let q = exact[c] / f[c];
                if !(f[c] > 0.0 && q.is_finite()) {
                    return;
                }
                r[c] = q as f32;
            }
            s.ratios.push(Entry {
                id,
                ratio: r,
                added: added.map(|a| a as f32),
            });
        }
    }

    /// Records term `id`'s interpolated `ratio` and what it `added` to the pixel (when
    /// recording for a finer grid).
    pub(crate) fn record_reused(&mut self, id: usize, ratio: [f64; 3], added: Rgb) {
        if let Some(s) = self.recording() {
            s.ratios.push(Entry {
                id,
                ratio: ratio.map(|r| r as f32),
                added: added.map(|a| a as f32),
            });
        }
    }
}

impl Corners<'_> {
    /// The block's four grid pixels.
    fn corners(&self) -> [&Sample; 4] {
        let (x0, y0, x1, y1) = (self.k.0, self.k.1, self.k1.0, self.k1.1);
        [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| &self.grid[y * self.nx + x])
    }

    fn sample(&self, x: isize, y: isize) -> Option<&Sample> {
        let ny = self.grid.len() / self.nx;
        if x < 0 || y < 0 || x as usize >= self.nx || y as usize >= ny {
            return None;
        }
        Some(&self.grid[y as usize * self.nx + x as usize])
    }

    /// Term `id`'s ratio at grid pixel `(x, y)` and its share of the pixel, per channel.
    fn at(&self, id: usize, x: isize, y: isize) -> Option<([f64; 3], [f64; 3])> {
        let s = self.sample(x, y)?;
        let k = s.ratios.binary_search_by_key(&id, |e| e.id).ok()?;
        let e = &s.ratios[k];
        let share = |c: usize| {
            let r = f64::from(s.radiance[c]);
            if r > 0.0 {
                f64::from(e.added[c]) / r
            } else {
                1.0
            }
        };
        Some((e.ratio.map(f64::from), [0, 1, 2].map(share)))
    }

    /// The interpolated ratio of term `id` (of light `light`), `None` where it is not safe
    /// (module docs).
    fn ratio(&self, id: usize, light: usize, scale: impl FnOnce() -> Rgb) -> Option<[f64; 3]> {
        if light >= 64 || self.near_light & (1 << light) != 0 || !self.reusable[id] {
            return None;
        }
        let (x0, y0) = (self.k.0 as isize, self.k.1 as isize);
        let (x1, y1) = (self.k1.0 as isize, self.k1.1 as isize);
        let found = [
            self.at(id, x0, y0),
            self.at(id, x1, y0),
            self.at(id, x0, y1),
            self.at(id, x1, y1),
        ];
        if found.iter().any(Option::is_none) {
            return self.faint(&found, scale);
        }
        let corners = found.map(|e| e.unwrap_or_default());
        let c = corners.map(|e| e.0);
        let ratio = |x: isize, y: isize| self.at(id, x, y).map(|e| e.0);
        // Along x, each of the block's rows: its second differences at the block's two
        // corners (the grid pixel beyond each as the third point); along y, each column.
        let rows = [
            (c[0], c[1], ratio(x0 - 1, y0), ratio(x1 + 1, y0)),
            (c[2], c[3], ratio(x0 - 1, y1), ratio(x1 + 1, y1)),
        ];
        let columns = [
            (c[0], c[2], ratio(x0, y0 - 1), ratio(x0, y1 + 1)),
            (c[1], c[3], ratio(x1, y0 - 1), ratio(x1, y1 + 1)),
        ];
        let mut sum = [0.0; 3];
        for ch in 0..3 {
            let err = axis_error(&rows, ch) + axis_error(&columns, ch);
            let scale = c.iter().map(|r| r[ch]).fold(0.0f64, f64::max);
            let rel = if err == 0.0 { 0.0 } else { err / scale };
            let share = corners.iter().map(|e| e.1[ch]).fold(0.0f64, f64::max);
            if !(rel <= MAX_RATIO_ERROR && rel * share.min(1.0) <= PIXEL_TOLERANCE) {
                return None;
            }
            sum[ch] = c.iter().zip(self.weights).map(|(r, w)| w * r[ch]).sum();
        }
        Some(sum)
    }
}

/// Two corners of a block along an axis and the grid pixels beyond each, if recorded.
pub(crate) type Line = ([f64; 3], [f64; 3], Option<[f64; 3]>, Option<[f64; 3]>);

/// The interpolation's estimated error along an axis in channel `ch`, over the block's two
/// lines along it: [`CURVATURE`] times the largest second difference at the corners, or
/// the corners' difference where neither has a neighbour beyond.
pub(crate) fn axis_error(lines: &[Line; 2], ch: usize) -> f64 {
    lines
        .iter()
        .map(|&(a, b, before, after)| {
            let d0 = before.map(|p| (p[ch] - 2.0 * a[ch] + b[ch]).abs());
            let d1 = after.map(|q| (a[ch] - 2.0 * b[ch] + q[ch]).abs());
            match (d0, d1) {
                (None, None) => (a[ch] - b[ch]).abs(),
                (d0, d1) => CURVATURE * d0.unwrap_or(0.0).max(d1.unwrap_or(0.0)),
            }
        })
        .fold(0.0f64, f64::max)
}

impl Corners<'_> {
    /// At a Gaussian's edge, where some corners did not record the term: the present
    /// corners' mean ratio, if even the largest of them times the pixel's `scale` (the
    /// term's unattenuated contribution) is at most [`PIXEL_TOLERANCE`] of the darkest
    /// corner's radiance — then the term itself is that small.
    fn faint(
        &self,
        found: &[Option<([f64; 3], [f64; 3])>; 4],
        scale: impl FnOnce() -> Rgb,
    ) -> Option<[f64; 3]> {
        let present: Vec<[f64; 3]> = found.iter().flatten().map(|e| e.0).collect();
        if present.is_empty() {
            return None;
        }
        let scale = scale();
        let dark = self.corners().map(|s| s.radiance);
        let mut mean = [0.0; 3];
        for c in 0..3 {
            let top = present.iter().map(|r| r[c]).fold(0.0f64, f64::max);
            let floor = dark
                .iter()
                .map(|r| f64::from(r[c]))
                .fold(f64::INFINITY, f64::min);
            // False for NaN: integrate.
            let faint = scale[c] * top <= PIXEL_TOLERANCE * floor;
            if !faint {
                return None;
            }
            mean[c] = present.iter().map(|r| r[c]).sum::<f64>() / present.len() as f64;
        }
        Some(mean)
    }
}

/// The grid's pixels along an axis of `len` pixels: every `stride`th and the last.
pub(crate) fn grid(len: usize, stride: usize) -> Vec<usize> {
    let mut g: Vec<usize> = (0..len).step_by(stride.max(1)).collect();
    if len > 0 && g.last() != Some(&(len - 1)) {
        g.push(len - 1);
    }
    g
}

/// Bilinear weights at `(tx, ty)` within a block, for its corners in the order `(0, 0)`,
/// `(1, 0)`, `(0, 1)`, `(1, 1)`.
pub(crate) fn bilinear(tx: f64, ty: f64) -> [f64; 4] {
    [
        (1.0 - tx) * (1.0 - ty),
        tx * (1.0 - ty),
        (1.0 - tx) * ty,
        tx * ty,
    ]
}

/// The grid interval holding pixel `v`: `(k, t)` with `v = g[k] + t·(g[k+1] − g[k])`,
/// `t ∈ [0, 1)`; `(k, 0)` at a grid pixel (the last included).
pub(crate) fn cell(g: &[usize], v: usize) -> (usize, f64) {
    let k = g.partition_point(|&p| p <= v) - 1;
    if g[k] == v || k + 1 == g.len() {
        return (k, 0.0);
    }
    (k, (v - g[k]) as f64 / (g[k + 1] - g[k]) as f64)
}

/// Per key ([`pair_id`], [`host_id`]): whether every Gaussian the term involves subtends
/// at least [`MIN_SCALE`] blocks of `stride` pixels (its radius `1/a` over its distance
/// from the eye, against a pixel's angle).
pub(crate) fn reusable(prep: &Prepared<'_>, stride: usize) -> Vec<bool> {
    let cam = &prep.scene.camera;
    let blobs = prep.set.blobs();
    let n = blobs.len();
    let lights = prep.lights.len();
    let least = MIN_SCALE * stride as f64 * 2.0 * cam.pixel_radius();
    let large = |j: usize| {
        let d = norm(sub(blobs[j].center, cam.eye));
        let r = 1.0 / blobs[j].a;
        d > r && r / d >= least
    };
    let mut out = vec![false; lights * n + lights];
    for (l, lit) in prep.lights.iter().enumerate() {
        for (i, e) in lit.pairs.integrated.iter().enumerate() {
            if e.is_some() {
                out[pair_id(n, l, i)] =
                    large(i) && lit.pairs.pair_exact[i].iter().all(|&k| large(k));
            }
        }
        out[host_id(n, lights, l)] = lit.pairs.exact.iter().all(|&k| large(k));
    }
    out
}

/// Each light's image in pixels (`None` for a sun or a point behind the eye).
fn light_images(prep: &Prepared<'_>) -> Vec<Option<(f64, f64)>> {
    prep.scene
        .lights
        .iter()
        .map(|l| match l {
            Light::Point { position, .. } => prep.scene.camera.project(*position),
            Light::Sun { .. } => None,
        })
        .collect()
}

/// Bit `l` set where light `l`'s image lies within `margin` pixels of the block of pixels
/// `x0..=x1 × y0..=y1`; bits past 63 are not kept (those lights' terms are integrated).
fn near_lights(
    images: &[Option<(f64, f64)>],
    (x0, x1): (usize, usize),
    (y0, y1): (usize, usize),
    margin: f64,
) -> u64 {
    let mut bits = 0;
    for (l, img) in images.iter().enumerate().take(64) {
        if let Some((px, py)) = *img {
            let inside =
                |p: f64, a: usize, b: usize| p >= a as f64 - margin && p <= (b + 1) as f64 + margin;
            if inside(px, x0, x1) && inside(py, y0, y1) {
                bits |= 1 << l;
            }
        }
    }
    bits
}

/// How often the fine pass took an integrated term from the grid.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReuseCount {
    /// Integrated terms met by the pixels off the grid.
    pub terms: usize,
    /// Of those, the ones interpolated from the grid.
    pub reused: usize,
}

/// [`crate::paper_b::render`] with the integrated terms reused (module docs), at
/// [`crate::paper_b::PaperBOptions::reuse`]'s stride, the surfaces' shadow on the sky from
/// `sky`; `lim` already holds the pixel's `γ_min`. Logs how often the terms were reused.
pub(crate) fn render(
    prep: &Prepared<'_>,
    lim: &Limits,
    sky: Option<&SkyTable>,
    progress: &(dyn Fn(usize) + Sync),
) -> Image {
    let (image, n) = render_counted(prep, lim, sky, progress);
    tracing::info!(
        "paper B: integrated terms taken from a {}-pixel grid at {} of the {} pixel crossings \
         off it",
        prep.options.reuse,
        n.reused,
        n.terms
    );
    image
}

/// The strides of the grids from `top` down to every pixel: `top`, then halved while it
/// stays even, then 1 — each grid holds the coarser one's pixels ([`grid`]).
pub(crate) fn strides(top: usize) -> Vec<usize> {
    let mut out = vec![top.max(1)];
    let mut s = top.max(1);
    while s > 1 {
        s = if s.is_multiple_of(2) { s / 2 } else { 1 };
        out.push(s);
    }
    out
}

/// A grid of recorded pixels: every `stride`th column `gx` and row `gy`.
struct Level {
    stride: usize,
    gx: Vec<usize>,
    gy: Vec<usize>,
    samples: Vec<Sample>,
    /// Per key: [`reusable`] across this grid's blocks.
    reusable: Vec<bool>,
}

impl Level {
    /// The block of this grid around pixel `(x, y)`, `None` at one of its pixels.
    fn corners<'l>(
        &'l self,
        x: usize,
        y: usize,
        images: &[Option<(f64, f64)>],
    ) -> Option<Corners<'l>> {
        let (kx, tx) = cell(&self.gx, x);
        let (ky, ty) = cell(&self.gy, y);
        if tx == 0.0 && ty == 0.0 {
            return None;
        }
        let nx = self.gx.len();
        let kx1 = (kx + 1).min(nx - 1);
        let ky1 = (ky + 1).min(self.gy.len() - 1);
        Some(Corners {
            grid: &self.samples,
            nx,
            k: (kx, ky),
            k1: (kx1, ky1),
            weights: bilinear(tx, ty),
            reusable: &self.reusable,
            near_light: near_lights(
                images,
                (self.gx[kx], self.gx[kx1]),
                (self.gy[ky], self.gy[ky1]),
                self.stride as f64,
            ),
        })
    }

    /// The sample recorded at pixel `(x, y)`, one of this grid's.
    fn at(&self, x: usize, y: usize) -> &Sample {
        let (kx, ky) = (cell(&self.gx, x).0, cell(&self.gy, y).0);
        &self.samples[ky * self.gx.len() + kx]
    }
}

/// [`render`], and how often it reused: the coarsest grid ([`PaperBOptions::reuse`]'s
/// stride) integrated, each finer grid ([`strides`]) taking its terms from the one
/// before where smooth and recording them, the pixels from the finest.
///
/// [`PaperBOptions::reuse`]: super::PaperBOptions::reuse
pub fn render_counted(
    prep: &Prepared<'_>,
    lim: &Limits,
    sky: Option<&SkyTable>,
    progress: &(dyn Fn(usize) + Sync),
) -> (Image, ReuseCount) {
    let cam = &prep.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let strides = strides(prep.options.reuse);
    let images = light_images(prep);
    let top = strides[0];
    let (gx, gy) = (grid(w, top), grid(h, top));
    let nx = gx.len();
    let samples: Vec<Sample> = (0..nx * gy.len())
        .into_par_iter()
        .map(|k| {
            let mut s = Sample::default();
            let (x, y) = (gx[k % nx], gy[k / nx]);
            let table = sky.map(|t| (t, x, y));
            let r = prep.radiance_with(
                lim,
                cam.pixel_ray(x, y),
                &mut PairMode::Record(&mut s),
                table,
            );
            s.radiance = r.map(|c| c as f32);
            s.ratios.sort_unstable_by_key(|e| e.id);
            s
        })
        .collect();
    let mut level = Level {
        stride: top,
        gx,
        gy,
        samples,
        reusable: reusable(prep, top),
    };
    let mut count = ReuseCount::default();
    // The grids between the coarsest and every pixel.
    for &s in &strides[1..strides.len() - 1] {
        let (fx, fy) = (grid(w, s), grid(h, s));
        let nx = fx.len();
        let refined: Vec<(Sample, ReuseCount)> = (0..nx * fy.len())
            .into_par_iter()
            .map(|k| {
                let (x, y) = (fx[k % nx], fy[k / nx]);
                let mut n = ReuseCount::default();
                let Some(corners) = level.corners(x, y, &images) else {
                    return (level.at(x, y).clone(), n);
                };
                let mut sample = Sample::default();
                let mut mode = PairMode::Reuse {
                    corners: &corners,
                    cut: f64::INFINITY,
                    count: &mut n,
                    record: Some(&mut sample),
                };
                let table = sky.map(|t| (t, x, y));
                let r = prep.radiance_with(lim, cam.pixel_ray(x, y), &mut mode, table);
                sample.radiance = r.map(|c| c as f32);
                sample.ratios.sort_unstable_by_key(|e| e.id);
                (sample, n)
            })
            .collect();
        let mut samples = Vec::with_capacity(refined.len());
        for (sample, n) in refined {
            samples.push(sample);
            count.terms += n.terms;
            count.reused += n.reused;
        }
        level = Level {
            stride: s,
            gx: fx,
            gy: fy,
            samples,
            reusable: reusable(prep, s),
        };
    }
    let done = AtomicUsize::new(0);
    let rows: Vec<(Vec<[f32; 3]>, ReuseCount)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut count = ReuseCount::default();
            let row = (0..w)
                .map(|x| {
                    let Some(corners) = level.corners(x, y, &images) else {
                        return level.at(x, y).radiance;
                    };
                    let mut mode = PairMode::Reuse {
                        corners: &corners,
                        cut: f64::INFINITY,
                        count: &mut count,
                        record: None,
                    };
                    let table = sky.map(|t| (t, x, y));
                    let r = prep.radiance_with(lim, cam.pixel_ray(x, y), &mut mode, table);
                    r.map(|c| c as f32)
                })
                .collect();
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            (row, count)
        })
        .collect();
    let mut pixels = Vec::with_capacity(w * h);
    for (row, n) in rows {
        pixels.extend(row);
        count.terms += n.terms;
        count.reused += n.reused;
    }
    let image = Image {
        width: w,
        height: h,
        pixels,
    };
    (image, count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_takes_every_stride_and_the_last_pixel() {
        assert_eq!(grid(10, 4), vec![0, 4, 8, 9]);
        assert_eq!(grid(9, 4), vec![0, 4, 8]);
        assert_eq!(grid(1, 4), vec![0]);
        assert_eq!(grid(3, 1), vec![0, 1, 2]);
        assert!(grid(0, 4).is_empty());
    }

    #[test]
    fn the_strides_halve_to_every_pixel_through_nested_grids() {
        assert_eq!(strides(8), vec![8, 4, 2, 1]);
        assert_eq!(strides(4), vec![4, 2, 1]);
        assert_eq!(strides(12), vec![12, 6, 3, 1]);
        assert_eq!(strides(5), vec![5, 1]);
        assert_eq!(strides(1), vec![1]);
        assert_eq!(strides(0), vec![1]);
        // Each grid holds the coarser one's pixels, the last row and column included.
        for top in [16, 12, 8, 6, 5] {
            for len in [1, 7, 16, 17, 120, 161] {
                for pair in strides(top).windows(2) {
                    let fine = grid(len, pair[1]);
                    assert!(grid(len, pair[0]).iter().all(|p| fine.contains(p)));
                }
            }
        }
    }

    #[test]
    fn a_pixel_falls_in_the_interval_that_holds_it() {
        let g = grid(10, 4);
        assert_eq!(cell(&g, 0), (0, 0.0));
        assert_eq!(cell(&g, 2), (0, 0.5));
        assert_eq!(cell(&g, 4), (1, 0.0));
        assert_eq!(cell(&g, 7), (1, 0.75));
        assert_eq!(cell(&g, 8), (2, 0.0));
        assert_eq!(cell(&g, 9), (3, 0.0));
        assert_eq!(cell(&[0], 0), (0, 0.0));
    }

    #[test]
    fn the_axis_error_sees_curvature_not_slope() {
        let line = |f: &dyn Fn(f64) -> f64, before: bool, after: bool| -> Line {
            let v = |x: f64| [f(x); 3];
            (
                v(0.0),
                v(1.0),
                before.then(|| v(-1.0)),
                after.then(|| v(2.0)),
            )
        };
        // A ratio linear across the grid interpolates exactly: no error, however steep.
        let steep = |x: f64| 1.0 + 0.4 * x;
        assert!(axis_error(&[line(&steep, true, true); 2], 0) < 1e-12);
        // A parabola `x²`: second difference 2 at both corners, CURVATURE·2 (bilinear
        // interpolation's true error at the middle is 1/4 = 2/8).
        let bowl = |x: f64| x * x;
        let e = axis_error(&[line(&bowl, true, false), line(&bowl, false, true)], 1);
        assert!((e - 2.0 * CURVATURE).abs() < 1e-12, "{e}");
        assert!(e >= 0.25);
        // No grid pixel beyond the block: the corners' whole difference.
        assert!((axis_error(&[line(&steep, false, false); 2], 2) - 0.4).abs() < 1e-12);
    }

    #[test]
    fn a_silhouette_in_the_block_sends_only_the_terms_it_may_cut_to_integration() {
        // A block whose upper corners' rays end on surface 0 at 5 and lower ones on none
        // (the sky): one term recorded at every corner with the same ratio, no grid
        // pixel beyond (the corners' difference, 0, is the error).
        let corner = |surface: Option<usize>, t_end: f64| Sample {
            radiance: [1.0; 3],
            surface,
            t_end,
            ratios: vec![Entry {
                id: 0,
                ratio: [0.5; 3],
                added: [0.1; 3],
            }],
        };
        let grid = vec![
            corner(Some(0), 5.0),
            corner(Some(0), 5.0),
            corner(None, f64::INFINITY),
            corner(None, f64::INFINITY),
        ];
        let corners = Corners {
            grid: &grid,
            nx: 2,
            k: (0, 0),
            k1: (1, 1),
            weights: bilinear(0.5, 0.5),
            reusable: &[true],
            near_light: 0,
        };
        let mut count = ReuseCount::default();
        let mut mode = PairMode::Reuse {
            corners: &corners,
            cut: f64::INFINITY,
            count: &mut count,
            record: None,
        };
        // The pixel's ray ends on the surface at 6: a Gaussian reaching 4 is before every
        // end, one reaching 5.5 may be cut, and a term to the ray's end is.
        mode.hit(Some(0), 6.0);
        let got = mode.ratio(0, 0, 4.0, || [1.0; 3]).unwrap();
        assert!(got.iter().all(|r| (r - 0.5).abs() < 1e-7), "{got:?}");
        assert!(mode.ratio(0, 0, 5.5, || [1.0; 3]).is_none());
        assert!(mode.ratio(0, 0, f64::INFINITY, || [1.0; 3]).is_none());
        // A block that ends on no surface throughout reuses even a term to the ray's end.
        let sky = vec![corner(None, f64::INFINITY); 4];
        let corners = Corners {
            grid: &sky,
            ..corners
        };
        let mut mode = PairMode::Reuse {
            corners: &corners,
            cut: 0.0,
            count: &mut count,
            record: None,
        };
        mode.hit(None, f64::INFINITY);
        assert!(mode.ratio(0, 0, f64::INFINITY, || [1.0; 3]).is_some());
        assert_eq!(
            count,
            ReuseCount {
                terms: 4,
                reused: 2
            }
        );
    }

    #[test]
    fn a_light_near_a_block_sets_its_bit() {
        let images = [Some((5.5, 5.5)), None, Some((30.0, 2.0))];
        assert_eq!(near_lights(&images, (4, 8), (4, 8), 4.0), 0b001);
        assert_eq!(near_lights(&images, (12, 16), (0, 4), 4.0), 0);
        assert_eq!(near_lights(&images, (20, 24), (0, 4), 6.0), 0b100);
        // The image just past the margin.
        assert_eq!(near_lights(&images, (10, 14), (4, 8), 4.4), 0);
        assert_eq!(near_lights(&images, (10, 14), (4, 8), 4.6), 0b001);
    }
}
