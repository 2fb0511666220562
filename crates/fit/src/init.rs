//! Greedy initialization of a first frame: RBFs are placed one at a time at the voxel of
//! largest positive residual, with the weight of the residual there and a common initial
//! radius, and subtracted from the residual before the next is placed. It stops early when
//! no positive residual is left (a single-voxel frame gets one RBF).
//!
//! Initial radius: `r₀ = ½·(V/n)^⅓`, clamped to the radius bounds, where `V` is the volume
//! of the non-zero voxels (unit cube): `n` RBFs of that size roughly tile the smoke.
//!
//! The residual's maximum is tracked per 8³ brick, so each placement rescans only the
//! bricks its support touches.

use crate::bounds::Bounds;
use crate::grid::FitGrid;
use crate::objective::PARAMS_PER_RBF;
use haze_volume::Rbf;
use haze_volume::rbf::voxel_span;
use multiversion::multiversion;
use rayon::prelude::*;

const BRICK: usize = 8;

/// The initial radius for `n` RBFs on `grid` (see the module docs).
pub fn initial_radius(grid: &FitGrid, n: usize, bounds: &Bounds) -> f64 {
    let voxel = grid.h[0] * grid.h[1] * grid.h[2];
    let v = grid.nonzero.len() as f64 * voxel;
    let r = 0.5 * (v / n.max(1) as f64).cbrt();
    let (lo, hi) = bounds.radius_on(grid);
    if r.is_finite() { r.clamp(lo, hi) } else { lo }
}

/// Largest value of `r` per brick, and where.
struct BrickMax {
    nb: [usize; 3],
    best: Vec<(f64, usize)>,
}

impl BrickMax {
    fn new(grid: &FitGrid, r: &[f64]) -> BrickMax {
        let nb = grid.dims.map(|d| d.div_ceil(BRICK));
        let mut m = BrickMax {
            nb,
            best: vec![(f64::NEG_INFINITY, 0); nb[0] * nb[1] * nb[2]],
        };
        for b in 0..m.best.len() {
            m.rescan(grid, r, b);
        }
        m
    }

    fn rescan(&mut self, grid: &FitGrid, r: &[f64], b: usize) {
        let bx = b % self.nb[0];
        let by = (b / self.nb[0]) % self.nb[1];
        let bz = b / (self.nb[0] * self.nb[1]);
        let lo = [bx, by, bz].map(|v| v * BRICK);
        let mut best = (f64::NEG_INFINITY, 0);
        for z in lo[2]..(lo[2] + BRICK).min(grid.dims[2]) {
            for y in lo[1]..(lo[1] + BRICK).min(grid.dims[1]) {
                for x in lo[0]..(lo[0] + BRICK).min(grid.dims[0]) {
                    let i = grid.index(x, y, z);
                    if r[i] > best.0 {
                        best = (r[i], i);
                    }
                }
            }
        }
        self.best[b] = best;
    }

    /// The largest value and its voxel (lowest brick on ties).
    fn max(&self) -> (f64, usize) {
        self.best
            .iter()
            .copied()
            .fold((f64::NEG_INFINITY, 0), |m, b| if b.0 > m.0 { b } else { m })
    }

    /// Rescans the bricks that the voxel ranges `span` touch.
    fn update(&mut self, grid: &FitGrid, r: &[f64], span: [(usize, usize); 3]) {
        for bz in span[2].0 / BRICK..=span[2].1 / BRICK {
            for by in span[1].0 / BRICK..=span[1].1 / BRICK {
                for bx in span[0].0 / BRICK..=span[0].1 / BRICK {
                    self.rescan(grid, r, bx + self.nb[0] * (by + self.nb[1] * bz));
                }
            }
        }
    }
}

/// Subtracts one RBF (unit-cube parameters) from `r` over its support; returns the voxel
/// ranges touched.
pub(crate) fn subtract(grid: &FitGrid, r: &mut [f64], p: &[f64]) -> Option<[(usize, usize); 3]> {
    let rbf = Rbf::new([p[0], p[1], p[2]], p[3], p[4]);
    let s = rbf.support_radius();
    let mut span = [(0, 0); 3];
    for a in 0..3 {
        span[a] = voxel_span(p[a] - s, p[a] + s, 0.0, grid.h[a], grid.dims[a])?;
    }
    for z in span[2].0..=span[2].1 {
        for y in span[1].0..=span[1].1 {
            for x in span[0].0..=span[0].1 {
                let i = grid.index(x, y, z);
                r[i] -= rbf.eval(grid.center(i));
            }
        }
    }
    Some(span)
}

