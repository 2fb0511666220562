//! The dense volume: dims, world box, `f32` samples at voxel centers, x fastest.

use serde::{Deserialize, Serialize};

/// An axis-aligned world box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bbox {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Bbox {
    pub fn new(min: [f64; 3], max: [f64; 3]) -> Self {
        Self { min, max }
    }

    /// Edge lengths `max − min`.
    pub fn size(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| self.max[a] - self.min[a])
    }

    /// Longest edge: the side of the unit cube that fitting works in.
    pub fn longest_side(&self) -> f64 {
        let s = self.size();
        s[0].max(s[1]).max(s[2])
    }

    /// Whether two boxes agree within `tol` times the larger extent (float noise from
    /// different writers must not split a sequence).
    pub fn approx_eq(&self, other: &Bbox, tol: f64) -> bool {
        let scale = self
            .longest_side()
            .abs()
            .max(other.longest_side().abs())
            .max(1e-300);
        (0..3).all(|a| {
            (self.min[a] - other.min[a]).abs() <= tol * scale
                && (self.max[a] - other.max[a]).abs() <= tol * scale
        })
    }
}

/// A dense scalar grid placed in a world box. Sample `(x, y, z)` sits at the voxel center
/// `bbox.min + (i + 0.5)·voxel_size` and is stored at `x + X·(y + Y·z)`.
///
/// A volume with a zero dimension is an empty frame: it has no samples.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    dims: [usize; 3],
    bbox: Bbox,
    data: Vec<f32>,
}

/// Why a `Volume` could not be built from its parts.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ShapeError {
    #[error("dims {dims:?} need {expected} samples but {actual} were given")]
    Length {
        dims: [usize; 3],
        expected: usize,
        actual: usize,
    },
    #[error("dims {0:?} overflow the address space")]
    Overflow([usize; 3]),
    #[error("world box {0:?} is not ordered (every max must exceed its min)")]
    BadBox(Bbox),
}

/// Number of samples of `dims`, or `None` on overflow.
pub fn voxel_count(dims: [usize; 3]) -> Option<usize> {
    dims[0].checked_mul(dims[1])?.checked_mul(dims[2])
}

impl Volume {
    /// Builds a volume, checking that `data` holds exactly one sample per voxel and that
    /// the box is ordered and finite.
    pub fn new(dims: [usize; 3], bbox: Bbox, data: Vec<f32>) -> Result<Self, ShapeError> {
        let expected = voxel_count(dims).ok_or(ShapeError::Overflow(dims))?;
        if data.len() != expected {
            return Err(ShapeError::Length {
                dims,
                expected,
                actual: data.len(),
            });
        }
        let ordered = (0..3).all(|a| {
            bbox.min[a].is_finite() && bbox.max[a].is_finite() && bbox.max[a] > bbox.min[a]
        });
        if !ordered {
            return Err(ShapeError::BadBox(bbox));
        }
        Ok(Self { dims, bbox, data })
    }

    /// An all-zero volume.
    pub fn zeros(dims: [usize; 3], bbox: Bbox) -> Result<Self, ShapeError> {
        let n = voxel_count(dims).ok_or(ShapeError::Overflow(dims))?;
        Self::new(dims, bbox, vec![0.0; n])
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    pub fn bbox(&self) -> &Bbox {
        &self.bbox
    }

    pub fn data(&self) -> &[f32] {
        &self.data
    }

    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }

