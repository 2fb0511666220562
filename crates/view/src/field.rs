//! The density as a continuous field for rendering: trilinear interpolation between voxel
//! centers (`bbox_min + (i + ½)·voxel`), constant to the box's faces, zero outside; and
//! ray–box clipping.

use haze_volume::{Bbox, Volume};

/// Density at world point `p` (0 outside the box): trilinear between voxel centers,
/// constant to the faces. The marches of the lighting call this for every step, so the
/// stencil is unrolled; a corner of zero weight is skipped (a NaN there stays out).
pub fn sample(v: &Volume, p: [f64; 3]) -> f64 {
    let b = v.bbox();
    let d = v.dims();
    if d.contains(&0) || (0..3).any(|a| !(p[a] >= b.min[a] && p[a] <= b.max[a])) {
        return 0.0;
    }
    let vs = v.voxel_size();
    // Per axis: the offsets (in the data) of the lower and upper corner, and the weights.
    let stride = [1, d[0], d[0] * d[1]];
    let mut off = [[0usize; 2]; 3];
    let mut w = [[0.0f64; 2]; 3];
    for a in 0..3 {
        // Clamped to ≥ 0, so the cast is the floor.
        let f = ((p[a] - b.min[a]) / vs[a] - 0.5).clamp(0.0, (d[a] - 1) as f64);
        let i = (f as usize).min(d[a].saturating_sub(2));
        let t = f - i as f64;
        off[a] = [i * stride[a], (i + 1).min(d[a] - 1) * stride[a]];
        w[a] = [1.0 - t, t];
    }
    let data = v.data();
    let mut s = 0.0;
    for corner in 0..8 {
        let (x, y, z) = (corner & 1, corner >> 1 & 1, corner >> 2);
        let weight = 1.0 * w[0][x] * w[1][y] * w[2][z];
        if weight != 0.0 {
            s += weight * f64::from(data[off[0][x] + off[1][y] + off[2][z]]);
        }
    }
    s
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
