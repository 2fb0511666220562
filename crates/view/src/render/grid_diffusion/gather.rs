//! Scattering orders computed explicitly on the coarse grid: the light scattered once
//! more, gathered along directions from every cell (source iteration, one order per call).
//!
//! For a source `J(y, ω)` (radiance emitted per unit optical depth at `y` into the
//! direction of propagation `ω`), the radiance arriving at `x` along `ω` is
//!
//! ```text
//! L(x, ω) = ∫₀^∞ T(x, x − sω) σt D(x − sω) J(x − sω, ω) ds
//! ```
//!
//! and its moments `L⁰ = (1/4π)∫L dω`, `L¹ = (3/4π)∫L ω dω` are what the next order's
//! source `J' = Ω (L⁰ + g L¹·ω)` (Funk–Hecke on HG, bands 0–1) needs. The sphere is the
//! environment pass's rule (Gauss–Legendre latitudes per hemisphere × azimuths,
//! [`crate::render::env_pass::directions`]); each ray is marched from the cell center to
//! the box's face in steps of the smallest cell side, the density and `D·J` trilinear
//! between cell centers, each step's share `T (1 − e^{−Δτ}) · (D·J)/D` exact for a
//! constant density within the step (so opaque smoke stays bounded), stopped below
//! transmittance [`T_MIN`]. `J` is given per cell as its moments `J⁰ + J¹·ω` (the sky's
//! and point lights' share) plus, per sun, the transmittance towards it: a sun's source
//! `(Ω/4π) E T(y) p̄(−s·ω)` is evaluated with the disk-averaged phase in the gathered
//! direction exactly (`p̄` does not vary along the ray, so the march sums `T` alone),
//! scaled so that the rule integrates `p̄` to `4π` ([`phase_norm`]): a peak sharper than
//! the rule's spacing would otherwise gain or lose light by where the sun stands among
//! its directions.
//! The mean of the rays' final transmittance is the escape probability `P` of the cell.
//!
//! Bands 2–4 of the gathered radiance, `c_lm = ∫L Y_lm dω` ([`HIGH`] per channel), are
//! kept too: not for the next order (its source stays bands 0–1), but for the light the
//! smoke finally scatters towards the eye, `J(ω) = Ω Σ_lm g^l c_lm Y_lm(ω)`, where bands
//! 0–1 alone are wrong by up to ±20 % for light that arrives from one side (a sun's
//! once-scattered light seen across its flow, `super::add_to_grids`).

use super::CoarseGrid;
use super::rays::{CellRays, RayCache};
use crate::diffusion::Sources;
use crate::lights::DiskPhase;
use crate::medium::FOUR_PI;
use crate::sh;
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Transmittance below which a ray stops.
pub const T_MIN: f64 = 1e-4;

/// A sun's share of the first source: `J = emit · T(y) · p̄(−s·ω)`.
#[derive(Clone, Debug)]
pub struct SunSource {
    /// `Ω E / 4π` per channel.
    pub emit: [f64; 3],
    /// Unit direction towards the sun.
    pub direction: [f64; 3],
    /// HG averaged over the disk ([`DiskPhase`]).
    pub phase: Arc<DiskPhase>,
    /// Transmittance from each cell center to the sun (one per cell).
    pub transmittance: Vec<f64>,
}

/// Coefficients of bands 2–4 (`Y_lm` at `sh::index(l, m) − 4`).
pub const HIGH: usize = 21;

/// `L⁰`, `L¹` of the gathered light per cell, bands 2–4 of it, and the escape probability.
#[derive(Clone, Debug)]
pub struct Gathered {
    pub l0: Vec<[f64; 3]>,
    /// `[channel][axis]`.
    pub l1: Vec<[[f64; 3]; 3]>,
    /// `c_lm = ∫L Y_lm dω` for `l = 2, 3, 4`, `[channel][sh::index(l, m) − 4]`.
    pub high: Vec<[[f64; HIGH]; 3]>,
    /// `P = (1/4π)∫T(x → outside) dω` per cell (1 without smoke).
    pub escape: Vec<f64>,
}

/// Values per cell in the march's record: `D`, `D·J⁰` (3), `D·J¹` (9), `D·T` per sun.
const BASE: usize = 1 + MOMENTS;