    pub fn into_data(self) -> Vec<f32> {
        self.data
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True for an empty frame (a zero dimension).
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// World size of one voxel along each axis: `(max − min) / dims` (zero on an empty
    /// axis).
    pub fn voxel_size(&self) -> [f64; 3] {
        let s = self.bbox.size();
        [0, 1, 2].map(|a| {
            if self.dims[a] == 0 {
                0.0
            } else {
                s[a] / self.dims[a] as f64
            }
        })
    }

    /// Linear index of voxel `(x, y, z)` (x fastest).
    #[inline]
    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// Voxel coordinates of linear index `i`.
    #[inline]
    pub fn coords(&self, i: usize) -> [usize; 3] {
        let x = i % self.dims[0];
        let yz = i / self.dims[0];
        [x, yz % self.dims[1], yz / self.dims[1]]
    }

    #[inline]
    pub fn get(&self, x: usize, y: usize, z: usize) -> f32 {
        self.data[self.index(x, y, z)]
    }

    /// World position of the center of voxel `(x, y, z)`.
    pub fn voxel_center(&self, x: usize, y: usize, z: usize) -> [f64; 3] {
        let v = self.voxel_size();
        let i = [x, y, z];
        [0, 1, 2].map(|a| self.bbox.min[a] + (i[a] as f64 + 0.5) * v[a])
    }

    /// World box of the voxels whose density exceeds `threshold` (whole voxels), or
    /// `None` when there are none: what a camera should frame.
    pub fn occupied_bbox(&self, threshold: f32) -> Option<Bbox> {
        let mut lo = [usize::MAX; 3];
        let mut hi = [0usize; 3];
        // Row by row (x fastest): each row's first and last dense voxel.
        for (r, row) in self.data.chunks_exact(self.dims[0].max(1)).enumerate() {
            let Some(first) = row.iter().position(|&d| d > threshold) else {
                continue;
            };
            let last = row.iter().rposition(|&d| d > threshold).unwrap_or(first);
            let (y, z) = (r % self.dims[1], r / self.dims[1]);
            lo = [lo[0].min(first), lo[1].min(y), lo[2].min(z)];
            hi = [hi[0].max(last), hi[1].max(y), hi[2].max(z)];
        }
        if lo[0] == usize::MAX {
            return None;
        }
        let v = self.voxel_size();
        Some(Bbox::new(
            [0, 1, 2].map(|a| self.bbox.min[a] + lo[a] as f64 * v[a]),
            [0, 1, 2].map(|a| self.bbox.min[a] + (hi[a] + 1) as f64 * v[a]),
        ))
    }

    /// Bytes held by the samples.
    pub fn memory_bytes(&self) -> usize {
        self.data.len() * std::mem::size_of::<f32>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn occupied_bbox_is_the_box_of_the_dense_voxels() {
        let mut v = Volume::zeros([4, 5, 6], Bbox::new([0.0; 3], [4.0, 10.0, 3.0])).unwrap();
        assert_eq!(v.occupied_bbox(0.0), None);
        let i = v.index(1, 2, 3);
        v.data_mut()[i] = 1.0;
        let j = v.index(2, 2, 5);
        v.data_mut()[j] = 0.5;
        let b = v.occupied_bbox(0.0).unwrap();
        assert_eq!((b.min, b.max), ([1.0, 4.0, 1.5], [3.0, 6.0, 3.0]));
        let b = v.occupied_bbox(0.6).unwrap();
        assert_eq!((b.min, b.max), ([1.0, 4.0, 1.5], [2.0, 6.0, 2.0]));
    }

    /// The row-by-row box against every voxel tested (sparse voxels on odd shapes).
    #[test]
    fn occupied_bbox_matches_every_voxel_tested() {
        for (dims, step) in [([7, 5, 3], 11usize), ([1, 9, 4], 7), ([6, 1, 1], 4)] {
            let mut v = Volume::zeros(dims, unit()).unwrap();
            for (i, d) in v.data_mut().iter_mut().enumerate() {
                *d = if (i * 37 + 5) % step == 0 {
                    1.0 + i as f32
                } else {
                    0.0
                };
            }
            let (mut lo, mut hi) = ([usize::MAX; 3], [0; 3]);
            for i in 0..v.data().len() {
                if v.data()[i] > 0.0 {
                    let c = v.coords(i);
                    (0..3).for_each(|a| (lo[a], hi[a]) = (lo[a].min(c[a]), hi[a].max(c[a])));
                }
            }
            let vs = v.voxel_size();
            let b = v.occupied_bbox(0.0).unwrap();
            for a in 0..3 {
                assert_eq!(b.min[a], lo[a] as f64 * vs[a], "{dims:?}");
                assert_eq!(b.max[a], (hi[a] + 1) as f64 * vs[a], "{dims:?}");
            }
        }
    }

    fn unit() -> Bbox {
        Bbox::new([0.0; 3], [1.0; 3])
    }

    #[test]
    fn index_and_coords_are_inverse_and_x_fastest() {
        let v = Volume::zeros([3, 4, 5], unit()).unwrap();
        assert_eq!(v.index(1, 0, 0), 1);
        assert_eq!(v.index(0, 1, 0), 3);
        assert_eq!(v.index(0, 0, 1), 12);
        for i in 0..v.len() {
            let [x, y, z] = v.coords(i);
            assert_eq!(v.index(x, y, z), i);
        }
    }

    #[test]
    fn voxel_centers_follow_the_convention() {
        let b = Bbox::new([-1.5, -1.5, 0.0], [1.5, 1.5, 4.0]);
        let v = Volume::zeros([48, 48, 64], b).unwrap();
        assert_eq!(v.voxel_size(), [0.0625; 3]);
        assert_eq!(v.voxel_center(0, 0, 0), [-1.46875, -1.46875, 0.03125]);
        assert_eq!(v.voxel_center(47, 47, 63), [1.46875, 1.46875, 3.96875]);
    }

    #[test]
    fn shape_errors_are_reported() {
        assert!(matches!(
            Volume::new([2, 2, 2], unit(), vec![0.0; 7]),
            Err(ShapeError::Length { expected: 8, .. })
        ));
        assert!(matches!(
            Volume::new([usize::MAX, 2, 2], unit(), vec![]),
            Err(ShapeError::Overflow(_))
        ));
        let flat = Bbox::new([0.0; 3], [1.0, 0.0, 1.0]);
        assert!(matches!(
            Volume::new([1, 1, 1], flat, vec![0.0]),
            Err(ShapeError::BadBox(_))
        ));
    }

    #[test]
    fn empty_frame_is_valid() {
        let v = Volume::zeros([0, 0, 0], unit()).unwrap();
        assert!(v.is_empty());
        assert_eq!(v.voxel_size(), [0.0; 3]);
        assert_eq!(v.memory_bytes(), 0);
    }
}
