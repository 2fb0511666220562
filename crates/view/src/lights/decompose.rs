//! The decomposition of a lat-long map into suns and a smooth rest: the map's concentrated
//! light (a sharp sun, a soft sun with its aureole, two suns, a studio's key and fill, a
//! bright cloud edge) becomes a few distant disks lit exactly ([`Sun`]); what stays in the
//! map is smooth at the scale of the environment pass's direction rule.
//!
//! **Background.** The smooth sky `B(ω)` is the morphological opening of the map (per
//! channel, on a coarse copy of at most [`COARSE_WIDTH`] × [`COARSE_WIDTH`]/2 texels,
//! each the solid-angle-weighted mean of the texels whose centers it holds): the minimum
//! over a spherical cap of angular radius `R` ([`DecomposeOptions::scale_degrees`]),
//! then the maximum of that over the same caps. An opening keeps every feature a cap
//! fits inside (sky gradients, a bright horizon band wider than the cap, an overcast
//! sky) and removes what is narrower — of a peak, what stands above its value at the
//! distance `R` from its center (the cap centered on the peak has that minimum): a
//! Gaussian lobe of standard deviation `σ` drops to the background `B` at
//! `σ·√(2 ln(peak/B))`, so `R = 30°` takes all of a lobe up to `σ ≈ 8°` at 1000× the
//! sky. It works at the coarse map's resolution whatever the
//! map's own, so the result does not depend on the map's size.
//!
//! **Regions.** The excess `X = Y(L) − Y(B)` (luminance `Y`, Rec. 709) seeds a region
//! at every coarse texel, brightest first, where `X > `[`PEAK_CONTRAST`]`·Y(B)`; the
//! region grows (8-neighbours, wrapping in azimuth) over the texels with
//! `X ≥ max(f·X_seed, `[`SKY_FRACTION`]`·Y(B))`, `f` the first of [`GROW_FRACTIONS`]
//! (1 %, 3 %, 10 %, 30 %) that leaves its RMS angular radius at most
//! [`MAX_SPREAD_DEGREES`] — 1 % of a Gaussian lobe's peak lies at `3.03σ`, inside which
//! is 99 % of its power; a sun beside a glowing horizon band stands alone at a higher
//! floor. Light broader than that is smooth enough for the rule and stays in the map. A
//! region becomes light when it carries at least [`DecomposeOptions::min_share`] of the
//! map's power — on the coarse map, and again on the full-resolution one below (a soft
//! sun's faint fringe passes the first and not the second: it stays in the map instead
//! of taking a sun from the budget).
//!
//! **Suns.** On the full-resolution map, every texel of a region gives its excess over
//! the background (bilinear between the coarse texels' centers), per channel, `≥ 0`:
//! `E_c = max(0, L_c − B_c)`, and keeps `L_c − E_c`; so the suns and the rest carry the
//! map's power exactly. A region whose RMS radius exceeds
//! [`DecomposeOptions::split_degrees`] is cut by a median cut (Debevec 2005: at the
//! weighted median of its longer axis in the plane tangent to its mean direction), the
//! widest piece first, while the light budget lasts and both halves would carry
//! `min_share` — a soft sun becomes a cluster of suns and keeps its soft shadow and its
//! spread of phase angles. Each piece is a
//! [`Sun`]: the irradiance `Σ E·Ω_texel`, the luminance-weighted mean direction, and the
//! apex angle of the uniform disk with the same mean squared angle (`⟨θ²⟩ = ρ²/2` for a
//! disk of angular radius `ρ`: angle `2ρ = 2√(2⟨θ²⟩)`).

use super::{Sun, basis, dot, unit};
use crate::distant::{LatLong, Rgb, bilinear};
use std::f64::consts::PI;

/// Width of the coarse map the background and regions are found on (2.8° texels).
pub const COARSE_WIDTH: usize = 128;
/// A region's seed exceeds the background by this factor (the texel is at least 3× the
/// sky around it).
pub const PEAK_CONTRAST: f64 = 2.0;
/// A region grows over texels whose excess is at least the first of these fractions of
/// its seed's that leaves it compact (RMS radius at most [`MAX_SPREAD_DEGREES`]).
pub const GROW_FRACTIONS: [f64; 4] = [0.01, 0.03, 0.1, 0.3];
/// ... and at least this fraction of the background there (texture on the sky stays sky).
pub const SKY_FRACTION: f64 = 0.25;
/// The largest RMS angular radius (degrees) of a region taken as light.
pub const MAX_SPREAD_DEGREES: f64 = 20.0;

