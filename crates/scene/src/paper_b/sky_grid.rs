//! The surfaces' exact shadow on the sky over the picture, on a grid of pixels (CPU; the
//! CPU's renders and the GPU's take it from here alike).
//!
//! Where a view ray ends on a surface under a sky, the surface receives the sky through
//! the Gaussians' depths towards each direction, `A = Σ_ω p(ω)e^{−T(p,ω)}`, which
//! [`GaussianEnv::surface_sky`] returns relative to paper B's `e^{−T̄(p)}` (1 where its
//! bound holds). That ratio varies on the scale of the Gaussians' shadows, not of a
//! pixel, so it is taken exactly every [`PaperBOptions::sky_stride`] pixels of each row
//! and column (and at the last row and column, [`grid`]) and bilinearly between, where
//! the four grid pixels around a pixel end on the pixel's own surface; a pixel whose
//! corners end elsewhere (a silhouette between them) or on no surface takes it exactly
//! itself. A stride of 1 takes every pixel exactly. (Where a block of floor seen at a
//! grazing angle spans a shadow's edge the bilinear value can be far off; the cloud in
//! front dims those pixels: BENCHMARKS.md measures the pictures.)
//!
//! The table holds each pixel's surface and ratio, or nothing where its ray ends on no
//! surface. It is built once a frame on the CPU: the GPU reads it from a buffer
//! (`crate::gpu::paper_b`), so the two render the same shadow.
//!
//! [`PaperBOptions::sky_stride`]: super::PaperBOptions::sky_stride

use super::Prepared;
use super::reuse::{cell, grid};
use crate::scene::{Hit, Rgb};
use rayon::prelude::*;

/// Each pixel's surface and its shadow on the sky relative to `e^{−T̄}` (module docs),
/// `width` pixels a row.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyTable {
    pub width: usize,
    pub pixels: Vec<Option<(usize, Rgb)>>,
}

impl SkyTable {
    /// Pixel `(x, y)`'s ratio, where its ray ends on `surface`; `None` elsewhere.
    pub fn at(&self, x: usize, y: usize, surface: usize) -> Option<Rgb> {
        match self.pixels[y * self.width + x] {
            Some((s, r)) if s == surface => Some(r),
            _ => None,
        }
    }
}

/// The table of `prep`'s picture at `stride` (module docs); `None` where no surface takes
/// the exact shadow: the option off, no environment or no surfaces.
pub fn sky_table(prep: &Prepared<'_>, stride: usize) -> Option<SkyTable> {
    let env = prep.env.as_ref()?;
    let scene = prep.scene;
    if !prep.options.surface_sky || scene.surfaces.is_empty() {
        return None;
    }
    let cam = &scene.camera;
    let (w, h) = (cam.width, cam.height);
    let hit = |x: usize, y: usize| {
        scene.intersect(
            cam.eye,
            cam.pixel_ray(x, y),
            0.0,
            scene.environment_distance,
        )
    };
    let exact = |hit: Hit| {
        let r = env.surface_sky(scene, &prep.set, hit.point, hit.normal, prep.options.target);
        (hit.surface, r)
    };
    let (gx, gy) = (grid(w, stride), grid(h, stride));
    let nx = gx.len();
    let corners: Vec<Option<(usize, Rgb)>> = (0..nx * gy.len())
        .into_par_iter()
        .map(|k| hit(gx[k % nx], gy[k / nx]).map(exact))
        .collect();
    let rows: Vec<Vec<Option<(usize, Rgb)>>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let (ky, ty) = cell(&gy, y);
            let ky1 = (ky + 1).min(gy.len() - 1);
            (0..w)
                .map(|x| {
                    let (kx, tx) = cell(&gx, x);
                    if tx == 0.0 && ty == 0.0 {
                        return corners[ky * nx + kx];
                    }
                    let hit = hit(x, y)?;
                    let kx1 = (kx + 1).min(nx - 1);
                    let around = [(kx, ky), (kx1, ky), (kx, ky1), (kx1, ky1)]
                        .map(|(i, j)| corners[j * nx + i]);
                    let weights = [
                        (1.0 - tx) * (1.0 - ty),
                        tx * (1.0 - ty),
                        (1.0 - tx) * ty,
                        tx * ty,
                    ];
                    Some(
                        interpolated(&around, weights, hit.surface)
                            .map_or_else(|| exact(hit), |r| (hit.surface, r)),
                    )
                })
                .collect()
        })
        .collect();
    Some(SkyTable {
        width: w,
        pixels: rows.into_iter().flatten().collect(),
    })
}

/// The corners' ratios weighted bilinearly, where all four end on `surface`.
fn interpolated(
    around: &[Option<(usize, Rgb)>; 4],
    weights: [f64; 4],
    surface: usize,
) -> Option<Rgb> {
    let mut sum = [0.0; 3];
    for (corner, w) in around.iter().zip(weights) {
        let (s, r) = (*corner)?;
        if s != surface {
            return None;
        }
        for c in 0..3 {
            sum[c] += w * r[c];
        }
    }
    Some(sum)
}
