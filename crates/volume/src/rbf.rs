//! Gaussian radial basis functions (paper A, §5.1).
//!
//! `B(x) = w·exp(−(|x − c| / r)²)` for `|x − c| < 3r`, and exactly zero beyond: the cut-off
//! drops at most `w·e⁻⁹ ≈ 1.2e-4·w`, and it makes every RBF touch a bounded set of voxels,
//! which is what keeps fitting and lighting linear in the number of RBFs.

use crate::volume::Bbox;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Support radius in units of `r`.
pub const CUTOFF: f64 = 3.0;

/// One Gaussian RBF in world coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Rbf {
    pub center: [f64; 3],
    pub radius: f64,
    pub weight: f64,
}

impl Rbf {
    pub fn new(center: [f64; 3], radius: f64, weight: f64) -> Self {
        Self {
            center,
            radius,
            weight,
        }
    }

    /// Value at world point `p`. A non-positive or non-finite radius has no support and
    /// evaluates to zero everywhere (never a division by zero).
    #[inline]
    pub fn eval(&self, p: [f64; 3]) -> f64 {
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return 0.0;
        }
        // Scale before squaring: |x − c|² and r² underflow for tiny radii.
        let q2: f64 = (0..3)
            .map(|a| ((p[a] - self.center[a]) / self.radius).powi(2))
            .sum();
        if q2 >= CUTOFF * CUTOFF {
            0.0
        } else {
            self.weight * (-q2).exp()
        }
    }

    /// Radius of the support sphere, `3r`.
    pub fn support_radius(&self) -> f64 {
        CUTOFF * self.radius.max(0.0)
    }
}

/// Inclusive voxel index range along one axis whose centers can lie within `[lo, hi]`,
/// clamped to `0..n`; `None` when empty.
pub fn voxel_span(lo: f64, hi: f64, min: f64, voxel: f64, n: usize) -> Option<(usize, usize)> {
    // Written so that NaN bounds or voxel sizes also take the early exit.
    let valid = voxel > 0.0 && lo <= hi;
    if n == 0 || !valid {
        return None;
    }
    // Voxel i's center is min + (i + 0.5)·voxel.
    let first = ((lo - min) / voxel - 0.5).ceil().max(0.0);
    let last = ((hi - min) / voxel - 0.5).floor().min(n as f64 - 1.0);
    if first > last {
        return None;
    }
    Some((first as usize, last as usize))
}

