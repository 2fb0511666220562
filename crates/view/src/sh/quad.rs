//! Quadrature on the sphere: Gauss–Legendre in `cos θ` × uniform `φ`.
//!
//! An `n`-point Gauss–Legendre rule integrates polynomials of degree `≤ 2n − 1` exactly;
//! `m` uniformly spaced azimuths integrate trigonometric polynomials of degree `< m`
//! exactly. Together they integrate every polynomial in `(x, y, z)` of total degree
//! `≤ min(2n − 1, m − 1)` on the unit sphere exactly: its terms are `z`-polynomials times
//! `sin^k θ·e^{ikφ}`, and those with odd `k` vanish under the uniform azimuth sum.

use std::f64::consts::PI;

use crate::distant::direction;

/// Nodes and weights of the `n`-point Gauss–Legendre rule on `[−1, 1]`, by Newton's
/// iteration on `P_n` from Tricomi's initial guesses (converges to machine precision
/// in a few steps for every `n`).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    let nf = n as f64;
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let kf = k as f64;
                (p0, p1) = (p1, ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf);
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pn1 = if n <= 1 { 1.0 } else { p0 };
            dp = nf * (x * pn - pn1) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// A product grid on the sphere: directions and their quadrature weights (summing to 4π).
#[derive(Clone, Debug)]
pub struct SphereGrid {
    points: Vec<([f64; 3], f64)>,
}

impl SphereGrid {
    /// `n_theta` Gauss–Legendre latitudes in `cos θ ∈ [−1, 1]` × `n_phi` azimuths
    /// `φ_j = 2π(j + ½)/n_phi`.
    pub fn new(n_theta: usize, n_phi: usize) -> SphereGrid {
        Self::from_latitudes(&gauss_legendre(n_theta), n_phi)
    }

    /// As [`SphereGrid::new`] with a separate `n`-point rule on each hemisphere, for
    /// functions with a jump at the horizon (`cos θ = 0`).
    pub fn hemispheres(n: usize, n_phi: usize) -> SphereGrid {
        Self::from_latitudes(&Self::hemisphere_latitudes(n), n_phi)
    }

    /// The latitudes `(cos θ, weight)` of [`SphereGrid::hemispheres`], in its order (the
    /// grid's points are these × the azimuths, latitude-major).
    pub fn hemisphere_latitudes(n: usize) -> Vec<(f64, f64)> {
        gauss_legendre(n)
            .into_iter()
            .flat_map(|(x, w)| [(0.5 * (x - 1.0), 0.5 * w), (0.5 * (x + 1.0), 0.5 * w)])
            .collect()
    }

    fn from_latitudes(lat: &[(f64, f64)], n_phi: usize) -> SphereGrid {
        let dphi = 2.0 * PI / n_phi as f64;
        let mut points = Vec::with_capacity(lat.len() * n_phi);
        for &(mu, w) in lat {
            let theta = mu.clamp(-1.0, 1.0).acos();
            for j in 0..n_phi {
                points.push((direction(theta, dphi * (j as f64 + 0.5)), w * dphi));
            }
        }
        SphereGrid { points }
    }

    /// `(direction, weight)` pairs.
    pub fn points(&self) -> impl Iterator<Item = ([f64; 3], f64)> + '_ {
        self.points.iter().copied()
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_to_degree_2n_minus_1() {
        for n in 1..=40 {
            let rule = gauss_legendre(n);
            let total: f64 = rule.iter().map(|(_, w)| w).sum();
            assert!((total - 2.0).abs() < 1e-13, "n {n}: {total}");
            // ∫₋₁¹ x^k dx = 2/(k+1) for even k, 0 for odd k.
            for k in 0..2 * n {
                let got: f64 = rule.iter().map(|(x, w)| w * x.powi(k as i32)).sum();
                let want = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    0.0
                };
                assert!((got - want).abs() < 1e-13, "n {n} k {k}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn sphere_grids_integrate_monomials_exactly() {
        // ∫ z² dω = 4π/3, ∫ x²y² dω = 4π/15, ∫ x⁴ dω = 4π/5, odd monomials vanish.
        for g in [SphereGrid::new(3, 5), SphereGrid::hemispheres(3, 5)] {
            let int = |f: &dyn Fn([f64; 3]) -> f64| g.points().map(|(d, w)| w * f(d)).sum::<f64>();
            assert!((int(&|_| 1.0) - 4.0 * PI).abs() < 1e-13);
            assert!((int(&|d| d[2] * d[2]) - 4.0 * PI / 3.0).abs() < 1e-13);
            assert!((int(&|d| d[0] * d[0] * d[1] * d[1]) - 4.0 * PI / 15.0).abs() < 1e-13);
            assert!((int(&|d| d[0].powi(4)) - 4.0 * PI / 5.0).abs() < 1e-13);
            assert!(int(&|d| d[0] * d[1] * d[2]).abs() < 1e-13);
            assert!(int(&|d| d[0].powi(3)).abs() < 1e-13);
        }
    }
}
