//! The orders' gathers walked along planes of parallel rays, one direction at a time,
//! where the rays are not kept ([`super::rays`]: grids whose rays outgrow the store, the
//! full-detail grids of `haze render`).
//!
//! A march from every cell ([`super::gather::gather`]) takes tens of steps a cell and
//! direction; the light arriving along `ω` obeys a recurrence along each line instead.
//! Walking a line downstream (along `ω`, the way the light travels) in steps of length
//! `h` with midpoint density `D` and source record `S = D·J(ω)` (the record's moments and
//! suns in that direction, [`super::gather::Gathering::light`]):
//!
//! ```text
//! L ← e^{−Δτ} L + (1 − e^{−Δτ}) · S/D,     τ ← τ + Δτ,     Δτ = σt D h
//! ```
//!
//! — the march's sum `Σ T (1 − e^{−Δτ}) S/D` taken from the far end, exact for a density
//! constant within each step, bounded in opaque smoke. So per direction `ω` with major
//! axis `k` (`|ω_k| ≥ 1/√3`): lines along `ω` one cell apart across `k` (spacing `h_a`,
//! `h_b` on the side axes `a`, `b`, shifted by `ω_a/ω_k` a plane), over the box of the
//! cells with smoke, are walked through its planes across `k` from a plane before the
//! upstream one (before that the density is zero), each plane-to-plane segment
//! (`h_k/|ω_k|` long) in steps of at most the smallest cell side, segments that miss the
//! occupied box skipped (they add nothing and take nothing away); each line keeps `L` per
//! channel and `τ` where it crosses each plane. A cell reads its plane's four values from
//! the 4 × 4 lines around its center (Catmull–Rom, held within the four nearest, as
//! [`crate::render::ray_planes`] reads depths): the light it gathers along `ω`, and its
//! transmittance to the box's face `e^{−τ}` — the march's two results. (`τ` read and then
//! exponentiated is 2.5× closer to the march at a blob's edge than `e^{−τ}` read.)
//!
//! **Where cells march.** Cells within two lines of a side face (across `a` or `b`) that
//! has smoke on its outermost cells: their reads lean on lines that crossed the plane
//! outside the box and entered it further on ([`crate::render::ray_planes`], "Side
//! faces"); every cell of a direction whose grid is fewer than three cells across `a`
//! or `b` (too few lines to read between); and every cell of a direction whose lines
//! would take more steps than the marches ([`READ_STEPS`]).
//!
//! **Cost.** About one line a cell, one or two steps a plane, instead of a march a cell
//! (its steps reach the face: tens to a hundred on a full-detail grid); the values are
//! kept in `f32` (relative `6·10⁻⁸`) for one direction at a time.

use super::HIGH;
use super::coarse::CoarseGrid;
use super::gather::{Cell, EMPTY, Gathering, finish};
use crate::render::env_sweep::DEPTH_CAP;
use crate::render::ray_planes::catmull_rom;
use rayon::prelude::*;

/// Cells across a side axis below which a direction's cells march (module docs).
const THIN: usize = 3;

/// What a cell's read of its lines costs, in a march's steps: 16 taps of four values
/// against a step's 8 corners of four and an exponential (an estimate, not tuned). A
/// direction whose lines' steps plus the reads come to the marches' ([`super::gather_work`])
/// or more marches: near the diagonals the lines over a thin plume's box can outnumber
/// its cells several times.
const READ_STEPS: f64 = 2.0;

/// Lines between a cell and a smoky side face within which the cell marches.
const SIDE_REACH: usize = 2;

