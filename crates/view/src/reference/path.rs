//! Multiple scattering by volumetric path tracing.
//!
//! A path starts at the eye along the camera ray. Each free flight draws `τ* ~ Exp(1)`
//! and stops where the exact optical depth from the start reaches it: the collision
//! distance then has density `σt D(t)·exp(−τ(0, t))`, exactly what delta tracking samples
//! but without a majorant, so neither an empty volume (`σt·max D = 0`) nor a huge
//! extinction changes its cost (it is proportional to the voxels crossed). A flight that
//! leaves the box first ends the path, which collects `weight·L_env(direction)`. At a
//! collision the weight is multiplied by the albedo Ω (survival weight; an albedo of 0
//! ends the path) and the new direction is drawn from the phase function about the current
//! one (density `p/4π`, which cancels the `(1/4π)p` of the source radiance).
//!
//! Each path is an unbiased estimate of the Neumann series of the radiative transfer
//! equation truncated after `max_bounces` scattering events: paths needing more contribute
//! 0, which is the only bias. The distant environment is not sampled at collisions (no
//! next-event estimation): under a smooth environment a path reaches it by itself with low
//! variance. Suns and point lights are: at every collision the path adds
//! `weight·(E·T_light·p/4π)` per light (`super::direct_light`), and a path that leaves
//! the box after a collision collects the distant radiance only (a sun's disk was
//! counted by the explicit sample); the camera ray itself sees the disks.

use rand::RngExt;
use rand_pcg::Pcg64;

use super::{RefOptions, Scene, direct_light, hg_direction};
use crate::Rgb;
use crate::field::ray_box;

/// Radiance arriving at `o` from direction `d` (unit), all orders of scattering up to
/// `opts.max_bounces`, averaged over `opts.spp` paths.
pub(crate) fn radiance(
    scene: &Scene<'_>,
    o: [f64; 3],
    d: [f64; 3],
    opts: &RefOptions,
    rng: &mut Pcg64,
) -> Rgb {
    let spp = opts.spp.max(1);
    let mut sum = [0.0f64; 3];
    for _ in 0..spp {
        let l = trace(scene, o, d, opts.max_bounces, rng);
        for c in 0..3 {
            sum[c] += l[c];
        }
    }
    sum.map(|s| s / f64::from(spp))
}

/// One path.
fn trace(
    scene: &Scene<'_>,
    mut o: [f64; 3],
    mut d: [f64; 3],
    max_bounces: u32,
    rng: &mut Pcg64,
) -> Rgb {
    let mut weight = 1.0f64;
    let mut bounces = 0u32;
    let mut sum = [0.0f64; 3];
    loop {
        let collision = ray_box(o, d, scene.volume.bbox()).and_then(|(t0, t1)| {
            let u: f64 = rng.random();
            scene.track(o, d).reach(t0, t1, -(-u).ln_1p())
        });
        let Some(t) = collision else {
            let l = if bounces == 0 {
                scene.env.radiance(d)
            } else {
                scene.env.distant.radiance(d)
            };
            for c in 0..3 {
                sum[c] += weight * l[c];
            }
            return sum;
        };
        if bounces == max_bounces {
            return sum;
        }
        bounces += 1;
        weight *= scene.medium.albedo;
        if weight == 0.0 {
            return sum;
        }
        o = [0, 1, 2].map(|a| o[a] + t * d[a]);
        if scene.env.has_lights() {
            let direct = direct_light(scene, o, d, rng);
            for c in 0..3 {
                sum[c] += weight * direct[c];
            }
        }
        d = hg_direction(d, scene.medium.g, rng.random(), rng.random());
    }
}