/// Settings of [`decompose`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DecomposeOptions {
    /// The most suns made (0: none, the map stays whole).
    pub max_lights: usize,
    /// Angular radius (degrees) of the opening's cap (module docs).
    pub scale_degrees: f64,
    /// The smallest share of the map's power (luminance) a region must carry to be light.
    pub min_share: f64,
    /// Regions (and pieces) with a larger RMS angular radius (degrees) are split while
    /// the budget lasts.
    pub split_degrees: f64,
}

impl Default for DecomposeOptions {
    /// Eight suns, a 30° cap, regions of 0.2 % of the power, pieces of 4° RMS radius.
    fn default() -> Self {
        DecomposeOptions {
            max_lights: 8,
            scale_degrees: 30.0,
            min_share: 0.002,
            split_degrees: 4.0,
        }
    }
}

/// A map split into suns and the rest.
#[derive(Clone, Debug, PartialEq)]
pub struct Decomposition {
    /// The concentrated light, brightest first.
    pub suns: Vec<Sun>,
    /// The map less the suns' excess (same size as the input).
    pub rest: LatLong,
    /// The input map's power (luminance of `∫ L dω`), which `suns` and `rest` share.
    pub power: f64,
}

impl Decomposition {
    /// The share of the map's power sun `k` carries (0 for a black map).
    pub fn share(&self, k: usize) -> f64 {
        if self.power > 0.0 {
            luminance(self.suns[k].irradiance) / self.power
        } else {
            0.0
        }
    }
}

/// Rec. 709 luminance.
pub fn luminance(c: Rgb) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Splits `map` into suns and a smooth rest (module docs).
pub fn decompose(map: &LatLong, opts: &DecomposeOptions) -> Decomposition {
    let coarse = Coarse::of(map);
    let background = coarse.opening(opts.scale_degrees.max(0.0).to_radians());
    let power = luminance(map_power(map));
    let min_power = power * opts.min_share.max(0.0);
    let regions = if opts.max_lights == 0 || power <= 0.0 || !power.is_finite() {
        Vec::new()
    } else {
        coarse.regions(&background, min_power)
    };
    let mut rest = map.clone();
    let mut pieces: Vec<Piece> = Vec::new();
    for region in regions {
        if pieces.len() >= opts.max_lights {
            break;
        }
        let texels = excess_texels(map, &coarse, &background, &region);
        let piece = Piece::new(texels);
        // The coarse map passed the region at `min_share`; its excess over the
        // full-resolution background may fall under it (a soft sun's faint fringe), and
        // then it stays in the map rather than take a sun from the budget.
        if piece.weight <= 0.0
            || piece.weight < min_power
            || piece.rms > MAX_SPREAD_DEGREES.to_radians()
        {
            continue;
        }
        for t in &piece.texels {
            let cell = &mut rest.texels[t.index];
            for (v, e) in cell.iter_mut().zip(t.excess) {
                *v = (f64::from(*v) - e / t.omega).max(0.0) as f32;
            }
        }
        pieces.push(piece);
    }
    split_widest(&mut pieces, opts, min_power);
    let mut suns: Vec<Sun> = pieces.iter().filter_map(Piece::sun).collect();
    suns.sort_by(|a, b| luminance(b.irradiance).total_cmp(&luminance(a.irradiance)));
    Decomposition { suns, rest, power }
}

/// `∫ L dω` of a map, RGB.
pub fn map_power(map: &LatLong) -> Rgb {
    let mut p = [0.0; 3];
    for y in 0..map.height {
        let (_, omega) = map.texel_direction(0, y);
        for t in &map.texels[y * map.width..(y + 1) * map.width] {
            for c in 0..3 {
                p[c] += f64::from(t[c]) * omega;
            }
        }
    }
    p
}

