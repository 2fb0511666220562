//! Fitting a sequence with temporal coherence (paper A §5.1): the first frame is fitted
//! from scratch with teleportation; every later frame starts from the previous frame's
//! RBFs, deletes the `k` with the smallest integrals, is minimized without teleportation,
//! and while its relative error exceeds the first frame's by more than the threshold ratio,
//! gets an RBF of fixed radius inserted at the largest error and is minimized again, up to
//! `m` insertions. Few RBFs move far between frames, so the fit does not flicker.
//!
//! An all-zero frame has no RBFs; the next non-empty frame starts afresh as a first frame.

use crate::frame::{FitOptions, FitStats, fit_first_frame, max_error, weakest};
use crate::grid::FitGrid;
use crate::init::initial_radius;
use crate::objective::{self, PARAMS_PER_RBF};
use crate::optimize::{Stop, minimize};
use haze_volume::{Rbf, Volume};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Settings of a sequence fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SequenceOptions {
    pub fit: FitOptions,
    /// RBFs of a first frame.
    pub rbfs: usize,
    /// RBFs deleted at the start of each later frame (paper: 3).
    pub delete: usize,
    /// Most RBFs inserted per later frame (paper: 8).
    pub max_insert: usize,
    /// Insert while rel_l2 / first frame's rel_l2 exceeds this (paper: 1.05–1.2).
    pub threshold: f64,
    /// Iteration budget of each warm-started minimization.
    pub warm_iterations: u64,
}

impl Default for SequenceOptions {
    fn default() -> Self {
        SequenceOptions {
            fit: FitOptions::default(),
            rbfs: 300,
            delete: 3,
            max_insert: 8,
            threshold: 1.1,
            warm_iterations: 200,
        }
    }
}

/// The fit of one frame.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FrameFit {
    /// The RBFs in world coordinates and density units.
    #[serde(skip)]
    pub rbfs: Vec<Rbf>,
    /// `sqrt(Σ(D − D̃)² / ΣD²)` (0 for an all-zero frame).
    pub rel_l2: f64,
    /// `sqrt(mean((D − D̃)²)) / max D` (0 for an all-zero frame).
    pub rms_over_max: f64,
    pub fit_seconds: f64,
    pub iterations: u64,
    pub teleports: u64,
    /// Started from the previous frame's RBFs.
    pub warm_started: bool,
    pub deleted: usize,
    pub inserted: usize,
    /// rel_l2 over the first frame's rel_l2 (1 for a first frame).
    pub error_ratio: f64,
    /// The insertion cap was reached with the ratio still above the threshold.
    pub insertion_capped: bool,
    /// RBFs with a radius or weight on its bound.
    pub rbfs_at_bounds: usize,
    /// Mean world distance moved by RBF centers that persisted from the previous frame.
    pub mean_center_displacement: Option<f64>,
}

/// Error measures of `params` on `grid`.
pub fn errors(grid: &FitGrid, params: &[f64]) -> (f64, f64) {
    if grid.sum_sq <= 0.0 || grid.is_empty() {
        return (0.0, 0.0);
    }
    let r = objective::residual(grid, params);
    let e: f64 = r.iter().map(|v| v * v).sum();
    ((e / grid.sum_sq).sqrt(), (e / r.len() as f64).sqrt())
}

/// Fits frames one after another, carrying RBFs from frame to frame.
#[derive(Debug)]
pub struct SequenceFitter {
    opts: SequenceOptions,
    previous: Option<Vec<Rbf>>,
    /// rel_l2 and insertion radius (world units) of the current run's first frame.
    first: Option<(f64, f64)>,
}

/// What a [`SequenceFitter`] carries from one frame to the next: enough to continue an
/// interrupted sequence exactly where it stopped.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FitterState {
    /// The last frame's RBFs (full precision).
    pub previous: Option<Vec<Rbf>>,
    /// rel_l2 and insertion radius (world units) of the current run's first frame.
    pub first: Option<(f64, f64)>,
}

impl SequenceFitter {
    pub fn new(opts: SequenceOptions) -> Self {
        Self::resume(opts, FitterState::default())
    }

    /// A fitter that continues after the frame whose [`state`](Self::state) this is.
    pub fn resume(opts: SequenceOptions, state: FitterState) -> Self {
        SequenceFitter {
            opts,
            previous: state.previous,
            first: state.first,
        }
    }

    /// The state after the last fitted frame.
    pub fn state(&self) -> FitterState {
        FitterState {
            previous: self.previous.clone(),
            first: self.first,
        }
    }

    pub fn options(&self) -> &SequenceOptions {
        &self.opts
    }

