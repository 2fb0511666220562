//! Where a fogmap sits in the world, and its vertical profile (paper E §4.1, §4.3).
//!
//! World space is Z up. Pixel `(i, j)` of the fogmap (column `i`, row `j` counted from
//! the map's south edge, see [`crate::fogmap`]) carries the coefficient of the scaling
//! function centred on `origin + (i + ½, j + ½)·cell`. In the finest level's units
//! `U = (x − origin_x)/cell + d/2` (and `V` likewise), that function is
//! `φ(U − i)·φ(V − j)` with support `[i, i + d + 1]`, so B-spline knots fall on integer
//! `U` and a level `l` of `L` has cells of `2^{L−l}` finest cells.
//!
//! The extinction coefficient is
//!
//! `K_t(x, y, z) = density · f(x, y) · h(z)`, `h(z) = e^{−falloff·(z − bottom)}` for
//! `bottom ≤ z ≤ top`, and 0 outside that slab,
//!
//! where `f` is the fog's 2-D function (the fogmap's spline). The paper keeps the fog
//! homogeneous vertically and fades it with a vertical extinction coefficient; here the
//! fade is an exponential in height (`falloff = 0` gives a homogeneous slab), which the
//! integration handles exactly.

use haze_core::number::shown;
use thiserror::Error;

/// World placement and vertical profile of a fog.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// World `(x, y)` of the fogmap's south-west corner.
    pub origin: [f64; 2],
    /// World size of one fogmap pixel.
    pub cell: f64,
    /// Extinction (per world unit) of a coefficient of 1 at the bottom of the layer.
    pub density: f64,
    /// Height of the layer's bottom, where `h = 1`.
    pub bottom: f64,
    /// Height of the layer's top, above which the fog is clear.
    pub top: f64,
    /// Vertical falloff `k` of `h(z) = e^{−k(z − bottom)}` (per world unit).
    pub falloff: f64,
}

/// The steepest vertical falloff: `h` drops by `e^{−10³⁰}` (to 0) within one unit of
/// height, and the GPU's `f32` (up to 3.4·10³⁸) still holds `falloff × height` for any
/// height up to 10⁸.
pub const MAX_FALLOFF: f64 = 1e30;

/// A placement that cannot describe a fog.
#[derive(Debug, Error, PartialEq)]
#[error("{0}")]
pub struct PlacementError(pub String);

impl Placement {
    /// Checks every value is finite and meaningful.
    pub fn validate(&self) -> Result<(), PlacementError> {
        let bad = |what: String| Err(PlacementError(what));
        if !self.origin.iter().all(|v| v.is_finite()) {
            return bad(format!(
                "origin {}, {} must be finite",
                shown(self.origin[0]),
                shown(self.origin[1])
            ));
        }
        if !(self.cell.is_finite() && self.cell > 0.0) {
            return bad(format!(
                "cell size {} must be positive and finite",
                shown(self.cell)
            ));
        }
        if !(self.density.is_finite() && self.density >= 0.0) {
            return bad(format!(
                "density {} must be non-negative and finite",
                shown(self.density)
            ));
        }
        if !(self.bottom.is_finite() && self.top.is_finite() && self.top > self.bottom) {
            return bad(format!(
                "fog layer bottom {} and top {} must be finite with top above bottom",
                shown(self.bottom),
                shown(self.top)
            ));
        }
        if !(self.falloff >= 0.0 && self.falloff <= MAX_FALLOFF) {
            return bad(format!(
                "vertical falloff {} must be between 0 and {MAX_FALLOFF:e} per unit height",
                shown(self.falloff)
            ));
        }
        Ok(())
    }

    /// `h(z)`, zero outside the slab.
    pub fn vertical(&self, z: f64) -> f64 {
        if (self.bottom..=self.top).contains(&z) {
            (-self.falloff * (z - self.bottom)).exp()
        } else {
            0.0
        }
    }

