//! Exact integration of one level along a ray, cell by cell (paper E §4.3, eq. 11).
//!
//! A level is a grid of unit cells (in the level's own units) carrying one or more
//! *terms*: a coefficient grid whose functions are tensor products `f_x(y − …)·f_y(…)` of
//! two 1-D piecewise polynomials ([`Piecewise`]). Inside one cell every overlapping
//! function is a single polynomial piece, so along the part of the ray inside the cell
//! it is a polynomial of the normalized ray parameter `σ ∈ [0, 1]`: with the local
//! coordinates `(s_a, r_a)` where the ray enters the cell and `(s_b, r_b)` where it
//! leaves, piece `P` along x is `P(s_a + σ(s_b − s_a))`, of degree `d`.
//!
//! The vertical profile is `h(z) = e^{−k(z − z₀)}` (see [`crate::placement`]), and `z` is
//! linear along the ray, so on the cell segment of length `Δ`
//!
//! `∫ K = Δ · h(z_lo) · Σ_n R_n M_n(x)`, `M_n(x) = ∫_0^1 σ^n e^{−xσ} dσ`,
//!
//! where `R(σ) = Σ_terms Σ_{kx,ky} c_{kx,ky} X_kx(σ) Y_ky(σ)` is the integrand polynomial
//! (degree `2d`), `σ` runs from the cell segment's lower end, where `h` is largest (so
//! `x = k·|z_b − z_a| ≥ 0` and nothing grows exponentially), and `M_n` comes from [`moments`]. Each product
//! `c · ∫ X Y h` is the paper's "coefficient × integral of the basis function over the
//! part of the ray inside the cell"; the cells whose support overlaps the current one
//! (the `d` previous ones along each axis for a scaling basis on its own grid) are the
//! `kx, ky` ranges. These integrals are exact — no table, no quadrature — up to rounding.
//!
//! The kernel uses only flat arrays, fixed-size loops and one `exp` per cell (none when
//! `k = 0`), so that a shader can mirror it.

use crate::basis::{Piecewise, Poly};
use crate::mallat::Grid;

/// Most pieces of one 1-D function (a coarse quadratic function on the finer grid).
pub const MAX_PIECES: usize = 6;
/// Most functions of one term overlapping a cell along one axis.
const MAX_OVERLAP: usize = 3;

/// `M_n(x) = ∫_0^1 σ^n e^{−xσ} dσ` for `n = 0 … nmax` (`nmax ≤ 4`, `x ≥ 0`).
///
/// For `x > nmax + 1` the upward recurrence `M_n = (n M_{n−1} − e^{−x})/x` from
/// `M_0 = −expm1(−x)/x` loses nothing (each step multiplies errors by `n/x < 1`). Below,
/// `M_nmax = e^{−x} Σ_m x^m / ((nmax+1)…(nmax+1+m))` (the series of the lower incomplete
/// gamma function, all terms positive) and the downward recurrence
/// `M_{n−1} = (x M_n + e^{−x})/n`, which adds positive terms only.
pub fn moments(x: f64, nmax: usize, out: &mut [f64; 5]) {
    debug_assert!(nmax <= 4 && x >= 0.0);
    if x == 0.0 {
        for (n, m) in out.iter_mut().enumerate().take(nmax + 1) {
            *m = 1.0 / (n + 1) as f64;
        }
        return;
    }
    let e = (-x).exp();
    if x > (nmax + 1) as f64 {
        out[0] = -(-x).exp_m1() / x;
        for n in 1..=nmax {
            out[n] = (n as f64 * out[n - 1] - e) / x;
        }
        return;
    }
    let a = (nmax + 1) as f64;
    let mut term = 1.0 / a;
    let mut sum = term;
    let mut m = 1.0;
    while term > 1e-17 * sum {
        term *= x / (a + m);
        sum += term;
        m += 1.0;
    }
    out[nmax] = e * sum;
    for n in (1..=nmax).rev() {
        out[n - 1] = (x * out[n] + e) / n as f64;
    }
}

