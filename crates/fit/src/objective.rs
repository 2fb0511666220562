//! The fitting objective of paper A §5.1 and its analytic gradient.
//!
//! With parameters `θ = (c_l, r_l, w_l)` of `n` RBFs, `e_lv = exp(−|x_v − c_l|²/r_l²)` inside
//! the `3r_l` sphere (0 outside), `D̃_v = Σ_l w_l e_lv` and `R_v = D_v − D̃_v`:
//!
//! ```text
//! f(θ)      = Σ_v R_v² / Σ_v D_v²                   (relative squared error, rel_l2²)
//! ∂f/∂w_l   = −2 Σ_v R_v e_lv / ΣD²
//! ∂f/∂c_l,a = −4 w_l Σ_v R_v e_lv (x_v,a − c_l,a) / (r_l² ΣD²)
//! ∂f/∂r_l   = −4 w_l Σ_v R_v e_lv |x_v − c_l|² / (r_l³ ΣD²)
//! ```
//!
//! The cut-off makes `f` piecewise smooth; the jump at the sphere is `w·e⁻⁹`, far below the
//! fit's error, and is ignored by the gradient.
//!
//! Evaluation is separable: `e_lv = ex_l[i]·ey_l[j]·ez_l[k]`, so each RBF gets three small
//! 1-D tables per pass and the inner loops are one multiply-add per voxel, with no `exp`.
//! The pass runs in parallel over z-planes, without atomics or locks: per plane, gather
//! the RBFs whose support meets the plane, copy `D` on the rows they reach, subtract `D̃`
//! there to get `R`, accumulate the plane's share of `Σ(R² − D²)` (outside every support
//! `R = D`, so `ΣR² = ΣD² + Σ_reached(R² − D²)` touches only the voxels the RBFs reach,
//! not the whole grid), and, for a gradient, each listed RBF's share of its five sums
//! over the plane while the plane's `R` is in cache. Partial sums are combined in plane
//! order, so results do not depend on the thread count.

use crate::grid::FitGrid;
use haze_volume::rbf::{CUTOFF, voxel_span};
use multiversion::multiversion;
use rayon::prelude::*;

/// Parameters per RBF in the flat parameter vector: `cx, cy, cz, r, w`.
pub const PARAMS_PER_RBF: usize = 5;

const CUT2: f64 = CUTOFF * CUTOFF;

/// One axis of one RBF's support: voxel range and per-voxel tables, the three tables in
/// one allocation (a pass builds them for every RBF).
#[derive(Debug, Default, Clone)]
struct Axis {
    lo: usize,
    /// Position of the smallest `q`: `q` does not increase up to it and does not
    /// decrease after it (rounding is monotone, so this holds in floating point too).
    mid: usize,
    /// Voxels on the axis.
    n: usize,
    /// `d`, then `q`, then `e` (see their accessors).
    v: Vec<f64>,
}

impl Axis {
    fn new(c: f64, r: f64, h: f64, n: usize) -> Option<Axis> {
        let s = CUTOFF * r;
        let (lo, hi) = voxel_span(c - s, c + s, 0.0, h, n)?;
        let n = hi + 1 - lo;
        let mut v = vec![0.0; 3 * n];
        let mut mid = 0;
        for k in 0..n {
            let d = ((lo + k) as f64 + 0.5) * h - c;
            let q = (d / r) * (d / r);
            v[k] = d;
            v[n + k] = q;
            v[2 * n + k] = (-q).exp();
            if q < v[n + mid] {
                mid = k;
            }
        }
        Some(Axis { lo, mid, n, v })
    }

    /// `x_i − c` for voxel `lo + k`.
    fn d(&self) -> &[f64] {
        &self.v[..self.n]
    }

    /// `(x_i − c)² / r²`.
    fn q(&self) -> &[f64] {
        &self.v[self.n..2 * self.n]
    }

    /// `exp(−q)`.
    fn e(&self) -> &[f64] {
        &self.v[2 * self.n..]
    }

    fn hi(&self) -> usize {
        self.lo + self.n - 1
    }
}

