//! Paper C's special function as a table: `K(ρ, δ) = (1 + ρ)·H/δ` of [`crate::paper_c::hfunc`],
//! on a grid uniform in `x = √(ρ/(1 + ρ))` and `y = 2w/π = 1 − 2δ/π`.
//!
//! Why this and not the paper's `F(u, v)` on a box of `u` (§5, a 64² texture): the
//! airlight needs the complement `F(u, π/2) − F(u, w)`, which a table of `F` gives as a
//! difference of two interpolated values — large relative errors wherever it is small,
//! and the paper's `e^{−T·cos γ}` factor amplifies them without bound for rays facing
//! away from the light. `K` is bounded and smooth on the whole quarter plane: `x ∈ [0, 1]`
//! covers every `u ≥ 0` (no clamping at a largest `u`), and the factors `(1 + ρ)` and
//! `1/δ` take out the decay in `u` and the zero at `w = π/2`. BENCHMARKS.md ("Paper C
//! tables") measures the three parameterizations against quadrature; 128² `f32` samples
//! (64 KiB) keep the relative error of `H` below 2·10⁻⁴ everywhere.

use super::hfunc::k_exact;
use super::table::Table2;
use std::f64::consts::FRAC_PI_2;

/// Default side of the table (128² `f32`, 64 KiB).
pub const DEFAULT_SIZE: usize = 128;

/// The tabulated `K`.
#[derive(Clone, Debug, PartialEq)]
pub struct HTable {
    pub table: Table2,
}

impl HTable {
    /// Samples `K` exactly (adaptive quadrature) at every node of an `n × n` grid.
    pub fn new(n: usize) -> HTable {
        HTable {
            table: Table2::build(n, n, |x, y| {
                let delta = FRAC_PI_2 * (1.0 - y);
                k_exact(rho_of(x), delta)
            }),
        }
    }

    /// `K(ρ, δ)` for `ρ ∈ [0, ∞]`, `δ ∈ [0, π/2]`.
    pub fn k(&self, rho: f64, delta: f64) -> f64 {
        self.table.at(x_of(rho), 1.0 - delta / FRAC_PI_2)
    }

    /// `H(u, w) = δ·K(ρ, δ)/(1 + ρ)` with `δ = π/2 − w`, `ρ = u/sin δ`.
    pub fn h(&self, u: f64, w: f64) -> f64 {
        let delta = (FRAC_PI_2 - w).clamp(0.0, FRAC_PI_2);
        let sin_d = delta.sin();
        if sin_d <= 0.0 {
            return 0.0;
        }
        let rho = u / sin_d;
        delta * self.k(rho, delta) / (1.0 + rho)
    }

    pub fn bytes(&self) -> usize {
        self.table.bytes()
    }
}

impl Default for HTable {
    fn default() -> Self {
        HTable::new(DEFAULT_SIZE)
    }
}

/// `x = √(ρ/(1 + ρ))` (`ρ = ∞` → 1).
pub fn x_of(rho: f64) -> f64 {
    if rho.is_infinite() {
        1.0
    } else {
        (rho / (1.0 + rho)).sqrt()
    }
}

/// The inverse, `ρ = x²/(1 − x²)` (`x = 1` → ∞).
pub fn rho_of(x: f64) -> f64 {
    let x2 = x * x;
    if x2 >= 1.0 {
        f64::INFINITY
    } else {
        x2 / (1.0 - x2)
    }
}

/// The `(u, w)` points where tables of `H` are measured: `u = 0` and 97 values
/// log-spaced over `[10⁻⁶, 10⁶]`, times `w = 0`, 120 values spaced to midpoints between
/// any table's nodes, and `π/2 − 10⁻ᵏ` for `k = 2…8` (the edge the renderer reaches for
/// escaping rays).
pub fn measurement_grid() -> Vec<(f64, f64)> {
    let mut us = vec![0.0];
    us.extend((0..97).map(|i| 10f64.powf(-6.0 + 12.0 * i as f64 / 96.0)));
    let mut ws = vec![0.0];
    ws.extend((0..120).map(|j| FRAC_PI_2 * (j as f64 + 0.37) / 120.0));
    ws.extend((2..=8).map(|k| FRAC_PI_2 - 10f64.powi(-k)));
    us.iter()
        .flat_map(|&u| ws.iter().map(move |&w| (u, w)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper_c::hfunc::h_oracle;
    use rayon::prelude::*;

    /// The default table's largest relative error of `H` over the measurement grid,
    /// against an independent quadrature (`h_oracle`, another substitution than the one
    /// that built the table): the target is 0.1 %; BENCHMARKS.md has 1.9·10⁻⁴.
    #[test]
    fn default_table_is_within_a_thousandth_everywhere() {
        let t = HTable::default();
        assert!(t.bytes() <= 256 * 1024);
        let worst = measurement_grid()
            .par_iter()
            .map(|&(u, w)| {
                let (h, o) = (t.h(u, w), h_oracle(u, w));
                assert!(h.is_finite() && h >= 0.0, "H({u}, {w}) = {h}");
                if o > 0.0 { ((h - o) / o).abs() } else { h }
            })
            .reduce(|| 0.0, f64::max);
        assert!(worst <= 1e-3, "max relative error {worst}");
        assert!(worst <= 3e-4, "max relative error {worst} (was 1.9e-4)");
    }

    #[test]
    fn edges_are_exact() {
        let t = HTable::new(16);
        // ρ = 0: K = 1 (H = π/2 − w); ρ = ∞: sin δ/δ; the corners.
        assert!((t.k(0.0, 0.8) - 1.0).abs() < 1e-6);
        let d = std::f64::consts::FRAC_PI_3; // a node of the 16² grid
        assert!((t.k(f64::INFINITY, d) - d.sin() / d).abs() < 1e-6);
        assert!((t.h(0.0, 0.0) - FRAC_PI_2).abs() < 1e-6);
        assert_eq!(t.h(5.0, FRAC_PI_2), 0.0);
        assert!((rho_of(x_of(3.0)) - 3.0).abs() < 1e-14);
    }
}