/// The coarse copy of a map the background and regions are found on.
struct Coarse {
    width: usize,
    height: usize,
    /// Solid-angle-weighted mean radiance per coarse texel.
    texels: Vec<Rgb>,
    /// `(fine width, fine height)`: fine texel `(x, y)` lies in coarse
    /// `(x·width/fw, y·height/fh)`.
    fine: (usize, usize),
}

impl Coarse {
    fn of(map: &LatLong) -> Coarse {
        let width = map.width.min(COARSE_WIDTH);
        let height = map.height.clamp(1, COARSE_WIDTH / 2);
        let mut sum = vec![[0.0f64; 3]; width * height];
        let mut area = vec![0.0f64; width * height];
        for y in 0..map.height {
            let (_, omega) = map.texel_direction(0, y);
            let cy = y * height / map.height;
            for x in 0..map.width {
                let i = cy * width + x * width / map.width;
                let t = map.texels[y * map.width + x];
                for c in 0..3 {
                    sum[i][c] += f64::from(t[c]) * omega;
                }
                area[i] += omega;
            }
        }
        let texels = sum
            .iter()
            .zip(&area)
            .map(|(s, a)| if *a > 0.0 { s.map(|v| v / a) } else { [0.0; 3] })
            .collect();
        Coarse {
            width,
            height,
            texels,
            fine: (map.width, map.height),
        }
    }

    /// Polar angle of coarse row `r`'s center.
    fn theta(&self, r: usize) -> f64 {
        PI * (r as f64 + 0.5) / self.height as f64
    }

    /// Solid angle of a texel of coarse row `r`.
    fn omega(&self, r: usize) -> f64 {
        let h = self.height as f64;
        (2.0 * PI / self.width as f64)
            * ((PI * r as f64 / h).cos() - (PI * (r + 1) as f64 / h).cos())
    }

