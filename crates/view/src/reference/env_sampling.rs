//! Importance sampling of the distant environment, and its combination with phase
//! sampling by multiple importance sampling (MIS).
//!
//! **The distribution.** A lat-long map of `w × h` texels (docs/conventions.md: column `x` covers
//! azimuths `φ ∈ 2π[x, x+1)/w`, row `y` polar angles `θ ∈ π[y, y+1)/h`) gets the texel
//! weights `W(x, y) = Ȳ(x, y)·Ω_y`, where
//!
//! - `Ȳ` is the luminance (Rec. 709) of the map averaged over the texel as
//!   [`LatLong::radiance`] reconstructs it: bilinear between texel centers, whose mean over
//!   a texel is `¾` of the texel plus `⅛` of each neighbour along each axis (wrapping in
//!   azimuth, the texel itself past a pole, where the lookup is clamped). So `Ȳ > 0` on
//!   every texel where the looked-up radiance is anywhere non-zero;
//! - `Ω_y = (2π/w)(cos θ_y − cos θ_{y+1}) = (2π/w)·2 sin(π(2y+1)/2h)·sin(π/2h)` is the
//!   texel's solid angle, the integral of `sin θ` over it (so `W` is luminance × `sin θ`
//!   without the point value's zero at the poles, and without cancellation).
//!
//! A texel is drawn with probability `W/ΣW`, as a row from the marginal CDF
//! `Σ_{y' ≤ y} Σ_x W` and a column from that row's conditional CDF (both in `f64`, built
//! once per map), then a direction uniformly per solid angle inside the texel (`φ` and
//! `cos θ` uniform over its ranges, from the two uniforms' positions within the chosen
//! CDF bins). The density per steradian is therefore constant over each texel:
//! `p(ω) = W/(ΣW·Ω_y) = Ȳ(x, y)/ΣW` — no division by `sin θ`, finite at the poles. A map
//! of one row or one column is no special case; a map without light (`ΣW = 0`, or any
//! non-finite sum) has no sampler ([`EnvSampler::new`] returns `None`).
//!
//! **MIS.** The source radiance's distant part at `x` seen along `d`,
//! `S = ∫ f(ω) dω` with `f(ω) = p_HG(ω·d)/4π · T(x, ω)·L(ω)`, is estimated with one
//! direction `ω_p` from the phase function (density `q_p = p_HG/4π`) and one `ω_e` from
//! the map (density `q_e`):
//! `Ŝ = w_p(ω_p)·f(ω_p)/q_p(ω_p) + w_e(ω_e)·f(ω_e)/q_e(ω_e)` with the power heuristic
//! `w_p = q_p²/(q_p² + q_e²)`, `w_e = q_e²/(q_p² + q_e²)` (Veach 1997, §9.2). Since
//! `w_p + w_e = 1` wherever `q_p > 0`, and the HG density is positive everywhere for
//! `|g| < 1`, `E[Ŝ] = S` whatever the map — a sampler blind to part of the map only costs
//! variance there. The phase sample covers a sharp forward peak (`g = 0.9`), the map
//! sample a small bright region; each weight switches the other off where it is better.

use std::f64::consts::PI;

use crate::distant::{Distant, LatLong, Sky, angles};

/// Rec. 709 luminance of linear RGB.
pub(crate) fn luminance(c: [f64; 3]) -> f64 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The texels the sky is tabulated on to sample it: `SKY_TABLE.0 × SKY_TABLE.1`.
const SKY_TABLE: (usize, usize) = (64, 32);

/// A piecewise-constant distribution of directions over a lat-long map's texels, with
/// density ∝ the map's luminance (module docs).
#[derive(Clone, Debug)]
pub(crate) struct EnvSampler {
    width: usize,
    height: usize,
    /// `height + 1` entries, from 0 to 1: the marginal CDF over rows.
    rows: Vec<f64>,
    /// `height × (width + 1)` entries, each row from 0 to 1: the conditional CDFs.
    columns: Vec<f64>,
    /// `width × height`: the density per steradian inside each texel, `Ȳ/ΣW`.
    density: Vec<f64>,
    /// `height + 1` entries: `cos θ` at the row edges.
    cos_edges: Vec<f64>,
    /// `height`: `cos θ_y − cos θ_{y+1}`, without cancellation.
    cos_spans: Vec<f64>,
    /// True when every texel has the same density (uniform over the sphere).
    uniform: bool,
    /// `∫ Ȳ dω` over the sphere: the map's luminance-weighted scalar irradiance.
    power: f64,
}