/// One family of functions on a level's grid: a coefficient window and the two 1-D
/// functions of its tensor product.
#[derive(Clone, Debug)]
pub struct Term {
    coef: Vec<f64>,
    k0: [i64; 2],
    n: [usize; 2],
    first: [i64; 2],
    stride: i64,
    support: [usize; 2],
    pieces: [[Poly; MAX_PIECES]; 2],
}

/// A term's data as flat arrays, for a GPU upload ([`crate::gpu`]).
#[derive(Clone, Copy, Debug)]
pub struct TermView<'a> {
    /// Coefficients, row after row (`n[0]` per row).
    pub coef: &'a [f64],
    /// Index of the first stored coefficient along x and y.
    pub k0: [i64; 2],
    /// Stored coefficients along x and y.
    pub n: [usize; 2],
    /// Cell of the first piece of coefficient 0, along x and y.
    pub first: [i64; 2],
    /// Cells between consecutive coefficients.
    pub stride: i64,
    /// Pieces per function along x and y.
    pub support: [usize; 2],
    /// The pieces along x and y (unused entries zero).
    pub pieces: &'a [[Poly; MAX_PIECES]; 2],
}

impl Term {
    /// The term's arrays.
    pub fn view(&self) -> TermView<'_> {
        TermView {
            coef: &self.coef,
            k0: self.k0,
            n: self.n,
            first: self.first,
            stride: self.stride,
            support: self.support,
            pieces: &self.pieces,
        }
    }

    /// The functions `c_{kx,ky} f_x(kx) f_y(ky)` of `coef`; `fx` and `fy` share a stride.
    pub fn new(coef: &Grid, fx: &Piecewise, fy: &Piecewise) -> Term {
        assert_eq!(fx.stride, fy.stride, "one grid per term");
        let table = |f: &Piecewise| {
            assert!(f.pieces.len() <= MAX_PIECES);
            let mut t = [[0.0; 3]; MAX_PIECES];
            t[..f.pieces.len()].copy_from_slice(&f.pieces);
            t
        };
        Term {
            coef: coef.data.clone(),
            k0: [coef.x0, coef.y0],
            n: [coef.nx, coef.ny],
            first: [fx.first, fy.first],
            stride: fx.stride,
            support: [fx.support(), fy.support()],
            pieces: [table(fx), table(fy)],
        }
    }

    /// Cells `[lo, hi)` along `axis` where some function of the term is non-zero.
    fn cells(&self, axis: usize) -> (i64, i64) {
        let lo = self.stride * self.k0[axis] + self.first[axis];
        let hi = self.stride * (self.k0[axis] + self.n[axis] as i64 - 1)
            + self.first[axis]
            + self.support[axis] as i64;
        (lo, hi)
    }

    /// The stored `k` whose function covers `cell` along `axis`: `k_lo ..= k_hi`.
    #[inline]
    fn overlap(&self, axis: usize, cell: i64) -> (i64, i64) {
        let rel = cell - self.first[axis];
        let s = self.stride;
        let lo = (rel - self.support[axis] as i64 + s).div_euclid(s);
        let hi = rel.div_euclid(s);
        (
            lo.max(self.k0[axis]),
            hi.min(self.k0[axis] + self.n[axis] as i64 - 1),
        )
    }
}

/// A level's grid and the terms it carries, placed in the finest level's units.
#[derive(Clone, Debug)]
pub struct Layer {
    /// Finest-level cells per cell of this grid (`2^{L−l}`).
    pub scale: f64,
    /// Polynomial degree `d` of the pieces.
    pub degree: usize,
    /// Cells covered: x `[c[0], c[1])`, y `[c[2], c[3])`; empty when `c[0] ≥ c[1]`.
    pub cells: [i64; 4],
    /// Lower bound of the layer's function, `≤ 0` (0 when it cannot be negative).
    pub floor: f64,
    terms: Vec<Term>,
}