/// The separable tables of one RBF for one pass.
#[derive(Debug, Clone)]
struct Tables {
    w: f64,
    r: f64,
    axes: [Axis; 3],
    /// For the x-row at table positions `(j, k)`, entry `k·ny + j`: the table positions
    /// `[a, b)` inside the sphere ([`SphereRows`]; empty: `a ≥ b`). Found once per pass
    /// and read by both halves of it.
    rows: Vec<(u32, u32)>,
}

impl Tables {
    /// `None` when the RBF touches no voxel center.
    fn new(grid: &FitGrid, p: &[f64]) -> Option<Tables> {
        let (c, r, w) = ([p[0], p[1], p[2]], p[3], p[4]);
        if !(r > 0.0 && r.is_finite()) {
            return None;
        }
        let x = Axis::new(c[0], r, grid.h[0], grid.dims[0])?;
        let y = Axis::new(c[1], r, grid.h[1], grid.dims[1])?;
        let z = Axis::new(c[2], r, grid.h[2], grid.dims[2])?;
        let rows = sphere_rows(&x, &y, &z);
        Some(Tables {
            w,
            r,
            axes: [x, y, z],
            rows,
        })
    }
}

/// The x-rows of one RBF's sphere: for the row `(j, k)`, the table positions `i` with
/// `qx_i + s < 9`, `s = qy_j + qz_k`.
///
/// `qx` does not increase up to `mid` and does not decrease after it, so the row is one
/// range `[a, b)`: `a` the length of the left half's prefix where `q + s ≥ 9`,
/// `b − mid − 1` that of the right half's prefix where `q + s < 9` (both prefixes by
/// monotone rounding). Each prefix's length is the count of its half's entries that pass
/// the test — the per-voxel test's range exactly, found without a branch per voxel: a
/// row is 5–46 voxels across, and a walk from the previous row's ends, branching at
/// every step, was a fifth of a warm frame (BENCHMARKS.md).
struct SphereRows<'a> {
    left: &'a [f64],
    right: &'a [f64],
}

impl<'a> SphereRows<'a> {
    fn new(ax: &'a Axis) -> Self {
        let (left, right) = ax.q().split_at(ax.mid + 1);
        SphereRows { left, right }
    }

    /// Table positions of the x-row with `s = qy + qz` whose voxels lie inside the sphere
    /// (`None`: no voxel).
    #[inline(always)]
    fn row(&self, s: f64) -> Option<(usize, usize)> {
        let a: usize = self.left.iter().map(|&q| usize::from(q + s >= CUT2)).sum();
        if a == self.left.len() {
            return None;
        }
        let b: usize = self.right.iter().map(|&q| usize::from(q + s < CUT2)).sum();
        Some((a, self.left.len() + b))
    }
}

/// Every x-row's range ([`SphereRows`]) of the sphere with axes `ax, ay, az`, entry
/// `k·ny + j` for the row at table positions `(j, k)` (empty: `(0, 0)`).
///
/// Compiled for any x86-64 and for AVX2 (chosen at run time, `multiversion`; the same
/// ranges either way: the counts are exact).
#[multiversion(targets("x86_64+avx2+fma"))]
fn sphere_rows(ax: &Axis, ay: &Axis, az: &Axis) -> Vec<(u32, u32)> {
    let rows = SphereRows::new(ax);
    let mut out = Vec::with_capacity(ay.q().len() * az.q().len());
    for &qz in az.q() {
        for &qy in ay.q() {
            let s = qy + qz;
            out.push(match (s < CUT2).then(|| rows.row(s)).flatten() {
                Some((a, b)) => (a as u32, b as u32),
                None => (0, 0),
            });
        }
    }
    out
}

fn tables(grid: &FitGrid, params: &[f64]) -> Vec<Option<Tables>> {
    params
        .par_chunks(PARAMS_PER_RBF)
        .map(|p| Tables::new(grid, p))
        .collect()
}

/// For each z-plane, the RBFs whose support meets it.
fn plane_lists(grid: &FitGrid, t: &[Option<Tables>]) -> Vec<Vec<u32>> {
    let mut lists = vec![Vec::new(); grid.dims[2]];
    for (l, tab) in t.iter().enumerate() {
        if let Some(tab) = tab {
            for list in &mut lists[tab.axes[2].lo..=tab.axes[2].hi()] {
                list.push(l as u32);
            }
        }
    }
    lists
}

