//! Where the fast renderer's voxels are too thick, and the finer grid it then lights on.
//!
//! **Why.** Compensated ray marching lights the smoke once per voxel: the environment
//! pass, the lights pass and the diffusion give every voxel one radiance `J̃`, taken at
//! its center, and the view pass holds it over the voxel. That is right while light
//! crosses a voxel almost unattenuated. A voxel of optical depth `τ_v = σt·D·h` (density
//! `D`, side `h`) well above 1 is lit on its sunny face and dark a fraction of it further
//! in; its center's radiance is that of the dark inside, while what the eye sees of it is
//! mostly its lit face: the picture comes out too dark. The reference (the same
//! trilinear density, lit at every point) shows how much: on a 64 × 64 × 80 plume
//! (density ≤ 1, `h` = 1) single scattering under the sky is 2 % off at `σt` 0.25,
//! 6 % at 1 and 12.5 % at 4; the same plume at 128- and 256-class with `σt` scaled to
//! keep its total thickness (`τ_v` 2 and 1) is 4.5 % and 2.8 % off.
//!
//! **The switch.** Lit on a grid `n` times finer per axis, a voxel's optical depth is
//! `τ_v/n`: the renderer's volume pass evaluates the RBFs at the fine voxel centers (they
//! are continuous), and the residual, a value per voxel, is resampled to them by the
//! trilinear field every renderer reads ([`crate::field::sample`]), so the fine grid
//! carries the same density. [`factor_for`] picks the smallest `n` with
//! `τ_v/n ≤` [`TAU_PER_VOXEL`] (give or take [`SLACK`]), within a memory budget
//! ([`MAX_FINE_VOXELS`]); time and memory grow as `n³`. Refined so, the 64-class plume
//! at `σt` 4 (`τ_v` 4) is 5.4 % off at `n` 2 and 5.0–5.3 % at 3 and 4 (the rest is the
//! coarse grid's own floor), and the 128-class one at `τ_v` 2 goes from 4.5 % to 2.0 %.
//!
//! `τ_v` is taken at the 99th percentile of the smoke's positive densities, so a few
//! stray dense voxels do not decide it, and along the voxel's longest side.

use crate::field;
use haze_volume::{Bbox, Volume};
use rayon::prelude::*;

/// The optical depth per voxel the fast renderer is trusted to light at voxel
/// resolution: above it, the grid is refined.
pub const TAU_PER_VOXEL: f64 = 1.0;

/// How far over [`TAU_PER_VOXEL`] a voxel may be before it is refined (or, refined as
/// far as allowed, warned about): the density's percentile is not that sharp, and a
/// plume of density 1.003 at `σt·h = 1` is not worth 8× the time.
pub const SLACK: f64 = 0.1;

/// Whether voxels `tau` optical depths thick are within the renderer's validity.
pub fn thin_enough(tau: f64) -> bool {
    tau.is_nan() || tau <= TAU_PER_VOXEL * (1.0 + SLACK)
}

/// The finest refinement per axis.
pub const MAX_FACTOR: usize = 4;

/// The most voxels a refined grid may have (16 M: the volume pass's grids then take about
/// 256 MB).
pub const MAX_FINE_VOXELS: usize = 1 << 24;

/// `σt·D₉₉·h`: the optical depth across one voxel of `density` at the 99th percentile of
/// its positive densities (`h` the voxel's longest side). 0 for a volume with no smoke or
/// a non-positive `σt`; NaN densities are ignored.
pub fn tau_per_voxel(density: &Volume, sigma_t: f64) -> f64 {
    let mut positive: Vec<f32> = density
        .data()
        .iter()
        .copied()
        .filter(|d| *d > 0.0)
        .collect();
    if positive.is_empty() || sigma_t.is_nan() || sigma_t <= 0.0 {
        return 0.0;
    }
    let k = ((positive.len() - 1) as f64 * 0.99).round() as usize;
    let (_, d99, _) = positive.select_nth_unstable_by(k, f32::total_cmp);
    let h = density.voxel_size().into_iter().fold(0.0, f64::max);
    let tau = sigma_t * f64::from(*d99) * h;
    if tau.is_finite() { tau } else { f64::MAX }
}

