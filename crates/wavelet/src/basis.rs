//! Scaling functions, wavelets and their filters (paper E §3.2, §4.1).
//!
//! # Scaling functions
//!
//! The scaling function of degree `d` is the cardinal B-spline `φ = B_d` on the integer
//! knots `0, 1, …, d+1`: `B_0` is the box of `[0, 1)` (Haar), and
//! `B_d(x) = ∫_{x−1}^{x} B_{d−1}(y) dy`. On each unit cell `[j, j+1]` it is one polynomial
//! `β_j(s)` of the local coordinate `s = x − j ∈ [0, 1]`; the recursion above gives the
//! pieces of degree `d` from those of degree `d − 1`:
//!
//! `β_j^d(s) = ∫_s^1 β_{j−1}^{d−1}(y) dy + ∫_0^s β_j^{d−1}(y) dy`,
//!
//! which [`Basis::pieces`] evaluates exactly on power-form polynomials:
//! Haar `β_0 = 1`; linear `β_0 = s`, `β_1 = 1 − s`; quadratic `β_0 = s²/2`,
//! `β_1 = ½ + s − s²`, `β_2 = (1 − s)²/2`. B-splines are non-negative, sum to one over
//! the integer translates and integrate to one: a fog made of non-negative coefficients
//! is non-negative everywhere, as the paper requires (§4.1).
//!
//! # Two-scale relations
//!
//! `B_d` is the `(d+1)`-fold convolution of the box, whose two-scale relation is
//! `B_0(x) = B_0(2x) + B_0(2x − 1)`; convolving `d + 1` times (and rescaling the
//! convolution to the half-size boxes) gives the refinement sequence of eq. 6,
//!
//! `φ(x) = Σ_m p_m φ(2x − m)`, `p_m = 2^{−d} C(d+1, m)`, `m = 0 … d+1`:
//! Haar `(1, 1)`, linear `(½, 1, ½)`, quadratic `(¼, ¾, ¾, ¼)`.
//!
//! # Wavelets: biorthogonal spline wavelets (Cohen–Daubechies–Feauveau)
//!
//! A level's fine coefficients `c_i` (of `φ(y − i)`) split into coarse coefficients
//! `s_k` (of `φ(y/2 − k)`) and details `d_k` (of `ψ(y/2 − k)`):
//!
//! * synthesis: `c_i = Σ_k s_k p_{i−2k} + d_k q_{i−2k}` (the two-scale relations of φ
//!   and of the wavelet, eq. 8: `ψ(x) = Σ_i q_i φ(2x − i)`);
//! * analysis: `s_k = Σ_i a_{i−2k} c_i`, `d_k = Σ_i b_{i−2k} c_i`.
//!
//! Perfect reconstruction holds exactly when
//! (1) `Σ_i a_i p_{i−2n} = δ_n`, and the other three sequences are the alternating flips
//! (2) `q_i = (−1)^i a_{1−i}` and `b_i = (−1)^i p_{1−i}`: then `Σ b_i p_{i−2n} = 0` and
//! `Σ a_i q_{i−2n} = 0` because each sum is mapped to minus itself by `i → 1 − i + 2n`,
//! and `Σ b_i q_{i−2n} = Σ_j p_j a_{j+2n} = δ_n` by (1). The 2×2 polyphase matrices of
//! analysis and synthesis are then inverse Laurent-polynomial matrices, so the transform
//! is lossless in both directions.
//!
//! The primal functions are the B-splines themselves (synthesis uses only `p` and `q`,
//! i.e. only B-splines), so every level is a B-spline fog. The dual lowpass `a` is the
//! shortest symmetric FIR solution of (1) whose wavelet has zero mean (`Σ q = 0`, i.e.
//! `Σ (−1)^i a_i = 0`); then `Σ a = 1` and a coarse coefficient is a weighted average, so a
//! constant fog keeps its density across levels:
//!
//! * Haar, `a = (½, ½)` at `i = 0, 1`: (1) at `n = 0` is `a_0 + a_1 = 1`; symmetry does
//!   the rest. The orthogonal Haar transform (averages and differences), CDF(1,1);
//!   wavelet `q = (½, −½)`.
//! * linear, `a = (−1, 2, 6, 2, −1)/8` at `i = −1 … 3`: with taps `(α, β, γ, β, α)`
//!   centred on `p`'s centre, (1) at `n = 0` reads `β + γ = 1` and at `n = ±1`
//!   `β/2 + α = 0`; a zero-mean wavelet adds `2β − 2α − γ = 0`, so `β = ¼`, `γ = ¾`,
//!   `α = −⅛`. This is CDF(2,2), the "5/3" pair; the wavelet
//!   `q = (−1, −2, 6, −2, −1)/8` at `i = −2 … 2` is symmetric, so it has two vanishing
//!   moments; it spans three coarse cells.
//! * quadratic, `a = (−1, 3, 3, −1)/4` at `i = 0 … 3`: with `(α, β, β, α)`, (1) at `n = 0`
//!   reads `(2α + 6β)/4 = 1` and at `n = ±1` `(β + 3α)/4 = 0`, so `α = −¼`, `β = ¾`; the
//!   wavelet `q = (−1, −3, 3, 1)/4` at `i = −2 … 1` has zero mean by symmetry. This is
//!   CDF(3,1); the wavelet spans three coarse cells, like the scaling function.
//!
//! Why biorthogonal rather than the semi-orthogonal spline wavelets of Stollnitz, DeRose &
//! Salesin: both share the B-spline scaling functions, but semi-orthogonal analysis
//! filters are infinite (the inverse of the B-spline Gram matrix), so a finite fogmap
//! would need truncated or boundary-adapted filters. With finite `a` and `b` a finite
//! fogmap has finitely many non-zero coefficients at every level, computed exactly.
//!
//! No linear lossless transform with quadratic B-spline synthesis can have a
//! non-negative `a` (every position is hit by some shift `2n ≠ 0` of the four positive
//! taps of `p`, so (1) forces a non-negative `a` to vanish), and for the linear B-spline
//! the only non-negative choice is plain subsampling. Coarse approximations of a
//! non-negative fog can therefore dip slightly below zero near sharp edges; see `lod` for
//! how the renderer stays exact anyway.