/// Subtracts `D̃` of the RBFs in `list` from one z-plane `out` (x fastest). Inlined into
/// its callers, so that it is compiled for the CPU features they are ([`plane_share`]).
#[inline(always)]
fn subtract_plane(grid: &FitGrid, t: &[Option<Tables>], z: usize, list: &[u32], out: &mut [f64]) {
    for &l in list {
        let Some(tab) = &t[l as usize] else { continue };
        let [ax, ay, az] = &tab.axes;
        let kz = z - az.lo;
        let ez = az.e()[kz];
        let rows = &tab.rows[kz * ay.q().len()..(kz + 1) * ay.q().len()];
        for (jy, (&ey, &(a, b))) in ay.e().iter().zip(rows).enumerate() {
            let (a, b) = (a as usize, b as usize);
            if a >= b {
                continue;
            }
            let f = tab.w * ey * ez;
            let row = grid.dims[0] * (ay.lo + jy) + ax.lo;
            for (o, &ex) in out[row + a..row + b].iter_mut().zip(&ax.e()[a..b]) {
                *o -= f * ex;
            }
        }
    }
}

/// For each x-row of one z-plane, a voxel range `[lo, hi)` that holds every voxel the
/// RBFs in `list` reach on it (the union of their bounding boxes' rows; empty: `lo ≥ hi`).
fn row_spans(grid: &FitGrid, t: &[Option<Tables>], list: &[u32]) -> Vec<(usize, usize)> {
    let mut spans = vec![(usize::MAX, 0); grid.dims[1]];
    for &l in list {
        let Some(tab) = &t[l as usize] else { continue };
        let [ax, ay, _] = &tab.axes;
        for span in &mut spans[ay.lo..=ay.hi()] {
            span.0 = span.0.min(ax.lo);
            span.1 = span.1.max(ax.hi() + 1);
        }
    }
    spans
}

/// A residual buffer kept from pass to pass, so that a pass touches only the voxels the
/// RBFs reach: with the fitted radii of 1–2 voxels that is a small part of a 128³ grid,
/// and copying and summing the whole grid each pass was most of its time (BENCHMARKS.md).
#[derive(Debug, Default, Clone)]
pub struct Scratch {
    r: Vec<f64>,
}

/// `Σ R²` (unnormalized) with `R = D − D̃` written into `scratch` on the rows of the RBFs'
/// bounding boxes ([`row_spans`]); the other entries are left as they were and
/// hold no meaning. Outside the RBFs `R = D`, so
/// `ΣR² = ΣD² + Σ_reached (R² − D²)`, with `ΣD²` the grid's `sum_sq`.
///
/// With `sums`, also each RBF's five gradient sums ([`Sums`]), accumulated plane by plane
/// while the plane's residual is still in cache (a second walk over each RBF's sphere
/// read `R` from memory in the RBFs' order, scattered over the grid); the planes' shares
/// are added in plane order, so the sums do not depend on the thread count.
fn residual_reached(
    grid: &FitGrid,
    t: &[Option<Tables>],
    scratch: &mut Scratch,
    sums: Option<&mut [Sums]>,
) -> f64 {
    let lists = plane_lists(grid, t);
    let plane = grid.dims[0] * grid.dims[1];
    let r = &mut scratch.r;
    r.resize(grid.len(), 0.0);
    if plane == 0 {
        return 0.0;
    }
    let with_sums = sums.is_some();
    let partial: Vec<(f64, Vec<Sums>)> = r
        .par_chunks_mut(plane)
        .zip(grid.density.par_chunks(plane))
        .zip(lists.par_iter())
        .enumerate()
        .map(|(z, ((out, density), list))| {
            if list.is_empty() {
                return (0.0, Vec::new());
            }
            plane_share(grid, t, z, list, out, density, with_sums)
        })
        .collect();
    if let Some(sums) = sums {
        sums.fill(Sums::default());
        for (list, (_, part)) in lists.iter().zip(&partial) {
            for (&l, p) in list.iter().zip(part) {
                sums[l as usize].add(p);
            }
        }
    }
    // Rounding can take a perfect fit a hair below zero.
    (grid.sum_sq + partial.iter().map(|p| p.0).sum::<f64>()).max(0.0)
}

