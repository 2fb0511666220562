//! A simple outdoor scene seen through a wavelet fog, on the CPU (paper E §3.1, §4.3).
//!
//! The scene is a ground plane `z = 0` (a two-tone checker, so distance and fog read
//! well) under a sky gradient. Each pixel casts one ray through its centre from a pinhole
//! camera (`fov` vertical, row 0 at the top); `P` is where it meets the ground, or, for a
//! sky ray, where it leaves the fog. With the fog's in-scattered light taken constant
//! (`L_fog`, the paper's eq. 3–4),
//!
//! `L(O) = τ(O, P)·L(P) + (1 − τ(O, P))·L_fog`, `τ = e^{−∫_O^P K_t}`.
//!
//! [`shade`] is the whole per-pixel computation — one ray, one call to the fog's
//! integrator, one blend — with no allocation, so a fragment shader can mirror it; rows
//! are shaded in parallel with rayon.

use crate::lod::Fog;
use rayon::prelude::*;

/// A pinhole camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: [f64; 3],
    /// Point looked at.
    pub target: [f64; 3],
    /// Up direction (need not be orthogonal to the view direction).
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub fov_deg: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| a.map(|c| c / n))
}

/// The camera's orthonormal frame: right, true up, forward.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Eye position.
    pub eye: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    forward: [f64; 3],
    tan_half: f64,
}

impl Camera {
    /// The camera's frame, or why it has none.
    pub fn frame(&self) -> Result<Frame, String> {
        if !self
            .eye
            .iter()
            .chain(&self.target)
            .chain(&self.up)
            .all(|v| v.is_finite())
        {
            return Err("camera eye, target and up must be finite".to_string());
        }
        let forward = normalize(sub(self.target, self.eye))
            .ok_or_else(|| "camera eye and target coincide".to_string())?;
        let right = normalize(cross(forward, self.up))
            .ok_or_else(|| "camera up is parallel to the view direction".to_string())?;
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(format!(
                "field of view {}° must be in (0, 180)",
                self.fov_deg
            ));
        }
        Ok(Frame {
            eye: self.eye,
            right,
            up: cross(right, forward),
            forward,
            tan_half: (self.fov_deg.to_radians() / 2.0).tan(),
        })
    }

    /// A camera that frames a fog from above the ground: from beyond the middle of the
    /// south edge, above the layer, looking north over the fog to the horizon (which
    /// crosses the upper part of the image at the default 50° field of view).
    pub fn framing(fog: &Fog) -> Camera {
        let [x0, x1, y0, y1] = fog.map_box();
        let p = fog.placement();
        let size = (x1 - x0).max(y1 - y0);
        let cx = (x0 + x1) / 2.0;
        Camera {
            eye: [cx, y0 - 0.2 * size, p.top.max(0.0) + 0.2 * size],
            target: [cx, y0 + 0.6 * size, p.bottom.max(0.0)],
            up: [0.0, 0.0, 1.0],
            fov_deg: 50.0,
        }
    }
}

impl Frame {
    /// Unit direction through pixel `(x, y)`'s centre of a `w × h` image (row 0 on top).
    pub fn ray(&self, x: usize, y: usize, w: usize, h: usize) -> [f64; 3] {
        let aspect = w as f64 / h as f64;
        let sx = ((x as f64 + 0.5) / w as f64 * 2.0 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - (y as f64 + 0.5) / h as f64 * 2.0) * self.tan_half;
        let d = [
            self.forward[0] + sx * self.right[0] + sy * self.up[0],
            self.forward[1] + sx * self.right[1] + sy * self.up[1],
            self.forward[2] + sx * self.right[2] + sy * self.up[2],
        ];
        normalize(d).unwrap_or(self.forward)
    }
}

/// Colours of the scene (linear RGB radiance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scene {
    /// Sky straight up.
    pub zenith: [f64; 3],
    /// Sky at the horizon.
    pub horizon: [f64; 3],
    /// Ground, two checker tones.
    pub ground: [[f64; 3]; 2],
    /// Checker square size in world units.
    pub checker: f64,
    /// `L_fog`, the fog's constant in-scattered radiance.
    pub fog: [f64; 3],
}

impl Default for Scene {
    fn default() -> Scene {
        Scene {
            zenith: [0.18, 0.32, 0.65],
            horizon: [0.62, 0.72, 0.85],
            ground: [[0.16, 0.22, 0.09], [0.12, 0.17, 0.07]],
            checker: 8.0,
            fog: [0.80, 0.82, 0.85],
        }
    }
}

/// Radiance of the pixel whose ray leaves `eye` along unit `dir`.
pub fn shade(fog: &Fog, scene: &Scene, eye: [f64; 3], dir: [f64; 3]) -> [f64; 3] {
    let (surface, tau) = if eye[2] > 0.0 && dir[2] < 0.0 {
        let t = -eye[2] / dir[2];
        let p = [eye[0] + t * dir[0], eye[1] + t * dir[1], 0.0];
        let parity =
            ((p[0] / scene.checker).floor() + (p[1] / scene.checker).floor()).rem_euclid(2.0);
        let colour = scene.ground[usize::from(parity >= 1.0)];
        (colour, (-fog.optical_depth(eye, p)).exp())
    } else {
        let e = dir[2].clamp(0.0, 1.0).sqrt();
        let sky = [0, 1, 2].map(|c| scene.horizon[c] + (scene.zenith[c] - scene.horizon[c]) * e);
        (sky, (-fog.optical_depth_ray(eye, dir)).exp())
    };
    [0, 1, 2].map(|c| tau * surface[c] + (1.0 - tau) * scene.fog[c])
}

/// Renders `width × height` pixels, row 0 on top, linear RGB; `row_done` is called once
/// per finished row (from worker threads).
pub fn render(
    fog: &Fog,
    camera: &Frame,
    scene: &Scene,
    width: usize,
    height: usize,
    row_done: &(dyn Fn() + Sync),
) -> Vec<[f32; 3]> {
    let mut pixels = vec![[0.0f32; 3]; width * height];
    pixels
        .par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let dir = camera.ray(x, y, width, height);
                *px = shade(fog, scene, camera.eye, dir).map(|c| c as f32);
            }
            row_done();
        });
    pixels
}
