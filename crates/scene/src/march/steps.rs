//! Step control of the march through media of Gaussians (paper B's reference): fine
//! steps where a Gaussian is, long ones through the homogeneous part between them.
//!
//! The march's midpoint rule errs by `~h²·j″/24` per step, `j` the in-scattered light
//! along the ray (its transmittance is exact, [`super`]). `j` varies on three scales:
//!
//! * a Gaussian's radius `rᵢ` inside its support, taken as the sphere of `3.5·rᵢ`
//!   (density `e^{−12.25}` of the peak beyond): steps of [`INSIDE`]`·rᵢ` there, error
//!   `~(0.2)²/24 < 2·10⁻³` relative over the Gaussian;
//! * the distance `d` to a point light (`1/d²`): steps of at most [`NEAR_LIGHT`]`·d`, error
//!   `~6·0.1²/24 = 2.5·10⁻³` relative where `d` is smallest; `d` is floored at
//!   [`INSIDE`]`/100` of the smallest radius so that a ray through the light passes it;
//! * the homogeneous extinction `β0` (the in-scattered light and the transmittance fall as
//!   `e^{−β0·t}`): steps of at most [`HOMOGENEOUS`]`/β0`, error `(0.2)²/24`.
//!
//! Between supports the step also stops at the next support's entry, so no Gaussian is
//! stepped over, and never exceeds [`FREE_MAX`]. The spans of a ray are found once, in
//! a [`SphereBvh`] of the supports.

use crate::media::HeteroMedium;
use crate::scene::{Light, Scene};
use crate::vec3::{Vec3, dot, norm, sub};
use haze_gaussians::bvh::SphereBvh;

/// Step inside a Gaussian's support, in its radii.
pub const INSIDE: f64 = 0.2;
/// A Gaussian's support, in its radii.
pub const SUPPORT: f64 = 3.5;
/// Longest step near a point light, as a fraction of the distance to it.
pub const NEAR_LIGHT: f64 = 0.1;
/// Longest step through the homogeneous part, in mean free paths `1/β0`.
pub const HOMOGENEOUS: f64 = 0.2;
/// Longest step anywhere (world units).
pub const FREE_MAX: f64 = 0.5;

/// The Gaussians' supports and the point lights of a scene whose heterogeneous media are
/// all Gaussian sums.
#[derive(Clone, Debug)]
pub struct GaussianSteps {
    centers: Vec<Vec3>,
    radii: Vec<f64>,
    lights: Vec<Vec3>,
    /// The largest homogeneous extinction (scene medium plus backgrounds) of any channel.
    beta0: f64,
    /// The shortest step taken near a light.
    floor: f64,
    bvh: SphereBvh,
}

impl PartialEq for GaussianSteps {
    fn eq(&self, o: &Self) -> bool {
        // The hierarchy is a function of the spheres.
        (&self.centers, &self.radii, &self.lights, self.beta0)
            == (&o.centers, &o.radii, &o.lights, o.beta0)
    }
}

impl GaussianSteps {
    /// The scene's step control; `None` when a heterogeneous medium is not a Gaussian
    /// sum (the march keeps its uniform step) or there are no media at all.
    pub fn new(scene: &Scene) -> Option<GaussianSteps> {
        if scene.hetero.is_empty()
            || scene
                .hetero
                .iter()
                .any(|m| !matches!(m, HeteroMedium::Gaussians(_)))
        {
            return None;
        }
        let (mut centers, mut radii) = (Vec::new(), Vec::new());
        let mut beta0 = scene.medium.sigma_t.iter().fold(0.0f64, |a, &b| a.max(b));
        for g in scene.gaussian_media() {
            beta0 += g.medium.beta0();
            for (i, x) in g.medium.gaussians().iter().enumerate() {
                if g.medium.peak(i).0 > 0.0 {
                    centers.push(x.center);
                    radii.push(x.radius);
                }
            }
        }
        let lights = scene
            .lights
            .iter()
            .filter_map(|l| match l {
                Light::Point { position, .. } => Some(*position),
                Light::Sun { .. } => None,
            })
            .collect();
        let floor = 0.01 * INSIDE * radii.iter().fold(1.0f64, |a, &b| a.min(b));
        let bvh = SphereBvh::new(centers.clone(), radii.iter().map(|r| SUPPORT * r).collect());
        Some(GaussianSteps {
            centers,
            radii,
            lights,
            beta0,
            floor,
            bvh,
        })
    }

    /// The ray's spans `(t_in, t_out, step)` inside the supports it crosses within
    /// `[0, t_end]`, sorted by entry.
    pub fn spans(&self, eye: Vec3, dir: Vec3, t_end: f64) -> Vec<(f64, f64, f64)> {
        let mut out = Vec::new();
        self.bvh.segment(eye, dir, t_end, |i| {
            let b = sub(self.centers[i], eye);
            let m = dot(b, dir);
            let rr = SUPPORT * self.radii[i];
            let h2 = (dot(b, b) - m * m).max(0.0);
            let half = (rr * rr - h2).max(0.0).sqrt();
            let (t0, t1) = ((m - half).max(0.0), (m + half).min(t_end));
            if t1 > t0 {
                out.push((t0, t1, INSIDE * self.radii[i]));
            }
        });
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    /// The step at `x = eye + t·dir` given the ray's `spans` (module docs).
    pub fn step(&self, spans: &[(f64, f64, f64)], t: f64, x: Vec3) -> f64 {
        let mut h = FREE_MAX;
        if self.beta0 > 0.0 {
            h = h.min(HOMOGENEOUS / self.beta0);
        }
        for &s in &self.lights {
            h = h.min((NEAR_LIGHT * norm(sub(s, x))).max(self.floor));
        }
        for &(t0, t1, inside) in spans {
            if t0 > t {
                h = h.min(t0 - t);
                break;
            }
            if t < t1 {
                h = h.min(inside);
            }
        }
        h
    }
}
