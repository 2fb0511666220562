//! The density as a continuous field for rendering: trilinear interpolation between voxel
//! centers (`bbox_min + (i + ½)·voxel`), constant to the box's faces, zero outside; and
//! ray–box clipping.

use haze_volume::{Bbox, Volume};

/// Density at world point `p` (0 outside the box): trilinear between voxel centers,
/// constant to the faces. [`Sampler`] is the same with the grid's constants taken once.
pub fn sample(v: &Volume, p: [f64; 3]) -> f64 {
    Sampler::new(v).at(p)
}

/// [`sample`] of one grid, its constants (box, voxel size, strides) taken once: the
/// marches of the lighting sample it at every step. The stencil is unrolled; a corner of
/// zero weight is skipped (a NaN there stays out).
#[derive(Clone, Copy, Debug)]
pub struct Sampler<'a> {
    data: &'a [f32],
    min: [f64; 3],
    max: [f64; 3],
    /// `1/voxel` per axis.
    inv_voxel: [f64; 3],
    dims: [usize; 3],
    stride: [usize; 3],
    empty: bool,
}

impl<'a> Sampler<'a> {
    pub fn new(v: &'a Volume) -> Sampler<'a> {
        let d = v.dims();
        let b = v.bbox();
        Sampler {
            data: v.data(),
            min: b.min,
            max: b.max,
            inv_voxel: v.voxel_size().map(|s| 1.0 / s),
            dims: d,
            stride: [1, d[0], d[0] * d[1]],
            empty: d.contains(&0),
        }
    }

    /// The density at world point `p` ([`sample`]).
    #[inline]
    pub fn at(&self, p: [f64; 3]) -> f64 {
        self.coords(p).map_or(0.0, |q| self.at_coords(q))
    }

    /// `p`'s voxel coordinates `(p − min)·(1/voxel)` (voxel `k`'s center at `k + ½`), `None`
    /// outside the box or for an empty grid (where the density is 0).
    #[inline]
    pub fn coords(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        if self.empty || (0..3).any(|a| !(p[a] >= self.min[a] && p[a] <= self.max[a])) {
            return None;
        }
        Some(std::array::from_fn(|a| {
            (p[a] - self.min[a]) * self.inv_voxel[a]
        }))
    }

    /// The samples of the line `u + t·s` in steps of `h` ([`Line`]).
    pub fn line(&self, u: [f64; 3], s: [f64; 3], h: f64) -> Line<'a> {
        let d = self.dims;
        Line {
            data: self.data,
            q0: std::array::from_fn(|a| (u[a] - self.min[a]) * self.inv_voxel[a]),
            dq: std::array::from_fn(|a| h * s[a] * self.inv_voxel[a]),
            dims: d.map(|n| n as f64),
            top: d.map(|n| n.saturating_sub(1) as f64),
            last_lower: d.map(|n| n.saturating_sub(2)),
            stride: self.stride,
            step: std::array::from_fn(|a| if d[a] > 1 { self.stride[a] } else { 0 }),
            empty: self.empty,
        }
    }

    /// The density at voxel coordinates `q` from [`Sampler::coords`].
    #[inline]
    pub fn at_coords(&self, q: [f64; 3]) -> f64 {
        self.stencil(q).sum(self.data)
    }

    /// The trilinear stencil at voxel coordinates `q` from [`Sampler::coords`]: the eight
    /// corners' offsets in the grid's data and their weights, for [`Stencil::sum`] over
    /// this grid's density or over any other grid of the same dimensions.
    #[inline]
    pub fn stencil(&self, q: [f64; 3]) -> Stencil {
        let d = self.dims;
        // Per axis: the offsets (in the data) of the lower and upper corner, and the weights.
        let mut off = [[0usize; 2]; 3];
        let mut w = [[0.0f64; 2]; 3];
        for a in 0..3 {
            // Clamped to ≥ 0, so the cast is the floor.
            let f = (q[a] - 0.5).clamp(0.0, (d[a] - 1) as f64);
            let i = (f as usize).min(d[a].saturating_sub(2));
            let t = f - i as f64;
            off[a] = [i * self.stride[a], (i + 1).min(d[a] - 1) * self.stride[a]];
            w[a] = [1.0 - t, t];
        }
        Stencil { off, w }
    }
}