/// The refinement chosen for a grid of `dims` whose voxels are `tau` optical depths
/// thick: the smallest `n ≤ MAX_FACTOR` with `tau/n ≤ TAU_PER_VOXEL` ([`thin_enough`]),
/// lowered until the fine grid holds at most `max_voxels` (at most [`MAX_FINE_VOXELS`];
/// a GPU's buffers may allow fewer). Also whether that `n` falls short (the caller warns).
pub fn factor_for(tau: f64, dims: [usize; 3], max_voxels: usize) -> (usize, bool) {
    let wanted = (1..=MAX_FACTOR)
        .find(|&n| thin_enough(tau / n as f64))
        .unwrap_or(MAX_FACTOR);
    let mut n = wanted;
    while n > 1 && !fits(dims, n, max_voxels) {
        n -= 1;
    }
    (n, !thin_enough(tau / n as f64))
}

/// Whether `dims` refined `n` times holds at most `max_voxels` and [`MAX_FINE_VOXELS`]
/// voxels.
pub fn fits(dims: [usize; 3], n: usize, max_voxels: usize) -> bool {
    dims.iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d.checked_mul(n)?))
        .is_some_and(|v| v <= MAX_FINE_VOXELS.min(max_voxels))
}

/// `dims` refined `n` times per axis.
pub fn fine_dims(dims: [usize; 3], n: usize) -> [usize; 3] {
    dims.map(|d| d * n.max(1))
}