/// Up to `n` RBFs placed greedily (see the module docs), as a flat parameter vector.
pub fn greedy(grid: &FitGrid, n: usize, radius: f64, bounds: &Bounds) -> Vec<f64> {
    let mut params = Vec::with_capacity(n * PARAMS_PER_RBF);
    if grid.is_empty() || n == 0 {
        return params;
    }
    let mut r = grid.density.clone();
    let mut bricks = BrickMax::new(grid, &r);
    for _ in 0..n {
        let (value, i) = bricks.max();
        if value <= 0.0 {
            break;
        }
        let c = grid.center(i);
        let mut p = [c[0], c[1], c[2], radius, value];
        bounds.clamp(grid, &mut p);
        params.extend_from_slice(&p);
        if let Some(span) = subtract(grid, &mut r, &p) {
            bricks.update(grid, &r, span);
        }
    }
    params
}

/// Up to `n` RBFs of radius `radius` for the residual in `grid.density` (values of
/// either sign) by matching pursuit: an RBF `w·g_c` added to the fit lowers `ΣR²` by
/// `⟨R, g_c⟩² / ⟨g_c, g_c⟩` at its best weight `w = ⟨R, g_c⟩ / ⟨g_c, g_c⟩`, so the
/// centers are the largest maxima of the residual correlated with the Gaussian
/// (`R ⋆ g`, separable: one 1-D pass per axis, cut at `3r`), at least `1.5r` apart,
/// each with that weight (clamped to the bounds). Unlike [`greedy`], which puts an RBF on
/// the largest single voxel (often a spike that a Gaussian of the smallest radius still
/// overshoots), this places RBFs where they lower the error most.
pub fn matched(grid: &FitGrid, n: usize, radius: f64, bounds: &Bounds) -> Vec<f64> {
    matched_with_gains(grid, n, radius, bounds).0
}

/// [`matched`], with each RBF's predicted reduction of `ΣR²` (in the grid's normalized
/// density², summed over voxels): at the weight `w` it gets after clamping to the bounds,
/// `Σ(R − w·g)² = ΣR² − (2w⟨R, g⟩ − w²⟨g, g⟩)`, so the gain is `2w⟨R, g⟩ − w²⟨g, g⟩`
/// (`⟨R, g⟩²/⟨g, g⟩` where the weight is not clamped). Exact for one RBF on its own
/// away from the grid's edges (up to the kernel's cube cut-off against the RBF's ball); RBFs `1.5r` apart overlap a little, so a batch's gains add
/// up to slightly more than it removes before the joint minimization (which removes more).
pub fn matched_with_gains(
    grid: &FitGrid,
    n: usize,
    radius: f64,
    bounds: &Bounds,
) -> (Vec<f64>, Vec<f64>) {
    let mut params = Vec::with_capacity(n * PARAMS_PER_RBF);
    let mut gains = Vec::with_capacity(n);
    if grid.is_empty() || n == 0 || radius.is_nan() || radius <= 0.0 {
        return (params, gains);
    }
    let d = grid.dims;
    let taps = gaussian_taps(grid, radius);
    let norm: f64 = taps
        .iter()
        .map(|k| k.iter().map(|v| v * v).sum::<f64>())
        .product();
    let corr = correlate(grid, &taps);
    let candidates: Vec<(f64, usize)> = corr
        .iter()
        .enumerate()
        .filter(|(_, v)| **v > 0.0)
        .map(|(i, v)| (*v, i))
        .collect();
    let mut taken = vec![false; grid.len()];
    let keep = [0, 1, 2].map(|a| (1.5 * radius / grid.h[a]).ceil() as usize);
    // Each pick takes a box of this many voxels out: the first picks' share of the
    // candidates, sorted, is enough.
    let per_pick = keep.iter().map(|&k| 2 * k + 1).product::<usize>();
    for (v, i) in LargestFirst::new(candidates, n.saturating_mul(per_pick)) {
        if params.len() / PARAMS_PER_RBF >= n {
            break;
        }
        if taken[i] {
            continue;
        }
        let c = grid.center(i);
        let mut p = [c[0], c[1], c[2], radius, v / norm];
        bounds.clamp(grid, &mut p);
        params.extend_from_slice(&p);
        gains.push(2.0 * p[4] * v - p[4] * p[4] * norm);
        let x = [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])];
        let lo = [0, 1, 2].map(|a| x[a].saturating_sub(keep[a]));
        let hi = [0, 1, 2].map(|a| (x[a] + keep[a]).min(d[a] - 1));
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = grid.index(0, y, z);
                taken[row + lo[0]..=row + hi[0]].fill(true);
            }
        }
    }
    (params, gains)
}

