//! The lights pass: suns and point lights added exactly to the volume-pass grids, per
//! voxel, after [`super::crm::volume_pass`] (which carries the environment's SH).
//!
//! At a voxel center `u` with `D(u) > 0`, seen along `d` (from the eye), each light adds
//! `J(u, d) += Ω·E(u)·T(u)·p(s·d)/4π` (`crate::lights` module docs), `s` the unit vector
//! towards the light, `p` the disk-averaged HG of a sun or HG for a point light. A point
//! light's `E = I·min(1/r², 1/R²)`, `R` four voxels: within that sphere the view pass
//! adds the rest of its `1/r²` along each ray ([`super::near_light`]). The
//! transmittance `T = exp(−σt·τ)` is marched through the grid's `D = D̃ + R` (the shadow
//! volume, residual included): `τ = Σ_k D(u + (k + ½)h·s)·h` over `n = ⌈ℓ/h₀⌉` equal
//! steps `h = ℓ/n`, `h₀` the smallest voxel side, `ℓ` the distance to the box's face (or
//! to a point light inside the box), `D` trilinear (`field::sample`); the march stops
//! once `σt·τ > 20` (`T < 2·10⁻⁹`), and skips its samples in blocks without density
//! ([`Occupancy`]: the same sum). Voxels with `D = 0` emit nothing and are skipped.
//!
//! **At a lower detail** ([`lights_pass_at`], `CrmOptions::detail` below 1) a sun's `τ`
//! comes instead from planes of parallel rays towards it ([`RayPlanes`]): rays one voxel
//! apart, or [`SUN_SPACING`] voxels at a detail of `1/SUN_SPACING` and below, each walked
//! once through the lit voxels' planes, one or two samples a plane, and each voxel reading
//! its plane's depths from the rays around it — about one sample a voxel instead of a
//! march a voxel, its shadows' edges blurred sideways by about a ray spacing at most
//! (voxels within two ray spacings of a box face with smoke on it march:
//! `RayPlanes::near_smoky_side`).
//! Point lights still march.
//!
//! **Kept across camera moves** ([`LightShadows`]): `T(u)` does not depend on the eye,
//! only `p(s·d)` does, so the pass is split into the shadows, marched (or walked along rays) once a
//! frame, and their addition through the phase function from an eye — on a 96 × 96 ×
//! 128 frame under one sun 0.25 s against 0.007 s (`BENCHMARKS.md`, "Camera moves keep
//! the lights' shadows").
//!
//! The GPU twin is `shaders/lights_pass.wgsl` (`gpu::lights_pass`).

use super::crm::VolumeGrids;
use super::occupancy::Occupancy;
use super::ray_planes::{Centers, RayPlanes, RaySpacing};
use super::shell::lit_voxels;
use crate::env::Environment;
use crate::field;
use crate::lights::{DiskPhase, dot};
use crate::medium::{FOUR_PI, Medium, hg};
use haze_volume::{Bbox, Volume};
use rayon::prelude::*;
use std::sync::Arc;

/// The spacing in voxels of the rays a sun's shadow is walked along ([`RayPlanes`]) at a
/// lighting detail of `1/SUN_SPACING` and below (between it and 1, one voxel). Chosen
/// for a sweep of the sun's depths over a lattice this far apart (decision 0082); the
/// rays that replaced it (decision 0084) keep it: on held-out plume-e at detail 0.43
/// they took the shadows from 16–23 ms to the figures in `BENCHMARKS.md`, "A sun's
/// shadow along planes of rays".
pub const SUN_SPACING: f64 = 1.5;

/// Optical depth (σt·τ) beyond which the shadow march stops.
pub const SHADOW_CUTOFF: f64 = 20.0;

/// Adds the suns and point lights of `env` to the radiance of `grids` (camera at `eye`),
/// every shadow marched (module docs).
pub fn lights_pass(grids: &mut VolumeGrids, env: &Environment, medium: &Medium, eye: [f64; 3]) {
    lights_pass_at(grids, env, medium, eye, 1.0);
}