/// `D·J⁰` and `D·J¹` of a record: the moments every march carries.
const MOMENTS: usize = 12;

fn finite(x: f64) -> f64 {
    if x.is_finite() { x } else { 0.0 }
}

/// The factor that makes a sun's phase function `phase` conserve its light on the rule
/// `dirs`: `4π / Σ_k w_k p̄(−s·ω_k)` for the sun towards `s` (1 where the sum is not
/// positive). HG 0.8 sums to 0.67–1.36 of `4π` over the first order's 72 directions by
/// where the sun stands among them, so the light the smoke scatters once — all the later
/// orders' source — would be that much too weak or strong (module docs).
pub fn phase_norm(phase: &DiskPhase, s: [f64; 3], dirs: &[([f64; 3], f64)]) -> f64 {
    let sum: f64 = dirs
        .iter()
        .map(|(w, wt)| wt * phase.eval(-(s[0] * w[0] + s[1] * w[1] + s[2] * w[2])))
        .sum();
    if sum > 0.0 && sum.is_finite() {
        FOUR_PI / sum
    } else {
        1.0
    }
}

/// The light `sources` (moments per cell) and `suns` scatter into every cell with smoke
/// of `grid`, gathered along `dirs` (`(ω, weight)`, weights summing to `4π`) through σt
/// `sigma_t` (module docs).
///
/// # Panics
/// If `sources` or a sun's transmittance do not hold one entry per cell.
pub fn gather(
    grid: &CoarseGrid,
    sigma_t: f64,
    sources: &Sources,
    suns: &[SunSource],
    dirs: &[([f64; 3], f64)],
) -> Gathered {
    gather_with(grid, sigma_t, sources, suns, dirs, Rays::March).0
}

/// [`gather`] keeping its rays in `rays` for the next gathers ([`super::rays`]): with
/// `rays` empty every ray is marched and each cell's kept while its budget holds them
/// (none with a budget of 0); else the kept rays sum the records of `sources` and `suns`
/// without a march (the same sums to the bit) and the cells not kept march. `rays` must
/// come from gathers through the same `grid`, `sigma_t` and `dirs`.
///
/// # Panics
/// If `sources` or a sun's transmittance do not hold one entry per cell.
pub fn gather_kept(
    grid: &CoarseGrid,
    sigma_t: f64,
    sources: &Sources,
    suns: &[SunSource],
    dirs: &[([f64; 3], f64)],
    rays: &mut RayCache,
) -> Gathered {
    if rays.budget == 0 {
        gather_with(grid, sigma_t, sources, suns, dirs, Rays::Planes).0
    } else if rays.cells.is_empty() {
        let left = AtomicUsize::new(rays.budget);
        let (out, kept) = gather_with(grid, sigma_t, sources, suns, dirs, Rays::Keep(&left));
        rays.cells = kept;
        out
    } else {
        gather_with(grid, sigma_t, sources, suns, dirs, Rays::Replay(rays)).0
    }
}

