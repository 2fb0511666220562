//! The environment pass's forward peak, integrated by its own shape: a rule of directions
//! around the view ray instead of the view ray alone.
//!
//! **What is integrated.** The environment pass ([`super::env_pass`]) splits HG's phase
//! function `p` (normalized to `(1/4π)∫p = 1`, Legendre coefficients `(2l+1)g^l`) into
//! its SH series cut after band `N − 1` with the factors `g^l − f`, `f = g^N`
//! ([`super::env_pass::peak_share`]), and the remainder
//! `p_f(μ) = p(μ) − Σ_{l<N} (g^l − f)(2l+1)·P_l(μ)`, whose Legendre coefficients are `f`
//! for `l < N` and `g^l` beyond: so `(1/4π)∫p_f = f`. The single scattering it adds at a
//! voxel `u` seen along `d` is `Ω·(1/4π)∫ p_f(ω·d)·L(ω)·T(u, ω) dω` (`L` the distant
//! light, `T` the transmittance towards it).
//!
//! **The δ** ([`PeakRule::delta`]). Where the cut is small (`f ≤` [`SHAPED_MIN`]) the
//! remainder is taken as `f` times a δ at `d`: `Ω·f·L(d)·T(u, d)`, one march.
//!
//! **The shaped rule** ([`PeakRule::new`]). At g 0.8 and `N = 4`, `p_f` is a lobe of
//! about 10° half-width that holds `0.47 · 4π` within its first zero (32°), with an
//! oscillating tail of `−0.06 · 4π` beyond; seen as a δ, thick front-lit smoke comes out
//! 8–12 % off a path tracer (BENCHMARKS.md "Skies of every shape"). The rule cuts the
//! angle `θ` from `d` into [`INNER_CELLS`] equal cells up to the first zero `θ₀` of `p_f`
//! and [`TAIL_CELLS`] from `θ₀` to π. A cell's weight is its share of the remainder,
//! `(1/4π)∫_cell p_f(cos θ)·2π sin θ dθ` (the weights sum to `f`, so a constant `L·T` is
//! integrated exactly); its node is at the cell's weighted mean angle (clamped to the
//! cell), and [`AZIMUTHS`] directions share its weight around `d`. The azimuths turn by a
//! fraction [`spin`] of their spacing from voxel to voxel (the golden-ratio sequence of
//! the voxel's index): without it every voxel aliases `T`'s angular detail the same way
//! and the error does not fall with more azimuths; with it, 2 azimuths a cell measure as
//! 4 and 8 do.

use crate::sh;
use std::f64::consts::PI;

/// `f` above which the remainder is integrated by its shape: where the SH series' cut
/// band weighs more than [`sh::PHASE_CUT_WARNING`] of band 0 (g above 0.56 at order 4).
pub const SHAPED_MIN: f64 = sh::PHASE_CUT_WARNING;

/// Cells of the shaped rule between `d` and the remainder's first zero.
pub const INNER_CELLS: usize = 3;

/// Cells of the shaped rule beyond the remainder's first zero.
pub const TAIL_CELLS: usize = 1;

/// Directions per cell of the shaped rule.
pub const AZIMUTHS: usize = 2;

/// Sub-intervals per cell of the weights' midpoint rule.
const SUBSTEPS: usize = 512;

/// One ring of the rule: its angle from `d` and its weight (shared by its azimuths).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub cos: f64,
    pub sin: f64,
    /// `(1/4π)∫_cell p_f dω`.
    pub weight: f64,
}

/// The directions and weights the forward peak's remainder is integrated with (module
/// docs).
#[derive(Clone, Debug, PartialEq)]
pub struct PeakRule {
    pub cells: Vec<Cell>,
    /// Directions per cell (1 for the δ).
    pub azimuths: usize,
}

impl PeakRule {
    /// The δ of weight `f` at `d`.
    pub fn delta(f: f64) -> PeakRule {
        PeakRule {
            cells: vec![Cell {
                cos: 1.0,
                sin: 0.0,
                weight: f,
            }],
            azimuths: 1,
        }
    }

