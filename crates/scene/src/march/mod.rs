//! Single scattering through all of a scene's media — the homogeneous one and every
//! [`Heterogeneous`](crate::media::Heterogeneous) medium — by ray marching with exact transmittance between samples:
//! the renderer of media without an analytic airlight and the reference of those with one
//! (papers B and D are checked against it).
//!
//! Along the camera ray `x(t) = eye + t·dir`, `t ∈ [0, t_end]`:
//! `L = ∫₀^{t_end} T(0, t) Σ_m σs_m(x) Σ_lights p_m(−dir·ωl) Lₗ(x) dt + T(0, t_end)·L_end`,
//! `T(a, b) = exp(−∫_a^b σt)` with `σt` the sum of every medium's extinction, `Lₗ(x)` a
//! point light's `I·T(x → light)/d²` or a sun's irradiance `E·T(x → ∞)` (the
//! homogeneous medium does not attenuate suns: paper C's convention, see
//! [`crate::paper_c::airlight`]), each zero when a surface blocks the light. The integral is the
//! midpoint rule on steps of at most [`MarchOptions::step`], every step's transmittance
//! from the media's own optical depths (closed forms where they have them), so the only
//! discretization is that of the in-scattered light. A surface at `t_end` reflects the
//! direct light of every light (Lambert + normalized Phong, [`crate::scene::Material::brdf`]) reaching
//! it through the media; light scattered onto surfaces by the medium is not included.
//! Where a homogeneous medium fills space the march ends where the transmittance falls
//! below [`MarchOptions::min_transmittance`]. The environment lights the heterogeneous
//! media too, by [`MarchOptions::env`] ([`env_smoke`]), added to `Σ_l`, and the
//! surfaces by [`MarchOptions::env_surfaces`] when set, each direction attenuated by the
//! media ([`env_smoke::Direct::surface`]).

pub mod env_smoke;
pub mod steps;

use crate::media::{HeteroMedium, henyey_greenstein};
use crate::paper_c::airlight::Limits;
use crate::render::Image;
use crate::scene::{Light, Rgb, Scene};
use crate::vec3::{Vec3, axpy, dot, norm, reflect, scale, sub};
use env_smoke::EnvLight;

/// Settings of the march.
#[derive(Clone, Debug, PartialEq)]
pub struct MarchOptions {
    /// Longest step along a camera ray (world units).
    pub step: f64,
    /// The march ends where the transmittance to the eye of every channel falls below this.
    pub min_transmittance: f64,
    /// Most steps along one ray (a guard against a tiny `step` on a long ray).
    pub max_steps: usize,
    /// The environment's light on the heterogeneous media ([`env_smoke`]).
    pub env: EnvLight,
    /// The environment's light on the surfaces, by direct quadrature
    /// ([`env_smoke::Direct::surface`]; paper B's reference), or none.
    pub env_surfaces: Option<std::sync::Arc<env_smoke::Direct>>,
    /// Steps from the Gaussians' radii, the lights' distances and the homogeneous
    /// extinction ([`steps`]; paper B's reference) instead of [`MarchOptions::step`].
    pub steps: Option<std::sync::Arc<steps::GaussianSteps>>,
}

impl Default for MarchOptions {
    fn default() -> Self {
        MarchOptions {
            step: 0.02,
            min_transmittance: 1e-6,
            max_steps: 200_000,
            env: EnvLight::None,
            env_surfaces: None,
            steps: None,
        }
    }
}

/// The optical depth of every medium along `o + t·d`, `t ∈ [0, len]` (unit `d`; `len`
/// may be `∞`).
pub fn optical_depth(scene: &Scene, o: Vec3, d: Vec3, len: f64) -> Rgb {
    let mut tau = [0.0; 3];
    if len <= 0.0 {
        return tau;
    }
    for (t, &s) in tau.iter_mut().zip(&scene.medium.sigma_t) {
        if s > 0.0 {
            *t += s * len;
        }
    }
    for m in &scene.hetero {
        let t = m.optical_depth(o, d, len);
        for c in 0..3 {
            tau[c] += t[c];
        }
    }
    tau
}

/// The optical depth of the heterogeneous media alone (what attenuates a sun).
fn hetero_depth(scene: &Scene, o: Vec3, d: Vec3, len: f64) -> Rgb {
    let mut tau = [0.0; 3];
    for m in &scene.hetero {
        let t = m.optical_depth(o, d, len);
        for c in 0..3 {
            tau[c] += t[c];
        }
    }
    tau
}

