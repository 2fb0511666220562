//! Multiple scattering by diffusion on a coarse voxel grid: paper A §4.3's diffusion with
//! the vacuum correction of [`crate::diffusion`], solved by finite volumes on the volume
//! pass's density instead of collocated on the RBF basis (§5.4), and with the first
//! collision taken locally.
//!
//! **Grid.** The density `D = D̃ + R` of the volume pass averaged over blocks of `f³` voxels
//! ([`CoarseGrid`]). Each cell's escape probability `P = (1/4π)∫ exp(−σt∫D dt) dω` is
//! marched through it along [`DIRECTIONS`] directions ([`escape`](mod@escape)); the sources `J⁰`,
//! `J¹` per cell are the environment's single scattering interpolated from the RBF
//! centers plus the suns and point lights with their transmittance marched through the
//! fine density (`source`).
//!
//! **First collision.** The light that the source `J` scatters collides again before
//! leaving with the probability `1 − P`; for a source uniform along the rays its mean
//! radiance is exactly `L⁰₁ = (1 − P) J⁰` (and its flux is taken as `L¹₁ = (1 − P) J¹`).
//! This part is kept local, per cell: diffusion underestimates it in thin smoke (a slab of
//! optical thickness 0.3 under Marshak's condition keeps 27 % less than the exact
//! first-collision density), and the RBF path spread it from the centers to the
//! silhouette.
//!
//! **The rest** `L₂` (light scattered twice or more) is the diffusion of `crate::diffusion`
//! with the vacuum correction, fed by the scattering of `L₁` (`J⁰₂ = Ω L⁰₁`,
//! `J¹₂ = Ω g L¹₁`):
//!
//! ```text
//! ∇·((1 − P)κ∇L⁰₂) − (σa + σs P) D L⁰₂ + σt D (1 − P) J⁰₂ − (σt/(3σtr))∇·((1 − P) J¹₂) = 0
//! ```
//!
//! (`κ = 1/(3σtr D)`; with `P` the collision series `(1 − P)J Σ (Ω(1 − P))^k` of the
//! local balance continues where `L₁` is its first term). Integrated over a cell of
//! volume `V` with faces of area `A = V/h` to the neighbouring cells `j`:
//!
//! ```text
//! Σ_j [G_ij (L_i − L_j) + A (σt/(3σtr)) ((1 − P)J¹)_ij·n] + V (σa + σs P_i) D_i L_i
//!     = V σt D_i (1 − P_i) J⁰_i,        G_ij = A (1 − P_ij) / (3σtr D_ij h)
//! ```
//!
//! with `·_ij` the means of the two cells. No flux crosses to a cell without smoke: the
//! light that leaves is the sink `σs P`. Cells thinner than [`THIN`] transport mean free
//! paths are left out (their `L₂ = 0`). The matrix is symmetric positive definite when
//! some `P > 0` or `Ω < 1` (always: `P ≥ e⁻²⁰` at the smoke's edge) and is solved by
//! Jacobi-preconditioned conjugate gradients ([`solve`](mod@solve)). `L¹₂` per cell is 3× the mean
//! of the two opposite faces' flux densities.
//!
//! **Forward peaks.** The explicit orders and the diffusion after them
//! ([`explicit_media_radiance`]) carry the light through the delta-Eddington transport
//! medium ([`Medium::delta_eddington`]): HG's forward peak `f = g²` counted as light
//! that goes straight on, `σt' = σt(1 − Ωf)`, `Ω' = Ω(1 − f)/(1 − Ωf)`, `g' = g/(1 + g)`.
//! The later orders' sources are bands 0–1, which spread a strong forward peak over a
//! hemisphere; with the peak counted as unscattered the held-out skies came nearer the
//! path tracer at every g > 0 (BENCHMARKS.md, "Speed at equal error, and the ends of the
//! range": σt 10, g 0.8 from 26.6 to 23.8 % front-lit and from 11.0 to 8.6 % back-lit).
//! With g ≤ 0 nothing changes.
//!
//! **Read per voxel.** `L⁰ = L⁰₁ + L⁰₂`, `L¹ = L¹₁ + L¹₂` (clamped to `|L¹| ≤ 3L⁰`, the
//! bound of a non-negative radiance) are interpolated trilinearly from the cells, weighted
//! by their density (a voxel next to empty cells keeps its smoke's value), and every voxel with smoke gains the multiple-scattering
//! source towards the eye, `ω = −d`, with bands 2–4 `c_lm` of the gathered orders
//! ([`Gathered::high`]; the diffusion's light has none). Bands 0–1 alone made the
//! multiple part 5–10 % too bright where a sun's scattered light is seen across its
//! flow (BENCHMARKS.md, "Multiple scattering: the light towards the eye").
//!
//! **The light towards the eye** (delta-M on the last scattering). Funk–Hecke on HG
//! gives `J(ω) = Ω Σ_l g^l Σ_m c_lm Y_lm(ω)` for every band of the scattered light
//! `L`; the gathered orders know bands 0–4. Cut there, the series is far off where `L`
//! is peaked (a sun's scattered light, HG-like about the sun's direction): at g 0.8 and
//! `L` an HG 0.64, 2.1× the exact value seen back towards the sun and 0.85× seen along
//! its flow. HG is split instead as `p = f·4πδ(ω − ω') + p*` with `f = g⁵`
//! ([`eye_peak_share`]), so that `p*`'s bands weigh `g^l − f` (0 at band 5, `g^l − g⁵`
//! small beyond) and bands 0–4 carry it:
//!
//! ```text
//! J_ms(ω) = Ω ((1 − f) L⁰ + (g − f) L¹·ω + Σ_{l=2}^{4} (g^l − f) Σ_m c_lm Y_lm(ω))
//! ```
//!
//! while the peak's share `Ωf·L(ω)` is the light already on the eye's ray scattered on
//! along it: the view pass carries every scattered light (single and multiple) to the
//! eye through `σt(1 − Ωf)` instead of `σt` ([`VolumeGrids::eye_peak`]), the background
//! through `σt`. With the exact `L(ω)`, the same HG 0.64 light is within 10 % of the exact
//! `J` at every angle (1.10× back towards the sun, 0.99× across, 1.08× along the flow);
//! the δ misses what the peak's width spreads (0.87× at 20° from a sun's flow seen
//! through HG 0.8 light, where the cut series is 1.02×). At g 0.5 `f` is 3 %.