impl Layer {
    /// The terms the layer carries.
    pub fn terms(&self) -> &[Term] {
        &self.terms
    }

    /// A layer of `terms` on a grid whose cells are `scale` finest cells wide; `floor`
    /// is a lower bound of the sum of the terms (0 if none can be negative).
    pub fn new(scale: f64, degree: usize, terms: Vec<Term>, floor: f64) -> Layer {
        let mut cells = [i64::MAX, i64::MIN, i64::MAX, i64::MIN];
        for t in terms.iter().filter(|t| t.n[0] > 0 && t.n[1] > 0) {
            let (x0, x1) = t.cells(0);
            let (y0, y1) = t.cells(1);
            cells = [
                cells[0].min(x0),
                cells[1].max(x1),
                cells[2].min(y0),
                cells[3].max(y1),
            ];
        }
        if cells[0] >= cells[1] {
            cells = [0, 0, 0, 0];
        }
        Layer {
            scale,
            degree,
            cells,
            floor: floor.min(0.0),
            terms,
        }
    }
}

/// A ray in a layer's units: `(u, v)(t) = (u0 + t·du, v0 + t·dv)` and world height
/// `z(t) = z0 + t·dz`, `t` in world length.
#[derive(Clone, Copy, Debug)]
pub struct LayerRay {
    /// Grid coordinates at `t = 0`.
    pub uv0: [f64; 2],
    /// Grid cells per unit of `t`.
    pub duv: [f64; 2],
    /// Height at `t = 0`.
    pub z0: f64,
    /// Height per unit of `t`.
    pub dz: f64,
}

/// The vertical profile seen by the kernel: `h(z) = e^{−k(z − bottom)}`.
#[derive(Clone, Copy, Debug)]
pub struct Vertical {
    /// Falloff `k` (per world unit), `≥ 0`.
    pub falloff: f64,
    /// Height where `h = 1`.
    pub bottom: f64,
}

/// Early termination: stop once the accumulated integral, plus the lowest value the rest
/// of this layer's segment can add (`floor × remaining length`), reaches `target`.
#[derive(Clone, Copy, Debug)]
pub struct Stop {
    /// Integral (in coefficient units × length) beyond which nothing matters, already
    /// lowered by whatever later layers might subtract.
    pub target: f64,
}

impl Stop {
    /// Never stop.
    pub const NEVER: Stop = Stop {
        target: f64::INFINITY,
    };
}

/// `∫_{ta}^{tb} f(u(t), v(t)) h(z(t)) dt` over one layer, added to `acc`. The segment
/// must already lie inside the vertical slab. Returns `true` if it stopped early.
pub fn integrate(
    layer: &Layer,
    ray: &LayerRay,
    vert: Vertical,
    ta: f64,
    tb: f64,
    stop: Stop,
    acc: &mut f64,
) -> bool {
    match layer.degree {
        0 => integrate_deg::<0>(layer, ray, vert, ta, tb, stop, acc),
        1 => integrate_deg::<1>(layer, ray, vert, ta, tb, stop, acc),
        _ => integrate_deg::<2>(layer, ray, vert, ta, tb, stop, acc),
    }
}

/// Clips `[ta, tb]` to `lo ≤ p0 + t·dp ≤ hi`.
fn clip_axis(p0: f64, dp: f64, lo: f64, hi: f64, ta: &mut f64, tb: &mut f64) {
    if dp == 0.0 {
        if !(lo..=hi).contains(&p0) {
            *tb = *ta - 1.0;
        }
        return;
    }
    let (t0, t1) = ((lo - p0) / dp, (hi - p0) / dp);
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    *ta = ta.max(t0);
    *tb = tb.min(t1);
}

