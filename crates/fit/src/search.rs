//! Choosing the RBF count: the smallest `n` whose first-frame fit reaches a target
//! relative error ("model only what the scene requires").
//!
//! Search: fit `n = 32, 64, 128, …` (doubling) until `rel_l2 ≤ target` or `n` reaches the
//! cap, then bisect the last bracket `(n/2, n]` until it is narrower than an eighth of its
//! upper end (or 4 RBFs). Each probe is a full first-frame fit with the given options, so
//! the cost is about `log₂(n/32) + 3` fits; every probe is returned for reporting.
//!
//! Plateau: when doubling the count lowers rel_l2 by less than [`PLATEAU_GAIN`], more RBFs
//! stop helping (the radius bounds keep the finest detail out of their reach; the residual
//! stores it). The search stops there, with the smaller count, rather than climbing to the
//! cap. Counts are the RBFs a fit really produced (a greedy start stops early when no
//! positive residual is left), not the ones asked for.

use crate::frame::{FitOptions, fit_first_frame};
use crate::grid::FitGrid;
use crate::objective::PARAMS_PER_RBF;
use crate::sequence::errors;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// One probe of the search.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Probe {
    /// RBFs asked for.
    pub rbfs: usize,
    /// RBFs the fit produced (fewer when the greedy start ran out of positive residual).
    #[serde(default)]
    pub fitted: usize,
    pub rel_l2: f64,
    pub seconds: f64,
}

/// The outcome: the chosen count (the cap, or where rel_l2 plateaued, if the target was
/// not reached) and the probes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Search {
    /// RBFs to fit the first frame with.
    pub rbfs: usize,
    pub reached: bool,
    /// The target was out of reach: rel_l2 stopped falling as the count doubled.
    #[serde(default)]
    pub plateau: bool,
    pub probes: Vec<Probe>,
}

/// Smallest relative gain in rel_l2 from doubling the RBF count that keeps the search
/// going: on the RBF-count curves of BENCHMARKS.md a doubling gains 15–30 % while the
/// radius bounds still admit the detail left.
pub const PLATEAU_GAIN: f64 = 0.03;

/// One first-frame fit of `n` RBFs.
fn probe(grid: &FitGrid, n: usize, opts: &FitOptions) -> Probe {
    let t = Instant::now();
    let (params, _) = fit_first_frame(grid, n, opts);
    let (rel_l2, _) = errors(grid, &params);
    Probe {
        rbfs: n,
        fitted: params.len() / PARAMS_PER_RBF,
        rel_l2,
        seconds: t.elapsed().as_secs_f64(),
    }
}

/// Smallest RBF count reaching `rel_l2 ≤ target` on `grid`, at most `cap` (see the module
/// docs for the plateau).
pub fn rbfs_for_target(grid: &FitGrid, target: f64, cap: usize, opts: &FitOptions) -> Search {
    let cap = cap.max(1).min(grid.nonzero.len().max(1));
    let mut probes: Vec<Probe> = Vec::new();
    if grid.sum_sq <= 0.0 {
        return Search {
            rbfs: 0,
            reached: true,
            plateau: false,
            probes,
        };
    }
    let run = |n: usize, probes: &mut Vec<Probe>| {
        let p = probe(grid, n, opts);
        probes.push(p);
        p.rel_l2 <= target
    };
    let mut lo = 0;
    let mut hi = 32.min(cap);
    let mut reached = run(hi, &mut probes);
    let mut plateau = false;
    while !reached && hi < cap {
        lo = hi;
        hi = (hi * 2).min(cap);
        reached = run(hi, &mut probes);
        if let [.., a, b] = probes.as_slice()
            && !reached
            && b.rel_l2 > a.rel_l2 * (1.0 - PLATEAU_GAIN)
        {
            plateau = true;
            break;
        }
    }
    if !reached {
        // The best fit's count, or the smaller one when doubling did not pay.
        let best = probes[probes.len() - if plateau { 2 } else { 1 }];
        return Search {
            rbfs: best.fitted,
            reached,
            plateau,
            probes,
        };
    }
    while hi - lo > (hi / 8).max(4) {
        let mid = (lo + hi) / 2;
        if run(mid, &mut probes) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let rbfs = probes
        .iter()
        .find(|p| p.rbfs == hi)
        .map_or(hi, |p| p.fitted);
    Search {
        rbfs,
        reached,
        plateau,
        probes,
    }
}
