//! Exact optical depth along a ray through the density field, and free-flight sampling by
//! its inversion.
//!
//! [`field::sample`] interpolates trilinearly between voxel centers and is constant from
//! the outermost centers to the faces. Between two consecutive planes of voxel centers on
//! every axis, the field restricted to a ray `o + t·d` is a product of three factors, each
//! affine or constant in `t`: a polynomial of degree ≤ 3. Splitting the ray at every
//! crossing of a center plane, two-point Gauss–Legendre quadrature, exact for cubics, gives
//! `τ(a, b) = ∫ₐᵇ σt·D(o + t·d) dt` exactly up to rounding: no step size, no variance.
//! Inverting `τ(t₀, t) = τ*` for `τ* ~ Exp(1)` (bisection inside the piece where it is
//! reached, again with exact quadrature) samples the distance to the next collision with
//! density `σt·D(t)·exp(−τ(t₀, t))`, the free-flight distribution — what delta tracking
//! samples, without a majorant and at a cost independent of σt.

use haze_volume::Volume;

use crate::field;

/// Extinction coefficients are clamped here so that optical depths stay finite (an
/// extinction of 1e250 per world unit is opaque over any representable distance).
const KAPPA_MAX: f64 = 1e250;

/// A ray through a volume with an extinction cross-section: `κt(t) = σt·D(o + t·d)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Track<'a> {
    volume: &'a Volume,
    /// The volume's sampler, its constants taken once per ray.
    field: field::Sampler<'a>,
    pub sigma_t: f64,
    o: [f64; 3],
    d: [f64; 3],
}

/// `(1 ∓ 1/√3)/2`: the two Gauss–Legendre nodes on [0, 1].
const GL_LO: f64 = 0.211_324_865_405_187_1;
const GL_HI: f64 = 0.788_675_134_594_812_9;

/// `t0 < t1`, false for NaN.
fn ordered(t0: f64, t1: f64) -> bool {
    t0 < t1
}

