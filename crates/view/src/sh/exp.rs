//! SH exponentiation `exp*(f) = ∫ exp(f(ω))·Y(ω) dω` (paper A appendix and §5.3, after
//! Ren et al. 2006, "Real-time soft shadows in dynamic scenes using spherical harmonic
//! exponentiation"): the transmittance vector of a point is `exp*(−σt·Σ_h w_h T_h)`.
//!
//! **DC term.** With orthonormal SH, `Y_0 = 1/√(4π)`, so `f = f_0/√(4π) + f̂(ω)` where
//! `f̂ = (0, f_1, …)` has no constant part, and `exp(f) = exp(f_0/√(4π))·exp(f̂)` pointwise:
//! the constant factor is exact and only `exp*(f̂)` is approximated. The constant
//! function 1 has the vector `1 = (√(4π), 0, …)`.
//!
//! **Optimal linear** ([`ExpMethod::OptimalLinear`], Ren et al. §5): `exp*(f̂) ≈
//! a(‖f̂‖)·1 + b(‖f̂‖)·f̂`. [`ShExp::new`] fits `a, b` per order by weighted least squares
//! (nalgebra SVD) over 24 fixed, smoke-like shapes `f̂/‖f̂‖` (random sums of rotated
//! Gaussian-RBF optical-depth lobes, [`random_optical_depth`]) scaled to each tabulated
//! norm, against [`exp_reference`]; each shape's rows are divided by `‖exp*(f̂)‖`, so the
//! fit minimizes the summed squared *relative* error. Tabulated for `‖f̂‖ ∈ [0, NORM_MAX]`
//! (steps 1/16 up to 2, then 1/8, 1/2 and 1 above 32), interpolated linearly in
//! `ln a`, `ln b`; `a(0) = b(0) = 1` is the limit `exp(εf̂) = 1 + εf̂ + O(ε²)`. Beyond
//! `NORM_MAX` the argument is halved `k = ⌈log₂(‖f̂‖/NORM_MAX)⌉` times and the result
//! squared `k` times by triple products. One table lookup and an axpy: the GPU path.
//!
//! **Scaling and squaring** ([`ExpMethod::ScaleSquare`]): `exp(f) = exp(f/2^k)^{2^k}`,
//! the small exponential by its Taylor series in triple products (to convergence,
//! at most [`TAYLOR_TERMS`] terms), then `k` triple-product squarings. Each product is
//! projected to the order, which is this method's error; it costs `k + terms` triple
//! products and is the CPU accuracy reference. [`halvings_for`] picks `k` so that
//! `‖f̂‖/2^k ≤ 1`.

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

use super::basis::{count, eval_into, order_of};
use super::quad::SphereGrid;
use super::triple::TripleProduct;
use super::zonal::{gaussian_optical_depth_zh, zh_rotate};

/// Largest `‖f̂‖` of the optimal-linear table.
pub const NORM_MAX: f64 = 100.0;

/// Most Taylor terms of [`ExpMethod::ScaleSquare`]'s small exponential.
pub const TAYLOR_TERMS: usize = 24;

/// Shapes in the optimal-linear fit.
const FIT_SHAPES: usize = 24;

/// How [`ShExp::exp`] approximates `exp*`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExpMethod {
    /// `a(‖f̂‖)·1 + b(‖f̂‖)·f̂` from the fitted table.
    OptimalLinear,
    /// `exp(f/2^k)^{2^k}` with `k = halvings`, by Taylor series and triple products.
    ScaleSquare { halvings: u32 },
    /// Scaling and squaring with `k = halvings_for(‖f̂‖)` chosen per vector, so that the
    /// Taylor series always starts from `‖f̂‖/2^k ≤ 1` (the renderer's default).
    ScaleSquareAuto,
}

/// Smallest `k` with `norm/2^k ≤ 1`, the usual `halvings` of [`ExpMethod::ScaleSquare`].
pub fn halvings_for(norm: f64) -> u32 {
    if norm > 1.0 && norm.is_finite() {
        norm.log2().ceil() as u32
    } else {
        0
    }
}

