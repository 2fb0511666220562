//! Choosing the RBF count: the smallest `n` whose first-frame fit reaches a target
//! relative error ("model only what the scene requires").
//!
//! Search: fit `n = 32, 64, 128, …` (doubling) until `rel_l2 ≤ target` or `n` reaches the
//! cap, then bisect the last bracket `(n/2, n]` until it is narrower than an eighth of its
//! upper end (or 4 RBFs). Each probe is a full first-frame fit with the given options, so
//! the cost is about `log₂(n/32) + 3` fits; every probe is returned for reporting.

use crate::frame::{FitOptions, fit_first_frame};
use crate::grid::FitGrid;
use crate::sequence::errors;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// One probe of the search.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Probe {
    pub rbfs: usize,
    pub rel_l2: f64,
    pub seconds: f64,
}

/// The outcome: the chosen count (the cap if the target was not reached) and the probes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Search {
    pub rbfs: usize,
    pub reached: bool,
    pub probes: Vec<Probe>,
}

/// Smallest RBF count reaching `rel_l2 ≤ target` on `grid`, at most `cap`.
pub fn rbfs_for_target(grid: &FitGrid, target: f64, cap: usize, opts: &FitOptions) -> Search {
    let cap = cap.max(1).min(grid.nonzero.len().max(1));
    let mut probes = Vec::new();
    let mut probe = |n: usize| {
        let t = Instant::now();
        let (params, _) = fit_first_frame(grid, n, opts);
        let (rel_l2, _) = errors(grid, &params);
        probes.push(Probe {
            rbfs: n,
            rel_l2,
            seconds: t.elapsed().as_secs_f64(),
        });
        rel_l2 <= target
    };
    if grid.sum_sq <= 0.0 {
        return Search {
            rbfs: 0,
            reached: true,
            probes,
        };
    }
    let mut lo = 0;
    let mut hi = 32.min(cap);
    let mut reached = probe(hi);
    while !reached && hi < cap {
        lo = hi;
        hi = (hi * 2).min(cap);
        reached = probe(hi);
    }
    if !reached {
        return Search {
            rbfs: cap,
            reached,
            probes,
        };
    }
    while hi - lo > (hi / 8).max(4) {
        let mid = (lo + hi) / 2;
        if probe(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Search {
        rbfs: hi,
        reached,
        probes,
    }
}
