//! Exchanging RBFs at a frame's ceiling: where a warm frame may not grow, its RBFs that
//! lower the error least make room for new ones where they would lower it most (the
//! warm-frame counterpart of the first frame's teleportation, paper A §5.1).
//!
//! With the residual `R = D − D̃`, removing an RBF `w·g` turns it into `R + w·g`, so
//! `ΣR²` grows by its removal cost `Σ(2R·wg + (wg)²)` over the RBF's support (exact for
//! one RBF; at a converged fit `⟨R, g⟩ ≈ 0` and the cost is about `w²⟨g, g⟩`). Matching
//! pursuit predicts each new RBF's gain ([`crate::init::matched_with_gains`]). Pairing the
//! `k`-th largest gain with the `k`-th smallest cost, an exchange pays while the gain
//! exceeds the cost; RBFs near one another interact, so the minimization that follows
//! ([`crate::local`]), not the prediction, decides whether a round is kept.

use crate::grid::FitGrid;
use crate::objective::PARAMS_PER_RBF;
use haze_volume::Rbf;
use haze_volume::rbf::voxel_span;
use rayon::prelude::*;

/// The increase of `ΣR²` (normalized density², summed over voxels) if each RBF of
/// `params` (unit-cube parameters) were removed from the fit whose residual
/// `D − D̃` is `residual` (one value per voxel of `grid`).
pub fn removal_costs(grid: &FitGrid, residual: &[f64], params: &[f64]) -> Vec<f64> {
    params
        .par_chunks(PARAMS_PER_RBF)
        .map(|p| {
            let rbf = Rbf::new([p[0], p[1], p[2]], p[3], p[4]);
            let s = rbf.support_radius();
            let mut span = [(0, 0); 3];
            for a in 0..3 {
                match voxel_span(p[a] - s, p[a] + s, 0.0, grid.h[a], grid.dims[a]) {
                    Some(r) => span[a] = r,
                    None => return 0.0,
                }
            }
            let mut cost = 0.0;
            for z in span[2].0..=span[2].1 {
                for y in span[1].0..=span[1].1 {
                    for x in span[0].0..=span[0].1 {
                        let i = grid.index(x, y, z);
                        let g = rbf.eval(grid.center(i));
                        cost += g * (2.0 * residual[i] + g);
                    }
                }
            }
            cost
        })
        .collect()
}

/// The exchanges that pay: the largest `k` such that the `k`-th largest of `gains`
/// exceeds the `k`-th smallest of `costs`. Returns the indices into `gains` of the new
/// RBFs to add and the indices into `costs` of the RBFs to remove (each list `k` long,
/// the removals in increasing index order).
pub fn paying_exchanges(gains: &[f64], costs: &[f64]) -> (Vec<usize>, Vec<usize>) {
    let mut add: Vec<usize> = (0..gains.len()).collect();
    add.sort_by(|&a, &b| gains[b].total_cmp(&gains[a]).then(a.cmp(&b)));
    let mut remove: Vec<usize> = (0..costs.len()).collect();
    remove.sort_by(|&a, &b| costs[a].total_cmp(&costs[b]).then(a.cmp(&b)));
    let k = add
        .iter()
        .zip(&remove)
        .take_while(|&(&a, &r)| gains[a] > costs[r])
        .count();
    add.truncate(k);
    remove.truncate(k);
    remove.sort_unstable();
    (add, remove)
}

#[cfg(test)]
mod tests {
    use super::{paying_exchanges, removal_costs};
    use crate::grid::FitGrid;
    use crate::objective::{self, PARAMS_PER_RBF};
    use haze_volume::{Bbox, Volume};

    /// Each RBF's removal cost equals `ΣR²` of the fit without it minus `ΣR²` with it,
    /// both from full passes over the grid, for RBFs inside, overlapping and at the edge.
    #[test]
    fn removal_cost_is_the_error_of_the_fit_without_the_rbf() {
        let b = Bbox::new([0.0; 3], [12.0, 10.0, 8.0]);
        let mut v = Volume::zeros([12, 10, 8], b).unwrap();
        for i in 0..v.len() {
            v.data_mut()[i] = ((i * 17) % 11) as f32 / 10.0;
        }
        let g = FitGrid::from_volume(&v).unwrap();
        let p = [
            0.4, 0.5, 0.5, 0.12, 0.6, //
            0.45, 0.5, 0.55, 0.08, 0.3, //
            0.02, 0.95, 0.1, 0.1, 0.9,
        ];
        let r = objective::residual(&g, &p);
        let with: f64 = r.iter().map(|v| v * v).sum();
        let costs = removal_costs(&g, &r, &p);
        for (l, &c) in costs.iter().enumerate() {
            let mut q = p.to_vec();
            q.drain(l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF);
            let without: f64 = objective::residual(&g, &q).iter().map(|v| v * v).sum();
            let want = without - with;
            assert!(
                (c - want).abs() <= 1e-9 * with.max(1.0),
                "RBF {l}: {c} vs {want}"
            );
        }
    }

    /// Pairs the largest gains with the smallest costs while the gain is larger.
    #[test]
    fn exchanges_pay_pairwise() {
        let (add, remove) = paying_exchanges(&[1.0, 5.0, 3.0, 0.5], &[2.0, 0.1, 4.0, 1.0]);
        // 5 > 0.1, 3 > 1, 1 < 2: two exchanges.
        assert_eq!(add, vec![1, 2]);
        assert_eq!(remove, vec![1, 3]);
        assert_eq!(paying_exchanges(&[1.0], &[2.0]), (vec![], vec![]));
        assert_eq!(paying_exchanges(&[], &[2.0]), (vec![], vec![]));
        assert_eq!(paying_exchanges(&[3.0, 2.0], &[1.0]), (vec![0], vec![0]));
    }
}
