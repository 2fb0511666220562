//! Special functions for closed-form limits: the exponential integral.

/// `eˣ·E₁(x)` for `x > 0` (`E₁(x) = ∫₁^∞ e^{−xt}/t dt`), accurate to about 1e-15:
/// the power series `E₁ = −γ − ln x − Σ (−x)ᵏ/(k·k!)` for `x ≤ 1`, the continued
/// fraction (modified Lentz) above. `+∞` at 0.
pub fn exp_e1(x: f64) -> f64 {
    if x <= 0.0 {
        return f64::INFINITY;
    }
    if x <= 1.0 {
        const EULER: f64 = 0.577_215_664_901_532_9;
        let mut sum = 0.0;
        let mut term = 1.0;
        for k in 1..60 {
            term *= -x / k as f64;
            let t = term / k as f64;
            sum += t;
            if t.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        return (-EULER - x.ln() - sum) * x.exp();
    }
    // E₁(x) = e^{−x} · 1/(x + 1 − 1/(x + 3 − 4/(x + 5 − …))).
    let tiny = 1e-300;
    let mut b = x + 1.0;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..200 {
        let a = -((i * i) as f64);
        b += 2.0;
        d = 1.0 / (a * d + b);
        c = b + a / c;
        let del = c * d;
        h *= del;
        if (del - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h
}

/// `g(c) = 1 − c·e^c·E₁(c)` (`g(0) = 1`, `g ≈ 1/c − 2/c²` for large `c`): the value of
/// `H(u, w)·(1 + ρ)/(π/2 − w)` at `w = π/2` (see [`crate::paper_c::hfunc`]). For large `c` the
/// asymptotic series is used (the difference cancels there).
pub fn g_edge(c: f64) -> f64 {
    if c <= 0.0 {
        return 1.0;
    }
    if c > 1e3 {
        // 1 − c·(1/c − 1/c² + 2/c³ − 6/c⁴ + 24/c⁵ − 120/c⁶ …)
        let r = 1.0 / c;
        return r * (1.0 - r * (2.0 - r * (6.0 - r * (24.0 - r * (120.0 - r * 720.0)))));
    }
    1.0 - c * exp_e1(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper_c::quad::adaptive;

    #[test]
    fn exp_e1_matches_quadrature() {
        for &x in &[1e-6, 0.01, 0.5, 1.0, 1.0001, 2.0, 7.5, 30.0, 200.0] {
            // eˣE₁(x) = ∫₀^∞ e^{−s}/(x + s) ds, s = q/(1 − q).
            let q = adaptive(
                |q: f64| {
                    let s = q / (1.0 - q);
                    if q >= 1.0 {
                        0.0
                    } else {
                        (-s).exp() / (x + s) / ((1.0 - q) * (1.0 - q))
                    }
                },
                0.0,
                1.0,
                1e-14,
            );
            let v = exp_e1(x);
            assert!((v / q - 1.0).abs() < 1e-12, "{x}: {v} vs {q}");
        }
    }

    #[test]
    fn g_edge_is_continuous_across_its_branches() {
        let a = g_edge(1e3);
        let b = g_edge(1e3 + 1e-7);
        assert!((a / b - 1.0).abs() < 1e-9, "{a} {b}");
        // g(c) = ∫₀^∞ e^{−ct}/(1 + t)² dt = ∫₀¹ e^{−c·s/(1−s)} ds.
        for &c in &[0.0, 1e-3, 0.7, 5.0, 39.0, 60.0, 999.0, 1e4] {
            let q = adaptive(
                |s: f64| {
                    if s >= 1.0 {
                        0.0
                    } else {
                        (-c * s / (1.0 - s)).exp()
                    }
                },
                0.0,
                1.0,
                1e-13,
            );
            let g = g_edge(c);
            assert!((g / q - 1.0).abs() < 1e-9, "{c}: {g} vs {q}");
        }
    }
}
