//! Rendering a scene: per pixel `L = Σ_lights La + e^{−β·t}·Lp` (paper C, eq. 19), with
//! `La` the airlight ([`crate::paper_c::airlight`]), `t` the distance to the surface hit and `Lp`
//! the light the surface reflects towards the eye — direct light attenuated by the medium
//! and shadowed by the scene's surfaces, plus light scattered once onto it (unshadowed, as
//! in paper C). Rays that hit nothing end at the environment distance and see the
//! environment (and the suns' disks) attenuated. The environment also glows through the
//! medium and lights the surfaces, directly and scattered once ([`EnvLight`], paper C
//! §6.4). Two models fill in the scattered terms: [`Analytic`] (paper C's tables, the
//! environment in SH: [`crate::paper_c::envglow`]) and [`Reference`] (quadrature:
//! [`crate::paper_c::reference`], [`crate::paper_c::envref`]).
//!
//! Per channel `c`: extinction `β = σt[c]`, scattering `σs = albedo[c]·β`. A surface's
//! reflected radiance from a light of irradiance `E` at direction `l` is
//! `E·[ρd/π·cos θs + ks·(m + 2)/(2π)·max(0, r·l)^m]` for `cos θs = n·l > 0`, `r` the
//! mirror direction of the view (the normalized Phong lobe of paper C §4). Suns light the
//! medium and the surfaces unattenuated (the fog is local) and scatter
//! `σs·E/(4π)·∫e^{−βx}dx` towards the eye, and `αE/(4π)·[ρd + ks(m + 2)/(m + 1)]` onto a
//! surface (the medium's in-scattering integrated over the lobes, rays to infinity).

use crate::paper_c::airlight::{self, Limits, attenuated_length, effective_light, light_off_point};
use crate::paper_c::envglow::{self, EnvGlow};
use crate::paper_c::envref::EnvReference;
use crate::paper_c::gtable::{self, GTable};
use crate::paper_c::htable::HTable;
use crate::paper_c::reference::{self, RefOptions};
use crate::scene::{Environment, Light, Material, Rgb, Scene};
use crate::vec3::{Vec3, axpy, cos_sin, dot, norm, reflect, scale, sub};
use std::f64::consts::PI;

pub use haze_core::Image;

/// How the point lights' scattered terms are computed, per unit intensity and channel.
pub trait Model: Sync {
    /// Airlight along `eye + t·dir`, `t ∈ [0, t_end]`.
    fn airlight(&self, eye: Vec3, dir: Vec3, t_end: f64, light: Vec3, beta: f64, ss: f64) -> f64;
    /// Light scattered onto the surface point `p` and reflected towards the viewer.
    #[allow(clippy::too_many_arguments)]
    fn surface(
        &self,
        p: Vec3,
        n: Vec3,
        r: Vec3,
        light: Vec3,
        beta: f64,
        ss: f64,
        m: &Material,
        ch: usize,
    ) -> f64;
    /// What it is, for summaries.
    fn name(&self) -> String;
    /// The environment's light through the medium for `scene` (built once per image),
    /// `None` for a black environment.
    fn environment(&self, scene: &Scene) -> Option<Box<dyn EnvLight>>;
}

/// The environment's light through the medium ([`crate::paper_c::envglow`]): its airlight along a
/// view ray and the light it sends onto surfaces, direct and scattered.
pub trait EnvLight: Sync {
    /// Airlight along `eye + x·dir`, `x ∈ [0, t]`.
    fn view(&self, dir: Vec3, t: f64) -> Rgb;
    /// Radiance reflected towards the viewer by a surface point of unit normal `n`, `r`
    /// the mirror direction of the view.
    fn surface(&self, n: Vec3, r: Vec3, m: &Material) -> Rgb;
}

impl EnvLight for EnvGlow {
    fn view(&self, dir: Vec3, t: f64) -> Rgb {
        EnvGlow::view(self, dir, t)
    }
    fn surface(&self, n: Vec3, r: Vec3, m: &Material) -> Rgb {
        EnvGlow::surface(self, n, r, m)
    }
}