/// `exp*` of one order. The optimal linear table is fitted on first use of
/// [`ExpMethod::OptimalLinear`] (about a second at order 6), so scaling and squaring
/// never pays for it.
#[derive(Clone, Debug)]
pub struct ShExp {
    order: usize,
    table: std::sync::OnceLock<Table>,
}

/// `ln a`, `ln b` at `norms`.
#[derive(Clone, Debug)]
struct Table {
    norms: Vec<f64>,
    ln_a: Vec<f64>,
    ln_b: Vec<f64>,
}

fn table_norms() -> Vec<f64> {
    let mut v = vec![0.0];
    for (step, end) in [
        (1.0 / 16.0, 2.0),
        (0.125, 8.0),
        (0.5, 32.0),
        (1.0, NORM_MAX),
    ] {
        while *v.last().unwrap() < end - 1e-9 {
            v.push(v.last().unwrap() + step);
        }
    }
    v
}

/// `‖f̂‖`, the L2 norm of the non-constant part.
fn hat_norm(f: &[f64]) -> f64 {
    f[1..].iter().map(|v| v * v).sum::<f64>().sqrt()
}

impl ShExp {
    /// `exp*` for `order` (1..=`MAX_ORDER`); cheap (the table is fitted when needed).
    pub fn new(order: usize) -> ShExp {
        assert!((1..=super::MAX_ORDER).contains(&order), "SH order {order}");
        ShExp {
            order,
            table: std::sync::OnceLock::new(),
        }
    }

    fn table(&self) -> &Table {
        self.table.get_or_init(|| Table::fit(self.order))
    }
}

impl Table {
    /// Least-squares `a`, `b` per norm against the reference exponential of random
    /// smoke-like shapes.
    fn fit(order: usize) -> Table {
        let n = count(order);
        // Unit-norm shapes f̂/‖f̂‖; a lobe seen from its own center is constant and has
        // no shape, so such draws are skipped.
        // Order 1 has no f̂ (a = b = 1 throughout): no shapes to draw.
        let wanted = if order == 1 { 0 } else { FIT_SHAPES };
        let shapes: Vec<Vec<f64>> = (0..)
            .filter_map(|seed| {
                let mut f = random_optical_depth(order, seed);
                let norm = hat_norm(&f);
                (norm > 1e-6 * f[0].abs()).then(|| {
                    f[0] = 0.0;
                    f.iter().map(|v| v / norm).collect()
                })
            })
            .take(wanted)
            .collect();
        let norms = table_norms();
        let fitted: Vec<(f64, f64)> = norms
            .par_iter()
            .map(|&nu| {
                if nu == 0.0 || order == 1 {
                    return (0.0, 0.0);
                }
                let reference = ReferenceGrid::new(order, nu);
                let rows = shapes.len() * n;
                let mut m = DMatrix::<f64>::zeros(rows, 2);
                let mut rhs = DVector::<f64>::zeros(rows);
                for (s, u) in shapes.iter().enumerate() {
                    let fh: Vec<f64> = u.iter().map(|v| nu * v).collect();
                    let e = reference.exp(&fh);
                    let weight = 1.0 / e.iter().map(|v| v * v).sum::<f64>().sqrt();
                    for i in 0..n {
                        let r = s * n + i;
                        m[(r, 0)] = if i == 0 {
                            (4.0 * PI).sqrt() * weight
                        } else {
                            0.0
                        };
                        m[(r, 1)] = fh[i] * weight;
                        rhs[r] = e[i] * weight;
                    }
                }
                // `a` and `b` differ in scale by many orders of magnitude at large norms:
                // solve for column-normalized unknowns, with a relative rank cut-off.
                let scales: Vec<f64> = (0..2).map(|c| m.column(c).norm()).collect();
                for (c, s) in scales.iter().enumerate() {
                    m.column_mut(c).unscale_mut(*s);
                }
                let svd = m.svd(true, true);
                let cut = 1e-12 * svd.singular_values.max();
                let x = svd
                    .solve(&rhs, cut)
                    .expect("SVD with both factors computed");
                let ab = [x[0] / scales[0], x[1] / scales[1]];
                assert!(
                    ab[0] > 0.0 && ab[1] > 0.0,
                    "order {order}, norm {nu}: fitted a = {}, b = {}",
                    ab[0],
                    ab[1]
                );
                (ab[0].ln(), ab[1].ln())
            })
            .collect();
        let (ln_a, ln_b) = fitted.into_iter().unzip();
        Table { norms, ln_a, ln_b }
    }
}