    /// The rule for HG `g` cut at SH `order` with peak share `f` (`env_pass::peak_share`;
    /// 0 for none gives an empty rule): the δ for `f ≤` [`SHAPED_MIN`], else the shaped
    /// rule.
    pub fn new(g: f64, order: usize, f: f64) -> PeakRule {
        if f.is_nan() || f <= 0.0 {
            return PeakRule {
                cells: Vec::new(),
                azimuths: 1,
            };
        }
        if f <= SHAPED_MIN || g.is_nan() || g <= 0.0 || g >= 1.0 {
            return PeakRule::delta(f);
        }
        let zero = first_zero(g, order, f);
        let bounds = (0..=INNER_CELLS)
            .map(|k| zero * k as f64 / INNER_CELLS as f64)
            .chain((1..=TAIL_CELLS).map(|k| zero + (PI - zero) * k as f64 / TAIL_CELLS as f64))
            .collect::<Vec<_>>();
        let mut cells: Vec<Cell> = bounds
            .windows(2)
            .map(|w| {
                let (a, b) = (w[0], w[1]);
                let h = (b - a) / SUBSTEPS as f64;
                let (mut mass, mut moment) = (0.0, 0.0);
                for s in 0..SUBSTEPS {
                    let t = a + (s as f64 + 0.5) * h;
                    let m = remainder(g, order, f, t.cos()) * 0.5 * t.sin() * h;
                    mass += m;
                    moment += m * t;
                }
                let theta = if mass != 0.0 {
                    (moment / mass).clamp(a, b)
                } else {
                    0.5 * (a + b)
                };
                Cell {
                    cos: theta.cos(),
                    sin: theta.sin(),
                    weight: mass,
                }
            })
            .collect();
        // The midpoint rule's sum is within ~10⁻⁶ of f; scale it to f exactly.
        let total: f64 = cells.iter().map(|c| c.weight).sum();
        if total != 0.0 {
            for c in &mut cells {
                c.weight *= f / total;
            }
        }
        PeakRule {
            cells,
            azimuths: AZIMUTHS,
        }
    }

    /// Number of directions.
    pub fn len(&self) -> usize {
        self.cells.len() * self.azimuths
    }

    /// No directions (no peak).
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The rule's directions around the unit `d` with their weights, the azimuths turned
    /// by `spin` (in `[0, 1)` of their spacing). The δ's direction is `d` itself.
    pub fn directions(&self, d: [f64; 3], spin: f64) -> impl Iterator<Item = ([f64; 3], f64)> {
        let (t1, t2) = tangents(d);
        let k = self.azimuths;
        self.cells.iter().enumerate().flat_map(move |(r, c)| {
            (0..k).map(move |j| {
                let phi = 2.0 * PI * (j as f64 + 0.5 * r as f64 + spin) / k as f64;
                let (s, co) = phi.sin_cos();
                let dir = [0, 1, 2].map(|a| c.cos * d[a] + c.sin * (co * t1[a] + s * t2[a]));
                (dir, c.weight / k as f64)
            })
        })
    }
}

/// The turn of voxel `index`'s azimuths, in `[0, 1)`: `index · 0x9E3779B9 mod 2³²`
/// (the golden ratio's fraction in 32 bits) over `2³²`, so neighbouring voxels turn far
/// apart and any run of voxels spreads evenly. The GPU twin computes the same integer.
pub fn spin(index: u32) -> f64 {
    f64::from(index.wrapping_mul(0x9E37_79B9)) / 4_294_967_296.0
}