/// [`lights_pass`] at the lighting's `detail` (`CrmOptions::detail`): below 1 the suns'
/// shadows come from planes of rays parallel to each sun (module docs).
pub fn lights_pass_at(
    grids: &mut VolumeGrids,
    env: &Environment,
    medium: &Medium,
    eye: [f64; 3],
    detail: f64,
) {
    if let Some(shadows) = LightShadows::new(&grids.density, env, medium, detail) {
        shadows.add_to(grids, env, medium, eye);
    }
}

/// The lights pass's shadows: every lit voxel's transmittance `T(u)` towards each light,
/// which depends on the density, σt, the lights and the detail but not on the eye — so a
/// camera move keeps them and adds the lights again through the phase function alone
/// ([`LightShadows::add_to`]). `T` is kept in `f64` as marched: a pass from kept
/// shadows is [`lights_pass_at`]'s to the bit.
#[derive(Clone, Debug)]
pub struct LightShadows {
    /// The voxels lit: those with `D > 0` and their shell ([`lit_voxels`]).
    lit: Vec<bool>,
    /// Per z slice, where its lit voxels' transmittances start in `t`.
    starts: Vec<usize>,
    /// Per lit voxel (x fastest), the suns' `T` then the point lights' (`NaN` for a
    /// point light at the voxel's center: isotropic and unshadowed there).
    t: Vec<f64>,
    /// Suns and point lights the shadows were marched for.
    lights: (usize, usize),
}

impl LightShadows {
    /// The shadows of `env`'s suns and point lights in `density` at `medium`'s σt and the
    /// lighting's `detail` (module docs); `None` where the pass adds nothing (no lights,
    /// albedo 0, no density).
    pub fn new(
        density: &Volume,
        env: &Environment,
        medium: &Medium,
        detail: f64,
    ) -> Option<LightShadows> {
        if !env.has_lights() || medium.albedo == 0.0 {
            return None;
        }
        // No density: nothing to light (the lit voxels are those with `D > 0` and their
        // shell).
        let occupied = Occupancy::new(density)?;
        let dims = density.dims();
        let vs = density.voxel_size();
        let h0 = vs[0].min(vs[1]).min(vs[2]);
        let plane = dims[0] * dims[1];
        let lit = lit_voxels(density);
        // Per sun, at a lower detail, σt·τ along rays parallel to it: one voxel apart, or
        // `SUN_SPACING` at `1/SUN_SPACING` and below.
        let detail = super::detail_or_one(detail);
        let lit_box = super::env_pass::node_domain(&lit, dims);
        let walked: Vec<Option<RayPlanes>> = env
            .suns
            .iter()
            .map(|sun| {
                let lit_box = lit_box.filter(|_| detail < 1.0)?;
                let spacing = if detail * SUN_SPACING <= 1.0 {
                    SUN_SPACING
                } else {
                    1.0
                };
                // Samples at most a ray spacing apart (one voxel at least).
                let spacing = RaySpacing {
                    across: spacing,
                    along: spacing.max(1.0) * h0,
                };
                RayPlanes::new(
                    density,
                    medium.sigma_t,
                    Centers::voxels(density),
                    lit_box,
                    sun.direction,
                    &occupied,
                    spacing,
                )
            })
            .collect();
        let slices: Vec<Vec<f64>> = (0..dims[2])
            .into_par_iter()
            .map(|z| {
                let mut out = Vec::new();
                for i in 0..plane {
                    let idx = z * plane + i;
                    if !lit[idx] {
                        continue;
                    }
                    let (x, y) = (i % dims[0], i / dims[0]);
                    let u = density.voxel_center(x, y, z);
                    for (sun, walked) in env.suns.iter().zip(&walked) {
                        let depth = match walked {
                            Some(planes) if !planes.near_smoky_side(u) => planes.at([x, y, z], u),
                            _ => optical_depth_within(
                                density,
                                medium.sigma_t,
                                u,
                                sun.direction,
                                f64::MAX,
                                h0,
                                &occupied,
                            ),
                        };
                        out.push((-depth).exp());
                    }
                    for light in &env.points {
                        let v = [0, 1, 2].map(|a| light.position[a] - u[a]);
                        let t = match crate::lights::unit(v) {
                            Some(s) => (-optical_depth_within(
                                density,
                                medium.sigma_t,
                                u,
                                s,
                                dot(v, v).sqrt(),
                                h0,
                                &occupied,
                            ))
                            .exp(),
                            None => f64::NAN,
                        };
                        out.push(t);
                    }
                }
                out
            })
            .collect();
        let mut starts = Vec::with_capacity(slices.len());
        let mut t = Vec::with_capacity(slices.iter().map(Vec::len).sum());
        for slice in slices {
            starts.push(t.len());
            t.extend(slice);
        }
        Some(LightShadows {
            lit,
            starts,
            t,
            lights: (env.suns.len(), env.points.len()),
        })
    }

