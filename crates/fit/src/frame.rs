//! Fitting one frame from scratch (paper A §5.1): greedy start, then L-BFGS-B with
//! teleportation. Every 20 iterations the RBF with the smallest integral (`w·r³`) moves to
//! the voxel of largest error; at convergence the smallest RBF is teleported alternately to
//! the largest error and to a random voxel with non-zero density, and the move is kept
//! only if the re-converged objective is lower; the fit ends when both kinds of move fail
//! in a row (or the iteration budget is spent).
//!
//! Coarse to fine: on large grids (see [`Coarse`]) all of the above runs on the frame at
//! half resolution ([`FitGrid::downsampled`], 8× fewer voxels, so passes are ~8× cheaper),
//! and a short polish at full resolution ([`FitOptions::polish`]) corrects what the box
//! filter moved.

use crate::bounds::Bounds;
use crate::grid::FitGrid;
use crate::init::{greedy, initial_radius};
use crate::objective::{self, PARAMS_PER_RBF};
use crate::optimize::{Optimizer, Stop, minimize};
use rand::RngExt;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

/// When a fit runs on the half-resolution grid first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Coarse {
    /// On grids of at least [`Coarse::AUTO_VOXELS`] voxels.
    #[default]
    Auto,
    Always,
    Never,
}

impl Coarse {
    /// 64³: below it a pass is already cheap and the coarse grid too coarse for the
    /// smallest default radius.
    pub const AUTO_VOXELS: usize = 1 << 18;

    /// Whether `grid` is fitted coarse to fine.
    pub fn applies(self, grid: &FitGrid) -> bool {
        match self {
            Coarse::Auto => grid.len() >= Self::AUTO_VOXELS,
            Coarse::Always => grid.dims.iter().all(|&d| d >= 2),
            Coarse::Never => false,
        }
    }
}

/// Settings of a frame fit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitOptions {
    pub bounds: Bounds,
    pub optimizer: Optimizer,
    /// Iterations between teleports, and the convergence test of each minimization.
    pub teleport_every: u64,
    pub stop: Stop,
    /// Teleportation on or off (off: one minimization from the greedy start).
    pub teleport: bool,
    /// Iteration budget of a whole first-frame fit.
    pub max_iterations: u64,
    /// Seed of the random teleports.
    pub seed: u64,
    /// Coarse-to-fine fitting of first frames.
    pub coarse: Coarse,
    /// Stopping rule of a full-resolution polish after a coarse fit.
    pub polish: Stop,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            bounds: Bounds::default(),
            optimizer: Optimizer::default(),
            teleport_every: 20,
            stop: Stop::default(),
            teleport: true,
            max_iterations: 1000,
            seed: 1,
            coarse: Coarse::default(),
            polish: Stop {
                max_iterations: 100,
                relative_reduction: 0.0,
                window: 5,
                window_gain: 1e-3,
            },
        }
    }
}

/// Counters of a fit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FitStats {
    /// Iterations in all, at either resolution.
    pub iterations: u64,
    /// Of which at half resolution.
    pub coarse_iterations: u64,
    /// Objective passes (cost or cost and gradient, line searches included), at either
    /// resolution.
    pub passes: u64,
    pub teleports: u64,
    /// Teleports kept (at convergence, only those that lowered the objective are kept).
    pub teleports_kept: u64,
}

/// Largest positive residual and its voxel, lowest index on ties; `None` when the density
/// is everywhere matched or over-estimated.
pub fn max_error(r: &[f64]) -> Option<(f64, usize)> {
    let mut best: Option<(f64, usize)> = None;
    for (i, &v) in r.iter().enumerate() {
        if v > 0.0 && best.is_none_or(|b| v > b.0) {
            best = Some((v, i));
        }
    }
    best
}

/// Index of the RBF with the smallest integral `w·r³` (lowest index on ties).
pub fn weakest(params: &[f64]) -> Option<usize> {
    params
        .chunks(PARAMS_PER_RBF)
        .map(|p| p[4] * p[3].powi(3))
        .enumerate()
        .fold(None, |m: Option<(usize, f64)>, (l, v)| match m {
            Some((_, mv)) if mv <= v => m,
            _ => Some((l, v)),
        })
        .map(|(l, _)| l)
}

/// Where a teleported RBF goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    MaxError,
    RandomNonzero,
}

