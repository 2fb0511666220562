//! The surfaces' exact shadow on the sky over the picture, on a grid of pixels (CPU; the
//! CPU's renders and the GPU's take it from here alike).
//!
//! Where a view ray ends on a surface under a sky, the surface receives the sky through
//! the Gaussians' depths towards each direction, `A = Σ_ω p(ω)e^{−T(p,ω)}`, which
//! [`GaussianEnv::surface_sky`] returns relative to paper B's `e^{−T̄(p)}` (1 where its
//! bound holds). That ratio varies on the scale of the Gaussians' shadows, not of a
//! pixel, so it is taken exactly every [`PaperBOptions::sky_stride`] pixels of each row
//! and column (and at the last row and column, [`grid`]) and bilinearly between, where
//! the four grid pixels around a pixel end on the pixel's own surface and the
//! interpolation's estimated error (the integrated pairs' estimate from the grid's
//! second differences, [`axis_error`]), relative to the ratio and times the sky's share
//! of the surface's light at the corners (against the lights'), is at most
//! [`PaperBOptions::target`] — the error the exact shadow itself allows where its bound
//! holds. A pixel whose corners end elsewhere (a silhouette between them) or on no
//! surface, or straddle a shadow's edge that matters to the picture, takes it exactly
//! itself. (A block of floor seen at a grazing angle behind a dense cloud spans its
//! shadow's edge, where a bilinear ratio was up to 60 % off.) A stride of 1 takes every
//! pixel exactly.
//!
//! The table holds each pixel's surface and ratio, or nothing where its ray ends on no
//! surface. It is built once a frame on the CPU: the GPU reads it from a buffer
//! (`crate::gpu::paper_b`), so the two render the same shadow.
//!
//! [`PaperBOptions::sky_stride`]: super::PaperBOptions::sky_stride
//! [`PaperBOptions::target`]: super::PaperBOptions::target

use super::Prepared;
use super::gaussian_env::GaussianEnv;
use super::reuse::{Line, axis_error, bilinear, cell, grid};
use crate::paper_c::airlight::Limits;
use crate::scene::{Hit, Rgb};
use crate::vec3::{Vec3, reflect, scale};
use rayon::prelude::*;

/// A grid pixel's record: its surface, its ratio and the sky's share of the surface's
/// light per channel ([`sky_share`]); `None` where its ray ends on no surface.
type Corner = Option<(usize, Rgb, Rgb)>;

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

/// The table of `prep`'s picture at `stride` (module docs), `lim` the renderer's; `None`
/// where no surface takes the exact shadow: the option off, no environment or no
/// surfaces.
pub fn sky_table(prep: &Prepared<'_>, lim: &Limits, stride: usize) -> Option<SkyTable> {
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
    let corners: Vec<Corner> = (0..nx * gy.len())
        .into_par_iter()
        .map(|k| {
            let (x, y) = (gx[k % nx], gy[k / nx]);
            let h = hit(x, y)?;
            let (s, r) = exact(h);
            Some((s, r, sky_share(prep, env, lim, cam.pixel_ray(x, y), h, r)))
        })
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
                        return corners[ky * nx + kx].map(|(s, r, _)| (s, r));
                    }
                    let hit = hit(x, y)?;
                    let kx1 = (kx + 1).min(nx - 1);
                    let block = Block {
                        grid: &corners,
                        nx,
                        k: (kx, ky),
                        k1: (kx1, ky1),
                    };
                    Some(
                        block
                            .interpolated(bilinear(tx, ty), hit.surface, prep.options.target)
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

/// A block of the grid: its corners `k` to `k1` in the grid's records, `nx` a row.
struct Block<'g> {
    grid: &'g [Corner],
    nx: usize,
    k: (usize, usize),
    k1: (usize, usize),
}

impl Block<'_> {
    /// Grid pixel `(x, y)`'s record where it ends on `surface`.
    fn on(&self, x: isize, y: isize, surface: usize) -> Option<(Rgb, Rgb)> {
        let ny = self.grid.len() / self.nx;
        if x < 0 || y < 0 || x as usize >= self.nx || y as usize >= ny {
            return None;
        }
        match self.grid[y as usize * self.nx + x as usize] {
            Some((s, r, q)) if s == surface => Some((r, q)),
            _ => None,
        }
    }

    /// The corners' ratios weighted bilinearly (`weights` in the order `k`, `(k1.0, k.1)`,
    /// `(k.0, k1.1)`, `k1`), where all four end on `surface` and the interpolation's
    /// estimated error (the integrated pairs' estimate, `reuse::axis_error`, from the
    /// grid's second differences beside the block on the same surface), relative to the
    /// largest corner and times the sky's largest share of their light, is at most
    /// `tolerance`.
    fn interpolated(&self, weights: [f64; 4], surface: usize, tolerance: f64) -> Option<Rgb> {
        let (x0, y0) = (self.k.0 as isize, self.k.1 as isize);
        let (x1, y1) = (self.k1.0 as isize, self.k1.1 as isize);
        let c = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| self.on(x, y, surface));
        let c = [c[0]?, c[1]?, c[2]?, c[3]?];
        let r = |x: isize, y: isize| self.on(x, y, surface).map(|e| e.0);
        let rows: [Line; 2] = [
            (c[0].0, c[1].0, r(x0 - 1, y0), r(x1 + 1, y0)),
            (c[2].0, c[3].0, r(x0 - 1, y1), r(x1 + 1, y1)),
        ];
        let columns: [Line; 2] = [
            (c[0].0, c[2].0, r(x0, y0 - 1), r(x0, y1 + 1)),
            (c[1].0, c[3].0, r(x1, y0 - 1), r(x1, y1 + 1)),
        ];
        let smooth = (0..3).all(|ch| {
            let top = c.iter().map(|e| e.0[ch]).fold(0.0f64, f64::max);
            let share = c.iter().map(|e| e.1[ch]).fold(0.0f64, f64::max);
            let err = axis_error(&rows, ch) + axis_error(&columns, ch);
            // False for NaN: take the pixel's own.
            err == 0.0 || err / top * share <= tolerance
        });
        smooth.then(|| [0, 1, 2].map(|ch| c.iter().zip(weights).map(|(e, w)| w * e.0[ch]).sum()))
    }
}

