//! Extinction stored on a voxel grid — a smoke asset's density resampled once (paper A's
//! `D = D̃ + R`) — as a continuous field: `σt(x) = scale·ρ(x)` with `ρ` the trilinear
//! interpolation of the voxel values between voxel centers (`min + (i + ½)·voxel`),
//! constant from the outermost centers to the box's faces, zero outside the box (the
//! convention of `haze_view::field::sample`).
//!
//! **Optical depth, exact.** Between two consecutive planes through voxel centers (of any
//! axis) a ray stays in one trilinear cell, where `ρ(o + t·d)` is a product of three
//! polynomials of degree ≤ 1 in `t` — a cubic — and Simpson's rule integrates cubics
//! exactly. [`VoxelGrid::optical_depth`] walks those planes along the clipped segment
//! (a 3D DDA, Amanatides–Woo) and sums Simpson's rule per piece, so the only error is
//! rounding.

use super::Aabb;
use crate::vec3::{Vec3, axpy};
use haze_core::Rgb;

/// Extinction on a grid of voxels (x fastest).
#[derive(Clone, Debug, PartialEq)]
pub struct VoxelGrid {
    pub dims: [usize; 3],
    /// The box's low corner (world).
    pub min: Vec3,
    /// A voxel's edge lengths (world, positive).
    pub voxel: Vec3,
    /// The grid values `ρ` (≥ 0), `dims[0]·dims[1]·dims[2]` of them.
    pub data: Vec<f32>,
    /// `σt = scale·ρ` per channel.
    pub scale: Rgb,
}