impl EnvSampler {
    /// The distribution of `map`; `None` when the map carries no light.
    pub fn new(map: &LatLong) -> Option<EnvSampler> {
        let (w, h) = (map.width, map.height);
        if w == 0 || h == 0 || map.texels.len() != w * h {
            return None;
        }
        // Luminance per texel; anything not a finite non-negative number counts as 0.
        let lum: Vec<f64> = map
            .texels
            .iter()
            .map(|t| {
                let y = luminance(t.map(f64::from));
                if y.is_finite() && y > 0.0 { y } else { 0.0 }
            })
            .collect();
        let at = |x: usize, y: usize| lum[y * w + x];
        // Mean over each texel of the bilinear reconstruction: (⅛, ¾, ⅛) along each axis.
        const TAP: [f64; 3] = [0.125, 0.75, 0.125];
        let mut mean = vec![0.0f64; w * h];
        for y in 0..h {
            let ys = [y.saturating_sub(1), y, (y + 1).min(h - 1)];
            for x in 0..w {
                let xs = [(x + w - 1) % w, x, (x + 1) % w];
                let mut s = 0.0;
                for (yy, ay) in ys.iter().zip(TAP) {
                    for (xx, ax) in xs.iter().zip(TAP) {
                        s += ay * ax * at(*xx, *yy);
                    }
                }
                mean[y * w + x] = s;
            }
        }
        let dphi = 2.0 * PI / w as f64;
        let half = PI / (2.0 * h as f64);
        let cos_spans: Vec<f64> = (0..h)
            .map(|y| 2.0 * (half * (2 * y + 1) as f64).sin() * half.sin())
            .collect();
        let cos_edges: Vec<f64> = (0..=h).map(|y| (PI * y as f64 / h as f64).cos()).collect();
        let mut rows = Vec::with_capacity(h + 1);
        let mut columns = Vec::with_capacity(h * (w + 1));
        rows.push(0.0);
        for y in 0..h {
            let row = &mean[y * w..(y + 1) * w];
            let sum: f64 = row.iter().sum();
            columns.push(0.0);
            let mut acc = 0.0;
            for (x, m) in row.iter().enumerate() {
                acc += m;
                // A dark row is never drawn; keep its CDF well formed (uniform).
                columns.push(if sum > 0.0 {
                    acc / sum
                } else {
                    (x + 1) as f64 / w as f64
                });
            }
            columns[y * (w + 1) + w] = 1.0;
            rows.push(rows[y] + sum * dphi * cos_spans[y]);
        }
        let total = rows[h];
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        for r in &mut rows {
            *r /= total;
        }
        rows[h] = 1.0;
        let first = mean[0];
        let uniform = mean.iter().all(|m| *m == first);
        let density = mean.iter().map(|m| m / total).collect();
        Some(EnvSampler {
            power: total,
            width: w,
            height: h,
            rows,
            columns,
            density,
            cos_edges,
            cos_spans,
            uniform,
        })
    }

    /// The built-in sky tabulated at the centers of a
    /// `SKY_TABLE.0 × SKY_TABLE.1` lat-long grid: only a proposal (the sky itself stays
    /// analytic), so its coarseness costs variance, not bias.
    pub fn for_sky(sky: &Sky) -> Option<EnvSampler> {
        let (w, h) = SKY_TABLE;
        let probe = LatLong {
            width: w,
            height: h,
            texels: vec![[0.0; 3]; w * h],
        };
        let texels = (0..w * h)
            .map(|i| {
                let (d, _) = probe.texel_direction(i % w, i / w);
                sky.radiance(d).map(|c| c as f32)
            })
            .collect();
        EnvSampler::new(&LatLong {
            width: w,
            height: h,
            texels,
        })
    }

    /// The sampler of a distant environment: its map's, or the tabulated sky's.
    pub fn for_distant(distant: &Distant) -> Option<EnvSampler> {
        match distant {
            Distant::Map(m) => EnvSampler::new(m),
            Distant::Sky(s) => EnvSampler::for_sky(s),
        }
    }

