//! A ground under the smoke: a horizontal diffuse plane that camera rays see where they
//! leave the smoke downwards, lit by the environment and carrying the smoke's shadow.
//!
//! **The model.** The plane `z = h` (world units; by default the floor of the volume's
//! box), Lambertian with albedo `ρ` (RGB), seen only by camera rays: it replaces the
//! distant radiance below the horizon in the picture's background, and it does not light
//! the smoke (which keeps the environment's own radiance from below). At a point `x` of
//! the plane (normal `+z`) its radiance is
//!
//! ```text
//! L_g(x) = ρ/π · ( E_sky + Σ_suns E_k·max(0, s_k,z)·T(x, s_k, ∞)
//!                        + Σ_points I_j·max(0, l_j,z)/r_j²·T(x, l_j, r_j) )
//! ```
//!
//! with `T(x, w, r) = exp(−σt ∫₀^r D(x + t·w) dt)` the smoke's transmittance towards a
//! light (its shadow), `E_sky = ∫_{ω_z > 0} L_distant(ω)·ω_z dω` the distant light's
//! irradiance on the open plane, and the first term times `V(x)`, the share of it the
//! smoke lets through ([`sky_seen`]: the sky's shadow, soft and wide under dense smoke).
//! A sun's disk is taken at its center.
//!
//! **What the ground hides.** The smoke stands above the plane, so a sun below the
//! horizon, or a point light below the plane, cannot light it: a path from the smoke to it
//! crosses the ground. [`Ground::hiding`] gives the environment the smoke sees — each
//! sun's irradiance times the share of its disk above the horizon
//! ([`disk_above_horizon`]: 0 below, 1 above, the disk's segment in between), each point
//! light below the plane left out — and what it hid, for the user. Every renderer takes
//! the environment that way where there is a ground (`haze render`, `--check`, the
//! viewer), so they see the same scene; the distant light below the horizon (the built-in
//! sky's ground colour, a map's lower half) still lights the smoke, as the ground's bounce.
//!
//! **Who computes `T`.** The fast renderers march it through the density grid
//! ([`crate::render::ground_shadow`]: the midpoint rule in steps of the view pass's slice
//! thickness, half the smallest voxel side at its default two slices per voxel, on the
//! CPU and in `grid_shadow.wgsl` on the GPU). The reference renderer integrates the same
//! field exactly.
//!
//! **`E_sky`.** For the built-in sky (smooth), a midpoint rule on 64 × 128 cells of the
//! upper hemisphere in `(θ, φ)` (relative error below 10⁻³ on a constant sky, tested);
//! for a lat-long map, the sum over the texels of its upper half of radiance × `cos θ` ×
//! solid angle (texels the horizon cuts count the part above it).

pub mod sky_seen;

use crate::Rgb;
use crate::distant::{Distant, LatLong, Sky};
use crate::env::Environment;
use haze_volume::Bbox;
use sky_seen::{RINGS, SECTORS, SkyDirections, SkyGrid, SkySeen};
use std::f64::consts::PI;

/// The ground's albedo by default: a darkish, slightly warm grey (asphalt or dark earth),
/// so that lit smoke stands out against it.
pub const DEFAULT_ALBEDO: Rgb = [0.16, 0.15, 0.13];

/// A ground plane (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ground {
    /// Its height `z`, world units.
    pub height: f64,
    /// Lambertian albedo per channel, in `[0, 1]`.
    pub albedo: Rgb,
}

impl Ground {
    /// The ground at the floor of a box whose lowest `z` is `floor`, default albedo.
    pub fn at(floor: f64) -> Ground {
        Ground {
            height: floor,
            albedo: DEFAULT_ALBEDO,
        }
    }

    /// What lights the ground under `env`: its sky irradiance, suns and point lights,
    /// each already multiplied by `ρ/π`.
    pub fn lit(&self, env: &Environment) -> GroundLight {
        let k = self.albedo.map(|a| a.clamp(0.0, 1.0) / PI);
        let sky = sky_irradiance(&env.distant);
        GroundLight {
            height: self.height,
            sky: [0, 1, 2].map(|c| k[c] * sky[c]),
            sky_directions: SkyDirections::new(&env.distant, RINGS, SECTORS),
            sky_seen: SkySeen::Open,
            suns: env
                .suns
                .iter()
                .map(|s| (s.direction, [0, 1, 2].map(|c| k[c] * s.irradiance[c])))
                .collect(),
            points: env
                .points
                .iter()
                .map(|p| (p.position, [0, 1, 2].map(|c| k[c] * p.intensity[c])))
                .collect(),
        }
    }
}

