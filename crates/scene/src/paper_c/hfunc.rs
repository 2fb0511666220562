//! The special function of paper C (Sun et al. 2005, §3 and appendix A) in the stable
//! form the renderer uses, computed exactly by quadrature (to build tables and check them).
//!
//! Paper C writes the airlight of a point light with
//! `F(u, v) = ∫₀^v exp(−u·tan ξ) dξ` as `A0·[F(A1, v1) − F(A1, γ/2)]`. Its complement
//! from `w` to `π/2`, rescaled by the value of the exponent at `w`,
//!
//! `H(u, w) = ∫_w^{π/2} exp(−u·(tan ξ − tan w)) dξ = e^{u·tan w}·[F(u, π/2) − F(u, w)]`,
//!
//! lies in `(0, π/2 − w]`, never overflows and needs no difference of two table values
//! (`crate::paper_c::airlight` writes the airlight with it). With `δ = π/2 − w`, `ξ = w + sδ`
//! and `ρ = u / cos w = u / sin δ`:
//!
//! `H = δ·∫₀¹ exp(−ρ·sin(sδ)/sin((1−s)δ)) ds`,
//!
//! so `K(ρ, δ) = (1 + ρ)·H/δ` is bounded on the whole quarter plane `ρ ≥ 0`,
//! `δ ∈ [0, π/2]`: `K(0, δ) = 1`, `K(∞, δ) = sin δ/δ`, `K(ρ, 0) = (1 + ρ)·g(ρ)` with
//! `g(c) = 1 − c·e^c·E₁(c)`. [`crate::paper_c::htable`] tabulates `K`.

use super::quad::adaptive_pieces;
use std::f64::consts::FRAC_PI_2;

/// Relative tolerance of the quadratures here.
const TOL: f64 = 1e-11;

/// `sin(sδ)/sin((1−s)δ)`, the exponent's shape (`s/(1−s)` as `δ → 0`; `+∞` at `s = 1`).
fn ratio(s: f64, delta: f64) -> f64 {
    if s >= 1.0 {
        return f64::INFINITY;
    }
    if delta < 1e-6 {
        // sin x = x(1 − x²/6 …): the ratio's relative correction is O(δ²) < 1e-12.
        return s / (1.0 - s);
    }
    (s * delta).sin() / ((1.0 - s) * delta).sin()
}

/// `K(ρ, δ) = (1 + ρ)·∫₀¹ exp(−ρ·sin(sδ)/sin((1−s)δ)) ds` by adaptive quadrature, with
/// breakpoints on the scale `1/ρ` of the integrand's decay. `ρ = ∞` gives its limit
/// `sin δ/δ` (1 at `δ = 0`).
pub fn k_exact(rho: f64, delta: f64) -> f64 {
    assert!(
        rho >= 0.0 && (0.0..=FRAC_PI_2 + 1e-12).contains(&delta),
        "K({rho}, {delta})"
    );
    if rho == 0.0 {
        return 1.0;
    }
    if rho.is_infinite() {
        return if delta > 0.0 {
            delta.sin() / delta
        } else {
            1.0
        };
    }
    let f = |s: f64| {
        let r = ratio(s, delta);
        if r.is_infinite() {
            0.0
        } else {
            (-rho * r).exp()
        }
    };
    let mut points = vec![0.0];
    for c in [1.0, 4.0, 16.0, 64.0] {
        let p = c / rho;
        if p < 1.0 {
            points.push(p);
        }
    }
    points.push(1.0);
    let integral = adaptive_pieces(f, &points, TOL);
    // (1 + ρ)·∫ is computed as ∫ + ρ∫ to keep full precision for tiny ρ.
    integral + rho * integral
}

/// `H(u, w)` for `u ≥ 0`, `w ∈ [0, π/2]`, through [`k_exact`].
pub fn h_exact(u: f64, w: f64) -> f64 {
    let delta = (FRAC_PI_2 - w).max(0.0);
    let sin_d = delta.sin();
    if sin_d <= 0.0 {
        return 0.0;
    }
    let rho = u / sin_d;
    delta * k_exact(rho, delta) / (1.0 + rho)
}