mod coarse;
mod escape;
mod gather;
mod gather_planes;
#[cfg(test)]
mod gather_tests;
mod rays;
mod solve;
mod source;
#[cfg(test)]
mod tests;

pub use coarse::CoarseGrid;
pub use escape::{escape, fibonacci_directions};
pub use gather::{Gathered, HIGH, SunSource, T_MIN, gather, gather_kept, phase_norm};
pub use rays::{RAY_CACHE_BYTES, RayCache};
pub use solve::{FvSystem, GridSolution, GridSolveOptions, THIN, solve};
pub use source::{
    NEAR_CELLS, NEAR_SUB, add_lights, env_grid_sources, interpolate_centers, near_light_mean,
    sun_sources,
};

use crate::diffusion::Sources;
use crate::env::Environment;
use crate::lighting::single::RgbSh;
use crate::medium::Medium;
use crate::render::crm::VolumeGrids;
use crate::render::env_pass::directions;
use crate::render::separable::{Separable, Stencil};
use crate::sh::ShGrid;
use haze_volume::{Rbf, Volume};
use rayon::prelude::*;

/// `L⁰`, `L¹` on every cell of a coarse grid (0 where there is no smoke).
#[derive(Clone, Debug)]
pub struct MediaRadiance {
    pub grid: CoarseGrid,
    /// `L⁰` per cell and channel.
    pub l0: Vec<[f64; 3]>,
    /// `L¹` per cell, `[channel][axis]`, clamped to `|L¹| ≤ 3 L⁰`.
    pub l1: Vec<[[f64; 3]; 3]>,
    /// Bands 2–4 of the gathered orders' radiance per cell ([`Gathered::high`]; 0 for
    /// the diffusions, whose light is bands 0–1).
    pub high: Vec<[[f64; HIGH]; 3]>,
    pub iterations: u32,
    pub residual: f64,
}

impl MediaRadiance {
    /// No light on any cell of `grid` (no solve run).
    fn zeros(grid: CoarseGrid) -> MediaRadiance {
        let n = grid.len();
        MediaRadiance {
            l0: vec![[0.0; 3]; n],
            l1: vec![[[0.0; 3]; 3]; n],
            high: vec![[[0.0; HIGH]; 3]; n],
            grid,
            iterations: 0,
            residual: 0.0,
        }
    }
}

/// Directions of the escape-probability march.
pub const DIRECTIONS: usize = 32;

