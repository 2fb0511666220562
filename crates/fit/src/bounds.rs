//! Box bounds of the fit (paper A §5.1): radii in `[r_min, 0.09]` of the unit cube,
//! weights in `[0.01, 1]·max D`, centers inside the grid's box.
//!
//! The smallest radius is the grid's Nyquist radius `r_N = 2h/π` (`h` the finest voxel
//! side, unit cube) unless a larger one is asked for. The Gaussian `exp(−x²/r²)` has the
//! spectrum `∝ exp(−k²r²/4)`; at `r = r_N` it falls by `1/e` across the grid's whole band
//! `[0, π/h]`, so a narrower one is, on the grid, the same flat-spectrum one-voxel spike
//! and only aliases more. The paper's fixed `0.015` is 1.4–1.9 voxels on 72–128-voxel
//! grids: on turbulent smoke two thirds of 1200 RBFs sat on it and a floor at `r_N` halves
//! their error (BENCHMARKS.md, "Radius floor at the Nyquist radius").

use crate::grid::FitGrid;
use crate::objective::PARAMS_PER_RBF;
use serde::{Deserialize, Serialize};

/// Radius and weight ranges, in unit-cube lengths and fractions of the frame's max density.
/// `radius.0` is a floor on top of the grid's Nyquist radius ([`nyquist_radius`]): the
/// default `0` leaves the grid's; the range a grid gets is [`Bounds::radius_on`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    pub radius: (f64, f64),
    pub weight: (f64, f64),
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds {
            radius: (0.0, 0.09),
            weight: (0.01, 1.0),
        }
    }
}

