//! Cosine functions (paper D §3.2.1): `γ(x) = Σ_j a_j cos(q_j·x + φ_j + ω_j t)`, each wave
//! a projection of `x` on a direction `d_j` scaled by a wavenumber `k_j` (`q_j = k_j d_j`).
//! A cosine term is one wave (`a = 1`); the product of two cosines the paper also uses
//! (`cos(πx)cos(πz/2)` in its Fig. 6) is two waves by
//! `cos α cos β = ½cos(α + β) + ½cos(α − β)`, wave vectors `q₁ ± q₂`.
//!
//! **Integral.** Along `x = o + s w`, `s ∈ [0, L]`, with `α = q·o + φ + ωt` and
//! `δ = q·w`: `∫₀^L cos(α + δs) ds = L cos(α + δL/2) sinc(δL/2)` — the paper's eq. 8
//! `(G(b) − G(a))/(d·w)` rewritten so that a ray parallel to the wave fronts (`δ → 0`)
//! needs no division (`sinc 0 = 1`).

use crate::vec3::{Vec3, dot};
use std::f64::consts::TAU;

/// One wave `amp·cos(q·x + phase + omega·t)`.
#[derive(Clone, Debug, PartialEq)]
pub struct Wave {
    pub amp: f64,
    pub q: Vec3,
    pub phase: f64,
    /// Phase drift (radians per second).
    pub omega: f64,
}

impl Wave {
    /// The phase at `o` and time `t`, reduced to `[0, 2π)`.
    pub fn phase_at(&self, o: Vec3, t: f64) -> f64 {
        (dot(self.q, o) + self.phase + self.omega * t).rem_euclid(TAU)
    }
}

/// A sum of waves.
#[derive(Clone, Debug, PartialEq)]
pub struct Cosine {
    pub waves: Vec<Wave>,
}

/// `sin x / x`, 1 at 0.
pub fn sinc(x: f64) -> f64 {
    if x == 0.0 { 1.0 } else { x.sin() / x }
}

impl Cosine {
    pub fn value(&self, x: Vec3, t: f64) -> f64 {
        self.waves
            .iter()
            .map(|w| w.amp * w.phase_at(x, t).cos())
            .sum()
    }

    /// `∫₀^len γ(o + s w) ds` (module docs).
    pub fn integral(&self, o: Vec3, w: Vec3, len: f64, t: f64) -> f64 {
        self.waves
            .iter()
            .map(|wave| {
                let half = 0.5 * dot(wave.q, w) * len;
                wave.amp * len * (wave.phase_at(o, t) + half).cos() * sinc(half)
            })
            .sum()
    }

    /// `−Σ|a_j|`: the least the waves can sum to.
    pub fn lower_bound(&self) -> f64 {
        -self.waves.iter().map(|w| w.amp.abs()).sum::<f64>()
    }
}
