//! Minimizing some RBFs with the others frozen: after a warm frame's insertion or
//! exchange round, the new (and removed) RBFs and those whose supports overlap theirs are
//! fitted against the residual of the rest.
//!
//! With the RBFs split into free ones `F` and frozen ones, `R = D − Σ_frozen − Σ_F`, so the
//! objective of paper A §5.1 restricted to `F` is the same objective on the background
//! `D' = D − Σ_frozen`: `ΣR² / ΣD² = (ΣR² / ΣD'²) · ΣD'² / ΣD²`, the frozen RBFs' gradient
//! entries are not needed, and the free ones' equal those of the full objective times
//! `ΣD'² / ΣD²`. The background costs one residual pass; every pass after it touches only
//! the free RBFs' supports ([`crate::objective`]). At 1200 RBFs a round of 3 frees
//! 50–80 of them and converges in 30–45 iterations, where a joint minimization ran its
//! 200 over all 1200; a round of hundreds frees nearly all, and costs what the joint
//! minimization did (BENCHMARKS.md, "Warm frames at the ceiling: the time split").

use crate::bounds::Bounds;
use crate::grid::FitGrid;
use crate::objective::{self, PARAMS_PER_RBF};
use crate::optimize::{Minimized, Optimizer, Stop, minimize};
use haze_volume::rbf::CUTOFF;

/// The RBFs of `params` whose supports (`3r` spheres) overlap the support of at least one
/// of the RBFs `seeds` (both unit-cube parameters), in increasing order: the RBFs a
/// round's new ones (and removed ones) change the residual under.
pub fn overlapping(params: &[f64], seeds: &[f64]) -> Vec<usize> {
    params
        .chunks(PARAMS_PER_RBF)
        .enumerate()
        .filter(|(_, a)| {
            seeds.chunks(PARAMS_PER_RBF).any(|b| {
                let d2: f64 = (0..3).map(|k| (a[k] - b[k]).powi(2)).sum();
                let reach = CUTOFF * (a[3] + b[3]);
                d2 < reach * reach
            })
        })
        .map(|(l, _)| l)
        .collect()
}

/// The background grid of the RBFs of `params` not in `free` (sorted): the density minus
/// their sum, with `sum_sq` its own `ΣD'²` (which the objective's passes over the
/// reached voxels need).
pub fn background(grid: &FitGrid, params: &[f64], free: &[usize]) -> FitGrid {
    let frozen: Vec<f64> = params
        .chunks(PARAMS_PER_RBF)
        .enumerate()
        .filter(|(l, _)| free.binary_search(l).is_err())
        .flat_map(|(_, p)| p.iter().copied())
        .collect();
    let mut bg = grid.residual_grid(objective::residual(grid, &frozen));
    bg.sum_sq = bg.density.iter().map(|d| d * d).sum();
    bg
}

/// `ΣR²/ΣD'²` on `bg` as the objective `ΣR²/ΣD²` on `grid` (see the module docs).
pub fn full_cost(grid: &FitGrid, bg: &FitGrid, f: f64) -> f64 {
    // The objective leaves ΣR² unnormalized on a grid whose ΣD² is 0.
    let e = if bg.sum_sq > 0.0 { f * bg.sum_sq } else { f };
    if grid.sum_sq > 0.0 {
        e / grid.sum_sq
    } else {
        e
    }
}