/// `L⁰`, `L¹`, bands 2–4 and the escape probability of every cell of `gathering`'s grid,
/// gathered along planes of rays (module docs): what [`Gathering::cell`] gives each by
/// marches.
pub(super) fn gather(gathering: &Gathering<'_>) -> Vec<Cell> {
    let grid = gathering.grid;
    let n = grid.len();
    let Some((_, lo, hi)) = grid.smoke_cells().filter(|_| !gathering.dirs.is_empty()) else {
        return vec![EMPTY; n];
    };
    // The cells with smoke, and their sums (the rest gather nothing).
    let smoke: Vec<usize> = (0..n).filter(|&i| grid.density[i] > 0.0).collect();
    let mut sums: Vec<Cell> = vec![([0.0; 3], [[0.0; 3]; 3], [[0.0; HIGH]; 3], 0.0); smoke.len()];
    // The marches' steps a direction, against which each direction's lines are weighed.
    let marches = super::gather_work(grid);
    let reads = READ_STEPS * smoke.len() as f64;
    let mut walked = 0;
    // Per axis, whether a cell with smoke lies on the grid's low and high face.
    let faces: [[bool; 2]; 3] = std::array::from_fn(|a| [lo[a] == 0, hi[a] + 1 == grid.dims[a]]);
    let stride = gathering.stride;
    // `D` and `S = D·J(ω)` per channel (zero without smoke): what the lines interpolate.
    let mut source = vec![[0.0f64; 4]; n];
    let mut values = Vec::new();
    for d in 0..gathering.dirs.len() {
        let w = gathering.dirs[d].0;
        let lines = Lines::new(grid, w, (lo, hi)).filter(|l| l.work(grid) + reads < marches);
        if let Some(lines) = &lines {
            walked += 1;
            let at: Vec<[f64; 4]> = smoke
                .par_iter()
                .map(|&i| {
                    let rec = &gathering.rec[i * stride..(i + 1) * stride];
                    [
                        rec[0],
                        gathering.light(d, rec, 0),
                        gathering.light(d, rec, 1),
                        gathering.light(d, rec, 2),
                    ]
                })
                .collect();
            for (&i, s) in smoke.iter().zip(at) {
                source[i] = s;
            }
            lines.walk(
                grid,
                &source,
                gathering.sigma_t,
                gathering.occupied,
                &mut values,
            );
        }
        sums.par_iter_mut().zip(&smoke).for_each_init(
            || vec![0.0; stride],
            |acc, (cell, &i)| {
                let at = grid.coords(i);
                let (l, t) = match &lines {
                    Some(lines) if !lines.near_smoky_side(grid, at, &faces) => {
                        lines.read(grid, &values, at)
                    }
                    _ => gathering.march(grid.center(at), d, acc),
                };
                gathering.add(d, l, t, cell);
            },
        );
    }
    tracing::debug!(
        "the orders' gather: {walked} of {} directions along planes of rays",
        gathering.dirs.len()
    );
    let mut out = vec![EMPTY; n];
    for (&i, s) in smoke.iter().zip(sums) {
        out[i] = finish(s);
    }
    out
}

/// The lines along one direction `ω` through the cells' planes across its major axis
/// (module docs).
struct Lines {
    /// `ω`'s major axis `k`, then `a` and `b`.
    axes: [usize; 3],
    /// `ω`.
    w: [f64; 3],
    /// Per `a`, `b`: `ω_·/ω_k`, where line 0 crosses plane 0 (world), and the lines.
    slope: [f64; 2],
    origin: [f64; 2],
    count: [usize; 2],
    /// The planes walked: those of the cells with smoke (upstream of them no light
    /// gathers, downstream no cell reads).
    first: usize,
    planes: usize,
}

