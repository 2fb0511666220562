//! Polynomial functions (paper D §3.2.2): a polynomial in one to three projections
//! `s_j = a_j·(x − center)` (unit axes `a_j`), defined on the reference cell
//! `[−C, C]` per axis and either tiled periodically over space (the paper's default; the
//! user makes it continuous across the cell's borders) or zero outside the cell.
//!
//! **Integrals.** Along `x = o + t w`, `t ∈ [0, L]`, each `s_j` is linear in `t`.
//! - One periodic axis, in O(1) whatever the number of cells crossed: with `Q` an
//!   antiderivative of `P` and `m(s) = ⌊(s + C)/2C⌋` the cell of `s`,
//!   `Φ(s) = ∫_{−C}^{s} P_periodic = m·(Q(C) − Q(−C)) + Q(s − 2Cm) − Q(−C)`, and
//!   `∫₀^L P = (Φ(b) − Φ(a))/δ` with `a = s(o)`, `δ = a₁·w`, `b = a + δL` — used when the
//!   ray spans at least one cell (`|δL| ≥ 2C`), so that the division by `δ` loses nothing.
//! - Otherwise (several axes, a ray within a cell, or a ray nearly parallel to the axis'
//!   planes): the ray is cut where it crosses a cell border of any axis (a DDA: the paper's
//!   "decompose each portion of the path in each bounded area", its Fig. 3) or clipped to
//!   the cell, and each piece, on which the integrand is a polynomial in `t` of the total
//!   degree `n ≤ 9`, is integrated exactly by 5-point Gauss–Legendre (exact to degree 9);
//!   no division by `a_j·w`.

use crate::vec3::{Vec3, dot, sub};

/// Most total degree: what 5-point Gauss–Legendre integrates exactly.
pub const MAX_DEGREE: u32 = 9;