/// Minimizes the RBFs `free` (sorted indices) of `params` in place with the others
/// frozen; the cost returned is the objective of all RBFs on `grid`.
pub fn minimize_free(
    grid: &FitGrid,
    params: &mut [f64],
    free: &[usize],
    bounds: &Bounds,
    optimizer: Optimizer,
    stop: Stop,
) -> Minimized {
    let bg = background(grid, params, free);
    let at = |l: usize| l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF;
    let mut sub: Vec<f64> = free.iter().flat_map(|&l| params[at(l)].to_vec()).collect();
    let mut m = minimize(&bg, &mut sub, bounds, optimizer, stop);
    for (&l, p) in free.iter().zip(sub.chunks(PARAMS_PER_RBF)) {
        params[at(l)].copy_from_slice(p);
    }
    m.cost = full_cost(grid, &bg, m.cost);
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::{Bbox, Volume};

    fn grid() -> FitGrid {
        let dims = [22, 18, 16];
        let b = Bbox::new([0.0; 3], [22.0, 18.0, 16.0]);
        let mut v = Volume::zeros(dims, b).unwrap();
        for i in 0..v.len() {
            let [x, y, z] = v.coords(i);
            let d2 = (x as f64 - 9.0).powi(2) + (y as f64 - 8.0).powi(2) + (z as f64 - 7.0).powi(2);
            v.data_mut()[i] = ((-d2 / 20.0).exp() + 0.1 * ((x * 7 + y * 3 + z) % 5) as f64) as f32;
        }
        FitGrid::from_volume(&v).unwrap()
    }

    const PARAMS: [f64; 20] = [
        0.40, 0.42, 0.30, 0.05, 0.6, //
        0.45, 0.40, 0.33, 0.04, 0.3, //
        0.10, 0.12, 0.60, 0.03, 0.5, //
        0.80, 0.70, 0.10, 0.04, 0.4,
    ];

    /// The background objective, rescaled, is the full objective, and its gradient is the
    /// full gradient's entries of the free RBFs times `ΣD'²/ΣD²`, both from full passes
    /// over all the RBFs.
    #[test]
    fn background_objective_is_the_full_objective_on_the_free_rbfs() {
        let g = grid();
        let free = [1, 2];
        let bg = background(&g, &PARAMS, &free);
        let sub: Vec<f64> = free
            .iter()
            .flat_map(|&l| PARAMS[l * 5..l * 5 + 5].to_vec())
            .collect();
        let mut gb = vec![0.0; sub.len()];
        let fb = objective::cost_and_gradient(&bg, &sub, &mut gb);
        let mut gf = vec![0.0; PARAMS.len()];
        let f = objective::cost_and_gradient(&g, &PARAMS, &mut gf);
        assert!(
            (full_cost(&g, &bg, fb) - f).abs() < 1e-12 * f,
            "{fb} vs {f}"
        );
        let ratio = bg.sum_sq / g.sum_sq;
        for (k, &l) in free.iter().enumerate() {
            for j in 0..5 {
                let want = gf[l * 5 + j];
                let got = gb[k * 5 + j] * ratio;
                assert!(
                    (got - want).abs() < 1e-10 * want.abs().max(1e-9),
                    "RBF {l} parameter {j}: {got} vs {want}"
                );
            }
        }
    }

    /// A free minimization moves only the free RBFs, lowers the objective, and returns the
    /// objective of all the RBFs as a full pass computes it.
    #[test]
    fn free_minimization_moves_the_free_rbfs_only() {
        let g = grid();
        let bounds = Bounds::default();
        let mut p = PARAMS.to_vec();
        for q in p.chunks_mut(5) {
            bounds.clamp(&g, q);
        }
        let before = objective::cost(&g, &p);
        let start = p.clone();
        let m = minimize_free(
            &g,
            &mut p,
            &[0, 2],
            &bounds,
            Optimizer::Lbfgsb,
            Stop::default(),
        );
        assert!(m.cost < before, "{} vs {before}", m.cost);
        assert!(
            (m.cost - objective::cost(&g, &p)).abs() < 1e-12,
            "{} vs {}",
            m.cost,
            objective::cost(&g, &p)
        );
        assert_eq!(p[5..10], start[5..10]);
        assert_eq!(p[15..20], start[15..20]);
        assert_ne!(p[0..5], start[0..5]);
    }

    /// The extremes: no free RBF leaves the parameters as they were and returns their full
    /// objective; every RBF free is the joint minimization (the background is the density
    /// itself); an empty frame (`ΣD² = 0`, background 0) gives the unnormalized `ΣR²` that
    /// the full objective gives there, finite.
    #[test]
    fn extremes_none_free_all_free_empty_frame() {
        let g = grid();
        let bounds = Bounds::default();
        let mut p = PARAMS.to_vec();
        for q in p.chunks_mut(5) {
            bounds.clamp(&g, q);
        }
        let start = p.clone();
        let stop = Stop {
            max_iterations: 30,
            ..Stop::default()
        };
        let none = minimize_free(&g, &mut p, &[], &bounds, Optimizer::Lbfgsb, stop);
        assert_eq!(p, start);
        assert!((none.cost - objective::cost(&g, &p)).abs() < 1e-12);
        let all = minimize_free(&g, &mut p, &[0, 1, 2, 3], &bounds, Optimizer::Lbfgsb, stop);
        let mut joint = start.clone();
        let j = minimize(&g, &mut joint, &bounds, Optimizer::Lbfgsb, stop);
        assert!(
            (all.cost - j.cost).abs() <= 1e-12 * j.cost,
            "{} vs {}",
            all.cost,
            j.cost
        );
        for (a, b) in p.iter().zip(&joint) {
            assert!((a - b).abs() <= 1e-9, "{a} vs {b}");
        }
        let b = Bbox::new([0.0; 3], [22.0, 18.0, 16.0]);
        let empty = FitGrid::from_volume(&Volume::zeros([22, 18, 16], b).unwrap()).unwrap();
        let mut q = start.clone();
        let m = minimize_free(&empty, &mut q, &[1], &bounds, Optimizer::Lbfgsb, stop);
        assert!(m.cost.is_finite() && m.cost >= 0.0, "{}", m.cost);
        assert!((m.cost - objective::cost(&empty, &q)).abs() <= 1e-12 * m.cost.max(1.0));
    }

    /// Overlap is `|c_a − c_b| < 3(r_a + r_b)`, checked against the distances.
    #[test]
    fn overlapping_supports() {
        // RBF 0 and 1: 0.058 apart < 0.27; 0 and 2: 0.45 apart > 0.24; 3 far from all.
        let rbf = |l: usize| PARAMS[l * 5..l * 5 + 5].to_vec();
        assert_eq!(overlapping(&PARAMS, &rbf(0)), vec![0, 1]);
        assert_eq!(overlapping(&PARAMS, &rbf(2)), vec![2]);
        assert_eq!(
            overlapping(&PARAMS, &[rbf(1), rbf(3)].concat()),
            vec![0, 1, 3]
        );
        assert!(overlapping(&PARAMS, &[]).is_empty());
        // A seed of radius 0.06 between RBFs 0 and 2 (0.260 from each, 0.267 from 1)
        // reaches all three: 0.26 < 3 · (0.03 + 0.06) = 0.27, not RBF 3 (0.78 away).
        let mid = [0.25, 0.27, 0.45, 0.06, 0.1];
        assert_eq!(overlapping(&PARAMS, &mid), vec![0, 1, 2]);
    }
}
