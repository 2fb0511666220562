//! The environment pass: single scattering of the distant environment (the sky or map,
//! the part in SH) per voxel, from a coarse grid of its transmitted radiance in SH —
//! instead of paper A §5.3's source at the RBF centers interpolated over their footprints
//! ([`EnvSource`]).
//!
//! **Model.** A point `x` of the smoke receives from direction `ω` (towards the source)
//! `L(ω)·T(x, ω)`, `T = exp(−σt·τ(x, ω))` through the grid's `D = D̃ + R` to the box's
//! face. Scattered towards the eye (viewing direction `d`, from the eye) with the HG phase
//! of `ω·d` (normalized to `(1/4π)∫p = 1`, Legendre coefficients `(2l+1)g^l`) and the
//! addition theorem, `J(x, d) = (Ω/4π)∫L T p dω = Ω·Σ_l g^l Σ_m E_lm(x)·Y_lm(d)` with
//! `E_lm(x) = ∫ L(ω)·T(x, ω)·Y_lm(ω) dω`, truncated at the renderer's SH order.
//!
//! **The grid** ([`env_grid`]). `E_lm = L_lm − S_lm`: `L_lm` the environment's projection
//! (exact, `sh::project_env`), `S_lm(x) = ∫ L·(1 − T)·Y_lm dω` the light the smoke
//! takes away, which the grid stores at its nodes, by the product rule of
//! `2·theta` Gauss–Legendre latitudes (`theta` per hemisphere: the sky jumps at the
//! horizon) × `4·theta` azimuths, `1 − T = −expm1(−σt·τ)`. The depths `τ` come from a
//! sweep over the node planes, each node's from the depths of nodes nearer the face
//! ([`super::env_sweep`], [`EnvDepths::Sweep`], the default and the GPU twin's rule), along
//! planes of parallel rays one node apart per direction ([`super::ray_planes`],
//! [`EnvDepths::Planes`], the CPU's below full detail: decision 0085), or
//! from a march per node with the lights pass's midpoint rule
//! ([`super::lights_pass::optical_depth`]; the samples in blocks without density skipped,
//! [`Occupancy`], the same sum; [`EnvDepths::March`], the reference the sweep's error is
//! measured against: `benches/env_grid.rs`). Written so, the rule's error is
//! proportional to the shadowing: thin smoke (`T → 1`) gets `L_lm` exactly, where the
//! centers' interpolated source was biased. Nodes span the voxel centers, `spacing`
//! voxels apart (rounded to fit the box), trilinear between ([`ShGrid`]).
//!
//! **The pass** ([`env_pass`]). At every voxel center `u` with `D(u) > 0` and of the
//! smoke's one-voxel shell ([`super::shell`]), seen along
//! `d = (u − eye)/|u − eye|`, `J̃(u, d) += max(0, Ω·Σ_l g^l Σ_m (L_lm − S_lm(u))·Y_lm(d))`
//! (the clamp removes the truncation's ringing where the smoke is almost black), after
//! the volume pass and before the lights pass. The centers then carry the multiple
//! scattering only; their single scattering still feeds the diffusion.
//!
//! **The forward peak** (delta-M, [`peak_share`]). Cut after band `order − 1`, HG's
//! series loses bands that weigh `g^order` and more: at g 0.8 and order 4 the first cut
//! band weighs 41 % of band 0, and the sky seen through the smoke's forward peak comes out
//! blurred (15 % off a path tracer on a held-out front-lit plume). So, for `g > 0`, the
//! pass splits `p = f·4πδ(ω − d) + (1 − f)·p*` with `f = g^order` (delta-M):
//! `p*`'s bands `l < order` are `(g^l − f)/(1 − f)`, so the SH sum takes the factors
//! `Ω(g^l − f)`, and the peak adds `Ω·f·L(d)·T(u, d)`: the distant light straight behind
//! the voxel (seen from the eye), through the smoke behind it, marched like the grid's
//! own directions. `L` is read from [`peak_sky`], the distant radiance averaged on a coarse
//! lat-long (the peak is a few degrees wide, not a ray). With `f` below [`PEAK_MIN`] the
//! peak is left in the series (no march). On the held-out front-lit plume at g 0.8:
//! single scattering 16.4 → 7.9 % off; at g ≤ 0.5 the sky cases move by ≤ 0.4 points.
//! Where the cut is large (`f >` [`super::peak_rule::SHAPED_MIN`], g above 0.56 at order
//! 4) the δ is too narrow: the peak's remainder is a lobe of ~10° with a negative tail,
//! and the pass integrates it by its shape over 8 directions around `d`
//! ([`super::peak_rule`]); thick front-lit smoke at g 0.8 then comes within 2.6–3.3 % of
//! a path tracer, where the δ left it 8–12 % off.
//!
//! The GPU twin is `shaders/env_pass.wgsl` (`gpu::env_pass`).

use super::crm::VolumeGrids;
use super::env_sweep::{DEPTH_CAP, sweep_depths};
use super::lights_pass::optical_depth_within;
use super::occupancy::Occupancy;
use super::peak_rule::{self, PeakRule};
use super::ray_planes::{Centers, RayPlanes, RaySpacing};
use super::separable::{Separable, Stencil};
use super::shell::lit_voxels;
use crate::distant::{Distant, LatLong, Sky, direction};
use crate::env::Environment;
use crate::lighting::single::RgbSh;
use crate::medium::Medium;
use crate::sh::{self, ShGrid, quad::SphereGrid};
use haze_volume::{Bbox, Volume};
use rayon::prelude::*;
use std::f64::consts::PI;