/// One z-plane's share of a pass ([`residual_reached`]): `R` written into `out` on the rows
/// the RBFs of `list` reach, `Σ (R² − D²)` over them and, `with_sums`, each listed RBF's
/// [`Sums`] on the plane.
///
/// Compiled twice, for any x86-64 and for AVX2 (chosen once at run time, `multiversion`):
/// the loops are the same operations in the same order either way (Rust never fuses or
/// reorders floating-point operations), so both give the same bits; AVX2 runs the rows'
/// interleaved sums four lanes at a time instead of two.
#[multiversion(targets("x86_64+avx2+fma"))]
fn plane_share(
    grid: &FitGrid,
    t: &[Option<Tables>],
    z: usize,
    list: &[u32],
    out: &mut [f64],
    density: &[f64],
    with_sums: bool,
) -> (f64, Vec<Sums>) {
    let spans = row_spans(grid, t, list);
    for (y, &(lo, hi)) in spans.iter().enumerate() {
        if lo < hi {
            let row = grid.dims[0] * y;
            out[row + lo..row + hi].copy_from_slice(&density[row + lo..row + hi]);
        }
    }
    subtract_plane(grid, t, z, list, out);
    let mut delta = 0.0;
    for (y, &(lo, hi)) in spans.iter().enumerate() {
        if lo < hi {
            let row = grid.dims[0] * y;
            delta += row_delta(&out[row + lo..row + hi], &density[row + lo..row + hi]);
        }
    }
    let sums = if with_sums {
        list.iter()
            .map(|&l| match &t[l as usize] {
                Some(tab) => plane_sums(grid, tab, z, out),
                None => Sums::default(),
            })
            .collect()
    } else {
        Vec::new()
    };
    (delta, sums)
}