/// Cell entered at `p` when moving with slope `dp`: a point on a grid line belongs to the
/// cell on the side the ray goes to.
#[inline]
fn start_cell(p: f64, dp: f64) -> i64 {
    if dp < 0.0 {
        p.ceil() as i64 - 1
    } else {
        p.floor() as i64
    }
}

/// Ray parameter of the next grid line after cell `c` along an axis.
#[inline]
fn next_crossing(c: i64, p0: f64, dp: f64) -> f64 {
    if dp > 0.0 {
        (c as f64 + 1.0 - p0) / dp
    } else if dp < 0.0 {
        (c as f64 - p0) / dp
    } else {
        f64::INFINITY
    }
}

/// `P(a + σ(b − a))` as a polynomial in `σ`.
#[inline]
fn along<const D: usize>(p: &Poly, a: f64, b: f64) -> Poly {
    let delta = b - a;
    match D {
        0 => [p[0], 0.0, 0.0],
        1 => [p[0] + p[1] * a, p[1] * delta, 0.0],
        _ => [
            (p[2] * a + p[1]) * a + p[0],
            (2.0 * p[2] * a + p[1]) * delta,
            p[2] * delta * delta,
        ],
    }
}

#[allow(clippy::too_many_arguments)]
fn integrate_deg<const D: usize>(
    layer: &Layer,
    ray: &LayerRay,
    vert: Vertical,
    mut ta: f64,
    mut tb: f64,
    stop: Stop,
    acc: &mut f64,
) -> bool {
    let [cx0, cx1, cy0, cy1] = layer.cells;
    if cx0 >= cx1 {
        return false;
    }
    let [u0, v0] = ray.uv0;
    let [du, dv] = ray.duv;
    clip_axis(u0, du, cx0 as f64, cx1 as f64, &mut ta, &mut tb);
    clip_axis(v0, dv, cy0 as f64, cy1 as f64, &mut ta, &mut tb);
    if tb.partial_cmp(&ta) != Some(std::cmp::Ordering::Greater) {
        return false;
    }
    let (mut ix, mut iy) = (start_cell(u0 + ta * du, du), start_cell(v0 + ta * dv, dv));
    let (sx, sy) = (if du < 0.0 { -1 } else { 1 }, if dv < 0.0 { -1 } else { 1 });
    let (mut tx, mut ty) = (next_crossing(ix, u0, du), next_crossing(iy, v0, dv));
    let mut t = ta;
    // Each step enters a new cell of the footprint; rounding can add a few.
    let mut budget = (cx1 - cx0) + (cy1 - cy0) + 8;
    let mut m = [0.0; 5];
    if vert.falloff == 0.0 {
        moments(0.0, 2 * D, &mut m);
    }
    loop {
        let t_exit = tx.min(ty).min(tb);
        let len = t_exit - t;
        if len > 0.0 {
            // Local coordinates at both ends, the lower end first.
            let (mut sa, mut sb) = (u0 + t * du - ix as f64, u0 + t_exit * du - ix as f64);
            let (mut ra, mut rb) = (v0 + t * dv - iy as f64, v0 + t_exit * dv - iy as f64);
            let mut h = 1.0;
            if vert.falloff > 0.0 {
                let (za, zb) = (ray.z0 + t * ray.dz, ray.z0 + t_exit * ray.dz);
                if zb < za {
                    std::mem::swap(&mut sa, &mut sb);
                    std::mem::swap(&mut ra, &mut rb);
                }
                // Clipped to the slab, a ray's lower end can round a hair below the
                // bottom: h is at most 1 there (a steep falloff would overflow).
                h = (-vert.falloff * (za.min(zb) - vert.bottom).max(0.0)).exp();
                moments(vert.falloff * (za - zb).abs(), 2 * D, &mut m);
            }
            let mut r = [0.0; 5];
            for term in &layer.terms {
                cell_polynomial::<D>(term, ix, iy, [sa, sb], [ra, rb], &mut r);
            }
            let mut sum = 0.0;
            for n in 0..=2 * D {
                sum += r[n] * m[n];
            }
            *acc += len * h * sum;
            if *acc + layer.floor * (tb - t_exit) >= stop.target {
                return true;
            }
        }
        budget -= 1;
        if t_exit >= tb || budget < 0 {
            return false;
        }
        if tx <= ty {
            ix += sx;
            tx = next_crossing(ix, u0, du);
        } else {
            iy += sy;
            ty = next_crossing(iy, v0, dv);
        }
        t = t.max(t_exit);
    }
}