    /// For each pair of rows `(r, r2)`, the azimuth half-width in columns of the cap of
    /// angular radius `radius` about a texel center of row `r`, on row `r2`: `None` when
    /// no center of row `r2` is within the cap.
    fn cap_spans(&self, radius: f64) -> Vec<Vec<Option<usize>>> {
        let (w, h) = (self.width, self.height);
        let dphi = 2.0 * PI / w as f64;
        let cos_r = radius.cos();
        (0..h)
            .map(|r| {
                let (s1, c1) = self.theta(r).sin_cos();
                (0..h)
                    .map(|r2| {
                        let (s2, c2) = self.theta(r2).sin_cos();
                        // cos(distance) = c1·c2 + s1·s2·cos Δφ ≥ cos R.
                        let den = s1 * s2;
                        let need = cos_r - c1 * c2;
                        if den <= 0.0 {
                            return (need <= 0.0).then_some(w);
                        }
                        let cos_dphi = need / den;
                        if cos_dphi > 1.0 {
                            None
                        } else if cos_dphi <= -1.0 {
                            Some(w)
                        } else {
                            Some(((cos_dphi.acos() / dphi + 1e-9).floor() as usize).min(w))
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// The opening of the coarse map by caps of angular radius `radius`, per channel.
    fn opening(&self, radius: f64) -> Vec<Rgb> {
        let spans = self.cap_spans(radius);
        let eroded = self.cap_filter(&self.texels, &spans, f64::min, f64::INFINITY);
        self.cap_filter(&eroded, &spans, f64::max, f64::NEG_INFINITY)
    }

    /// `op` (min or max) of `values` over the cap about every texel: per row `r2` and
    /// half-width `k`, the row's running `op` over `2k + 1` columns (wrapping; van Herk's
    /// and Gil & Werman's block prefix/suffix, three `op`s per texel whatever `k`), then
    /// per texel the `op` over the rows its cap reaches.
    fn cap_filter(
        &self,
        values: &[Rgb],
        spans: &[Vec<Option<usize>>],
        op: fn(f64, f64) -> f64,
        init: f64,
    ) -> Vec<Rgb> {
        let (w, h) = (self.width, self.height);
        // windows[r2][k]: row r2's running op over 2k + 1 columns (full row for 2k+1 ≥ w).
        let mut windows: Vec<std::collections::HashMap<usize, Vec<Rgb>>> =
            vec![Default::default(); h];
        for row_spans in spans {
            for (r2, span) in row_spans.iter().enumerate() {
                if let Some(k) = *span {
                    windows[r2]
                        .entry(k)
                        .or_insert_with(|| running(&values[r2 * w..(r2 + 1) * w], k, op, init));
                }
            }
        }
        let mut out = vec![[init; 3]; values.len()];
        for (r, row_spans) in spans.iter().enumerate() {
            for (r2, span) in row_spans.iter().enumerate() {
                let Some(k) = *span else { continue };
                let win = &windows[r2][&k];
                for (o, v) in out[r * w..(r + 1) * w].iter_mut().zip(win) {
                    for c in 0..3 {
                        o[c] = op(o[c], v[c]);
                    }
                }
            }
        }
        out
    }

    /// The regions of concentrated light (module docs), brightest seed first, those
    /// carrying at least `min_power` (luminance of `∫ excess dω`).
    fn regions(&self, background: &[Rgb], min_power: f64) -> Vec<Vec<usize>> {
        let (w, h) = (self.width, self.height);
        let bg: Vec<f64> = background.iter().map(|b| luminance(*b)).collect();
        let excess: Vec<f64> = self
            .texels
            .iter()
            .zip(&bg)
            .map(|(t, b)| (luminance(*t) - b).max(0.0))
            .collect();
        let mut order: Vec<usize> = (0..w * h)
            .filter(|&i| excess[i] > PEAK_CONTRAST * bg[i] && excess[i] > 0.0)
            .collect();
        order.sort_by(|a, b| excess[*b].total_cmp(&excess[*a]));
        let mut taken = vec![false; w * h];
        let mut regions = Vec::new();
        for seed in order {
            if taken[seed] {
                continue;
            }
            // The lowest floor whose region is compact: a sun beside a bright horizon
            // band joins the band at 1 % of its peak and stands alone at 30 %.
            let mut last = Vec::new();
            for fraction in GROW_FRACTIONS {
                let region = self.grow(seed, fraction * excess[seed], &excess, &bg, &taken);
                if self.spread(&region, &excess) <= MAX_SPREAD_DEGREES.to_radians() {
                    let carried: f64 = region.iter().map(|&i| excess[i] * self.omega(i / w)).sum();
                    if carried >= min_power && carried > 0.0 {
                        regions.push(region.clone());
                    }
                    last = region;
                    break;
                }
                last = region;
            }
            for i in last {
                taken[i] = true;
            }
        }
        regions
    }

    /// The connected texels (8-neighbours, wrapping in azimuth) not `taken` around `seed`
    /// whose excess is at least `floor` and [`SKY_FRACTION`] of the background.
    fn grow(
        &self,
        seed: usize,
        floor: f64,
        excess: &[f64],
        bg: &[f64],
        taken: &[bool],
    ) -> Vec<usize> {
        let (w, h) = (self.width as i64, self.height as i64);
        let mut inside = vec![false; excess.len()];
        inside[seed] = true;
        let mut region = vec![seed];
        let mut k = 0;
        while k < region.len() {
            let (x, r) = (region[k] as i64 % w, region[k] as i64 / w);
            for rr in (r - 1).max(0)..=(r + 1).min(h - 1) {
                for dx in -1..=1i64 {
                    let n = (rr * w + (x + dx).rem_euclid(w)) as usize;
                    if !inside[n] && !taken[n] && excess[n] >= floor.max(SKY_FRACTION * bg[n]) {
                        inside[n] = true;
                        region.push(n);
                    }
                }
            }
            k += 1;
        }
        region
    }

    /// RMS angle (radians) of a region's excess about its excess-weighted mean direction.
    fn spread(&self, region: &[usize], excess: &[f64]) -> f64 {
        let w = self.width;
        let dir = |i: usize| {
            let phi = 2.0 * PI * ((i % w) as f64 + 0.5) / w as f64;
            crate::distant::direction(self.theta(i / w), phi)
        };
        let weight = |i: usize| excess[i] * self.omega(i / w);
        let mut sum = [0.0; 3];
        let mut total = 0.0;
        for &i in region {
            let (d, y) = (dir(i), weight(i));
            total += y;
            for a in 0..3 {
                sum[a] += y * d[a];
            }
        }
        let Some(mean) = unit(sum) else {
            return PI;
        };
        if total <= 0.0 {
            return PI;
        }
        let m2: f64 = region
            .iter()
            .map(|&i| weight(i) * dot(dir(i), mean).clamp(-1.0, 1.0).acos().powi(2))
            .sum();
        (m2 / total).sqrt()
    }

    /// The background at fine texel `(x, y)`: bilinear between coarse texel centers
    /// (wrapping in azimuth, clamped at the poles), as [`LatLong::radiance`] looks up.
    fn background_at(&self, background: &[Rgb], x: usize, y: usize) -> Rgb {
        let (fw, fh) = (self.fine.0 as f64, self.fine.1 as f64);
        bilinear(
            self.width,
            self.height,
            (x as f64 + 0.5) / fw * self.width as f64 - 0.5,
            (y as f64 + 0.5) / fh * self.height as f64 - 0.5,
            |cx, cy| background[cy * self.width + cx],
        )
    }
}

/// `op` of `row` over the `2k + 1` columns centered on each column, wrapping (the whole
/// row's `op` where the window covers it): the block prefix/suffix scheme of van Herk
/// (1992) and Gil & Werman (1993) on the row extended by `k` columns each side.
fn running(row: &[Rgb], k: usize, op: fn(f64, f64) -> f64, init: f64) -> Vec<Rgb> {
    let w = row.len();
    let fold3 = |a: Rgb, b: Rgb| [op(a[0], b[0]), op(a[1], b[1]), op(a[2], b[2])];
    if 2 * k + 1 >= w {
        let all = row.iter().fold([init; 3], |a, b| fold3(a, *b));
        return vec![all; w];
    }
    let b = 2 * k + 1;
    let n = w + 2 * k;
    let ext: Vec<Rgb> = (0..n).map(|i| row[(i + w - k) % w]).collect();
    let mut prefix = ext.clone();
    let mut suffix = ext.clone();
    for i in 1..n {
        if i % b != 0 {
            prefix[i] = fold3(prefix[i - 1], ext[i]);
        }
    }
    for i in (0..n - 1).rev() {
        if (i + 1) % b != 0 {
            suffix[i] = fold3(suffix[i + 1], ext[i]);
        }
    }
    // Window [x, x + 2k] of the extended row is centered on column x of the row.
    (0..w)
        .map(|x| fold3(suffix[x], prefix[x + 2 * k]))
        .collect()
}

/// A full-resolution texel's share of a sun.
#[derive(Clone, Copy, Debug)]
struct Texel {
    /// Index in the map.
    index: usize,
    direction: [f64; 3],
    /// Solid angle.
    omega: f64,
    /// `max(0, L − B)·Ω` per channel.
    excess: Rgb,
}

/// The full-resolution texels of a coarse region, with their excess over the background.
fn excess_texels(
    map: &LatLong,
    coarse: &Coarse,
    background: &[Rgb],
    region: &[usize],
) -> Vec<Texel> {
    let mut inside = vec![false; coarse.width * coarse.height];
    for &i in region {
        inside[i] = true;
    }
    let rows = region.iter().map(|&i| i / coarse.width);
    let (lo, hi) = (rows.clone().min().unwrap_or(0), rows.max().unwrap_or(0));
    // Fine rows whose coarse row (y·ch/fh) lies in [lo, hi].
    let first = (lo * map.height).div_ceil(coarse.height);
    let last = ((hi + 1) * map.height)
        .div_ceil(coarse.height)
        .min(map.height);
    let mut out = Vec::new();
    for y in first..last {
        let cy = y * coarse.height / map.height;
        for x in 0..map.width {
            if !inside[cy * coarse.width + x * coarse.width / map.width] {
                continue;
            }
            let index = y * map.width + x;
            let (direction, omega) = map.texel_direction(x, y);
            let b = coarse.background_at(background, x, y);
            let t = map.texels[index];
            let excess = [0, 1, 2].map(|c| (f64::from(t[c]) - b[c]).max(0.0) * omega);
            if excess.iter().any(|&e| e > 0.0) {
                out.push(Texel {
                    index,
                    direction,
                    omega,
                    excess,
                });
            }
        }
    }
    out
}

/// A set of texels that becomes one sun.
#[derive(Clone, Debug)]
struct Piece {
    texels: Vec<Texel>,
    /// Luminance of the excess power.
    weight: f64,
    /// Luminance-weighted mean direction.
    direction: [f64; 3],
    /// RMS angle (radians) from `direction`.
    rms: f64,
}

impl Piece {
    fn new(texels: Vec<Texel>) -> Piece {
        let mut sum = [0.0; 3];
        let mut weight = 0.0;
        for t in &texels {
            let y = luminance(t.excess);
            weight += y;
            for (s, d) in sum.iter_mut().zip(t.direction) {
                *s += y * d;
            }
        }
        let direction = unit(sum).unwrap_or([0.0, 0.0, 1.0]);
        let mut m2 = 0.0;
        for t in &texels {
            let theta = dot(t.direction, direction).clamp(-1.0, 1.0).acos();
            m2 += luminance(t.excess) * theta * theta;
        }
        let rms = if weight > 0.0 {
            (m2 / weight).sqrt()
        } else {
            0.0
        };
        Piece {
            texels,
            weight,
            direction,
            rms,
        }
    }

    /// The two halves of a median cut: at the weighted median of the longer axis of the
    /// texels' projection on the plane tangent to the mean direction.
    fn cut(self) -> (Piece, Piece) {
        let (t1, t2) = basis(self.direction);
        let coords: Vec<[f64; 2]> = self
            .texels
            .iter()
            .map(|t| [dot(t.direction, t1), dot(t.direction, t2)])
            .collect();
        let variance = |axis: usize| {
            let (mut m, mut m2) = (0.0, 0.0);
            for (t, p) in self.texels.iter().zip(&coords) {
                let y = luminance(t.excess);
                m += y * p[axis];
                m2 += y * p[axis] * p[axis];
            }
            m2 / self.weight - (m / self.weight).powi(2)
        };
        let axis = if variance(0) >= variance(1) { 0 } else { 1 };
        let mut order: Vec<usize> = (0..self.texels.len()).collect();
        order.sort_by(|a, b| coords[*a][axis].total_cmp(&coords[*b][axis]));
        let mut acc = 0.0;
        let mut split = order.len() / 2;
        for (k, &i) in order.iter().enumerate() {
            acc += luminance(self.texels[i].excess);
            if acc >= 0.5 * self.weight {
                split = (k + 1).clamp(1, order.len() - 1);
                break;
            }
        }
        let (a, b) = order.split_at(split);
        (
            Piece::new(a.iter().map(|&i| self.texels[i]).collect()),
            Piece::new(b.iter().map(|&i| self.texels[i]).collect()),
        )
    }

    /// The sun the piece is, if it carries light.
    fn sun(&self) -> Option<Sun> {
        let mut irradiance = [0.0; 3];
        for t in &self.texels {
            for (e, x) in irradiance.iter_mut().zip(t.excess) {
                *e += x;
            }
        }
        (self.weight > 0.0).then(|| Sun {
            direction: self.direction,
            irradiance,
            angle: (2.0 * std::f64::consts::SQRT_2 * self.rms).min(PI),
        })
    }
}

/// Splits the widest piece (largest `weight·rms²`, the spread its single direction
/// misses) while the budget lasts and it is wider than `split_degrees` — and heavy enough
/// that both halves of a median cut carry `min_power` (a sun must).
fn split_widest(pieces: &mut Vec<Piece>, opts: &DecomposeOptions, min_power: f64) {
    let limit = opts.split_degrees.max(0.0).to_radians();
    while pieces.len() < opts.max_lights {
        let widest = pieces
            .iter()
            .enumerate()
            .filter(|(_, p)| p.rms > limit && p.texels.len() >= 2 && p.weight >= 2.0 * min_power)
            .max_by(|a, b| {
                (a.1.weight * a.1.rms.powi(2)).total_cmp(&(b.1.weight * b.1.rms.powi(2)))
            });
        let Some((k, _)) = widest else { break };
        let (a, b) = pieces.swap_remove(k).cut();
        pieces.push(a);
        pieces.push(b);
    }
}

#[cfg(test)]
mod tests;