/// A polynomial of degree at most 2 in power form: `c[0] + c[1]·s + c[2]·s²`.
pub type Poly = [f64; 3];

/// The basis family of a fog (paper E figure 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Basis {
    /// Degree 0: box scaling functions, support one cell.
    Haar,
    /// Degree 1: hat functions, support two cells.
    Linear,
    /// Degree 2: quadratic B-splines, support three cells.
    Quadratic,
}

impl Basis {
    /// Every basis, coarsest degree first.
    pub const ALL: [Basis; 3] = [Basis::Haar, Basis::Linear, Basis::Quadratic];

    /// Polynomial degree `d` of the B-spline.
    pub fn degree(self) -> usize {
        match self {
            Basis::Haar => 0,
            Basis::Linear => 1,
            Basis::Quadratic => 2,
        }
    }

    /// Cells covered by one scaling function, `d + 1`.
    pub fn support(self) -> usize {
        self.degree() + 1
    }

    /// Lower-case name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Basis::Haar => "haar",
            Basis::Linear => "linear",
            Basis::Quadratic => "quadratic",
        }
    }

    /// The pieces `β_0 … β_d` of the B-spline of this degree, derived by the convolution
    /// recursion of the module docs.
    pub fn pieces(self) -> Vec<Poly> {
        let mut pieces = vec![[1.0, 0.0, 0.0]];
        for d in 1..=self.degree() {
            let lower = pieces;
            pieces = (0..=d)
                .map(|j| {
                    let mut out = [0.0; 3];
                    if j >= 1 {
                        // ∫_s^1 β_{j−1} = F(1) − F(s).
                        let f = antiderivative(&lower[j - 1]);
                        out[0] += eval_poly(&f, 1.0);
                        for n in 0..3 {
                            out[n] -= f[n];
                        }
                    }
                    if j < d {
                        // ∫_0^s β_j = F(s).
                        let f = antiderivative(&lower[j]);
                        for n in 0..3 {
                            out[n] += f[n];
                        }
                    }
                    out
                })
                .collect();
        }
        pieces
    }

    /// The four sequences of the filter bank (module docs).
    pub fn filters(self) -> Filters {
        let d = self.degree();
        let binom =
            |n: usize, k: usize| (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64);
        let p = Filter {
            first: 0,
            taps: (0..=d + 1)
                .map(|m| binom(d + 1, m) / f64::from(1u32 << d))
                .collect(),
        };
        let a = match self {
            Basis::Haar => Filter {
                first: 0,
                taps: vec![0.5, 0.5],
            },
            Basis::Linear => Filter {
                first: -1,
                taps: [-1.0, 2.0, 6.0, 2.0, -1.0].map(|t| t / 8.0).to_vec(),
            },
            Basis::Quadratic => Filter {
                first: 0,
                taps: [-1.0, 3.0, 3.0, -1.0].map(|t| t / 4.0).to_vec(),
            },
        };
        let q = a.alternating_flip();
        let b = p.alternating_flip();
        Filters { p, q, a, b }
    }

    /// The scaling function `φ(y − k)` on its own grid: stride 1, pieces `β_0 … β_d`.
    pub fn scaling(self) -> Piecewise {
        Piecewise {
            first: 0,
            stride: 1,
            pieces: self.pieces(),
        }
    }

    /// The function `Σ_i h_i φ(y − 2k − i)` of coefficient `k` of the next coarser level,
    /// seen on this level's grid: `h = p` gives the coarse scaling function, `h = q` the
    /// wavelet (eq. 6 and 8).
    pub fn refined(self, h: &Filter) -> Piecewise {
        let beta = self.pieces();
        let d = self.degree() as i64;
        let pieces = (h.first..=h.last() + d)
            .map(|cell| {
                let mut out = [0.0; 3];
                for (j, b) in beta.iter().enumerate() {
                    let w = h.get(cell - j as i64);
                    for n in 0..3 {
                        out[n] += w * b[n];
                    }
                }
                out
            })
            .collect();
        Piecewise {
            first: h.first,
            stride: 2,
            pieces,
        }
    }
}

