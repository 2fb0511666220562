//! Greedy initialization of a first frame: RBFs are placed one at a time at the voxel of
//! largest positive residual, with the weight of the residual there and a common initial
//! radius, and subtracted from the residual before the next is placed. It stops early when
//! no positive residual is left (a single-voxel frame gets one RBF).
//!
//! Initial radius: `r₀ = ½·(V/n)^⅓`, clamped to the radius bounds, where `V` is the volume
//! of the non-zero voxels (unit cube): `n` RBFs of that size roughly tile the smoke.
//!
//! The residual's maximum is tracked per 8³ brick, so each placement rescans only the
//! bricks its support touches.

use crate::bounds::Bounds;
use crate::grid::FitGrid;
use crate::objective::PARAMS_PER_RBF;
use haze_volume::Rbf;
use haze_volume::rbf::voxel_span;

const BRICK: usize = 8;

/// The initial radius for `n` RBFs on `grid` (see the module docs).
pub fn initial_radius(grid: &FitGrid, n: usize, bounds: &Bounds) -> f64 {
    let voxel = grid.h[0] * grid.h[1] * grid.h[2];
    let v = grid.nonzero.len() as f64 * voxel;
    let r = 0.5 * (v / n.max(1) as f64).cbrt();
    if r.is_finite() {
        r.clamp(bounds.radius.0, bounds.radius.1)
    } else {
        bounds.radius.0
    }
}

/// Largest value of `r` per brick, and where.
struct BrickMax {
    nb: [usize; 3],
    best: Vec<(f64, usize)>,
}

impl BrickMax {
    fn new(grid: &FitGrid, r: &[f64]) -> BrickMax {
        let nb = grid.dims.map(|d| d.div_ceil(BRICK));
        let mut m = BrickMax {
            nb,
            best: vec![(f64::NEG_INFINITY, 0); nb[0] * nb[1] * nb[2]],
        };
        for b in 0..m.best.len() {
            m.rescan(grid, r, b);
        }
        m
    }

    fn rescan(&mut self, grid: &FitGrid, r: &[f64], b: usize) {
        let bx = b % self.nb[0];
        let by = (b / self.nb[0]) % self.nb[1];
        let bz = b / (self.nb[0] * self.nb[1]);
        let lo = [bx, by, bz].map(|v| v * BRICK);
        let mut best = (f64::NEG_INFINITY, 0);
        for z in lo[2]..(lo[2] + BRICK).min(grid.dims[2]) {
            for y in lo[1]..(lo[1] + BRICK).min(grid.dims[1]) {
                for x in lo[0]..(lo[0] + BRICK).min(grid.dims[0]) {
                    let i = grid.index(x, y, z);
                    if r[i] > best.0 {
                        best = (r[i], i);
                    }
                }
            }
        }
        self.best[b] = best;
    }

    /// The largest value and its voxel (lowest brick on ties).
    fn max(&self) -> (f64, usize) {
        self.best
            .iter()
            .copied()
            .fold((f64::NEG_INFINITY, 0), |m, b| if b.0 > m.0 { b } else { m })
    }

    /// Rescans the bricks that the voxel ranges `span` touch.
    fn update(&mut self, grid: &FitGrid, r: &[f64], span: [(usize, usize); 3]) {
        for bz in span[2].0 / BRICK..=span[2].1 / BRICK {
            for by in span[1].0 / BRICK..=span[1].1 / BRICK {
                for bx in span[0].0 / BRICK..=span[0].1 / BRICK {
                    self.rescan(grid, r, bx + self.nb[0] * (by + self.nb[1] * bz));
                }
            }
        }
    }
}

/// Subtracts one RBF (unit-cube parameters) from `r` over its support; returns the voxel
/// ranges touched.
pub(crate) fn subtract(grid: &FitGrid, r: &mut [f64], p: &[f64]) -> Option<[(usize, usize); 3]> {
    let rbf = Rbf::new([p[0], p[1], p[2]], p[3], p[4]);
    let s = rbf.support_radius();
    let mut span = [(0, 0); 3];
    for a in 0..3 {
        span[a] = voxel_span(p[a] - s, p[a] + s, 0.0, grid.h[a], grid.dims[a])?;
    }
    for z in span[2].0..=span[2].1 {
        for y in span[1].0..=span[1].1 {
            for x in span[0].0..=span[0].1 {
                let i = grid.index(x, y, z);
                r[i] -= rbf.eval(grid.center(i));
            }
        }
    }
    Some(span)
}

/// Up to `n` RBFs placed greedily (see the module docs), as a flat parameter vector.
pub fn greedy(grid: &FitGrid, n: usize, radius: f64, bounds: &Bounds) -> Vec<f64> {
    let mut params = Vec::with_capacity(n * PARAMS_PER_RBF);
    if grid.is_empty() || n == 0 {
        return params;
    }
    let mut r = grid.density.clone();
    let mut bricks = BrickMax::new(grid, &r);
    for _ in 0..n {
        let (value, i) = bricks.max();
        if value <= 0.0 {
            break;
        }
        let c = grid.center(i);
        let mut p = [c[0], c[1], c[2], radius, value];
        bounds.clamp(grid, &mut p);
        params.extend_from_slice(&p);
        if let Some(span) = subtract(grid, &mut r, &p) {
            bricks.update(grid, &r, span);
        }
    }
    params
}