    /// `∫ Y(ω) dω` of the map (luminance, Rec. 709): the light it brings to a point, in
    /// the units of a sun's irradiance.
    pub fn power(&self) -> f64 {
        self.power
    }

    /// True when the density is the same everywhere (`1/4π`): a map of constant
    /// luminance, which the phase function already samples as well as it can be.
    pub fn is_uniform(&self) -> bool {
        self.uniform
    }

    /// A direction drawn from the distribution for `u1, u2 ∈ [0, 1)`, with its density
    /// per steradian (that of the texel it was drawn in, always > 0).
    pub fn sample(&self, u1: f64, u2: f64) -> ([f64; 3], f64) {
        let (y, ty) = pick(&self.rows, u1);
        let w1 = self.width + 1;
        let (x, tx) = pick(&self.columns[y * w1..(y + 1) * w1], u2);
        let phi = 2.0 * PI * (x as f64 + tx) / self.width as f64;
        let cos_t = (self.cos_edges[y] - ty * self.cos_spans[y]).clamp(-1.0, 1.0);
        let sin_t = ((1.0 - cos_t) * (1.0 + cos_t)).max(0.0).sqrt();
        let d = [sin_t * phi.cos(), sin_t * phi.sin(), cos_t];
        (d, self.density[y * self.width + x])
    }

    /// The density per steradian of direction `d` (any length; the zero vector is the
    /// zenith).
    pub fn pdf(&self, d: [f64; 3]) -> f64 {
        let (theta, phi) = angles(d);
        let x = ((phi / (2.0 * PI) * self.width as f64) as usize).min(self.width - 1);
        let y = ((theta / PI * self.height as f64) as usize).min(self.height - 1);
        self.density[y * self.width + x]
    }
}

/// The bin `i` of a CDF (`cdf[0] = 0`, last = 1, non-decreasing) with
/// `cdf[i] ≤ u < cdf[i+1]` — so never a bin of zero mass — and `u`'s position in it,
/// in `[0, 1)`.
fn pick(cdf: &[f64], u: f64) -> (usize, f64) {
    let bins = cdf.len() - 1;
    let i = cdf.partition_point(|c| *c <= u).clamp(1, bins) - 1;
    let span = cdf[i + 1] - cdf[i];
    let t = if span > 0.0 {
        ((u - cdf[i]) / span).clamp(0.0, 1.0 - f64::EPSILON / 2.0)
    } else {
        0.5
    };
    (i, t)
}

