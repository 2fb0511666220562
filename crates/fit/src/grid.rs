//! The density of one frame as the fit sees it: unit-cube coordinates, values normalized.
//!
//! Fitting works in the unit cube of the grid's longest side (paper A §5.1 bounds radii
//! relative to it): a world point `p` maps to `(p − bbox.min) / L`, `L` the longest side.
//! Densities are divided by their maximum so that the weight bounds `[0.01, 1]·max D`
//! become `[0.01, 1]` and the whole fit is invariant to the density's scale.

use haze_volume::{Rbf, Volume};

/// Indices of the positive values, ascending.
fn positive(v: &[f64]) -> Vec<usize> {
    v.iter()
        .enumerate()
        .filter(|(_, d)| **d > 0.0)
        .map(|(i, _)| i)
        .collect()
}

/// A frame prepared for fitting.
#[derive(Clone, Debug)]
pub struct FitGrid {
    /// Voxels per axis.
    pub dims: [usize; 3],
    /// Voxel size per axis, in unit-cube coordinates.
    pub h: [f64; 3],
    /// Smallest voxel side of the frame at full resolution (unit cube): grids derived
    /// from it ([`FitGrid::downsampled`], [`FitGrid::residual_grid`]) keep it, so the
    /// radius floor ([`crate::bounds::nyquist_radius`]) of a coarse pass is the frame's.
    pub full_h: f64,
    /// Size of the box per axis in unit-cube coordinates (the longest is 1).
    pub extent: [f64; 3],
    /// World position of the box's min corner.
    pub origin: [f64; 3],
    /// World length of the unit (the longest side of the box).
    pub unit: f64,
    /// Densities divided by `max_density`, x fastest.
    pub density: Vec<f64>,
    /// Largest density of the frame in world units (0 for an all-zero frame).
    pub max_density: f64,
    /// Σ density² of the normalized densities (0 for an all-zero frame).
    pub sum_sq: f64,
    /// Linear indices of the non-zero voxels, ascending.
    pub nonzero: Vec<usize>,
}

impl FitGrid {
    /// Prepares `v`; refuses NaN, infinite and negative densities (the importers reject
    /// them already; this guards volumes built in code).
    pub fn from_volume(v: &Volume) -> Result<FitGrid, String> {
        if let Some(i) = v.data().iter().position(|d| !(d.is_finite() && *d >= 0.0)) {
            let [x, y, z] = v.coords(i);
            return Err(format!(
                "voxel ({x}, {y}, {z}) is {}: the fit needs finite, non-negative densities",
                v.data()[i]
            ));
        }
        let dims = v.dims();
        let unit = v.bbox().longest_side();
        let unit = if unit > 0.0 && unit.is_finite() {
            unit
        } else {
            1.0
        };
        let vs = v.voxel_size();
        let max_density = v.data().iter().fold(0.0f64, |m, &d| m.max(f64::from(d)));
        let inv = if max_density > 0.0 {
            1.0 / max_density
        } else {
            0.0
        };
        let density: Vec<f64> = v.data().iter().map(|&d| f64::from(d) * inv).collect();
        let sum_sq = density.iter().map(|d| d * d).sum();
        let nonzero = positive(&density);
        let size = v.bbox().size();
        Ok(FitGrid {
            dims,
            h: [0, 1, 2].map(|a| vs[a] / unit),
            full_h: [0, 1, 2]
                .map(|a| vs[a] / unit)
                .into_iter()
                .fold(f64::INFINITY, f64::min),
            extent: [0, 1, 2].map(|a| size[a] / unit),
            origin: v.bbox().min,
            unit,
            density,
            max_density,
            sum_sq,
            nonzero,
        })
    }

    /// The frame at half the resolution for coarse-to-fine fitting: each coarse voxel is
    /// the mean of the 2×2×2 fine voxels it covers (voxels past an odd edge count as zero
    /// density), so its center is the centroid of theirs and the unit cube, the box and
    /// the normalization are those of `self`. An RBF's parameters mean the same on both
    /// grids; the coarse objective is the fine one with the density box-filtered, which
    /// shifts optima by much less than a voxel for radii above one coarse voxel.
    pub fn downsampled(&self) -> FitGrid {
        let d = self.dims.map(|n| n.div_ceil(2));
        let mut density = vec![0.0; d[0] * d[1] * d[2]];
        for z in 0..self.dims[2] {
            for y in 0..self.dims[1] {
                let row = self.index(0, y, z);
                let out = (d[0] * (y / 2 + d[1] * (z / 2)))..;
                let out = &mut density[out];
                for (x, v) in self.density[row..row + self.dims[0]].iter().enumerate() {
                    out[x / 2] += v;
                }
            }
        }
        density.iter_mut().for_each(|v| *v *= 0.125);
        self.with_density(d, self.h.map(|h| 2.0 * h), density)
    }

