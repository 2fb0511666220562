//! A picture whose smooth parts take every other pixel from their neighbours.
//!
//! The view pass marches a ray per pixel, yet where a voxel spans several pixels (a
//! 96-voxel plume across 500 pixels: five) the picture between two pixels two apart is
//! their mean to well within a grey level. [`reused`] computes the *coarse* pixels, those
//! of even column and even row, then every other pixel from the coarse pixels around it —
//! the mean of the two beside it (odd column, even row: left and right; even column, odd
//! row: above and below) or of the four at its corners (odd column and row) — where the
//! coarse grid says that mean is within `tol` of the picture, and computes it otherwise.
//!
//! **The test.** The mean of `f(x − 1)` and `f(x + 1)` differs from `f(x)` by
//! `f''(ξ)/2` (pixels as unit lengths), and the coarse grid's second difference
//! `Δ² = f(x − 2) − 2 f(x) + f(x + 2)` at a coarse pixel is `4 f''` to first order, so the
//! mean is within `|Δ²|/8` where the second derivative is about what the two coarse
//! pixels' differences say. A pixel between two coarse pixels takes their mean where, in
//! every channel, the larger of the two coarse pixels' second differences along that
//! axis, divided by 8, is at most `tol · s`; the four corners' mean (within
//! `(|f_xx| + |f_yy|)/2`) where the largest along `x` plus the largest along `y`, over
//! 8, is. The scale `s` is the corners' mean in that channel, or `FLOOR` times the
//! brightest coarse value where that is larger (dark pixels are held to a share of the
//! picture's light, not of their own). A coarse pixel without a coarse neighbour on both
//! sides along an axis (the first and last coarse column or row) has no second difference
//! there: the pixels that need it are computed, as are the last column and row where the
//! picture's size is even.
//!
//! What the test cannot see is a feature narrower than the coarse grid's spacing that
//! leaves no trace at the coarse pixels (a wisp one pixel wide between them). The view
//! pass's density is trilinear over voxels, so that takes voxels smaller than two pixels,
//! where nearly every pixel then fails the test and is computed. Edges the scene draws
//! sharp — the horizon, a surface's silhouette, a point light's image — make large second
//! differences and are computed. Measured against computing every pixel in
//! BENCHMARKS.md ("Viewer playback").

use rayon::prelude::*;

/// Below this share of the brightest coarse value, a pixel's scale is that share
/// (module docs).
pub const FLOOR: f64 = 0.02;

/// How many pixels [`reused`] computed and how many it took from their neighbours.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReuseCount {
    /// Pixels computed: the coarse grid's and those whose test failed.
    pub computed: usize,
    /// Pixels taken as their coarse neighbours' mean.
    pub reused: usize,
}

