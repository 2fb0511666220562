//! Fitting one frame from scratch (paper A §5.1): greedy start, then L-BFGS-B with
//! teleportation. Every 20 iterations the RBF with the smallest integral (`w·r³`) moves to
//! the voxel of largest error; at convergence the smallest RBF is teleported alternately to
//! the largest error and to a random voxel with non-zero density, and the move is kept
//! only if the re-converged objective is lower; the fit ends when both kinds of move fail
//! in a row (or the iteration budget is spent).

use crate::bounds::Bounds;
use crate::grid::FitGrid;
use crate::init::{greedy, initial_radius};
use crate::objective::{self, PARAMS_PER_RBF};
use crate::optimize::{Optimizer, Stop, minimize};
use rand::RngExt;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

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
        }
    }
}

/// Counters of a fit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FitStats {
    pub iterations: u64,
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

/// Fits `n` RBFs to `grid` from scratch. Returns the parameters (unit cube, normalized
/// weights) and counters.
pub fn fit_first_frame(grid: &FitGrid, n: usize, opts: &FitOptions) -> (Vec<f64>, FitStats) {
    let mut stats = FitStats::default();
    let n = n.min(grid.nonzero.len());
    let radius = initial_radius(grid, n, &opts.bounds);
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
        stats.iterations = m.iterations;
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
        stats.iterations += m.iterations;
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
            stats.iterations += m.iterations;
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