/// Settings of the environment's grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvGridOptions {
    /// Voxels between neighbouring nodes (> 0; rounded per axis so the nodes span the
    /// voxel centers evenly).
    pub spacing: f64,
    /// Gauss–Legendre latitudes per hemisphere of the direction rule
    /// (`2·theta × 2·theta` directions).
    pub theta: usize,
    /// How each node's optical depth towards each direction is found.
    pub depths: EnvDepths,
    /// Whether [`EnvGridOptions::for_smoke`] may move the nodes onto the voxel centers
    /// where the smoke is thick (`false`: `spacing` is a user's and stays as given).
    pub follow_smoke: bool,
}

/// How [`env_grid`] finds the optical depth from each node towards each direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EnvDepths {
    /// A march of its own from every node to the box's face (the reference).
    March,
    /// From the upstream nodes' depths, one node plane at a time
    /// ([`super::env_sweep`]): the same sums to the sweep's interpolation, several
    /// times faster on large grids (the GPU's rule).
    #[default]
    Sweep,
    /// Along planes of parallel rays per direction, one node apart, read at each node
    /// between the 4 × 4 rays around it ([`super::ray_planes`]; the sweep where the
    /// needed nodes are fewer than three across a direction's rays): no march for the
    /// nodes whose way out leaves the domain through a side, no blur that grows with the
    /// planes crossed. The CPU's rule below full detail ([`super::CrmOptions::env_grid`],
    /// decision 0085).
    Planes,
}

impl Default for EnvGridOptions {
    fn default() -> Self {
        EnvGridOptions {
            spacing: 1.5,
            theta: 3,
            depths: EnvDepths::default(),
            follow_smoke: true,
        }
    }
}

/// The grid's spacing, in voxels, on smoke too thick for a wider one
/// ([`EnvGridOptions::for_smoke`]): the nodes on the voxel centers.
pub const THICK_SPACING: f64 = 1.0;

impl EnvGridOptions {
    /// The grid for smoke whose lit voxels are `tau` optical depths across
    /// ([`super::supersample::tau_per_voxel`] on the grid the renderer lights). Where a
    /// cell, `spacing · tau` optical depths across, is thicker than
    /// [`super::MAX_CELL_TAU`], the spacing becomes [`THICK_SPACING`] (at most; a finer
    /// one is kept): the pass then reads `S_lm` at its own nodes, the voxel centers, where
    /// a wider grid interpolated it trilinearly across cells through which the light
    /// taken away changes by more than the model holds (decision 0076: on thick
    /// front-lit smoke, σt 10 at 0.42 optical depths a voxel, the sky's single scattering
    /// 2.1 % bright in the mean and 4.6 % off a path tracer at 1.5 voxels, 0.6 % dark and
    /// 2.6 % off at 1; spacings between gain in proportion).
    /// Unchanged without [`EnvGridOptions::follow_smoke`], for thin smoke, and for a `tau`
    /// that is not a positive number (no bound can be given); an infinite `tau` is thick.
    pub fn for_smoke(self, tau: f64) -> Self {
        if self.follow_smoke && self.spacing * tau > super::MAX_CELL_TAU {
            EnvGridOptions {
                spacing: self.spacing.min(THICK_SPACING),
                ..self
            }
        } else {
            self
        }
    }
}

/// How the fast renderer lights the smoke by the distant environment (single scattering;
/// suns and point lights are the lights pass's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EnvSource {
    /// Paper A §5.3: the source at the RBF centers (`CrmOptions::source_points`),
    /// interpolated by the volume pass.
    Centers,
    /// Per voxel from the grid of the transmitted environment (module docs).
    Grid(EnvGridOptions),
}

/// The direction rule of `theta` latitudes per hemisphere: `(direction, weight)`,
/// weights summing to `4π`.
pub fn directions(theta: usize) -> SphereGrid {
    let t = theta.max(1);
    SphereGrid::hemispheres(t, 4 * t)
}

/// The finest spacing of the grid, in voxels: the density is trilinear between voxel
/// centers, so nodes closer than a quarter voxel hold no more of its shadows, and a finer
/// request would only multiply the nodes (as the inverse cube).
pub const MIN_SPACING: f64 = 0.25;

/// The most nodes the CPU's grid holds (16 M: 1 GiB of `S_lm` at SH order 4, 2.3 GiB at
/// order 6); [`cpu_spacing`] widens a finer grid to fit, as the GPU's widens to fit its
/// buffers (`gpu::env_pass`).
pub const MAX_NODES: usize = 1 << 24;

/// The nodes of the grid over a `dims` grid on `bbox` (no coefficients yet): from the
/// first voxel center to the last, about `spacing` voxels apart (at least two nodes per
/// axis of two voxels or more, one on an axis of one voxel; `spacing` at least
/// [`MIN_SPACING`], 1 where it is not a positive number).
pub fn grid_frame(dims: [usize; 3], bbox: &Bbox, spacing: f64, order: usize) -> ShGrid {
    let spacing = if spacing > 0.0 && spacing.is_finite() {
        spacing.max(MIN_SPACING)
    } else {
        1.0
    };
    let vs = [0, 1, 2].map(|a| bbox.size()[a] / dims[a].max(1) as f64);
    let mut nodes = [1usize; 3];
    let mut cell = [0.0; 3];
    for a in 0..3 {
        if dims[a] >= 2 {
            let span = (dims[a] - 1) as f64;
            nodes[a] = ((span / spacing).ceil() as usize).max(1) + 1;
            cell[a] = span * vs[a] / (nodes[a] - 1) as f64;
        }
    }
    ShGrid {
        min: [0, 1, 2].map(|a| bbox.min[a] + 0.5 * vs[a]),
        cell,
        nodes,
        order,
        coeffs: Vec::new(),
    }
}

