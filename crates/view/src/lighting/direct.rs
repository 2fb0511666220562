//! The direct light of suns and point lights at the RBF centers, as the multiple-
//! scattering source moments (paper A §5.4's `J⁰`, `J¹`; the lights themselves are added
//! per voxel by `render::lights_pass`, so they stay out of the SH source the volume pass
//! interpolates).
//!
//! A light of irradiance `E` at a point, arriving along the propagation direction `−s`
//! (`s` towards the light), scatters `J(ω) = (Ω/4π)·E·T·p(−s·ω)` into the propagation
//! direction `ω`, so with `(1/4π)∫p = 1` and `(1/4π)∫p(u·ω)·ω dω = g·u`:
//!
//! ```text
//! J⁰ = (1/4π)∫J dω = Ω·E·T/4π,        J¹ = (3/4π)∫J·ω dω = 3·g·m·J⁰·(−s)
//! ```
//!
//! with `m = (1 + cos(α/2))/2` the mean cosine of a disk of apex angle `α` about its
//! center (1 for a point light). The transmittance `T` is that of the RBFs alone:
//! `τ = Σ_h w_h ∫ exp(−|x + t·s − c_h|²/r_h²) dt` in closed form (erf), along the whole ray
//! to infinity for a sun and to the light for a point light, the `3r` cut-off ignored
//! (`e⁻⁹`). It is taken at the center: the diffusion is collocated at the centers, so its
//! source is the value there. (The footprint mean that `SourcePoints::Footprint` gives
//! the environment's transmittance is for the volume pass, which spreads a center's value
//! over the whole Gaussian; fed to the diffusion it made the multiple scattering of a
//! sun-lit plume 23 % too bright against the path tracer, the center 7 %: BENCHMARKS.md.)
//! A point light's `1/d²` is softened to `1/(d² + r²/3)` (the mean of `1/d²` over a ball
//! of the RBF's radius `r`).

use crate::diffusion::Sources;
use crate::env::Environment;
use crate::medium::{FOUR_PI, Medium};
use haze_volume::Rbf;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Optical depth `∫₀^len Σ_h w_h exp(−|x + t·s − c_h|²/r_h²) dt` of the RBFs from `x`
/// along the unit `s` (`len` may be infinite), in closed form per RBF.
pub fn rbf_depth(rbfs: &[Rbf], x: [f64; 3], s: [f64; 3], len: f64) -> f64 {
    let mut depth = 0.0;
    for h in rbfs {
        let r = h.radius;
        if r.is_nan() || r <= 0.0 || h.weight == 0.0 {
            continue;
        }
        let v = [0, 1, 2].map(|a| h.center[a] - x[a]);
        // Closest approach at t_h, perpendicular distance² d2.
        let th = v[0] * s[0] + v[1] * s[1] + v[2] * s[2];
        let d2 = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2] - th * th).max(0.0);
        if d2 > 9.0 * r * r || th < -3.0 * r || th - len > 3.0 * r {
            continue;
        }
        // ∫₀^len exp(−(t − t_h)²/r²) dt = (r√π/2)·[erf((len − t_h)/r) − erf(−t_h/r)].
        let hi = if len.is_finite() {
            libm::erf((len - th) / r)
        } else {
            1.0
        };
        let span = hi - libm::erf(-th / r);
        depth += h.weight * (-d2 / (r * r)).exp() * r * 0.5 * PI.sqrt() * span;
    }
    depth
}

