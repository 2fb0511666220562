//! Assembly of `A L⁰ = b` at the RBF centers (paper A eq. 13, in docs/derivations.md's form).
//!
//! With `v_l = w_l B_l` and `L⁰(x) = Σ v_l(x) L⁰_l / D̃(x)`, at a center `c_h` (all fields
//! there, `D̃ = D̃(c_h)`):
//!
//! ```text
//! A_hl = (1 − P_h) [D̃²∇²v_l − 3D̃ ∇D̃·∇v_l + (3|∇D̃|² − D̃∇²D̃) v_l] / (3σtr D̃⁴) − (σa + σs P_h) v_l
//! b_h  = −S'(c_h) = Σ_l (1 − P_l) [−σt v_l J⁰_l + (σt/(3σtr)) (D̃∇v_l − v_l∇D̃)/D̃² · J¹_l]
//! ```
//!
//! (`P`: the escape probabilities of the vacuum correction, module docs). The first line is
//! `∇·(κ∇(v_l/D̃)) − (σa + σs P) D̃ (v_l/D̃)` with `κ = (1 − P_h)/(3σtr D̃)` taken constant
//! over the row's neighbourhood; the second
//! uses `D J⁰ ≈ D̃ J⁰(x) = Σ v_l J⁰_l` and `∇·J¹(x) = Σ ∇(v_l/D̃)·J¹_l`. To stay finite
//! where `D̃` is small, each ratio is formed before the products:
//! `A_hl = [∇²v_l/D̃ − 3 (∇D̃/D̃)·(∇v_l/D̃) + (3|∇D̃/D̃|² − ∇²D̃/D̃)(v_l/D̃)]/(3σtr D̃) − σa v_l`,
//! where `v_l/D̃ ∈ [0, 1]` and `D̃ ≥ w_h` at an active center.

use super::{Csr, Operators, Sources};
use crate::Medium;
use haze_volume::Rbf;
use nalgebra::DVector;

/// The linear system of one frame: `a · L⁰ = b[c]` for each colour channel `c`.
#[derive(Clone, Debug)]
pub struct System {
    pub a: Csr,
    pub b: [DVector<f64>; 3],
}

/// Assembles the diffusion system at the centers of `rbfs` (module docs): the frame's
/// [`Operators`], then [`Operators::system`]. Degenerate cases, all finite:
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
    Operators::new(rbfs).system(medium, sources)
}