/// The rule's directions that bring light: `(ω, P(ω), Y(ω))` with `P` the distant
/// radiance's power in the direction's cell of the rule, `Y` the SH at `order`.
///
/// A cell spans its latitude's share of `cos θ` (the Gauss–Legendre weights laid end to
/// end from the pole of its hemisphere: each node lies inside its span) × its azimuth's
/// `2π/n_φ`, so the cells tile the sphere and their solid angles are the rule's weights.
/// The distant radiance's power per cell is its integral over the cell (a map's:
/// [`cell_powers`]; the built-in sky's: [`sky_cell_powers`]): the light is band-limited
/// to the rule's cells before the rule integrates it, so a bright region narrower than
/// the rule's spacing keeps its power instead of being missed or multiplied by a whole
/// cell's weight (aliasing), and the sky's horizon is not sampled at a few nodes.
pub fn lit_directions(
    env: &Environment,
    theta: usize,
    order: usize,
) -> Vec<([f64; 3], [f64; 3], Vec<f64>)> {
    let rule = directions(theta);
    let powers: Vec<[f64; 3]> = match &env.distant {
        Distant::Map(map) => cell_powers(map, theta),
        Distant::Sky(sky) => sky_cell_powers(sky, theta),
    };
    rule.points()
        .zip(powers)
        .map(|((w, _), p)| (w, p, sh::eval(order, w)))
        .filter(|(_, l, _)| l.iter().any(|&c| c != 0.0))
        .collect()
}

/// The spans of `μ = cos θ` of the latitudes of [`directions`]`(theta)`, in the rule's
/// order: the Gauss–Legendre weights laid end to end from `μ = −1` in increasing `μ`
/// (each node lies inside its span; the spans tile `[−1, 1]`).
fn latitude_spans(theta: usize) -> Vec<(f64, f64)> {
    let lats = SphereGrid::hemisphere_latitudes(theta.max(1));
    let mut by_mu: Vec<usize> = (0..lats.len()).collect();
    by_mu.sort_by(|a, b| lats[*a].0.total_cmp(&lats[*b].0));
    let mut spans = vec![(0.0, 0.0); lats.len()];
    let mut lo = -1.0;
    for &k in &by_mu {
        spans[k] = (lo, lo + lats[k].1);
        lo += lats[k].1;
    }
    spans
}

/// Sub-samples per axis of a cell in [`sky_cell_powers`].
const SKY_CELL_SAMPLES: usize = 8;

/// `∫ L dω` of the built-in `sky` over each cell of [`directions`]`(theta)`, in the rule's
/// order: the midpoint rule on [`SKY_CELL_SAMPLES`]² points of each cell, equally
/// spaced in `μ` and `φ` (equal solid angles, `dω = dμ dφ`). Like a map's
/// ([`cell_powers`]), the sky is band-limited to the rule's cells before the rule
/// integrates it: its horizon, where the sky meets the darker ground, and its sun's glow
/// are not sampled at a few nodes (at 4 × 8 directions the nodes alone moved a plume's
/// picture by 1.4 % against 6 × 12).
pub fn sky_cell_powers(sky: &Sky, theta: usize) -> Vec<[f64; 3]> {
    let n_phi = 4 * theta.max(1);
    let dphi = 2.0 * PI / n_phi as f64;
    let k = SKY_CELL_SAMPLES;
    let mut out = Vec::with_capacity(2 * theta.max(1) * n_phi);
    for (lo, hi) in latitude_spans(theta) {
        let dmu = (hi - lo) / k as f64;
        for j in 0..n_phi {
            let mut p = [0.0; 3];
            for a in 0..k {
                let mu: f64 = lo + (a as f64 + 0.5) * dmu;
                let t = mu.clamp(-1.0, 1.0).acos();
                for b in 0..k {
                    let phi = dphi * (j as f64 + (b as f64 + 0.5) / k as f64);
                    let l = sky.radiance(direction(t, phi));
                    for c in 0..3 {
                        p[c] += l[c] * dmu * dphi / k as f64;
                    }
                }
            }
            out.push(p);
        }
    }
    out
}

/// `∫ L dω` of `map` over each cell of [`directions`]`(theta)`, in the rule's order
/// (see [`lit_directions`]): each texel, constant over its span of `φ` and `cos θ`,
/// gives `L·Δφ·Δμ` of its overlap with each cell (exact for the piecewise-constant map,
/// whatever its size: a one-texel map gives every cell `L·w`).
pub fn cell_powers(map: &LatLong, theta: usize) -> Vec<[f64; 3]> {
    let t = theta.max(1);
    let n_phi = 4 * t;
    // The latitudes' spans of μ = cos θ, in the rule's order.
    let spans = latitude_spans(t);
    let overlap = |a: (f64, f64), b: (f64, f64)| (a.1.min(b.1) - a.0.max(b.0)).max(0.0);
    let (w, h) = (map.width, map.height);
    // Per texel column, the azimuth cells it overlaps and by how much.
    let dphi_cell = 2.0 * PI / n_phi as f64;
    let columns: Vec<Vec<(usize, f64)>> = (0..w)
        .map(|x| {
            let span = (
                2.0 * PI * x as f64 / w as f64,
                2.0 * PI * (x + 1) as f64 / w as f64,
            );
            (0..n_phi)
                .map(|j| {
                    (
                        j,
                        overlap(span, (dphi_cell * j as f64, dphi_cell * (j + 1) as f64)),
                    )
                })
                .filter(|(_, o)| *o > 0.0)
                .collect()
        })
        .collect();
    let mut out = vec![[0.0; 3]; spans.len() * n_phi];
    for y in 0..h {
        let mu = (
            (PI * (y + 1) as f64 / h as f64).cos(),
            (PI * y as f64 / h as f64).cos(),
        );
        let rows: Vec<(usize, f64)> = (0..spans.len())
            .map(|k| (k, overlap(mu, spans[k])))
            .filter(|(_, o)| *o > 0.0)
            .collect();
        for (x, cols) in columns.iter().enumerate() {
            let c = map.texels[y * w + x];
            for &(k, dmu) in &rows {
                for &(j, dphi) in cols {
                    let cell = &mut out[k * n_phi + j];
                    for (o, v) in cell.iter_mut().zip(c) {
                        *o += f64::from(v) * dmu * dphi;
                    }
                }
            }
        }
    }
    out
}

