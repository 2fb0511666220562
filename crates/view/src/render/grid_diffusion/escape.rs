//! The escape probability per coarse cell: `P(x) = (1/4π)∫ exp(−σt ∫₀^∞ D(x + tω) dt) dω`,
//! the mean transmittance from the cell center to the outside, by `N` directions of a
//! spherical Fibonacci set (equal solid angles) marched through the coarse density.

use super::CoarseGrid;
use rayon::prelude::*;

/// Optical depth beyond which a march stops (`e⁻²⁰`).
const CUTOFF: f64 = 20.0;

/// `n` unit vectors of the spherical Fibonacci lattice (each stands for `4π/n`).
pub fn fibonacci_directions(n: usize) -> Vec<[f64; 3]> {
    let golden = std::f64::consts::PI * (3.0 - 5.0f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

/// The density of `grid` at world point `p`, trilinear between cell centers (0 outside).
pub fn sample(grid: &CoarseGrid, p: [f64; 3]) -> f64 {
    grid.corners(p).map_or(0.0, |corners| {
        corners
            .iter()
            .fold(0.0, |s, &(i, w)| s + w * grid.density[i])
    })
}

/// `P` at every cell with smoke (1 elsewhere), `dirs` directions, steps of the smallest
/// cell side by the midpoint rule until the box's face.
pub fn escape(grid: &CoarseGrid, sigma_t: f64, dirs: &[[f64; 3]]) -> Vec<f64> {
    let h = grid.h[0].min(grid.h[1]).min(grid.h[2]);
    (0..grid.len())
        .into_par_iter()
        .map(|i| {
            if grid.density[i] <= 0.0 || dirs.is_empty() {
                return 1.0;
            }
            let x = grid.center(grid.coords(i));
            let mut sum = 0.0;
            for d in dirs {
                // Distance to the box's face along d.
                let len = grid.exit_distance(x, *d);
                let n = (len / h).ceil().max(1.0) as usize;
                let step = len / n as f64;
                let mut depth = 0.0;
                for k in 0..n {
                    let t = (k as f64 + 0.5) * step;
                    depth += sigma_t * sample(grid, [0, 1, 2].map(|a| x[a] + t * d[a])) * step;
                    if depth > CUTOFF {
                        break;
                    }
                }
                sum += (-depth).exp();
            }
            (sum / dirs.len() as f64).clamp(0.0, 1.0)
        })
        .collect()
}
