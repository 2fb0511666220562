//! Box bounds of the fit (paper A §5.1): radii in `[0.015, 0.09]` of the unit cube by
//! default (settable: finer grids want smaller radii), weights in `[0.01, 1]·max D`,
//! centers inside the grid's box.

use crate::grid::FitGrid;
use crate::objective::PARAMS_PER_RBF;
use serde::{Deserialize, Serialize};

/// Radius and weight ranges, in unit-cube lengths and fractions of the frame's max density.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    pub radius: (f64, f64),
    pub weight: (f64, f64),
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds {
            radius: (0.015, 0.09),
            weight: (0.01, 1.0),
        }
    }
}

impl Bounds {
    /// Checks the ranges are ordered, positive and finite.
    pub fn validate(&self) -> Result<(), String> {
        let ok = |(lo, hi): (f64, f64)| lo > 0.0 && hi >= lo && hi.is_finite();
        if !ok(self.radius) {
            return Err(format!(
                "radius bounds {:?} must satisfy 0 < min ≤ max",
                self.radius
            ));
        }
        if !ok(self.weight) {
            return Err(format!(
                "weight bounds {:?} must satisfy 0 < min ≤ max",
                self.weight
            ));
        }
        Ok(())
    }

    /// Lower and upper bound vectors for `n` RBFs on `grid`.
    pub fn vectors(&self, grid: &FitGrid, n: usize) -> (Vec<f64>, Vec<f64>) {
        let lo = [0.0, 0.0, 0.0, self.radius.0, self.weight.0];
        let hi = [
            grid.extent[0],
            grid.extent[1],
            grid.extent[2],
            self.radius.1,
            self.weight.1,
        ];
        (lo.repeat(n), hi.repeat(n))
    }

    /// Clamps one RBF's parameters into the box.
    pub fn clamp(&self, grid: &FitGrid, p: &mut [f64]) {
        for (c, &e) in p[..3].iter_mut().zip(&grid.extent) {
            *c = c.clamp(0.0, e);
        }
        p[3] = p[3].clamp(self.radius.0, self.radius.1);
        p[4] = p[4].clamp(self.weight.0, self.weight.1);
    }

    /// How many RBFs of `params` sit on a radius or weight bound (within 1e-9 of it).
    pub fn count_at_bounds(&self, params: &[f64]) -> usize {
        let at = |v: f64, (lo, hi): (f64, f64)| {
            (v - lo).abs() <= 1e-9 * hi || (v - hi).abs() <= 1e-9 * hi
        };
        params
            .chunks(PARAMS_PER_RBF)
            .filter(|p| at(p[3], self.radius) || at(p[4], self.weight))
            .count()
    }
}
