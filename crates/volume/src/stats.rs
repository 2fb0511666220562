//! Summary statistics of a volume, as `haze inspect` reports them.

use crate::volume::Volume;
use serde::Serialize;

/// Value range, active (non-zero) count and bounding box of the non-zero voxels.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VolumeStats {
    pub min: f32,
    pub max: f32,
    /// Σ of all samples, accumulated in f64.
    pub sum: f64,
    /// Voxels whose value is not zero.
    pub nonzero: usize,
    /// Inclusive voxel-index box of the non-zero voxels; `None` for an all-zero volume.
    pub nonzero_bbox: Option<[[usize; 3]; 2]>,
}

impl VolumeStats {
    /// Statistics of `v`. An empty volume reports a zero range.
    pub fn of(v: &Volume) -> Self {
        let mut s = VolumeStats {
            min: if v.is_empty() { 0.0 } else { f32::INFINITY },
            max: if v.is_empty() { 0.0 } else { f32::NEG_INFINITY },
            sum: 0.0,
            nonzero: 0,
            nonzero_bbox: None,
        };
        let mut lo = [usize::MAX; 3];
        let mut hi = [0usize; 3];
        for (i, &d) in v.data().iter().enumerate() {
            s.min = s.min.min(d);
            s.max = s.max.max(d);
            s.sum += d as f64;
            if d != 0.0 {
                s.nonzero += 1;
                let c = v.coords(i);
                for a in 0..3 {
                    lo[a] = lo[a].min(c[a]);
                    hi[a] = hi[a].max(c[a]);
                }
            }
        }
        if s.nonzero > 0 {
            s.nonzero_bbox = Some([lo, hi]);
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Bbox;

    #[test]
    fn stats_of_a_small_volume() {
        let b = Bbox::new([0.0; 3], [1.0; 3]);
        let mut v = Volume::zeros([3, 3, 3], b).unwrap();
        let (i, j) = (v.index(1, 2, 1), v.index(2, 0, 2));
        v.data_mut()[i] = 0.5;
        v.data_mut()[j] = -0.25;
        let s = VolumeStats::of(&v);
        assert_eq!((s.min, s.max, s.nonzero), (-0.25, 0.5, 2));
        assert_eq!(s.sum, 0.25);
        assert_eq!(s.nonzero_bbox, Some([[1, 0, 1], [2, 2, 2]]));
    }

    #[test]
    fn stats_of_empty_and_zero_volumes() {
        let b = Bbox::new([0.0; 3], [1.0; 3]);
        let e = VolumeStats::of(&Volume::zeros([0, 0, 0], b).unwrap());
        assert_eq!(
            (e.min, e.max, e.nonzero, e.nonzero_bbox),
            (0.0, 0.0, 0, None)
        );
        let z = VolumeStats::of(&Volume::zeros([2, 2, 2], b).unwrap());
        assert_eq!((z.min, z.max, z.nonzero), (0.0, 0.0, 0));
    }
}