impl Ground {
    /// The environment the smoke above this ground sees (module docs, "What the ground
    /// hides"), with [`Ground::hidden`]'s lines; `None` when it hides nothing (and then
    /// nothing is copied).
    pub fn hiding(&self, env: &Environment) -> Option<(Environment, Vec<String>)> {
        let said = self.hidden(env);
        if said.is_empty() {
            return None;
        }
        let mut out = env.clone();
        for sun in &mut out.suns {
            let share = disk_above_horizon(sun.direction, sun.angle);
            sun.irradiance = sun.irradiance.map(|e| e * share);
        }
        out.points.retain(|p| self.below(p.position).is_none());
        Some((out, said))
    }

    /// One line per light of `env` this ground hides from the smoke, wholly or in part
    /// (empty when it hides none).
    pub fn hidden(&self, env: &Environment) -> Vec<String> {
        let mut said = Vec::new();
        for (i, sun) in env.suns.iter().enumerate() {
            let share = disk_above_horizon(sun.direction, sun.angle);
            // A dark sun hides nothing.
            if share >= 1.0 || sun.irradiance.iter().all(|&e| e <= 0.0) {
                continue;
            }
            let elevation = sun.direction[2].clamp(-1.0, 1.0).asin().to_degrees();
            said.push(if share <= 0.0 {
                format!(
                    "sun {} is below the horizon (elevation {elevation:.1}°): the ground hides it from the smoke (--ground off lights the smoke from below)",
                    i + 1
                )
            } else {
                format!(
                    "sun {} is on the horizon (elevation {elevation:.2}°): {:.0} % of its disk lights the smoke above the ground",
                    i + 1,
                    100.0 * share
                )
            });
        }
        for (i, p) in env.points.iter().enumerate() {
            if let Some(line) = self.below(p.position)
                && p.intensity.iter().any(|&e| e > 0.0)
            {
                said.push(format!("point light {} {line}", i + 1));
            }
        }
        said
    }

    /// What is said of a point light at `position` below the plane; `None` at or above it.
    fn below(&self, position: [f64; 3]) -> Option<String> {
        (position[2] < self.height || position[2].is_nan()).then(|| {
            format!(
                "at z = {} is below the ground (z = {}): it lights neither the smoke nor the ground",
                haze_core::number::shown(position[2]),
                haze_core::number::shown(self.height)
            )
        })
    }
}

/// The share of a sun's disk of apex angle `angle` (radians) around the unit `direction`
/// that stands above the horizon `z = 0`: with `α = angle/2` the disk's angular radius
/// and `h = elevation/α`, the segment `1 − (acos h − h√(1 − h²))/π` for `|h| < 1` (the disk
/// small enough to be flat), 1 above and 0 below; a point-like sun (`angle` 0) is seen
/// from the horizon up. Non-finite directions give 0.
pub fn disk_above_horizon(direction: [f64; 3], angle: f64) -> f64 {
    let z = direction[2];
    if !z.is_finite() {
        return 0.0;
    }
    let elevation = z.clamp(-1.0, 1.0).asin();
    let alpha = 0.5 * angle;
    if alpha.is_nan() || alpha <= 0.0 {
        return if elevation >= 0.0 { 1.0 } else { 0.0 };
    }
    let h = elevation / alpha;
    if h >= 1.0 {
        1.0
    } else if h <= -1.0 {
        0.0
    } else {
        1.0 - (h.acos() - h * (1.0 - h * h).sqrt()) / PI
    }
}

/// A ground with its light, ready to shade (module docs): every term is already
/// multiplied by `ρ/π`.
#[derive(Clone, Debug, PartialEq)]
pub struct GroundLight {
    pub height: f64,
    /// `ρ/π · E_sky`, of the open sky.
    pub sky: Rgb,
    /// The sky's directions the fast renderers take its share `V` by ([`sky_seen`]).
    pub sky_directions: SkyDirections,
    /// How the fast renderers take `V`: [`SkySeen::Open`] until they set it
    /// ([`GroundLight::seeing_sky_through`]); the reference estimates its own
    /// ([`GroundLight::radiance_seeing`]).
    pub sky_seen: SkySeen,
    /// Per sun: unit direction towards it, `ρ/π · E`.
    pub suns: Vec<([f64; 3], Rgb)>,
    /// Per point light: position, `ρ/π · I`.
    pub points: Vec<([f64; 3], Rgb)>,
}

