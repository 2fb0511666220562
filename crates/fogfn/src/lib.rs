//! Analytic fog functions (paper D: Biri, Michelin, Arquès 2002, "Real-time animation of
//! realistic fog"): an extinction `K(x, t) = Σ_i w_i γ_i(x, t)` built from families whose
//! line integrals have closed forms, so that the optical depth `∫_O^P K` along any ray —
//! the transmittance `τ = e^{−∫K}` of the paper's eq. 6 and 8 — is exact and costs a
//! fixed amount per term:
//! - [`cosine`]: waves `cos(k d·x + φ)` and products of two (§3.2.1);
//! - [`polynomial`]: polynomials in one to three projections, periodic or clipped to a
//!   cell (§3.2.2);
//! - [`blob`]: equipotentials `1/(c + d r²)` of a point, line or sphere (§3.2.3);
//! - [`height`]: exponential height falloff;
//! - constants.
//!
//! **Wind** (§5): a term marked as moving with the wind is carried by the fog's uniform
//! wind velocity `v`: `γ(x, t) = γ₀(x − v t)` — for a cosine the phase shift
//! `φ − k d·v t`, for a polynomial the ray integrated from `O − vt` to `P − vt`, for a blob
//! its center moved by `vt`, as the paper animates each family. Every integral is then
//! the static one along the ray shifted by `−vt`. Cosines may also drift in phase on
//! their own (`ω`).
//!
//! [`spec`] reads a fog from JSON; [`gpu`] is the `f32` WGSL twin of the integrals.

pub mod blob;
pub mod cosine;
pub mod gpu;
pub mod height;
pub mod polynomial;
pub mod quadratic;
pub mod spec;

pub use haze_core::vec3;

use vec3::{Vec3, scale, sub};

/// The shape of one term.
#[derive(Clone, Debug, PartialEq)]
pub enum Family {
    Constant,
    Cosine(cosine::Cosine),
    Polynomial(polynomial::Polynomial),
    Blob(blob::Blob),
    Height(height::Height),
}

/// `weight·γ(x − v t)` (or `weight·γ(x)` when the term stays still).
#[derive(Clone, Debug, PartialEq)]
pub struct Term {
    pub weight: f64,
    /// Whether the wind carries the term.
    pub windy: bool,
    pub family: Family,
}

impl Term {
    /// `γ` at the point `x` (already shifted by the wind), time `t`.
    fn gamma(&self, x: Vec3, t: f64) -> f64 {
        match &self.family {
            Family::Constant => 1.0,
            Family::Cosine(c) => c.value(x, t),
            Family::Polynomial(p) => p.value(x),
            Family::Blob(b) => b.value(x),
            Family::Height(h) => h.value(x),
        }
    }

    /// `∫₀^len γ(o + s w) ds`, `o` already shifted by the wind.
    fn gamma_integral(&self, o: Vec3, w: Vec3, len: f64, t: f64) -> f64 {
        match &self.family {
            Family::Constant => len,
            Family::Cosine(c) => c.integral(o, w, len, t),
            Family::Polynomial(p) => p.integral(o, w, len),
            Family::Blob(b) => b.integral(o, w, len),
            Family::Height(h) => h.integral(o, w, len),
        }
    }

    /// A lower bound of `weight·γ` over space, `−∞` when there is none.
    pub fn lower_bound(&self) -> f64 {
        let w = self.weight;
        match &self.family {
            Family::Constant => w,
            Family::Cosine(c) => w.abs() * c.lower_bound(),
            Family::Polynomial(p) => {
                // w·P = |w|·(±P).
                let mut signed = p.clone();
                for m in &mut signed.monomials {
                    m.0 *= w.signum();
                }
                w.abs() * signed.lower_bound()
            }
            Family::Blob(b) => (w * b.max_value()).min(0.0),
            Family::Height(_) if w >= 0.0 => 0.0,
            Family::Height(_) => f64::NEG_INFINITY,
        }
    }
}

impl Term {
    /// The shortest length over which the term varies by a sizeable part of itself (`∞`
    /// for a constant): a wave's `1/|q|`, a polynomial's half width over its degree, a
    /// blob's core radius `√(c/d)`, a height layer's `1/b`. What a march that samples `K`
    /// (the lit picture) sets its step from.
    pub fn feature_size(&self) -> f64 {
        let positive = |x: f64| {
            if x > 0.0 && x.is_finite() {
                x
            } else {
                f64::INFINITY
            }
        };
        match &self.family {
            Family::Constant => f64::INFINITY,
            Family::Cosine(c) => c
                .waves
                .iter()
                .map(|w| positive(1.0 / vec3::norm2(w.q).sqrt()))
                .fold(f64::INFINITY, f64::min),
            Family::Polynomial(p) => {
                let degree = p
                    .monomials
                    .iter()
                    .map(|(_, pw)| pw.iter().sum::<u32>())
                    .max()
                    .unwrap_or(0)
                    .max(1);
                positive(p.half / f64::from(degree))
            }
            Family::Blob(b) => positive((b.c / b.d).sqrt()),
            Family::Height(h) => positive(1.0 / h.falloff),
        }
    }
}

/// A fog: its terms and the wind carrying them.
#[derive(Clone, Debug, PartialEq)]
pub struct Fog {
    pub terms: Vec<Term>,
    /// Wind velocity (world units per second).
    pub wind: Vec3,
}

impl Fog {
    /// Where the wind has carried a windy term's origin by time `t`: `x − v t`.
    pub fn shifted(&self, term: &Term, x: Vec3, t: f64) -> Vec3 {
        if term.windy {
            sub(x, scale(self.wind, t))
        } else {
            x
        }
    }

    /// The smallest [`Term::feature_size`] of the terms of non-zero weight.
    pub fn feature_size(&self) -> f64 {
        self.terms
            .iter()
            .filter(|t| t.weight != 0.0)
            .map(Term::feature_size)
            .fold(f64::INFINITY, f64::min)
    }

    /// `K(x, t) = Σ w_i γ_i(x − v t, t)`.
    pub fn density(&self, x: Vec3, t: f64) -> f64 {
        self.terms
            .iter()
            .map(|term| term.weight * term.gamma(self.shifted(term, x, t), t))
            .sum()
    }

    /// The optical depth `∫₀^len K(o + s w, t) ds` along the unit direction `w`, in closed
    /// form term by term (paper D eq. 8); 0 for `len ≤ 0`.
    pub fn optical_depth(&self, o: Vec3, w: Vec3, len: f64, t: f64) -> f64 {
        if len <= 0.0 {
            return 0.0;
        }
        self.terms
            .iter()
            .map(|term| term.weight * term.gamma_integral(self.shifted(term, o, t), w, len, t))
            .sum()
    }

    /// A lower bound of `K` over space and time (the terms' bounds summed).
    pub fn lower_bound(&self) -> f64 {
        self.terms.iter().map(Term::lower_bound).sum()
    }
}