/// The power heuristic (β = 2) weight of a strategy of density `a` combined with one of
/// density `b`, one sample each: `a²/(a² + b²)`, 0 when `a = 0`.
pub(crate) fn power_heuristic(a: f64, b: f64) -> f64 {
    if a > 0.0 {
        let r = b / a;
        1.0 / (1.0 + r * r)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// The cell `(x, y)` of a `w × h` lat-long grid containing direction `d`.
    fn cell_of(d: [f64; 3], w: usize, h: usize) -> (usize, usize) {
        let (theta, phi) = angles(d);
        let x = ((phi / (2.0 * PI) * w as f64) as usize).min(w - 1);
        let y = ((theta / PI * h as f64) as usize).min(h - 1);
        (x, y)
    }

    /// Solid angle of row `y` of a `w × h` lat-long grid's cells.
    fn cell_solid_angle(y: usize, w: usize, h: usize) -> f64 {
        let (t0, t1) = (PI * y as f64 / h as f64, PI * (y + 1) as f64 / h as f64);
        2.0 * PI / w as f64 * (t0.cos() - t1.cos())
    }

    /// The mean luminance over texel `(x, y)` of what `map.radiance` returns, computed
    /// from the lookups themselves: the midpoints of the texel's four half-texel quarters
    /// in (φ, θ). The lookup is bilinear on each quarter (its kinks are on the texel
    /// centers), where the midpoint rule is exact.
    fn looked_up_mean(map: &LatLong, x: usize, y: usize) -> f64 {
        let (w, h) = (map.width as f64, map.height as f64);
        let mut s = 0.0;
        for (fx, fy) in [(0.25, 0.25), (0.75, 0.25), (0.25, 0.75), (0.75, 0.75)] {
            let d =
                crate::distant::direction(PI * (y as f64 + fy) / h, 2.0 * PI * (x as f64 + fx) / w);
            s += 0.25 * luminance(map.radiance(d));
        }
        s
    }

    /// Checks a sampler against the map it was built from:
    /// 1. its density at each texel center is the looked-up mean luminance over the
    ///    normalization `Σ mean·Ω` (1e-9: both are sums of a few products);
    /// 2. `∫ pdf dω = 1` by quadrature on 4 × 4 sub-cells per texel, each of exact solid
    ///    angle, `pdf` looked up at the sub-cell centers (1e-9);
    /// 3. `n` drawn directions are unit, lie in texels of positive density, carry the
    ///    density `pdf` gives them, and their histogram over the quarters of the texels
    ///    (halved in φ and θ, so that the spread inside a texel is checked too) follows
    ///    `P = mean·Ω_quarter/Σ`: Pearson's χ² over the quarters expecting ≥ 5 samples
    ///    (the rest pooled into one bin), which for `k` bins has mean `k − 1` and
    ///    standard deviation `√(2(k − 1))`; the bound is that mean plus 6 standard
    ///    deviations (a correct sampler exceeds it with probability < 1e-5 whatever the
    ///    seed).
    fn check_sampler(map: &LatLong, n: usize) -> EnvSampler {
        let s = EnvSampler::new(map).expect("a map with light");
        let (w, h) = (map.width, map.height);
        let mut p = vec![0.0; w * h];
        for y in 0..h {
            for x in 0..w {
                p[y * w + x] = looked_up_mean(map, x, y) * map.texel_direction(x, y).1;
            }
        }
        let total: f64 = p.iter().sum();
        p.iter_mut().for_each(|v| *v /= total);
        for y in 0..h {
            for x in 0..w {
                let (d, omega) = map.texel_direction(x, y);
                let want = p[y * w + x] / omega;
                let got = s.pdf(d);
                assert!(
                    (got - want).abs() <= 1e-9 * want.max(1e-300),
                    "texel ({x}, {y}): density {got} vs {want}"
                );
            }
        }
        let k = 4;
        let mut integral = 0.0;
        for sy in 0..h * k {
            let (t0, t1) = (
                PI * sy as f64 / (h * k) as f64,
                PI * (sy + 1) as f64 / (h * k) as f64,
            );
            let omega = 2.0 * PI / (w * k) as f64 * (t0.cos() - t1.cos());
            for sx in 0..w * k {
                let phi = 2.0 * PI * (sx as f64 + 0.5) / (w * k) as f64;
                integral += s.pdf(crate::distant::direction(0.5 * (t0 + t1), phi)) * omega;
            }
        }
        assert!((integral - 1.0).abs() < 1e-9, "∫pdf dω = {integral}");
        let mut rng = Pcg64::seed_from_u64(11);
        let (qw, qh) = (2 * w, 2 * h);
        let mut counts = vec![0usize; qw * qh];
        for _ in 0..n {
            let (d, pdf) = s.sample(rng.random(), rng.random());
            let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            assert!((norm - 1.0).abs() < 1e-12, "{d:?}");
            assert!(pdf > 0.0 && pdf.is_finite());
            assert!((pdf - s.pdf(d)).abs() <= 1e-12 * pdf, "{d:?}: {pdf}");
            let (x, y) = cell_of(d, w, h);
            assert!(p[y * w + x] > 0.0, "drawn in texel ({x}, {y}) of no light");
            let (qx, qy) = cell_of(d, qw, qh);
            counts[qy * qw + qx] += 1;
        }
        let quarter_p: Vec<f64> = (0..qw * qh)
            .map(|i| {
                let (qx, qy) = (i % qw, i / qw);
                p[(qy / 2) * w + qx / 2] * cell_solid_angle(qy, qw, qh)
                    / cell_solid_angle(qy / 2, w, h)
            })
            .collect();
        let (mut chi2, mut bins) = (0.0, 0usize);
        let (mut pooled_count, mut pooled_p) = (0usize, 0.0);
        for (c, pk) in counts.iter().zip(&quarter_p) {
            let e = *pk * n as f64;
            if e >= 5.0 {
                chi2 += (*c as f64 - e).powi(2) / e;
                bins += 1;
            } else {
                pooled_count += c;
                pooled_p += pk;
            }
        }
        if pooled_p * n as f64 >= 5.0 {
            let e = pooled_p * n as f64;
            chi2 += (pooled_count as f64 - e).powi(2) / e;
            bins += 1;
        }
        let dof = bins.saturating_sub(1) as f64;
        let bound = dof + 6.0 * (2.0 * dof).sqrt();
        eprintln!("{w}×{h}: χ² {chi2:.1} over {bins} bins (bound {bound:.1})");
        assert!(bins >= 2 && chi2 < bound, "χ² {chi2} over {bins} bins");
        s
    }

    #[test]
    fn a_map_with_a_bright_patch_and_a_black_ground_is_sampled_by_its_luminance() {
        // 32 × 16: a sky graded in colour and azimuth, a 3 × 2 patch 1000× brighter,
        // the lower quarter black (its texels must never be drawn, the bilinear
        // lookup's spill into the row above it must be), a bright texel at a pole.
        let (w, h) = (32, 16);
        let mut texels = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let t = if y >= 12 {
                    [0.0; 3]
                } else if (20..23).contains(&x) && (3..5).contains(&y) {
                    [300.0, 250.0, 200.0]
                } else if y == 0 && x == 5 {
                    [50.0, 50.0, 50.0]
                } else {
                    let a = 0.3 + 0.2 * (x as f32 * 0.4).sin();
                    [a, 0.5 * a, (y as f32) * 0.1]
                };
                texels.push(t);
            }
        }
        let map = LatLong::new(w, h, texels).unwrap();
        let s = check_sampler(&map, 400_000);
        assert!(!s.is_uniform());
        // The sampler's extremes stay finite and inside the sphere.
        for (u1, u2) in [
            (0.0, 0.0),
            (1.0 - f64::EPSILON, 1.0 - f64::EPSILON),
            (0.5, 0.0),
        ] {
            let (d, pdf) = s.sample(u1, u2);
            assert!(d.iter().all(|c| c.is_finite()) && pdf > 0.0 && pdf.is_finite());
        }
    }

    #[test]
    fn one_row_one_column_and_pole_heavy_maps_are_sampled_by_their_luminance() {
        // One row: the lookup varies in azimuth only.
        let row: Vec<[f32; 3]> = (0..8).map(|x| [x as f32, 1.0, 0.5]).collect();
        check_sampler(&LatLong::new(8, 1, row).unwrap(), 100_000);
        // One column: in polar angle only; its rows' solid angles differ by 20×.
        let col: Vec<[f32; 3]> = (0..12).map(|y| [1.0 + (y % 3) as f32, 0.2, 0.0]).collect();
        check_sampler(&LatLong::new(1, 12, col).unwrap(), 100_000);
        // Light only in the rows touching the poles, where sin θ → 0.
        let (w, h) = (16, 8);
        let poles: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let y = i / w;
                if y == 0 || y == h - 1 {
                    [1.0 + (i % 3) as f32, 1.0, 1.0]
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        check_sampler(&LatLong::new(w, h, poles).unwrap(), 100_000);
    }

    #[test]
    fn a_black_map_has_no_sampler_and_a_constant_one_is_uniform() {
        assert!(EnvSampler::new(&LatLong::new(4, 2, vec![[0.0; 3]; 8]).unwrap()).is_none());
        for (w, h) in [(1, 1), (6, 3)] {
            let s = EnvSampler::new(&LatLong::new(w, h, vec![[0.5, 2.0, 1.0]; w * h]).unwrap())
                .unwrap();
            assert!(s.is_uniform());
            for d in [[0.0, 0.0, 1.0], [0.3, -0.2, -0.9], [-1.0, 0.0, 0.0]] {
                assert!((s.pdf(d) - 1.0 / (4.0 * PI)).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn the_power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (1e-8, 3e5), (7.0, 0.0), (2.5, 2.5)] {
            let s = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((s - 1.0).abs() < 1e-12, "{a} {b}: {s}");
        }
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}