impl ShExp {
    pub fn order(&self) -> usize {
        self.order
    }

    /// The optimal linear table `(‖f̂‖, ln a, ln b)` at its tabulated norms, ascending from
    /// 0 to [`NORM_MAX`] (fitted on first use; what the GPU uploads).
    pub fn linear_table(&self) -> (&[f64], &[f64], &[f64]) {
        let tb = self.table();
        (&tb.norms, &tb.ln_a, &tb.ln_b)
    }

    /// `(a, b)` of the optimal linear approximation at `‖f̂‖ = norm ∈ [0, NORM_MAX]`.
    pub fn coefficients(&self, norm: f64) -> (f64, f64) {
        let nu = norm.clamp(0.0, NORM_MAX);
        let tb = self.table();
        let i = tb
            .norms
            .partition_point(|&x| x <= nu)
            .clamp(1, tb.norms.len() - 1);
        let (x0, x1) = (tb.norms[i - 1], tb.norms[i]);
        let t = (nu - x0) / (x1 - x0);
        let lerp = |v: &[f64]| v[i - 1] + t * (v[i] - v[i - 1]);
        (lerp(&tb.ln_a).exp(), lerp(&tb.ln_b).exp())
    }

    /// `exp*(f)` for `f` of this order (`tp` of the same order).
    pub fn exp(&self, f: &[f64], method: ExpMethod, tp: &TripleProduct) -> Vec<f64> {
        let n = count(self.order);
        assert!(
            f.len() == n && tp.order() == self.order,
            "exp of {} coefficients at order {}",
            f.len(),
            self.order
        );
        let nu = hat_norm(f);
        let halvings = match method {
            ExpMethod::OptimalLinear if nu > NORM_MAX => (nu / NORM_MAX).log2().ceil() as u32,
            ExpMethod::OptimalLinear => 0,
            ExpMethod::ScaleSquare { halvings } => halvings,
            ExpMethod::ScaleSquareAuto => halvings_for(nu),
        };
        let scale = 0.5f64.powi(halvings as i32);
        // The DC factor goes into the base, so that squarings of a transmittance stay in
        // range: exp(f/2^k) = exp(f_0/(2^k·√4π))·exp(f̂/2^k).
        let dc = (scale * f[0] / (4.0 * PI).sqrt()).exp();
        let g: Vec<f64> = std::iter::once(0.0)
            .chain(f[1..].iter().map(|v| scale * v))
            .collect();
        let mut r = match method {
            ExpMethod::OptimalLinear => {
                let (a, b) = self.coefficients(scale * nu);
                let mut r: Vec<f64> = g.iter().map(|v| b * v).collect();
                r[0] = a * (4.0 * PI).sqrt();
                r
            }
            ExpMethod::ScaleSquare { .. } | ExpMethod::ScaleSquareAuto => taylor(&g, tp),
        };
        for v in &mut r {
            *v *= dc;
        }
        let mut sq = vec![0.0; n];
        for _ in 0..halvings {
            tp.product_into(&r, &r, &mut sq);
            std::mem::swap(&mut r, &mut sq);
        }
        r
    }
}

