//! A warm frame's minimizations ([`crate::sequence`]): on the half-resolution grid first
//! where [`Coarse`] applies, then a short polish at full resolution.
//!
//! A warm start of fast, turbulent smoke sits far from its optimum: its centers move a
//! tenth of the box a frame, and a minimization at full resolution creeps down for its
//! whole budget (80 iterations), each pass over RBFs a dozen voxels wide. The coarse
//! grid ([`FitGrid::downsampled`]: the density box-filtered over 2 × 2 × 2 voxels, the
//! same unit cube, normalization and radius floor, so the parameters mean the same on
//! both) has an eighth of the voxels, and its optimum lies within a fraction of a fine
//! voxel of the fine one for RBFs wider than a coarse voxel: the long walk is taken there
//! at an eighth of the cost, and `polish` iterations at full resolution finish it. On a
//! held-out turbulent plume that cuts the warm frames' time by 40–45 % at the same RBF
//! count and error (BENCHMARKS.md, decision 0057).
//! [`Coarse::Auto`] follows the frame ([`coarse_suits`]): below [`Coarse::AUTO_VOXELS`] a
//! pass is cheap, and RBFs narrower than a coarse voxel are blurred and aliased by the
//! coarse grid, so there every iteration runs at full resolution.
//!
//! The same two stages serve every warm minimization: of all RBFs after the deletions,
//! and of the RBFs an insertion or exchange round frees ([`crate::local`]).

use crate::bounds::Bounds;
use crate::frame::{Coarse, FitStats};
use crate::grid::FitGrid;
use crate::local::minimize_free;
use crate::objective::PARAMS_PER_RBF;
use crate::optimize::{Minimized, Optimizer, Stop, minimize};

/// The warm minimizations of one frame's grid.
#[derive(Debug)]
pub struct WarmMinimizer<'a> {
    grid: &'a FitGrid,
    /// The half-resolution grid, where the first stage runs (`None`: full resolution only).
    coarse: Option<FitGrid>,
    bounds: &'a Bounds,
    optimizer: Optimizer,
    /// The first stage's stopping rule (the only stage without a coarse grid).
    stop: Stop,
    /// The full-resolution polish's after a coarse stage: `stop` with its own budget.
    polish: Stop,
}

/// One warm minimization: its stages' counts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WarmMinimized {
    /// The half-resolution stage, if one ran.
    pub coarse: Option<Minimized>,
    /// The full-resolution stage: its cost is the objective at the parameters returned.
    pub fine: Minimized,
}

impl WarmMinimized {
    /// Objective passes of both stages (a coarse pass costs about an eighth of a fine one).
    pub fn passes(&self) -> u64 {
        self.coarse.map_or(0, |c| c.passes) + self.fine.passes
    }

    /// `ΣR²/ΣD²` on the full-resolution grid at the parameters returned.
    pub fn cost(&self) -> f64 {
        self.fine.cost
    }

    /// Adds both stages' counts to `stats` (the coarse one's as half-resolution iterations).
    pub fn add_to(&self, stats: &mut FitStats) {
        if let Some(c) = &self.coarse {
            stats.add(c, true);
        }
        stats.add(&self.fine, false);
    }
}

/// The radius, in the frame's voxels, that [`Coarse::Auto`] asks of a quarter of a warm
/// start's RBFs at least for the coarse stage: one coarse voxel (two fine ones).
pub const MIN_COARSE_RADIUS: f64 = 2.0;

/// Whether a warm start `params` (unit-cube parameters) on `grid` minimizes on the
/// half-resolution grid first: `Always` on any grid of at least 2 voxels a side, `Never`
/// never, `Auto` on grids of [`Coarse::AUTO_VOXELS`] or more whose RBFs are wide: the
/// radius three quarters of them reach or pass is at least [`MIN_COARSE_RADIUS`] voxels.
/// Narrower RBFs are what the box filter of a coarse voxel blurs and its sampling
/// aliases: there the coarse optimum lies farther from the fine one than a short polish
/// walks back (on a slow held-out plume whose RBFs are 1–2.5 voxels, a coarse stage left
/// 17 of 25 warm frames over the error threshold with a third more RBFs; the turbulent
/// plume's RBFs are 2.6–7.7 voxels, BENCHMARKS.md).
pub fn coarse_suits(coarse: Coarse, grid: &FitGrid, params: &[f64]) -> bool {
    match coarse {
        Coarse::Never => false,
        Coarse::Always => coarse.applies(grid),
        Coarse::Auto => {
            if !coarse.applies(grid) {
                return false;
            }
            let mut radii: Vec<f64> = params.chunks_exact(PARAMS_PER_RBF).map(|p| p[3]).collect();
            if radii.is_empty() {
                return false;
            }
            let k = radii.len() / 4;
            let (_, quartile, _) = radii.select_nth_unstable_by(k, f64::total_cmp);
            *quartile >= MIN_COARSE_RADIUS * grid.full_h
        }
    }
}