/// The spacing the CPU's grid over `dims` takes for the requested `spacing`: the same,
/// or wider until the grid holds at most [`MAX_NODES`] nodes (each time by the cube root
/// of the excess and a hundredth more).
pub fn cpu_spacing(dims: [usize; 3], spacing: f64) -> f64 {
    let unit = Bbox::new([0.0; 3], [1.0; 3]);
    let mut spacing = if spacing > 0.0 && spacing.is_finite() {
        spacing.max(MIN_SPACING)
    } else {
        1.0
    };
    // Per axis at most 4·span + 1 nodes (MIN_SPACING), so the count fits a u64.
    let count = |s: f64| {
        grid_frame(dims, &unit, s, 0)
            .nodes
            .iter()
            .fold(1u64, |n, &k| n.saturating_mul(k as u64))
    };
    for _ in 0..64 {
        let n = count(spacing);
        if n <= MAX_NODES as u64 {
            break;
        }
        spacing *= 1.01 * (n as f64 / MAX_NODES as f64).cbrt();
    }
    spacing
}

/// Whether the CPU's widening of the grid was said already (once a process: a viewer
/// would say it every frame).
static WIDENED_SAID: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The grid of `S_lm` (module docs) of `env`'s distant light through `density` (σt
/// `sigma_t`), SH of `order`; its spacing [`cpu_spacing`] of `opts.spacing` (a warning
/// says when it is wider).
pub fn env_grid(
    density: &Volume,
    sigma_t: f64,
    env: &Environment,
    order: usize,
    opts: &EnvGridOptions,
) -> ShGrid {
    let dims = density.dims();
    let vs = density.voxel_size();
    let spacing = cpu_spacing(dims, opts.spacing);
    if spacing > opts.spacing.max(MIN_SPACING)
        && !WIDENED_SAID.swap(true, std::sync::atomic::Ordering::Relaxed)
    {
        tracing::warn!(
            "the environment's grid is spaced {spacing:.2} voxels, not {}, to hold at most {} M nodes over {} × {} × {} voxels: the sky's light through the smoke is coarser",
            opts.spacing,
            MAX_NODES >> 20,
            dims[0],
            dims[1],
            dims[2]
        );
    }
    let grid = grid_frame(dims, density.bbox(), spacing, order);
    let nodes = grid.nodes;
    let n2 = sh::count(order);
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let rule = lit_directions(env, opts.theta, order);
    let total = grid.len();
    let occupied = Occupancy::new(density);
    let needed = needed_nodes(density, &grid);
    let coeffs: Vec<f32> = match occupied {
        Some(occupied) if sigma_t > 0.0 => match opts.depths {
            EnvDepths::March => (0..total)
                .into_par_iter()
                .flat_map_iter(|i| {
                    let mut s = vec![0.0f64; 3 * n2];
                    if needed[i] {
                        let x = grid.node([
                            i % nodes[0],
                            (i / nodes[0]) % nodes[1],
                            i / (nodes[0] * nodes[1]),
                        ]);
                        for (w, l, y) in &rule {
                            let tau = optical_depth_within(
                                density,
                                sigma_t,
                                x,
                                *w,
                                f64::MAX,
                                h0,
                                &occupied,
                            );
                            add_lost(&mut s, tau, l, y);
                        }
                    }
                    s.into_iter().map(|v| v as f32)
                })
                .collect(),
            EnvDepths::Sweep | EnvDepths::Planes => {
                let Some(domain) = node_domain(&needed, nodes) else {
                    return ShGrid {
                        coeffs: vec![0.0; total * 3 * n2],
                        ..grid
                    };
                };
                let mut coeffs = vec![0.0f32; total * 3 * n2];
                let depths = NodeDepths {
                    density,
                    sigma_t,
                    grid: &grid,
                    domain,
                    h0,
                    occupied: &occupied,
                    needed: &needed,
                };
                // A few directions' depths at a time (each on its own thread), added to
                // the nodes' sums: memory for SWEEP_BATCH depths a node.
                for batch in rule.chunks(SWEEP_BATCH) {
                    let taus: Vec<Vec<f32>> = batch
                        .par_iter()
                        .map(|(w, _, _)| depths.toward(*w, opts.depths))
                        .collect();
                    coeffs
                        .par_chunks_mut(3 * n2)
                        .enumerate()
                        .filter(|(i, _)| needed[*i])
                        .for_each_init(
                            || vec![0.0f64; 3 * n2],
                            |s, (i, out)| {
                                for (a, &v) in s.iter_mut().zip(out.iter()) {
                                    *a = f64::from(v);
                                }
                                for ((_, l, y), tau) in batch.iter().zip(&taus) {
                                    add_lost(s, f64::from(tau[i]), l, y);
                                }
                                for (o, &v) in out.iter_mut().zip(s.iter()) {
                                    *o = v as f32;
                                }
                            },
                        );
                }
                coeffs
            }
        },
        _ => vec![0.0; total * 3 * n2],
    };
    ShGrid { coeffs, ..grid }
}

/// The box of node indices (per axis the first and last) holding every needed node;
/// `None` without one.
pub(crate) fn node_domain(needed: &[bool], nodes: [usize; 3]) -> Option<[(usize, usize); 3]> {
    let mut domain: Option<[(usize, usize); 3]> = None;
    for (i, _) in needed.iter().enumerate().filter(|(_, n)| **n) {
        let k = [
            i % nodes[0],
            (i / nodes[0]) % nodes[1],
            i / (nodes[0] * nodes[1]),
        ];
        let d = domain.get_or_insert([(k[0], k[0]), (k[1], k[1]), (k[2], k[2])]);
        for a in 0..3 {
            d[a] = (d[a].0.min(k[a]), d[a].1.max(k[a]));
        }
    }
    domain
}

