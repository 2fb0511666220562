//! The first-scattering source moments `J⁰`, `J¹` per coarse cell: the environment's
//! single scattering interpolated from the RBF centers (eq. 12, as the volume pass
//! interpolates it), and the suns' and point lights' direct light with its transmittance
//! marched through the volume pass's density, as the lights pass marches it.

use super::CoarseGrid;
use super::gather::SunSource;
use crate::diffusion::Sources;
use crate::env::Environment;
use crate::lighting::single::RgbSh;
use crate::lights::{DiskPhase, unit};
use crate::medium::{FOUR_PI, Medium};
use crate::render::env_pass::phase_factors;
use crate::render::lights_pass::transmittance;
use crate::sh::{self, ShGrid};
use haze_volume::rbf::voxel_span;
use haze_volume::{Rbf, Volume};
use rayon::prelude::*;
use std::f64::consts::PI;

/// `J¹` of one point, `[channel][axis]`.
type Moment1 = [[f64; 3]; 3];

/// `J⁰`, `J¹` of the centers' sources `centers` (one per RBF) at every cell center:
/// `J(x) = Σ v_l(x) J_l / Σ v_l(x)`, `v_l = w_l B_l`; 0 where no RBF reaches.
pub fn interpolate_centers(grid: &CoarseGrid, rbfs: &[Rbf], centers: &Sources) -> Sources {
    let d = grid.dims;
    let plane = d[0] * d[1];
    let slices: Vec<(Vec<[f64; 3]>, Vec<Moment1>)> = (0..d[2])
        .into_par_iter()
        .map(|z| {
            let pz = grid.origin[2] + (z as f64 + 0.5) * grid.h[2];
            let mut w = vec![0.0f64; plane];
            let mut j0 = vec![[0.0f64; 3]; plane];
            let mut j1 = vec![[[0.0f64; 3]; 3]; plane];
            for (l, rbf) in rbfs.iter().enumerate() {
                let s = rbf.support_radius();
                if s <= 0.0 || (pz - rbf.center[2]).abs() >= s {
                    continue;
                }
                let span = |a: usize| {
                    voxel_span(
                        rbf.center[a] - s,
                        rbf.center[a] + s,
                        grid.origin[a],
                        grid.h[a],
                        d[a],
                    )
                };
                let (Some((x0, x1)), Some((y0, y1))) = (span(0), span(1)) else {
                    continue;
                };
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let p = grid.center([x, y, z]);
                        let b = rbf.eval(p);
                        if b.is_nan() || b <= 0.0 {
                            continue;
                        }
                        let i = x + d[0] * y;
                        w[i] += b;
                        for (c, (s0, s1)) in j0[i].iter_mut().zip(&mut j1[i]).enumerate() {
                            *s0 += b * centers.j0[l][c];
                            s1.iter_mut()
                                .zip(centers.j1[l][c])
                                .for_each(|(s, v)| *s += b * v);
                        }
                    }
                }
            }
            for i in 0..plane {
                if w[i] > 0.0 {
                    j0[i] = j0[i].map(|v| v / w[i]);
                    j1[i] = j1[i].map(|c| c.map(|v| v / w[i]));
                }
            }
            (j0, j1)
        })
        .collect();
    let mut out = Sources::zeros(0);
    for (a, b) in slices {
        out.j0.extend(a);
        out.j1.extend(b);
    }
    out
}

/// Adds the direct light of `env`'s suns (with `suns`) and point lights at every cell
/// center with smoke (`lighting::direct`'s moments: `J⁰ = Ω·E·T/4π`, `J¹ = −3·g·m·J⁰·s`,
/// `m` the disk's mean cosine), `T` marched through `fine`
/// (`render::lights_pass::transmittance`).
pub fn add_lights(
    sources: &mut Sources,
    grid: &CoarseGrid,
    fine: &Volume,
    env: &Environment,
    medium: &Medium,
    suns: bool,
) {
    if !env.has_lights() || medium.albedo == 0.0 {
        return;
    }
    let sun_list = if suns { &env.suns[..] } else { &[] };
    let k = medium.albedo / FOUR_PI;
    let vs = fine.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    // A point light inside a cell: the mean of 1/r² over a ball of half a cell.
    let hc = grid.h[0].min(grid.h[1]).min(grid.h[2]);
    let soft = (0.5 * hc).powi(2) / 3.0;
    sources
        .j0
        .par_iter_mut()
        .zip(sources.j1.par_iter_mut())
        .enumerate()
        .for_each(|(i, (j0, j1))| {
            if grid.density[i] <= 0.0 {
                return;
            }
            let u = grid.center(grid.coords(i));
            let mut light = |e: [f64; 3], s: [f64; 3], t: f64, m: f64| {
                for c in 0..3 {
                    let a = k * e[c] * t;
                    j0[c] += a;
                    for (axis, sa) in s.iter().enumerate() {
                        j1[c][axis] -= 3.0 * medium.g * m * a * sa;
                    }
                }
            };
            for sun in sun_list {
                let t = transmittance(fine, medium.sigma_t, u, sun.direction, f64::MAX, h0);
                light(
                    sun.irradiance,
                    sun.direction,
                    t,
                    0.5 * (1.0 + (0.5 * sun.angle).cos()),
                );
            }
            for pl in &env.points {
                let v = [0, 1, 2].map(|a| pl.position[a] - u[a]);
                let r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                match unit(v) {
                    Some(s) => {
                        let t = transmittance(fine, medium.sigma_t, u, s, r2.sqrt(), h0);
                        light(pl.intensity.map(|x| x / (r2 + soft)), s, t, 1.0);
                    }
                    None => light(pl.intensity.map(|x| x / soft), [0.0; 3], 1.0, 0.0),
                }
            }
        });
}