/// Σ of `rbfs` sampled at the voxel centers of a `dims` grid over `bbox` (x fastest),
/// accumulated in `f64`. Each RBF visits only the voxels inside its `3r` support box;
/// z-slices are filled in parallel.
pub fn evaluate_on_grid(dims: [usize; 3], bbox: &Bbox, rbfs: &[Rbf]) -> Vec<f64> {
    let n = dims[0] * dims[1] * dims[2];
    let mut out = vec![0.0f64; n];
    if n == 0 {
        return out;
    }
    let size = bbox.size();
    let vs = [0, 1, 2].map(|a| size[a] / dims[a] as f64);
    let slice = dims[0] * dims[1];
    out.par_chunks_mut(slice)
        .enumerate()
        .for_each(|(z, plane)| {
            let pz = bbox.min[2] + (z as f64 + 0.5) * vs[2];
            for rbf in rbfs {
                let s = rbf.support_radius();
                if s <= 0.0 || (pz - rbf.center[2]).abs() >= s {
                    continue;
                }
                let span = |a: usize| {
                    voxel_span(
                        rbf.center[a] - s,
                        rbf.center[a] + s,
                        bbox.min[a],
                        vs[a],
                        dims[a],
                    )
                };
                let (Some((x0, x1)), Some((y0, y1))) = (span(0), span(1)) else {
                    continue;
                };
                for y in y0..=y1 {
                    let py = bbox.min[1] + (y as f64 + 0.5) * vs[1];
                    for x in x0..=x1 {
                        let px = bbox.min[0] + (x as f64 + 0.5) * vs[0];
                        plane[x + dims[0] * y] += rbf.eval([px, py, pz]);
                    }
                }
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eval_matches_closed_form_and_cuts_off_at_3r() {
        let b = Rbf::new([1.0, 2.0, 3.0], 0.5, 2.0);
        assert_eq!(b.eval([1.0, 2.0, 3.0]), 2.0);
        let at_r = b.eval([1.5, 2.0, 3.0]);
        assert!((at_r - 2.0 * (-1.0f64).exp()).abs() < 1e-15);
        assert!(b.eval([1.0 + 1.4999, 2.0, 3.0]) > 0.0);
        assert_eq!(b.eval([1.0 + 1.5, 2.0, 3.0]), 0.0);
        assert_eq!(b.eval([100.0, 2.0, 3.0]), 0.0);
    }

    #[test]
    fn degenerate_radii_evaluate_to_zero() {
        for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let b = Rbf::new([0.0; 3], r, 1.0);
            assert_eq!(b.eval([0.0; 3]), 0.0, "radius {r}");
            assert!(b.support_radius() >= 0.0 || r.is_nan());
        }
        // A tiny radius is still exact at the center and zero a hair away.
        let b = Rbf::new([0.0; 3], 1e-300, 1.0);
        assert_eq!(b.eval([0.0; 3]), 1.0);
        assert_eq!(b.eval([1e-200, 0.0, 0.0]), 0.0);
    }

    #[test]
    fn voxel_span_selects_centers_in_range() {
        // Centers at 0.5, 1.5, ..., 9.5 on a unit grid from 0.
        assert_eq!(voxel_span(1.0, 3.0, 0.0, 1.0, 10), Some((1, 2)));
        assert_eq!(voxel_span(1.5, 1.5, 0.0, 1.0, 10), Some((1, 1)));
        assert_eq!(voxel_span(-5.0, 100.0, 0.0, 1.0, 10), Some((0, 9)));
        assert_eq!(voxel_span(20.0, 30.0, 0.0, 1.0, 10), None);
        assert_eq!(voxel_span(0.6, 1.4, 0.0, 1.0, 10), None);
        assert_eq!(voxel_span(0.0, 1.0, 0.0, 1.0, 0), None);
    }

    /// The support-box evaluation equals brute force over every voxel and RBF.
    #[test]
    fn grid_evaluation_matches_brute_force() {
        let dims = [13, 9, 11];
        let bbox = Bbox::new([-1.0, 0.0, 2.0], [1.6, 1.8, 4.2]);
        let mut rbfs = Vec::new();
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..40 {
            let c = [-1.5 + 3.5 * rnd(), -0.5 + 2.8 * rnd(), 1.5 + 3.2 * rnd()];
            rbfs.push(Rbf::new(c, 0.05 + 0.4 * rnd(), 0.1 + rnd()));
        }
        let fast = evaluate_on_grid(dims, &bbox, &rbfs);
        let vs = [0, 1, 2].map(|a| bbox.size()[a] / dims[a] as f64);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let p = [x, y, z].map(|i| i as f64 + 0.5);
                    let p = [0, 1, 2].map(|a| bbox.min[a] + p[a] * vs[a]);
                    let brute: f64 = rbfs.iter().map(|b| b.eval(p)).sum();
                    let got = fast[x + dims[0] * (y + dims[1] * z)];
                    assert!(
                        (got - brute).abs() <= 1e-12,
                        "({x},{y},{z}): {got} vs {brute}"
                    );
                }
            }
        }
        assert!(fast.iter().any(|&v| v > 0.0));
    }

    #[test]
    fn grid_evaluation_of_nothing_is_zero() {
        let bbox = Bbox::new([0.0; 3], [1.0; 3]);
        assert!(
            evaluate_on_grid([4, 4, 4], &bbox, &[])
                .iter()
                .all(|&v| v == 0.0)
        );
        assert!(evaluate_on_grid([0, 4, 4], &bbox, &[Rbf::new([0.5; 3], 0.1, 1.0)]).is_empty());
    }
}