    /// Fits the next frame; refuses non-finite or negative densities.
    pub fn fit(&mut self, volume: &Volume) -> Result<FrameFit, String> {
        let start = Instant::now();
        let grid = FitGrid::from_volume(volume)?;
        let mut out = if grid.sum_sq <= 0.0 {
            self.previous = None;
            self.first = None;
            empty_fit()
        } else {
            match (self.previous.take(), self.first) {
                (Some(prev), Some(first)) if !prev.is_empty() => self.warm(&grid, &prev, first),
                _ => self.cold(&grid),
            }
        };
        out.fit_seconds = start.elapsed().as_secs_f64();
        self.previous = Some(out.rbfs.clone());
        Ok(out)
    }

    fn cold(&mut self, grid: &FitGrid) -> FrameFit {
        let (params, stats) = fit_first_frame(grid, self.opts.rbfs, &self.opts.fit);
        let (rel_l2, rms) = errors(grid, &params);
        let n = (params.len() / PARAMS_PER_RBF).max(1);
        let radius = initial_radius(grid, n, &self.opts.fit.bounds) * grid.unit;
        self.first = Some((rel_l2, radius));
        finish(grid, &params, &self.opts, stats, rel_l2, rms)
    }

    fn warm(
        &mut self,
        grid: &FitGrid,
        prev: &[Rbf],
        (first_rel, radius_world): (f64, f64),
    ) -> FrameFit {
        let o = &self.opts;
        let bounds = &o.fit.bounds;
        let mut params: Vec<f64> = Vec::with_capacity(prev.len() * PARAMS_PER_RBF);
        for rbf in prev {
            if let Some((c, r, w)) = grid.from_world(rbf) {
                let mut p = [c[0], c[1], c[2], r, w];
                bounds.clamp(grid, &mut p);
                params.extend_from_slice(&p);
            }
        }
        // Delete the k weakest; remember which survive to measure their motion.
        let mut alive: Vec<usize> = (0..prev.len()).collect();
        let mut deleted = 0;
        while deleted < o.delete && params.len() > PARAMS_PER_RBF {
            let Some(l) = weakest(&params) else { break };
            params.drain(l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF);
            alive.remove(l);
            deleted += 1;
        }
        let stop = Stop {
            max_iterations: o.warm_iterations,
            ..o.fit.stop
        };
        let mut stats = FitStats::default();
        stats.iterations += minimize(grid, &mut params, bounds, o.fit.optimizer, stop).iterations;
        let (mut rel_l2, mut rms) = errors(grid, &params);
        let ratio = |rel: f64| {
            if first_rel > 0.0 {
                rel / first_rel
            } else {
                1.0
            }
        };
        let radius = radius_world / grid.unit;
        let mut inserted = 0;
        while ratio(rel_l2) > o.threshold && inserted < o.max_insert {
            let r = objective::residual(grid, &params);
            let Some((value, i)) = max_error(&r) else {
                break;
            };
            let c = grid.center(i);
            let mut p = [c[0], c[1], c[2], radius, value];
            bounds.clamp(grid, &mut p);
            params.extend_from_slice(&p);
            inserted += 1;
            stats.iterations +=
                minimize(grid, &mut params, bounds, o.fit.optimizer, stop).iterations;
            (rel_l2, rms) = errors(grid, &params);
        }
        let mut f = finish(grid, &params, o, stats, rel_l2, rms);
        f.warm_started = true;
        f.deleted = deleted;
        f.inserted = inserted;
        f.error_ratio = ratio(rel_l2);
        f.insertion_capped = f.error_ratio > o.threshold;
        let moved: Vec<f64> = alive
            .iter()
            .zip(&f.rbfs)
            .map(|(&k, now)| {
                let was = prev[k].center;
                (0..3)
                    .map(|a| (now.center[a] - was[a]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .collect();
        if !moved.is_empty() {
            f.mean_center_displacement = Some(moved.iter().sum::<f64>() / moved.len() as f64);
        }
        f
    }
}

fn empty_fit() -> FrameFit {
    FrameFit {
        rbfs: Vec::new(),
        rel_l2: 0.0,
        rms_over_max: 0.0,
        fit_seconds: 0.0,
        iterations: 0,
        teleports: 0,
        warm_started: false,
        deleted: 0,
        inserted: 0,
        error_ratio: 1.0,
        insertion_capped: false,
        rbfs_at_bounds: 0,
        mean_center_displacement: None,
    }
}

fn finish(
    grid: &FitGrid,
    params: &[f64],
    o: &SequenceOptions,
    stats: FitStats,
    rel_l2: f64,
    rms: f64,
) -> FrameFit {
    FrameFit {
        rbfs: params
            .chunks(PARAMS_PER_RBF)
            .map(|p| grid.to_world([p[0], p[1], p[2]], p[3], p[4]))
            .collect(),
        rel_l2,
        rms_over_max: rms,
        iterations: stats.iterations,
        teleports: stats.teleports,
        rbfs_at_bounds: o.fit.bounds.count_at_bounds(params),
        ..empty_fit()
    }
}