impl std::fmt::Display for Basis {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A finite sequence `h_i`, `i = first … first + taps.len() − 1`, zero elsewhere.
#[derive(Clone, Debug, PartialEq)]
pub struct Filter {
    /// Index of the first tap.
    pub first: i64,
    /// The taps.
    pub taps: Vec<f64>,
}

impl Filter {
    /// Index of the last tap.
    pub fn last(&self) -> i64 {
        self.first + self.taps.len() as i64 - 1
    }

    /// `h_i`, zero outside the taps.
    pub fn get(&self, i: i64) -> f64 {
        usize::try_from(i - self.first)
            .ok()
            .and_then(|j| self.taps.get(j).copied())
            .unwrap_or(0.0)
    }

    /// `g_i = (−1)^i h_{1−i}`.
    fn alternating_flip(&self) -> Filter {
        let first = 1 - self.last();
        let taps = (first..=1 - self.first)
            .map(|i| {
                let sign = if i.rem_euclid(2) == 0 { 1.0 } else { -1.0 };
                sign * self.get(1 - i)
            })
            .collect();
        Filter { first, taps }
    }
}

/// The filter bank of one basis: synthesis `p`, `q`; analysis `a`, `b` (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Filters {
    /// Refinement sequence of the scaling function (synthesis lowpass).
    pub p: Filter,
    /// Two-scale sequence of the wavelet (synthesis highpass).
    pub q: Filter,
    /// Analysis lowpass (dual scaling function).
    pub a: Filter,
    /// Analysis highpass (dual wavelet).
    pub b: Filter,
}

/// A 1-D function made of polynomial pieces on unit cells of a grid: the function of
/// coefficient `k` has piece `j` (a polynomial of the local coordinate `s ∈ [0, 1]`) on
/// cell `stride·k + first + j`.
#[derive(Clone, Debug, PartialEq)]
pub struct Piecewise {
    /// Cell offset of the first piece of coefficient 0.
    pub first: i64,
    /// Cells between consecutive coefficients (1 on the function's own grid, 2 for a
    /// coarser level's function seen on the finer grid).
    pub stride: i64,
    /// The pieces, one per cell of the support.
    pub pieces: Vec<Poly>,
}

impl Piecewise {
    /// Cells covered by one function.
    pub fn support(&self) -> usize {
        self.pieces.len()
    }

    /// The function of coefficient `k` at grid coordinate `y` (right-continuous: a point
    /// on a grid line belongs to the cell above it).
    pub fn eval(&self, k: i64, y: f64) -> f64 {
        let cell = y.floor();
        let j = cell as i64 - self.stride * k - self.first;
        usize::try_from(j)
            .ok()
            .and_then(|j| self.pieces.get(j))
            .map_or(0.0, |p| eval_poly(p, y - cell))
    }
}

/// `p(s)` by Horner's rule.
pub fn eval_poly(p: &Poly, s: f64) -> f64 {
    (p[2] * s + p[1]) * s + p[0]
}