impl<'a> WarmMinimizer<'a> {
    /// Minimizations on `grid` of RBFs starting at `params`, coarse to fine where
    /// [`coarse_suits`] says so: the first stage stops by `stop`, the polish after a
    /// coarse stage by `stop` with at most `polish_iterations` (at least 1, so that the
    /// cost returned is the fine grid's).
    pub fn new(
        grid: &'a FitGrid,
        coarse: Coarse,
        params: &[f64],
        bounds: &'a Bounds,
        optimizer: Optimizer,
        stop: Stop,
        polish_iterations: u64,
    ) -> Self {
        WarmMinimizer {
            grid,
            coarse: coarse_suits(coarse, grid, params).then(|| grid.downsampled()),
            bounds,
            optimizer,
            stop,
            polish: Stop {
                max_iterations: polish_iterations.max(1),
                ..stop
            },
        }
    }

    /// Whether the first stage runs on the half-resolution grid.
    pub fn is_coarse(&self) -> bool {
        self.coarse.is_some()
    }

    /// Minimizes every RBF of `params` (unit-cube parameters) in place.
    pub fn all(&self, params: &mut Vec<f64>) -> WarmMinimized {
        let (b, o) = (self.bounds, self.optimizer);
        match &self.coarse {
            Some(coarse) => WarmMinimized {
                coarse: Some(minimize(coarse, params, b, o, self.stop)),
                fine: minimize(self.grid, params, b, o, self.polish),
            },
            None => WarmMinimized {
                coarse: None,
                fine: minimize(self.grid, params, b, o, self.stop),
            },
        }
    }

