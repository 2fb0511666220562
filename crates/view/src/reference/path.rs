//! Multiple scattering by volumetric path tracing.
//!
//! A path starts at the eye along the camera ray. The camera ray's own part is exact, as
//! in single scattering: the background `T·L_env(d)` (`T` the ray's transmittance
//! through the box, the suns' disks included) is added once, and the path's first
//! collision is forced inside the box, drawn with density `σt D(t)·T(t₀, t)/(1 − T)` and
//! weighted by `1 − T` — so no path of a thin pixel is spent on seeing the background,
//! whose all-or-nothing share was most of such a pixel's noise. Every later free flight
//! draws `τ* ~ Exp(1)` and stops where the exact optical depth from the start reaches
//! it: the collision distance then has density `σt D(t)·exp(−τ(0, t))`, exactly what
//! delta tracking samples but without a majorant, so neither an empty volume
//! (`σt·max D = 0`) nor a huge extinction changes its cost (it is proportional to the
//! voxels crossed). A flight that leaves the box first ends the path, which collects
//! `weight·L_env(direction)`. At a
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
    let Some((t0, t1)) = ray_box(o, d, scene.volume.bbox()) else {
        return scene.background(o, d, opts.spp, rng);
    };
    let view = scene.track(o, d);
    let tau = view.depth(t0, t1);
    let mut out = scene
        .background(o, d, opts.spp, rng)
        .map(|c| c * (-tau).exp());
    // 1 − T without cancellation for thin media.
    let mass = -(-tau).exp_m1();
    if scene.medium.albedo == 0.0 || mass <= 0.0 || opts.max_bounces == 0 {
        return out;
    }
    let spp = opts.spp.max(1);
    let mut sum = [0.0f64; 3];
    for _ in 0..spp {
        let xi: f64 = rng.random();
        // ξ < 1, so 1 − ξ·mass > T and τ* < τ; rounding may still overshoot: then t₁.
        let t = view.reach(t0, t1, -(-xi * mass).ln_1p()).unwrap_or(t1);
        let x = [0, 1, 2].map(|a| o[a] + t * d[a]);
        let l = scatter(scene, x, d, mass, opts.max_bounces, rng);
        for c in 0..3 {
            sum[c] += l[c];
        }
    }
    for c in 0..3 {
        out[c] += sum[c] / f64::from(spp);
    }
    out
}

/// The rest of one path from its first collision at `x` on a ray along `d`, reached with
/// the weight `weight`: what it collects at this and later collisions and where it
/// leaves the box.
fn scatter(
    scene: &Scene<'_>,
    mut x: [f64; 3],
    mut d: [f64; 3],
    mut weight: f64,
    max_bounces: u32,
    rng: &mut Pcg64,
) -> Rgb {
    let g = scene.medium.g;
    let mut sum = [0.0f64; 3];
    for _ in 0..max_bounces {
        weight *= scene.medium.albedo;
        if weight == 0.0 {
            return sum;
        }
        if scene.env.has_lights() {
            let direct = direct_light(scene, x, d, rng);
            for c in 0..3 {
                sum[c] += weight * direct[c];
            }
        }
        if let Some(sampler) = scene.sampler {
            let (w, q_e) = sampler.sample(rng.random(), rng.random());
            let l = scene.env.distant.radiance(w);
            if l.iter().any(|c| *c > 0.0) {
                let q_p = hg(g, dot(w, d)) / FOUR_PI;
                let k = weight * power_heuristic(q_e, q_p) * q_p / q_e
                    * scene.transmittance(x, w, f64::INFINITY);
                for c in 0..3 {
                    sum[c] += k * l[c];
                }
            }
        }
        let next = hg_direction(d, g, rng.random(), rng.random());
        let phase_pdf = hg(g, dot(next, d)) / FOUR_PI;
        d = next;
        let collision = ray_box(x, d, scene.volume.bbox()).and_then(|(t0, t1)| {
            let u: f64 = rng.random();
            scene.track(x, d).reach(t0, t1, -(-u).ln_1p())
        });
        let Some(t) = collision else {
            let w = match scene.sampler {
                Some(s) => weight * power_heuristic(phase_pdf, s.pdf(d)),
                None => weight,
            };
            let l = scene.env.distant.radiance(d);
            for c in 0..3 {
                sum[c] += w * l[c];
            }
            return sum;
        };
        x = [0, 1, 2].map(|a| x[a] + t * d[a]);
    }
    // A collision past `max_bounces`: the truncated tail.
    sum
}