impl EnvLight for EnvReference {
    fn view(&self, dir: Vec3, t: f64) -> Rgb {
        EnvReference::view(self, dir, t)
    }
    fn surface(&self, n: Vec3, r: Vec3, m: &Material) -> Rgb {
        EnvReference::surface(self, n, r, m)
    }
}

/// Paper C: the airlight's table `K` and the `G0`/`Gn` tables (one per Phong exponent in
/// the scene).
#[derive(Debug)]
pub struct Analytic {
    pub h: HTable,
    pub g0: GTable,
    pub gn: Vec<GTable>,
    /// The environment's glow with `h`, kept between renders ([`envglow::Cache`]).
    pub glow: envglow::Cache,
}

impl Analytic {
    /// Builds the tables the scene needs (the `Gn` tables only for specular materials).
    pub fn new(scene: &Scene) -> Analytic {
        let h = HTable::default();
        let g0 = GTable::new(&h, 1.0, gtable::DEFAULT_SIZE);
        let mut exps: Vec<f64> = scene
            .surfaces
            .iter()
            .filter(|s| s.material.is_specular())
            .map(|s| s.material.shininess)
            .collect();
        exps.sort_by(f64::total_cmp);
        exps.dedup();
        let gn = exps
            .iter()
            .map(|&n| GTable::new(&h, n, gtable::DEFAULT_SIZE))
            .collect();
        Analytic {
            h,
            g0,
            gn,
            glow: envglow::Cache::default(),
        }
    }

    fn gn(&self, n: f64) -> Option<&GTable> {
        self.gn.iter().find(|t| t.exponent == n)
    }

    /// The Phong exponents it has `Gn` tables for.
    pub fn exponents(&self) -> Vec<f64> {
        self.gn.iter().map(|g| g.exponent).collect()
    }
}

/// The angle between two unit vectors, by `atan2` (exact near 0 and π).
fn angle(a: Vec3, b: Vec3) -> f64 {
    let (c, s) = cos_sin(a, b);
    s.atan2(c)
}

impl Model for Analytic {
    fn airlight(&self, eye: Vec3, dir: Vec3, t_end: f64, light: Vec3, beta: f64, ss: f64) -> f64 {
        airlight::point(&self.h, eye, dir, t_end, light, 1.0, beta, ss)
    }

    /// `σs·I/(2π Dsp)·[ρd/π·G0(T, θs) + ks(m + 2)/(2π)·Gm(T, θ′s)]` (paper C eq. 17–18,
    /// [`crate::paper_c::gtable`]).
    fn surface(
        &self,
        p: Vec3,
        n: Vec3,
        r: Vec3,
        light: Vec3,
        beta: f64,
        ss: f64,
        m: &Material,
        ch: usize,
    ) -> f64 {
        if ss <= 0.0 {
            return 0.0;
        }
        let v = sub(light, p);
        let d = norm(v);
        let l = scale(v, 1.0 / d);
        let t = beta * d;
        let mut out = m.diffuse[ch] / PI * self.g0.g(t, angle(n, l));
        if let Some(g) = self.gn(m.shininess).filter(|_| m.specular[ch] > 0.0) {
            let k = m.specular[ch] * (m.shininess + 2.0) / (2.0 * PI);
            out += k * g.g(t, angle(r, l));
        }
        ss / (2.0 * PI * d) * out
    }

    fn name(&self) -> String {
        format!(
            "paper C analytic (K table {}², G tables {}×{}, environment in SH of order {})",
            self.h.table.nx,
            self.g0.table.nx,
            self.g0.table.ny,
            envglow::DEFAULT_ORDER
        )
    }

    /// The environment in SH with the medium's glow ([`EnvGlow`]), with `Phong` factors
    /// for the exponents of the scene's specular surfaces.
    fn environment(&self, scene: &Scene) -> Option<Box<dyn EnvLight>> {
        let mut exps: Vec<f64> = scene
            .surfaces
            .iter()
            .filter(|s| s.material.is_specular())
            .map(|s| s.material.shininess)
            .collect();
        exps.sort_by(f64::total_cmp);
        exps.dedup();
        self.glow
            .glow(scene, &self.h, envglow::DEFAULT_ORDER, &exps)
            .map(|g| Box::new(g) as Box<dyn EnvLight>)
    }
}