    /// Adds `env`'s suns and point lights through these shadows to the radiance of
    /// `grids` seen from `eye` (module docs): `env`, `medium` and the grids' density must
    /// be those the shadows were marched for (the eye alone may differ).
    pub fn add_to(
        &self,
        grids: &mut VolumeGrids,
        env: &Environment,
        medium: &Medium,
        eye: [f64; 3],
    ) {
        debug_assert_eq!(self.lights, (env.suns.len(), env.points.len()));
        debug_assert_eq!(self.lit.len(), grids.density.data().len());
        let phases: Vec<Arc<DiskPhase>> = env
            .suns
            .iter()
            .map(|s| DiskPhase::shared(medium.g, s.angle))
            .collect();
        let density = &grids.density;
        let dims = density.dims();
        let vs = density.voxel_size();
        let h0 = vs[0].min(vs[1]).min(vs[2]);
        // A point light's 1/r² held at most 1/R² (R four voxels): the view pass adds the rest
        // inside that sphere along its rays (`near_light`, "The split").
        let soft = super::near_light::NearLights::radius2(h0);
        let plane = dims[0] * dims[1];
        let k = medium.albedo / FOUR_PI;
        let per_voxel = env.suns.len() + env.points.len();
        grids
            .radiance
            .par_chunks_mut(plane.max(1))
            .enumerate()
            .for_each(|(z, slice)| {
                let mut kept = self.t[self.starts[z]..].chunks_exact(per_voxel.max(1));
                for (i, out) in slice.iter_mut().enumerate() {
                    let idx = z * plane + i;
                    if !self.lit[idx] {
                        continue;
                    }
                    let ts = kept.next().unwrap_or(&[]);
                    let u = density.voxel_center(i % dims[0], i / dims[0], z);
                    let Some(d) = crate::lights::unit([0, 1, 2].map(|a| u[a] - eye[a])) else {
                        continue;
                    };
                    let (sun_t, point_t) = ts.split_at(env.suns.len().min(ts.len()));
                    let mut add = [0.0f64; 3];
                    for ((sun, phase), &t) in env.suns.iter().zip(&phases).zip(sun_t) {
                        if t <= 0.0 {
                            continue;
                        }
                        let p = phase.eval(dot(sun.direction, d));
                        for (a, e) in add.iter_mut().zip(sun.irradiance) {
                            *a += e * t * p;
                        }
                    }
                    for (light, &t) in env.points.iter().zip(point_t) {
                        let v = [0, 1, 2].map(|a| light.position[a] - u[a]);
                        let Some(s) = crate::lights::unit(v) else {
                            // The light at the voxel center: isotropic, unshadowed.
                            for (a, i) in add.iter_mut().zip(light.intensity) {
                                *a += i / soft;
                            }
                            continue;
                        };
                        let r2 = dot(v, v);
                        let p = hg(medium.g, dot(s, d));
                        for (a, i) in add.iter_mut().zip(light.intensity) {
                            *a += i / r2.max(soft) * t * p;
                        }
                    }
                    for c in 0..3 {
                        out[c] = (f64::from(out[c]) + k * add[c]) as f32;
                    }
                }
            });
    }
}

