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
/// accumulated in `f64`. Each RBF visits only the voxels inside its `3r` support sphere,
/// its value there the product of per-axis factors ([`SliceSplats`]: no `exp` a voxel);
/// z-slices are filled in parallel.
pub fn evaluate_on_grid(dims: [usize; 3], bbox: &Bbox, rbfs: &[Rbf]) -> Vec<f64> {
    let n = dims[0] * dims[1] * dims[2];
    let mut out = vec![0.0f64; n];
    if n == 0 {
        return out;
    }
    let slice = dims[0] * dims[1];
    out.par_chunks_mut(slice)
        .enumerate()
        .for_each(|(z, plane)| {
            SliceSplats::new(rbfs, z, dims, bbox).splat(0, dims[1], |_, x, y, b| {
                plane[x + dims[0] * y] += b;
            });
        });
    out
}

/// The RBFs that reach one z-slice of voxel centers, each with its factors along x and y.
///
/// `B(x) = w·e^{−(Δx² + Δy² + Δz²)/r²}` is separable: a slice takes `w·e^{−Δz²/r²}` once,
/// `e^{−Δx²/r²}` once per column and `e^{−Δy²/r²}` once per row of the RBF's span, and a
/// voxel the product of its two — the sum [`Rbf::eval`] takes in one `exp`, rounded
/// differently (a few ulps). The support is [`Rbf::eval`]'s: the sphere of `3r`, tested
/// on the same `Σ (Δ/r)²`.
#[derive(Debug)]
pub struct SliceSplats {
    /// Per RBF that reaches the slice.
    reach: Vec<Reach>,
    /// Every reaching RBF's factors along x then along y, each beside its `(Δ/r)²`, back
    /// to back in `reach`'s order.
    factors: Vec<(f64, f64)>,
}

/// An RBF that reaches a slice: its index, its voxel spans along x and y (inclusive),
/// `Δz²/r²`.
type Reach = (usize, (usize, usize), (usize, usize), f64);

impl SliceSplats {
    /// The RBFs of `rbfs` that reach voxel slice `z` of a `dims` grid over `bbox`.
    pub fn new(rbfs: &[Rbf], z: usize, dims: [usize; 3], bbox: &Bbox) -> Self {
        let size = bbox.size();
        let vs = [0, 1, 2].map(|a| size[a] / dims[a].max(1) as f64);
        let center = |a: usize, i: usize| bbox.min[a] + (i as f64 + 0.5) * vs[a];
        let pz = center(2, z);
        let mut reach = Vec::new();
        let mut factors = Vec::new();
        for (l, rbf) in rbfs.iter().enumerate() {
            let s = rbf.support_radius();
            if !(s > 0.0 && s.is_finite()) || (pz - rbf.center[2]).abs() >= s {
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
            let (Some(sx), Some(sy)) = (span(0), span(1)) else {
                continue;
            };
            let q = |a: usize, p: f64| ((p - rbf.center[a]) / rbf.radius).powi(2);
            let qz = q(2, pz);
            let scale = rbf.weight * (-qz).exp();
            for x in sx.0..=sx.1 {
                let qx = q(0, center(0, x));
                factors.push((scale * (-qx).exp(), qx));
            }
            for y in sy.0..=sy.1 {
                let qy = q(1, center(1, y));
                factors.push(((-qy).exp(), qy));
            }
            reach.push((l, sx, sy, qz));
        }
        SliceSplats { reach, factors }
    }

    /// Calls `add(l, x, y, B_l)` for every RBF `l` and voxel `(x, y)` of rows `y0..y1`
    /// inside its support, with a non-zero value.
    pub fn splat(&self, y0: usize, y1: usize, mut add: impl FnMut(usize, usize, usize, f64)) {
        let mut at = 0;
        for &(l, (x0, x1), (ya, yb), qz) in &self.reach {
            let (fx, rest) = self.factors[at..].split_at(x1 - x0 + 1);
            let fy = &rest[..yb - ya + 1];
            at += fx.len() + fy.len();
            let (lo, hi) = (ya.max(y0), yb.min(y1.saturating_sub(1)));
            if lo > hi {
                continue;
            }
            for y in lo..=hi {
                let (ey, qy) = fy[y - ya];
                for (x, &(ex, qx)) in (x0..=x1).zip(fx) {
                    // The support sphere, as `Rbf::eval`: zero from 3 radii out.
                    if qx + qy + qz >= CUTOFF * CUTOFF {
                        continue;
                    }
                    let b = ex * ey;
                    if b != 0.0 {
                        add(l, x, y, b);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;

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
        let mut rng = Pcg64::seed_from_u64(12345);
        let mut rnd = || rng.random::<f64>();
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
                    // Per-axis factors against one `exp`: a few ulps a term.
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
