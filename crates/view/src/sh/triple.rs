//! The SH triple product (paper A appendix; Ren et al. 2006 §4):
//! `(a ∗ b)_i = Σ_jk Γ_ijk a_j b_k` with `Γ_ijk = ∫ Y_i Y_j Y_k dω`, the order-n
//! projection of the product of two order-n functions.
//!
//! Γ is computed by a quadrature that is exact for it: `Y_i Y_j Y_k` is a polynomial of
//! degree `≤ 3(n−1)` in `(x, y, z)`, which `⌈(3(n−1)+1)/2⌉` Gauss–Legendre latitudes ×
//! `3(n−1)+1` azimuths integrate exactly (see `quad`); entries below 1e-12 in magnitude
//! are the rounding of exact zeros (the true non-zero real Gaunt coefficients of
//! orders ≤ 6 are all above 1e-3) and are dropped.

use super::basis::{count, eval_into};
use super::quad::SphereGrid;

/// The sparse tensor Γ of one order, stored once per unordered pair `j ≤ k`.
#[derive(Clone, Debug)]
pub struct TripleProduct {
    order: usize,
    /// `(i, j, k, Γ_ijk)` with `j ≤ k`, sorted by `i`.
    entries: Vec<(u16, u16, u16, f64)>,
}

impl TripleProduct {
    pub fn new(order: usize) -> TripleProduct {
        assert!(order >= 1, "SH order 0 has no coefficients");
        let n = count(order);
        let degree = 3 * (order - 1);
        let grid = SphereGrid::new(degree / 2 + 1, degree + 1);
        let mut ys = Vec::with_capacity(grid.len());
        for (d, w) in grid.points() {
            let mut y = vec![0.0; n];
            eval_into(order, d, &mut y);
            ys.push((y, w));
        }
        let mut entries = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for k in j..n {
                    let g: f64 = ys.iter().map(|(y, w)| w * y[i] * y[j] * y[k]).sum();
                    if g.abs() > 1e-12 {
                        entries.push((i as u16, j as u16, k as u16, g));
                    }
                }
            }
        }
        TripleProduct { order, entries }
    }

    pub fn order(&self) -> usize {
        self.order
    }

    /// Non-zero entries of the full tensor `Γ_ijk` (all index orders counted).
    pub fn nonzeros(&self) -> usize {
        self.entries
            .iter()
            .map(|&(_, j, k, _)| if j == k { 1 } else { 2 })
            .sum()
    }

    /// Entries stored (one per `(i, {j, k})`); the work of one product.
    pub fn stored(&self) -> usize {
        self.entries.len()
    }

    /// The stored entries `(i, j, k, Γ_ijk)`, one per `(i, {j, k})` with `j ≤ k`, sorted by
    /// `i` (what the GPU uploads).
    pub fn entries(&self) -> &[(u16, u16, u16, f64)] {
        &self.entries
    }

    /// `Γ_ijk` (zero when not stored).
    pub fn gamma(&self, i: usize, j: usize, k: usize) -> f64 {
        let (j, k) = (j.min(k), j.max(k));
        self.entries
            .iter()
            .find(|&&(a, b, c, _)| (a as usize, b as usize, c as usize) == (i, j, k))
            .map_or(0.0, |e| e.3)
    }

    /// `a ∗ b`.
    pub fn product(&self, a: &[f64], b: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; count(self.order)];
        self.product_into(a, b, &mut out);
        out
    }

    /// `a ∗ b` into `out`; `a`, `b`, `out` all of length `order²`.
    pub fn product_into(&self, a: &[f64], b: &[f64], out: &mut [f64]) {
        let n = count(self.order);
        assert!(
            a.len() == n && b.len() == n && out.len() == n,
            "triple product of order {} on lengths {}, {}, {}",
            self.order,
            a.len(),
            b.len(),
            out.len()
        );
        out.fill(0.0);
        for &(i, j, k, g) in &self.entries {
            let (j, k) = (j as usize, k as usize);
            let ab = if j == k {
                a[j] * b[j]
            } else {
                a[j] * b[k] + a[k] * b[j]
            };
            out[i as usize] += g * ab;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sh::basis::{index, reconstruct};
    use crate::sh::project::project_fn;
    use std::f64::consts::PI;

    #[test]
    fn known_gaunt_coefficients_and_symmetry() {
        let tp = TripleProduct::new(4);
        let y0 = 1.0 / (4.0 * PI).sqrt();
        for j in 0..16 {
            // Γ_0jj = Y_0·∫Y_j² = 1/√(4π); Γ_0jk = 0 for j ≠ k.
            assert!((tp.gamma(0, j, j) - y0).abs() < 1e-14);
            assert!((tp.gamma(j, 0, j) - y0).abs() < 1e-14);
            assert_eq!(tp.gamma(0, j, (j + 1) % 16), 0.0);
        }
        // ∫ Y_10² Y_20 dω = (3/4π)·¼√(5/π)·(3·4π/5 − 4π/3) = 1/√(5π).
        let want = 1.0 / (5.0 * PI).sqrt();
        assert!((tp.gamma(index(2, 0), index(1, 0), index(1, 0)) - want).abs() < 1e-14);
        // Odd total parity vanishes: Y_10·Y_10·Y_10.
        assert_eq!(tp.gamma(2, 2, 2), 0.0);
        // Symmetric in all indices.
        for (i, j, k) in [(4, 5, 7), (8, 3, 12), (15, 9, 6)] {
            let g = tp.gamma(i, j, k);
            for (a, b, c) in [(j, i, k), (k, j, i), (i, k, j)] {
                assert!((tp.gamma(a, b, c) - g).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn product_matches_projection_of_the_pointwise_product() {
        for order in 1..=6 {
            let tp = TripleProduct::new(order);
            let n = count(order);
            let a: Vec<f64> = (0..n).map(|i| (i * 37 % 17) as f64 / 8.0 - 1.0).collect();
            let b: Vec<f64> = (0..n).map(|i| (i * 23 % 13) as f64 / 6.0 - 1.0).collect();
            let c = tp.product(&a, &b);
            // Independent route: reconstruct both, multiply pointwise, project. The
            // integrand has degree ≤ 3(n−1) ≤ 15: 12 × 24 nodes are exact.
            let want = project_fn(order, |d| reconstruct(&a, d) * reconstruct(&b, d), 12, 24);
            for i in 0..n {
                assert!(
                    (c[i] - want[i]).abs() < 1e-12,
                    "order {order} i {i}: {} vs {}",
                    c[i],
                    want[i]
                );
            }
        }
    }

    #[test]
    fn sparsity_is_reported() {
        // Order 1: Γ_000 only. Order 2: Γ_000 and the 3·3 permutations of Γ_0jj.
        assert_eq!(TripleProduct::new(1).nonzeros(), 1);
        assert_eq!(TripleProduct::new(2).nonzeros(), 1 + 3 * 3);
        let t6 = TripleProduct::new(6);
        assert!(t6.nonzeros() < count(6).pow(3) / 4, "{}", t6.nonzeros());
    }
}