/// Directions swept (or walked) at once by [`EnvDepths::Sweep`] and
/// [`EnvDepths::Planes`].
const SWEEP_BATCH: usize = 8;

/// The planes of rays one node apart over the nodes of `grid` in `domain` towards the
/// unit `w` ([`EnvDepths::Planes`]), their samples at most a node cell apart and at least
/// the march's step (the smallest voxel side) — the sweep's segments' step; `None` where
/// [`RayPlanes::new`] lays none.
pub(crate) fn node_planes(
    density: &Volume,
    sigma_t: f64,
    grid: &ShGrid,
    domain: [(usize, usize); 3],
    w: [f64; 3],
    occupied: &Occupancy,
) -> Option<RayPlanes> {
    let vs = density.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let cell = grid
        .cell
        .iter()
        .filter(|c| **c > 0.0)
        .fold(f64::INFINITY, |m, c| m.min(*c));
    let spacing = RaySpacing {
        across: 1.0,
        along: if cell.is_finite() { cell.max(h0) } else { h0 },
    };
    let centers = Centers::nodes(grid);
    RayPlanes::new(density, sigma_t, centers, domain, w, occupied, spacing)
}

/// What the depths from a grid's nodes take: the density at `sigma_t`, the grid, the box
/// of its needed nodes (`domain`, [`node_domain`]) and which nodes are needed, the
/// march's step `h0` and the density's occupied blocks.
struct NodeDepths<'a> {
    density: &'a Volume,
    sigma_t: f64,
    grid: &'a ShGrid,
    domain: [(usize, usize); 3],
    h0: f64,
    occupied: &'a Occupancy,
    needed: &'a [bool],
}

impl NodeDepths<'_> {
    /// `σt·τ` from every needed node along the unit `w` to the box's face, in node order
    /// (0 at the nodes not needed, or outside the domain with the sweep), by `rule`
    /// (not [`EnvDepths::March`]: the sweep's); [`EnvDepths::Planes`] along
    /// [`node_planes`], the sweep where it lays none.
    fn toward(&self, w: [f64; 3], rule: EnvDepths) -> Vec<f32> {
        let g = self.grid;
        let sweep = || {
            let occupied = self.occupied;
            sweep_depths(
                self.density,
                self.sigma_t,
                g,
                self.domain,
                w,
                self.h0,
                occupied,
            )
        };
        if rule != EnvDepths::Planes {
            return sweep();
        }
        let (density, sigma_t, occupied) = (self.density, self.sigma_t, self.occupied);
        let Some(planes) = node_planes(density, sigma_t, g, self.domain, w, occupied) else {
            return sweep();
        };
        let n = g.nodes;
        let mut tau = vec![0.0f32; g.len()];
        tau.par_iter_mut()
            .enumerate()
            .filter(|(i, _)| self.needed[*i])
            .for_each(|(i, t)| {
                let k = [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
                let x = g.node(k);
                *t = if planes.near_smoky_side(x) {
                    optical_depth_within(density, sigma_t, x, w, f64::MAX, self.h0, occupied)
                        .min(DEPTH_CAP)
                } else {
                    planes.at(k, x)
                } as f32;
            });
        tau
    }
}

/// Adds to a node's sums `s` (3 per coefficient) the light lost along one direction of
/// the rule, power `l` and SH `y`, through optical depth `tau`: `1 − T = −expm1(−τ)`,
/// exact for small τ.
fn add_lost(s: &mut [f64], tau: f64, l: &[f64; 3], y: &[f64]) {
    let lost = -(-tau).exp_m1();
    if lost == 0.0 {
        return;
    }
    for (j, yj) in y.iter().enumerate() {
        for c in 0..3 {
            s[3 * j + c] += lost * l[c] * yj;
        }
    }
}

/// Which nodes the pass reads: those within one cell (per axis, strictly) of the center
/// of a voxel it lights (`D > 0` or the smoke's shell, [`super::shell`]) — the nodes of
/// its trilinear stencil with a non-zero weight. The others are left at zero and cost
/// nothing. (The GPU twin asks the same of each node as: a voxel with `D > 0` within one
/// cell and one voxel, per axis — the shell voxel between them is then within one cell.)
///
/// Per axis a voxel's nodes form an interval that moves up with the voxel, so a node's
/// voxels do too: the node is needed where the box of its voxels holds a lit one, found
/// one axis at a time (an OR over each node's voxel interval along x, then y, then z).
pub fn needed_nodes(density: &Volume, grid: &ShGrid) -> Vec<bool> {
    let dims = density.dims();
    let n = grid.nodes;
    let lit = lit_voxels(density);
    if lit.is_empty() || grid.is_empty() {
        return vec![false; grid.len()];
    }
    let spans = [0, 1, 2].map(|a| voxel_spans(density, grid, a));
    // Along x: per voxel row, its nodes' ORs.
    let rows: Vec<bool> = lit
        .par_chunks(dims[0])
        .flat_map_iter(|row| {
            spans[0]
                .iter()
                .map(move |&(lo, hi)| row[lo..hi].contains(&true))
        })
        .collect();
    // Along y, then z: `src` holds `n[0]` (then `n[0]·n[1]`) entries a voxel line.
    let along = |src: &[bool], line: usize, count: usize, spans: &[(usize, usize)]| {
        src.par_chunks(line * count)
            .flat_map_iter(move |block| {
                spans.iter().flat_map(move |&(lo, hi)| {
                    (0..line).map(move |i| (lo..hi).any(|v| block[v * line + i]))
                })
            })
            .collect::<Vec<bool>>()
    };
    let planes = along(&rows, n[0], dims[1], &spans[1]);
    along(&planes, n[0] * n[1], dims[2], &spans[2])
}