/// `Σ (R² − D²)` over one row, in four interleaved partial sums (one running sum waits
/// on the previous addition at every voxel).
#[inline(always)]
fn row_delta(r: &[f64], d: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (rc, dc) = (r.chunks_exact(4), d.chunks_exact(4));
    let tail: f64 = rc
        .remainder()
        .iter()
        .zip(dc.remainder())
        .map(|(&r, &d)| r * r - d * d)
        .sum();
    for (r4, d4) in rc.zip(dc) {
        for k in 0..4 {
            acc[k] += r4[k] * r4[k] - d4[k] * d4[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// One RBF's gradient sums over the voxels of its sphere, with `R` the residual and
/// `e, d_a, q` its tables: `S0 = Σ R e`, `S_a = Σ R e d_a`, `Sq = Σ R e q`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sums([f64; 5]);

impl Sums {
    fn add(&mut self, o: &Sums) {
        for (a, b) in self.0.iter_mut().zip(&o.0) {
            *a += b;
        }
    }
}

/// The share of [`Sums`] of one RBF on the z-plane `z`, whose residual is `plane`.
#[inline(always)]
fn plane_sums(grid: &FitGrid, tab: &Tables, z: usize, plane: &[f64]) -> Sums {
    let [ax, ay, az] = &tab.axes;
    let kz = z - az.lo;
    let (dz, qz, ez) = (az.d()[kz], az.q()[kz], az.e()[kz]);
    let (mut s0, mut sx, mut sy, mut sq) = (0.0, 0.0, 0.0, 0.0);
    let rows = &tab.rows[kz * ay.q().len()..(kz + 1) * ay.q().len()];
    let table = ay.d().iter().zip(ay.q()).zip(ay.e()).zip(rows);
    for (jy, (((&dy, &qy), &ey), &(a, b))) in table.enumerate() {
        let (a, b) = (a as usize, b as usize);
        if a >= b {
            continue;
        }
        let s = qy + qz;
        let row = grid.dims[0] * (ay.lo + jy) + ax.lo;
        let [t0, t1, t2] = row_sums(
            &plane[row + a..row + b],
            &ax.e()[a..b],
            &ax.d()[a..b],
            &ax.q()[a..b],
        );
        let f = ey * ez;
        s0 += f * t0;
        sx += f * t1;
        sy += f * dy * t0;
        sq += f * (t2 + s * t0);
    }
    Sums([s0, sx, sy, dz * s0, sq])
}

/// `(Σ R e, Σ R e d, Σ R e q)` over one row, in interleaved partial sums.
#[inline(always)]
fn row_sums(r: &[f64], e: &[f64], d: &[f64], q: &[f64]) -> [f64; 3] {
    const L: usize = 4;
    let mut acc = [[0.0; L]; 3];
    let n = r.len() / L * L;
    for i in (0..n).step_by(L) {
        for k in 0..L {
            let re = r[i + k] * e[i + k];
            acc[0][k] += re;
            acc[1][k] += re * d[i + k];
            acc[2][k] += re * q[i + k];
        }
    }
    let mut out = acc.map(|a| (a[0] + a[1]) + (a[2] + a[3]));
    for i in n..r.len() {
        let re = r[i] * e[i];
        out[0] += re;
        out[1] += re * d[i];
        out[2] += re * q[i];
    }
    out
}

/// The residual `D − D̃` of the normalized density (x fastest).
pub fn residual(grid: &FitGrid, params: &[f64]) -> Vec<f64> {
    let t = tables(grid, params);
    let lists = plane_lists(grid, &t);
    let plane = grid.dims[0] * grid.dims[1];
    let mut r = grid.density.clone();
    if plane > 0 {
        r.par_chunks_mut(plane)
            .zip(lists.par_iter())
            .enumerate()
            .for_each(|(z, (out, list))| subtract_list(grid, &t, z, list, out));
    }
    r
}

/// [`subtract_plane`] compiled for any x86-64 and for AVX2, as [`plane_share`] is.
#[multiversion(targets("x86_64+avx2+fma"))]
fn subtract_list(grid: &FitGrid, t: &[Option<Tables>], z: usize, list: &[u32], out: &mut [f64]) {
    subtract_plane(grid, t, z, list, out);
}

/// `f(θ)` = ΣR² / ΣD² (0 for an all-zero frame).
pub fn cost(grid: &FitGrid, params: &[f64]) -> f64 {
    cost_with(grid, params, &mut Scratch::default())
}

/// [`cost`] with a residual buffer reused across calls.
pub fn cost_with(grid: &FitGrid, params: &[f64], scratch: &mut Scratch) -> f64 {
    let e = residual_reached(grid, &tables(grid, params), scratch, None);
    normalize(grid, e)
}

fn normalize(grid: &FitGrid, e: f64) -> f64 {
    if grid.sum_sq > 0.0 {
        e / grid.sum_sq
    } else {
        e
    }
}

/// [`cost_and_gradient_with`] with a fresh buffer.
pub fn cost_and_gradient(grid: &FitGrid, params: &[f64], grad: &mut [f64]) -> f64 {
    cost_and_gradient_with(grid, params, grad, &mut Scratch::default())
}

/// `f(θ)` and its gradient (written into `grad`, same layout as `params`) in one pass,
/// reusing `scratch` for the residual.
pub fn cost_and_gradient_with(
    grid: &FitGrid,
    params: &[f64],
    grad: &mut [f64],
    scratch: &mut Scratch,
) -> f64 {
    let t = tables(grid, params);
    let mut sums = vec![Sums::default(); t.len()];
    let e = residual_reached(grid, &t, scratch, Some(&mut sums));
    let scale = if grid.sum_sq > 0.0 {
        1.0 / grid.sum_sq
    } else {
        1.0
    };
    for ((g, tab), Sums([s0, sx, sy, sz, sq])) in grad.chunks_mut(PARAMS_PER_RBF).zip(&t).zip(sums)
    {
        g.fill(0.0);
        let Some(tab) = tab else { continue };
        let (w, rr) = (tab.w, tab.r);
        let k = -4.0 * w * scale / (rr * rr);
        g[0] = k * sx;
        g[1] = k * sy;
        g[2] = k * sz;
        g[3] = k * sq * rr;
        g[4] = -2.0 * s0 * scale;
    }
    normalize(grid, e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::{Bbox, Volume, rbf};

    /// `D̃` of `params` (unit-cube parameters) on every voxel of `g`, by the independent
    /// reference evaluation of `haze_volume::rbf`.
    fn reference_sum(g: &FitGrid, params: &[f64]) -> Vec<f64> {
        let rbfs: Vec<_> = params
            .chunks(5)
            .map(|p| haze_volume::Rbf::new([p[0], p[1], p[2]], p[3], p[4]))
            .collect();
        let ext = haze_volume::Bbox::new([0.0; 3], g.extent);
        rbf::evaluate_on_grid(g.dims, &ext, &rbfs)
    }

    fn grid_of(dims: [usize; 3], f: impl Fn([f64; 3]) -> f32) -> FitGrid {
        let b = Bbox::new([0.0; 3], [dims[0] as f64, dims[1] as f64, dims[2] as f64]);
        let mut v = Volume::zeros(dims, b).unwrap();
        for i in 0..v.len() {
            let [x, y, z] = v.coords(i);
            let c = v.voxel_center(x, y, z);
            v.data_mut()[i] = f(c);
        }
        FitGrid::from_volume(&v).unwrap()
    }

    /// Residual against `haze_volume::rbf::evaluate_on_grid` (independent, support-box
    /// evaluation through `Rbf::eval`).
    #[test]
    fn residual_matches_reference_evaluation() {
        let g = grid_of([17, 12, 9], |p| {
            ((p[0] * 0.3).sin().abs() + p[2] * 0.1) as f32
        });
        let params = [
            0.3, 0.2, 0.15, 0.08, 0.7, //
            0.9, 0.5, 0.3, 0.05, 0.2, //
            0.0, 0.0, 0.0, 0.2, 1.0, // corner, clipped
            2.0, 2.0, 2.0, 0.05, 1.0, // outside: touches nothing
        ];
        let r = residual(&g, &params);
        let reference = reference_sum(&g, &params);
        for i in 0..g.len() {
            let want = g.density[i] - reference[i];
            assert!((r[i] - want).abs() < 1e-12, "voxel {i}: {} vs {want}", r[i]);
        }
        let e: f64 = r.iter().map(|v| v * v).sum::<f64>() / g.sum_sq;
        assert!((cost(&g, &params) - e).abs() < 1e-12);
    }

    /// A reused residual buffer gives the cost and gradient of a fresh one, also when the
    /// previous pass's RBFs reached voxels the next pass's do not (stale entries there
    /// must not count), and the cost equals `Σ(D − D̃)²/ΣD²` with `D̃` from the
    /// independent reference evaluation.
    #[test]
    fn reused_buffer_matches_fresh_passes_and_the_reference() {
        let g = grid_of([20, 14, 11], |p| {
            ((p[1] * 0.4).cos().abs() + p[0] * 0.05) as f32
        });
        let a = [0.2, 0.3, 0.2, 0.06, 0.8, 0.7, 0.2, 0.4, 0.04, 0.3];
        let b = [0.8, 0.5, 0.1, 0.03, 0.5, 0.45, 0.45, 0.3, 0.12, 0.4];
        let mut scratch = Scratch::default();
        let mut ga = vec![0.0; a.len()];
        cost_and_gradient_with(&g, &a, &mut ga, &mut scratch);
        for params in [&b[..], &a[..], &b[..]] {
            let mut reused = vec![0.0; params.len()];
            let mut fresh = vec![0.0; params.len()];
            let c1 = cost_and_gradient_with(&g, params, &mut reused, &mut scratch);
            let c2 = cost_and_gradient(&g, params, &mut fresh);
            assert_eq!(c1, c2);
            assert_eq!(reused, fresh);
            let reference = reference_sum(&g, params);
            let e: f64 = (0..g.len())
                .map(|i| (g.density[i] - reference[i]).powi(2))
                .sum::<f64>()
                / g.sum_sq;
            assert!((c1 - e).abs() < 1e-12 * e.max(1.0), "{c1} vs {e}");
            assert_eq!(cost_with(&g, params, &mut scratch), c1);
        }
    }

    /// The gradient, accumulated plane by plane, against the formulas of the module docs
    /// summed voxel by voxel with `R` from the independent reference evaluation and
    /// `e_lv` from `Rbf::eval`, for overlapping RBFs, one clipped by the grid's corner and
    /// one outside it.
    #[test]
    fn gradient_matches_a_voxel_by_voxel_sum() {
        let g = grid_of([19, 13, 15], |p| {
            ((p[0] * 0.2).sin().abs() + p[1] * 0.07 + p[2] * 0.03) as f32
        });
        let params = [
            0.31, 0.42, 0.37, 0.09, 0.7, //
            0.36, 0.45, 0.33, 0.06, 0.4, //
            0.02, 0.03, 0.04, 0.12, 0.9, //
            2.0, 2.0, 2.0, 0.05, 1.0,
        ];
        let mut grad = vec![0.0; params.len()];
        let f = cost_and_gradient(&g, &params, &mut grad);
        let reference = reference_sum(&g, &params);
        let r: Vec<f64> = (0..g.len()).map(|i| g.density[i] - reference[i]).collect();
        let e: f64 = r.iter().map(|v| v * v).sum();
        assert!((f - e / g.sum_sq).abs() < 1e-12);
        for (l, p) in params.chunks(5).enumerate() {
            let (c, rr, w) = ([p[0], p[1], p[2]], p[3], p[4]);
            let mut want = [0.0; 5];
            for (i, &rv) in r.iter().enumerate() {
                let x = g.center(i);
                let d: Vec<f64> = (0..3).map(|a| x[a] - c[a]).collect();
                let d2: f64 = d.iter().map(|v| v * v).sum();
                if d2 >= CUT2 * rr * rr {
                    continue;
                }
                let ev = (-d2 / (rr * rr)).exp();
                for a in 0..3 {
                    want[a] -= 4.0 * w * rv * ev * d[a] / (rr * rr * g.sum_sq);
                }
                want[3] -= 4.0 * w * rv * ev * d2 / (rr * rr * rr * g.sum_sq);
                want[4] -= 2.0 * rv * ev / g.sum_sq;
            }
            for k in 0..5 {
                let got = grad[l * 5 + k];
                assert!(
                    (got - want[k]).abs() <= 1e-10 * want[k].abs().max(1e-6),
                    "RBF {l} parameter {k}: {got} vs {}",
                    want[k]
                );
            }
            if l < 3 {
                assert!(
                    want.iter().any(|v| v.abs() > 1e-6),
                    "RBF {l} reaches voxels"
                );
            }
        }
    }

    /// The counted row is exactly the range of the per-voxel sphere test, for centers on
    /// and between voxel centers and `s` across `[0, 9)`.
    #[test]
    fn row_ranges_equal_the_per_voxel_test() {
        let g = grid_of([24, 3, 3], |_| 1.0);
        for (c, r) in [
            (0.5, 0.07),
            (0.52083, 0.02),
            (0.01, 0.05),
            (0.97, 0.1),
            (0.3, 0.013),
        ] {
            // y and z: the middle of the 3-voxel axes (the unit is the 24-voxel side).
            let tab = Tables::new(&g, &[c, 1.5 / 24.0, 1.5 / 24.0, r, 1.0]).unwrap();
            let q = tab.axes[0].q();
            let rows = SphereRows::new(&tab.axes[0]);
            let steps = (0..200)
                .chain((0..200).rev())
                .chain((0..200).map(|k| (k * 67) % 200));
            for k in steps {
                let s = 9.0 * k as f64 / 200.0;
                let inside: Vec<usize> = (0..q.len()).filter(|&i| q[i] + s < CUT2).collect();
                let want = inside.first().map(|&a| (a, inside[inside.len() - 1] + 1));
                assert_eq!(rows.row(s), want, "c {c} r {r} s {s}");
                if let Some((a, b)) = want {
                    assert_eq!(b - a, inside.len(), "one contiguous range");
                }
            }
        }
    }

    #[test]
    fn all_zero_frames_and_no_rbfs() {
        let g = grid_of([4, 4, 4], |_| 0.0);
        assert_eq!(g.sum_sq, 0.0);
        let mut grad = vec![1.0; 5];
        let c = cost_and_gradient(&g, &[0.5, 0.5, 0.5, 0.1, 0.5], &mut grad);
        assert!(c > 0.0 && c.is_finite());
        let g = grid_of([4, 4, 4], |_| 1.0);
        let mut none: Vec<f64> = vec![];
        assert_eq!(cost_and_gradient(&g, &[], &mut none), 1.0);
    }
}