/// The density along one line `u + t·s` sampled in steps of `h`
/// ([`Sampler::line`]): [`Sampler::at`] of the point `u + (k + ½)h·s` for step `k`, its
/// voxel coordinates stepped from the line's start instead of computed from the point
/// (the same to rounding) and the trilinear stencil taken as seven linear interpolations.
/// For the shadow marches, which sample it at every step. Unlike [`Stencil::sum`] a NaN
/// voxel reaches a sample even at zero weight (imports refuse NaN densities).
#[derive(Clone, Copy, Debug)]
pub struct Line<'a> {
    data: &'a [f32],
    /// Voxel coordinates of the line's start `u`, and their change per step `h·s`: step
    /// `k`'s sample is at `q₀ + (k + ½)·Δq`.
    q0: [f64; 3],
    dq: [f64; 3],
    /// Per axis: the voxel count, the last voxel's index, the last lower corner's.
    dims: [f64; 3],
    top: [f64; 3],
    last_lower: [usize; 3],
    stride: [usize; 3],
    /// The upper corner's offset from the lower one (0 on an axis of one voxel).
    step: [usize; 3],
    empty: bool,
}

impl Line<'_> {
    /// Voxel coordinates of step `k`'s sample, `None` outside the box (density 0).
    #[inline(always)]
    pub fn coords(&self, k: u64) -> Option<[f64; 3]> {
        let t = k as f64 + 0.5;
        let q: [f64; 3] = std::array::from_fn(|a| self.q0[a] + t * self.dq[a]);
        (!self.empty && (0..3).all(|a| q[a] >= 0.0 && q[a] <= self.dims[a])).then_some(q)
    }

    /// The trilinear density at voxel coordinates `q` from [`Line::coords`].
    #[inline(always)]
    pub fn at_coords(&self, q: [f64; 3]) -> f64 {
        let (mut base, mut w) = (0, [0.0f64; 3]);
        for a in 0..3 {
            // Clamped to ≥ 0, so the cast is the floor.
            let f = (q[a] - 0.5).clamp(0.0, self.top[a]);
            let i = (f as usize).min(self.last_lower[a]);
            w[a] = f - i as f64;
            base += i * self.stride[a];
        }
        let [sx, sy, sz] = self.step;
        let d = |o: usize| f64::from(self.data[o]);
        let lerp = |lo: f64, hi: f64, t: f64| lo + t * (hi - lo);
        let row = |o: usize| lerp(d(o), d(o + sx), w[0]);
        let plane = |o: usize| lerp(row(o), row(o + sy), w[1]);
        lerp(plane(base), plane(base + sz), w[2])
    }
}

/// The trilinear stencil of one point ([`Sampler::stencil`]): per axis the offsets in the
/// data (x fastest) of the lower and upper corner and their weights `1 − t`, `t`.
#[derive(Clone, Copy, Debug)]
pub struct Stencil {
    off: [[usize; 2]; 3],
    w: [[f64; 2]; 3],
}

impl Stencil {
    /// The eight corners, `corner = x + 2y + 4z` (0: lower, 1: upper on each axis): each
    /// one's offset in the data and its weight `w_x·w_y·w_z`.
    #[inline]
    pub fn corners(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        (0..8).map(|corner| {
            let (x, y, z) = (corner & 1, corner >> 1 & 1, corner >> 2);
            (
                self.off[0][x] + self.off[1][y] + self.off[2][z],
                1.0 * self.w[0][x] * self.w[1][y] * self.w[2][z],
            )
        })
    }