/// The sky's share of the light the surface point hit by the view ray `dir` sends
/// towards the eye, per channel, with the shadow ratio `ratio`: its environment term
/// ([`GaussianEnv::surface`]) over the whole surface term (the lights' too), within
/// `[0, 1]`; 0 where the surface sends no light.
fn sky_share(
    prep: &Prepared<'_>,
    env: &GaussianEnv,
    lim: &Limits,
    dir: Vec3,
    hit: Hit,
    ratio: Rgb,
) -> Rgb {
    let m = &prep.scene.surfaces[hit.surface].material;
    let r = reflect(scale(dir, -1.0), hit.normal);
    let scattering = prep.options.surface_scattering;
    let sky = env.surface(hit.point, hit.normal, r, m, scattering, ratio);
    let all = prep.surface(lim, dir, hit, Some(ratio));
    [0, 1, 2].map(|c| {
        let q = sky[c] / all[c];
        if all[c] > 0.0 && q.is_finite() {
            q.clamp(0.0, 1.0)
        } else {
            0.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4 × 4 grid on surface 0 whose red ratio is `f(x, y)` and the sky's share `q`; the
    /// block between grid pixels (1, 1) and (2, 2).
    fn block(grid: &mut Vec<Corner>, f: impl Fn(f64, f64) -> f64, q: f64) -> Block<'_> {
        *grid = (0..16)
            .map(|k| Some((0, [f((k % 4) as f64, (k / 4) as f64), 1.0, 1.0], [q; 3])))
            .collect();
        Block {
            grid,
            nx: 4,
            k: (1, 1),
            k1: (2, 2),
        }
    }

    #[test]
    fn a_block_interpolates_where_its_estimated_error_matters_little() {
        let w = [0.25; 4];
        let mut g = Vec::new();
        // A steep ramp interpolates exactly: reused whatever the share.
        let got = block(&mut g, |x, y| 0.2 + 0.1 * x + 0.05 * y, 1.0)
            .interpolated(w, 0, 0.005)
            .unwrap();
        assert!((got[0] - (0.2 + 0.15 + 0.075)).abs() < 1e-15, "{got:?}");
        // A bowl: second difference 0.02 along x, estimated error 0.25 · 0.02 = 0.005 of
        // the largest corner, 0.9025: a sky that is the whole light takes its own, one that
        // is a tenth of it the corners' mean.
        let bowl = |x: f64, _: f64| 0.9 + 0.01 * (x - 1.5) * (x - 1.5);
        assert_eq!(block(&mut g, bowl, 1.0).interpolated(w, 0, 0.005), None);
        assert!(block(&mut g, bowl, 0.1).interpolated(w, 0, 0.005).is_some());
        // A corner on another surface or on none: the pixel's own.
        let b = block(&mut g, |_, _| 0.5, 0.0);
        let mut other = b.grid.to_vec();
        other[5] = Some((1, [0.5; 3], [0.0; 3]));
        let b = Block { grid: &other, ..b };
        assert_eq!(b.interpolated(w, 0, 0.005), None);
        let mut none = other.clone();
        none[5] = None;
        assert_eq!(Block { grid: &none, ..b }.interpolated(w, 0, 0.005), None);
        // A neighbour beyond on another surface is left out of the estimate: the same
        // bowl with its far side elsewhere still sees the near side's curvature.
        let mut cut = Vec::new();
        let b = block(&mut cut, bowl, 1.0);
        let mut cut = b.grid.to_vec();
        cut[3] = None;
        cut[7] = None;
        cut[11] = None;
        cut[15] = None;
        assert_eq!(Block { grid: &cut, ..b }.interpolated(w, 0, 0.005), None);
        // Ratios of 0 (the sky wholly shadowed): nothing to weigh.
        assert!(
            block(&mut g, |_, _| 0.0, 1.0)
                .interpolated(w, 0, 0.005)
                .is_some()
        );
    }
}