/// `Σ_j g^{∗j}/j!` by triple products, until a term is below 1e-15 of the sum.
fn taylor(g: &[f64], tp: &TripleProduct) -> Vec<f64> {
    let mut sum = vec![0.0; g.len()];
    sum[0] = (4.0 * PI).sqrt();
    let mut term = sum.clone();
    let mut next = vec![0.0; g.len()];
    for j in 1..=TAYLOR_TERMS {
        tp.product_into(&term, g, &mut next);
        let inv = 1.0 / j as f64;
        let mut tn = 0.0;
        for (t, x) in term.iter_mut().zip(&next) {
            *t = x * inv;
            tn += *t * *t;
        }
        for (s, t) in sum.iter_mut().zip(&term) {
            *s += t;
        }
        if tn.sqrt() <= 1e-15 * sum.iter().map(|v| v * v).sum::<f64>().sqrt() {
            break;
        }
    }
    sum
}

/// A quadrature grid with the basis tabulated, resolving `exp(f̂)` for `‖f̂‖ ≤ norm`.
struct ReferenceGrid {
    n: usize,
    weights: Vec<f64>,
    /// `Y_i` at every point, point-major.
    ys: Vec<f64>,
}

impl ReferenceGrid {
    /// `exp(f̂)` is smooth on the scale `1/√(max curvature of f̂)`, and the curvature
    /// grows like `l²·‖f̂‖`: the latitudes grow with `order·√norm`, twice as many
    /// azimuths. The sizes are checked by a refinement test.
    fn new(order: usize, norm: f64) -> ReferenceGrid {
        let n_theta = 2 * order + 6 + (1.5 * order as f64 * norm.max(0.0).sqrt()).ceil() as usize;
        let grid = SphereGrid::new(n_theta, 2 * n_theta);
        let n = count(order);
        let mut ys = vec![0.0; grid.len() * n];
        let mut weights = Vec::with_capacity(grid.len());
        for ((d, w), y) in grid.points().zip(ys.chunks_exact_mut(n)) {
            eval_into(order, d, y);
            weights.push(w);
        }
        ReferenceGrid { n, weights, ys }
    }

    /// Projection of `exp(f(ω))`, computed as `e^M·∫ exp(f − M)·Y` with `M` the largest
    /// sampled `f` so that no intermediate overflows.
    fn exp(&self, f: &[f64]) -> Vec<f64> {
        let values: Vec<f64> = self
            .ys
            .chunks_exact(self.n)
            .map(|y| y.iter().zip(f).map(|(y, c)| y * c).sum())
            .collect();
        let top = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut out = vec![0.0; self.n];
        for ((v, w), y) in values
            .iter()
            .zip(&self.weights)
            .zip(self.ys.chunks_exact(self.n))
        {
            let e = w * (v - top).exp();
            for (o, y) in out.iter_mut().zip(y) {
                *o += e * y;
            }
        }
        let s = top.exp();
        out.iter_mut().for_each(|o| *o *= s);
        out
    }
}

/// Ground truth: the numerical projection of `exp` of the reconstructed `f` (order
/// `√len`), on a Gauss–Legendre × uniform grid sized from `‖f̂‖` (see the refinement
/// test: relative accuracy better than 1e-9 for smoke-like functions up to NORM_MAX).
pub fn exp_reference(order: usize, f: &[f64]) -> Vec<f64> {
    assert_eq!(
        order_of(f.len()),
        order,
        "{} coefficients at order {order}",
        f.len()
    );
    ReferenceGrid::new(order, hat_norm(f)).exp(f)
}

