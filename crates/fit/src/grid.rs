//! The density of one frame as the fit sees it: unit-cube coordinates, values normalized.
//!
//! Fitting works in the unit cube of the grid's longest side (paper A §5.1 bounds radii
//! relative to it): a world point `p` maps to `(p − bbox.min) / L`, `L` the longest side.
//! Densities are divided by their maximum so that the weight bounds `[0.01, 1]·max D`
//! become `[0.01, 1]` and the whole fit is invariant to the density's scale.

use haze_volume::{Rbf, Volume};

/// A frame prepared for fitting.
#[derive(Clone, Debug)]
pub struct FitGrid {
    /// Voxels per axis.
    pub dims: [usize; 3],
    /// Voxel size per axis, in unit-cube coordinates.
    pub h: [f64; 3],
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
        let nonzero = density
            .iter()
            .enumerate()
            .filter(|(_, d)| **d != 0.0)
            .map(|(i, _)| i)
            .collect();
        let size = v.bbox().size();
        Ok(FitGrid {
            dims,
            h: [0, 1, 2].map(|a| vs[a] / unit),
            extent: [0, 1, 2].map(|a| size[a] / unit),
            origin: v.bbox().min,
            unit,
            density,
            max_density,
            sum_sq,
            nonzero,
        })
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
