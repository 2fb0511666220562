//! The multiple-scattering source radiance at the centers, as order-2 SH (paper A §5.4,
//! last paragraph).
//!
//! From the first-moment equation (module docs) the media radiance at `c_l` is
//! `L_m(ω) ≈ L⁰_l + L¹_l·ω` with `L¹_l = (σt D̃ J¹_ss − ∇L⁰)/(σtr D̃)`, everything at `c_l`:
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
//! (DESIGN's eq. 11 factor `(1/4π)√(4π/(2l+1)) p_l` is the same number). The tests check it
//! against quadrature of the defining integral.

use super::basis::{Neighbours, active, local};
use super::{Coefficients, Sources};
use crate::Medium;
use haze_volume::Rbf;
use nalgebra::Vector3;
use std::f64::consts::PI;

/// `J_ms` at every center, per channel, as the 4 SH coefficients above. Inactive RBFs and
/// a medium with `σt = 0` give zeros.
///
/// # Panics
/// If `sources` or `l0` do not hold one entry per RBF.
pub fn ms_source_sh(
    rbfs: &[Rbf],
    medium: &Medium,
    sources: &Sources,
    l0: &[[f64; 3]],
) -> Vec<[[f64; 4]; 3]> {
    let n = rbfs.len();
    assert!(
        sources.j1.len() == n && l0.len() == n,
        "sources for {} and L⁰ for {} centers, {n} RBFs",
        sources.j1.len(),
        l0.len()
    );
    let Some(k) = Coefficients::of(medium) else {
        return vec![[[0.0; 4]; 3]; n];
    };
    let act = active(rbfs);
    let nb = Neighbours::new(rbfs, &act);
    let band0 = medium.albedo * 2.0 * PI.sqrt();
    let band1 = medium.albedo * medium.g * (4.0 * PI / 3.0).sqrt();
    (0..n)
        .map(|h| {
            if !act[h] {
                return [[0.0; 4]; 3];
            }
            let loc = local(rbfs, &nb, rbfs[h].center);
            let d = loc.density;
            let g = loc.grad / d;
            [0, 1, 2].map(|c| {
                let grad_l0: Vector3<f64> = loc
                    .terms
                    .iter()
                    .map(|t| (t.grad / d - g * (t.v / d)) * l0[t.l][c])
                    .sum();
                let j1 = Vector3::from(sources.j1(h, c));
                let l1 = (j1 * (k.sigma_t * d) - grad_l0) / (k.sigma_tr * d);
                [band0 * l0[h][c], band1 * l1.y, band1 * l1.z, band1 * l1.x]
            })
        })
        .collect()
}