/// `L⁰`, `L¹` on `grid` for the per-cell first-scattering sources `sources` and escape
/// probabilities `escape` (module docs): the first collision locally, the rest by the
/// diffusion.
///
/// # Panics
/// If `sources` or `escape` do not hold one entry per cell.
pub fn media_radiance(
    grid: CoarseGrid,
    medium: &Medium,
    sources: &Sources,
    escape: &[f64],
    opts: &GridSolveOptions,
) -> MediaRadiance {
    let n = grid.len();
    let mut out = MediaRadiance::zeros(grid);
    assert!(sources.j0.len() == n && sources.j1.len() == n && escape.len() == n);
    if medium.albedo <= 0.0 || medium.sigma_t.is_nan() || medium.sigma_t <= 0.0 {
        return out;
    }
    // L₁ and the sources of L₂.
    let mut next = Sources::zeros(n);
    let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
    for (i, p) in escape.iter().enumerate() {
        if out.grid.density[i] <= 0.0 {
            continue;
        }
        let kept = 1.0 - p.clamp(0.0, 1.0);
        out.l0[i] = sources.j0[i].map(|j| kept * finite(j));
        out.l1[i] = sources.j1[i].map(|c| c.map(|j| kept * finite(j)));
        next.j0[i] = out.l0[i].map(|l| medium.albedo * l);
        next.j1[i] = out.l1[i].map(|c| c.map(|l| medium.albedo * medium.g * l));
    }
    diffuse_rest(&mut out, medium, &next, escape, opts);
    clamp_moments(&mut out);
    out
}

/// Adds to `out` the diffusion (module docs) of the light that `next` (the sources of the
/// first order not yet in `out`) and everything after it carry.
fn diffuse_rest(
    out: &mut MediaRadiance,
    medium: &Medium,
    next: &Sources,
    escape: &[f64],
    opts: &GridSolveOptions,
) {
    if let Some(sys) = FvSystem::new(&out.grid, medium, next, escape) {
        let sol = solve(&sys, None, opts);
        for (k, &i) in sys.cells.iter().enumerate() {
            let l1 = sys.flux_moment(&out.grid, &sol.l0, k);
            for (c, (o0, o1)) in out.l0[i].iter_mut().zip(&mut out.l1[i]).enumerate() {
                *o0 += sol.l0[k][c].max(0.0);
                o1.iter_mut().zip(l1[c]).for_each(|(o, v)| *o += v);
            }
        }
        out.iterations = sol.iterations;
        out.residual = sol.residual;
    }
}

/// `L⁰ ≥ 0` and `|L¹| ≤ 3 L⁰` (a non-negative radiance) per cell and channel.
fn clamp_moments(out: &mut MediaRadiance) {
    for (l0, l1) in out.l0.iter_mut().zip(&mut out.l1) {
        for c in 0..3 {
            l0[c] = l0[c].max(0.0);
            let norm = l1[c].iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm.is_nan() || norm > 3.0 * l0[c] {
                let s = if norm > 0.0 && norm.is_finite() {
                    3.0 * l0[c] / norm
                } else {
                    0.0
                };
                l1[c] = l1[c].map(|v| v * s);
            }
        }
    }
}

/// The next order's source `J = Ω (L⁰ + g L¹·ω)` of the gathered light `g`.
fn scattered(l: &Gathered, medium: &Medium) -> Sources {
    Sources {
        j0: l.l0.iter().map(|c| c.map(|v| medium.albedo * v)).collect(),
        j1: l
            .l1
            .iter()
            .map(|c| c.map(|a| a.map(|v| medium.albedo * medium.g * v)))
            .collect(),
        escape: Vec::new(),
    }
}