    /// Minimizes the RBFs `free` of `params` in place, the others frozen
    /// ([`minimize_free`]).
    pub fn free(&self, params: &mut [f64], free: &[usize]) -> WarmMinimized {
        let (b, o) = (self.bounds, self.optimizer);
        match &self.coarse {
            Some(coarse) => WarmMinimized {
                coarse: Some(minimize_free(coarse, params, free, b, o, self.stop)),
                fine: minimize_free(self.grid, params, free, b, o, self.polish),
            },
            None => WarmMinimized {
                coarse: None,
                fine: minimize_free(self.grid, params, free, b, o, self.stop),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::objective;
    use haze_volume::{Bbox, Volume};

    /// A 72 × 64 × 64 grid (above 64³ voxels: `Auto` goes coarse) of three wide
    /// Gaussian blobs.
    fn blobs() -> FitGrid {
        let dims = [72, 64, 64];
        let b = Bbox::new([0.0; 3], [72.0, 64.0, 64.0]);
        let mut v = Volume::zeros(dims, b).unwrap();
        let centers = [[24.0, 30.0, 28.0], [46.0, 34.0, 36.0], [36.0, 22.0, 40.0]];
        for i in 0..v.len() {
            let [x, y, z] = v.coords(i);
            let p = [x as f64, y as f64, z as f64];
            let d: f64 = centers
                .iter()
                .map(|c| {
                    let r2: f64 = (0..3).map(|a| (p[a] - c[a]).powi(2)).sum();
                    (-r2 / 36.0).exp()
                })
                .sum();
            v.data_mut()[i] = d as f32;
        }
        FitGrid::from_volume(&v).unwrap()
    }

    /// Unit-cube parameters of the blobs (radius 6 voxels), each center off by about a
    /// voxel and a half and the radius by one: a warm start that has moved.
    fn moved(grid: &FitGrid) -> Vec<f64> {
        // World units are voxels here; the unit cube's side is the longest, 72.
        let s = grid.unit;
        let centers = [[25.5, 29.0, 29.5], [44.8, 35.2, 35.0], [37.2, 21.0, 41.3]];
        centers
            .iter()
            .flat_map(|c| [c[0] / s, c[1] / s, c[2] / s, 5.0 / s, 0.8])
            .collect()
    }

    /// A per-iteration stop at `10⁻¹²` (to convergence) with at most `max_iterations`.
    fn tight(max_iterations: u64) -> Stop {
        Stop {
            max_iterations,
            relative_reduction: 1e-12,
            window: 0,
            window_gain: 0.0,
        }
    }

    /// Coarse then fine reaches the full-resolution minimization's minimum, the cost it
    /// reports is the fine grid's, and the fine stage keeps to the polish's budget.
    #[test]
    fn coarse_then_polish_reaches_the_fine_optimum_and_reports_the_fine_cost() {
        let grid = blobs();
        let bounds = Bounds::default();
        let stop = tight(200);
        let start = moved(&grid);
        let start_cost = objective::cost(&grid, &start);
        let fine_only = WarmMinimizer::new(
            &grid,
            Coarse::Never,
            &start,
            &bounds,
            Default::default(),
            stop,
            20,
        );
        assert!(!fine_only.is_coarse());
        let mut p_fine = start.clone();
        let f = fine_only.all(&mut p_fine);
        assert!(f.coarse.is_none());
        let two = WarmMinimizer::new(
            &grid,
            Coarse::Auto,
            &start,
            &bounds,
            Default::default(),
            stop,
            20,
        );
        assert!(two.is_coarse());
        let mut p_two = start.clone();
        let w = two.all(&mut p_two);
        let c = w.coarse.expect("a coarse stage");
        assert!(w.fine.iterations <= 20, "{w:?}");
        assert_eq!(w.passes(), c.passes + w.fine.passes);
        // The reported cost is the objective on the full grid at the returned parameters.
        let exact = objective::cost(&grid, &p_two);
        assert!(
            (w.cost() - exact).abs() <= 1e-12 * exact.max(1e-30),
            "{} {exact}",
            w.cost()
        );
        assert!(f.cost() < 0.01 * start_cost, "{} {start_cost}", f.cost());
        assert!(w.cost() < 0.01 * start_cost, "{} {start_cost}", w.cost());
        // Both end by the same per-iteration test at the same minimum (here 8·10⁻⁸ from 0.27,
        // equal to 2·10⁻¹³): the coarse walk must not leave the polish elsewhere.
        assert!(
            (w.cost() - f.cost()).abs() <= 1e-4 * start_cost,
            "{} {}",
            w.cost(),
            f.cost()
        );
        // The counts land in the stats, the coarse ones as half-resolution iterations.
        let mut stats = FitStats::default();
        w.add_to(&mut stats);
        assert_eq!(stats.iterations, c.iterations + w.fine.iterations);
        assert_eq!(stats.coarse_iterations, c.iterations);
    }

    /// Freed RBFs only: the frozen ones do not move on either stage.
    #[test]
    fn a_free_minimization_leaves_the_frozen_rbfs_on_both_stages() {
        let grid = blobs();
        let bounds = Bounds::default();
        let stop = tight(50);
        let start = moved(&grid);
        let two = WarmMinimizer::new(
            &grid,
            Coarse::Always,
            &start,
            &bounds,
            Default::default(),
            stop,
            10,
        );
        let mut p = start.clone();
        let w = two.free(&mut p, &[1]);
        assert!(w.coarse.is_some());
        assert_eq!(p[..5], start[..5]);
        assert_eq!(p[10..], start[10..]);
        assert_ne!(p[5..10], start[5..10]);
        let exact = objective::cost(&grid, &p);
        assert!(
            (w.cost() - exact).abs() <= 1e-9 * exact.max(1e-30),
            "{} {exact}",
            w.cost()
        );
        assert!(w.cost() < objective::cost(&grid, &start));
    }

    /// A polish budget of 0 is taken as 1: the fine stage still runs, so the cost reported
    /// is the full-resolution objective at the parameters returned, not the coarse one.
    #[test]
    fn a_zero_polish_still_reports_the_fine_cost() {
        let grid = blobs();
        let bounds = Bounds::default();
        let start = moved(&grid);
        let two = WarmMinimizer::new(
            &grid,
            Coarse::Always,
            &start,
            &bounds,
            Default::default(),
            tight(30),
            0,
        );
        let mut p = start.clone();
        let w = two.all(&mut p);
        assert!(w.coarse.is_some() && w.fine.iterations <= 1, "{w:?}");
        let exact = objective::cost(&grid, &p);
        assert!(
            (w.cost() - exact).abs() <= 1e-12 * exact,
            "{} {exact}",
            w.cost()
        );
        assert!(w.cost() < objective::cost(&grid, &start));
    }

    /// `Auto` goes coarse only on a grid of 64³ voxels or more whose RBFs are a coarse
    /// voxel wide or wider in three quarters of them; `Always` and `Never` as they say.
    #[test]
    fn auto_goes_coarse_only_for_wide_rbfs_on_large_grids() {
        let grid = blobs();
        let h = grid.full_h;
        let with_radii = |radii: &[f64]| -> Vec<f64> {
            radii
                .iter()
                .flat_map(|&r| [0.5, 0.5, 0.5, r * h, 0.5])
                .collect()
        };
        assert!(coarse_suits(
            Coarse::Auto,
            &grid,
            &with_radii(&[2.0, 3.0, 5.0, 8.0])
        ));
        // One RBF in four may be narrower; two may not.
        assert!(coarse_suits(
            Coarse::Auto,
            &grid,
            &with_radii(&[1.0, 2.0, 3.0, 4.0])
        ));
        assert!(!coarse_suits(
            Coarse::Auto,
            &grid,
            &with_radii(&[1.0, 1.9, 3.0, 4.0])
        ));
        assert!(!coarse_suits(Coarse::Auto, &grid, &with_radii(&[1.5; 40])));
        assert!(!coarse_suits(Coarse::Auto, &grid, &[]));
        assert!(coarse_suits(Coarse::Always, &grid, &with_radii(&[1.0])));
        assert!(!coarse_suits(Coarse::Never, &grid, &with_radii(&[8.0])));
        // Below 64³ voxels `Auto` stays at full resolution however wide the RBFs.
        let dims = [40, 40, 40];
        let v = Volume::zeros(dims, Bbox::new([0.0; 3], [40.0; 3])).unwrap();
        let small = FitGrid::from_volume(&v).unwrap();
        let wide: Vec<f64> = [0.5, 0.5, 0.5, 8.0 * small.full_h, 0.5].repeat(4);
        assert!(!coarse_suits(Coarse::Auto, &small, &wide));
        assert!(coarse_suits(Coarse::Always, &small, &wide));
    }
}