/// The quadrature reference ([`crate::paper_c::reference`]).
#[derive(Debug, Default)]
pub struct Reference {
    pub options: RefOptions,
}

impl Model for Reference {
    fn airlight(&self, eye: Vec3, dir: Vec3, t_end: f64, light: Vec3, beta: f64, ss: f64) -> f64 {
        reference::point_airlight(eye, dir, t_end, light, beta, ss, self.options.tolerance)
    }

    fn surface(
        &self,
        p: Vec3,
        n: Vec3,
        r: Vec3,
        light: Vec3,
        beta: f64,
        ss: f64,
        m: &Material,
        ch: usize,
    ) -> f64 {
        reference::surface_scattered(p, n, r, light, beta, ss, m, ch, &self.options)
    }

    fn name(&self) -> String {
        "single-scattering reference (quadrature)".to_string()
    }

    /// The environment integrated on the sphere ([`EnvReference`]).
    fn environment(&self, scene: &Scene) -> Option<Box<dyn EnvLight>> {
        EnvReference::new(scene).map(|r| Box::new(r) as Box<dyn EnvLight>)
    }
}

/// `e^{−βt}`, 1 at `β = 0` whatever `t` (no `0·∞`).
fn transmittance(beta: f64, t: f64) -> f64 {
    if beta <= 0.0 { 1.0 } else { (-beta * t).exp() }
}

/// Renders the scene's camera image with `model`; `progress` hears the number of rows
/// finished so far.
pub fn render(
    scene: &Scene,
    model: &dyn Model,
    lim: &Limits,
    progress: &(dyn Fn(usize) + Sync),
) -> Image {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let lim = Limits {
        gamma_min: lim.gamma_min.max(0.5 * cam.pixel_radius()),
        ..*lim
    };
    let env = model.environment(scene);
    let env = env.as_deref();
    Image::by_rows(w, h, progress, |x, y| {
        radiance(scene, model, env, &lim, cam.pixel_ray(x, y))
    })
}

/// Channels grouped by equal `(β, σs)`: each group's scattering is computed once per
/// unit intensity.
fn channel_groups(scene: &Scene) -> Vec<(f64, f64, Vec<usize>)> {
    let mut groups: Vec<(f64, f64, Vec<usize>)> = Vec::new();
    let ss = scene.medium.sigma_s();
    for (c, &s) in ss.iter().enumerate() {
        let key = (scene.medium.sigma_t[c], s);
        match groups.iter_mut().find(|g| (g.0, g.1) == key) {
            Some(g) => g.2.push(c),
            None => groups.push((key.0, key.1, vec![c])),
        }
    }
    groups
}

/// Radiance along the camera ray of unit direction `dir`; `env` is the model's
/// [`Model::environment`].
pub fn radiance(
    scene: &Scene,
    model: &dyn Model,
    env: Option<&dyn EnvLight>,
    lim: &Limits,
    dir: Vec3,
) -> Rgb {
    let eye = scene.camera.eye;
    let hit = scene.intersect(eye, dir, 0.0, scene.environment_distance);
    let t_end = hit.map_or(scene.environment_distance, |h| h.t);
    let groups = channel_groups(scene);
    let mut out = [0.0; 3];
    // Airlight.
    for light in &scene.lights {
        match light {
            Light::Point {
                position,
                intensity,
            } => {
                let s = effective_light(eye, dir, *position, lim);
                for (beta, ss, chans) in &groups {
                    if *ss <= 0.0 || chans.iter().all(|&c| intensity[c] <= 0.0) {
                        continue;
                    }
                    let la = model.airlight(eye, dir, t_end, s, *beta, *ss);
                    for &c in chans {
                        out[c] += intensity[c] * la;
                    }
                }
            }
            Light::Sun {
                radiance, angle, ..
            } => {
                let e = Light::sun_irradiance(*radiance, *angle);
                for c in 0..3 {
                    let ss = scene.medium.sigma_s()[c];
                    out[c] += airlight::sun(t_end, e[c], scene.medium.sigma_t[c], ss);
                }
            }
        }
    }
    // The environment's airlight.
    if let Some(env) = env {
        let a = env.view(dir, t_end);
        for c in 0..3 {
            out[c] += a[c];
        }
    }
    // What the ray ends on, attenuated.
    let behind = match hit {
        Some(h) => surface(scene, model, env, lim, &groups, dir, h),
        None if t_end.is_infinite() && scene.medium.sigma_t.iter().all(|&b| b > 0.0) => [0.0; 3],
        None => background(scene, dir),
    };
    for c in 0..3 {
        if behind[c] != 0.0 {
            out[c] += transmittance(scene.medium.sigma_t[c], t_end) * behind[c];
        }
    }
    out
}