/// `exp(−σt·τ)` from `u` along the unit `s` to the box's face or `max_len`, whichever is
/// nearer, by the midpoint rule on the trilinear density (module docs); `h0` the step.
pub fn transmittance(
    density: &Volume,
    sigma_t: f64,
    u: [f64; 3],
    s: [f64; 3],
    max_len: f64,
    h0: f64,
) -> f64 {
    (-optical_depth(density, sigma_t, u, s, max_len, h0)).exp()
}

/// The optical depth `σt·τ` of [`transmittance`], the march stopped once it exceeds
/// [`SHADOW_CUTOFF`] (0 for σt = 0 or no way through the box).
pub fn optical_depth(
    density: &Volume,
    sigma_t: f64,
    u: [f64; 3],
    s: [f64; 3],
    max_len: f64,
    h0: f64,
) -> f64 {
    march(density, sigma_t, u, s, max_len, h0, density.bbox(), None)
}

/// [`optical_depth`] with the samples outside `occupied`'s box and in its empty blocks
/// skipped: the same sum, since the trilinear density is zero there ([`Occupancy`]), the
/// same steps and sample points, only fewer of them visited.
pub fn optical_depth_within(
    density: &Volume,
    sigma_t: f64,
    u: [f64; 3],
    s: [f64; 3],
    max_len: f64,
    h0: f64,
    occupied: &Occupancy,
) -> f64 {
    march(
        density,
        sigma_t,
        u,
        s,
        max_len,
        h0,
        occupied.bbox(),
        Some(occupied),
    )
}

/// The midpoint march of [`optical_depth`] over the samples within `bbox` (a step to
/// spare on each side), those `blocks` says are zero skipped.
#[allow(clippy::too_many_arguments)]
fn march(
    density: &Volume,
    sigma_t: f64,
    u: [f64; 3],
    s: [f64; 3],
    max_len: f64,
    h0: f64,
    bbox: &Bbox,
    blocks: Option<&Occupancy>,
) -> f64 {
    if sigma_t == 0.0 {
        return 0.0;
    }
    let len = match field::ray_box(u, s, density.bbox()) {
        Some((_, t1)) => t1.min(max_len),
        None => return 0.0,
    };
    if len.is_nan() || len <= 0.0 {
        return 0.0;
    }
    let Some((ta, tb)) = field::ray_box(u, s, bbox) else {
        return 0.0;
    };
    let n = (len / h0).ceil().max(1.0);
    let h = len / n;
    // Sample k sits at (k + ½)h: those in [ta, tb] and a step to spare on each side.
    let k0 = ((ta / h - 1.0).floor().max(0.0)).min(n) as u64;
    let k1 = ((tb / h + 1.0).ceil().max(0.0)).min(n) as u64;
    let line = field::Sampler::new(density).line(u, s, h);
    let mut depth = 0.0;
    for k in k0..k1 {
        // Outside the box the density is 0: nothing to add.
        let Some(q) = line.coords(k) else {
            continue;
        };
        if blocks.is_some_and(|b| !b.may_hold_coords(q)) {
            continue;
        }
        depth += sigma_t * line.at_coords(q) * h;
        if depth > SHADOW_CUTOFF {
            break;
        }
    }
    depth
}

/// A box outside which the trilinear density of `density` is zero: the voxel centers
/// with `D > 0` grown by one voxel (the reach of `field::sample`'s stencil), within the
/// grid's box; `None` when no voxel has `D > 0`.
pub fn occupied_box(density: &Volume) -> Option<Bbox> {
    let cells = density.occupied_bbox(0.0)?;
    Some(grown_by_half_a_voxel(density, &cells))
}

/// The cells `cells` of `density`'s voxels grown by half a voxel on every side, within
/// the box ([`occupied_box`]).
pub(crate) fn grown_by_half_a_voxel(density: &Volume, cells: &Bbox) -> Bbox {
    let vs = density.voxel_size();
    let outer = density.bbox();
    Bbox::new(
        [0, 1, 2].map(|a| (cells.min[a] - 0.5 * vs[a]).max(outer.min[a])),
        [0, 1, 2].map(|a| (cells.max[a] + 0.5 * vs[a]).min(outer.max[a])),
    )
}
