//! Paper D's analytic fog in a scene (`{"type": "analytic", …}`, docs/formats.md "Analytic fog"):
//! the extinction `σt·K(x, t)` with `K` a sum of [`haze_fogfn`]'s functions, as a
//! [`Heterogeneous`] medium (lit by [`crate::march`] like every medium) and rendered as
//! paper D renders it (§3.1, eq. 5–6, §4): per pixel the exact optical depth `∫_O^P σt K`
//! from the eye `O` to the point `P` the ray ends on, and the picture the scene's own
//! renderer made (paper C) composited with the fog's colour
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
//!
//! The fog ends `far` from the eye along any ray (paper D §4.2's viewing threshold), so
//! that rays to an environment at `∞` and the suns' shadow rays have a finite depth.

use crate::media::{Aabb, HeteroMedium, Heterogeneous};
use crate::render::{Image, Model};
use crate::scene::{Environment, Light, Rgb, Scene};
use crate::vec3::Vec3;
use haze_fogfn::Fog;
use rayon::prelude::*;
use serde::Deserialize;
use serde_json::Value;
use std::sync::Arc;

/// One analytic medium, frozen at `time`.
#[derive(Clone, Debug, PartialEq)]
pub struct AnalyticMedium {
    pub fog: Fog,
    /// Extinction per unit of `K`, per channel.
    pub sigma_t: Rgb,
    pub albedo: Rgb,
    pub g: f64,
    /// `C_fog` when given (module docs).
    pub colour: Option<Rgb>,
    /// Where the fog ends along a ray (world units from the ray's origin).
    pub far: f64,
    /// Seconds since the start of the wind.
    pub time: f64,
}

impl AnalyticMedium {
    /// The same medium at time `t`.
    pub fn at(&self, t: f64) -> AnalyticMedium {
        AnalyticMedium {
            time: t,
            ..self.clone()
        }
    }

    /// `∫₀^{min(len, far)} K(o + s d, time) ds` (unit `d`), in closed form.
    pub fn depth(&self, o: Vec3, d: Vec3, len: f64) -> f64 {
        self.fog.optical_depth(o, d, len.min(self.far), self.time)
    }
}

impl Heterogeneous for AnalyticMedium {
    fn name(&self) -> String {
        format!("analytic fog of {} terms", self.fog.terms.len())
    }
    fn sigma_t(&self, x: Vec3) -> Rgb {
        let k = self.fog.density(x, self.time);
        self.sigma_t.map(|s| s * k)
    }
    fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb {
        if len <= 0.0 {
            return [0.0; 3];
        }
        let k = self.depth(o, d, len);
        self.sigma_t.map(|s| s * k)
    }
    fn albedo(&self) -> Rgb {
        self.albedo
    }
    fn g(&self) -> f64 {
        self.g
    }
    fn bounds(&self) -> Option<Aabb> {
        None
    }
    fn as_analytic(&self) -> Option<&AnalyticMedium> {
        Some(self)
    }
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Channels {
    One(f64),
    Rgb(Rgb),
}

impl Channels {
    fn rgb(&self) -> Rgb {
        match *self {
            Channels::One(v) => [v; 3],
            Channels::Rgb(c) => c,
        }
    }
}

fn default_far() -> f64 {
    1000.0
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnalyticSpec {
    #[allow(dead_code)]
    r#type: String,
    sigma_t: Channels,
    #[serde(default = "Default::default")]
    albedo: Option<Channels>,
    #[serde(default)]
    g: f64,
    #[serde(default)]
    colour: Option<Rgb>,
    #[serde(default = "default_far")]
    far: f64,
    #[serde(default)]
    wind: Vec3,
    terms: Vec<Value>,
}

/// Reads an `"analytic"` medium of the scene file.
pub fn parse(v: &Value) -> Result<HeteroMedium, String> {
    let s = AnalyticSpec::deserialize(v).map_err(|e| e.to_string())?;
    let sigma_t = s.sigma_t.rgb();
    if !sigma_t.iter().all(|x| x.is_finite() && *x >= 0.0) {
        return Err(format!(
            "sigma_t {sigma_t:?} must be finite and not negative"
        ));
    }
    let albedo = s.albedo.map_or([1.0; 3], |a| a.rgb());
    if !albedo.iter().all(|a| (0.0..=1.0).contains(a)) {
        return Err(format!("albedo {albedo:?} must be in [0, 1]"));
    }
    if !(s.g > -1.0 && s.g < 1.0) {
        return Err(format!("g = {} must be in (−1, 1)", s.g));
    }
    if let Some(c) = s.colour
        && !c.iter().all(|x| x.is_finite() && *x >= 0.0)
    {
        return Err(format!("colour {c:?} must be finite and not negative"));
    }
    if !(s.far > 0.0 && s.far.is_finite()) {
        return Err(format!("far {} must be positive and finite", s.far));
    }
    if s.terms.is_empty() {
        return Err("an analytic medium needs at least one term".to_string());
    }
    let fog = haze_fogfn::spec::fog(s.wind, &s.terms)?;
    Ok(HeteroMedium(Arc::new(AnalyticMedium {
        fog,
        sigma_t,
        albedo,
        g: s.g,
        colour: s.colour,
        far: s.far,
        time: 0.0,
    })))
}

impl Scene {
    /// The scene at time `t` (seconds): every analytic medium carried by its wind.
    pub fn at_time(&self, t: f64) -> Scene {
        let mut s = self.clone();
        for m in &mut s.hetero {
            if let Some(a) = m.as_analytic() {
                *m = HeteroMedium(Arc::new(a.at(t)));
            }
        }
        s
    }

    /// The scene's analytic media.
    pub fn analytic_media(&self) -> impl Iterator<Item = &AnalyticMedium> {
        self.hetero.iter().filter_map(|m| m.as_analytic())
    }
}

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
    lim: &crate::airlight::Limits,
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