/// A smoke-like optical-depth function of order `order`, deterministic in `seed`: the
/// SH projection of `Σ_h w_h·T_h(ω)`, 1–8 Gaussian RBFs of radius 0.05–0.3 with weights
/// 0.2–1 at distances 0–1 in random directions (`T_h` from
/// [`gaussian_optical_depth_zh`], rotated). Non-negative up to the ringing of the
/// projection; the exponent of a transmittance is `−σt` times it.
pub fn random_optical_depth(order: usize, seed: u64) -> Vec<f64> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut f = vec![0.0; count(order)];
    let blobs = rng.random_range(1..=8);
    for _ in 0..blobs {
        let r = rng.random_range(0.05..0.3);
        let d = rng.random_range(0.0..1.0);
        let w = rng.random_range(0.2..1.0);
        let z: f64 = rng.random_range(-1.0..1.0);
        let phi = rng.random_range(0.0..2.0 * PI);
        let s = (1.0 - z * z).max(0.0).sqrt();
        let axis = [s * phi.cos(), s * phi.sin(), z];
        let lobe = zh_rotate(&gaussian_optical_depth_zh(order, d, r), axis);
        for (f, l) in f.iter_mut().zip(lobe) {
            *f += w * l;
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel_err(a: &[f64], r: &[f64]) -> f64 {
        let d: f64 = a.iter().zip(r).map(|(a, r)| (a - r) * (a - r)).sum();
        (d / r.iter().map(|r| r * r).sum::<f64>()).sqrt()
    }

    /// `−σ·T` of seed `seed` with `σ` chosen so that `‖f̂‖ = nu` (the example's inputs).
    fn exponent(order: usize, seed: u64, nu: f64) -> Vec<f64> {
        let t = random_optical_depth(order, seed);
        let hat = hat_norm(&t);
        assert!(hat > 0.0);
        t.iter().map(|v| -nu / hat * v).collect()
    }

    #[test]
    fn exp_of_zero_and_of_constants_is_exact() {
        for order in 1..=MAX {
            let (table, tp) = (ShExp::new(order), TripleProduct::new(order));
            let n = count(order);
            for c in [0.0, -3.0, 2.0] {
                let mut f = vec![0.0; n];
                f[0] = c * (4.0 * PI).sqrt();
                for m in [
                    ExpMethod::OptimalLinear,
                    ExpMethod::ScaleSquare { halvings: 3 },
                ] {
                    let e = table.exp(&f, m, &tp);
                    // exp(c)·1: a(0) = 1 and products with the constant are exact.
                    assert!(
                        (e[0] - c.exp() * (4.0 * PI).sqrt()).abs() < 1e-13 * c.exp(),
                        "{order} {m:?} {e:?}"
                    );
                    assert!(
                        e[1..].iter().all(|v| v.abs() < 1e-13 * c.exp()),
                        "{order} {m:?} {e:?}"
                    );
                }
            }
        }
    }

    const MAX: usize = super::super::MAX_ORDER;

    #[test]
    fn small_norms_match_the_reference_with_the_expected_error_orders() {
        for order in [3, 4, 6] {
            let (table, tp) = (ShExp::new(order), TripleProduct::new(order));
            for seed in [100, 101] {
                let err = |m: ExpMethod, nu: f64| {
                    let f = exponent(order, seed, nu);
                    rel_err(&table.exp(&f, m, &tp), &exp_reference(order, &f))
                };
                let ss = ExpMethod::ScaleSquare { halvings: 0 };
                let ol = ExpMethod::OptimalLinear;
                // Scaling-and-squaring loses only what products push beyond the order:
                // f̂∗f̂ is exact, so the error is O(‖f̂‖³) (measured 3e-6 at 0.1).
                let (s1, s2) = (err(ss, 0.1), err(ss, 0.05));
                assert!(s1 < 2e-5, "order {order} seed {seed}: {s1}");
                assert!(s1 / s2 > 6.0, "order {order} seed {seed}: {s1} / {s2}");
                // The linear approximation misses f̂²/2 beyond band 0: O(‖f̂‖²)
                // (measured ≤ 2.1e-3 at 0.1 for orders ≤ 6).
                let (o1, o2) = (err(ol, 0.1), err(ol, 0.05));
                assert!(o1 < 3e-3, "order {order} seed {seed}: {o1}");
                assert!(
                    o1 / o2 > 3.5 && o1 / o2 < 4.5,
                    "order {order} seed {seed}: {o1} / {o2}"
                );
            }
        }
    }

    #[test]
    fn order_2_linear_approximation_is_exact() {
        // With band 1 only, exp(v·Y_1) projects onto span(1, f̂) by symmetry: the fit is
        // exact at the tabulated norms, up to the interpolation of ln a, ln b between them.
        let (table, tp) = (ShExp::new(2), TripleProduct::new(2));
        for nu in [0.5, 3.0, 40.0] {
            let f = exponent(2, 7, nu);
            let e = rel_err(
                &table.exp(&f, ExpMethod::OptimalLinear, &tp),
                &exp_reference(2, &f),
            );
            assert!(e < 1e-10, "norm {nu}: {e}");
        }
    }

    #[test]
    fn large_norm_errors_stay_within_the_tabulated_bounds() {
        // BENCHMARKS.md "SH exponentiation": at order 4, scaling-and-squaring with
        // `halvings_for` has mean/max relative error 1.4e-2 / 2.2e-2 at ‖f̂‖ = 2 and
        // 0.21 / 0.37 at 8; the optimal linear one 0.10 / 0.12 at 1. Bounds with margin:
        let (table, tp) = (ShExp::new(4), TripleProduct::new(4));
        for (nu, ss_max, ol_max) in [
            (1.0, 1e-2, 0.2),
            (2.0, 4e-2, 0.7),
            (8.0, 0.5, f64::INFINITY),
        ] {
            for seed in 200..204 {
                let f = exponent(4, seed, nu);
                let r = exp_reference(4, &f);
                let ss = table.exp(
                    &f,
                    ExpMethod::ScaleSquare {
                        halvings: halvings_for(nu),
                    },
                    &tp,
                );
                let ol = table.exp(&f, ExpMethod::OptimalLinear, &tp);
                assert!(
                    rel_err(&ss, &r) < ss_max,
                    "norm {nu} seed {seed}: {}",
                    rel_err(&ss, &r)
                );
                assert!(
                    rel_err(&ol, &r) < ol_max,
                    "norm {nu} seed {seed}: {}",
                    rel_err(&ol, &r)
                );
                // A transmittance: the band-0 coefficient (√4π × mean) stays positive.
                assert!(ss[0] > 0.0 && r[0] > 0.0);
            }
        }
    }

    #[test]
    fn fitted_coefficients_follow_the_small_norm_expansion() {
        // a = (1/4π)∫exp(f̂) = 1 + ‖f̂‖²/(8π) + O(‖f̂‖³) for every shape, and
        // b = ⟨exp*(f̂), f̂⟩/‖f̂‖² = 1 + O(‖f̂‖); the cubic term is ≤ ‖f̂‖³·0.03 at order 6.
        for order in [3, 6] {
            let table = ShExp::new(order);
            for nu in [0.125, 0.25] {
                let (a, b) = table.coefficients(nu);
                assert!(
                    (a - 1.0 - nu * nu / (8.0 * PI)).abs() < 0.03 * nu * nu * nu,
                    "{order} {nu}: a {a}"
                );
                assert!((b - 1.0).abs() < 0.5 * nu, "{order} {nu}: b {b}");
            }
            assert_eq!(table.coefficients(0.0), (1.0, 1.0));
            let (a, b) = table.coefficients(NORM_MAX);
            assert!(a.is_finite() && b.is_finite() && a > 1.0 && b > 1.0);
        }
    }

    #[test]
    fn reference_quadrature_is_converged() {
        // Twice the latitudes of `exp_reference`'s rule (via a 4× norm) at the top of the
        // table, order 6: agreement to 1e-9 relative shows the rule resolves exp(f̂).
        for seed in [300, 301] {
            let f = exponent(6, seed, NORM_MAX);
            let fine = ReferenceGrid::new(6, 4.0 * NORM_MAX).exp(&f);
            let e = rel_err(&exp_reference(6, &f), &fine);
            assert!(e < 1e-9, "seed {seed}: {e}");
        }
    }

    #[test]
    fn beyond_the_table_squarings_take_over() {
        let (table, tp) = (ShExp::new(3), TripleProduct::new(3));
        let f = exponent(3, 9, 3.0 * NORM_MAX);
        let e = table.exp(&f, ExpMethod::OptimalLinear, &tp);
        assert!(e.iter().all(|v| v.is_finite()), "{e:?}");
        assert_eq!(halvings_for(0.5), 0);
        assert_eq!(halvings_for(1.0), 0);
        assert_eq!(halvings_for(3.0), 2);
        assert_eq!(halvings_for(f64::NAN), 0);
    }
}
