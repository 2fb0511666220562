//! Optical depth of a unit RBF as zonal harmonics (paper A §5.3, Fig. 5).
//!
//! Seen from a point at distance `d` from the center of the unit Gaussian
//! `B(x) = exp(−|x|²)` (cut off at `|x| = 3`, as everywhere in haze), the optical depth
//! along a direction at angle `acos μ` from the axis towards the center is, with
//! `b = dμ`, `h² = d²(1 − μ²)` and the chord half-length `s = √(9 − h²)`:
//!
//! ```text
//! T(μ) = ∫ exp(−|p + tω|²) dt over t ≥ 0 inside the cut-off sphere
//!      = e^{−h²} · (√π/2) · [erf(s) − erf(max(−b, −s))]      (0 when h ≥ 3 or b + s ≤ 0)
//! ```
//!
//! `T` is symmetric about the axis, so its SH projection is zonal:
//! `z_l = 2π ∫₋₁¹ T(μ) Y_l0(μ) dμ`, `Y_l0 = √((2l+1)/4π) P_l`. An RBF of radius `r` at
//! distance `D` has optical depth `r · T` at `d = D/r`. The table holds `z_l` at 256
//! uniform samples of the paper's angle `β ∈ [0, π]`: `β = asin(1/d)` for `d > 1`, else
//! `acos(d) + π/2` (inside the RBF), and interpolates linearly in `β`.

use crate::sh::quad::gauss_legendre;
use std::f64::consts::PI;

/// Cut-off of the Gaussian, in radii.
const CUTOFF: f64 = 3.0;
/// Samples of β (paper: 256).
pub const SAMPLES: usize = 256;

/// Optical depth of the unit RBF from distance `d`, along a direction with cosine `mu` to
/// the axis towards its center (closed form above).
pub fn optical_depth(d: f64, mu: f64) -> f64 {
    let mu = mu.clamp(-1.0, 1.0);
    let b = d * mu;
    let h2 = (d * d * (1.0 - mu * mu)).max(0.0);
    if h2 >= CUTOFF * CUTOFF {
        return 0.0;
    }
    let s = (CUTOFF * CUTOFF - h2).sqrt();
    if b + s <= 0.0 {
        return 0.0;
    }
    let lo = (-b).max(-s);
    (-h2).exp() * 0.5 * PI.sqrt() * (libm::erf(s) - libm::erf(lo))
}

/// Distance of the table's angle `β` (∞ at β = 0, 0 at β = π).
pub fn distance_of(beta: f64) -> f64 {
    if beta <= PI / 2.0 {
        let s = beta.sin();
        if s <= 0.0 { f64::INFINITY } else { 1.0 / s }
    } else {
        beta.sin().max(0.0)
    }
}

/// The paper's angle `β` of a unit RBF seen from distance `d ≥ 0`.
pub fn beta_of(d: f64) -> f64 {
    if d > 1.0 {
        (1.0 / d).asin()
    } else {
        d.max(0.0).acos() + PI / 2.0
    }
}

/// `Y_l0(μ)` for `l < order`.
fn zonal_basis(order: usize, mu: f64, out: &mut [f64]) {
    let (mut p0, mut p1) = (1.0, mu);
    for (l, o) in out.iter_mut().enumerate().take(order) {
        let p = match l {
            0 => 1.0,
            1 => mu,
            _ => {
                let p2 = ((2 * l - 1) as f64 * mu * p1 - (l - 1) as f64 * p0) / l as f64;
                p0 = p1;
                p1 = p2;
                p2
            }
        };
        *o = ((2 * l + 1) as f64 / (4.0 * PI)).sqrt() * p;
    }
}

/// Zonal coefficients of the unit RBF's optical depth seen from distance `d`, by
/// Gauss–Legendre quadrature (on the cone `μ ≥ √(1 − 9/d²)` outside the cut-off sphere,
/// with `μ = μc + (1 − μc)v²` to absorb the square-root edge of the chord).
pub fn project(order: usize, d: f64) -> Vec<f64> {
    let mut z = vec![0.0; order];
    if !d.is_finite() {
        return z;
    }
    let gl = gauss_legendre(96);
    let mut y = vec![0.0; order];
    let mut add = |mu: f64, w: f64, z: &mut [f64]| {
        let t = optical_depth(d, mu);
        if t == 0.0 {
            return;
        }
        zonal_basis(order, mu, &mut y);
        for l in 0..order {
            z[l] += 2.0 * PI * w * t * y[l];
        }
    };
    if d > CUTOFF {
        let mc = (1.0 - CUTOFF * CUTOFF / (d * d)).max(0.0).sqrt();
        for &(x, w) in &gl {
            let v = 0.5 * (x + 1.0);
            let mu = mc + (1.0 - mc) * v * v;
            add(mu, w * 0.5 * 2.0 * (1.0 - mc) * v, &mut z);
        }
    } else {
        // Inside or near the sphere: smooth on [−1, 1]; split at μ = 0 for accuracy.
        for (a, b) in [(-1.0, 0.0), (0.0, 1.0)] {
            for &(x, w) in &gl {
                add(a + (b - a) * 0.5 * (x + 1.0), w * 0.5 * (b - a), &mut z);
            }
        }
    }
    z
}