/// `L⁰`, `L¹` on `grid` with the first `orders` scattering orders gathered explicitly
/// (`gather`, from the first-scattering sources `sources` and `suns`, along `first`, the
/// later orders, whose sources are smoother, along `later`) and
/// the rest by the diffusion fed by the last gathered order, with the escape probability
/// of the first gather as its vacuum correction (module docs). The light is carried
/// through `medium`'s delta-Eddington transport medium ([`Medium::delta_eddington`]):
/// the first sources (`sources`, `suns`, with the full phase function) scaled to its
/// optical depth, the later orders' sources and the diffusion with its albedo and
/// asymmetry. The returned radiance is the medium's own; the caller scatters it towards
/// the eye with `medium`'s phase function.
///
/// # Panics
/// If `sources` or a sun's transmittance do not hold one entry per cell.
#[allow(clippy::too_many_arguments)]
pub fn explicit_media_radiance(
    grid: CoarseGrid,
    medium: &Medium,
    sources: &Sources,
    suns: &[SunSource],
    orders: usize,
    first: &[([f64; 3], f64)],
    later: &[([f64; 3], f64)],
    opts: &GridSolveOptions,
) -> MediaRadiance {
    let mut out = MediaRadiance::zeros(grid);
    if medium.albedo <= 0.0 || medium.sigma_t.is_nan() || medium.sigma_t <= 0.0 {
        return out;
    }
    let (transport, scale) = medium.delta_eddington();
    let (first_sources, first_suns) = scaled_first_sources(sources, suns, scale);
    let medium = &transport;
    // The later orders march their rays once and sum the kept ones after, where they fit;
    // the first order keeps them where it gathers along the same rule. Where they do not
    // fit, every order walks planes of rays (`gather_planes`).
    let mut rays = later_rays(&out.grid, later.len());
    let mut last = if first == later || rays.budget == 0 {
        gather_kept(
            &out.grid,
            medium.sigma_t,
            &first_sources,
            &first_suns,
            first,
            &mut rays,
        )
    } else {
        gather(
            &out.grid,
            medium.sigma_t,
            &first_sources,
            &first_suns,
            first,
        )
    };
    let escape = last.escape.clone();
    out.l0.clone_from(&last.l0);
    out.l1.clone_from(&last.l1);
    out.high.clone_from(&last.high);
    for _ in 1..orders.max(1) {
        last = gather_kept(
            &out.grid,
            medium.sigma_t,
            &scattered(&last, medium),
            &[],
            later,
            &mut rays,
        );
        for (o, l) in out.l0.iter_mut().zip(&last.l0) {
            (0..3).for_each(|c| o[c] += l[c]);
        }
        for (o, l) in out.l1.iter_mut().zip(&last.l1) {
            (0..3).for_each(|c| (0..3).for_each(|a| o[c][a] += l[c][a]));
        }
        for (o, l) in out.high.iter_mut().zip(&last.high) {
            (0..3).for_each(|c| (0..HIGH).for_each(|k| o[c][k] += l[c][k]));
        }
    }
    if orders > 1 {
        tracing::debug!(
            "the orders' rays: {} of {} cells kept, {:.1} MB",
            rays.kept(),
            out.grid.len(),
            rays.bytes() as f64 / 1e6
        );
    }
    diffuse_rest(&mut out, medium, &scattered(&last, medium), &escape, opts);
    clamp_moments(&mut out);
    out
}

/// Corners a ray's step keeps on average in [`later_rays`]' estimate (at most 8; 2.3 on
/// held-out plume-e at 5³-voxel cells, where the empty corners are left out).
const KEPT_CORNERS: f64 = 4.0;

/// The store for the later orders' rays on `grid` along `dirs` directions
/// ([`RayCache`]): [`RAY_CACHE_BYTES`] where the estimate of all of them —
/// [`gather_work`] steps a direction, [`KEPT_CORNERS`] a step, 12 bytes each — fits it,
/// else none (every order marches: a store that holds a few of the cells would cost its
/// memory and the keeping for little).
fn later_rays(grid: &CoarseGrid, dirs: usize) -> RayCache {
    let estimate = gather_work(grid) * dirs as f64 * KEPT_CORNERS * 12.0;
    if estimate <= RAY_CACHE_BYTES as f64 {
        RayCache::default()
    } else {
        RayCache::within(0)
    }
}

/// The first sources `sources` and `suns` times `scale`: in the delta-Eddington transport
/// medium ([`Medium::delta_eddington`]'s factor `1/(1 − Ωf)`), what `explicit_media_radiance`
/// gathers first.
pub fn scaled_first_sources(
    sources: &Sources,
    suns: &[SunSource],
    scale: f64,
) -> (Sources, Vec<SunSource>) {
    let first = Sources {
        j0: sources.j0.iter().map(|c| c.map(|v| v * scale)).collect(),
        j1: sources
            .j1
            .iter()
            .map(|c| c.map(|a| a.map(|v| v * scale)))
            .collect(),
        escape: sources.escape.clone(),
    };
    let suns = suns
        .iter()
        .map(|s| SunSource {
            emit: s.emit.map(|e| e * scale),
            ..s.clone()
        })
        .collect();
    (first, suns)
}