/// Gauss–Legendre nodes and weights on `[−1, 1]`, 5 points.
pub const GL5: [(f64, f64); 5] = [
    (0.0, 0.568_888_888_888_888_9),
    (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
    (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
    (0.906_179_845_938_664, 0.236_926_885_056_189_1),
];

/// A polynomial on a cell, periodic or zero outside it.
#[derive(Clone, Debug, PartialEq)]
pub struct Polynomial {
    /// One to three unit axes.
    pub axes: Vec<Vec3>,
    pub center: Vec3,
    /// `C`: the cell is `[−C, C]` on every axis.
    pub half: f64,
    pub periodic: bool,
    /// `(coefficient, powers)`: `Σ coef·Π s_j^{p_j}` (powers of missing axes are 0).
    pub monomials: Vec<(f64, [u32; 3])>,
}

impl Polynomial {
    /// `P` at cell coordinates `s`.
    pub fn eval(&self, s: [f64; 3]) -> f64 {
        self.monomials
            .iter()
            .map(|&(c, p)| {
                c * s[0].powi(p[0] as i32) * s[1].powi(p[1] as i32) * s[2].powi(p[2] as i32)
            })
            .sum()
    }

    /// The projections `s_j` of `x` (unwrapped).
    pub fn coords(&self, x: Vec3) -> [f64; 3] {
        let r = sub(x, self.center);
        let mut s = [0.0; 3];
        for (sj, a) in s.iter_mut().zip(&self.axes) {
            *sj = dot(*a, r);
        }
        s
    }

    /// `s` wrapped into the reference cell `[−C, C)`.
    pub fn wrap(&self, s: f64) -> f64 {
        let p = 2.0 * self.half;
        s - p * ((s + self.half) / p).floor()
    }

    pub fn value(&self, x: Vec3) -> f64 {
        let mut s = self.coords(x);
        let n = self.axes.len();
        if self.periodic {
            for sj in s.iter_mut().take(n) {
                *sj = self.wrap(*sj);
            }
        } else if s[..n].iter().any(|v| v.abs() > self.half) {
            return 0.0;
        }
        self.eval(s)
    }

    /// `Q(s) = Σ c s^{p+1}/(p + 1)` of a one-axis polynomial.
    fn antiderivative(&self, s: f64) -> f64 {
        self.monomials
            .iter()
            .map(|&(c, p)| c * s.powi(p[0] as i32 + 1) / f64::from(p[0] + 1))
            .sum()
    }

    /// `Φ(s) = ∫_{−C}^{s}` of the periodic one-axis polynomial (module docs).
    pub fn phi(&self, s: f64) -> f64 {
        let (c, p) = (self.half, 2.0 * self.half);
        let m = ((s + c) / p).floor();
        let q_c = self.antiderivative(-c);
        m * (self.antiderivative(c) - q_c) + self.antiderivative(s - p * m) - q_c
    }

    /// `∫₀^len γ(o + t w) dt` (module docs).
    pub fn integral(&self, o: Vec3, w: Vec3, len: f64) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        let s0 = self.coords(o);
        let mut ds = [0.0; 3];
        for (d, a) in ds.iter_mut().zip(&self.axes) {
            *d = dot(*a, w);
        }
        let n = self.axes.len();
        if !self.periodic {
            return self.clipped(s0, ds, len);
        }
        if n == 1 && (ds[0] * len).abs() >= 2.0 * self.half {
            let a = s0[0];
            return (self.phi(a + ds[0] * len) - self.phi(a)) / ds[0];
        }
        self.walk(s0, ds, len)
    }

    /// Gauss–Legendre on `[t0, t1]` of `P(s0 + t·ds − shift)`.
    fn piece(&self, s0: [f64; 3], ds: [f64; 3], shift: [f64; 3], t0: f64, t1: f64) -> f64 {
        let (mid, half) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
        GL5.iter()
            .map(|&(x, wt)| {
                let t = mid + half * x;
                wt * self.eval([0, 1, 2].map(|j| s0[j] + t * ds[j] - shift[j]))
            })
            .sum::<f64>()
            * half
    }

    /// Zero outside the cell: the ray clipped to `|s_j| ≤ C` (slabs), one piece.
    fn clipped(&self, s0: [f64; 3], ds: [f64; 3], len: f64) -> f64 {
        let (mut t0, mut t1) = (0.0f64, len);
        for j in 0..self.axes.len() {
            if ds[j] == 0.0 {
                if s0[j].abs() > self.half {
                    return 0.0;
                }
                continue;
            }
            let (a, b) = ((-self.half - s0[j]) / ds[j], (self.half - s0[j]) / ds[j]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        if t1 <= t0 {
            return 0.0;
        }
        self.piece(s0, ds, [0.0; 3], t0, t1)
    }

    /// Periodic: the ray cut at every cell border (DDA), each piece shifted into the
    /// reference cell.
    fn walk(&self, s0: [f64; 3], ds: [f64; 3], len: f64) -> f64 {
        let (c, p) = (self.half, 2.0 * self.half);
        let n = self.axes.len();
        // Per axis: the next border crossing and the spacing of crossings.
        let mut next = [f64::INFINITY; 3];
        let mut step = [f64::INFINITY; 3];
        for j in 0..n {
            if ds[j] != 0.0 {
                let m = ((s0[j] + c) / p).floor();
                let border = if ds[j] > 0.0 {
                    (m + 1.0) * p - c
                } else {
                    m * p - c
                };
                next[j] = ((border - s0[j]) / ds[j]).max(0.0);
                step[j] = p / ds[j].abs();
            }
        }
        let mut t = 0.0;
        let mut total = 0.0;
        while t < len {
            let j = (0..n)
                .min_by(|&a, &b| next[a].total_cmp(&next[b]))
                .unwrap_or(0);
            let end = next[j].min(len);
            if end > t {
                let mid = 0.5 * (t + end);
                let shift = [0, 1, 2].map(|k| {
                    if k < n {
                        p * ((s0[k] + mid * ds[k] + c) / p).floor()
                    } else {
                        0.0
                    }
                });
                total += self.piece(s0, ds, shift, t, end);
            }
            t = end;
            next[j] += step[j];
        }
        total
    }

    /// A lower bound of `P` over the cell (of `min(0, P)` when zero outside it): the least
    /// value on a grid of spacing `h` less the most `P` can fall between grid points,
    /// `Σ_j G_j h/2` with `G_j = Σ |c|·p_j C^{p_j − 1}·Π_{k≠j} C^{p_k}` bounding
    /// `|∂P/∂s_j|` on the cell.
    pub fn lower_bound(&self) -> f64 {
        let n = self.axes.len();
        let per_axis = [1025usize, 129, 33][n - 1];
        let c = self.half;
        let h = 2.0 * c / (per_axis - 1) as f64;
        let mut least = f64::INFINITY;
        let total = per_axis.pow(n as u32);
        for i in 0..total {
            let mut s = [0.0; 3];
            let mut r = i;
            for sj in s.iter_mut().take(n) {
                *sj = -c + (r % per_axis) as f64 * h;
                r /= per_axis;
            }
            least = least.min(self.eval(s));
        }
        let mut margin = 0.0;
        for j in 0..n {
            let g: f64 = self
                .monomials
                .iter()
                .filter(|(_, p)| p[j] > 0)
                .map(|&(coef, p)| {
                    coef.abs()
                        * f64::from(p[j])
                        * (0..3)
                            .map(|k| c.powi(p[k] as i32 - i32::from(k == j)))
                            .product::<f64>()
                })
                .sum();
            margin += g * 0.5 * h;
        }
        let bound = least - margin;
        if self.periodic { bound } else { bound.min(0.0) }
    }
}