/// Per node along axis `a`, the voxels (`lo..hi`, maybe empty) whose center lies within
/// one cell of it, strictly ([`needed_nodes`]); every voxel at node 0 on an axis of one
/// node.
fn voxel_spans(density: &Volume, grid: &ShGrid, a: usize) -> Vec<(usize, usize)> {
    let count = density.dims()[a];
    let mut spans = vec![(usize::MAX, 0); grid.nodes[a]];
    for v in 0..count {
        let (lo, hi) = node_range(density, grid, a, v);
        for span in &mut spans[lo..=hi] {
            *span = (span.0.min(v), span.1.max(v + 1));
        }
    }
    spans
        .into_iter()
        .map(|(lo, hi)| if lo < hi { (lo, hi) } else { (0, 0) })
        .collect()
}

/// The nodes along axis `a` within one cell, strictly, of voxel `v`'s center (the first
/// and last; node 0 on an axis of one node).
fn node_range(density: &Volume, grid: &ShGrid, a: usize, v: usize) -> (usize, usize) {
    let n = grid.nodes[a];
    if n < 2 || grid.cell[a].is_nan() || grid.cell[a] <= 0.0 {
        return (0, 0);
    }
    let u = density.bbox().min[a] + (v as f64 + 0.5) * density.voxel_size()[a];
    let f = (u - grid.min[a]) / grid.cell[a];
    let lo = (f - 1.0).floor() + 1.0;
    let hi = (f + 1.0).ceil() - 1.0;
    let top = (n - 1) as f64;
    (lo.clamp(0.0, top) as usize, hi.clamp(0.0, top) as usize)
}

/// `f` below which the environment pass keeps HG's forward peak in its SH series: the
/// peak's light is then at most 1 % of the single scattering it would correct.
pub const PEAK_MIN: f64 = 0.01;

/// Size of [`peak_sky`]'s lat-long, texels (about 5.6° each).
pub const PEAK_SKY: [usize; 2] = [64, 32];

/// The share `f = g^order` of HG's phase function that the environment pass takes as its
/// forward peak (module docs): 0 for `g ≤ 0` or `f <` [`PEAK_MIN`].
pub fn peak_share(medium: &Medium, order: usize) -> f64 {
    if medium.g.is_nan() || medium.g <= 0.0 {
        return 0.0;
    }
    let f = medium.g.powi(order as i32);
    if f >= PEAK_MIN { f } else { 0.0 }
}

/// The environment pass's per-coefficient factors `Ω·(g^l − f)`, `f` its
/// [`peak_share`] (module docs).
pub fn env_phase_factors(medium: &Medium, order: usize) -> Vec<f64> {
    let f = peak_share(medium, order);
    phase_factors(medium, order)
        .into_iter()
        .map(|a| a - medium.albedo * f)
        .collect()
}

/// The distant radiance the forward peak sees: `distant` averaged over each texel of a
/// [`PEAK_SKY`] lat-long (4 × 4 samples a texel), read bilinearly
/// ([`LatLong::radiance`]). The GPU twin reads the same texels.
pub fn peak_sky(distant: &Distant) -> LatLong {
    const SUB: usize = 4;
    let [w, h] = PEAK_SKY;
    let texels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut sum = [0.0f64; 3];
            for sy in 0..SUB {
                for sx in 0..SUB {
                    let phi = 2.0 * PI * (x as f64 + (sx as f64 + 0.5) / SUB as f64) / w as f64;
                    let theta = PI * (y as f64 + (sy as f64 + 0.5) / SUB as f64) / h as f64;
                    let l = distant.radiance(crate::distant::direction(theta, phi));
                    for c in 0..3 {
                        sum[c] += l[c];
                    }
                }
            }
            sum.map(|v| (v / (SUB * SUB) as f64) as f32)
        })
        .collect();
    LatLong {
        width: w,
        height: h,
        texels,
    }
}

/// The per-coefficient factors `Ω·g^l` of `J = Σ_j Ω g^l E_j Y_j(d)` at `order`.
pub fn phase_factors(medium: &Medium, order: usize) -> Vec<f64> {
    (0..sh::count(order))
        .map(|j| medium.albedo * medium.g.powi(sh::basis::band_of(j) as i32))
        .collect()
}

/// Adds the environment's single scattering to the radiance of `grids` (camera at `eye`),
/// from [`env_grid`] of `opts` and `light`, the environment's projection at `order`
/// (module docs). Returns the grid (for inspection, the GPU twin's tests, and
/// [`add_env_grid`] from another camera); nothing is added with albedo 0.
pub fn env_pass(
    grids: &mut VolumeGrids,
    env: &Environment,
    light: &RgbSh,
    medium: &Medium,
    eye: [f64; 3],
    order: usize,
    opts: &EnvGridOptions,
) -> ShGrid {
    let grid = env_grid(&grids.density, medium.sigma_t, env, order, opts);
    add_env_grid(grids, &grid, light, medium, eye, order, &env.distant);
    grid
}