/// `F(s) = ∫_0^s p`, which must stay of degree ≤ 2 (p of degree ≤ 1).
fn antiderivative(p: &Poly) -> Poly {
    debug_assert!(p[2] == 0.0, "B-spline pieces have degree ≤ 2");
    [0.0, p[0], p[1] / 2.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Independent closed form of the cardinal B-spline: truncated powers,
    /// `B_d(x) = (1/d!) Σ_k (−1)^k C(d+1, k) (x − k)_+^d` (right-continuous for d = 0).
    fn bspline(d: usize, x: f64) -> f64 {
        if !(0.0..(d + 1) as f64).contains(&x) {
            return 0.0;
        }
        let mut sum = 0.0;
        let mut binom = 1.0;
        let mut fact = 1.0;
        for i in 1..=d {
            fact *= i as f64;
        }
        for k in 0..=d + 1 {
            let t = x - k as f64;
            if t >= 0.0 {
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                sum += sign * binom * t.powi(d as i32);
            }
            binom = binom * (d + 1 - k) as f64 / (k + 1) as f64;
        }
        sum / fact
    }

    fn grid_points() -> impl Iterator<Item = f64> {
        (0..=400).map(|i| -0.5 + 4.0 * i as f64 / 400.0 + 1e-3)
    }

    #[test]
    fn pieces_match_truncated_powers() {
        for basis in Basis::ALL {
            let phi = basis.scaling();
            for x in grid_points() {
                let want = bspline(basis.degree(), x);
                assert!((phi.eval(0, x) - want).abs() < 1e-14, "{basis} at {x}");
            }
        }
    }

    #[test]
    fn pieces_are_non_negative_partition_of_unity_of_unit_integral() {
        for basis in Basis::ALL {
            let pieces = basis.pieces();
            for i in 0..=100 {
                let s = i as f64 / 100.0;
                let sum: f64 = pieces.iter().map(|p| eval_poly(p, s)).sum();
                assert!((sum - 1.0).abs() < 1e-15, "{basis}");
                assert!(pieces.iter().all(|p| eval_poly(p, s) >= 0.0), "{basis}");
            }
            // ∫ φ = Σ_j ∫_0^1 β_j = Σ_j (c0 + c1/2 + c2/3).
            let integral: f64 = pieces.iter().map(|p| p[0] + p[1] / 2.0 + p[2] / 3.0).sum();
            assert!((integral - 1.0).abs() < 1e-15, "{basis}");
        }
    }

    #[test]
    fn refinement_relation_holds_pointwise() {
        for basis in Basis::ALL {
            let d = basis.degree();
            let f = basis.filters();
            assert!((f.p.taps.iter().sum::<f64>() - 2.0).abs() < 1e-15);
            for x in grid_points() {
                let fine: f64 = (f.p.first..=f.p.last())
                    .map(|m| f.p.get(m) * bspline(d, 2.0 * x - m as f64))
                    .sum();
                assert!((fine - bspline(d, x)).abs() < 1e-14, "{basis} at {x}");
                // The same function through the piece tables of the finer grid.
                let refined = basis.refined(&f.p).eval(0, 2.0 * x);
                assert!((refined - bspline(d, x)).abs() < 1e-14, "{basis} at {x}");
            }
        }
    }

    #[test]
    fn filters_are_biorthogonal() {
        let dot = |u: &Filter, v: &Filter, n: i64| -> f64 {
            (u.first.min(v.first) - 8..=u.last().max(v.last()) + 8)
                .map(|i| u.get(i) * v.get(i - 2 * n))
                .sum()
        };
        for basis in Basis::ALL {
            let f = basis.filters();
            for n in -4..=4 {
                let delta = if n == 0 { 1.0 } else { 0.0 };
                assert!(
                    (dot(&f.a, &f.p, n) - delta).abs() < 1e-15,
                    "{basis} a·p {n}"
                );
                assert!(
                    (dot(&f.b, &f.q, n) - delta).abs() < 1e-15,
                    "{basis} b·q {n}"
                );
                assert!(dot(&f.a, &f.q, n).abs() < 1e-15, "{basis} a·q {n}");
                assert!(dot(&f.b, &f.p, n).abs() < 1e-15, "{basis} b·p {n}");
            }
            assert!((f.a.taps.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn wavelets_have_zero_mean_and_documented_support() {
        for (basis, cells) in [(Basis::Haar, 1), (Basis::Linear, 3), (Basis::Quadratic, 3)] {
            let f = basis.filters();
            assert!(f.q.taps.iter().sum::<f64>().abs() < 1e-15, "{basis}");
            let psi = basis.refined(&f.q);
            // Pieces on the finer grid: two per coarse cell.
            assert_eq!(psi.support(), 2 * cells, "{basis}");
            let integral: f64 = psi
                .pieces
                .iter()
                .map(|p| p[0] + p[1] / 2.0 + p[2] / 3.0)
                .sum();
            assert!(integral.abs() < 1e-15, "{basis}");
        }
    }
}