/// The environment and the suns' disks in direction `dir`.
pub fn background(scene: &Scene, dir: Vec3) -> Rgb {
    let mut l = match &scene.environment {
        Environment::Black => [0.0; 3],
        env => env.radiance(dir),
    };
    for light in &scene.lights {
        if let Light::Sun {
            direction,
            radiance,
            angle,
        } = light
            && *angle > 0.0
            && dot(dir, *direction) >= (0.5 * angle).cos()
        {
            for (o, r) in l.iter_mut().zip(radiance) {
                *o += r;
            }
        }
    }
    l
}

/// Radiance leaving the surface hit towards the eye.
fn surface(
    scene: &Scene,
    model: &dyn Model,
    env: Option<&dyn EnvLight>,
    lim: &Limits,
    groups: &[(f64, f64, Vec<usize>)],
    dir: Vec3,
    hit: crate::scene::Hit,
) -> Rgb {
    let m = &scene.surfaces[hit.surface].material;
    let (p, n) = (hit.point, hit.normal);
    let r = reflect(scale(dir, -1.0), n);
    // Shadow rays start a little off the surface.
    let p_off = axpy(p, 1e-9 * (1.0 + norm(p)), n);
    let brdf = |l: Vec3, c: usize| m.brdf(n, r, l, c);
    let mut out = env.map_or([0.0; 3], |e| e.surface(n, r, m));
    for light in &scene.lights {
        match light {
            Light::Point {
                position,
                intensity,
            } => {
                let s = light_off_point(p, n, *position, lim.r_min);
                let v = sub(s, p);
                let d = norm(v);
                let l = scale(v, 1.0 / d);
                let lit = dot(n, l) > 0.0 && scene.visible(p_off, s);
                for (beta, ss, chans) in groups {
                    let reflects = chans
                        .iter()
                        .any(|&c| m.diffuse[c] > 0.0 || m.specular[c] > 0.0);
                    let scattered = if *ss > 0.0 && reflects {
                        Some(
                            chans
                                .iter()
                                .map(|&c| model.surface(p, n, r, s, *beta, *ss, m, c)),
                        )
                    } else {
                        None
                    };
                    let direct = transmittance(*beta, d) / (d * d);
                    let scattered: Vec<f64> = match scattered {
                        Some(it) => it.collect(),
                        None => vec![0.0; chans.len()],
                    };
                    for (i, &c) in chans.iter().enumerate() {
                        let mut v = scattered[i];
                        if lit {
                            v += direct * brdf(l, c);
                        }
                        out[c] += intensity[c] * v;
                    }
                }
            }
            Light::Sun {
                direction,
                radiance,
                angle,
            } => {
                let e = Light::sun_irradiance(*radiance, *angle);
                let lit = dot(n, *direction) > 0.0
                    && scene
                        .intersect(p_off, *direction, 0.0, f64::INFINITY)
                        .is_none();
                let ss = scene.medium.sigma_s();
                for c in 0..3 {
                    if lit {
                        out[c] += e[c] * brdf(*direction, c);
                    }
                    if ss[c] > 0.0 {
                        let lobes = m.diffuse[c]
                            + m.specular[c] * (m.shininess + 2.0) / (m.shininess + 1.0);
                        let path = scene.medium.sigma_t[c]
                            * attenuated_length(scene.medium.sigma_t[c], f64::INFINITY);
                        out[c] += scene.medium.albedo[c] * e[c] / (4.0 * PI) * path * lobes;
                    }
                }
            }
        }
    }
    out
}
