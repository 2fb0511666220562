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
//! 0, which is the only bias. Suns and point lights are sampled at every collision: the
//! path adds `weight·(E·T_light·p/4π)` per light (`super::direct_light`), and a path that
//! leaves the box after a collision collects the distant radiance only (a sun's disk was
//! counted by the explicit sample); the camera ray itself sees the disks.
//!
//! With an environment sampler (`env_sampling.rs`) the distant radiance is collected by
//! both ends at once, by MIS: at every collision a direction `ω_e` drawn from the map
//! (density `q_e`) adds `weight·w_e·(p(ω_e·d)/4π)·T_light·L/q_e` (next-event estimation),
//! and the path that leaves the box after a collision, along the direction `ω` its last
//! phase sample drew with density `q_p`, collects `weight·w_p·L(ω)` instead of
//! `weight·L(ω)`; `w_e = q_e²/(q_e² + q_p²)` and `w_p = q_p²/(q_p² + q_e²)` (power
//! heuristic), evaluated at the same direction sum to 1, so each path length keeps its
//! expectation. Without a sampler the distant radiance is reached by escaping only.

use rand::RngExt;
use rand_pcg::Pcg64;

use super::{RefOptions, Scene, direct_light, hg_direction, power_heuristic};
use crate::Rgb;
use crate::field::ray_box;
use crate::lights::dot;
use crate::medium::{FOUR_PI, hg};

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
    // The density of the last phase-sampled direction (read only after a collision).
    let mut phase_pdf = 0.0f64;
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
            let w = match scene.sampler {
                Some(s) if bounces > 0 => weight * power_heuristic(phase_pdf, s.pdf(d)),
                _ => weight,
            };
            for c in 0..3 {
                sum[c] += w * l[c];
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
        let g = scene.medium.g;
        if let Some(sampler) = scene.sampler {
            let (w, q_e) = sampler.sample(rng.random(), rng.random());
            let l = scene.env.distant.radiance(w);
            if l.iter().any(|c| *c > 0.0) {
                let q_p = hg(g, dot(w, d)) / FOUR_PI;
                let k = weight * power_heuristic(q_e, q_p) * q_p / q_e
                    * scene.transmittance(o, w, f64::INFINITY);
                for c in 0..3 {
                    sum[c] += k * l[c];
                }
            }
        }
        let next = hg_direction(d, g, rng.random(), rng.random());
        phase_pdf = hg(g, dot(next, d)) / FOUR_PI;
        d = next;
    }
}