/// The second half of [`env_pass`]: adds the single scattering of the environment's
/// projection `light` less the blocked light of `grid` (its [`env_grid`] for the density
/// of `grids`) towards `eye`. The grid does not depend on the camera, so a camera move
/// only repeats this.
pub fn add_env_grid(
    grids: &mut VolumeGrids,
    grid: &ShGrid,
    light: &RgbSh,
    medium: &Medium,
    eye: [f64; 3],
    order: usize,
    distant: &Distant,
) {
    if medium.albedo == 0.0 {
        return;
    }
    let n2 = sh::count(order);
    let a = env_phase_factors(medium, order);
    let f = peak_share(medium, order);
    let sky = (f > 0.0).then(|| peak_sky(distant));
    let rule = PeakRule::new(medium.g, order, f);
    let density = &grids.density;
    // The peak's marches skip empty blocks; without a peak nothing marches here.
    let occupied = if f > 0.0 {
        Occupancy::new(density)
    } else {
        None
    };
    let dims = density.dims();
    let bbox = *density.bbox();
    let vs = density.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let plane = dims[0] * dims[1];
    let lit = lit_voxels(density);
    // The grid's SH at the voxel centers, one axis at a time ([`super::separable`]).
    let axes = [0, 1, 2].map(|a| {
        (0..dims[a])
            .map(|v| {
                let (lo, t) = grid.axis_stencil(a, bbox.min[a] + (v as f64 + 0.5) * vs[a]);
                Stencil::new(lo, t, grid.nodes[a])
            })
            .collect()
    });
    let nodes = (!grid.is_empty()).then(|| Separable::new(&grid.coeffs, 3 * n2, grid.nodes, axes));
    grids
        .radiance
        .par_chunks_mut(plane.max(1))
        .enumerate()
        .for_each(|(z, slice)| {
            let lit = &lit[z * plane..(z + 1) * plane];
            if !lit.contains(&true) {
                return;
            }
            let mut nodes = nodes.as_ref().map(|n| n.slice(z));
            let mut s = vec![0.0; 3 * n2];
            let mut y = vec![0.0; n2];
            let rows = slice.chunks_mut(dims[0]).zip(lit.chunks(dims[0]));
            for (yy, (row, lit)) in rows.enumerate() {
                if !lit.contains(&true) {
                    continue;
                }
                if let Some(nodes) = &mut nodes {
                    nodes.row(yy);
                }
                for (x, out) in row.iter_mut().enumerate().filter(|(x, _)| lit[*x]) {
                    if let Some(nodes) = &nodes {
                        nodes.at(x, &mut s);
                    }
                    let i = x + dims[0] * yy;
                    let u = [x, yy, z].map(|k| k as f64 + 0.5);
                    let u = [0, 1, 2].map(|k| bbox.min[k] + u[k] * vs[k]);
                    let Some(d) = crate::lights::unit([0, 1, 2].map(|k| u[k] - eye[k])) else {
                        continue;
                    };
                    sh::eval_into(order, d, &mut y);
                    for c in 0..3 {
                        let j: f64 = (0..n2)
                            .map(|k| a[k] * (light[c][k] - s[3 * k + c]) * y[k])
                            .sum();
                        out[c] = (f64::from(out[c]) + j.max(0.0)) as f32;
                    }
                    if let (Some(sky), Some(occupied)) = (&sky, &occupied) {
                        // The forward peak: the light behind u, through the smoke, over the
                        // peak's rule (its δ: straight behind).
                        let spin = peak_rule::spin((z * plane + i) as u32);
                        for (w, weight) in rule.directions(d, spin) {
                            let tau = optical_depth_within(
                                density,
                                medium.sigma_t,
                                u,
                                w,
                                f64::MAX,
                                h0,
                                occupied,
                            );
                            let t = (-tau).exp();
                            let l = sky.radiance(w);
                            for c in 0..3 {
                                out[c] =
                                    (f64::from(out[c]) + medium.albedo * weight * l[c] * t) as f32;
                            }
                        }
                    }
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// [`needed_nodes`] by its definition, voxel by voxel: every lit voxel marks the
    /// nodes within one cell of its center on every axis.
    fn needed_by_each_voxel(density: &Volume, grid: &ShGrid) -> Vec<bool> {
        let d = density.dims();
        let n = grid.nodes;
        let mut needed = vec![false; grid.len()];
        for (i, _) in lit_voxels(density).iter().enumerate().filter(|(_, l)| **l) {
            let k = [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])];
            let r = [0, 1, 2].map(|a| node_range(density, grid, a, k[a]));
            for z in r[2].0..=r[2].1 {
                for y in r[1].0..=r[1].1 {
                    for x in r[0].0..=r[0].1 {
                        needed[x + n[0] * (y + n[1] * z)] = true;
                    }
                }
            }
        }
        needed
    }

    #[test]
    fn the_needed_nodes_are_those_each_lit_voxel_marks() {
        // Pseudo-random smoke (a seeded PCG), one voxel in 40 and
        // one in 400, on grids finer and coarser than the voxels, with axes one voxel and
        // one node thick; and the voxel-by-voxel count of a node's voxels checked once.
        let mut rng = Pcg64::seed_from_u64(0x2545_f491_4f6c_dd1d);
        for dims in [[17, 12, 9], [1, 10, 14], [11, 9, 1]] {
            for every in [40, 400] {
                let total: usize = dims.iter().product();
                let data = (0..total)
                    .map(|_| {
                        if rng.random_range(0..every) == 0 {
                            0.7
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let bbox = Bbox::new([-1.0, 0.0, 2.0], [1.5, 1.0, 3.5]);
                let density = Volume::new(dims, bbox, data).unwrap();
                for spacing in [0.4, 1.0, 1.5, 2.6, 3.9, 40.0] {
                    let grid = grid_frame(dims, &bbox, spacing, 1);
                    assert_eq!(
                        needed_nodes(&density, &grid),
                        needed_by_each_voxel(&density, &grid),
                        "{dims:?}, one in {every}, spacing {spacing}"
                    );
                }
            }
        }
    }

    fn map(w: usize, h: usize, f: impl Fn(usize, usize) -> f32) -> LatLong {
        let texels = (0..w * h).map(|i| [f(i % w, i / w), 1.0, 0.5]).collect();
        LatLong::new(w, h, texels).unwrap()
    }

    #[test]
    fn the_cpu_grid_widens_to_its_node_budget_and_no_further() {
        // A grid that fits keeps its spacing; a production-size one (512 × 512 × 640
        // voxels at the default 1.5: 342 × 342 × 427 = 49.9 M nodes) widens to at most
        // MAX_NODES, in one step of the cube root of its excess and a hundredth here
        // (2.18 voxels, 98 % of the budget; a second step would only be for the node
        // counts' rounding); spacings below MIN_SPACING and nonsense ones give finite
        // grids of at most 4 nodes a voxel.
        let nodes = |dims: [usize; 3], s: f64| {
            let g = grid_frame(dims, &Bbox::new([0.0; 3], [1.0; 3]), s, 4);
            g.nodes.iter().map(|&n| n as u64).product::<u64>()
        };
        assert_eq!(cpu_spacing([96, 96, 128], 1.5), 1.5);
        let big = [512, 512, 640];
        let excess = nodes(big, 1.5) as f64 / MAX_NODES as f64;
        assert!(excess > 2.0, "{excess}");
        let s = cpu_spacing(big, 1.5);
        assert!(nodes(big, s) <= MAX_NODES as u64);
        let most = 1.5 * 1.01 * excess.cbrt() * (1.0 + 1e-12);
        assert!(s > 1.5 && s <= most, "{s} (at most {most})");
        for bad in [1e-300, 0.0, -1.0, f64::NAN, f64::INFINITY] {
            let s = cpu_spacing(big, bad);
            assert!(s.is_finite() && s >= MIN_SPACING, "{bad}: {s}");
            assert!(nodes(big, s) <= MAX_NODES as u64, "{bad}");
        }
        let fine = grid_frame([48, 48, 64], &Bbox::new([0.0; 3], [1.0; 3]), 1e-12, 4);
        assert_eq!(fine.nodes, [189, 189, 253]);
    }

    #[test]
    fn the_built_in_skys_cells_keep_its_power() {
        // ∫ L dω of the built-in sky: the horizon-to-zenith blend over the upper
        // hemisphere π(h + z) and the ground 2π·g in closed form, the glow
        // ∫_{ω_z ≥ 0} max(0, ω·s)⁸ dω (it stops at the horizon) by a fine midpoint rule
        // (400 × 800 cells of the upper hemisphere; the integrand is C⁷).
        let sky = Sky::default();
        let s = sky.sun_direction;
        let (nu, np) = (400, 800);
        let mut glow = 0.0;
        for i in 0..nu {
            let mu = (i as f64 + 0.5) / nu as f64;
            let r = (1.0 - mu * mu).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let c = r * phi.cos() * s[0] + r * phi.sin() * s[1] + mu * s[2];
                glow += c.max(0.0).powi(8);
            }
        }
        glow *= 2.0 * PI / (nu * np) as f64;
        assert!(
            glow < 2.0 * PI / 9.0 && glow > 0.8 * 2.0 * PI / 9.0,
            "{glow}"
        );
        let want = |c: usize| {
            PI * (sky.horizon[c] + sky.zenith[c]) + 2.0 * PI * sky.ground[c] + sky.sun[c] * glow
        };
        for theta in [2, 3, 4] {
            let cells = sky_cell_powers(&sky, theta);
            assert_eq!(cells.len(), directions(theta).len());
            for c in 0..3 {
                let total: f64 = cells.iter().map(|p| p[c]).sum();
                // The horizon's step lies on a cell edge (μ = 0); the blend is linear in
                // μ (exact under the midpoint rule); only the glow's curvature and its
                // kink where ω·s = 0 are left (6.6e-4 of the total at 4 × 8 cells).
                assert!(
                    (total - want(c)).abs() < 1e-3 * want(c),
                    "θ {theta}: {total} vs {}",
                    want(c)
                );
            }
            // Every cell holds the sky's light around its node: below the horizon the
            // ground's `g·w` exactly (the glow stops at the horizon).
            for ((d, w), p) in directions(theta).points().zip(&cells) {
                if d[2] < 0.0 {
                    assert!(
                        (p[0] - sky.ground[0] * w).abs() < 1e-12 * w.max(1.0),
                        "{d:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn cells_tile_the_sphere_and_keep_a_maps_power() {
        for theta in [1, 3, 4] {
            let rule: Vec<f64> = directions(theta).points().map(|(_, w)| w).collect();
            // A constant map of any size, one texel included, gives every cell L·w: the
            // cells' solid angles are the rule's weights.
            for (w, h) in [(1, 1), (5, 3), (64, 32), (100, 50)] {
                let cells = cell_powers(&map(w, h, |_, _| 2.0), theta);
                for (c, wt) in cells.iter().zip(&rule) {
                    assert!((c[0] - 2.0 * wt).abs() < 1e-12, "{w}×{h}, θ {theta}");
                    assert!((c[1] - wt).abs() < 1e-12);
                }
            }
            // Any map: the cells share its power exactly (Σ L·Ω of its texels).
            let m = map(37, 19, |x, y| ((x * 7 + y * 3) % 11) as f32);
            let cells = cell_powers(&m, theta);
            let total: f64 = cells.iter().map(|c| c[0]).sum();
            let mut want = 0.0;
            for y in 0..m.height {
                for x in 0..m.width {
                    want += f64::from(m.texels[y * m.width + x][0]) * m.texel_direction(x, y).1;
                }
            }
            assert!(
                (total - want).abs() < 1e-9 * want,
                "θ {theta}: {total} vs {want}"
            );
        }
    }

    #[test]
    fn a_bright_texel_between_nodes_keeps_its_power() {
        // One bright texel in a black map, away from every node: point samples at the
        // nodes see nothing of it (the aliasing this fixes); one cell gets all its power.
        let (w, h) = (256, 128);
        let (x, y) = (10, 40);
        let mut texels = vec![[0.0f32; 3]; w * h];
        texels[y * w + x] = [1000.0, 0.0, 0.0];
        let m = LatLong::new(w, h, texels).unwrap();
        let omega = m.texel_direction(x, y).1;
        let nodes_see: f64 = directions(3).points().map(|(n, _)| m.radiance(n)[0]).sum();
        assert_eq!(nodes_see, 0.0);
        let lit = lit_directions(&Environment::map(m), 3, 2);
        assert_eq!(lit.len(), 1);
        assert!((lit[0].1[0] - 1000.0 * omega).abs() < 1e-9 * lit[0].1[0]);
    }
}