/// The `width × height` picture (row 0 on top) whose pixel `i = x + width·y` is
/// `pixel(i)`, its pixels between coarse ones taken as their mean where the module's
/// test allows it at tolerance `tol` (relative, ≥ 0; 0 computes every pixel whose
/// neighbourhood is not exactly flat).
pub fn reused<F>(width: usize, height: usize, tol: f64, pixel: F) -> (Vec<[f32; 3]>, ReuseCount)
where
    F: Fn(usize) -> [f64; 3] + Sync,
{
    let (cw, ch) = (width.div_ceil(2), height.div_ceil(2));
    let coarse: Vec<[f64; 3]> = (0..cw * ch)
        .into_par_iter()
        .map(|k| pixel(2 * (k % cw) + 2 * (k / cw) * width))
        .collect();
    let brightest = coarse
        .iter()
        .flatten()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let floor = FLOOR * brightest;
    let at = |cx: usize, cy: usize| coarse[cx + cw * cy];
    // |Δ²| per channel at each coarse pixel along x and along y (NaN where a neighbour
    // is missing, which fails every test).
    let second = |along_x: bool| -> Vec<[f64; 3]> {
        (0..cw * ch)
            .into_par_iter()
            .map(|k| {
                let (cx, cy) = (k % cw, k / cw);
                let (n, i) = if along_x { (cw, cx) } else { (ch, cy) };
                if i == 0 || i + 1 >= n {
                    return [f64::NAN; 3];
                }
                let (a, b) = if along_x {
                    (at(cx - 1, cy), at(cx + 1, cy))
                } else {
                    (at(cx, cy - 1), at(cx, cy + 1))
                };
                let m = at(cx, cy);
                [0, 1, 2].map(|c| (a[c] - 2.0 * m[c] + b[c]).abs())
            })
            .collect()
    };
    let (dxx, dyy) = (second(true), second(false));
    let tol = tol.max(0.0);
    // The corners' mean where its bound `curvature/8` is within `tol · s` in every
    // channel (`curvature` per channel from the corners' second differences).
    let mean_if = |corners: &[usize], curvature: &dyn Fn(usize) -> f64| -> Option<[f64; 3]> {
        let n = corners.len() as f64;
        let mean = [0, 1, 2].map(|c| corners.iter().map(|&k| coarse[k][c]).sum::<f64>() / n);
        (0..3)
            .all(|c| curvature(c) / 8.0 <= tol * mean[c].max(floor))
            .then_some(mean)
    };
    let mut count = ReuseCount::default();
    let pixels: Vec<([f32; 3], bool)> = (0..width * height)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let (cx, cy) = (x / 2, y / 2);
            let k = |cx: usize, cy: usize| cx + cw * cy;
            let got = match (x % 2, y % 2) {
                (0, 0) => return (at(cx, cy).map(|v| v as f32), false),
                (1, 0) if cx + 1 < cw => {
                    let (a, b) = (k(cx, cy), k(cx + 1, cy));
                    mean_if(&[a, b], &|c| worst(dxx[a][c], dxx[b][c]))
                }
                (0, 1) if cy + 1 < ch => {
                    let (a, b) = (k(cx, cy), k(cx, cy + 1));
                    mean_if(&[a, b], &|c| worst(dyy[a][c], dyy[b][c]))
                }
                (1, 1) if cx + 1 < cw && cy + 1 < ch => {
                    let q = [k(cx, cy), k(cx + 1, cy), k(cx, cy + 1), k(cx + 1, cy + 1)];
                    mean_if(&q, &|c| {
                        q.iter().map(|&j| dxx[j][c]).fold(0.0, worst)
                            + q.iter().map(|&j| dyy[j][c]).fold(0.0, worst)
                    })
                }
                _ => None,
            };
            match got {
                Some(v) => (v.map(|v| v as f32), true),
                None => (pixel(i).map(|v| v as f32), false),
            }
        })
        .collect();
    count.reused = pixels.iter().filter(|p| p.1).count();
    count.computed = width * height - count.reused;
    (pixels.into_iter().map(|p| p.0).collect(), count)
}

/// The larger of `a` and `b`, NaN if either is (a missing second difference fails).
fn worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

#[cfg(test)]
mod tests {
    use super::{FLOOR, reused};

    /// The picture `f` at pixel `i` of a `w`-wide picture, as `[f64; 3]`.
    fn picture(w: usize, f: impl Fn(f64, f64) -> f64 + Sync) -> impl Fn(usize) -> [f64; 3] + Sync {
        move |i| {
            let v = f((i % w) as f64, (i / w) as f64);
            [v, 0.5 * v, 0.25 * v + 0.1]
        }
    }

    /// A smooth picture (a Gaussian 40 pixels wide on a ramp): every pixel within the
    /// bound the test promises for a second derivative it measures, `tol` of the corners'
    /// mean plus rounding (the Gaussian's third derivative moves `f''` by under a percent
    /// between the coarse pixels, so the bound holds with that margin), and most pixels
    /// reused.
    #[test]
    fn a_smooth_picture_is_within_the_tolerance() {
        let (w, h) = (96, 71);
        let f = |x: f64, y: f64| {
            let r2 = (x - 40.3).powi(2) + (y - 33.7).powi(2);
            2.0 * (-r2 / (2.0 * 40.0f64.powi(2))).exp() + 0.001 * x
        };
        let exact = picture(w, f);
        for tol in [1e-4, 2e-3, 1e-2] {
            let (got, count) = reused(w, h, tol, &exact);
            assert_eq!(count.computed + count.reused, w * h);
            // At 10⁻⁴ the Gaussian's curvature (|Δ²|/8 ≈ 6·10⁻⁴ of its peak) fails
            // most tests: few pixels reused, every one still within the bound.
            assert!(
                tol < 1e-3 || count.reused > w * h / 2,
                "tol {tol}: {count:?}"
            );
            for (i, p) in got.iter().enumerate() {
                let want = exact(i);
                for c in 0..3 {
                    let err = (f64::from(p[c]) - want[c]).abs();
                    assert!(
                        err <= 1.02 * tol * want[c] + 1e-6 * want[c],
                        "tol {tol}, pixel {i} ch {c}: {} vs {}",
                        p[c],
                        want[c]
                    );
                }
            }
        }
    }