/// What a gather does with its rays.
enum Rays<'a> {
    /// Marches every ray.
    March,
    /// Marches every ray and keeps each cell's within the bytes left.
    Keep(&'a AtomicUsize),
    /// Sums the kept rays; marches the cells not kept.
    Replay(&'a RayCache),
    /// Walks planes of parallel rays, one direction at a time ([`super::gather_planes`]).
    Planes,
}

/// `L⁰`, `L¹`, bands 2–4 and the escape probability of one cell.
pub(super) type Cell = ([f64; 3], [[f64; 3]; 3], [[f64; HIGH]; 3], f64);

/// [`gather`] with its rays marched, kept or replayed: also each cell's kept rays with
/// [`Rays::Keep`] (empty otherwise).
fn gather_with(
    grid: &CoarseGrid,
    sigma_t: f64,
    sources: &Sources,
    suns: &[SunSource],
    dirs: &[([f64; 3], f64)],
    rays: Rays<'_>,
) -> (Gathered, Vec<Option<CellRays>>) {
    let n = grid.len();
    assert!(sources.j0.len() == n && sources.j1.len() == n);
    assert!(suns.iter().all(|s| s.transmittance.len() == n));
    let stride = BASE + suns.len();
    let sigma_t = if sigma_t.is_finite() {
        sigma_t.max(0.0)
    } else {
        0.0
    };
    let gathering = Gathering {
        grid,
        rec: cell_records(grid, sources, suns, stride),
        stride,
        occupied: occupied(grid),
        sigma_t,
        dirs,
        // Bands 2–4 of the SH basis at every direction.
        ys: dirs
            .iter()
            .map(|(w, _)| {
                let mut y = [0.0; 25];
                sh::eval_into(5, *w, &mut y);
                std::array::from_fn(|k| y[4 + k])
            })
            .collect(),
        norms: suns
            .iter()
            .map(|sun| phase_norm(&sun.phase, sun.direction, dirs))
            .collect(),
        // Each sun's phase function towards every direction, `p̄(−s·ω)`: the same for
        // every cell, so taken once.
        phases: dirs
            .iter()
            .flat_map(|(w, _)| {
                suns.iter().map(|sun| {
                    let cos = -(0..3).map(|a| sun.direction[a] * w[a]).sum::<f64>();
                    sun.phase.eval(cos)
                })
            })
            .collect(),
        suns,
    };
    let cells: Vec<(Cell, Option<CellRays>)> = if matches!(rays, Rays::Planes) {
        super::gather_planes::gather(&gathering)
            .into_iter()
            .map(|c| (c, None))
            .collect()
    } else {
        (0..n)
            .into_par_iter()
            .map(|i| gathering.cell(i, &rays))
            .collect()
    };
    let mut out = Gathered {
        l0: Vec::with_capacity(n),
        l1: Vec::with_capacity(n),
        high: Vec::with_capacity(n),
        escape: Vec::with_capacity(n),
    };
    let keep = matches!(rays, Rays::Keep(_));
    let mut kept = Vec::with_capacity(if keep { n } else { 0 });
    for ((a, b, h, p), k) in cells {
        out.l0.push(a);
        out.l1.push(b);
        out.high.push(h);
        out.escape.push(p);
        if keep {
            kept.push(k);
        }
    }
    (out, kept)
}

/// What every cell of one gather shares: the grid, its records, the rule and the suns.
pub(super) struct Gathering<'a> {
    pub(super) grid: &'a CoarseGrid,
    /// [`cell_records`]: `stride` values a cell.
    pub(super) rec: Vec<f64>,
    pub(super) stride: usize,
    /// The world box outside which the density is 0 ([`occupied`]).
    pub(super) occupied: ([f64; 3], [f64; 3]),
    pub(super) sigma_t: f64,
    pub(super) dirs: &'a [([f64; 3], f64)],
    ys: Vec<[f64; HIGH]>,
    norms: Vec<f64>,
    phases: Vec<f64>,
    suns: &'a [SunSource],
}

