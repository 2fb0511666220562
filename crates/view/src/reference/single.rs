//! Single scattering, ray traced.
//!
//! Along the camera ray, inside the volume box `[t₀, t₁]`, with `T = exp(−τ(t₀, t₁))`:
//!
//! `L = T·L_env(d) + ∫ T(t₀, t)·σt D(x_t)·Ω·S(x_t) dt`,
//! `S(x) = (1/4π)∫ p(ω·d)·T_light(x, ω)·L_env(ω) dω`,
//!
//! `L_env` the distant radiance plus the suns' disks, and point lights adding
//! `(1/4π)·p(ω·d)·T_light·I/r²` towards each.
//!
//! The first term is exact. For the integral, the scattering point is drawn with density
//! `σt D(t)·T(t₀, t)/(1 − T)` (a collision forced inside the box: `τ* = −ln(1 − ξ(1 − T))`,
//! then `τ(t₀, t) = τ*` inverted exactly), so one sample is `(1 − T)·Ω·S(x_t)`. `S` is
//! estimated `light_samples` times, each with exact transmittances to the box exit. The
//! distant radiance: a direction drawn from the phase function itself (density
//! `p(ω·d)/4π`, so it contributes `T_light·L_env`), and, when the environment is
//! importance-sampled, one drawn from the map's luminance, the two combined by the power
//! heuristic (`super::distant_light`, `env_sampling.rs`). The suns and point lights are
//! sampled explicitly (their small disks are what phase sampling would almost never hit):
//! a point drawn uniformly in each sun's disk contributes `E·T_light·p/4π` (density
//! `1/Ω☉`, radiance `E/Ω☉`), each point light `I/r²·T_light·p/4π`; the other directions
//! see the distant radiance only. Averaging `spp` such points gives an unbiased estimate
//! whose only noise comes from the positions and directions; an albedo of 0 or an empty
//! ray is exact.

use rand::RngExt;
use rand_pcg::Pcg64;

use super::{RefOptions, Scene, direct_light, distant_light};
use crate::Rgb;
use crate::field::ray_box;

/// Single-scattering radiance arriving at `o` from direction `d` (unit), i.e. along the
/// camera ray `o + t·d`.
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
    let albedo = scene.medium.albedo;
    if albedo == 0.0 || mass <= 0.0 {
        return out;
    }
    let (spp, lights) = (opts.spp.max(1), opts.light_samples.max(1));
    let mut sum = [0.0f64; 3];
    for _ in 0..spp {
        let xi: f64 = rng.random();
        // ξ < 1, so 1 − ξ·mass > T and τ* < τ; rounding may still overshoot: then t₁.
        let target = -(-xi * mass).ln_1p();
        let t = view.reach(t0, t1, target).unwrap_or(t1);
        let x = [0, 1, 2].map(|a| o[a] + t * d[a]);
        for _ in 0..lights {
            let distant = distant_light(scene, x, d, rng);
            let direct = direct_light(scene, x, d, rng);
            for c in 0..3 {
                sum[c] += distant[c] + direct[c];
            }
        }
    }
    let k = mass * albedo / (f64::from(spp) * f64::from(lights));
    for c in 0..3 {
        out[c] += k * sum[c];
    }
    out
}