/// Scattering orders gathered explicitly on the coarse grid of `factor` of `grids`' density
/// (0: [`auto_grid`]'s at the lighting's `detail`, for its voxels' optical depth in
/// `medium` where `thick_cells`, else as thin smoke) (`explicit_media_radiance`): the environment's single scattering from the environment
/// pass's grid `env_grid` and projection `light` when given (else from the centers'
/// moments `center_moments` of `rbfs`), the point lights as moments and the suns exactly,
/// along [`first_theta`]'s directions for the first order (at full detail the
/// environment pass's 72 where HG's peak is broad) and 32 for the later; `orders` of them at full detail,
/// [`orders_at_detail`] below it.
#[allow(clippy::too_many_arguments)]
pub fn frame_explicit_media_radiance(
    grids: &VolumeGrids,
    rbfs: &[Rbf],
    center_moments: &Sources,
    env_grid: Option<(&ShGrid, &RgbSh)>,
    env: &Environment,
    medium: &Medium,
    factor: usize,
    orders: usize,
    (detail, thick_cells): (f64, bool),
    opts: &GridSolveOptions,
) -> MediaRadiance {
    let grid = if factor == 0 {
        // The thickness matters at full detail only (`auto_grid`), where thick cells are
        // asked for (`CrmOptions::thick_cells`): playback skips its pass.
        let tau = if thick_cells && crate::render::detail_or_one(detail) >= 1.0 {
            crate::render::supersample::tau_per_voxel(&grids.density, medium.sigma_t)
        } else {
            0.0
        };
        auto_grid(&grids.density, detail, tau)
    } else {
        CoarseGrid::new(&grids.density, factor)
    };
    let mut sources = match env_grid {
        Some((g, light)) => env_grid_sources(&grid, &grids.density, g, light, medium),
        None => interpolate_centers(&grid, rbfs, center_moments),
    };
    add_lights(&mut sources, &grid, &grids.density, env, medium, false);
    let suns = sun_sources(&grid, &grids.density, env, medium);
    let first: Vec<_> = directions(first_theta(medium.g, detail)).points().collect();
    let later: Vec<_> = directions(GATHER_LATER_THETA).points().collect();
    let orders = orders_at_detail(orders, detail);
    explicit_media_radiance(grid, medium, &sources, &suns, orders, &first, &later, opts)
}

/// The work of the gathered orders on `grid`, in cell steps per direction: the cells
/// with smoke times the mean side, in cells, of the box they occupy (each ray from a
/// cell crosses about that many before it leaves the smoke or the light runs out).
pub fn gather_work(grid: &CoarseGrid) -> f64 {
    let Some((cells, lo, hi)) = grid.smoke_cells() else {
        return 0.0;
    };
    let side = (0..3).map(|a| (hi[a] + 1 - lo[a]) as f64).sum::<f64>() / 3.0;
    cells as f64 * side
}

/// The most [`gather_work`] that the automatic cell size lets the gathered orders do:
/// about 10 s of multiple scattering (measured at four orders, 72 + 3 × 32 directions:
/// 16–18 µs per unit of work on a 2-core machine shared three ways; BENCHMARKS.md,
/// "Multiple scattering: the cell size"; the default six orders add two gathers of 32
/// directions, decision 0079). For g above 0.74 the first order's finer rule
/// ([`gather_theta`]: 128 to 288 directions) makes the same work cost up to 2.3× that:
/// the cells stay as fine, since the rule is what the narrow peak needs.
pub const GATHER_BUDGET: f64 = 6e5;

/// The optical depth across a cell of 2 voxels above which the automatic cells start at
/// one voxel ([`auto_grid`]): voxels over a third of an optical depth thick, the edge
/// where the environment grid's nodes move onto the voxel centers too
/// (`EnvGridOptions::for_smoke`). On thick held-out plumes (σt 10, g 0.8, voxels 0.36–0.42
/// optical depths) cells of one voxel took the final image from 4.8–5.8 % to 3.2–5.1 %
/// off the path tracer, every case measured closer (BENCHMARKS.md, "Thick smoke's
/// scattering orders on the voxels").
pub const MAX_ORDERS_CELL_TAU: f64 = 2.0 / 3.0;

/// Whether voxels `tau` optical depths thick ask for cells of one voxel: a cell of two
/// more than [`MAX_ORDERS_CELL_TAU`] across. False for a `tau` that is not a number.
pub fn thick_for_cells(tau: f64) -> bool {
    2.0 * tau > MAX_ORDERS_CELL_TAU
}

