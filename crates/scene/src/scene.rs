//! A scene as the renderers see it, validated: camera, environment, lights, the medium
//! (all homogeneous media summed) and surfaces. [`crate::file`] reads it from JSON.

use crate::Camera;
use crate::media::HeteroMedium;
use crate::media::analytic::AnalyticMedium;
use crate::media::gaussians::GaussianMediumOf;
use crate::mesh::Mesh;
use crate::vec3::{Vec3, dot, sub};
use haze_view::LatLong;
use std::sync::Arc;

pub use haze_core::Rgb;

/// A whole scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub camera: Camera,
    pub environment: Environment,
    /// Where rays that hit no surface end: the environment lies this far from the eye
    /// (the fog in front of it scatters and attenuates); `∞` by default, when a medium
    /// hides the environment entirely.
    pub environment_distance: f64,
    pub lights: Vec<Light>,
    pub medium: Medium,
    /// Media whose extinction varies in space (smoke assets, Gaussians, analytic fog),
    /// adding to `medium` where they overlap.
    pub hetero: Vec<HeteroMedium>,
    pub surfaces: Vec<Surface>,
}

impl Scene {
    /// The scene at time `t` (seconds): every analytic medium carried by its wind.
    pub fn at_time(&self, t: f64) -> Scene {
        let mut s = self.clone();
        for m in &mut s.hetero {
            if let HeteroMedium::Analytic(a) = m {
                *a = Arc::new(a.at(t));
            }
        }
        s
    }

    /// The scene's analytic media (paper D).
    pub fn analytic_media(&self) -> impl Iterator<Item = &AnalyticMedium> {
        self.hetero.iter().filter_map(|m| match m {
            HeteroMedium::Analytic(a) => Some(&**a),
            _ => None,
        })
    }

    /// The scene's Gaussian media (paper B).
    pub fn gaussian_media(&self) -> impl Iterator<Item = &GaussianMediumOf> {
        self.hetero.iter().filter_map(|m| match m {
            HeteroMedium::Gaussians(g) => Some(&**g),
            _ => None,
        })
    }
}

/// Radiance seen where rays leave the scene: the scene file's `"environment"`, distant
/// radiance only (the scene's suns and point lights are its [`Light`]s; not
/// `haze_view::Environment`, which lights a smoke asset and carries its own lights).
#[derive(Clone, Debug, PartialEq)]
pub enum Environment {
    /// `null`: black.
    Black,
    /// `"sky"`: the built-in sky of `haze render` (same colours; see [`Environment::radiance`]).
    Sky,
    /// `[r, g, b]`: the same radiance in every direction.
    Constant(Rgb),
    /// `"ENV.exr"`: a lat-long map (crates/view's convention, looked up bilinearly).
    Map(Arc<LatLong>),
}

impl Environment {
    /// Radiance arriving from the unit direction `d` (pointing away from the scene). The
    /// sky blends horizon `(0.8, 0.85, 0.9)` to zenith `(0.25, 0.45, 0.9)` with `cos θ`
    /// above the horizon plus a glow `(4, 3.6, 3)·max(0, d·s)⁸` around
    /// `s ∝ (0.5, 0.3, 0.8)`, and ground `(0.25, 0.22, 0.2)` below, which the glow does not
    /// reach — the sky of crates/view.
    pub fn radiance(&self, d: Vec3) -> Rgb {
        match self {
            Environment::Black => [0.0; 3],
            Environment::Constant(c) => *c,
            Environment::Map(m) => m.radiance(d),
            Environment::Sky => {
                let (zenith, horizon, ground) =
                    ([0.25, 0.45, 0.9], [0.8, 0.85, 0.9], [0.25, 0.22, 0.2]);
                // Below the horizon the ground, which the glow does not reach.
                if d[2] < 0.0 {
                    return ground;
                }
                let mut out: Rgb = [0, 1, 2].map(|c| horizon[c] * (1.0 - d[2]) + zenith[c] * d[2]);
                let n = (0.25f64 + 0.09 + 0.64).sqrt();
                let c = (dot(d, [0.5 / n, 0.3 / n, 0.8 / n])).max(0.0);
                let glow = c.powi(8);
                for (o, s) in out.iter_mut().zip([4.0, 3.6, 3.0]) {
                    *o += s * glow;
                }
                out
            }
        }
    }
}

/// A light.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// An isotropic point light of radiant intensity `intensity` (irradiance `I/d²`
    /// unoccluded, in vacuum).
    Point { position: Vec3, intensity: Rgb },
    /// A distant disk: unit `direction` towards it, the `radiance` of the disk, its
    /// apparent diameter `angle` in radians (0: a point-like sun whose `radiance` is its
    /// irradiance).
    Sun {
        direction: Vec3,
        radiance: Rgb,
        angle: f64,
    },
}

impl Light {
    /// A sun's irradiance (normal to its direction): radiance × the disk's solid angle
    /// `2π(1 − cos(angle/2))`, or the radiance itself for a point-like sun.
    pub fn sun_irradiance(radiance: Rgb, angle: f64) -> Rgb {
        if angle <= 0.0 {
            radiance
        } else {
            let omega = 2.0 * std::f64::consts::PI * (1.0 - (0.5 * angle).cos());
            radiance.map(|r| r * omega)
        }
    }
}

/// The homogeneous medium filling space: the sum of the scene's homogeneous media,
/// isotropic (paper C). Per channel: extinction `σt` and albedo `σs/σt`.
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    pub sigma_t: Rgb,
    pub albedo: Rgb,
}