/// The environment pass's single scattering as moments per cell: at every fine voxel `v`
/// with smoke, `J(v, d) = Ω Σ_{l≤1} g^l (L_lm − S_lm(v)) Y_lm(d)` from the grid `env_grid`
/// of the light the smoke takes away and `light`, the environment's projection
/// (`render::env_pass`), turned into `J⁰`, `J¹` (`lighting::single::moments`), then averaged over
/// the cell weighted by the density (the cell's `D·J` is the mean of its voxels' `D·J`).
pub fn env_grid_sources(
    grid: &CoarseGrid,
    fine: &Volume,
    env_grid: &ShGrid,
    light: &RgbSh,
    medium: &Medium,
) -> Sources {
    let order = env_grid.order.min(2);
    let n2 = sh::count(order);
    let a = phase_factors(medium, order);
    // Bands 0–1 only: the first `3·n2` coefficients of each node.
    let k3 = 3 * n2;
    let (r0, k1) = ((4.0 * PI).sqrt(), -(3.0 / (4.0 * PI)).sqrt());
    let dims = fine.dims();
    let bbox = *fine.bbox();
    let vs = fine.voxel_size();
    let f = grid.factor;
    let cells: Vec<([f64; 3], Moment1)> = (0..grid.len())
        .into_par_iter()
        .map(|i| {
            if grid.density[i] <= 0.0 {
                return ([0.0; 3], [[0.0; 3]; 3]);
            }
            let c = grid.coords(i);
            let mut s = vec![0.0; k3];
            let (mut w, mut j0, mut j1) = (0.0, [0.0f64; 3], [[0.0f64; 3]; 3]);
            for z in c[2] * f..((c[2] + 1) * f).min(dims[2]) {
                for y in c[1] * f..((c[1] + 1) * f).min(dims[1]) {
                    for x in c[0] * f..((c[0] + 1) * f).min(dims[0]) {
                        let d = f64::from(fine.get(x, y, z));
                        if !(d > 0.0 && d.is_finite()) {
                            continue;
                        }
                        let u = [x, y, z];
                        let u = [0, 1, 2].map(|k| bbox.min[k] + (u[k] as f64 + 0.5) * vs[k]);
                        env_grid.at_first(u, &mut s);
                        w += d;
                        // `lighting::single::moments` of the SH source `j`, inline.
                        for (ch, (s0, s1)) in j0.iter_mut().zip(&mut j1).enumerate() {
                            let j = |k: usize| a[k] * (light[ch][k] - s[3 * k + ch]);
                            *s0 += d * (j(0) / r0);
                            if n2 >= 4 {
                                let m1 = [k1 * j(3), k1 * j(1), k1 * j(2)];
                                s1.iter_mut().zip(m1).for_each(|(s, v)| *s += d * v);
                            }
                        }
                    }
                }
            }
            if w > 0.0 {
                (j0.map(|v| v / w), j1.map(|c| c.map(|v| v / w)))
            } else {
                ([0.0; 3], [[0.0; 3]; 3])
            }
        })
        .collect();
    let mut out = Sources::zeros(0);
    for (a, b) in cells {
        out.j0.push(a);
        out.j1.push(b);
    }
    out
}

/// `env`'s suns as sources of the first gathered order (`super::gather`): `Ω E/4π`, the
/// disk-averaged phase and the transmittance from every cell center with smoke to the
/// sun, marched through `fine` (`render::lights_pass::transmittance`).
pub fn sun_sources(
    grid: &CoarseGrid,
    fine: &Volume,
    env: &Environment,
    medium: &Medium,
) -> Vec<SunSource> {
    let vs = fine.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    env.suns
        .iter()
        .map(|sun| SunSource {
            emit: sun.irradiance.map(|e| medium.albedo * e / FOUR_PI),
            direction: sun.direction,
            phase: DiskPhase::shared(medium.g, sun.angle),
            transmittance: (0..grid.len())
                .into_par_iter()
                .map(|i| {
                    if grid.density[i] <= 0.0 {
                        return 0.0;
                    }
                    let u = grid.center(grid.coords(i));
                    transmittance(fine, medium.sigma_t, u, sun.direction, f64::MAX, h0)
                })
                .collect(),
        })
        .collect()
}