/// Light arriving at `x` from each light: `(unit direction towards the light, radiance
/// scale per channel)` — `I·T/d²` for a point light, `E·T` for a sun; lights blocked by a
/// surface are left out.
fn lights_at(scene: &Scene, lim: &Limits, x: Vec3) -> Vec<(Vec3, Rgb)> {
    let mut out = Vec::with_capacity(scene.lights.len());
    for light in &scene.lights {
        match light {
            Light::Point {
                position,
                intensity,
            } => {
                let v = sub(*position, x);
                let d = norm(v).max(lim.r_min);
                let l = scale(v, 1.0 / d);
                if !scene.visible(x, *position) {
                    continue;
                }
                let tau = optical_depth(scene, x, l, d);
                out.push((
                    l,
                    [0, 1, 2].map(|c| intensity[c] * (-tau[c]).exp() / (d * d)),
                ));
            }
            Light::Sun {
                direction,
                radiance,
                angle,
            } => {
                if scene
                    .intersect(x, *direction, 1e-9 * (1.0 + norm(x)), f64::INFINITY)
                    .is_some()
                {
                    continue;
                }
                let e = Light::sun_irradiance(*radiance, *angle);
                let tau = hetero_depth(scene, x, *direction, f64::INFINITY);
                out.push((*direction, [0, 1, 2].map(|c| e[c] * (-tau[c]).exp())));
            }
        }
    }
    out
}

/// Light scattered once towards `-dir` at `x`: `Σ_m σs_m(x) Σ_l p_m(dir·ωl) Lₗ`.
fn in_scattered(scene: &Scene, lim: &Limits, x: Vec3, dir: Vec3) -> Rgb {
    // Each medium's σs and phase; the homogeneous medium is isotropic.
    let mut media: Vec<(Rgb, f64)> = Vec::with_capacity(1 + scene.hetero.len());
    media.push((scene.medium.sigma_s(), 0.0));
    for m in &scene.hetero {
        let (st, a) = (m.sigma_t(x), m.albedo());
        media.push(([0, 1, 2].map(|c| st[c] * a[c]), m.g()));
    }
    if media.iter().all(|(s, _)| s.iter().all(|&v| v <= 0.0)) {
        return [0.0; 3];
    }
    let mut out = [0.0; 3];
    for (l, li) in lights_at(scene, lim, x) {
        let cos = dot(dir, l);
        for (ss, g) in &media {
            let p = henyey_greenstein(*g, cos);
            for c in 0..3 {
                out[c] += ss[c] * p * li[c];
            }
        }
    }
    out
}