impl Gathering<'_> {
    /// The light gathered at cell `i` along every direction (its rays marched, kept or
    /// replayed as `rays` says), and its rays where they are to be kept.
    fn cell(&self, i: usize, rays: &Rays<'_>) -> (Cell, Option<CellRays>) {
        let grid = self.grid;
        if grid.density[i] <= 0.0 || grid.density[i].is_nan() || self.dirs.is_empty() {
            return (EMPTY, None);
        }
        let x = grid.center(grid.coords(i));
        let replay = match rays {
            Rays::Replay(cache) => cache.cells.get(i).and_then(Option::as_ref),
            _ => None,
        };
        // Rays are kept while the store has room (its bytes are taken at the end).
        let mut keep = match rays {
            Rays::Keep(left) if left.load(Ordering::Relaxed) > 0 => Some(CellRays::default()),
            _ => None,
        };
        let mut sums: Cell = ([0.0; 3], [[0.0; 3]; 3], [[0.0; HIGH]; 3], 0.0);
        let mut acc = vec![0.0f64; self.stride];
        for (d, &(w, _)) in self.dirs.iter().enumerate() {
            let t = match replay {
                Some(ray) => ray.replay(d, &self.rec, self.stride, &mut acc),
                None => {
                    // Light arriving along w comes from x − s·w.
                    let t = march_back(self, x, w.map(|v| -v), &mut acc, |cell, sw| {
                        if keep.as_mut().is_some_and(|k| !k.push(cell, sw)) {
                            keep = None;
                        }
                    });
                    if let Some(k) = keep.as_mut() {
                        k.end_ray(t);
                    }
                    t
                }
            };
            let l = [0, 1, 2].map(|c| self.light(d, &acc, c));
            self.add(d, l, t, &mut sums);
        }
        let kept = match rays {
            Rays::Keep(left) => keep.and_then(|k| k.within(left)),
            _ => None,
        };
        (finish(sums), kept)
    }

    /// The light of channel `c` along direction `d` of a ray's sums `acc` (the march's
    /// `Σ share·record`, or a record itself: `D·J⁰ + D·J¹·ω` and each sun's
    /// `(Ω E/4π)·norm·p̄(−s·ω)·D·T`), before it is clamped at 0.
    pub(super) fn light(&self, d: usize, acc: &[f64], c: usize) -> f64 {
        let w = self.dirs[d].0;
        let phase = &self.phases[d * self.suns.len()..(d + 1) * self.suns.len()];
        let mut l = acc[1 + c] + (0..3).map(|a| acc[4 + 3 * c + a] * w[a]).sum::<f64>();
        for (k, sun) in self.suns.iter().enumerate() {
            l += self.norms[k] * sun.emit[c] * acc[BASE + k] * phase[k];
        }
        l
    }

    /// Adds the light `l` (clamped at 0) arriving along direction `d` and the ray's
    /// transmittance `t` left to a cell's sums (divided by `4π` in [`finish`]).
    pub(super) fn add(&self, d: usize, l: [f64; 3], t: f64, sums: &mut Cell) {
        let ((w, wt), y) = (self.dirs[d], &self.ys[d]);
        let (l0, l1, high, escape) = sums;
        *escape += wt * t;
        for c in 0..3 {
            let l = l[c].max(0.0);
            l0[c] += wt * l;
            for a in 0..3 {
                l1[c][a] += 3.0 * wt * l * w[a];
            }
            for (h, y) in high[c].iter_mut().zip(y) {
                *h += wt * l * y;
            }
        }
    }

    /// The light gathered at the center `x` of a cell along direction `d` by a march back
    /// to the box's face, and the transmittance left.
    pub(super) fn march(&self, x: [f64; 3], d: usize, acc: &mut [f64]) -> ([f64; 3], f64) {
        let back = self.dirs[d].0.map(|v| -v);
        let t = march_back(self, x, back, acc, |_, _| {});
        ([0, 1, 2].map(|c| self.light(d, acc, c)), t)
    }
}

/// A cell's sums over the directions as [`Gathered`] holds them: `L⁰`, `L¹` and the
/// escape probability divided by `4π`, the escape held in `[0, 1]`.
pub(super) fn finish((l0, l1, high, escape): Cell) -> Cell {
    (
        l0.map(|v| v / FOUR_PI),
        l1.map(|c| c.map(|v| v / FOUR_PI)),
        high,
        (escape / FOUR_PI).clamp(0.0, 1.0),
    )
}

/// A cell without smoke: no light gathered, every ray escapes.
pub(super) const EMPTY: Cell = ([0.0; 3], [[0.0; 3]; 3], [[0.0; HIGH]; 3], 1.0);

/// The world box outside which the trilinear density of `grid` is 0: the cells with
/// smoke and one cell around them (the interpolation reaches half a cell beyond), within
/// the grid's box.
fn occupied(grid: &CoarseGrid) -> ([f64; 3], [f64; 3]) {
    let Some((_, lo, hi)) = grid.smoke_cells() else {
        return (grid.origin, grid.origin);
    };
    (
        [0, 1, 2].map(|a| grid.origin[a] + lo[a].saturating_sub(1) as f64 * grid.h[a]),
        [0, 1, 2].map(|a| grid.origin[a] + (hi[a] + 2).min(grid.dims[a]) as f64 * grid.h[a]),
    )
}