impl GroundLight {
    /// Where the ray `o + t·d` meets the ground from above (`None` when it does not: it
    /// rises, runs level, or starts below the plane).
    pub fn hit(&self, o: [f64; 3], d: [f64; 3]) -> Option<[f64; 3]> {
        let above = o[2] - self.height;
        if !(d[2] < 0.0 && above > 0.0) {
            return None;
        }
        let t = above / -d[2];
        t.is_finite()
            .then(|| [o[0] + t * d[0], o[1] + t * d[1], self.height])
    }

    /// This ground with the sky's share `V` taken on [`SkyGrid`]'s nodes for the smoke
    /// in `bbox` by the shadow rays `transmittance` (the fast renderers; the sky stays
    /// open where the box stands wholly below the ground).
    pub fn seeing_sky_through(
        mut self,
        bbox: &Bbox,
        transmittance: impl Fn([f64; 3], [f64; 3], f64) -> f64 + Sync,
    ) -> GroundLight {
        self.sky_seen =
            match SkyGrid::compute(&self.sky_directions, bbox, self.height, transmittance) {
                Some(grid) => SkySeen::Grid(grid),
                None => SkySeen::Open,
            };
        self
    }

    /// `L_g(x)` (module docs) with the smoke's transmittance `transmittance(x, w, r)` from
    /// `x` along the unit `w` over the distance `r` (`∞`: out of the smoke).
    pub fn radiance(
        &self,
        x: [f64; 3],
        transmittance: impl Fn([f64; 3], [f64; 3], f64) -> f64,
    ) -> Rgb {
        self.radiance_seeing(x, self.sky_seen.at(x), transmittance)
    }

    /// [`GroundLight::radiance`] with the sky's share at `x` given, `seen` (the
    /// reference's own estimate, [`sky_seen::sampled`]).
    pub fn radiance_seeing(
        &self,
        x: [f64; 3],
        seen: Rgb,
        transmittance: impl Fn([f64; 3], [f64; 3], f64) -> f64,
    ) -> Rgb {
        let mut out = [0, 1, 2].map(|c| self.sky[c] * seen[c]);
        for (w, e) in &self.suns {
            if w[2] > 0.0 {
                let k = w[2] * transmittance(x, *w, f64::INFINITY);
                for c in 0..3 {
                    out[c] += k * e[c];
                }
            }
        }
        for (p, i) in &self.points {
            let v = [p[0] - x[0], p[1] - x[1], p[2] - x[2]];
            let r2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            if !(r2 > 0.0 && r2.is_finite() && v[2] > 0.0) {
                continue;
            }
            let r = r2.sqrt();
            let w = v.map(|c| c / r);
            let k = w[2] / r2 * transmittance(x, w, r);
            for c in 0..3 {
                out[c] += k * i[c];
            }
        }
        out
    }
}

/// `E_sky = ∫_{ω_z > 0} L(ω)·ω_z dω` of the distant light (module docs).
pub fn sky_irradiance(distant: &Distant) -> Rgb {
    match distant {
        Distant::Sky(s) => sky_quadrature(s),
        Distant::Map(m) => map_sum(m),
    }
}

/// Midpoint rule on 64 × 128 cells of the upper hemisphere.
fn sky_quadrature(sky: &Sky) -> Rgb {
    let (nt, np) = (64, 128);
    let (dt, dp) = (0.5 * PI / nt as f64, 2.0 * PI / np as f64);
    let mut out = [0.0; 3];
    for i in 0..nt {
        let theta = (i as f64 + 0.5) * dt;
        let (s, c) = theta.sin_cos();
        let weight = c * s * dt * dp;
        for j in 0..np {
            let phi = (j as f64 + 0.5) * dp;
            let l = sky.radiance([s * phi.cos(), s * phi.sin(), c]);
            for k in 0..3 {
                out[k] += weight * l[k];
            }
        }
    }
    out
}