/// Adds the direct light of `env`'s suns and point lights at the centers of `rbfs` to the
/// diffusion's source moments (module docs).
pub fn add_light_moments(sources: &mut Sources, rbfs: &[Rbf], env: &Environment, medium: &Medium) {
    if !env.has_lights() || medium.albedo == 0.0 {
        return;
    }
    let k = medium.albedo / FOUR_PI;
    let add: Vec<([f64; 3], [[f64; 3]; 3])> = rbfs
        .par_iter()
        .map(|rbf| {
            let c = rbf.center;
            let mut j0 = [0.0f64; 3];
            let mut j1 = [[0.0f64; 3]; 3];
            let mut light = |e: [f64; 3], s: [f64; 3], t: f64, m: f64| {
                for c in 0..3 {
                    let a = k * e[c] * t;
                    j0[c] += a;
                    for (axis, sa) in s.iter().enumerate() {
                        j1[c][axis] -= 3.0 * medium.g * m * a * sa;
                    }
                }
            };
            for sun in &env.suns {
                let t = (-medium.sigma_t * rbf_depth(rbfs, c, sun.direction, f64::INFINITY)).exp();
                let m = 0.5 * (1.0 + (0.5 * sun.angle).cos());
                light(sun.irradiance, sun.direction, t, m);
            }
            for pl in &env.points {
                let v = [0, 1, 2].map(|a| pl.position[a] - rbf.center[a]);
                let d2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
                let soft = rbf.radius * rbf.radius / 3.0;
                let Some(s) = crate::lights::unit(v) else {
                    light(
                        pl.intensity.map(|i| i / soft.max(1e-300)),
                        [0.0; 3],
                        1.0,
                        0.0,
                    );
                    continue;
                };
                let t = (-medium.sigma_t * rbf_depth(rbfs, c, s, d2.sqrt())).exp();
                let e = pl.intensity.map(|i| i / (d2 + soft).max(1e-300));
                light(e, s, t, 1.0);
            }
            (j0, j1)
        })
        .collect();
    for (l, (j0, j1)) in add.into_iter().enumerate() {
        for (c, (s0, s1)) in sources.j0[l].iter_mut().zip(&mut sources.j1[l]).enumerate() {
            *s0 += j0[c];
            for (s, v) in s1.iter_mut().zip(j1[c]) {
                *s += v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lighting::single::moments;
    use crate::lights::{PointLight, Sun};
    use crate::medium::hg;
    use crate::sh;

    #[test]
    fn rbf_depth_matches_quadrature() {
        let rbfs = [
            Rbf::new([0.1, 0.2, 0.3], 0.2, 1.5),
            Rbf::new([0.5, -0.1, 0.0], 0.1, 0.7),
        ];
        let s = {
            let v: [f64; 3] = [0.8, 0.1, 0.3];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / n)
        };
        let x = [-0.3, 0.1, 0.1];
        for len in [0.2, 0.6, f64::INFINITY] {
            // Midpoint rule on [0, min(len, 5)] with 200k steps, without the cut-off.
            let end = len.min(5.0);
            let n = 200_000;
            let h = end / n as f64;
            let mut q = 0.0;
            for k in 0..n {
                let t = (k as f64 + 0.5) * h;
                let p = [0, 1, 2].map(|a| x[a] + t * s[a]);
                for r in &rbfs {
                    let d2: f64 = (0..3).map(|a| (p[a] - r.center[a]).powi(2)).sum();
                    q += r.weight * (-d2 / (r.radius * r.radius)).exp() * h;
                }
            }
            let a = rbf_depth(&rbfs, x, s, len);
            assert!((a - q).abs() < 1e-8 * q.max(1.0), "len {len}: {a} vs {q}");
        }
    }

    /// `J⁰`, `J¹` against `lighting::single::moments` of the SH projection of the scattered light
    /// as a function of the viewing direction (another route to the same moments).
    #[test]
    fn moments_match_the_projected_phase_function() {
        let medium = Medium::new(0.0, 0.7, 0.6).unwrap();
        let dir = [0.36, 0.48, 0.8];
        let mut env = Environment::constant([0.0; 3]);
        env.suns.push(Sun {
            direction: dir,
            irradiance: [2.0, 1.0, 0.5],
            angle: 0.0,
        });
        let rbfs = [Rbf::new([0.0; 3], 0.1, 1.0)];
        let mut direct = Sources::zeros(1);
        add_light_moments(&mut direct, &rbfs, &env, &medium);
        // J(d) = Ω·E·p(s·d)/4π over viewing directions d, order 2.
        let proj = [2.0, 1.0, 0.5].map(|e| {
            sh::project_fn(
                2,
                |d| {
                    let p = hg(medium.g, d[0] * dir[0] + d[1] * dir[1] + d[2] * dir[2]);
                    medium.albedo * e * p / FOUR_PI
                },
                200,
                400,
            )
        });
        let via_sh = moments(&[proj]);
        for c in 0..3 {
            assert!((direct.j0[0][c] - via_sh.j0[0][c]).abs() < 1e-6 * via_sh.j0[0][c]);
            for a in 0..3 {
                let (x, y) = (direct.j1[0][c][a], via_sh.j1[0][c][a]);
                assert!(
                    (x - y).abs() < 1e-5 * via_sh.j0[0][c],
                    "{c} {a}: {x} vs {y}"
                );
            }
        }
        // A point light at distance 2 along the same axis: E = I/(4 + r²/3).
        let mut env = Environment::constant([0.0; 3]);
        env.points
            .push(PointLight::new(dir.map(|c| 2.0 * c), [4.0; 3]).unwrap());
        let mut pl = Sources::zeros(1);
        add_light_moments(&mut pl, &rbfs, &env, &medium);
        let e = 4.0 / (4.0 + 0.01 / 3.0);
        assert!((pl.j0[0][0] - medium.albedo * e / FOUR_PI).abs() < 1e-12);
    }
}