    /// The grid of the residual `D − D̃` of `self` (values may be negative): fitting RBFs
    /// to it fits them with `D̃` frozen. Its normalization `ΣD²` stays that of `self`, so
    /// costs on both grids compare.
    pub fn residual_grid(&self, residual: Vec<f64>) -> FitGrid {
        assert_eq!(residual.len(), self.len(), "one residual value per voxel");
        FitGrid {
            nonzero: positive(&residual),
            density: residual,
            ..self.clone_geometry()
        }
    }

    /// Same box and normalization as `self`, other samples.
    fn with_density(&self, dims: [usize; 3], h: [f64; 3], density: Vec<f64>) -> FitGrid {
        FitGrid {
            dims,
            h,
            sum_sq: density.iter().map(|d| d * d).sum(),
            nonzero: positive(&density),
            density,
            ..self.clone_geometry()
        }
    }

    fn clone_geometry(&self) -> FitGrid {
        FitGrid {
            dims: self.dims,
            h: self.h,
            full_h: self.full_h,
            extent: self.extent,
            origin: self.origin,
            unit: self.unit,
            density: Vec::new(),
            max_density: self.max_density,
            sum_sq: self.sum_sq,
            nonzero: Vec::new(),
        }
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        self.density.len()
    }

    pub fn is_empty(&self) -> bool {
        self.density.is_empty()
    }

    /// Linear index of voxel `(x, y, z)`.
    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// Unit-cube position of the center of linear voxel `i`.
    pub fn center(&self, i: usize) -> [f64; 3] {
        let x = i % self.dims[0];
        let yz = i / self.dims[0];
        let c = [x, yz % self.dims[1], yz / self.dims[1]];
        [0, 1, 2].map(|a| (c[a] as f64 + 0.5) * self.h[a])
    }

    /// A unit-cube, normalized RBF in world coordinates and density units.
    pub fn to_world(&self, center: [f64; 3], radius: f64, weight: f64) -> Rbf {
        Rbf::new(
            [0, 1, 2].map(|a| self.origin[a] + center[a] * self.unit),
            radius * self.unit,
            weight * self.max_density,
        )
    }

    /// A world RBF in this grid's unit-cube coordinates and normalized weight (the
    /// inverse of [`FitGrid::to_world`]); `None` when the frame is all zero.
    pub fn from_world(&self, rbf: &Rbf) -> Option<([f64; 3], f64, f64)> {
        if self.max_density <= 0.0 {
            return None;
        }
        Some((
            [0, 1, 2].map(|a| (rbf.center[a] - self.origin[a]) / self.unit),
            rbf.radius / self.unit,
            rbf.weight / self.max_density,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::Bbox;

    /// Each coarse voxel is the mean of its 2×2×2 fine voxels (zeros past odd edges), at
    /// their centroid; box and normalization stay.
    #[test]
    fn downsampled_grid_averages_blocks() {
        let dims = [5, 4, 3];
        let b = Bbox::new([1.0, 2.0, 3.0], [6.0, 6.0, 6.0]);
        let mut v = Volume::zeros(dims, b).unwrap();
        for i in 0..v.len() {
            v.data_mut()[i] = (i % 7) as f32 + 0.5;
        }
        let g = FitGrid::from_volume(&v).unwrap();
        let c = g.downsampled();
        assert_eq!(c.dims, [3, 2, 2]);
        assert_eq!(
            (c.extent, c.unit, c.max_density),
            (g.extent, g.unit, g.max_density)
        );
        for cz in 0..2 {
            for cy in 0..2 {
                for cx in 0..3 {
                    let mut sum = 0.0;
                    let mut centroid = [0.0; 3];
                    for (dx, dy, dz) in (0..8).map(|k| (k & 1, (k >> 1) & 1, k >> 2)) {
                        let (x, y, z) = (2 * cx + dx, 2 * cy + dy, 2 * cz + dz);
                        let inside = x < 5 && y < 4 && z < 3;
                        let p = [x, y, z].map(|v| v as f64 + 0.5);
                        for a in 0..3 {
                            centroid[a] += p[a] * g.h[a] / 8.0;
                        }
                        if inside {
                            sum += g.density[g.index(x, y, z)];
                        }
                    }
                    let i = c.index(cx, cy, cz);
                    assert!((c.density[i] - sum / 8.0).abs() < 1e-15);
                    let got = c.center(i);
                    assert!((0..3).all(|a| (got[a] - centroid[a]).abs() < 1e-12));
                }
            }
        }
        let r = g.residual_grid(vec![-1.0; g.len()]);
        assert!(r.nonzero.is_empty() && r.sum_sq == g.sum_sq);
    }
}