/// The texels of the upper half of a lat-long map (row `y` spans `θ ∈ [πy/h, π(y+1)/h]`):
/// `∫ cos θ sin θ dθ` over the part of the row above the horizon, times `2π/w`.
fn map_sum(m: &LatLong) -> Rgb {
    let (w, h) = (m.width, m.height);
    let mut out = [0.0; 3];
    if w == 0 || h == 0 {
        return out;
    }
    let dp = 2.0 * PI / w as f64;
    for y in 0..h {
        let a = PI * y as f64 / h as f64;
        let b = (PI * (y + 1) as f64 / h as f64).min(0.5 * PI);
        if a >= b {
            break;
        }
        // ∫ₐᵇ cos θ sin θ dθ = (sin²b − sin²a)/2.
        let weight = 0.5 * (b.sin().powi(2) - a.sin().powi(2)) * dp;
        for x in 0..w {
            let l = m.texels[y * w + x];
            for k in 0..3 {
                out[k] += weight * f64::from(l[k]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{PointLight, Sun};

    fn constant_sky(l: f64) -> Sky {
        Sky {
            zenith: [l; 3],
            horizon: [l; 3],
            ground: [0.0; 3],
            sun: [0.0; 3],
            ..Sky::default()
        }
    }

    /// A constant sky or map of radiance `L` gives `E = πL` (the cosine-weighted
    /// hemisphere's solid angle is π): within 10⁻³ by the midpoint rule, to rounding by
    /// the texel sum; a map's lower half does not count.
    #[test]
    fn a_constant_sky_gives_pi_times_its_radiance() {
        let e = sky_irradiance(&Distant::Sky(constant_sky(2.0)));
        assert!(
            e.iter().all(|c| (c / (2.0 * PI) - 1.0).abs() < 1e-3),
            "{e:?}"
        );
        let (w, h) = (16, 8);
        let texels = (0..w * h)
            .map(|i| {
                if i < w * h / 2 {
                    [3.0f32; 3]
                } else {
                    [50.0; 3]
                }
            })
            .collect();
        let e = sky_irradiance(&Distant::Map(LatLong::new(w, h, texels).unwrap()));
        assert!(
            e.iter().all(|c| (c / (3.0 * PI) - 1.0).abs() < 1e-12),
            "{e:?}"
        );
        // An odd row count: the horizon cuts the middle row.
        let e = sky_irradiance(&Distant::Map(
            LatLong::new(2, 1, vec![[1.0; 3]; 2]).unwrap(),
        ));
        assert!(e.iter().all(|c| (c / PI - 1.0).abs() < 1e-12), "{e:?}");
    }

    /// The ground's radiance is `ρ/π` times the irradiance it adds up: the sky, a sun at
    /// 30° elevation (`E·sin 30°`) and a point light 2 above (`I/4`), each shadowed by
    /// the transmittance given; a sun below the horizon and a light under the plane add
    /// nothing.
    #[test]
    fn the_radiance_adds_the_lights_with_their_shadows() {
        let mut env = Environment::sky(constant_sky(1.0));
        let s = 30f64.to_radians();
        env.suns.push(Sun {
            direction: [s.cos(), 0.0, s.sin()],
            irradiance: [4.0; 3],
            angle: 0.01,
        });
        env.suns.push(Sun {
            direction: [0.0, 0.0, -1.0],
            irradiance: [9.0; 3],
            angle: 0.01,
        });
        env.points
            .push(PointLight::new([0.0, 0.0, 2.0], [8.0; 3]).unwrap());
        env.points
            .push(PointLight::new([0.0, 0.0, -1.0], [8.0; 3]).unwrap());
        let ground = Ground {
            height: 0.0,
            albedo: [0.5, 0.25, 0.0],
        }
        .lit(&env);
        let x = [0.0; 3];
        let half = ground.radiance(x, |_, _, _| 0.5);
        let sky = sky_irradiance(&env.distant)[0];
        for c in 0..3 {
            let rho = [0.5, 0.25, 0.0][c];
            let want = rho / PI * (sky + 0.5 * (4.0 * 0.5 + 8.0 / 4.0));
            assert!((half[c] - want).abs() < 1e-12, "{c}: {} vs {want}", half[c]);
        }
    }

    /// Rays meet the plane from above only.
    #[test]
    fn rays_meet_the_plane_from_above() {
        let g = Ground::at(1.0).lit(&Environment::sky(Sky::default()));
        let hit = g.hit([0.0, 0.0, 3.0], [0.6, 0.0, -0.8]).unwrap();
        assert!((hit[0] - 1.5).abs() < 1e-12 && hit[2] == 1.0);
        assert!(g.hit([0.0, 0.0, 3.0], [1.0, 0.0, 0.0]).is_none());
        assert!(g.hit([0.0, 0.0, 3.0], [0.0, 0.0, 1.0]).is_none());
        assert!(g.hit([0.0, 0.0, 0.5], [0.0, 0.0, -1.0]).is_none());
    }

    /// The share of a disk above the horizon against a count over the disk itself:
    /// directions spread evenly over the cone of the disk's angular radius (equal areas
    /// in `1 − cos` and in azimuth), the share of them with `z ≥ 0`.
    #[test]
    fn a_disks_share_above_the_horizon_is_its_segment() {
        let counted = |elevation_deg: f64, angle: f64| {
            let e = elevation_deg.to_radians();
            let (axis, up, side) = (
                [e.cos(), 0.0, e.sin()],
                [-e.sin(), 0.0, e.cos()],
                [0.0, 1.0, 0.0],
            );
            let (rings, sectors) = (400, 400);
            let mut above = 0usize;
            for i in 0..rings {
                // Equal solid angle: cos θ evenly between 1 and cos α.
                let q = (i as f64 + 0.5) / rings as f64;
                let c = 1.0 - q * (1.0 - (0.5 * angle).cos());
                let s = (1.0 - c * c).sqrt();
                for j in 0..sectors {
                    let phi = 2.0 * PI * (j as f64 + 0.5) / sectors as f64;
                    let z = c * axis[2] + s * (phi.cos() * up[2] + phi.sin() * side[2]);
                    above += usize::from(z >= 0.0);
                }
            }
            above as f64 / (rings * sectors) as f64
        };
        for angle in [0.53f64.to_radians(), 10f64.to_radians()] {
            let alpha = 0.5 * angle.to_degrees();
            for h in [-1.2, -0.9, -0.5, -0.1, 0.0, 0.3, 0.7, 0.99, 1.5] {
                let e = h * alpha;
                let d = [e.to_radians().cos(), 0.0, e.to_radians().sin()];
                let got = disk_above_horizon(d, angle);
                let want = counted(e, angle);
                // The grid's 1/400 steps, and the flat disk's error (α²/8 at 5°).
                assert!(
                    (got - want).abs() < 4e-3,
                    "angle {angle} h {h}: {got} vs {want}"
                );
            }
        }
        // A point-like sun: seen from the horizon up; a broken direction: not at all.
        assert_eq!(disk_above_horizon([1.0, 0.0, 0.0], 0.0), 1.0);
        assert_eq!(disk_above_horizon([1.0, 0.0, -1e-9], 0.0), 0.0);
        assert_eq!(disk_above_horizon([f64::NAN, 0.0, f64::NAN], 0.01), 0.0);
        assert_eq!(disk_above_horizon([0.0, 0.0, 1.0], f64::NAN), 1.0);
    }

    /// The ground hides a sun below the horizon and a point light below the plane from
    /// the smoke, takes part of a sun on the horizon, keeps the rest, and says so.
    #[test]
    fn the_ground_hides_the_lights_below_it() {
        use crate::lights::{PointLight, Sun};
        let g = Ground::at(1.0);
        let mut env = Environment::constant([0.1; 3]);
        let sun = |z: f64| Sun {
            direction: crate::lights::unit([1.0, 0.0, z]).unwrap(),
            irradiance: [10.0, 8.0, 6.0],
            angle: 0.53f64.to_radians(),
        };
        env.suns = vec![sun(0.5), sun(-0.3), sun(0.0)];
        env.points = vec![
            PointLight {
                position: [0.0, 0.0, 2.0],
                intensity: [1.0; 3],
            },
            PointLight {
                position: [0.0, 0.0, 0.5],
                intensity: [1.0; 3],
            },
        ];
        let (seen, said) = g.hiding(&env).expect("two suns and a lamp hidden");
        assert_eq!(seen.suns[0], env.suns[0]);
        assert_eq!(seen.suns[1].irradiance, [0.0; 3]);
        assert_eq!(seen.suns[2].irradiance, [5.0, 4.0, 3.0], "half the disk");
        assert_eq!(seen.points, env.points[..1].to_vec());
        assert_eq!(seen.distant, env.distant);
        assert_eq!(said.len(), 3, "{said:?}");
        assert!(
            said[0].starts_with("sun 2 is below the horizon (elevation -16.7°)"),
            "{said:?}"
        );
        assert!(
            said[1].contains("sun 3 is on the horizon") && said[1].contains("50 %"),
            "{said:?}"
        );
        assert!(
            said[2].starts_with("point light 2 at z = 0.5 is below the ground (z = 1)"),
            "{said:?}"
        );
        // Nothing below: nothing hidden, nothing said.
        env.suns.truncate(1);
        env.points.truncate(1);
        assert!(g.hiding(&env).is_none());
    }
}