/// The coarse grid of the automatic cell size at the lighting's `detail` (`(0, 1]`,
/// `CrmOptions::detail`; 1 as measured) for smoke whose voxels are `tau` optical depths
/// thick (`supersample::tau_per_voxel`): cells of `⌈2/detail⌉` voxels a side (2, the
/// measured default, at detail 1; 1 at detail 1 where cells of 2 would be more than
/// [`MAX_ORDERS_CELL_TAU`] across), or the smallest larger side up to 8 whose
/// [`gather_work`] is within [`GATHER_BUDGET`]` × detail⁴` (the work falls as `F⁻⁴`:
/// `F⁻³` cells, `F⁻¹` steps per ray), so cells grow as `1/detail` either way and thick
/// smoke keeps cells of one voxel only while they cost no more than the budget.
pub fn auto_grid(fine: &Volume, detail: f64, tau: f64) -> CoarseGrid {
    let detail = crate::render::detail_or_one(detail);
    let first = if detail >= 1.0 && thick_for_cells(tau) {
        1
    } else {
        auto_min_factor(detail)
    };
    let budget = GATHER_BUDGET * detail.powi(4);
    let mut grid = CoarseGrid::new(fine, first);
    for f in first + 1..=8 {
        if gather_work(&grid) <= budget {
            break;
        }
        grid = CoarseGrid::new(fine, f);
    }
    grid
}

/// Whether [`auto_grid`] at full detail takes cells of one voxel on the grid `n` times
/// finer per axis than `density` (the lit grid, `supersample::refine`), whose voxels are
/// `tau` optical depths thick: cells of two voxels more than [`MAX_ORDERS_CELL_TAU`]
/// across, and the work of one-voxel cells within [`GATHER_BUDGET`]. The work is counted
/// on `density` and scaled by `n⁴` (`n³` times the cells, their box `n` times as many
/// cells a side): exact for `n = 1`, for a refined grid up to the cells its smoother
/// edges add. For a renderer that cannot measure the smoke itself (the GPU's gathered
/// orders, `CrmOptions::for_gpu_cells`). False for a `tau` that is not a number.
pub fn one_voxel_cells(density: &Volume, n: usize, tau: f64) -> bool {
    thick_for_cells(tau)
        && gather_work(&CoarseGrid::new(density, 1)) * (n.max(1) as f64).powi(4) <= GATHER_BUDGET
}

/// The fewest explicit orders a lighting detail below 1 leaves ([`orders_at_detail`]).
pub const MIN_DETAIL_ORDERS: usize = 4;

/// The explicit orders gathered at the lighting's `detail` (`(0, 1]`,
/// `CrmOptions::detail`; 1 where it is not a number in that range): `orders` at full
/// detail; below it `⌈orders·detail⌉`, at least [`MIN_DETAIL_ORDERS`] and at most
/// `orders` (decision 0081). A lower detail already widens the cells to `⌈2/detail⌉`
/// voxels ([`auto_min_factor`]), and the viewer's floor takes it only where such cells
/// stay within half an optical depth: smoke thin at the cells' scale, whose later
/// orders carry little that the diffusion after them does not. Six orders at detail
/// 0.43 gather four: held-out plume-e at 400 × 300 within 0.01 points of six against the
/// full-detail picture (1.6–2.0 % at that detail), plume-b 30 at σt 4 within 0.08
/// (BENCHMARKS.md "Fewer orders at a lower detail").
pub fn orders_at_detail(orders: usize, detail: f64) -> usize {
    let detail = crate::render::detail_or_one(detail);
    if detail >= 1.0 {
        return orders;
    }
    ((orders as f64 * detail - 1e-9).ceil() as usize)
        .max(MIN_DETAIL_ORDERS)
        .min(orders)
}

/// The smallest automatic cell side at `detail` (`(0, 1]`) on smoke thinner than
/// [`MAX_ORDERS_CELL_TAU`] a cell of two voxels: `⌈2/detail⌉` voxels, at most 8 (2 at
/// detail 1; the `1e-9` keeps `2/0.5` at 4).
pub fn auto_min_factor(detail: f64) -> usize {
    let detail = crate::render::detail_or_one(detail);
    ((2.0 / detail - 1e-9).ceil() as usize).clamp(2, 8)
}

/// Gauss–Legendre latitudes per hemisphere of the first order's directions where HG's
/// peak is broad (`2·3 × 4·3 = 72`, the environment pass's rule); [`gather_theta`] takes
/// more for a narrow one.
pub const GATHER_THETA: usize = 3;

/// The most latitudes per hemisphere [`gather_theta`] takes (`2·6 × 4·6 = 288`
/// directions, 4× the first order's work at [`GATHER_THETA`]).
pub const GATHER_THETA_MAX: usize = 6;

/// The rule's spacing, `π/(2θ)` in latitude and azimuth, that the first order allows
/// per unit of HG's full width at half maximum (module docs of [`gather_theta`]).
pub const SPACING_PER_WIDTH: f64 = 1.15;

