//! The RBF basis at a point: which RBFs take part, which overlap a point, and the density
//! `D̃ = Σ w_l B_l` with its gradient and Laplacian, from the Gaussians analytically.
//!
//! Each `w B(x) = w·exp(−|x − c|²/r²)` is cut off at `3r` exactly as in rendering
//! ([`Rbf::eval`]): inside the support its derivatives are the Gaussian's,
//! `∇(wB) = −2 (x − c)/r² · wB` and `∇²(wB) = (4|x − c|²/r² − 6)/r² · wB`; the jump of at
//! most `w e⁻⁹` at the cut-off sphere is ignored. Consistency with the rendered density
//! (and a sparse matrix) matter more than that tail.

use haze_volume::Rbf;
use nalgebra::Vector3;
use std::collections::HashMap;

/// An RBF lighter than this fraction of the heaviest holds no density worth lighting.
const MIN_WEIGHT_REL: f64 = 1e-12;
/// An RBF narrower than this fraction of the widest holds no density worth lighting.
const MIN_RADIUS_REL: f64 = 1e-6;

/// Which RBFs take part in the diffusion: finite center, radius and weight, weight
/// `> 1e-12·max w` (so `> 0`) and radius `> 1e-6·max r`. The others (zero or negative
/// weights, degenerate radii) carry no density: their `L⁰` is 0 and they touch no other
/// center. Every active center then has `D̃(c_h) ≥ w_h > 0`, which bounds the `1/D̃`
/// factors of the operator.
pub(crate) fn active(rbfs: &[Rbf]) -> Vec<bool> {
    let finite = |b: &Rbf| {
        b.center.iter().all(|c| c.is_finite()) && b.radius.is_finite() && b.weight.is_finite()
    };
    let (max_w, max_r) = rbfs
        .iter()
        .filter(|b| finite(b))
        .fold((0.0f64, 0.0f64), |(w, r), b| {
            (w.max(b.weight), r.max(b.radius))
        });
    rbfs.iter()
        .map(|b| {
            finite(b)
                && b.weight > MIN_WEIGHT_REL * max_w
                && b.radius > MIN_RADIUS_REL * max_r
                && (b.radius * b.radius).recip().is_finite()
        })
        .collect()
}

/// Active RBFs binned in a uniform grid whose cell is the largest support radius `3r`, so
/// the RBFs whose support holds a point lie in the 27 cells around it.
#[derive(Debug)]
pub(crate) struct Neighbours {
    cell: f64,
    bins: HashMap<[i64; 3], Vec<usize>>,
}

impl Neighbours {
    pub(crate) fn new(rbfs: &[Rbf], active: &[bool]) -> Neighbours {
        let cell = rbfs
            .iter()
            .zip(active)
            .filter(|(_, a)| **a)
            .map(|(b, _)| b.support_radius())
            .fold(0.0f64, f64::max);
        let mut bins: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (l, b) in rbfs.iter().enumerate().filter(|(l, _)| active[*l]) {
            bins.entry(key(b.center, cell)).or_default().push(l);
        }
        Neighbours { cell, bins }
    }

    /// Active RBFs that may be non-zero at `p`, in an order fixed by the set (cells in a
    /// fixed order, indices increasing within a cell), so sums over them are deterministic.
    pub(crate) fn candidates(&self, p: [f64; 3]) -> Vec<usize> {
        let k = key(p, self.cell);
        let mut out = Vec::new();
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let cell = [0, 1, 2].map(|a| k[a].saturating_add([dx, dy, dz][a]));
                    if let Some(v) = self.bins.get(&cell) {
                        out.extend_from_slice(v);
                    }
                }
            }
        }
        out
    }
}

/// Grid cell of a point (saturating for far or degenerate coordinates).
fn key(p: [f64; 3], cell: f64) -> [i64; 3] {
    p.map(|x| {
        if cell > 0.0 {
            (x / cell).floor() as i64
        } else {
            0
        }
    })
}

/// One weighted Gaussian `v = w_l B_l(p)` that is non-zero at `p`, with `∇v` and `∇²v`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Term {
    pub l: usize,
    pub v: f64,
    pub grad: Vector3<f64>,
    pub lap: f64,
}

/// The basis at a point: `D̃`, `∇D̃`, `∇²D̃` and the non-zero terms they sum.
#[derive(Clone, Debug)]
pub(crate) struct Local {
    pub density: f64,
    pub grad: Vector3<f64>,
    pub lap: f64,
    pub terms: Vec<Term>,
}

pub(crate) fn local(rbfs: &[Rbf], nb: &Neighbours, p: [f64; 3]) -> Local {
    let mut out = Local {
        density: 0.0,
        grad: Vector3::zeros(),
        lap: 0.0,
        terms: Vec::new(),
    };
    for l in nb.candidates(p) {
        let b = &rbfs[l];
        let v = b.eval(p);
        if v == 0.0 {
            continue;
        }
        // Scaled offsets: s = (p − c)/r, so ∇v = −2 s/r · v and ∇²v = (4|s|² − 6)/r² · v.
        let s = Vector3::from_fn(|a, _| (p[a] - b.center[a]) / b.radius);
        let t = Term {
            l,
            v,
            grad: s * (-2.0 * v / b.radius),
            lap: (4.0 * s.norm_squared() - 6.0) * v / (b.radius * b.radius),
        };
        out.density += t.v;
        out.grad += t.grad;
        out.lap += t.lap;
        out.terms.push(t);
    }
    out
}