    /// A step across the picture: the pixels beside it are computed, so the picture
    /// equals the exact one everywhere (to `f32`), however loose the tolerance; a ramp
    /// (no second difference) is reused at tolerance 0, exactly its mean.
    #[test]
    fn edges_are_computed_and_ramps_reused() {
        let (w, h) = (33, 20);
        let step = picture(w, |x, y| if 0.7 * x + 0.3 * y < 14.2 { 1.0 } else { 3.0 });
        let (got, count) = reused(w, h, 0.1, &step);
        assert!(count.reused > 0);
        for (i, p) in got.iter().enumerate() {
            assert_eq!(*p, step(i).map(|v| v as f32), "pixel {i}");
        }
        let ramp = picture(w, |x, y| 0.25 * x + 0.5 * y + 1.0);
        let (got, count) = reused(w, h, 0.0, &ramp);
        // Every pixel but the coarse ones' outer ring, whose second differences are
        // missing, and the last column (33 is odd: its pixels are coarse or between).
        assert!(count.reused > w * h / 2, "{count:?}");
        for (i, p) in got.iter().enumerate() {
            assert_eq!(*p, ramp(i).map(|v| v as f32), "pixel {i}");
        }
    }

    /// Dark pixels are held to `FLOOR` of the brightest coarse value, not to their own:
    /// a faint ripple beside a bright spot is reused within `tol · FLOOR · peak`.
    #[test]
    fn dark_pixels_are_held_to_a_share_of_the_picture() {
        let (w, h) = (64, 32);
        let f = |x: f64, y: f64| {
            let spot = 10.0 * (-((x - 56.0).powi(2) + (y - 16.0).powi(2)) / 8.0).exp();
            spot + 1e-4 * (1.0 + (x / 7.0).sin())
        };
        let exact = picture(w, f);
        let tol = 1e-2;
        let (got, _) = reused(w, h, tol, &exact);
        let peak = (0..w * h).map(|i| exact(i)[0]).fold(0.0, f64::max);
        for (i, p) in got.iter().enumerate() {
            let want = exact(i);
            let err = (f64::from(p[0]) - want[0]).abs();
            assert!(
                err <= 1.02 * tol * want[0].max(FLOOR * peak) + 1e-6 * want[0],
                "pixel {i}"
            );
        }
    }

    /// Extremes: pictures of one pixel and 2 × 2 (no pixel between coarse ones with
    /// second differences on both sides: every pixel computed), one row and one column (a
    /// ramp's pixels between coarse ones reused, exactly); a NaN pixel among the coarse
    /// ones fails the tests around it rather than spreading; a negative tolerance is 0.
    #[test]
    fn extremes_compute_what_they_cannot_reuse() {
        for (w, h) in [(1, 1), (2, 2), (7, 1), (1, 9)] {
            let f = picture(w, |x, y| 1.0 + x + 2.0 * y);
            let (got, count) = reused(w, h, 0.5, &f);
            assert_eq!(count.computed + count.reused, w * h);
            if w * h <= 4 {
                assert_eq!(count.computed, w * h, "{w} × {h}");
            }
            for (i, p) in got.iter().enumerate() {
                assert_eq!(*p, f(i).map(|v| v as f32), "{w} × {h}, pixel {i}");
            }
        }
        let (w, h) = (21, 15);
        let f = picture(w, |x, y| if (x, y) == (10.0, 6.0) { f64::NAN } else { 2.0 });
        let (got, _) = reused(w, h, 0.5, &f);
        let nan: Vec<usize> = (0..w * h).filter(|&i| got[i][0].is_nan()).collect();
        assert_eq!(nan, vec![10 + 6 * w]);
        let ramp = picture(w, |x, _| x * x);
        let (a, _) = reused(w, h, -1.0, &ramp);
        let (b, _) = reused(w, h, 0.0, &ramp);
        assert_eq!(a, b);
    }
}