impl Lines {
    /// The lines along the unit `w` through `grid`; `None` for a `w` that is not finite or
    /// a grid fewer than [`THIN`] cells across a side axis (its cells march).
    fn new(grid: &CoarseGrid, w: [f64; 3], (lo, hi): ([usize; 3], [usize; 3])) -> Option<Lines> {
        if !w.iter().all(|c| c.is_finite()) {
            return None;
        }
        let k = (0..3).max_by(|&x, &y| w[x].abs().total_cmp(&w[y].abs()))?;
        if w[k] == 0.0 {
            return None;
        }
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        if grid.dims[a] < THIN || grid.dims[b] < THIN {
            return None;
        }
        let slope = [w[a] / w[k], w[b] / w[k]];
        let rise = (hi[k] - lo[k]) as f64 * grid.h[k];
        let mut origin = [0.0; 2];
        let mut count = [0; 2];
        for (c, ax) in [a, b].into_iter().enumerate() {
            // The lines cover the smoke's cell centers on every plane of it, shifted, with
            // one line to spare before them and two after (the 4 × 4 read).
            let shift = rise * slope[c];
            let (down, up) = (shift.min(0.0), shift.max(0.0));
            let first = grid.center(lo)[ax];
            let last = grid.center(hi)[ax];
            origin[c] = first - up - grid.h[ax];
            count[c] = ((last - down - origin[c]) / grid.h[ax]).ceil() as usize + 3;
        }
        Some(Lines {
            axes: [k, a, b],
            w,
            slope,
            origin,
            count,
            first: lo[k],
            planes: hi[k] - lo[k] + 1,
        })
    }

    /// The steps of [`Lines::walk`]: every line's steps over the planes walked, at most
    /// the smallest cell side each (some are skipped outside the occupied box).
    fn work(&self, grid: &CoarseGrid) -> f64 {
        let k = self.axes[0];
        let h = grid.h[0].min(grid.h[1]).min(grid.h[2]);
        let steps = (grid.h[k] / self.w[k].abs() / h).ceil().max(1.0);
        (self.count[0] * self.count[1] * self.planes) as f64 * steps
    }

    /// Where line `(α, β)` crosses plane `j`, in the grid's cell coordinates (cell `i`'s
    /// center at `i`).
    fn crossing(&self, grid: &CoarseGrid, j: usize, line: [usize; 2]) -> [f64; 3] {
        let [k, a, b] = self.axes;
        let rise = (j - self.first) as f64 * grid.h[k];
        let mut c = [0.0; 3];
        c[k] = j as f64;
        for (s, ax) in [a, b].into_iter().enumerate() {
            let x = self.origin[s] + line[s] as f64 * grid.h[ax] + rise * self.slope[s];
            c[ax] = (x - grid.origin[ax]) / grid.h[ax] - 0.5;
        }
        c
    }

    /// Every line's `L` per channel and `τ` where it crosses each plane, walked from the
    /// upstream face (module docs), into `out`: per line `β`, plane, line `α`.
    fn walk(
        &self,
        grid: &CoarseGrid,
        source: &[[f64; 4]],
        sigma_t: f64,
        (occ_lo, occ_hi): ([f64; 3], [f64; 3]),
        out: &mut Vec<[f32; 4]>,
    ) {
        let [k, ..] = self.axes;
        let planes = self.planes;
        let h = grid.h[0].min(grid.h[1]).min(grid.h[2]);
        let segment = grid.h[k] / self.w[k].abs();
        let m = (segment / h).ceil().max(1.0);
        // A segment's run in cell coordinates, from the plane before to this one.
        let back: [f64; 3] = std::array::from_fn(|ax| self.w[ax] * segment / grid.h[ax]);
        // The occupied box in cell coordinates (within the grid's box: beyond it nothing).
        let cell = |x: f64, ax: usize| (x - grid.origin[ax]) / grid.h[ax] - 0.5;
        let lo: [f64; 3] = std::array::from_fn(|ax| cell(occ_lo[ax], ax));
        let hi: [f64; 3] = std::array::from_fn(|ax| cell(occ_hi[ax], ax));
        let row = planes * self.count[0];
        // Every value is written below; the store is kept from one direction to the next
        // (a fresh one a direction was a tenth of the render in page faults).
        out.clear();
        out.resize(row * self.count[1], [0.0; 4]);
        // Downstream: up the planes when the light travels up `k`.
        let (first, last) = (self.first, self.first + planes - 1);
        let plane = |s: usize| if self.w[k] > 0.0 { first + s } else { last - s };
        out.par_chunks_mut(row).enumerate().for_each(|(beta, out)| {
            for alpha in 0..self.count[0] {
                let (mut l, mut tau) = ([0.0f64; 3], 0.0f64);
                // The segments that reach the occupied box: from the whole line's clip.
                let entry = self.crossing(grid, plane(0), [alpha, beta]);
                let from: [f64; 3] = std::array::from_fn(|ax| entry[ax] - back[ax]);
                let run = back.map(|c| c * planes as f64);
                let (near, far) = match clip(from, run, lo, hi) {
                    Some((u0, u1)) => (u0 * planes as f64 - 1.0, u1 * planes as f64 + 1.0),
                    None => (f64::INFINITY, f64::NEG_INFINITY),
                };
                for s in 0..planes {
                    let j = plane(s);
                    // The part of the segment within the occupied box, in steps of at most
                    // `h` (midpoints, downstream order).
                    let start: [f64; 3] = std::array::from_fn(|ax| from[ax] + s as f64 * back[ax]);
                    let within = (s as f64) >= near && (s as f64) <= far;
                    if let Some((u0, u1)) = within.then(|| clip(start, back, lo, hi)).flatten() {
                        let steps = ((u1 - u0) * m).ceil().max(1.0);
                        let du = (u1 - u0) / steps;
                        let sigma_h = sigma_t * du * segment;
                        for i in 0..steps as usize {
                            let u = u0 + (i as f64 + 0.5) * du;
                            let q = std::array::from_fn(|ax| start[ax] + u * back[ax]);
                            step_through(grid, source, sigma_h, q, &mut l, &mut tau);
                        }
                    }
                    out[(j - first) * self.count[0] + alpha] = [
                        l[0] as f32,
                        l[1] as f32,
                        l[2] as f32,
                        tau.min(DEPTH_CAP) as f32,
                    ];
                }
            }
        });
    }