/// Adds to `r` the integrand polynomial of one term in cell `(ix, iy)`, whose local
/// coordinates run from `(s[0], q[0])` to `(s[1], q[1])`.
#[inline]
fn cell_polynomial<const D: usize>(
    term: &Term,
    ix: i64,
    iy: i64,
    s: [f64; 2],
    q: [f64; 2],
    r: &mut [f64; 5],
) {
    let (kx0, kx1) = term.overlap(0, ix);
    let (ky0, ky1) = term.overlap(1, iy);
    if kx0 > kx1 || ky0 > ky1 {
        return;
    }
    let stride = term.stride;
    let mut y = [[0.0; 3]; MAX_OVERLAP];
    let ny = (ky1 - ky0 + 1) as usize;
    for (j, yj) in y.iter_mut().enumerate().take(ny) {
        let piece = (iy - term.first[1] - stride * (ky0 + j as i64)) as usize;
        *yj = along::<D>(&term.pieces[1][piece], q[0], q[1]);
    }
    let row0 = (ky0 - term.k0[1]) as usize;
    let width = term.n[0];
    for kx in kx0..=kx1 {
        let piece = (ix - term.first[0] - stride * kx) as usize;
        let x = along::<D>(&term.pieces[0][piece], s[0], s[1]);
        let col = (kx - term.k0[0]) as usize;
        // Z(σ) = Σ_ky c Y_ky(σ).
        let mut z = [0.0; 3];
        for (j, yj) in y.iter().enumerate().take(ny) {
            let c = term.coef[(row0 + j) * width + col];
            for n in 0..=D {
                z[n] += c * yj[n];
            }
        }
        for a in 0..=D {
            for b in 0..=D {
                r[a + b] += x[a] * z[b];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `∫_0^1 σ^n e^{−xσ}` by composite Simpson with many panels (smooth integrand).
    fn simpson(n: i32, x: f64) -> f64 {
        let panels = 20_000;
        let h = 1.0 / panels as f64;
        let f = |s: f64| s.powi(n) * (-x * s).exp();
        let mut sum = f(0.0) + f(1.0);
        for i in 1..panels {
            sum += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        sum * h / 3.0
    }

    #[test]
    fn moments_match_quadrature_across_regimes() {
        for x in [
            0.0, 1e-12, 1e-6, 0.01, 0.3, 1.0, 2.9, 3.0, 3.1, 5.0, 5.5, 12.0, 80.0, 700.0, 1e6,
        ] {
            for nmax in 0..=4 {
                let mut m = [0.0; 5];
                moments(x, nmax, &mut m);
                for (n, &got) in m.iter().enumerate().take(nmax + 1) {
                    // Simpson's error is ~h⁴ f⁗ ≲ 1e-13 here; for large x the integrand is
                    // a spike at 0 of width 1/x: compare with its closed tail n!/x^{n+1}.
                    let (want, tol) = if x > 100.0 {
                        let fact = (1..=n).product::<usize>() as f64;
                        (fact / x.powi(n as i32 + 1), 1e-9)
                    } else {
                        (simpson(n as i32, x), 1e-11)
                    };
                    assert!(
                        (got - want).abs() <= tol * want,
                        "x={x} n={n}: {got} vs {want}"
                    );
                    assert!(got.is_finite() && got > 0.0);
                }
            }
        }
    }
}