/// `(value, index)` pairs in descending value (ascending index among equals), sorted a
/// batch at a time: the largest `batch` first, then twice as many of the rest, and so on,
/// so that a caller that stops after a few takes does not sort them all. The order is the
/// full sort's.
struct LargestFirst {
    items: Vec<(f64, usize)>,
    /// `items[..sorted]` are the largest, in order.
    sorted: usize,
    next: usize,
    batch: usize,
}

impl LargestFirst {
    fn new(items: Vec<(f64, usize)>, batch: usize) -> Self {
        LargestFirst {
            items,
            sorted: 0,
            next: 0,
            batch: batch.max(1),
        }
    }

    fn order(a: &(f64, usize), b: &(f64, usize)) -> std::cmp::Ordering {
        b.0.total_cmp(&a.0).then(a.1.cmp(&b.1))
    }
}

impl Iterator for LargestFirst {
    type Item = (f64, usize);

    fn next(&mut self) -> Option<(f64, usize)> {
        if self.next == self.sorted && self.sorted < self.items.len() {
            let rest = &mut self.items[self.sorted..];
            let k = self.batch.min(rest.len());
            if k < rest.len() {
                rest.select_nth_unstable_by(k - 1, Self::order);
            }
            rest[..k].sort_by(Self::order);
            self.sorted += k;
            self.batch = self.batch.saturating_mul(2);
        }
        let item = self.items.get(self.next).copied();
        self.next += usize::from(item.is_some());
        item
    }
}

/// Support of the correlation kernel, in radii (the RBFs' cut-off).
const CUTOFF_TAPS: f64 = haze_volume::rbf::CUTOFF;

/// Taps `exp(−(t·h)²/r²)` for `|t·h| < 3r`, per axis of `grid`.
fn gaussian_taps(grid: &FitGrid, radius: f64) -> [Vec<f64>; 3] {
    [0, 1, 2].map(|a| {
        let reach = (CUTOFF_TAPS * radius / grid.h[a]).floor() as isize;
        (-reach..=reach)
            .map(|t| (-(t as f64 * grid.h[a] / radius).powi(2)).exp())
            .collect()
    })
}

/// `grid.density` correlated with the separable kernel `taps`, one axis after another.
fn correlate(grid: &FitGrid, taps: &[Vec<f64>; 3]) -> Vec<f64> {
    let mut v = blur_axis(&grid.density, grid.dims, 0, &taps[0]);
    for (a, k) in taps.iter().enumerate().skip(1) {
        v = blur_axis(&v, grid.dims, a, k);
    }
    v
}

/// `v` correlated with the symmetric kernel `k` (odd length, centered) along axis `a`
/// of a grid of `dims` (x fastest); outside the grid counts as zero. Along `y` and `z`
/// whole x-rows are weighed and added, row after row (a voxel's taps in the same order
/// as along `x`, so the sums are the same to the bit), which reads memory in order where
/// a voxel-by-voxel walk would stride across the grid. Rows of zeros (the air around the
/// smoke) add nothing and are skipped.
fn blur_axis(v: &[f64], dims: [usize; 3], a: usize, k: &[f64]) -> Vec<f64> {
    let reach = k.len() / 2;
    let n = dims[a];
    let taps = |pos: usize| (pos.saturating_sub(reach), (pos + reach).min(n - 1));
    let mut out = vec![0.0; v.len()];
    let live: Vec<bool> = v
        .par_chunks(dims[0])
        .map(|row| row.iter().any(|&x| x != 0.0))
        .collect();
    if a == 0 {
        out.par_chunks_mut(dims[0])
            .zip(v.par_chunks(dims[0]))
            .zip(&live)
            .filter(|(_, live)| **live)
            .for_each(|((o, row), _)| correlate_row(o, row, k));
        return out;
    }
    let stride = if a == 1 { dims[0] } else { dims[0] * dims[1] };
    out.par_chunks_mut(dims[0]).enumerate().for_each(|(r, o)| {
        // Row r = y + dims₁ z; its place along the axis, and where the axis starts.
        let pos = if a == 1 { r % dims[1] } else { r / dims[1] };
        let start = r * dims[0] - pos * stride;
        let (lo, hi) = taps(pos);
        let rows = (lo..=hi).filter_map(|q| {
            let first = start + q * stride;
            live[first / dims[0]].then(|| (k[q + reach - pos], &v[first..first + dims[0]]))
        });
        add_weighted_rows(o, rows);
    });
    out
}