/// Per-voxel `values` on a `dims` grid over `bbox`, resampled to the voxel centers of the
/// grid `n` times finer by the trilinear field between the coarse centers (constant to
/// the box's faces), x fastest. `n = 1` returns the values as they are.
pub fn refine(values: &[f32], dims: [usize; 3], bbox: &Bbox, n: usize) -> Vec<f32> {
    if n <= 1 {
        return values.to_vec();
    }
    let Ok(coarse) = Volume::new(dims, *bbox, values.to_vec()) else {
        return values.to_vec();
    };
    let fine = fine_dims(dims, n);
    let size = bbox.size();
    let h = [0, 1, 2].map(|a| size[a] / fine[a].max(1) as f64);
    let plane = fine[0] * fine[1];
    let mut out = vec![0.0f32; plane * fine[2]];
    out.par_chunks_mut(plane.max(1))
        .enumerate()
        .for_each(|(z, slice)| {
            let pz = bbox.min[2] + (z as f64 + 0.5) * h[2];
            for (i, o) in slice.iter_mut().enumerate() {
                let px = bbox.min[0] + ((i % fine[0]) as f64 + 0.5) * h[0];
                let py = bbox.min[1] + ((i / fine[0]) as f64 + 0.5) * h[1];
                *o = field::sample(&coarse, [px, py, pz]) as f32;
            }
        });
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn volume(dims: [usize; 3], size: [f64; 3], f: impl Fn(usize) -> f32) -> Volume {
        let n = dims.iter().product();
        Volume::new(dims, Bbox::new([0.0; 3], size), (0..n).map(f).collect()).unwrap()
    }

    #[test]
    fn tau_is_sigma_t_times_the_99th_percentile_times_the_longest_side() {
        // 1000 voxels with densities 0.001..1.000; voxel 0.5 × 0.25 × 2.
        let v = volume([10, 10, 10], [5.0, 2.5, 20.0], |i| (i + 1) as f32 / 1000.0);
        // The 99th percentile of 1..1000 (rank round(999·0.99) = 989) is 0.990.
        let want = 3.0 * 0.990 * 2.0;
        assert!((tau_per_voxel(&v, 3.0) - want).abs() < 1e-6);
        // One stray dense voxel does not move it.
        let mut data = v.data().to_vec();
        data[999] = 1e6;
        let v2 = Volume::new(v.dims(), *v.bbox(), data).unwrap();
        assert!((tau_per_voxel(&v2, 3.0) - want).abs() < 1e-6);
    }

    #[test]
    fn tau_at_its_extremes() {
        let empty = volume([4, 4, 4], [4.0; 3], |_| 0.0);
        assert_eq!(tau_per_voxel(&empty, 4.0), 0.0);
        let nan = volume(
            [4, 4, 4],
            [4.0; 3],
            |i| if i % 2 == 0 { f32::NAN } else { 0.5 },
        );
        assert!((tau_per_voxel(&nan, 4.0) - 2.0).abs() < 1e-12);
        let some = volume([4, 4, 4], [4.0; 3], |_| 1.0);
        assert_eq!(tau_per_voxel(&some, 0.0), 0.0);
        assert_eq!(tau_per_voxel(&some, f64::NAN), 0.0);
        assert_eq!(tau_per_voxel(&some, f64::INFINITY), f64::MAX);
        let huge = volume([4, 4, 4], [4e300; 3], |_| f32::MAX);
        assert_eq!(tau_per_voxel(&huge, 1e300), f64::MAX);
    }

    #[test]
    fn the_factor_brings_tau_under_the_limit_within_the_budget() {
        let small = [32, 32, 32];
        assert_eq!(factor_for(0.0, small, MAX_FINE_VOXELS), (1, false));
        assert_eq!(
            factor_for(TAU_PER_VOXEL, small, MAX_FINE_VOXELS),
            (1, false)
        );
        // Within the slack: as it is.
        assert_eq!(
            factor_for(1.09 * TAU_PER_VOXEL, small, MAX_FINE_VOXELS),
            (1, false)
        );
        assert_eq!(
            factor_for(1.11 * TAU_PER_VOXEL, small, MAX_FINE_VOXELS),
            (2, false)
        );
        assert_eq!(
            factor_for(3.0 * TAU_PER_VOXEL, small, MAX_FINE_VOXELS),
            (3, false)
        );
        assert_eq!(
            factor_for(4.3 * TAU_PER_VOXEL, small, MAX_FINE_VOXELS),
            (4, false)
        );
        // Beyond the finest refinement: as far as it goes, and said.
        assert_eq!(
            factor_for(100.0, small, MAX_FINE_VOXELS),
            (MAX_FACTOR, true)
        );
        assert_eq!(
            factor_for(f64::MAX, small, MAX_FINE_VOXELS),
            (MAX_FACTOR, true)
        );
        // 256³ × 2³ is 134 M voxels: over the budget, so none.
        assert_eq!(factor_for(2.0, [256, 256, 256], MAX_FINE_VOXELS), (1, true));
        // 128³ × 2³ = 16.8 M fits exactly; × 3³ does not.
        assert_eq!(factor_for(3.0, [128, 128, 128], MAX_FINE_VOXELS), (2, true));
        // Dimensions that overflow usize never refine.
        assert_eq!(
            factor_for(4.0, [usize::MAX, 1, 1], MAX_FINE_VOXELS),
            (1, true)
        );
        assert!(!fits([usize::MAX, 2, 1], 1, usize::MAX));
        assert!(fits([1 << 8, 1 << 8, 1 << 8], 1, usize::MAX));
        // A smaller budget (a GPU's buffers) lowers the factor.
        assert_eq!(factor_for(3.0, small, 8 * 32 * 32 * 32), (2, true));
        assert_eq!(factor_for(3.0, small, 0), (1, true));
        // NaN never refines.
        assert_eq!(factor_for(f64::NAN, small, MAX_FINE_VOXELS), (1, false));
    }

    #[test]
    fn refine_reproduces_the_trilinear_field() {
        // A linear field is reproduced exactly between the coarse centers, and held
        // constant beyond them (the field's clamp to the faces).
        let dims = [4, 3, 5];
        let size = [8.0, 3.0, 5.0];
        let bbox = Bbox::new([0.0; 3], size);
        let lin = |p: [f64; 3]| 1.0 + 0.5 * p[0] - 0.25 * p[1] + 2.0 * p[2];
        let coarse: Vec<f32> = (0..60)
            .map(|i| {
                let k = [i % 4, (i / 4) % 3, i / 12];
                let c = [0, 1, 2].map(|a| (k[a] as f64 + 0.5) * size[a] / dims[a] as f64);
                lin(c) as f32
            })
            .collect();
        for n in [1, 2, 3] {
            let fine = refine(&coarse, dims, &bbox, n);
            let fd = fine_dims(dims, n);
            assert_eq!(fine.len(), fd.iter().product::<usize>());
            for (i, v) in fine.iter().enumerate() {
                let k = [i % fd[0], (i / fd[0]) % fd[1], i / (fd[0] * fd[1])];
                let p = [0, 1, 2].map(|a| (k[a] as f64 + 0.5) * size[a] / fd[a] as f64);
                // Clamped to the span of the coarse centers, per axis.
                let c = [0, 1, 2].map(|a| {
                    let h = size[a] / dims[a] as f64;
                    p[a].clamp(0.5 * h, size[a] - 0.5 * h)
                });
                assert!(
                    (f64::from(*v) - lin(c)).abs() < 1e-5 * lin(c).abs().max(1.0),
                    "n {n}, voxel {k:?}: {v} vs {}",
                    lin(c)
                );
            }
        }
        // Refining a constant field keeps it; the mean of a refined field is the coarse
        // mean's within the clamp's edge effect (here: none, constant).
        let ones = vec![0.75f32; 60];
        assert!(refine(&ones, dims, &bbox, 2).iter().all(|v| *v == 0.75));
    }
}