/// Two unit vectors completing the unit `d` to a right-handed frame: `t₁ = d × a / |…|`
/// with `a` the x axis (the y axis where `|d_x| ≥ 0.9`), `t₂ = d × t₁`.
fn tangents(d: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let a = if d[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let c = cross(d, a);
    let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let t1 = if n > 0.0 { c.map(|x| x / n) } else { [0.0; 3] };
    (t1, cross(d, t1))
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The remainder `p_f(μ)` (module docs), normalized as `p`: HG's
/// `(1 − g²)/(1 + g² − 2gμ)^{3/2}` less the series' `Σ_{l<N} (g^l − f)(2l+1)·P_l(μ)`
/// (Legendre polynomials by their three-term recurrence). `|g| < 1`.
pub fn remainder(g: f64, order: usize, f: f64, mu: f64) -> f64 {
    let hg = (1.0 - g * g) / (1.0 + g * g - 2.0 * g * mu).powf(1.5);
    let (mut before, mut p) = (0.0, 1.0);
    let mut series = 0.0;
    for l in 0..order {
        series += (g.powi(l as i32) - f) * (2 * l + 1) as f64 * p;
        // P_{l+1} = ((2l + 1) μ P_l − l P_{l−1}) / (l + 1).
        let next = ((2 * l + 1) as f64 * mu * p - l as f64 * before) / (l + 1) as f64;
        before = p;
        p = next;
    }
    hg - series
}

/// The first angle where [`remainder`] reaches 0 (π if it never does): a scan in steps
/// of π/4096, then bisection to 10⁻¹² rad.
fn first_zero(g: f64, order: usize, f: f64) -> f64 {
    let at = |t: f64| remainder(g, order, f, t.cos());
    let steps = 4096;
    for s in 1..=steps {
        let (a, b) = (
            PI * (s - 1) as f64 / steps as f64,
            PI * s as f64 / steps as f64,
        );
        if at(b) <= 0.0 {
            let (mut lo, mut hi) = (a, b);
            while hi - lo > 1e-12 {
                let mid = 0.5 * (lo + hi);
                if at(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return hi;
        }
    }
    PI
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The remainder's Legendre coefficients, by Gauss–Legendre quadrature in μ (200
    /// nodes: the integrand is smooth for g ≤ 0.9), are `f` below the order and `g^l`
    /// beyond, as the split defines them.
    #[test]
    fn the_remainder_has_the_split_coefficients() {
        let (nodes, weights) = gauss_legendre(200);
        for (g, order) in [(0.8, 4), (0.6, 4), (0.9, 6), (0.7, 2)] {
            let f = f64::powi(g, order as i32);
            for l in 0..order + 4 {
                // p_f = Σ c_l (2l + 1) P_l, so (1/2)∫ p_f P_l dμ = c_l.
                let mut sum = 0.0;
                for (&mu, &w) in nodes.iter().zip(&weights) {
                    sum += 0.5 * w * remainder(g, order, f, mu) * legendre(l, mu);
                }
                let want = if l < order { f } else { g.powi(l as i32) };
                assert!(
                    (sum - want).abs() < 1e-9,
                    "g {g}, order {order}, band {l}: {sum} against {want}"
                );
            }
        }
    }

    /// The shaped rule's weights sum to `f`, its nodes lie in their cells and in order,
    /// and the δ is one direction, `d` itself.
    #[test]
    fn rules_hold_the_peaks_share() {
        for (g, order) in [(0.8, 4), (0.6, 4), (0.95, 4), (0.9, 6)] {
            let f = f64::powi(g, order as i32);
            let rule = PeakRule::new(g, order, f);
            assert_eq!(rule.len(), (INNER_CELLS + TAIL_CELLS) * AZIMUTHS);
            let sum: f64 = rule.cells.iter().map(|c| c.weight).sum();
            assert!((sum - f).abs() < 1e-12 * f, "g {g}: {sum} against {f}");
            let angles: Vec<f64> = rule.cells.iter().map(|c| c.sin.atan2(c.cos)).collect();
            assert!(angles.windows(2).all(|w| w[0] < w[1]), "{angles:?}");
            // The inner cells hold more than the whole peak (the tail is negative).
            let inner: f64 = rule.cells[..INNER_CELLS].iter().map(|c| c.weight).sum();
            assert!(inner > f && rule.cells[INNER_CELLS].weight < 0.0);
        }
        let d = [0.0, 0.6, 0.8];
        let delta = PeakRule::new(0.5, 4, 0.0625);
        assert_eq!(delta, PeakRule::delta(0.0625));
        assert_eq!(
            delta.directions(d, 0.3).collect::<Vec<_>>(),
            vec![(d, 0.0625)]
        );
        assert!(PeakRule::new(0.0, 4, 0.0).is_empty());
        assert!(PeakRule::new(f64::NAN, 4, f64::NAN).is_empty());
    }

    /// Against brute force: `(1/4π)∫ p_f(ω·d) F(ω) dω` for smooth lobes `F = e^{κ ω·a}`
    /// of widths like a shadow's edge (κ 4–12, `a` 0–40° from `d`), by a product rule of
    /// 2000 × 400 cells in `θ` (from `d`) and azimuth, against the rule averaged over its
    /// spins. The rule is a midpoint rule over cells ~10° wide: within 2 % (measured
    /// 0.5–1.6 %). The δ at `d` is 1.4 % off the centred lobe and 5–8 % off the tilted
    /// ones, which the same bound would fail.
    #[test]
    fn the_rule_integrates_smooth_lobes_better_than_the_delta() {
        let (g, order) = (0.8, 4);
        let f = f64::powi(g, order as i32);
        let rule = PeakRule::new(g, order, f);
        let d = [0.36, -0.48, 0.8];
        let (t1, t2) = tangents(d);
        for (kappa, tilt) in [(4.0, 0.0), (8.0, 0.2), (12.0, 0.4), (8.0, 0.7)] {
            let (st, ct) = f64::sin_cos(tilt);
            let a = [0, 1, 2].map(|k| ct * d[k] + st * t1[k]);
            let lobe = |w: [f64; 3]| (kappa * (w[0] * a[0] + w[1] * a[1] + w[2] * a[2])).exp();
            let (nt, np) = (2000, 400);
            let mut exact = 0.0;
            for i in 0..nt {
                let t = PI * (i as f64 + 0.5) / nt as f64;
                let p = remainder(g, order, f, t.cos()) * t.sin() * (PI / nt as f64);
                for j in 0..np {
                    let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                    let w = [0, 1, 2].map(|k| {
                        t.cos() * d[k] + t.sin() * (phi.cos() * t1[k] + phi.sin() * t2[k])
                    });
                    exact += p * lobe(w) * (2.0 * PI / np as f64);
                }
            }
            exact /= 4.0 * PI;
            let spins = 64;
            let ruled: f64 = (0..spins)
                .map(|s| {
                    rule.directions(d, s as f64 / spins as f64)
                        .map(|(w, wt)| wt * lobe(w))
                        .sum::<f64>()
                })
                .sum::<f64>()
                / spins as f64;
            let delta = f * lobe(d);
            let (e_rule, e_delta) = ((ruled - exact).abs() / exact, (delta - exact).abs() / exact);
            assert!(
                e_rule < 0.02 && (tilt == 0.0 || e_delta > 0.04),
                "κ {kappa}, tilt {tilt}: rule {ruled} ({e_rule:.4}), δ {delta} ({e_delta:.4}), exact {exact}"
            );
        }
    }

    /// Directions are unit vectors, the spin turns them about `d`, and an axis-aligned or
    /// x-leaning `d` still gets a frame.
    #[test]
    fn directions_are_unit_and_turn_with_the_spin() {
        let rule = PeakRule::new(0.8, 4, 0.4096);
        let lean = [0.95, 0.0, (1.0f64 - 0.95 * 0.95).sqrt()];
        for d in [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], lean] {
            for spin in [0.0, 0.25, 0.999] {
                for (w, _) in rule.directions(d, spin) {
                    let n = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
                    assert!((n - 1.0).abs() < 1e-12, "{d:?}: |ω| = {n}");
                }
            }
            let a: Vec<_> = rule.directions(d, 0.0).collect();
            let b: Vec<_> = rule.directions(d, 0.5).collect();
            // Same angles from d, other azimuths.
            for ((wa, _), (wb, _)) in a.iter().zip(&b) {
                let dot = |w: &[f64; 3]| w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
                assert!((dot(wa) - dot(wb)).abs() < 1e-12);
                assert!(wa != wb);
            }
        }
        assert_eq!(spin(0), 0.0);
        assert!((spin(1) - 0.618_033_988_7).abs() < 1e-9);
        assert!((0..10_000).map(spin).all(|s| (0.0..1.0).contains(&s)));
    }

    fn legendre(l: usize, mu: f64) -> f64 {
        let (mut before, mut p) = (0.0, 1.0);
        for k in 0..l {
            let next = ((2 * k + 1) as f64 * mu * p - k as f64 * before) / (k + 1) as f64;
            before = p;
            p = next;
        }
        p
    }

    /// Gauss–Legendre nodes and weights on [−1, 1] (Newton on `P_n`).
    fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
        let mut nodes = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        for i in 0..n {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (p, q) = (legendre(n, x), legendre(n - 1, x));
                dp = n as f64 * (x * p - q) / (x * x - 1.0);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            nodes.push(x);
            weights.push(2.0 / ((1.0 - x * x) * dp * dp));
        }
        (nodes, weights)
    }
}
