//! The multiple-scattering source radiance at the centers, as order-2 SH (paper A §5.4,
//! last paragraph).
//!
//! From the first-moment equation (module docs) the media radiance at `c_l` is
//! `L_m(ω) ≈ L⁰_l + L¹_l·ω` with `L¹_l = (σt D̃ (1 − P_l) J¹_ss − ∇L⁰)/(σtr D̃)` (`P_l` the
//! escape probability, `super` module docs), everything at `c_l`:
//! `J¹_ss` is the given center value, `∇L⁰ = Σ_k ∇(v_k/D̃) L⁰_k` the gradient of the
//! interpolated field (eq. 12). Its projection on the real orthonormal SH
//! (`Y00 = 1/(2√π)`, `(Y1−1, Y10, Y11) = √(3/4π)·(y, z, x)`, index `l(l+1)+m`) is
//!
//! ```text
//! L_00 = 2√π L⁰,   (L_1−1, L_10, L_11) = √(4π/3)·(L¹_y, L¹_z, L¹_x).
//! ```
//!
//! The source `J_ms(ω) = (Ω/4π)∫ p(ω·ω') L_m(ω') dω'` with the normalized
//! Henyey–Greenstein phase is, by Funk–Hecke, `J_lm = Ω g^l L_lm`: `½∫p(μ)P_l(μ)dμ = g^l`
//! (docs/derivations.md's eq. 11 factor `(1/4π)√(4π/(2l+1)) p_l` is the same number). The tests check it
//! against quadrature of the defining integral.

use super::{Operators, Sources};
use crate::Medium;
use haze_volume::Rbf;

/// `J_ms` at every center, per channel, as the 4 SH coefficients above
/// ([`Operators::ms_source_sh`] on the operators of `rbfs`). Inactive RBFs and a medium
/// with `σt = 0` give zeros.
///
/// # Panics
/// If `sources` or `l0` do not hold one entry per RBF.
pub fn ms_source_sh(
    rbfs: &[Rbf],
    medium: &Medium,
    sources: &Sources,
    l0: &[[f64; 3]],
) -> Vec<[[f64; 4]; 3]> {
    Operators::new(rbfs).ms_source_sh(medium, sources, l0)
}
