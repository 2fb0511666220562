//! Paper B §6, "Creating inhomogeneous media": the editing tools of a Gaussian medium, as
//! a library the viewer drives (`haze view --scene`) and tests script.
//!
//! Every tool works on a [`Draft`] of the medium's Gaussians (what the stroke has done so
//! far, shown live) which becomes one undoable [`Edit`] when the stroke ends;
//! [`Document`] keeps the Gaussians and the command history (undo/redo).
//!
//! - [`paintbrush`]: Gaussians every `0.75/a` (by default) along a stroke projected onto a
//!   plane or the surface under the cursor, jittered perpendicular to the stroke;
//! - [`airbrush`]: particles sprayed along the cursor ray, bouncing off the surfaces and
//!   diffusing, frozen into Gaussians when the stroke ends;
//! - [`eraser`]: lowers the weight of the Gaussians under the brush, deleting those that
//!   reach zero;
//! - [`emitter`]: particles on parabolic paths whose Gaussians grow and fade with age;
//! - [`clipboard`]: copy, cut and paste of the Gaussians whose centres project inside a
//!   screen rectangle;
//! - [`file`](mod@file): the edited medium written back into the scene file (temp file + rename)
//!   and read from one.
//!
//! Random choices come from a seeded stream ([`haze_gaussians::cloud::Uniform`]), so a
//! scripted stroke gives the same Gaussians every time.

pub mod airbrush;
pub mod clipboard;
pub mod emitter;
pub mod eraser;
pub mod file;
pub mod history;
pub mod paintbrush;

pub use history::{Document, Draft, Edit};

use crate::Camera;
use crate::scene::Scene;
use crate::vec3::{Vec3, dot, normalize, scale, sub};
use haze_gaussians::cloud::Uniform;

/// Where a screen point lands in the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// The plane through `point` with unit `normal`.
    Plane { point: Vec3, normal: Vec3 },
    /// The first surface the cursor's ray meets.
    Surface,
}

impl Target {
    /// The point where the ray through image point `(px, py)` meets the target and the
    /// unit normal there, turned towards the eye; `None` when it meets none in front.
    pub fn hit(&self, scene: &Scene, camera: &Camera, px: f64, py: f64) -> Option<(Vec3, Vec3)> {
        let eye = camera.eye;
        let d = camera.ray(px, py);
        match *self {
            Target::Plane { point, normal } => {
                let den = dot(d, normal);
                if den == 0.0 || !den.is_finite() {
                    return None;
                }
                let t = dot(sub(point, eye), normal) / den;
                let n = if den > 0.0 {
                    scale(normal, -1.0)
                } else {
                    normal
                };
                (t > 0.0 && t.is_finite()).then(|| ([0, 1, 2].map(|a| eye[a] + t * d[a]), n))
            }
            Target::Surface => scene
                .intersect(eye, d, 0.0, f64::INFINITY)
                .map(|h| (h.point, h.normal)),
        }
    }
}

/// A plane through `point` with normal `normal` (normalized), or an error naming it.
pub fn plane(point: Vec3, normal: Vec3) -> Result<Target, String> {
    let normal = normalize(normal).ok_or_else(|| format!("plane normal {normal:?} is zero"))?;
    if !point.iter().chain(&normal).all(|x| x.is_finite()) {
        return Err("the plane must be finite".into());
    }
    Ok(Target::Plane { point, normal })
}

/// A standard normal deviate from two uniforms (Box–Muller; `1 − u` keeps the log finite).
pub(crate) fn normal_deviate(u: &mut Uniform) -> f64 {
    let (a, b) = (1.0 - u.sample(), u.sample());
    (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
}