impl Bounds {
    /// Checks the ranges are ordered, finite and positive (the radius floor may be 0: the
    /// grid's Nyquist radius).
    pub fn validate(&self) -> Result<(), String> {
        let ok = |(lo, hi): (f64, f64)| lo > 0.0 && hi >= lo && hi.is_finite();
        let (lo, hi) = self.radius;
        if !(lo >= 0.0 && hi >= lo && hi > 0.0 && hi.is_finite()) {
            return Err(format!(
                "radius bounds {:?} must satisfy 0 ≤ min ≤ max, max > 0",
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

    /// The radius range on `grid`: the floor raised to the grid's Nyquist radius, the
    /// ceiling raised to the floor (grids under 15 voxels a side have `r_N > 0.09`).
    pub fn radius_on(&self, grid: &FitGrid) -> (f64, f64) {
        let lo = self.radius.0.max(nyquist_radius(grid));
        (lo, self.radius.1.max(lo))
    }

    /// Lower and upper bound vectors for `n` RBFs on `grid`.
    pub fn vectors(&self, grid: &FitGrid, n: usize) -> (Vec<f64>, Vec<f64>) {
        let radius = self.radius_on(grid);
        let lo = [0.0, 0.0, 0.0, radius.0, self.weight.0];
        let hi = [
            grid.extent[0],
            grid.extent[1],
            grid.extent[2],
            radius.1,
            self.weight.1,
        ];
        (lo.repeat(n), hi.repeat(n))
    }

    /// Clamps one RBF's parameters into the box.
    pub fn clamp(&self, grid: &FitGrid, p: &mut [f64]) {
        for (c, &e) in p[..3].iter_mut().zip(&grid.extent) {
            *c = c.clamp(0.0, e);
        }
        let (lo, hi) = self.radius_on(grid);
        p[3] = p[3].clamp(lo, hi);
        p[4] = p[4].clamp(self.weight.0, self.weight.1);
    }

    /// How many RBFs of `params` on `grid` sit on a radius or weight bound (within 1e-9
    /// of it).
    pub fn count_at_bounds(&self, grid: &FitGrid, params: &[f64]) -> usize {
        let at = |v: f64, (lo, hi): (f64, f64)| {
            (v - lo).abs() <= 1e-9 * hi || (v - hi).abs() <= 1e-9 * hi
        };
        let radius = self.radius_on(grid);
        params
            .chunks(PARAMS_PER_RBF)
            .filter(|p| at(p[3], radius) || at(p[4], self.weight))
            .count()
    }
}

/// The grid's Nyquist radius `2h/π`, `h` the finest voxel side of the frame at full
/// resolution ([`FitGrid::full_h`], unit cube): the narrowest Gaussian the frame's grid
/// tells apart from a one-voxel spike (module docs). A coarse pass keeps the frame's floor:
/// with its own (twice as large) the radii it hands to the full-resolution polish are
/// held 3–4 % worse on plume-b at 600–1200 RBFs. 0 for a grid without a voxel size
/// (a `Volume` refuses such boxes).
pub fn nyquist_radius(grid: &FitGrid) -> f64 {
    let h = grid.full_h;
    if h.is_finite() && h > 0.0 {
        2.0 * h / std::f64::consts::PI
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_volume::{Bbox, Volume};

    /// A grid of `dims` voxels over `size`, one non-zero voxel.
    fn grid(dims: [usize; 3], size: [f64; 3]) -> FitGrid {
        let mut v = Volume::zeros(dims, Bbox::new([0.0; 3], size)).unwrap();
        v.data_mut()[0] = 1.0;
        FitGrid::from_volume(&v).unwrap()
    }

    /// The rule's premise, by quadrature rather than the closed form: the spectrum of
    /// `exp(−x²/r²)` at the Nyquist frequency `π/h` of the finest axis is `1/e` of its
    /// value at 0 for `r = nyquist_radius`. Trapezoid rule over `±8r` with 4000 steps:
    /// the integrand is smooth and decays to `e⁻⁶⁴`, so the error is far below 1e-9.
    #[test]
    fn the_floor_is_the_gaussian_whose_spectrum_falls_to_1_over_e_at_nyquist() {
        // Voxel sides 0.5, 0.25, 1 world units; unit = 16: finest h = 0.25/16.
        let g = grid([32, 40, 16], [16.0, 10.0, 16.0]);
        let h = 0.25 / 16.0;
        let r = nyquist_radius(&g);
        let (steps, reach) = (4000, 8.0 * r);
        let dx = 2.0 * reach / steps as f64;
        let integral = |k: f64| {
            (0..=steps)
                .map(|i| {
                    let x = -reach + i as f64 * dx;
                    let w = if i == 0 || i == steps { 0.5 } else { 1.0 };
                    w * (-(x / r).powi(2)).exp() * (k * x).cos() * dx
                })
                .sum::<f64>()
        };
        let ratio = integral(std::f64::consts::PI / h) / integral(0.0);
        assert!((ratio - (-1.0f64).exp()).abs() < 1e-9, "{ratio}");
    }

    #[test]
    fn the_radius_range_is_floored_at_the_frames_nyquist_radius() {
        let g = grid([32, 40, 16], [16.0, 10.0, 16.0]);
        let rn = 2.0 * (0.25 / 16.0) / std::f64::consts::PI;
        let default = Bounds::default();
        assert!((default.radius_on(&g).0 - rn).abs() < 1e-15);
        assert_eq!(default.radius_on(&g).1, 0.09);
        // A coarse pass and a residual keep the frame's floor, not twice it.
        assert_eq!(default.radius_on(&g.downsampled()), default.radius_on(&g));
        let res = g.residual_grid(vec![0.0; g.len()]);
        assert_eq!(default.radius_on(&res), default.radius_on(&g));
        // A floor above r_N stands; one below it is raised.
        let above = Bounds {
            radius: (0.05, 0.09),
            ..default
        };
        assert_eq!(above.radius_on(&g), (0.05, 0.09));
        let below = Bounds {
            radius: (rn / 2.0, 0.09),
            ..default
        };
        assert!((below.radius_on(&g).0 - rn).abs() < 1e-15);
        // 4 voxels a side: r_N = 0.5/π > 0.09, and the ceiling follows.
        let tiny = grid([4, 4, 4], [1.0, 1.0, 1.0]);
        let (lo, hi) = default.radius_on(&tiny);
        assert!((lo - 0.5 / std::f64::consts::PI).abs() < 1e-15 && hi == lo);
        let mut p = [0.5, 0.5, 0.5, 0.01, 0.5];
        default.clamp(&tiny, &mut p);
        assert_eq!(p[3], lo);
    }

    #[test]
    fn validation_accepts_a_zero_floor_and_refuses_the_rest() {
        assert!(Bounds::default().validate().is_ok());
        for radius in [
            (-0.01, 0.09),
            (0.1, 0.09),
            (0.0, 0.0),
            (f64::NAN, 0.09),
            (0.0, f64::INFINITY),
        ] {
            let b = Bounds {
                radius,
                ..Bounds::default()
            };
            assert!(b.validate().is_err(), "{radius:?}");
        }
    }
}