/// Moves RBF `l` to `target` with radius `radius`. Its weight is the residual there; at a
/// random voxel, where the residual may be small or negative, at least half the density
/// there (so the move is a real proposal, and the minimizer then adjusts it). Weights are
/// clamped to the bounds. Returns false when there is nowhere to go.
pub fn teleport(
    grid: &FitGrid,
    params: &mut [f64],
    l: usize,
    target: Target,
    radius: f64,
    bounds: &Bounds,
    rng: &mut Pcg64,
) -> bool {
    let r = objective::residual(grid, params);
    let (value, i) = match target {
        Target::MaxError => match max_error(&r) {
            Some(m) => m,
            None => return false,
        },
        Target::RandomNonzero => {
            if grid.nonzero.is_empty() {
                return false;
            }
            let i = grid.nonzero[rng.random_range(0..grid.nonzero.len())];
            (r[i].max(grid.density[i] * 0.5), i)
        }
    };
    let c = grid.center(i);
    let p = &mut params[l * PARAMS_PER_RBF..(l + 1) * PARAMS_PER_RBF];
    p.copy_from_slice(&[c[0], c[1], c[2], radius, value]);
    bounds.clamp(grid, p);
    true
}

impl FitStats {
    /// Adds one minimization's counts (`coarse`: it ran at half resolution).
    pub fn add(&mut self, m: &crate::optimize::Minimized, coarse: bool) {
        self.iterations += m.iterations;
        self.passes += m.passes;
        if coarse {
            self.coarse_iterations += m.iterations;
        }
    }
}

/// Fits `n` RBFs to `grid` from scratch, coarse to fine where [`FitOptions::coarse`]
/// applies. Returns the parameters (unit cube, normalized weights) and counters.
pub fn fit_first_frame(grid: &FitGrid, n: usize, opts: &FitOptions) -> (Vec<f64>, FitStats) {
    let n = n.min(grid.nonzero.len());
    let radius = initial_radius(grid, n, &opts.bounds);
    if !opts.coarse.applies(grid) {
        return fit_from_scratch(grid, n, radius, opts, false);
    }
    let (mut params, mut stats) = fit_from_scratch(&grid.downsampled(), n, radius, opts, true);
    if !params.is_empty() {
        let m = minimize(grid, &mut params, &opts.bounds, opts.optimizer, opts.polish);
        stats.add(&m, false);
    }
    (params, stats)
}

/// The fit of the module docs on one grid (`coarse`: the half-resolution one, for the
/// counters).
fn fit_from_scratch(
    grid: &FitGrid,
    n: usize,
    radius: f64,
    opts: &FitOptions,
    coarse: bool,
) -> (Vec<f64>, FitStats) {
    let mut stats = FitStats::default();
    let mut params = greedy(grid, n, radius, &opts.bounds);
    if params.is_empty() {
        return (params, stats);
    }
    let mut rng = Pcg64::new(
        u128::from(opts.seed),
        0xa02b_dbf7_bb3c_0a7a_c28f_a16a_64ab_f96d,
    );
    let budget = opts.max_iterations;
    if !opts.teleport {
        let m = minimize(
            grid,
            &mut params,
            &opts.bounds,
            opts.optimizer,
            Stop {
                max_iterations: budget,
                ..opts.stop
            },
        );
        stats.add(&m, coarse);
        return (params, stats);
    }
    // Phase 1: minimize in chunks, teleporting the weakest RBF to the largest error between
    // chunks, until a chunk converges.
    let mut best = (f64::INFINITY, params.clone());
    loop {
        let chunk = opts.teleport_every.min(budget - stats.iterations);
        let m = minimize(
            grid,
            &mut params,
            &opts.bounds,
            opts.optimizer,
            Stop {
                max_iterations: chunk,
                ..opts.stop
            },
        );
        stats.add(&m, coarse);
        if m.cost < best.0 {
            best = (m.cost, params.clone());
        }
        if m.converged || m.iterations == 0 || stats.iterations >= budget {
            break;
        }
        if let Some(l) = weakest(&params)
            && teleport(
                grid,
                &mut params,
                l,
                Target::MaxError,
                radius,
                &opts.bounds,
                &mut rng,
            )
        {
            stats.teleports += 1;
            stats.teleports_kept += 1;
        }
    }
    // Phase 2: teleport at convergence, keep improvements, stop when both targets fail.
    let (mut best_cost, mut params) = best;
    let mut failures = 0;
    let mut target = Target::MaxError;
    while failures < 2 && stats.iterations < budget {
        let mut trial = params.clone();
        let Some(l) = weakest(&trial) else { break };
        if teleport(grid, &mut trial, l, target, radius, &opts.bounds, &mut rng) {
            stats.teleports += 1;
            let m = minimize(
                grid,
                &mut trial,
                &opts.bounds,
                opts.optimizer,
                Stop {
                    max_iterations: opts.stop.max_iterations.min(budget - stats.iterations),
                    ..opts.stop
                },
            );
            stats.add(&m, coarse);
            if m.cost < best_cost * (1.0 - 1e-6) {
                best_cost = m.cost;
                params = trial;
                stats.teleports_kept += 1;
                failures = 0;
            } else {
                failures += 1;
            }
        } else {
            failures += 1;
        }
        target = match target {
            Target::MaxError => Target::RandomNonzero,
            Target::RandomNonzero => Target::MaxError,
        };
    }
    (params, stats)
}