/// The interval of the camera ray that holds extinction: `[0, t_end]` when the
/// homogeneous medium is present, else the union of the heterogeneous media's boxes (an
/// analytic fog's: `[0, min(t_end, far)]`).
fn medium_span(scene: &Scene, eye: Vec3, dir: Vec3, t_end: f64) -> Option<(f64, f64)> {
    if scene.medium.sigma_t.iter().any(|&s| s > 0.0) {
        return Some((0.0, t_end));
    }
    let mut span: Option<(f64, f64)> = None;
    for m in &scene.hetero {
        let s = match (m.bounds(), m) {
            (Some(b), _) => b.clip(eye, dir, 0.0, t_end),
            // An analytic fog ends at its `far` from the eye (crate::media::analytic).
            (None, HeteroMedium::Analytic(a)) => Some((0.0, t_end.min(a.far))),
            (None, _) => Some((0.0, t_end)),
        };
        if let Some((a, b)) = s {
            span = Some(span.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
        }
    }
    span
}

/// Radiance along the camera ray of unit direction `dir` (module docs).
pub fn radiance(scene: &Scene, lim: &Limits, opt: &MarchOptions, dir: Vec3) -> Rgb {
    let eye = scene.camera.eye;
    let hit = scene.intersect(eye, dir, 0.0, scene.environment_distance);
    let t_end = hit.map_or(scene.environment_distance, |h| h.t);
    let mut out = [0.0; 3];
    let mut trans = [1.0; 3];
    let mut faded = false;
    if let Some((t0, t1)) = medium_span(scene, eye, dir, t_end) {
        // Transmittance from the eye to where the extinction starts.
        let tau = optical_depth(scene, eye, dir, t0);
        trans = tau.map(|t| (-t).exp());
        let spans = opt
            .steps
            .as_ref()
            .map_or_else(Vec::new, |s| s.spans(eye, dir, t1));
        let mut t = t0;
        let mut steps = 0;
        while t < t1 && steps < opt.max_steps {
            let h = match &opt.steps {
                Some(s) => s.step(&spans, t, axpy(eye, t, dir)),
                None => opt.step,
            }
            .min(t1 - t);
            let mid = axpy(eye, t + 0.5 * h, dir);
            // Transmittance to the midpoint, then over the rest of the step.
            let first = optical_depth(scene, axpy(eye, t, dir), dir, 0.5 * h);
            let second = optical_depth(scene, mid, dir, 0.5 * h);
            let mut j = in_scattered(scene, lim, mid, dir);
            if opt.env != EnvLight::None {
                let e = opt.env.in_scattered(scene, mid, dir);
                for c in 0..3 {
                    j[c] += e[c];
                }
            }
            for c in 0..3 {
                out[c] += trans[c] * (-first[c]).exp() * j[c] * h;
                trans[c] *= (-(first[c] + second[c])).exp();
            }
            t += h;
            steps += 1;
            if trans.iter().all(|&x| x < opt.min_transmittance) {
                faded = true;
                break;
            }
        }
    }
    if faded {
        return out;
    }
    let behind = match hit {
        Some(h) => {
            let m = &scene.surfaces[h.surface].material;
            let (p, n) = (h.point, h.normal);
            let r = reflect(scale(dir, -1.0), n);
            let p_off = axpy(p, 1e-9 * (1.0 + norm(p)), n);
            let mut l_out = [0.0; 3];
            for (l, li) in lights_at(scene, lim, p_off) {
                for c in 0..3 {
                    l_out[c] += m.brdf(n, r, l, c) * li[c];
                }
            }
            if let Some(d) = &opt.env_surfaces {
                let e = d.surface(scene, p_off, n, r, m);
                for c in 0..3 {
                    l_out[c] += e[c];
                }
            }
            l_out
        }
        None if t_end.is_infinite() && scene.medium.sigma_t.iter().all(|&b| b > 0.0) => [0.0; 3],
        None => crate::render::background(scene, dir),
    };
    for c in 0..3 {
        out[c] += trans[c] * behind[c];
    }
    out
}

/// Renders the scene's camera image by the march; `progress` hears the rows finished.
pub fn render(
    scene: &Scene,
    lim: &Limits,
    opt: &MarchOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Image {
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    Image::by_rows(w, h, progress, |x, y| {
        radiance(scene, lim, opt, cam.pixel_ray(x, y))
    })
}

/// The march's settings for `scene`: steps of half the smallest voxel
/// of its voxel media (a trilinear field varies over a voxel; the midpoint rule's error
/// then stays ~`h²/24` of the in-scattered light's curvature) and an eighth of its
/// analytic fogs' finest feature, whichever is smaller, or the default step
/// when it has neither; `fine` (the reference) takes a quarter of that. The environment
/// lights the media through [`env_smoke::light`], computed here (once per render).
pub fn march_options(scene: &Scene, fine: bool) -> MarchOptions {
    let mut opt = march_steps(scene, fine);
    opt.env = env_smoke::light(scene);
    opt
}

/// [`march_options`] without the environment's light on the media.
pub fn march_steps(scene: &Scene, fine: bool) -> MarchOptions {
    let mut opt = MarchOptions::default();
    let voxel = scene
        .hetero
        .iter()
        .filter_map(|m| match m {
            HeteroMedium::Asset(a) => Some(a.grid()),
            _ => None,
        })
        .flat_map(|g| g.voxel)
        .fold(f64::INFINITY, f64::min);
    // Analytic fogs: an eighth of their finest feature (haze_fogfn::Fog::feature_size).
    let fog = scene
        .analytic_media()
        .map(|a| 0.125 * a.fog.feature_size())
        .fold(f64::INFINITY, f64::min);
    let step = (0.5 * voxel).min(fog);
    if step.is_finite() {
        opt.step = step;
    }
    if fine {
        opt.step *= 0.25;
    }
    opt
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::media::{Aabb, Heterogeneous};
    use std::sync::Arc;

    /// A box of constant extinction — its optical depth in closed form (the clipped
    /// length times `σt`).
    #[derive(Debug)]
    struct Slab {
        b: Aabb,
        sigma: f64,
        albedo: f64,
    }

    impl Heterogeneous for Slab {
        fn name(&self) -> String {
            "slab".into()
        }
        fn sigma_t(&self, x: Vec3) -> Rgb {
            let inside = (0..3).all(|k| x[k] >= self.b.min[k] && x[k] <= self.b.max[k]);
            [if inside { self.sigma } else { 0.0 }; 3]
        }
        fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb {
            let l = self.b.clip(o, d, 0.0, len).map_or(0.0, |(a, b)| b - a);
            [self.sigma * l; 3]
        }
        fn albedo(&self) -> Rgb {
            [self.albedo; 3]
        }
        fn bounds(&self) -> Option<Aabb> {
            Some(self.b)
        }
    }

    fn scene_with(json_lights: &str, slab: Slab) -> Scene {
        let text = format!(
            r#"{{"camera": {{"eye": [0, -5, 0], "target": [0, 0, 0], "up": [0, 0, 1],
                "fov": 30, "width": 8, "height": 6}},
               "environment": [0.5, 0.5, 0.5], "lights": [{json_lights}]}}"#
        );
        let mut s = crate::file::parse(&text).unwrap();
        s.hetero.push(HeteroMedium::Other(Arc::new(slab)));
        s
    }

    #[test]
    fn sun_through_a_slab_matches_the_closed_form() {
        // A sun straight down onto a box |x|,|z| ≤ 1, |y| ≤ 0.5 of σt, albedo a, seen
        // along +y through its middle: the light at depth u below the top is E·e^{−σ(1−z)},
        // the path inside is 1 long, the phase isotropic, so
        // L = ∫₋.₅^.₅ e^{−σ(y+.5)} a σ E/(4π) e^{−σ(1−0)} dy + e^{−σ}·L_env
        //   = aE/(4π)·e^{−σ}(1 − e^{−σ}) + e^{−σ}·0.5.
        let (sigma, a, e) = (1.3, 0.7, 2.0);
        let s = scene_with(
            r#"{"type": "sun", "direction": [0, 0, 1], "radiance": [2, 2, 2], "angle": 0}"#,
            Slab {
                b: Aabb {
                    min: [-1.0, -0.5, -1.0],
                    max: [1.0, 0.5, 1.0],
                },
                sigma,
                albedo: a,
            },
        );
        let opt = MarchOptions {
            step: 1e-3,
            ..Default::default()
        };
        let l = radiance(&s, &Limits::default(), &opt, [0.0, 1.0, 0.0]);
        let want = a * e / (4.0 * std::f64::consts::PI) * (-sigma).exp() * (1.0 - (-sigma).exp())
            + (-sigma).exp() * 0.5;
        // The midpoint rule on a smooth exponential: error ~ h²σ²/24 relative.
        assert!((l[0] - want).abs() < 1e-6 * want, "{} vs {want}", l[0]);
    }

    #[test]
    fn empty_media_leave_the_background() {
        let s = scene_with(
            r#"{"type": "point", "position": [0, 0, 3], "intensity": [5, 5, 5]}"#,
            Slab {
                b: Aabb {
                    min: [-1.0; 3],
                    max: [1.0; 3],
                },
                sigma: 0.0,
                albedo: 1.0,
            },
        );
        let l = radiance(
            &s,
            &Limits::default(),
            &MarchOptions::default(),
            [0.0, 1.0, 0.0],
        );
        assert_eq!(l, [0.5; 3]);
    }

    #[test]
    fn opaque_media_are_black_without_nan() {
        let s = scene_with(
            r#"{"type": "point", "position": [0, 0, 0.2], "intensity": [5, 5, 5]}"#,
            Slab {
                b: Aabb {
                    min: [-1.0; 3],
                    max: [1.0; 3],
                },
                sigma: 1e6,
                albedo: 1.0,
            },
        );
        let l = radiance(
            &s,
            &Limits::default(),
            &MarchOptions::default(),
            [0.0, 1.0, 0.0],
        );
        assert!(
            l.iter().all(|v| v.is_finite() && *v >= 0.0 && *v < 1e-3),
            "{l:?}"
        );
    }
}