    /// The finest level's `(U, V)` of a world `(x, y)` for basis degree `d`.
    pub fn to_grid(&self, degree: usize, x: f64, y: f64) -> [f64; 2] {
        let shift = degree as f64 / 2.0;
        [
            (x - self.origin[0]) / self.cell + shift,
            (y - self.origin[1]) / self.cell + shift,
        ]
    }

    /// The part `[ta, tb]` of `o + t·dir`, `t ∈ [ta, tb]`, inside the slab; `None` if empty.
    pub fn clip_slab(&self, o: [f64; 3], dir: [f64; 3], ta: f64, tb: f64) -> Option<(f64, f64)> {
        let (mut a, mut b) = (ta, tb);
        if dir[2] == 0.0 {
            if !(self.bottom..=self.top).contains(&o[2]) {
                return None;
            }
        } else {
            let (t0, t1) = ((self.bottom - o[2]) / dir[2], (self.top - o[2]) / dir[2]);
            a = a.max(t0.min(t1));
            b = b.min(t0.max(t1));
        }
        (b > a).then_some((a, b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Placement {
        Placement {
            origin: [-8.0, 2.0],
            cell: 0.5,
            density: 1.0,
            bottom: 0.0,
            top: 3.0,
            falloff: 0.5,
        }
    }

    #[test]
    fn pixel_centres_map_to_bump_centres() {
        let p = sample();
        for d in 0..=2 {
            // Pixel (3, 5) is centred at origin + 3.5·cell, 5.5·cell; its function
            // φ(U − 3) peaks at U = 3 + (d + 1)/2.
            let [u, v] = p.to_grid(d, -8.0 + 3.5 * 0.5, 2.0 + 5.5 * 0.5);
            let peak = (d + 1) as f64 / 2.0;
            assert!((u - (3.0 + peak)).abs() < 1e-12 && (v - (5.0 + peak)).abs() < 1e-12);
        }
    }

    #[test]
    fn slab_clipping_handles_horizontal_and_vertical_rays() {
        let p = sample();
        // Horizontal inside and outside the slab.
        assert_eq!(
            p.clip_slab([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], 0.0, 10.0),
            Some((0.0, 10.0))
        );
        assert_eq!(
            p.clip_slab([0.0, 0.0, 4.0], [1.0, 0.0, 0.0], 0.0, 10.0),
            None
        );
        // Straight down from above: enters at the top.
        assert_eq!(
            p.clip_slab([0.0, 0.0, 5.0], [0.0, 0.0, -1.0], 0.0, 100.0),
            Some((2.0, 5.0))
        );
        // Zero-length segment.
        assert_eq!(
            p.clip_slab([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 0.0, 0.0),
            None
        );
    }

    #[test]
    fn bad_values_are_named() {
        let mut p = sample();
        p.cell = 0.0;
        assert!(p.validate().unwrap_err().0.contains("cell size 0"));
        let mut p = sample();
        p.density = f64::NAN;
        assert!(p.validate().unwrap_err().0.contains("density NaN"));
        let mut p = sample();
        p.top = p.bottom;
        assert!(p.validate().is_err());
        // Extremes as typed, not 300 digits.
        let mut p = sample();
        p.falloff = 1e300;
        let e = p.validate().unwrap_err().0;
        assert!(
            e.contains("falloff 1e300 must be between 0 and 1e30"),
            "{e}"
        );
        let mut p = sample();
        p.bottom = 1e300;
        assert!(
            p.validate()
                .unwrap_err()
                .0
                .contains("bottom 1e300 and top 3")
        );
        let mut p = sample();
        p.falloff = MAX_FALLOFF;
        assert!(p.validate().is_ok());
        assert!(sample().validate().is_ok());
        assert_eq!(sample().vertical(4.0), 0.0);
        assert!((sample().vertical(2.0) - (-1.0f64).exp()).abs() < 1e-15);
    }
}
