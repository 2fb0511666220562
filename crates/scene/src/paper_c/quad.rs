//! Numerical quadrature, used to build the tables and as the independent reference:
//! adaptive Gauss–Kronrod (7/15 points) and fixed Gauss–Legendre rules.

/// Gauss–Kronrod 15-point nodes on [−1, 1] (non-negative half, descending), their Kronrod
/// weights, and the weights of the embedded 7-point Gauss rule (odd-indexed nodes).
const XK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
const WK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_8,
];
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// One Gauss–Kronrod 15 panel on `[a, b]`: (Kronrod estimate, |Kronrod − Gauss|).
fn gk15(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let fc = f(c);
    let mut k = WK[7] * fc;
    let mut g = WG[3] * fc;
    for i in 0..7 {
        let x = h * XK[i];
        let s = f(c - x) + f(c + x);
        k += WK[i] * s;
        if i % 2 == 1 {
            g += WG[i / 2] * s;
        }
    }
    (k * h, ((k - g) * h).abs())
}

/// `∫_a^b f` by adaptive Gauss–Kronrod bisection until the error estimate of every panel
/// is below `tol · max(|panel|, floor)`, where `floor` is the running total's scale
/// (relative tolerance on the whole integral) or a depth of 40 is reached. Finite
/// integrands on a finite interval only (map infinite ones first).
pub fn adaptive(mut f: impl FnMut(f64) -> f64, a: f64, b: f64, tol: f64) -> f64 {
    if a == b {
        return 0.0;
    }
    let (whole, _) = gk15(&mut f, a, b);
    let scale = whole.abs();
    let mut total = 0.0;
    let mut stack = vec![(a, b, 0u32)];
    while let Some((lo, hi, depth)) = stack.pop() {
        let (v, e) = gk15(&mut f, lo, hi);
        if e <= tol * scale.max(v.abs()) || e == 0.0 || depth >= 40 || !e.is_finite() {
            total += v;
        } else {
            let mid = 0.5 * (lo + hi);
            stack.push((lo, mid, depth + 1));
            stack.push((mid, hi, depth + 1));
        }
    }
    total
}

/// [`adaptive`] over consecutive pieces `[p₀, p₁], [p₁, p₂], …` (breakpoints where the
/// integrand has a kink or a narrow peak), each with the relative tolerance `tol`.
pub fn adaptive_pieces(mut f: impl FnMut(f64) -> f64, points: &[f64], tol: f64) -> f64 {
    points
        .windows(2)
        .map(|w| adaptive(&mut f, w[0], w[1], tol))
        .sum()
}

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on the Legendre recurrence).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            // p1 = P_n(x), p0 = P_{n−1}(x).
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

/// `∫_a^b f` by the Gauss–Legendre `rule` (from [`gauss_legendre`]) on `panels` equal
/// panels.
pub fn composite(
    f: impl Fn(f64) -> f64,
    a: f64,
    b: f64,
    rule: &[(f64, f64)],
    panels: usize,
) -> f64 {
    let h = (b - a) / panels as f64;
    let mut s = 0.0;
    for p in 0..panels {
        let c = a + (p as f64 + 0.5) * h;
        for &(x, w) in rule {
            s += w * f(c + 0.5 * h * x);
        }
    }
    0.5 * h * s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_integrate_known_functions() {
        // ∫₀^π sin = 2; ∫₀¹ √x = 2/3 (endpoint singularity of the derivative).
        let s = adaptive(f64::sin, 0.0, std::f64::consts::PI, 1e-12);
        assert!((s - 2.0).abs() < 1e-13, "{s}");
        let r = adaptive(f64::sqrt, 0.0, 1.0, 1e-10);
        assert!((r - 2.0 / 3.0).abs() < 1e-10, "{r}");
        // A narrow peak: ∫ e^{−(x/ε)²} = ε√π, found when breakpoints bracket it on its own
        // scale (a panel whose 15 nodes all miss a peak cannot see it).
        let e = 1e-4;
        let pts = [-1.0, -10.0 * e, 0.0, 10.0 * e, 1.0];
        let p = adaptive_pieces(|x| (-(x / e) * (x / e)).exp(), &pts, 1e-12);
        assert!(
            (p / (e * std::f64::consts::PI.sqrt()) - 1.0).abs() < 1e-10,
            "{p}"
        );
        // Gauss–Legendre with n nodes is exact for degree 2n − 1.
        for n in [1, 2, 5, 16, 48] {
            let rule = gauss_legendre(n);
            let w: f64 = rule.iter().map(|r| r.1).sum();
            assert!((w - 2.0).abs() < 1e-13, "{n}: {w}");
            let d = 2 * n - 1;
            let v = composite(|x| x.powi(d as i32 - 1) * (d as f64), 0.0, 1.0, &rule, 1);
            assert!((v - 1.0).abs() < 1e-12, "{n}: {v}");
        }
    }
}
