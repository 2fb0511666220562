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
    let mut lo = [0usize; 3];
    let mut t = [0.0f64; 3];
    for a in 0..3 {
        let u = (p[a] - grid.origin[a]) / grid.h[a];
        if !(u >= 0.0 && u <= grid.dims[a] as f64) {
            return 0.0;
        }
        let c = (u - 0.5).clamp(0.0, (grid.dims[a] - 1) as f64);
        lo[a] = (c.floor() as usize).min(grid.dims[a].saturating_sub(2));
        t[a] = c - lo[a] as f64;
    }
    let mut s = 0.0;
    for corner in 0..8 {
        let mut w = 1.0;
        let mut c = [0usize; 3];
        for a in 0..3 {
            let hi = corner >> a & 1 == 1;
            c[a] = (lo[a] + usize::from(hi)).min(grid.dims[a] - 1);
            w *= if hi { t[a] } else { 1.0 - t[a] };
        }
        s += w * grid.density[grid.index(c)];
    }
    s
}

/// `P` at every cell with smoke (1 elsewhere), `dirs` directions, steps of the smallest
/// cell side by the midpoint rule until the box's face.
pub fn escape(grid: &CoarseGrid, sigma_t: f64, dirs: &[[f64; 3]]) -> Vec<f64> {
    let h = grid.h[0].min(grid.h[1]).min(grid.h[2]);
    let size = [0, 1, 2].map(|a| grid.h[a] * grid.dims[a] as f64);
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
                let mut len = f64::INFINITY;
                for a in 0..3 {
                    if d[a] > 0.0 {
                        len = len.min((grid.origin[a] + size[a] - x[a]) / d[a]);
                    } else if d[a] < 0.0 {
                        len = len.min((grid.origin[a] - x[a]) / d[a]);
                    }
                }
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