/// One x-row `row` correlated with the symmetric kernel `k` (odd length, centered) into
/// `o`, outside the row counting as zero: each voxel's taps added from the lowest, as
/// weighed whole rows (`o += k_t · row shifted by t`, `t` ascending) — every voxel's sum
/// the same operations in the same order as a tap-by-tap loop, but vectorizable.
///
/// Compiled for any x86-64 and for AVX2 (chosen at run time, `multiversion`; the same
/// bits either way, as `objective`'s passes).
#[multiversion(targets("x86_64+avx2+fma"))]
fn correlate_row(o: &mut [f64], row: &[f64], k: &[f64]) {
    let reach = k.len() / 2;
    let n = row.len();
    o.fill(0.0);
    for (t, &w) in k.iter().enumerate() {
        // Voxel `pos` takes `row[pos + t − reach]`: the voxels whose tap lies in the row.
        let lo = reach.saturating_sub(t);
        let hi = (n + reach).saturating_sub(t).min(n);
        if lo >= hi {
            continue;
        }
        let src = &row[lo + t - reach..hi + t - reach];
        for (o, &x) in o[lo..hi].iter_mut().zip(src) {
            *o += w * x;
        }
    }
}

/// `o += w · row` for each weighed row, in order (compiled for AVX2 too, as
/// [`correlate_row`]).
#[multiversion(targets("x86_64+avx2+fma"))]
fn add_weighted_rows<'a>(o: &mut [f64], rows: impl Iterator<Item = (f64, &'a [f64])>) {
    for (w, src) in rows {
        for (o, &x) in o.iter_mut().zip(src) {
            *o += w * x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::{Bbox, Volume};

    fn grid(dims: [usize; 3], f: impl Fn(usize, usize, usize) -> f32) -> FitGrid {
        let b = Bbox::new([0.0; 3], [dims[0] as f64, dims[1] as f64, dims[2] as f64]);
        let mut v = Volume::zeros(dims, b).unwrap();
        for i in 0..v.len() {
            let [x, y, z] = v.coords(i);
            v.data_mut()[i] = f(x, y, z);
        }
        FitGrid::from_volume(&v).unwrap()
    }

    /// Batches of the largest give the full sort's order, ties by index, whatever the
    /// batch.
    #[test]
    fn largest_first_is_the_full_sort() {
        let items: Vec<(f64, usize)> = (0..1000).map(|i| (((i * 7919) % 97) as f64, i)).collect();
        let mut want = items.clone();
        want.sort_by(LargestFirst::order);
        for batch in [0, 1, 3, 64, 999, 1000, 5000] {
            let got: Vec<_> = LargestFirst::new(items.clone(), batch).collect();
            assert_eq!(got, want, "batch {batch}");
        }
        assert_eq!(LargestFirst::new(Vec::new(), 4).next(), None);
    }

    /// The correlation pass against a brute-force `Σ_v R_v g(x_v − c)` with the same
    /// cut-off, at every voxel of a small random grid (edges included).
    #[test]
    fn separable_correlation_matches_brute_force() {
        // Dense, then with whole rows and planes of zeros (which the passes skip).
        for g in [
            grid([9, 7, 6], |x, y, z| ((x * 7 + y * 3 + z * 5) % 11) as f32),
            grid([9, 7, 6], |x, y, z| {
                if y % 3 == 1 || z == 2 {
                    0.0
                } else {
                    ((x * 5 + y + z * 3) % 7) as f32
                }
            }),
        ] {
            correlation_matches_brute_force(&g, 0.12);
        }
        // Kernels wider than the grid (reach 13 taps across 9, 7 and 6 voxels, and across
        // rows of one voxel): every tap that falls outside counts as zero.
        correlation_matches_brute_force(
            &grid([9, 7, 6], |x, y, z| (x + 2 * y + 3 * z) as f32),
            0.5,
        );
        correlation_matches_brute_force(&grid([1, 5, 4], |_, y, z| (1 + y + z) as f32), 0.5);
    }

    fn correlation_matches_brute_force(g: &FitGrid, r: f64) {
        let c = correlate(g, &gaussian_taps(g, r));
        for (i, &got) in c.iter().enumerate() {
            let p = g.center(i);
            let mut want = 0.0;
            for j in 0..g.len() {
                let q = g.center(j);
                let inside = (0..3).all(|a| (p[a] - q[a]).abs() < CUTOFF_TAPS * r + 1e-12);
                if inside {
                    let d2: f64 = (0..3).map(|a| (p[a] - q[a]).powi(2)).sum();
                    want += g.density[j] * (-d2 / (r * r)).exp();
                }
            }
            assert!((got - want).abs() < 1e-9 * want.abs().max(1.0), "voxel {i}");
        }
    }

    /// Matching pursuit puts one RBF on a Gaussian blob at its center with its weight,
    /// even beside a taller single-voxel spike (which the largest-voxel rule would take).
    #[test]
    fn matched_finds_the_blob_not_the_spike() {
        let blob = |x: usize, y: usize, z: usize| {
            let d2 = [x, y, z]
                .iter()
                .zip([8.0, 9.0, 10.0])
                .map(|(&v, c)| (v as f64 + 0.5 - c - 0.5).powi(2))
                .sum::<f64>();
            0.6 * (-d2 / 6.25).exp()
        };
        let g = grid([20, 20, 20], |x, y, z| {
            if (x, y, z) == (16, 3, 3) {
                1.0
            } else {
                blob(x, y, z) as f32
            }
        });
        let r = 2.5 / 20.0;
        let bounds = Bounds {
            radius: (0.01, 0.2),
            ..Bounds::default()
        };
        let p = matched(&g, 1, r, &bounds);
        let want = g.center(g.index(8, 9, 10));
        for a in 0..3 {
            assert!((p[a] - want[a]).abs() < 1e-12, "{p:?}");
        }
        assert!((p[4] - 0.6).abs() < 0.02, "weight {}", p[4]);
        // More RBFs keep at least 1.5 r apart.
        let p = matched(&g, 6, r, &bounds);
        assert_eq!(p.len(), 30);
        for (i, a) in p.chunks(5).enumerate() {
            for b in p.chunks(5).skip(i + 1) {
                let far = (0..3).any(|k| (a[k] - b[k]).abs() >= 1.5 * r - 1e-9);
                assert!(far, "{a:?} {b:?}");
            }
        }
        assert!(matched(&grid([4, 4, 4], |_, _, _| 0.0), 3, r, &bounds).is_empty());
    }

    /// The predicted gain is `ΣR² − Σ(R − w·g)²` summed by brute force over the grid, for
    /// an RBF away from the edges, with its weight free and clamped by the bounds.
    #[test]
    fn predicted_gain_is_the_drop_of_the_squared_residual() {
        let g = grid([24, 24, 24], |x, y, z| {
            let d2 = [x, y, z]
                .iter()
                .zip([11.0, 12.0, 12.5])
                .map(|(&v, c)| (v as f64 + 0.5 - c).powi(2))
                .sum::<f64>();
            (0.8 * (-d2 / 9.0).exp() + 0.05 * ((x * 5 + y * 3 + z) % 4) as f64) as f32
        });
        let r = 2.0 / 24.0;
        for weight in [(0.01, 1.0), (0.01, 0.3)] {
            let bounds = Bounds {
                radius: (0.01, 0.2),
                weight,
            };
            let (p, gains) = matched_with_gains(&g, 1, r, &bounds);
            let mut after = g.density.clone();
            subtract(&g, &mut after, &p).unwrap();
            let before: f64 = g.density.iter().map(|v| v * v).sum();
            let after: f64 = after.iter().map(|v| v * v).sum();
            let want = before - after;
            assert!(want > 0.0);
            // The correlation kernel is cut per axis at 3r (a cube), the RBF at a ball of
            // 3r: the corners between carry values below e^−9 ≈ 1.2e-4 of the peak.
            assert!(
                (gains[0] - want).abs() < 1e-3 * want,
                "{} vs {want}",
                gains[0]
            );
        }
    }
}