impl Medium {
    pub const NONE: Medium = Medium {
        sigma_t: [0.0; 3],
        albedo: [0.0; 3],
    };

    /// `σs = albedo·σt` per channel.
    pub fn sigma_s(&self) -> Rgb {
        [0, 1, 2].map(|c| self.albedo[c] * self.sigma_t[c])
    }
}

/// Lambert + normalized Phong: `f = diffuse/π + specular·(n + 2)/(2π)·cosⁿα/cos θᵢ`,
/// `α` the angle between the light and the mirror direction of the view (paper C §4's
/// Phong lobe, which carries no `cos θᵢ`).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub diffuse: Rgb,
    pub specular: Rgb,
    pub shininess: f64,
}

impl Material {
    /// Whether the material has a specular lobe.
    pub fn is_specular(&self) -> bool {
        self.specular.iter().any(|&s| s > 0.0)
    }

    /// `f·cos θᵢ` of channel `c` for light arriving from unit `l` at a point of unit
    /// normal `n`, `r` the mirror direction of the view: `diffuse/π·cos θᵢ +
    /// specular·(n + 2)/(2π)·max(0, r·l)ⁿ`; zero for light from behind the surface.
    pub fn brdf(&self, n: Vec3, r: Vec3, l: Vec3, c: usize) -> f64 {
        let cos = dot(n, l);
        if cos <= 0.0 {
            return 0.0;
        }
        let mut f = self.diffuse[c] / std::f64::consts::PI * cos;
        if self.specular[c] > 0.0 {
            f += self.specular[c] * (self.shininess + 2.0) / (2.0 * std::f64::consts::PI)
                * dot(r, l).max(0.0).powf(self.shininess);
        }
        f
    }
}

/// A surface's shape.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// The plane through `point` with unit `normal` (both sides are lit; the normal is
    /// turned towards the viewer).
    Plane {
        point: Vec3,
        normal: Vec3,
    },
    Sphere {
        center: Vec3,
        radius: f64,
    },
    /// Triangles in world space with their hierarchy (both sides lit, like the plane).
    Mesh(Arc<Mesh>),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    pub shape: Shape,
    pub material: Material,
}

/// Where a ray meets a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub point: Vec3,
    /// Unit normal, on the side the ray came from.
    pub normal: Vec3,
    pub surface: usize,
}

impl Shape {
    /// The nearest `t ∈ (t_min, t_max)` where the ray `o + t·d` (unit `d`) meets the
    /// shape, with the unit normal there (outward for a sphere; a plane's or a triangle's
    /// on either side, turned by the caller).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<(f64, Vec3)> {
        match self {
            &Shape::Plane { point, normal } => {
                let den = dot(d, normal);
                if den == 0.0 {
                    return None;
                }
                let t = dot(sub(point, o), normal) / den;
                (t > t_min && t < t_max).then_some((t, normal))
            }
            &Shape::Sphere { center, radius } => {
                // |o + t·d − c|² = r², written to avoid cancellation: b = d·(c − o),
                // the discriminant from the distance of c to the line.
                let oc = sub(center, o);
                let b = dot(d, oc);
                let perp = sub(oc, crate::vec3::scale(d, b));
                let disc = radius * radius - dot(perp, perp);
                if disc < 0.0 {
                    return None;
                }
                let s = disc.sqrt();
                let (t0, t1) = (b - s, b + s);
                let t = if t0 > t_min && t0 < t_max {
                    t0
                } else if t1 > t_min && t1 < t_max {
                    t1
                } else {
                    return None;
                };
                let p = crate::vec3::axpy(o, t, d);
                let n = crate::vec3::normalize(sub(p, center)).unwrap_or([0.0, 0.0, 1.0]);
                Some((t, n))
            }
            Shape::Mesh(mesh) => {
                let h = mesh.intersect(o, d, t_min, t_max)?;
                let tri = &mesh.triangles[h.triangle];
                // The shading normal, on the side of the face the ray arrives at.
                let mut n = tri.normal(h.u, h.v);
                let face = tri.face_normal().unwrap_or(n);
                if dot(face, d) * dot(n, d) < 0.0 {
                    n = crate::vec3::scale(n, -1.0);
                }
                Some((h.t, n))
            }
        }
    }
}

impl Scene {
    /// The nearest surface along `o + t·d` with `t ∈ (t_min, t_max)`.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f64, t_max: f64) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for (i, s) in self.surfaces.iter().enumerate() {
            let hi = best.map_or(t_max, |b| b.t);
            if let Some((t, mut normal)) = s.shape.intersect(o, d, t_min, hi) {
                let point = crate::vec3::axpy(o, t, d);
                if dot(normal, d) > 0.0 {
                    normal = crate::vec3::scale(normal, -1.0);
                }
                best = Some(Hit {
                    t,
                    point,
                    normal,
                    surface: i,
                });
            }
        }
        best
    }

    /// Whether the segment from `p` to `q` is free of surfaces (the ends excluded by a
    /// small relative margin, so a point does not shadow itself).
    pub fn visible(&self, p: Vec3, q: Vec3) -> bool {
        let d = sub(q, p);
        let len = crate::vec3::norm(d);
        if len <= 0.0 {
            return true;
        }
        let dir = crate::vec3::scale(d, 1.0 / len);
        let eps = 1e-7 * (1.0 + len);
        !self
            .surfaces
            .iter()
            .any(|s| s.shape.intersect(p, dir, eps, len - eps).is_some())
    }
}