/// Latitudes per hemisphere of the first order's directions for HG asymmetry `g`: the
/// smallest `θ ≥` [`GATHER_THETA`] whose spacing `π/(2θ)` is within [`SPACING_PER_WIDTH`]
/// of HG's full width at half maximum ([`crate::medium::hg_half_width`]), at most
/// [`GATHER_THETA_MAX`]; [`GATHER_THETA`] where HG has no half maximum (`g` below about
/// 0.115, or not a positive number). The first order gathers the suns' once-scattered
/// light with its phase function evaluated at each direction; a rule coarser than the
/// peak aliases it, and bands 2–4 of what it gathers — the light the smoke scatters
/// towards an eye that looks into the sun — come out wrong although [`phase_norm`]
/// keeps the total. Full widths: g 0.5 62.9°, 0.7 31.6°, 0.75 25.4°, 0.8 19.7°, 0.85
/// 14.3°, so `θ` is 3 up to g ≈ 0.74, 4 at 0.8, 5 at 0.82–0.83, 6 from 0.84
/// (BENCHMARKS.md, "The first order's rule follows the phase function's peak": at g 0.8
/// the back-lit multiple scattering went from 6 % dark at `θ = 3` to within 1 % at 4).
pub fn gather_theta(g: f64) -> usize {
    peak_theta(g).max(GATHER_THETA)
}

/// The latitudes per hemisphere HG's peak asks of the first order's rule
/// ([`gather_theta`]'s criterion without its floor): 1 where HG has no half maximum, at
/// most [`GATHER_THETA_MAX`].
fn peak_theta(g: f64) -> usize {
    let Some(half) = crate::medium::hg_half_width(g) else {
        return 1;
    };
    let theta = (std::f64::consts::FRAC_PI_2 / (SPACING_PER_WIDTH * 2.0 * half)).ceil();
    if theta.is_finite() {
        (theta as usize).clamp(1, GATHER_THETA_MAX)
    } else {
        GATHER_THETA_MAX
    }
}

/// Latitudes per hemisphere of the first order's directions at the lighting's `detail`
/// (`(0, 1]`, `CrmOptions::detail`): [`gather_theta`] at full detail; below it the
/// environment pass's rule at that detail (`crate::render::theta_at_detail`: 32
/// directions at 2/3 and below) unless HG's peak asks for more
/// ([`peak_theta`]: 72 directions from g 0.65, 128 from 0.75). Where that is the later
/// orders' rule, every order marches the same rays and the later orders sum the first's
/// kept rays ([`RayCache`]). Decision 0083: on held-out plume-e at detail 0.43 the
/// pictures came out 0.07–0.12 points closer to full detail, not further.
pub fn first_theta(g: f64, detail: f64) -> usize {
    let detail = crate::render::detail_or_one(detail);
    if detail >= 1.0 {
        return gather_theta(g);
    }
    let env = crate::render::theta_at_detail(GATHER_THETA, detail);
    peak_theta(g).max(env).min(gather_theta(g))
}

/// The same for the later orders (`2·2 × 4·2 = 32`): their sources are smooth, and on
/// the tuning scenes 32 directions measured as 72 (BENCHMARKS.md, "Multiple scattering:
/// explicit orders"), 8 a point worse.
pub const GATHER_LATER_THETA: usize = 2;

/// The media radiance of a frame on the grid of `factor`: the coarse grid of `grids`'
/// density, the sources (the centers' single scattering `center_moments` of `rbfs`, and
/// `env`'s lights), the escape probabilities, the solve (module docs).
pub fn frame_media_radiance(
    grids: &VolumeGrids,
    rbfs: &[Rbf],
    center_moments: &Sources,
    env: &Environment,
    medium: &Medium,
    factor: usize,
    opts: &GridSolveOptions,
) -> MediaRadiance {
    let grid = CoarseGrid::new(&grids.density, factor);
    let mut sources = interpolate_centers(&grid, rbfs, center_moments);
    add_lights(&mut sources, &grid, &grids.density, env, medium, true);
    let p = escape(&grid, medium.sigma_t, &fibonacci_directions(DIRECTIONS));
    media_radiance(grid, medium, &sources, &p, opts)
}

/// HG's forward peak beyond the bands that the light towards the eye keeps (0–4):
/// `f = g⁵` for `g > 0`, else 0 (module docs, "The light towards the eye").
pub fn eye_peak_share(g: f64) -> f64 {
    if g > 0.0 { g.powi(5) } else { 0.0 }
}