    /// Cell `at`'s light along `ω` and transmittance to the face, read from the 4 × 4
    /// lines around its center on its plane (Catmull–Rom, each held within the four
    /// nearest).
    fn read(&self, grid: &CoarseGrid, values: &[[f32; 4]], at: [usize; 3]) -> ([f64; 3], f64) {
        let [k, a, b] = self.axes;
        let j = at[k] - self.first;
        let rise = j as f64 * grid.h[k];
        let mut taps = [[0usize; 4]; 2];
        let mut weights = [[0.0f64; 4]; 2];
        for (s, ax) in [a, b].into_iter().enumerate() {
            let center = grid.origin[ax] + (at[ax] as f64 + 0.5) * grid.h[ax];
            let x = (center - rise * self.slope[s] - self.origin[s]) / grid.h[ax];
            let x = x.clamp(1.0, (self.count[s] - 3) as f64);
            let lo = (x as usize).min(self.count[s] - 3);
            taps[s] = [lo - 1, lo, lo + 1, lo + 2];
            weights[s] = catmull_rom(x - lo as f64);
        }
        let row = self.planes * self.count[0];
        let value =
            |i: usize, jb: usize| values[taps[1][jb] * row + j * self.count[0] + taps[0][i]];
        let mut sum = [0.0f64; 4];
        for (jb, wb) in weights[1].iter().enumerate() {
            for (i, wa) in weights[0].iter().enumerate() {
                let v = value(i, jb);
                for (s, v) in sum.iter_mut().zip(v) {
                    *s += wa * wb * f64::from(v);
                }
            }
        }
        let near = [value(1, 1), value(2, 1), value(1, 2), value(2, 2)];
        let held: [f64; 4] = std::array::from_fn(|c| {
            let (lo, hi) = near
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    let v = f64::from(v[c]);
                    (l.min(v), h.max(v))
                });
            sum[c].clamp(lo, hi)
        });
        ([held[0], held[1], held[2]], (-held[3]).exp())
    }

    /// Whether cell `at` lies within [`SIDE_REACH`] lines of a side face with smoke on it
    /// (module docs).
    fn near_smoky_side(&self, grid: &CoarseGrid, at: [usize; 3], faces: &[[bool; 2]; 3]) -> bool {
        let [_, a, b] = self.axes;
        [a, b].into_iter().any(|ax| {
            (faces[ax][0] && at[ax] < SIDE_REACH)
                || (faces[ax][1] && at[ax] + SIDE_REACH >= grid.dims[ax])
        })
    }
}

