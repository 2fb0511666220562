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
use haze_camera::{Camera, LookAt};
use rayon::prelude::*;

/// A view that frames a fog from above the ground: from beyond the middle of the south
/// edge, above the layer, looking north over the fog to the horizon (which crosses the
/// upper part of the image at the default 50° field of view), Z up.
pub fn framing(fog: &Fog) -> LookAt {
    let [x0, x1, y0, y1] = fog.map_box();
    let p = fog.placement();
    let size = (x1 - x0).max(y1 - y0);
    let cx = (x0 + x1) / 2.0;
    LookAt {
        eye: [cx, y0 - 0.2 * size, p.top.max(0.0) + 0.2 * size],
        target: [cx, y0 + 0.6 * size, p.bottom.max(0.0)],
        up: [0.0, 0.0, 1.0],
        fov_deg: 50.0,
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

/// Renders the camera's `width × height` pixels, row 0 on top, linear RGB; `row_done` is
/// called once per finished row (from worker threads).
pub fn render(
    fog: &Fog,
    camera: &Camera,
    scene: &Scene,
    row_done: &(dyn Fn() + Sync),
) -> Vec<[f32; 3]> {
    let (width, height) = (camera.width, camera.height);
    let mut pixels = vec![[0.0f32; 3]; width * height];
    pixels
        .par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let dir = camera.pixel_ray(x, y);
                *px = shade(fog, scene, camera.eye, dir).map(|c| c as f32);
            }
            row_done();
        });
    pixels
}