/// The 1D table of zonal optical-depth vectors over β.
#[derive(Clone, Debug)]
pub struct ZhTable {
    order: usize,
    /// `SAMPLES × order`, row k at `β = π k / (SAMPLES − 1)`.
    rows: Vec<f64>,
}

impl ZhTable {
    pub fn new(order: usize) -> ZhTable {
        let mut rows = Vec::with_capacity(SAMPLES * order);
        for k in 0..SAMPLES {
            let beta = PI * k as f64 / (SAMPLES - 1) as f64;
            rows.extend(project(order, distance_of(beta)));
        }
        ZhTable { order, rows }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// The samples: `SAMPLES` rows of `order` zonal coefficients, row `k` at
    /// `β = π k / (SAMPLES − 1)` (what the GPU uploads).
    pub fn rows(&self) -> &[f64] {
        &self.rows
    }

    /// Zonal coefficients of a unit RBF seen from distance `d` (linear in β), into `out`.
    pub fn lookup_into(&self, d: f64, out: &mut [f64]) {
        let f = beta_of(d) / PI * (SAMPLES - 1) as f64;
        let k = (f.floor() as usize).min(SAMPLES - 2);
        let t = (f - k as f64).clamp(0.0, 1.0);
        let (a, b) = (
            &self.rows[k * self.order..(k + 1) * self.order],
            &self.rows[(k + 1) * self.order..(k + 2) * self.order],
        );
        for l in 0..self.order {
            out[l] = (1.0 - t) * a[l] + t * b[l];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Optical depth by brute-force quadrature along the ray (fine midpoint rule).
    fn brute_depth(d: f64, mu: f64) -> f64 {
        let p = [0.0, 0.0, -d]; // center at the origin, point below it on the axis
        let w = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
        let n = 200_000;
        let tmax = d + CUTOFF;
        let dt = tmax / n as f64;
        (0..n)
            .map(|i| {
                let t = (i as f64 + 0.5) * dt;
                let q = [p[0] + t * w[0], p[1] + t * w[1], p[2] + t * w[2]];
                let r2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
                if r2 < CUTOFF * CUTOFF {
                    (-r2).exp() * dt
                } else {
                    0.0
                }
            })
            .sum()
    }

    #[test]
    fn closed_form_depth_matches_line_quadrature() {
        for &d in &[0.0, 0.3, 1.0, 2.5, 2.999, 3.5, 8.0] {
            for &mu in &[-1.0, -0.6, 0.0, 0.4, 0.9, 0.99, 1.0] {
                let (a, b) = (optical_depth(d, mu), brute_depth(d, mu));
                // Midpoint rule with dt ≤ 5.5e-5: error ≪ 1e-6 (the cut-off jump of
                // e⁻⁹ over one step adds at most 1.2e-4·dt).
                assert!((a - b).abs() < 1e-6, "d {d} mu {mu}: {a} vs {b}");
            }
        }
        assert_eq!(optical_depth(10.0, 0.5), 0.0, "outside the cone");
        assert!((optical_depth(0.0, 0.3) - 0.5 * PI.sqrt() * libm::erf(3.0)).abs() < 1e-15);
    }

    #[test]
    fn zonal_projection_reconstructs_the_depth() {
        // Band 0 is the mean depth × √(4π): compare with a plain midpoint average in μ.
        for &d in &[0.0, 0.7, 2.0, 5.0] {
            let z = project(6, d);
            let n = 100_000;
            let mean: f64 = (0..n)
                .map(|i| optical_depth(d, -1.0 + (i as f64 + 0.5) * 2.0 / n as f64))
                .sum::<f64>()
                / n as f64;
            assert!(
                (z[0] / (4.0 * PI).sqrt() - mean).abs() < 1e-5 * (1.0 + mean),
                "d {d}"
            );
        }
        // Inside the RBF at its center the depth is isotropic: only band 0.
        let z = project(4, 0.0);
        assert!(z[1..].iter().all(|v| v.abs() < 1e-12), "{z:?}");
    }

    #[test]
    fn table_matches_direct_projection_between_samples() {
        let t = ZhTable::new(4);
        let mut out = [0.0; 4];
        for &d in &[0.05, 0.5, 0.99, 1.01, 1.7, 3.3, 12.0, 40.0] {
            t.lookup_into(d, &mut out);
            let z = project(4, d);
            let scale = z.iter().fold(1e-12, |m, v| v.abs().max(m));
            for l in 0..4 {
                // Linear interpolation over 256 samples of β: within 1 % of the largest band
                // (far away the depth ∝ sin²β is quadratic between samples).
                assert!(
                    (out[l] - z[l]).abs() < 1e-2 * scale,
                    "d {d} l {l}: {} vs {}",
                    out[l],
                    z[l]
                );
            }
        }
        t.lookup_into(f64::INFINITY, &mut out);
        assert!(out.iter().all(|v| v.abs() < 1e-12));
        for &d in &[0.0, 0.5, 1.0, 2.0, 100.0] {
            assert!((distance_of(beta_of(d)) - d).abs() < 1e-9 * (1.0 + d));
        }
    }
}