/// The part `[u₀, u₁]` of the segment `start + u·run`, `u ∈ [0, 1]`, within the box
/// `[lo, hi]` (per axis); `None` where it misses the box or is a single point.
fn clip(start: [f64; 3], run: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> Option<(f64, f64)> {
    let (mut u0, mut u1) = (0.0f64, 1.0f64);
    for ax in 0..3 {
        if run[ax] == 0.0 {
            if start[ax] < lo[ax] || start[ax] > hi[ax] {
                return None;
            }
        } else {
            let (a, b) = (
                (lo[ax] - start[ax]) / run[ax],
                (hi[ax] - start[ax]) / run[ax],
            );
            u0 = u0.max(a.min(b));
            u1 = u1.min(a.max(b));
        }
    }
    (u1 > u0).then_some((u0, u1))
}

/// One step of a line at cell coordinates `q`, `σt·h` given: `L ← e^{−Δτ}L + (1 −
/// e^{−Δτ})·S/D` with `D`, `S` trilinear between the cell centers (module docs); nothing
/// outside the box or where `D` is 0.
fn step_through(
    grid: &CoarseGrid,
    source: &[[f64; 4]],
    sigma_h: f64,
    q: [f64; 3],
    l: &mut [f64; 3],
    tau: &mut f64,
) {
    let Some(corners) = grid.corners_at(q) else {
        return;
    };
    let mut v = [0.0f64; 4];
    for (cell, w) in corners {
        if w != 0.0 {
            let s = &source[cell];
            for (v, s) in v.iter_mut().zip(s) {
                *v += w * s;
            }
        }
    }
    let d = v[0];
    if d <= 0.0 {
        return;
    }
    let dtau = sigma_h * d;
    let e = (-dtau).exp();
    let share = (1.0 - e) / d;
    for c in 0..3 {
        l[c] = e * l[c] + share * v[1 + c];
    }
    *tau += dtau;
}

#[cfg(test)]
mod tests {
    use super::super::{
        CoarseGrid, Gathered, RayCache, SunSource, gather, gather_kept, phase_norm,
    };
    use crate::diffusion::Sources;
    use crate::lights::DiskPhase;
    use crate::medium::FOUR_PI;
    use crate::sh::quad::SphereGrid;
    use std::sync::Arc;

    fn grid(n: [usize; 3], h: [f64; 3], density: impl Fn([f64; 3]) -> f64) -> CoarseGrid {
        let mut g = CoarseGrid {
            dims: n,
            factor: 1,
            h,
            origin: [0.2, -0.1, 0.05],
            density: vec![0.0; n[0] * n[1] * n[2]],
        };
        for i in 0..g.len() {
            g.density[i] = density(g.coords(i).map(|v| v as f64));
        }
        g
    }

    fn rule(n: usize) -> Vec<([f64; 3], f64)> {
        SphereGrid::hemispheres(n, 4 * n).points().collect()
    }

    fn sun(cells: usize, t: impl Fn(usize) -> f64) -> SunSource {
        SunSource {
            emit: [0.3, 0.2, 0.1],
            direction: crate::lights::unit([0.3, 0.5, 0.8]).unwrap(),
            phase: Arc::new(DiskPhase::new(0.6, 0.1)),
            transmittance: (0..cells).map(t).collect(),
        }
    }

    /// Sources that vary over the cells (moments of both bands, all channels).
    fn sources(cells: usize) -> Sources {
        let mut s = Sources::zeros(cells);
        for i in 0..cells {
            let x = i as f64 * 0.37;
            s.j0[i] = [1.0 + 0.5 * x.sin(), 0.5 + 0.2 * x.cos(), 0.2];
            s.j1[i] = [[0.1 * x.sin(), 0.0, -0.05], [0.0, 0.05, 0.0], [0.01; 3]];
        }
        s
    }

    /// The gather along planes of rays: through a store of no bytes, where they are used.
    fn planes(g: &CoarseGrid, sigma_t: f64, s: &Sources, suns: &[SunSource]) -> Gathered {
        let dirs = rule(3);
        gather_kept(g, sigma_t, s, suns, &dirs, &mut RayCache::within(0))
    }

    /// Mean difference of `L⁰` (each channel) over the cells against the largest `L⁰`,
    /// and of `P`.
    fn mean(x: &Gathered, y: &Gathered) -> (f64, f64) {
        let peak = y.l0.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        let n = x.l0.len() as f64;
        let l0: f64 = (x.l0.iter().flatten().zip(y.l0.iter().flatten()))
            .map(|(a, b)| (a - b).abs())
            .sum();
        let p: f64 = x
            .escape
            .iter()
            .zip(&y.escape)
            .map(|(a, b)| (a - b).abs())
            .sum();
        (l0 / (3.0 * n * peak), p / n)
    }

    /// Largest difference of `L⁰` over the cells against the largest `L⁰`, and of `P`.
    fn worst(x: &Gathered, y: &Gathered) -> (f64, f64) {
        let peak = y.l0.iter().flatten().fold(0.0f64, |m, v| m.max(*v));
        let l0 =
            x.l0.iter()
                .flatten()
                .zip(y.l0.iter().flatten())
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        let p = x
            .escape
            .iter()
            .zip(&y.escape)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        (l0 / peak, p)
    }

    /// In a uniform box each direction's light has a closed form at every cell:
    /// `L = max(0, J(ω))·(1 − e^{−σt D ℓ})`, `ℓ` the way back to the face, and the
    /// escape `e^{−σt D ℓ}` — summed over the gather's own rule, so that the only error
    /// left is the planes' (the reads between lines across the kinks of `ℓ` where the way
    /// out turns from one face to another, and `f32`): measured 5.9·10⁻⁴ of the largest
    /// `L⁰` and 8.2·10⁻⁴ on `P`.
    #[test]
    fn a_uniform_box_has_the_closed_form_at_every_cell() {
        let (n, h, d, sigma_t) = ([11, 9, 8], [0.1, 0.12, 0.08], 1.5, 3.0);
        let g = grid(n, h, |_| d);
        // The same source in every cell (a closed form needs it constant along the way).
        let mut src = Sources::zeros(g.len());
        src.j0 = vec![[1.0, 0.5, 0.2]; g.len()];
        src.j1 = vec![[[0.2, 0.0, -0.1], [0.0, 0.3, 0.0], [0.0, 0.05, 0.0]]; g.len()];
        let s = sun(g.len(), |_| 0.7);
        let out = planes(&g, sigma_t, &src, std::slice::from_ref(&s));
        let dirs = rule(3);
        let norm = phase_norm(&s.phase, s.direction, &dirs);
        let size = [0, 1, 2].map(|a| n[a] as f64 * h[a]);
        let mut exact = out.clone();
        for i in 0..g.len() {
            let x = g.center(g.coords(i));
            let (mut l0, mut p) = ([0.0; 3], 0.0);
            for &(w, wt) in &dirs {
                let l = (0..3)
                    .map(|a| {
                        let to = if w[a] < 0.0 {
                            size[a] + g.origin[a]
                        } else {
                            g.origin[a]
                        };
                        if w[a] == 0.0 {
                            f64::INFINITY
                        } else {
                            (x[a] - to) / w[a]
                        }
                    })
                    .fold(f64::INFINITY, f64::min);
                let t = (-sigma_t * d * l).exp();
                let cos = -(0..3).map(|a| s.direction[a] * w[a]).sum::<f64>();
                for (c, l0) in l0.iter_mut().enumerate() {
                    let j = src.j0[i][c]
                        + (0..3).map(|a| src.j1[i][c][a] * w[a]).sum::<f64>()
                        + norm * s.emit[c] * 0.7 * s.phase.eval(cos);
                    *l0 += wt * j.max(0.0) * (1.0 - t) / FOUR_PI;
                }
                p += wt * t / FOUR_PI;
            }
            exact.l0[i] = l0;
            exact.escape[i] = p;
        }
        let (l0, p) = worst(&out, &exact);
        assert!(l0 < 3e-3 && p < 2e-3, "L⁰ {l0:.2e}, P {p:.2e}");
    }

    /// A blob with empty cells around it (touching the low face across z) and a sun,
    /// against the march from every cell (an independent sum along each cell's own ray).
    /// Measured at σt 1 / 8: on average 0.9 / 1.6·10⁻³ of the largest `L⁰` and 5.3 /
    /// 4.4·10⁻⁴ on `P`; at worst 3.2 / 4.9·10⁻² and 1.2 / 1.4·10⁻² in the blob's outermost
    /// cells (a radius of eight cells), whose reads take lines that pass beside it: the
    /// light blurred across about a cell. The walk reversed fails it (0.74 of the peak).
    #[test]
    fn a_blob_matches_the_march() {
        let g = grid([20, 18, 16], [0.1, 0.12, 0.09], |c| {
            let r2 = (c[0] - 9.5).powi(2) + (c[1] - 8.5).powi(2) + (c[2] - 7.5).powi(2);
            if r2 < 64.0 {
                1.0 + 0.3 * c[0] - 0.1 * c[2]
            } else {
                0.0
            }
        });
        let src = sources(g.len());
        let suns = [sun(g.len(), |i| (0.3 + 0.1 * (i as f64).sin()).abs())];
        for sigma_t in [1.0, 8.0] {
            let out = planes(&g, sigma_t, &src, &suns);
            let march = gather(&g, sigma_t, &src, &suns, &rule(3));
            let (l0, p) = worst(&out, &march);
            let (l0_mean, p_mean) = mean(&out, &march);
            assert!(
                l0 < 7e-2 && p < 3e-2 && l0_mean < 4e-3 && p_mean < 1.5e-3,
                "σt {sigma_t}: L⁰ {l0:.2e} (mean {l0_mean:.2e}), P {p:.2e} (mean {p_mean:.2e})"
            );
        }
    }

    /// Extremes: smoke on every face (its cells near the sides march), grids too thin
    /// across for lines (every cell marches), opaque and clear smoke, and directions along
    /// the axes: finite, and the march's where every cell marches.
    #[test]
    fn extremes_stay_finite() {
        let src = |g: &CoarseGrid| sources(g.len());
        let thin = grid([2, 2, 7], [0.1, 0.1, 0.1], |_| 1.0);
        let dirs = rule(3);
        let out = gather_kept(
            &thin,
            2.0,
            &src(&thin),
            &[],
            &dirs,
            &mut RayCache::within(0),
        );
        let march = gather(&thin, 2.0, &src(&thin), &[], &dirs);
        assert_eq!(out.l0, march.l0);
        assert_eq!(out.escape, march.escape);
        let g = grid([6, 5, 7], [0.1, 0.2, 0.05], |c| 0.5 + c[0]);
        let axes = vec![
            ([1.0, 0.0, 0.0], FOUR_PI / 2.0),
            ([0.0, 0.0, -1.0], FOUR_PI / 2.0),
        ];
        for sigma_t in [0.0, 1e-12, 1.0, 1e6, 1e300] {
            let s = src(&g);
            for dirs in [&dirs, &axes] {
                let out = gather_kept(&g, sigma_t, &s, &[], dirs, &mut RayCache::within(0));
                let finite = out.l0.iter().flatten().all(|v| v.is_finite() && *v >= 0.0)
                    && out.escape.iter().all(|p| (0.0..=1.0).contains(p));
                assert!(finite, "σt {sigma_t}");
                if sigma_t == 0.0 {
                    assert!(out.l0.iter().flatten().all(|v| *v == 0.0));
                    assert!(out.escape.iter().all(|p| (p - 1.0).abs() < 1e-12));
                }
            }
        }
    }
}
