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
//!
//! [`shade_over`] composites a second participating medium — smoke, given per pixel as
//! its radiance, transmittance and a representative depth — with the fog, splitting the
//! fog's integral at that depth.

use crate::lod::Fog;
use haze_camera::{Camera, LookAt};
pub use haze_view::render::crm::SmokeSample;
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

/// Distance along unit `dir` from `eye` to the ground `z = 0`, if the ray meets it (the
/// eye above the ground, looking down).
pub fn ground_distance(eye: [f64; 3], dir: [f64; 3]) -> Option<f64> {
    (eye[2] > 0.0 && dir[2] < 0.0).then(|| -eye[2] / dir[2])
}

/// The ground's colour at a point of it.
fn ground_colour(scene: &Scene, p: [f64; 2]) -> [f64; 3] {
    let parity = ((p[0] / scene.checker).floor() + (p[1] / scene.checker).floor()).rem_euclid(2.0);
    scene.ground[usize::from(parity >= 1.0)]
}

/// The sky's colour along unit `dir`.
fn sky_colour(scene: &Scene, dir: [f64; 3]) -> [f64; 3] {
    let e = dir[2].clamp(0.0, 1.0).sqrt();
    [0, 1, 2].map(|c| scene.horizon[c] + (scene.zenith[c] - scene.horizon[c]) * e)
}

/// Radiance of the pixel whose ray leaves `eye` along unit `dir`.
pub fn shade(fog: &Fog, scene: &Scene, eye: [f64; 3], dir: [f64; 3]) -> [f64; 3] {
    let (surface, tau) = match ground_distance(eye, dir) {
        Some(t) => {
            let p = [eye[0] + t * dir[0], eye[1] + t * dir[1], 0.0];
            (
                ground_colour(scene, [p[0], p[1]]),
                (-fog.optical_depth(eye, p)).exp(),
            )
        }
        None => (
            sky_colour(scene, dir),
            (-fog.optical_depth_ray(eye, dir)).exp(),
        ),
    };
    [0, 1, 2].map(|c| tau * surface[c] + (1.0 - tau) * scene.fog[c])
}

/// Radiance of the pixel whose ray leaves `eye` along unit `dir` with a second medium,
/// smoke, composited by depth (its layer `smoke`: radiance `L_s`, transmittance `T_s`,
/// depth `d`, see [`SmokeSample`]).
///
/// Along the ray both media emit and absorb; with the smoke taken as concentrated at its
/// representative depth `d`, the fog in front of `d` attenuates the smoke and everything
/// behind it, and the smoke attenuates the fog behind it and the ground or sky:
///
/// `L = F[0, d] + T_f[0, d]·(L_s + T_s·F[d, P])`,
///
/// with `T_f[a, b] = e^{−∫_a^b K_t}` and, the fog's in-scattered radiance being the
/// constant `L_fog`, `F[a, b] = (1 − T_f[a, b])·L_fog` in front and
/// `F[d, P] = (1 − T_f[d, P])·L_fog + T_f[d, P]·L(P)` with the ground or sky behind.
/// Both fog parts come from [`Fog::optical_depth_span`] with the µ bands of the whole ray,
/// so without smoke (`L_s = 0`, `T_s = 1`) this is [`shade`] for any `d`: splitting the
/// fog at `d` is exact. `d` is clamped to `[0, |OP|]`.
pub fn shade_over(
    fog: &Fog,
    scene: &Scene,
    eye: [f64; 3],
    dir: [f64; 3],
    smoke: &SmokeSample,
) -> [f64; 3] {
    let (surface, len) = match ground_distance(eye, dir) {
        Some(t) => (
            ground_colour(scene, [eye[0] + t * dir[0], eye[1] + t * dir[1]]),
            t,
        ),
        None => (sky_colour(scene, dir), fog.exit_distance(eye, dir)),
    };
    let s = f64::from(smoke.depth).clamp(0.0, len);
    let front = (-fog.optical_depth_span(eye, dir, len, 0.0, s)).exp();
    let back = (-fog.optical_depth_span(eye, dir, len, s, len)).exp();
    let ts = f64::from(smoke.transmittance);
    [0, 1, 2].map(|c| {
        let lf = scene.fog[c];
        let behind = (1.0 - back) * lf + back * surface[c];
        (1.0 - front) * lf + front * (f64::from(smoke.radiance[c]) + ts * behind)
    })
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

/// [`render`] with a smoke layer composited by depth ([`shade_over`]): `smoke` holds one
/// [`SmokeSample`] per pixel of the camera, row 0 on top, computed with the same camera
/// (e.g. `haze_view::render::crm::view_layer` with [`ground_distance`] as the rays' end).
///
/// # Panics
/// If `smoke` does not have one sample per pixel.
pub fn render_over(
    fog: &Fog,
    camera: &Camera,
    scene: &Scene,
    smoke: &[SmokeSample],
    row_done: &(dyn Fn() + Sync),
) -> Vec<[f32; 3]> {
    let (width, height) = (camera.width, camera.height);
    assert_eq!(smoke.len(), width * height, "one smoke sample per pixel");
    let mut pixels = vec![[0.0f32; 3]; width * height];
    pixels
        .par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, px) in row.iter_mut().enumerate() {
                let dir = camera.pixel_ray(x, y);
                let layer = &smoke[y * width + x];
                *px = shade_over(fog, scene, camera.eye, dir, layer).map(|c| c as f32);
            }
            row_done();
        });
    pixels
}