/// `H(u, w)` by a different route, as an oracle: the substitution `tan ξ = tan w + s`
/// gives `H = ∫₀^∞ e^{−us}/(1 + (tan w + s)²) ds`, integrated after mapping
/// `s = σ·q/(1 − q)` to `q ∈ [0, 1)` with `σ` the integrand's scale.
pub fn h_oracle(u: f64, w: f64) -> f64 {
    let a = w.tan();
    if !a.is_finite() || a > 1e150 {
        return 0.0;
    }
    let sigma = 1.0 / (u + 1.0 / (1.0 + a));
    let f = |q: f64| {
        if q >= 1.0 {
            return 0.0;
        }
        let s = sigma * q / (1.0 - q);
        let ds = sigma / ((1.0 - q) * (1.0 - q));
        (-u * s).exp() / (1.0 + (a + s) * (a + s)) * ds
    };
    adaptive_pieces(f, &[0.0, 0.1, 0.5, 0.9, 1.0], 1e-12)
}

/// `F(u, v) = ∫₀^v exp(−u·tan ξ) dξ` by adaptive quadrature (paper C's own function, for
/// measuring its table scheme).
pub fn f_exact(u: f64, v: f64) -> f64 {
    let f = |x: f64| {
        let t = x.tan();
        if t.is_finite() { (-u * t).exp() } else { 0.0 }
    };
    let mut points = vec![0.0];
    if u > 1.0 {
        for c in [1.0, 8.0, 64.0] {
            let p = (c / u).atan();
            if p < v {
                points.push(p);
            }
        }
    }
    points.push(v);
    adaptive_pieces(f, &points, TOL)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper_c::special::g_edge;

    #[test]
    fn h_agrees_with_its_oracle_and_limits() {
        for &u in &[0.0, 1e-8, 1e-3, 0.3, 1.0, 7.0, 100.0, 1e5] {
            for &w in &[0.0, 0.2, 0.785, 1.3, 1.55, FRAC_PI_2 - 1e-4] {
                let (h, o) = (h_exact(u, w), h_oracle(u, w));
                assert!((h / o - 1.0).abs() < 1e-9, "H({u}, {w}) = {h} vs {o}");
            }
        }
        // H(0, w) = π/2 − w; H ≈ cos²w/u for large u.
        assert!((h_exact(0.0, 0.4) - (FRAC_PI_2 - 0.4)).abs() < 1e-15);
        let u = 1e7;
        let w: f64 = 0.6;
        assert!((h_exact(u, w) * u / (w.cos() * w.cos()) - 1.0).abs() < 1e-6);
        // The δ = 0 edge is (1 + ρ)·g(ρ); the ρ = ∞ edge is sin δ/δ.
        for &rho in &[1e-3, 0.5, 3.0, 50.0, 5e3] {
            let k = k_exact(rho, 0.0);
            assert!(
                (k / ((1.0 + rho) * g_edge(rho)) - 1.0).abs() < 1e-9,
                "{rho}"
            );
        }
        let k = k_exact(1e9, 1.0);
        assert!((k / (1f64.sin() / 1.0) - 1.0).abs() < 1e-7, "{k}");
    }

    #[test]
    fn f_relates_to_h() {
        // F(u, π/2) − F(u, w) = e^{−u·tan w}·H(u, w).
        for &(u, w) in &[(0.5, 0.3), (3.0, 1.0), (0.01, 1.4)] {
            let d = f_exact(u, FRAC_PI_2) - f_exact(u, w);
            let h = (-u * f64::tan(w)).exp() * h_exact(u, w);
            assert!((d / h - 1.0).abs() < 1e-9, "{u} {w}: {d} vs {h}");
        }
        assert!((f_exact(0.0, 0.7) - 0.7).abs() < 1e-14);
    }
}
