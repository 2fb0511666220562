//! Assembly of `A L⁰ = b` at the RBF centers (paper A eq. 13, in DESIGN's corrected form).
//!
//! With `v_l = w_l B_l` and `L⁰(x) = Σ v_l(x) L⁰_l / D̃(x)`, at a center `c_h` (all fields
//! there, `D̃ = D̃(c_h)`):
//!
//! ```text
//! A_hl = [D̃²∇²v_l − 3D̃ ∇D̃·∇v_l + (3|∇D̃|² − D̃∇²D̃) v_l] / (3σtr D̃⁴) − (σa + σs P_h) v_l
//! b_h  = −S'(c_h) = −σt Σ_l v_l (1 − P_l) J⁰_l + (σt/(3σtr)) Σ_l (D̃∇v_l − v_l∇D̃)/D̃² · J¹_l
//! ```
//!
//! (`P`: the escape probabilities of the vacuum correction, module docs). The first line is
//! `∇·(κ∇(v_l/D̃)) − (σa + σs P) D̃ (v_l/D̃)` with `κ = 1/(3σtr D̃)`; the second
//! uses `D J⁰ ≈ D̃ J⁰(x) = Σ v_l J⁰_l` and `∇·J¹(x) = Σ ∇(v_l/D̃)·J¹_l`. To stay finite
//! where `D̃` is small, each ratio is formed before the products:
//! `A_hl = [∇²v_l/D̃ − 3 (∇D̃/D̃)·(∇v_l/D̃) + (3|∇D̃/D̃|² − ∇²D̃/D̃)(v_l/D̃)]/(3σtr D̃) − σa v_l`,
//! where `v_l/D̃ ∈ [0, 1]` and `D̃ ≥ w_h` at an active center.

use super::basis::{Neighbours, active, local};
use super::{Coefficients, Csr, Sources};
use crate::Medium;
use haze_volume::Rbf;
use nalgebra::{DVector, Vector3};
use rayon::prelude::*;

/// The linear system of one frame: `a · L⁰ = b[c]` for each colour channel `c`.
#[derive(Clone, Debug)]
pub struct System {
    pub a: Csr,
    pub b: [DVector<f64>; 3],
}

/// Assembles the diffusion system at the centers of `rbfs` (module docs), row by row in
/// parallel. Degenerate cases, all finite:
/// - an inactive RBF (zero or negative weight, degenerate radius; see `basis::active`)
///   gets the row and column of the identity and `b = 0`, so its `L⁰` is 0;
/// - a medium with `σt = 0` (no extinction, hence no source: `S ≡ 0`) gives the identity
///   and `b = 0` for every center;
/// - coincident centers give equal rows, hence a singular (consistent) system, which the
///   least-squares solver handles.
///
/// # Panics
/// If `sources` does not hold one entry per RBF.
pub fn assemble(rbfs: &[Rbf], medium: &Medium, sources: &Sources) -> System {
    let n = rbfs.len();
    assert!(
        sources.j0.len() == n && sources.j1.len() == n,
        "sources for {} / {} centers, {n} RBFs",
        sources.j0.len(),
        sources.j1.len()
    );
    let identity = |_| (Vec::new(), [0.0; 3]);
    let rows: Vec<_> = match Coefficients::of(medium) {
        None => (0..n).map(identity).collect(),
        Some(k) => {
            let act = active(rbfs);
            let nb = Neighbours::new(rbfs, &act);
            (0..n)
                .into_par_iter()
                .map(|h| {
                    if act[h] {
                        row(rbfs, &nb, &k, sources, h)
                    } else {
                        identity(h)
                    }
                })
                .collect()
        }
    };
    let mut b = [(); 3].map(|_| DVector::zeros(n));
    let rows = rows
        .into_iter()
        .enumerate()
        .map(|(h, (entries, bh))| {
            for c in 0..3 {
                b[c][h] = bh[c];
            }
            if entries.is_empty() {
                vec![(h, 1.0)]
            } else {
                entries
            }
        })
        .collect();
    System {
        a: Csr::from_rows(rows),
        b,
    }
}

/// Row `h` of `A` (entries by increasing column) and `b_h` per channel.
fn row(
    rbfs: &[Rbf],
    nb: &Neighbours,
    k: &Coefficients,
    sources: &Sources,
    h: usize,
) -> (Vec<(usize, f64)>, [f64; 3]) {
    let loc = local(rbfs, nb, rbfs[h].center);
    let d = loc.density;
    let g = loc.grad / d;
    let lap = loc.lap / d;
    let kappa = 1.0 / (3.0 * k.sigma_tr * d);
    let j1_factor = k.sigma_t / (3.0 * k.sigma_tr);
    let sink = k.sigma_a + k.sigma_s * sources.escape(h);
    let mut b = [0.0; 3];
    let entries = loc
        .terms
        .iter()
        .map(|t| {
            let u = t.v / d;
            let gu = t.grad / d;
            let diffusion = t.lap / d - 3.0 * g.dot(&gu) + (3.0 * g.norm_squared() - lap) * u;
            // ∇(v_l/D̃) = (∇v_l − (v_l/D̃)∇D̃)/D̃.
            let grad_basis: Vector3<f64> = gu - g * u;
            for (c, bc) in b.iter_mut().enumerate() {
                let j1 = Vector3::from(sources.j1(t.l, c));
                let j0 = (1.0 - sources.escape(t.l)) * sources.j0(t.l, c);
                *bc += -k.sigma_t * t.v * j0 + j1_factor * grad_basis.dot(&j1);
            }
            (t.l, diffusion * kappa - sink * t.v)
        })
        .collect();
    (entries, b)
}