/// Per cell `stride` values, the density `D` first, then `D·J⁰` and `D·J¹` per channel
/// and `D·T` per sun (0 in an empty cell): what the gathers' rays interpolate.
fn cell_records(
    grid: &CoarseGrid,
    sources: &Sources,
    suns: &[SunSource],
    stride: usize,
) -> Vec<f64> {
    let n = grid.len();
    let mut rec = vec![0.0f64; n * stride];
    for (i, r) in rec.chunks_mut(stride).enumerate() {
        let d = grid.density[i];
        if !(d > 0.0 && d.is_finite()) {
            continue;
        }
        r[0] = d;
        for c in 0..3 {
            r[1 + c] = d * finite(sources.j0[i][c]);
            for a in 0..3 {
                r[4 + 3 * c + a] = d * finite(sources.j1[i][c][a]);
            }
        }
        for (k, s) in suns.iter().enumerate() {
            r[BASE + k] = d * finite(s.transmittance[i]).clamp(0.0, 1.0);
        }
    }
    rec
}

/// Marches back from `x` along `back` to the grid's edge (steps of the finest cell side,
/// those beyond the occupied box skipped): accumulates into `acc` the records of the
/// gathering weighted by each step's share of the light, tells `seen` each corner added
/// (its cell and weight, in order), and returns the transmittance left (0 once below
/// [`T_MIN`]).
fn march_back(
    gathering: &Gathering<'_>,
    x: [f64; 3],
    back: [f64; 3],
    acc: &mut [f64],
    mut seen: impl FnMut(usize, f64),
) -> f64 {
    let (grid, rec, stride) = (gathering.grid, gathering.rec.as_slice(), gathering.stride);
    let ((occ_lo, occ_hi), sigma_t) = (gathering.occupied, gathering.sigma_t);
    let h = grid.h[0].min(grid.h[1]).min(grid.h[2]);
    let len = grid.exit_distance(x, back);
    let steps = (len / h).ceil().max(1.0) as usize;
    let step = len / steps as f64;
    // The same steps, those beyond the occupied box (density 0) skipped.
    let mut reach = f64::INFINITY;
    for a in 0..3 {
        if back[a] > 0.0 {
            reach = reach.min((occ_hi[a] - x[a]) / back[a]);
        } else if back[a] < 0.0 {
            reach = reach.min((occ_lo[a] - x[a]) / back[a]);
        }
    }
    let steps = steps.min((reach / step + 0.5).ceil().max(0.0) as usize);
    acc.fill(0.0);
    // The moments summed in registers, the suns' transmittances (first order) in `acc`.
    let mut sum = [0.0f64; MOMENTS];
    // The steps' midpoints in cell coordinates, stepped from the start.
    let c0 = [0, 1, 2].map(|a| (x[a] - grid.origin[a]) / grid.h[a] - 0.5);
    let dc = [0, 1, 2].map(|a| step * back[a] / grid.h[a]);
    let mut t = 1.0;
    for k in 0..steps {
        let s = k as f64 + 0.5;
        let Some(corners) = grid.corners_at([0, 1, 2].map(|a| c0[a] + s * dc[a])) else {
            continue;
        };
        let d: f64 = corners
            .iter()
            .map(|&(cell, w)| w * rec[cell * stride])
            .sum();
        if d <= 0.0 {
            continue;
        }
        let dtau = sigma_t * d * step;
        // `1 − e^{−Δτ}` from the one exponential: off by at most an ulp of 1, a relative
        // `10⁻⁸` of the step's share at `Δτ = 10⁻⁸`, where the share is that small.
        let e = (-dtau).exp();
        let share = t * (1.0 - e) / d;
        // `acc += share · Σ w·record`, taken corner by corner (empty cells hold zeros).
        for (cell, w) in corners {
            let r = &rec[cell * stride..(cell + 1) * stride];
            if w == 0.0 || r[0] <= 0.0 {
                continue;
            }
            let sw = share * w;
            let Some((moments, sun)) = r[1..].split_first_chunk::<MOMENTS>() else {
                continue;
            };
            seen(cell, sw);
            for (a, v) in sum.iter_mut().zip(moments) {
                *a += sw * v;
            }
            for (a, v) in acc[BASE..].iter_mut().zip(sun) {
                *a += sw * v;
            }
        }
        t *= e;
        if t < T_MIN {
            t = 0.0;
            break;
        }
    }
    acc[1..BASE].copy_from_slice(&sum);
    t
}