impl VoxelGrid {
    /// The box `[min, min + dims·voxel]`.
    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.min,
            max: [0, 1, 2].map(|a| self.min[a] + self.dims[a] as f64 * self.voxel[a]),
        }
    }

    fn value(&self, i: [usize; 3]) -> f64 {
        f64::from(self.data[i[0] + self.dims[0] * (i[1] + self.dims[1] * i[2])])
    }

    /// `ρ` at continuous voxel coordinates `u` (voxel `i`'s center at `u = i`), clamped
    /// to `[0, dims − 1]`: the field anywhere in the box.
    fn at_index(&self, u: [f64; 3]) -> f64 {
        let mut i0 = [0usize; 3];
        let mut f = [0.0f64; 3];
        for a in 0..3 {
            let n = self.dims[a];
            let x = u[a].clamp(0.0, (n - 1) as f64);
            let i = (x.floor() as usize).min(n.saturating_sub(2));
            i0[a] = i;
            f[a] = x - i as f64;
        }
        let mut s = 0.0;
        for corner in 0..8 {
            let mut w = 1.0;
            let mut idx = [0usize; 3];
            for a in 0..3 {
                let hi = corner >> a & 1 == 1;
                idx[a] = (i0[a] + usize::from(hi)).min(self.dims[a] - 1);
                w *= if hi { f[a] } else { 1.0 - f[a] };
            }
            if w != 0.0 {
                s += w * self.value(idx);
            }
        }
        s
    }

    /// The trilinear cell holding continuous voxel coordinates `u` (its lowest voxel, as
    /// [`VoxelGrid::at_index`] picks it) and its eight voxel values, corner `k` at offset
    /// `(k & 1, k >> 1 & 1, k >> 2 & 1)` (clamped to the grid).
    fn cell_at(&self, u: [f64; 3]) -> ([usize; 3], [f64; 8]) {
        // Written out axis by axis (no closures over `[0, 1, 2]`, no `floor`: the clamped
        // coordinate is ≥ 0, so truncation is the floor) for the shadow rays' inner loop.
        let low = |a: usize| {
            let n = self.dims[a];
            let x = u[a].clamp(0.0, (n - 1) as f64);
            (x as usize).min(n.saturating_sub(2))
        };
        let i0 = [low(0), low(1), low(2)];
        let (nx, ny) = (self.dims[0], self.dims[1]);
        let x1 = (i0[0] + 1).min(nx - 1) - i0[0];
        let y1 = ((i0[1] + 1).min(ny - 1) - i0[1]) * nx;
        let z1 = ((i0[2] + 1).min(self.dims[2] - 1) - i0[2]) * nx * ny;
        let base = i0[0] + nx * (i0[1] + ny * i0[2]);
        let v = |o: usize| f64::from(self.data[base + o]);
        let corners = [
            v(0),
            v(x1),
            v(y1),
            v(x1 + y1),
            v(z1),
            v(x1 + z1),
            v(y1 + z1),
            v(x1 + y1 + z1),
        ];
        (i0, corners)
    }

    /// The trilinear interpolation of `corners` (of the cell at `i0`, from
    /// [`VoxelGrid::cell_at`]) at `u` (clamped to the grid, as [`VoxelGrid::at_index`]).
    fn trilinear(&self, i0: [usize; 3], c: &[f64; 8], u: [f64; 3]) -> f64 {
        let f = |a: usize| u[a].clamp(0.0, (self.dims[a] - 1) as f64) - i0[a] as f64;
        let (fx, fy, fz) = (f(0), f(1), f(2));
        let x00 = c[0] + fx * (c[1] - c[0]);
        let x10 = c[2] + fx * (c[3] - c[2]);
        let x01 = c[4] + fx * (c[5] - c[4]);
        let x11 = c[6] + fx * (c[7] - c[6]);
        let y0 = x00 + fy * (x10 - x00);
        let y1 = x01 + fy * (x11 - x01);
        y0 + fz * (y1 - y0)
    }

    /// Continuous voxel coordinates of the world point `x`.
    fn index_of(&self, x: Vec3) -> [f64; 3] {
        [0, 1, 2].map(|a| (x[a] - self.min[a]) / self.voxel[a] - 0.5)
    }

    /// `ρ(x)` (0 outside the box, and for a NaN point).
    pub fn density(&self, x: Vec3) -> f64 {
        let b = self.bounds();
        if (0..3).any(|a| !(x[a] >= b.min[a] && x[a] <= b.max[a])) {
            return 0.0;
        }
        self.at_index(self.index_of(x))
    }

    /// Whether `σt` may be non-zero somewhere in the closed box `b`: a point `x` of the box
    /// reads the voxels around `u(x)` (trilinear, clamped to the grid), so `b` reads those
    /// from `⌊u(b.min)⌋` to `⌊u(b.max)⌋ + 1`; `σt` is 0 everywhere in `b` when they all are,
    /// when `b` misses the grid's box, or when `scale` is 0.
    pub fn occupies(&self, b: &Aabb) -> bool {
        let g = self.bounds();
        if (0..3).any(|a| !(b.max[a] >= g.min[a] && b.min[a] <= g.max[a]))
            || self.scale.iter().all(|&s| s == 0.0)
            || self.data.is_empty()
        {
            return false;
        }
        let (lo, hi) = (self.index_of(b.min), self.index_of(b.max));
        let range = [0, 1, 2].map(|a| {
            let last = self.dims[a] as f64 - 1.0;
            let first = lo[a].floor().clamp(0.0, last) as usize;
            let end = (hi[a].floor() + 1.0).clamp(0.0, last) as usize;
            (first, end)
        });
        (range[2].0..=range[2].1).any(|z| {
            (range[1].0..=range[1].1).any(|y| {
                let row = self.dims[0] * (y + self.dims[1] * z);
                self.data[row + range[0].0..=row + range[0].1]
                    .iter()
                    .any(|&v| v != 0.0)
            })
        })
    }

    /// `σt(x) = scale·ρ(x)`.
    pub fn sigma_t(&self, x: Vec3) -> Rgb {
        let r = self.density(x);
        self.scale.map(|s| s * r)
    }

    /// `∫₀^len ρ(o + t·d) dt` for a unit `d` (`len` may be `∞`), exactly (module docs).
    pub fn density_integral(&self, o: Vec3, d: Vec3, len: f64) -> f64 {
        // Also a NaN length.
        if len.is_nan() || len <= 0.0 {
            return 0.0;
        }
        let Some((t0, t1)) = self.bounds().clip(o, d, 0.0, len) else {
            return 0.0;
        };
        if t1 <= t0 || !t1.is_finite() {
            return 0.0;
        }
        // Per axis: the ray's voxel coordinate u(t) = u0 + (t − t0)·du, and the t of
        // the next plane through voxel centers (integer u) after t0.
        let u0 = self.index_of(axpy(o, t0, d));
        let mut next = [f64::INFINITY; 3];
        let mut step = [f64::INFINITY; 3];
        let mut du = [0.0; 3];
        for a in 0..3 {
            du[a] = d[a] / self.voxel[a];
            if du[a] > 0.0 {
                step[a] = 1.0 / du[a];
                next[a] = t0 + ((u0[a].floor() + 1.0) - u0[a]) * step[a];
            } else if du[a] < 0.0 {
                step[a] = -1.0 / du[a];
                next[a] = t0 + (u0[a] - (u0[a].ceil() - 1.0)) * step[a];
            }
        }
        let u = |t: f64| {
            let s = t - t0;
            [u0[0] + s * du[0], u0[1] + s * du[1], u0[2] + s * du[2]]
        };
        let mut sum = 0.0;
        let mut t = t0;
        let mut f_t = self.at_index(u(t0));
        // Each piece ends at the nearest plane (or t1); planes within rounding of it
        // are passed together. A piece lies in one trilinear cell, the one holding its
        // midpoint: its eight voxels are read once for the midpoint and the end, and a
        // cell of eight zeros adds nothing.
        while t < t1 {
            let tn = next.iter().fold(t1, |m, &v| m.min(v));
            let h = tn - t;
            if h > 0.0 {
                let (cell, corners) = self.cell_at(u(t + 0.5 * h));
                let f_end = if corners.iter().all(|&c| c == 0.0) {
                    0.0
                } else {
                    let f_mid = self.trilinear(cell, &corners, u(t + 0.5 * h));
                    let f_end = self.trilinear(cell, &corners, u(tn));
                    sum += h / 6.0 * (f_t + 4.0 * f_mid + f_end);
                    f_end
                };
                f_t = f_end;
            }
            t = tn;
            for a in 0..3 {
                while next[a] <= t + 1e-12 * (1.0 + t.abs()) {
                    next[a] += step[a];
                }
            }
        }
        sum
    }

    /// `∫₀^len σt(o + t·d) dt` per channel (see [`VoxelGrid::density_integral`]).
    pub fn optical_depth(&self, o: Vec3, d: Vec3, len: f64) -> Rgb {
        let r = self.density_integral(o, d, len);
        self.scale.map(|s| s * r)
    }

    /// The same field on the smallest sub-grid holding every non-zero voxel plus one
    /// voxel of margin on each side (where the grid has it): outside the non-zero voxels'
    /// neighbours the field is zero, so the field is unchanged; renderers then march a
    /// smaller box. An all-zero grid keeps one voxel.
    pub fn cropped(&self) -> VoxelGrid {
        let [nx, ny, _] = self.dims;
        let mut lo = self.dims;
        let mut hi = [0usize; 3];
        let mut any = false;
        for (i, &v) in self.data.iter().enumerate() {
            if v > 0.0 {
                let p = [i % nx, (i / nx) % ny, i / (nx * ny)];
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
                any = true;
            }
        }
        if !any {
            lo = [0; 3];
            hi = [0; 3];
        }
        let lo = [0, 1, 2].map(|a| lo[a].saturating_sub(1));
        let hi = [0, 1, 2].map(|a| (hi[a] + 1).min(self.dims[a] - 1));
        let dims = [0, 1, 2].map(|a| hi[a] - lo[a] + 1);
        let mut data = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let row = lo[0] + nx * (y + ny * z);
                data.extend_from_slice(&self.data[row..row + dims[0]]);
            }
        }
        VoxelGrid {
            dims,
            min: [0, 1, 2].map(|a| self.min[a] + lo[a] as f64 * self.voxel[a]),
            voxel: self.voxel,
            data,
            scale: self.scale,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

    /// A 5×4×6 grid of pseudo-random values (a seeded PCG) with some zeros, voxels of
    /// unequal sides.
    fn grid() -> VoxelGrid {
        let dims = [5, 4, 6];
        let mut rng = Pcg64::seed_from_u64(12345);
        let data = (0..120)
            .map(|i| {
                let v: f32 = rng.random();
                if i % 7 == 0 { 0.0 } else { v }
            })
            .collect();
        VoxelGrid {
            dims,
            min: [-1.0, 0.5, 2.0],
            voxel: [0.3, 0.5, 0.2],
            data,
            scale: [1.0, 2.0, 0.5],
        }
    }

    /// Uniform numbers in `[0, 1)` from a PCG seeded with `seed`.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = Pcg64::seed_from_u64(seed);
        move || rng.random()
    }

    /// `∫ρ` over `[0, len]` by the composite midpoint rule on `n` steps of the part
    /// inside the box (where `ρ` is continuous: error ~ h²·max|ρ''|, the kinks at the
    /// planes adding O(h²) too; the jumps at the faces would add O(h)).
    fn quadrature(g: &VoxelGrid, o: Vec3, d: Vec3, len: f64, n: usize) -> f64 {
        let Some((t0, t1)) = g.bounds().clip(o, d, 0.0, len) else {
            return 0.0;
        };
        let h = (t1 - t0) / n as f64;
        (0..n)
            .map(|i| g.density(axpy(o, t0 + (i as f64 + 0.5) * h, d)))
            .sum::<f64>()
            * h
    }

    /// `occupies` never says a box is empty where the field is not: on a grid of two
    /// non-zero voxels, every box it calls empty reads 0 at its corners, centre and 200
    /// random points; a box around a non-zero voxel's centre is occupied, one far from both
    /// (and one beside the grid, and any box when the scale is 0) is not.
    #[test]
    fn occupancy_is_never_empty_where_the_field_is_not() {
        let mut g = grid();
        g.data.iter_mut().for_each(|v| *v = 0.0);
        let at = |g: &VoxelGrid, i: [usize; 3]| i[0] + g.dims[0] * (i[1] + g.dims[1] * i[2]);
        let (i1, i2) = (at(&g, [1, 1, 1]), at(&g, [4, 3, 5]));
        g.data[i1] = 0.5;
        g.data[i2] = 0.25;
        let b = g.bounds();
        let mut r = uniform(99);
        let (mut empty, mut full) = (0, 0);
        for _ in 0..3000 {
            // Boxes up to a third of the grid's box, some reaching past its faces.
            let lo: Vec3 = [0, 1, 2].map(|a| b.min[a] + (1.2 * r() - 0.1) * (b.max[a] - b.min[a]));
            let hi: Vec3 = [0, 1, 2].map(|a| lo[a] + r() * (b.max[a] - b.min[a]) / 3.0);
            let bx = Aabb { min: lo, max: hi };
            if g.occupies(&bx) {
                full += 1;
                continue;
            }
            empty += 1;
            let mut points: Vec<Vec3> = (0..8)
                .map(|c| [0, 1, 2].map(|a| if c >> a & 1 == 1 { hi[a] } else { lo[a] }))
                .collect();
            points.push([0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a])));
            for _ in 0..200 {
                points.push([0, 1, 2].map(|a| lo[a] + r() * (hi[a] - lo[a])));
            }
            for p in points {
                assert_eq!(g.density(p), 0.0, "{bx:?} called empty, ρ({p:?}) > 0");
            }
        }
        assert!(empty > 300 && full > 300, "{empty} empty, {full} occupied");
        let centre = |i: [usize; 3]| -> Vec3 {
            [0, 1, 2].map(|a| g.min[a] + (i[a] as f64 + 0.5) * g.voxel[a])
        };
        let c = centre([1, 1, 1]);
        let around = Aabb {
            min: c.map(|v| v - 1e-3),
            max: c.map(|v| v + 1e-3),
        };
        assert!(g.occupies(&around));
        let far = centre([4, 0, 0]);
        assert!(!g.occupies(&Aabb {
            min: far.map(|v| v - 1e-3),
            max: far.map(|v| v + 1e-3)
        }));
        let beside = Aabb {
            min: [b.max[0] + 1.0, b.min[1], b.min[2]],
            max: [b.max[0] + 2.0, b.max[1], b.max[2]],
        };
        assert!(!g.occupies(&beside));
        g.scale = [0.0; 3];
        assert!(!g.occupies(&around));
    }

    /// Through cells of eight zero voxels (skipped) and the few that are not, the
    /// integral stays the field's: against fine quadrature along rays across a mostly
    /// empty grid.
    #[test]
    fn empty_cells_are_passed_and_the_rest_integrated() {
        let mut g = grid();
        for (i, v) in g.data.iter_mut().enumerate() {
            if i % 23 != 5 {
                *v = 0.0;
            }
        }
        assert!(g.data.iter().filter(|&&v| v != 0.0).count() >= 4);
        let b = g.bounds();
        let mut r = uniform(5);
        let mut hit = 0;
        for _ in 0..40 {
            let p: Vec3 = [0, 1, 2].map(|a| b.min[a] + r() * (b.max[a] - b.min[a]));
            let Some(d) = crate::vec3::normalize([r() - 0.5, r() - 0.5, r() - 0.5]) else {
                continue;
            };
            let o = axpy(p, -10.0, d);
            let exact = quadrature(&g, o, d, 20.0, 200_000);
            let e = g.density_integral(o, d, 20.0);
            assert!((e - exact).abs() < 1e-8 * (1.0 + exact), "{e} vs {exact}");
            hit += usize::from(exact > 1e-3);
        }
        assert!(hit >= 10, "{hit} rays met the voxels");
    }

    /// A grid one voxel thick along an axis (no trilinear cell across it: the field is
    /// constant through it) integrates as its field does, and passes its zero cells.
    #[test]
    fn a_grid_one_voxel_thick_integrates_as_its_field() {
        let mut g = grid();
        g.dims = [5, 4, 1];
        g.data.truncate(20);
        g.data[..6].iter_mut().for_each(|v| *v = 0.0);
        let b = g.bounds();
        let mut r = uniform(17);
        for _ in 0..20 {
            let p: Vec3 = [0, 1, 2].map(|a| b.min[a] + r() * (b.max[a] - b.min[a]));
            let Some(d) = crate::vec3::normalize([r() - 0.5, r() - 0.5, r() - 0.5]) else {
                continue;
            };
            let o = axpy(p, -5.0, d);
            let exact = quadrature(&g, o, d, 10.0, 200_000);
            let e = g.density_integral(o, d, 10.0);
            assert!((e - exact).abs() < 1e-7 * (1.0 + exact), "{e} vs {exact}");
        }
    }

    #[test]
    fn density_interpolates_the_voxels() {
        let g = grid();
        // At a voxel center the field is the voxel's value.
        let c = |i: [usize; 3]| [0, 1, 2].map(|a| g.min[a] + (i[a] as f64 + 0.5) * g.voxel[a]);
        for i in [[0, 0, 0], [4, 3, 5], [2, 1, 3]] {
            assert!((g.density(c(i)) - g.value(i)).abs() < 1e-7, "{i:?}");
        }
        // Midway between two centers: their mean.
        let m = [0, 1, 2].map(|a| 0.5 * (c([1, 1, 1])[a] + c([2, 1, 1])[a]));
        let want = 0.5 * (g.value([1, 1, 1]) + g.value([2, 1, 1]));
        assert!((g.density(m) - want).abs() < 1e-7);
        // Constant to the face, zero beyond and for NaN.
        let face = [g.min[0], c([0, 0, 0])[1], c([0, 0, 0])[2]];
        assert!((g.density(face) - g.value([0, 0, 0])).abs() < 1e-7);
        assert_eq!(g.density([g.min[0] - 1e-9, face[1], face[2]]), 0.0);
        assert_eq!(g.density([f64::NAN, face[1], face[2]]), 0.0);
        assert!((g.sigma_t(c([2, 1, 3]))[1] - 2.0 * g.value([2, 1, 3])).abs() < 1e-7);
    }

    #[test]
    fn optical_depth_matches_fine_quadrature() {
        let g = grid();
        let b = g.bounds();
        let rays: [(Vec3, Vec3); 5] = [
            ([-3.0, 1.0, 2.5], [1.0, 0.0, 0.0]),
            ([-2.0, -1.0, 1.0], [0.5, 0.6, 0.6244998]),
            ([0.0, 1.5, 2.6], [0.0, 0.0, 1.0]),
            ([0.2, 1.1, 2.9], [-0.3, 0.4, -0.8660254]),
            ([0.0, 1.5, 5.0], [0.0, 0.0, -1.0]),
        ];
        for (o, d) in rays {
            let n = crate::vec3::norm(d);
            let d = crate::vec3::scale(d, 1.0 / n);
            let len = 8.0;
            let exact = g.density_integral(o, d, len);
            // Midpoint with 4·10⁵ steps of ≤ 10⁻⁵: error ≲ 10⁻⁹ of the integral.
            let q = quadrature(&g, o, d, len, 400_000);
            assert!(
                (exact - q).abs() < 1e-8 * (1.0 + q),
                "{o:?} {d:?}: {exact} vs {q}"
            );
            // Up to ∞ equals up to far past the box, and a segment that stops inside.
            assert!(
                (g.density_integral(o, d, f64::INFINITY) - exact).abs() < 1e-12 * (1.0 + exact)
            );
            let (t0, t1) = b.clip(o, d, 0.0, len).unwrap();
            let mid = 0.5 * (t0 + t1);
            let q = quadrature(&g, o, d, mid, 400_000);
            let e = g.density_integral(o, d, mid);
            assert!((e - q).abs() < 1e-8 * (1.0 + q), "half: {e} vs {q}");
        }
        // Missing the box, zero and negative lengths.
        assert_eq!(
            g.density_integral([5.0, 5.0, 5.0], [1.0, 0.0, 0.0], 10.0),
            0.0
        );
        assert_eq!(
            g.density_integral([0.0, 1.5, 2.5], [1.0, 0.0, 0.0], 0.0),
            0.0
        );
        assert_eq!(
            g.density_integral([0.0, 1.5, 2.5], [1.0, 0.0, 0.0], -1.0),
            0.0
        );
        let tau = g.optical_depth([-3.0, 1.0, 2.5], [1.0, 0.0, 0.0], 10.0);
        assert!((tau[1] - 2.0 * tau[0]).abs() < 1e-12 * tau[1]);
    }

    #[test]
    fn cropping_keeps_the_field() {
        let mut g = grid();
        // Zero all but a 2×2×2 block in the middle.
        for (i, v) in g.data.iter_mut().enumerate() {
            let p = [i % 5, (i / 5) % 4, i / 20];
            if !(1..=2).contains(&p[0]) || !(1..=2).contains(&p[1]) || !(2..=3).contains(&p[2]) {
                *v = 0.0;
            }
        }
        let c = g.cropped();
        assert_eq!(c.dims, [4, 4, 4]);
        let b = g.bounds();
        let mut f = uniform(7);
        for _ in 0..2000 {
            let p = [0, 1, 2].map(|a| b.min[a] - 0.1 + f() * (b.max[a] - b.min[a] + 0.2));
            assert!((c.density(p) - g.density(p)).abs() < 1e-12, "{p:?}");
        }
    }
}
