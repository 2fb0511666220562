//! Paper D's analytic fog in a scene ([`crate::media::analytic`], docs/formats.md "Analytic fog": the extinction
//! `σt·K(x, t)` with `K` a sum of [`haze_fogfn`]'s functions, lit by [`crate::march`]
//! like every medium) rendered as paper D renders it (§3.1, eq. 5–6, §4): per pixel the
//! exact optical depth `∫_O^P σt K` from the eye `O` to the point `P` the ray ends on,
//! and the picture the scene's own renderer made (paper C) composited with the fog's colour
//! `C_fin = τ C_in + (1 − τ) C_fog`, `τ = e^{−∫σt K}` per channel. That composite is
//! exact for a fog whose in-scattered radiance is the constant `C_fog`: `∫τ K J = J(1 − τ)`.
//!
//! `C_fog` is the medium's `"colour"` when given, else the fog's albedo times the
//! ambient light of the scene seen by an isotropic phase function —
//! `(1/4π)∫ L_env dω` plus `E/(4π)` of each sun, unshadowed — paper D's "uniform
//! daylight". Several analytic media composite as one: their depths add and `C_fog` is
//! their colours weighted by each one's depth (exact when the colours agree).
//!
//! The lit picture — single scattering of the scene's lights through every medium, the
//! analytic fog included — is [`crate::march`]'s.

use crate::render::{Image, Model};
use crate::scene::{Environment, Light, Rgb, Scene};
use crate::vec3::Vec3;
use rayon::prelude::*;

/// The ambient in-scattered radiance per unit albedo (module docs): the environment
/// averaged over the sphere by the midpoint rule in `(cos θ, φ)` on 64 × 128 cells (the
/// sky's glow, the sharpest feature, is `cos⁸` wide: its mean is within 10⁻⁴; a map's
/// features narrower than a cell, ~1.4°, are sampled, not averaged), plus
/// `E/(4π)` of each sun.
pub fn ambient(scene: &Scene) -> Rgb {
    let mut a = match &scene.environment {
        Environment::Black => [0.0; 3],
        Environment::Constant(c) => *c,
        env @ (Environment::Sky | Environment::Map(_)) => {
            let (nu, nphi) = (64, 128);
            let mut sum = [0.0; 3];
            for i in 0..nu {
                let z = -1.0 + (i as f64 + 0.5) * 2.0 / nu as f64;
                let r = (1.0 - z * z).sqrt();
                for j in 0..nphi {
                    let phi = (j as f64 + 0.5) * std::f64::consts::TAU / nphi as f64;
                    let l = env.radiance([r * phi.cos(), r * phi.sin(), z]);
                    for c in 0..3 {
                        sum[c] += l[c];
                    }
                }
            }
            sum.map(|s| s / (nu * nphi) as f64)
        }
    };
    for light in &scene.lights {
        if let Light::Sun {
            radiance, angle, ..
        } = light
        {
            let e = Light::sun_irradiance(*radiance, *angle);
            for c in 0..3 {
                a[c] += e[c] / (4.0 * std::f64::consts::PI);
            }
        }
    }
    a
}

/// What the composite needs of each analytic medium: `(σt, C_fog)`.
pub fn fog_colours(scene: &Scene) -> Vec<(Rgb, Rgb)> {
    let amb = ambient(scene);
    scene
        .analytic_media()
        .map(|m| {
            let colour = m
                .colour
                .unwrap_or_else(|| [0, 1, 2].map(|c| m.albedo[c] * amb[c]));
            (m.sigma_t, colour)
        })
        .collect()
}

/// `C_fin` of the camera ray `dir` ending at `t_end` (`∞`: the fog's `far`) over `c_in`
/// (module docs).
pub fn composite(scene: &Scene, colours: &[(Rgb, Rgb)], dir: Vec3, t_end: f64, c_in: Rgb) -> Rgb {
    let eye = scene.camera.eye;
    let mut depth = [0.0; 3];
    let mut weighted = [0.0; 3];
    for (m, (sigma, colour)) in scene.analytic_media().zip(colours) {
        let k = m.depth(eye, dir, t_end);
        for c in 0..3 {
            depth[c] += sigma[c] * k;
            weighted[c] += sigma[c] * k * colour[c];
        }
    }
    [0, 1, 2].map(|c| {
        if depth[c] <= 0.0 {
            return c_in[c];
        }
        let tau = (-depth[c]).exp();
        tau * c_in[c] + (1.0 - tau) * weighted[c] / depth[c]
    })
}

/// Paper D's picture: the scene rendered by `model` (paper C), then the analytic fog
/// composited over every pixel; `progress` hears the rows of the first pass.
pub fn render(
    scene: &Scene,
    model: &dyn Model,
    lim: &crate::paper_c::airlight::Limits,
    progress: &(dyn Fn(usize) + Sync),
) -> Image {
    let mut image = crate::render::render(scene, model, lim, progress);
    let colours = fog_colours(scene);
    if colours.is_empty() {
        return image;
    }
    let cam = &scene.camera;
    let w = cam.width;
    image
        .pixels
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                let dir = cam.pixel_ray(x, y);
                let t_end = scene
                    .intersect(cam.eye, dir, 0.0, scene.environment_distance)
                    .map_or(scene.environment_distance, |h| h.t);
                let c = composite(scene, &colours, dir, t_end, p.map(f64::from));
                *p = c.map(|v| v as f32);
            }
        });
    image
}