/// Adds `J_ms(−d) = Ω ((1 − f) L⁰ − (g − f) L¹·d + Σ_{l=2}^{4} (g^l − f) c_lm Y_lm(−d))`
/// of `ms` (`f` [`eye_peak_share`]) to the radiance of every voxel of `grids` with smoke
/// and of its shell ([`crate::render::shell`]), `d` the unit direction from `eye` to the
/// voxel, and sets [`VolumeGrids::eye_peak`] to `Ωf` (module docs).
pub fn add_to_grids(grids: &mut VolumeGrids, ms: &MediaRadiance, medium: &Medium, eye: [f64; 3]) {
    let peak = eye_peak_share(medium.g);
    grids.eye_peak = medium.albedo * peak;
    let density = &grids.density;
    let dims = density.dims();
    let bbox = *density.bbox();
    let vs = density.voxel_size();
    let g = &ms.grid;
    let f = g.factor as f64;
    let plane = dims[0] * dims[1];
    let lit = crate::render::shell::lit_voxels(density);
    // Bands 2–4's factors `g^l − f` (Funk–Hecke on HG less its peak): band 2 is the first
    // 5 of the high coefficients, band 3 the next 7, band 4 the last 9.
    let gl: [f64; HIGH] = std::array::from_fn(|k| {
        medium.g.powi(if k < 5 {
            2
        } else if k < 12 {
            3
        } else {
            4
        }) - peak
    });
    // Per cell `D·(1, L⁰, L¹, bands 2–4)` per channel, interpolated one axis at a time
    // ([`crate::render::separable`]): the cells' trilinear weights times their density.
    const K: usize = 1 + 3 * (4 + HIGH);
    let values: Vec<f64> = (0..g.len())
        .flat_map(|k| {
            let rho = if g.density[k] > 0.0 {
                g.density[k]
            } else {
                0.0
            };
            let mut v = [0.0; K];
            v[0] = rho;
            for ch in 0..3 {
                let at = 1 + ch * (4 + HIGH);
                v[at] = rho * ms.l0[k][ch];
                for a in 0..3 {
                    v[at + 1 + a] = rho * ms.l1[k][ch][a];
                }
                for (h, x) in v[at + 4..at + 4 + HIGH].iter_mut().zip(&ms.high[k][ch]) {
                    *h = rho * x;
                }
            }
            v
        })
        .collect();
    let axes = [0, 1, 2].map(|a| {
        (0..dims[a])
            .map(|v| {
                let c = ((v as f64 + 0.5) / f - 0.5).clamp(0.0, (g.dims[a] - 1) as f64);
                let lo = (c as usize).min(g.dims[a].saturating_sub(2));
                Stencil::new(lo, c - lo as f64, g.dims[a])
            })
            .collect()
    });
    let cells = Separable::new(&values, K, g.dims, axes);
    grids
        .radiance
        .par_chunks_mut(plane.max(1))
        .enumerate()
        .for_each(|(z, slice)| {
            let lit = &lit[z * plane..(z + 1) * plane];
            if !lit.contains(&true) {
                return;
            }
            let mut nodes = cells.slice(z);
            let mut v = [0.0; K];
            for (y, (row, lit)) in slice
                .chunks_mut(dims[0])
                .zip(lit.chunks(dims[0]))
                .enumerate()
            {
                if !lit.contains(&true) {
                    continue;
                }
                nodes.row(y);
                for (x, out) in row.iter_mut().enumerate().filter(|(x, _)| lit[*x]) {
                    nodes.at(x, &mut v);
                    let ws = v[0];
                    if ws <= 0.0 {
                        continue;
                    }
                    let p = [x, y, z].map(|k| k as f64 + 0.5);
                    let p = [0, 1, 2].map(|a| bbox.min[a] + p[a] * vs[a]);
                    let Some(d) = crate::lights::unit([0, 1, 2].map(|a| p[a] - eye[a])) else {
                        continue;
                    };
                    // Bands 2–4 towards the eye, ω = −d, each scaled by `gl`.
                    let mut basis = [0.0; 25];
                    crate::sh::eval_into(5, d.map(|c| -c), &mut basis);
                    for (ch, o) in out.iter_mut().enumerate() {
                        let at = 1 + ch * (4 + HIGH);
                        let l1 = &v[at + 1..at + 4];
                        let flux = l1[0] * d[0] + l1[1] * d[1] + l1[2] * d[2];
                        let high = &v[at + 4..at + 4 + HIGH];
                        let bands: f64 = (0..HIGH).map(|k| gl[k] * high[k] * basis[4 + k]).sum();
                        let j = medium.albedo
                            * ((1.0 - peak) * v[at] - (medium.g - peak) * flux + bands)
                            / ws;
                        *o = (f64::from(*o) + j.max(0.0)) as f32;
                    }
                }
            }
        });
}