    /// `Σ w_k·data_k` over the corners, a corner of zero weight skipped (a NaN there
    /// stays out).
    #[inline]
    pub fn sum(&self, data: &[f32]) -> f64 {
        let mut s = 0.0;
        for (offset, weight) in self.corners() {
            if weight != 0.0 {
                s += weight * f64::from(data[offset]);
            }
        }
        s
    }
}

/// Parameters `t0 ≤ t1` (with `t0 ≥ 0`) where the ray `o + t·d` is inside the box, if it
/// meets it. Rays parallel to a face are handled (no division by zero).
pub fn ray_box(o: [f64; 3], d: [f64; 3], b: &Bbox) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < b.min[a] || o[a] > b.max[a] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let (mut ta, mut tb) = ((b.min[a] - o[a]) * inv, (b.max[a] - o[a]) * inv);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
    }
    (t0 <= t1 && t1.is_finite()).then_some((t0, t1))
}

/// Largest density of a volume (0 for an empty one).
pub fn max_density(v: &Volume) -> f64 {
    v.data().iter().fold(0.0f64, |m, d| m.max(f64::from(*d)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Volume {
        // 4×3×2, density = x + 10 y + 100 z at voxel (x, y, z), voxel size 1.
        let dims = [4, 3, 2];
        let data = (0..24)
            .map(|i| {
                let (x, y, z) = (i % 4, (i / 4) % 3, i / 12);
                (x + 10 * y + 100 * z) as f32
            })
            .collect();
        Volume::new(dims, Bbox::new([0.0; 3], [4.0, 3.0, 2.0]), data).unwrap()
    }

    #[test]
    fn trilinear_is_exact_on_a_linear_field_and_clamped_to_the_faces() {
        let v = ramp();
        // Linear field: value = (x−½) + 10 (y−½) + 100 (z−½) between the centers.
        for p in [
            [0.5, 0.5, 0.5],
            [1.7, 2.2, 1.1],
            [3.5, 2.5, 1.5],
            [2.0, 1.0, 0.9],
        ] {
            let want = (p[0] - 0.5) + 10.0 * (p[1] - 0.5) + 100.0 * (p[2] - 0.5);
            assert!((sample(&v, p) - want).abs() < 1e-9, "{p:?}");
        }
        assert_eq!(sample(&v, [0.1, 0.5, 0.5]), 0.0, "constant to the face");
        assert_eq!(sample(&v, [4.0, 3.0, 2.0]), 3.0 + 20.0 + 100.0);
        assert_eq!(sample(&v, [4.01, 1.0, 1.0]), 0.0);
        assert_eq!(sample(&v, [f64::NAN, 1.0, 1.0]), 0.0);
    }

    #[test]
    fn one_voxel_axes_and_a_nan_at_zero_weight() {
        // An axis of one voxel is constant along it; a NaN voxel whose weight is zero
        // stays out of the sum, one with weight reaches it.
        let b = Bbox::new([0.0; 3], [2.0, 1.0, 1.0]);
        let v = Volume::new([2, 1, 1], b, vec![3.0, f32::NAN]).unwrap();
        assert_eq!(sample(&v, [0.5, 0.2, 0.9]), 3.0);
        assert_eq!(sample(&v, [0.1, 0.5, 0.5]), 3.0);
        assert!(sample(&v, [1.0, 0.5, 0.5]).is_nan());
        let w = Volume::new([1, 1, 1], Bbox::new([0.0; 3], [1.0; 3]), vec![2.5]).unwrap();
        for p in [[0.0; 3], [0.3, 0.9, 1.0], [1.0; 3]] {
            assert_eq!(sample(&w, p), 2.5, "{p:?}");
        }
    }

    #[test]
    fn a_lines_samples_are_the_samplers_points() {
        // Random lines through and past random grids (axes of one and two voxels among
        // them, steps of every size, axis-parallel directions): each step's density equals
        // the sampler's at the point u + (k + ½)h·s, to rounding, zero outside the box.
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        for case in 0..60 {
            let dims = [0, 1, 2].map(|_| [1, 2, 3, 7][rng.random_range(0..4)]);
            let n = dims.iter().product::<usize>();
            let data = (0..n).map(|_| rng.random_range(-0.5..4.0f32)).collect();
            let min = [0, 1, 2].map(|_| rng.random_range(-3.0..3.0));
            let max = std::array::from_fn(|a| min[a] + rng.random_range(0.2..5.0));
            let v = Volume::new(dims, Bbox::new(min, max), data).unwrap();
            let sampler = Sampler::new(&v);
            let u = std::array::from_fn(|a| rng.random_range(min[a] - 1.0..max[a] + 1.0));
            let mut s: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0));
            if case % 5 == 0 {
                s = [0.0, 0.0, 0.0];
                s[case % 3] = if case % 2 == 0 { 1.0 } else { -1.0 };
            }
            let h = rng.random_range(0.01..0.7);
            let line = sampler.line(u, s, h);
            for k in 0..40u64 {
                let t = (k as f64 + 0.5) * h;
                let want = sampler.at([0, 1, 2].map(|a| u[a] + t * s[a]));
                let got = line.coords(k).map_or(0.0, |q| line.at_coords(q));
                assert!(
                    (got - want).abs() <= 1e-12 * (1.0 + want.abs()),
                    "case {case}, step {k}: {got} against {want}"
                );
            }
        }
    }

    #[test]
    fn a_line_at_its_extremes() {
        // A zero step samples the start at every step; a NaN or infinite start or
        // direction, and a step past f64's range, give no sample (density 0) rather
        // than a NaN; an empty grid none at all.
        let v = ramp();
        let sampler = Sampler::new(&v);
        let u = [1.7, 2.2, 1.1];
        let still = sampler.line(u, [0.6, 0.0, 0.8], 0.0);
        for k in [0, 1, 1000] {
            let (got, want) = (still.coords(k).map(|q| still.at_coords(q)), sampler.at(u));
            assert!(
                got.is_some_and(|g| (g - want).abs() <= 1e-12 * want.abs()),
                "step {k}: {got:?} against {want}"
            );
        }
        for (u, s, h) in [
            ([f64::NAN, 1.0, 1.0], [1.0, 0.0, 0.0], 0.1),
            (u, [f64::NAN, 0.0, 1.0], 0.1),
            (u, [f64::INFINITY, 0.0, 0.0], 0.1),
            ([f64::NEG_INFINITY, 1.0, 1.0], [1.0, 0.0, 0.0], 0.1),
            (u, [1.0, 0.0, 0.0], f64::MAX),
        ] {
            let line = sampler.line(u, s, h);
            for k in [0, 1, 7, u64::MAX] {
                assert_eq!(line.coords(k), None, "{u:?} {s:?} {h} step {k}");
            }
        }
        let empty = Volume::zeros([0, 3, 2], Bbox::new([0.0; 3], [1.0; 3])).unwrap();
        let line = Sampler::new(&empty).line([0.5; 3], [1.0, 0.0, 0.0], 0.1);
        assert_eq!(line.coords(0), None);
    }

    #[test]
    fn ray_box_clips_including_axis_parallel_rays() {
        let b = Bbox::new([0.0; 3], [1.0; 3]);
        assert_eq!(
            ray_box([-1.0, 0.5, 0.5], [1.0, 0.0, 0.0], &b),
            Some((1.0, 2.0))
        );
        assert_eq!(ray_box([-1.0, 1.5, 0.5], [1.0, 0.0, 0.0], &b), None);
        assert_eq!(
            ray_box([0.5, 0.5, 0.5], [0.0, 0.0, 1.0], &b),
            Some((0.0, 0.5))
        );
        assert_eq!(
            ray_box([2.0, 0.5, 0.5], [1.0, 0.0, 0.0], &b),
            None,
            "behind"
        );
    }
}