impl<'a> Track<'a> {
    /// The ray `o + t·d` through `volume` of extinction cross-section `sigma_t`.
    pub fn new(volume: &'a Volume, sigma_t: f64, o: [f64; 3], d: [f64; 3]) -> Track<'a> {
        Track {
            volume,
            field: field::Sampler::new(volume),
            sigma_t,
            o,
            d,
        }
    }

    fn point(&self, t: f64) -> [f64; 3] {
        [0, 1, 2].map(|a| self.o[a] + t * self.d[a])
    }

    /// `κt` at parameter `t`.
    pub fn kappa(&self, t: f64) -> f64 {
        (self.sigma_t * self.field.at(self.point(t))).min(KAPPA_MAX)
    }

    /// `∫ₐᵇ κt dt` for `[a, b]` inside one polynomial piece (exact: Gauss–Legendre, 2 nodes).
    fn piece_depth(&self, a: f64, b: f64) -> f64 {
        let h = b - a;
        if h <= 0.0 || self.sigma_t == 0.0 {
            return 0.0;
        }
        0.5 * h * (self.kappa(a + GL_LO * h) + self.kappa(a + GL_HI * h))
    }

    /// `t0`, every crossing of a plane of voxel centers strictly between, and `t1`, in
    /// ascending order: the pieces on which the density is one cubic in `t`.
    fn breaks(&self, t0: f64, t1: f64) -> Breaks {
        let v = self.volume;
        let (dims, bbox, vs) = (v.dims(), v.bbox(), v.voxel_size());
        let axes = std::array::from_fn(|a| {
            if self.d[a] == 0.0 || dims[a] == 0 {
                return None;
            }
            // Continuous voxel coordinate: center i at f = i.
            let f = |t: f64| (self.o[a] + t * self.d[a] - bbox.min[a]) / vs[a] - 0.5;
            let (fa, fb) = (f(t0), f(t1));
            let (lo, hi) = (fa.min(fb), fa.max(fb));
            let first = (lo.floor() + 1.0).max(0.0);
            let last = (hi.ceil() - 1.0).min(dims[a] as f64 - 1.0);
            if first > last {
                return None;
            }
            // The centers' planes in the order the ray meets them.
            let (from, to) = (first as i64, last as i64);
            let step = if self.d[a] > 0.0 { 1 } else { -1 };
            let start = if step > 0 { from } else { to };
            Some(Crossings {
                next: start,
                left: (to - from + 1) as u64,
                step,
                min: bbox.min[a],
                voxel: vs[a],
                o: self.o[a],
                d: self.d[a],
            })
        });
        Breaks {
            axes,
            t0,
            t1,
            started: false,
            done: false,
        }
    }

    /// The consecutive pairs of [`Track::breaks`].
    fn pieces(&self, t0: f64, t1: f64) -> impl Iterator<Item = (f64, f64)> {
        let mut breaks = self.breaks(t0, t1);
        let mut a = breaks.next();
        std::iter::from_fn(move || {
            let b = breaks.next()?;
            let piece = (a?, b);
            a = Some(b);
            Some(piece)
        })
    }

    /// Optical depth `τ(t0, t1)` (`t0 ≤ t1`), exact up to rounding.
    pub fn depth(&self, t0: f64, t1: f64) -> f64 {
        if self.sigma_t == 0.0 || !ordered(t0, t1) {
            return 0.0;
        }
        self.pieces(t0, t1)
            .map(|(a, b)| self.piece_depth(a, b))
            .sum()
    }

    /// The `t ∈ [t0, t1]` where the optical depth from `t0` reaches `tau ≥ 0`, or `None`
    /// if `τ(t0, t1) < tau` (the ray leaves the interval first).
    pub fn reach(&self, t0: f64, t1: f64, tau: f64) -> Option<f64> {
        if self.sigma_t == 0.0 || !ordered(t0, t1) || tau.is_nan() || tau < 0.0 {
            return None;
        }
        let mut left = tau;
        for (a, b) in self.pieces(t0, t1) {
            let piece = self.piece_depth(a, b);
            if piece < left {
                left -= piece;
                continue;
            }
            // τ(a, ·) is continuous and non-decreasing on [a, b]: bisect to 1e-14 of the
            // piece (about 47 halvings), far below any length the image can resolve.
            let (mut lo, mut hi) = (a, b);
            let resolution = 1e-14 * (b - a);
            while hi - lo > resolution {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if self.piece_depth(a, mid) < left {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return Some(hi);
        }
        None
    }
}

/// The crossings of one axis's planes of voxel centers by a ray, in the order it meets
/// them: `t = (min + (i + ½)·voxel − o)/d` for `i` from `next` by `step`, `left` more.
#[derive(Clone, Copy, Debug)]
struct Crossings {
    next: i64,
    left: u64,
    step: i64,
    min: f64,
    voxel: f64,
    o: f64,
    d: f64,
}

impl Crossings {
    /// The next crossing's `t`, if any is left.
    fn peek(&self) -> Option<f64> {
        (self.left > 0).then(|| {
            let c = self.min + (self.next as f64 + 0.5) * self.voxel;
            (c - self.o) / self.d
        })
    }

    fn advance(&mut self) {
        self.next += self.step;
        self.left -= 1;
    }
}

/// [`Track::breaks`]: `t0`, the three axes' crossings strictly between `t0` and `t1`
/// merged in ascending order (each axis's already is), then `t1`. Crossings that rounding
/// puts outside `(t0, t1)` are left out, as are NaNs.
#[derive(Clone, Copy, Debug)]
struct Breaks {
    axes: [Option<Crossings>; 3],
    t0: f64,
    t1: f64,
    started: bool,
    done: bool,
}

impl Iterator for Breaks {
    type Item = f64;

    fn next(&mut self) -> Option<f64> {
        if !self.started {
            self.started = true;
            return Some(self.t0);
        }
        if self.done {
            return None;
        }
        loop {
            // The axis whose next crossing comes first (`total_cmp`, as a sort would).
            let mut best: Option<(usize, f64)> = None;
            for (a, axis) in self.axes.iter().enumerate() {
                if let Some(t) = axis.as_ref().and_then(Crossings::peek)
                    && best.is_none_or(|(_, b)| t.total_cmp(&b).is_lt())
                {
                    best = Some((a, t));
                }
            }
            let Some((a, t)) = best else {
                self.done = true;
                return Some(self.t1);
            };
            if let Some(axis) = self.axes[a].as_mut() {
                axis.advance();
            }
            if t > self.t0 && t < self.t1 {
                return Some(t);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::Bbox;

    /// D = x·y·z at the voxel centers of a 7×5×6 grid over [0,7]×[0,5]×[0,6]; trilinear
    /// interpolation reproduces this multilinear field exactly between the outer centers.
    fn product() -> Volume {
        let dims = [7, 5, 6];
        let data = (0..7 * 5 * 6)
            .map(|i| {
                let (x, y, z) = (i % 7, (i / 7) % 5, i / 35);
                ((x as f64 + 0.5) * (y as f64 + 0.5) * (z as f64 + 0.5)) as f32
            })
            .collect();
        Volume::new(dims, Bbox::new([0.0; 3], [7.0, 5.0, 6.0]), data).unwrap()
    }

    #[test]
    fn optical_depth_is_exact_for_a_cubic_along_an_oblique_ray() {
        let v = product();
        let o = [0.6, 0.7, 0.8];
        let n = (5.7f64 * 5.7 + 3.6 * 3.6 + 4.4 * 4.4).sqrt();
        let d = [5.7 / n, 3.6 / n, 4.4 / n];
        let track = Track::new(&v, 0.3, o, d);
        // ∫₀ᴸ Π(oₐ + t dₐ) dt expanded: the ray stays within the hull of the centers.
        let (a, b, c) = (o, d, n);
        let poly = |t: f64| {
            let c0 = a[0] * a[1] * a[2];
            let c1 = b[0] * a[1] * a[2] + a[0] * b[1] * a[2] + a[0] * a[1] * b[2];
            let c2 = a[0] * b[1] * b[2] + b[0] * a[1] * b[2] + b[0] * b[1] * a[2];
            let c3 = b[0] * b[1] * b[2];
            c0 * t + c1 * t * t / 2.0 + c2 * t.powi(3) / 3.0 + c3 * t.powi(4) / 4.0
        };
        let want = 0.3 * poly(c);
        let got = track.depth(0.0, c);
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        // Inversion lands where the depth is reached.
        for frac in [0.0, 1e-9, 0.3, 0.77, 1.0] {
            let t = track.reach(0.0, c, frac * want).unwrap();
            let back = track.depth(0.0, t);
            assert!((back - frac * want).abs() < 1e-10 * want, "{frac}: {back}");
        }
        assert_eq!(track.reach(0.0, c, want * 1.000_001), None);
    }

    #[test]
    fn optical_depth_matches_a_fine_march_through_faces_and_clamped_borders() {
        // Irregular data, a ray that enters and leaves through the half-voxel borders
        // where the field is clamped; reference: midpoint rule with 2·10⁵ steps (error
        // O(h²) of the piecewise-smooth integrand, about 1e-8 here).
        let v = product();
        let data: Vec<f32> = v
            .data()
            .iter()
            .enumerate()
            .map(|(i, x)| x * (1.0 + (i as f32 * 0.37).sin()))
            .collect();
        let v = Volume::new(v.dims(), *v.bbox(), data).unwrap();
        let (o, d): ([f64; 3], [f64; 3]) = ([-1.0, 2.6, 0.1], [0.8, -0.1, 0.59]);
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let d = d.map(|c: f64| c / n);
        let (t0, t1) = field::ray_box(o, d, v.bbox()).unwrap();
        let track = Track::new(&v, 1.0, o, d);
        let steps = 200_000;
        let h = (t1 - t0) / steps as f64;
        let march: f64 = (0..steps)
            .map(|i| track.kappa(t0 + (i as f64 + 0.5) * h) * h)
            .sum();
        let got = track.depth(t0, t1);
        assert!((got - march).abs() < 1e-7 * march, "{got} vs {march}");
    }

    #[test]
    fn zero_extinction_empty_volumes_and_huge_extinction_are_finite() {
        let v = product();
        let mut t = Track::new(&v, 0.0, [0.5; 3], [0.0, 0.0, 1.0]);
        assert_eq!(t.depth(0.0, 5.0), 0.0);
        assert_eq!(t.reach(0.0, 5.0, 0.0), None);
        t.sigma_t = f64::MAX;
        let huge = t.depth(0.0, 5.0);
        assert!(huge.is_finite() && huge > 1e249);
        // The collision is 3e-250 away, found to the bisection's resolution (1e-14 of the
        // unit-long piece).
        let hit = t.reach(0.0, 5.0, 3.0).unwrap();
        assert!((0.0..2e-14).contains(&hit), "{hit}");
        let empty = Volume::new([0, 0, 0], Bbox::new([0.0; 3], [1.0; 3]), vec![]).unwrap();
        let e = Track::new(&empty, 5.0, [0.5; 3], [1.0, 0.0, 0.0]);
        assert_eq!(e.depth(0.0, 0.5), 0.0);
        assert_eq!(e.reach(0.0, 0.5, 1e-3), None);
    }

    /// The merged breaks are every plane crossing strictly inside `(t0, t1)`, found by
    /// trying every plane of every axis, sorted: rays along and against the axes, oblique,
    /// parallel to a plane, from outside the box and from inside.
    #[test]
    fn breaks_are_every_crossing_in_order() {
        let v = product();
        let (dims, bbox, vs) = (v.dims(), v.bbox(), v.voxel_size());
        let rays = [
            ([0.6, 0.7, 0.8], [0.7f64, 0.5, 0.51]),
            ([6.9, 4.3, 5.5], [-0.3, -0.8, -0.52]),
            ([-1.0, 2.5, 3.0], [1.0, 0.0, 0.0]),
            ([3.5, 9.0, 3.0], [0.0, -1.0, 0.0]),
            ([2.0, 2.0, -3.0], [0.1, -0.2, 0.97]),
        ];
        for (o, d) in rays {
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let d = d.map(|x| x / n);
            let track = Track::new(&v, 1.0, o, d);
            for (t0, t1) in [(0.0, 3.0), (0.5, 12.0), (2.25, 2.5), (4.0, 4.0)] {
                let mut want = vec![t0];
                for a in 0..3 {
                    for i in 0..dims[a] {
                        let t = (bbox.min[a] + (i as f64 + 0.5) * vs[a] - o[a]) / d[a];
                        if t > t0 && t < t1 {
                            want.push(t);
                        }
                    }
                }
                want.push(t1);
                want.sort_by(f64::total_cmp);
                let got: Vec<f64> = track.breaks(t0, t1).collect();
                assert_eq!(got, want, "ray {o:?} {d:?} over [{t0}, {t1}]");
                let pieces: Vec<(f64, f64)> = track.pieces(t0, t1).collect();
                assert_eq!(pieces.len(), want.len() - 1);
                assert!(
                    pieces
                        .iter()
                        .zip(want.windows(2))
                        .all(|(p, w)| *p == (w[0], w[1]))
                );
            }
        }
    }
}
