//! Multiple scattering by diffusion on the RBF basis (paper A §5.4).
//!
//! The media radiance is the two-term expansion `L_m(x, ω) ≈ L⁰(x) + L¹(x)·ω`, `ω` the
//! direction of propagation, with `L⁰ = (1/4π)∫L dω` and `L¹ = (3/4π)∫L ω dω`; the
//! single-scattering source `J_ss` (which carries the albedo) has moments `J⁰_ss`, `J¹_ss`
//! defined the same way. Taking the zeroth and first moments of the RTE (docs/derivations.md,
//! "Notes on the mangled equations", re-derived and checked here):
//!
//! ```text
//! (1/3)∇·L¹ = −σa D L⁰ + σt D J⁰_ss            σa = (1 − Ω) σt
//!       ∇L⁰ = −σtr D L¹ + σt D J¹_ss           σtr = (1 − Ω g) σt
//! ```
//!
//! (`σtr = (1 − Ω μ̄/3) σt` with `μ̄ = 3g`, the first Legendre coefficient of the normalized
//! Henyey–Greenstein phase). Eliminating `L¹` gives the diffusion equation
//!
//! ```text
//! ∇·(κ∇L⁰) − σa D L⁰ + S = 0,   κ = 1/(3 σtr D),   S = σt D J⁰_ss − (σt/(3σtr)) ∇·J¹_ss.
//! ```
//!
//! The paper's eq. 6 and 13 are mangled in the text we have: they carry a factor 3 on
//! `κ`'s flux law, `σt/σtr` instead of `σt/(3σtr)` on the `J¹` term and an `Ω` next to `σt`
//! on the `J⁰` term. The equations above are docs/derivations.md's, which the tests verify
//! (finite differences of the continuous fields, and the exact uniform solution
//! `L⁰ = J⁰/(1 − Ω)`).
//!
//! **Vacuum correction.** Written on the RBF basis the equation has no boundary: nothing
//! leaves the smoke, so in the interior `L⁰` tends to the trapped-light value
//! `J⁰/(1 − Ω)` (5× the source at Ω = 0.8), and at Ω = 1 the system is singular.
//! Measured against the path tracer this made multiple scattering 2–3× too bright on
//! plume-a. The light a collision scatters escapes without another collision with the
//! probability `P(x) = (1/4π)∫τ(x, ω) dω`, which the single-scattering pass already has
//! (`τ̃_00/√4π`). The media radiance fed by a source `J` across the smoke is about
//! `(1 − P) J` (the fraction of directions the smoke covers), and of every scattered
//! generation the part `P` leaves. Both enter the local balance:
//!
//! ```text
//! ∇·(κ'∇L⁰) − (σa + σs P) D L⁰ + S' = 0,   κ' = (1 − P) κ,
//! S' = σt D (1 − P) J⁰_ss − (σt/(3σtr)) ∇·((1 − P) J¹_ss)
//! ```
//!
//! Without transport it gives `L⁰ = (1 − P) J⁰/(1 − Ω(1 − P))`: the trapped value deep
//! inside (`P → 0`), the single-collision value `(1 − P) J⁰ → 0` in thin smoke (`P → 1`),
//! and a non-singular system at Ω = 1 wherever `P > 0`. The source's flux `J¹` is kept
//! in the same proportion as `J⁰` (in `S'` and in `L¹ = (σt D (1 − P) J¹ − ∇L⁰)/(σtr D)`):
//! without it a thin region kept the whole flux of its source, `|L¹|/3` exceeded `L⁰`,
//! and the forward-scattered light was too bright (against the path tracer the multiple
//! scattering of sun-lit held-out plumes was 5–9 % too bright in the mean, and 17 % under
//! the built-in sky on plume-a; BENCHMARKS.md, "Multiple scattering under a sun").
//! The diffusion coefficient is kept in that proportion too: `L⁰` describes the light
//! that collides again, and the flights that would have carried it furthest are the ones
//! that leave the smoke (a measured choice: it lowered the error of the multiple
//! scattering part on every scene tried; a flight length conditioned on colliding within
//! a slab of escape probability `P` would shorten it even more, which measured worse).
//! With `P ≡ 0` (the `escape` of [`Sources`] empty) it is the equation above.
//!
//! On the RBF basis every field `F` is interpolated from its values `F_l` at the centers as
//! `F(x) = Σ w_l B_l(x) F_l / D̃(x)` with `D̃ = Σ w_l B_l` (eq. 12), the density `D` is taken
//! to be `D̃`, and the equation is enforced at every center `c_h`: `A L⁰ = b` with
//! `A = ∇·(κ∇·) − σa D̃` and `b = −S` ([`assemble`]). It is solved per colour channel by
//! CGLS with a warm start ([`DiffusionSolver`]), and converted into the order-2 SH source
//! radiance of multiple scattering ([`ms_source_sh`]).

mod basis;
mod cgls;
mod csr;
mod operators;
mod radiance;
mod solver;
mod system;
#[cfg(test)]
mod tests;

pub use cgls::{Cgls, cgls};
pub use csr::Csr;
pub use operators::{OperatorEntry, Operators};
pub use radiance::ms_source_sh;
pub use solver::{DiffusionSolver, Solution, SolveOptions, solve_system};
pub use system::{System, assemble};

use crate::Medium;

/// Single-scattering source radiance moments at the RBF centers, per colour channel (RGB):
/// `j0[l][c] = J⁰_ss(c_l)` and `j1[l][c] = J¹_ss(c_l)` (x, y, z), functions of the direction
/// of propagation. Non-finite entries are read as 0.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Sources {
    pub j0: Vec<[f64; 3]>,
    pub j1: Vec<[[f64; 3]; 3]>,
    /// Escape probability `P_l ∈ [0, 1]` at each center: the mean over directions of the
    /// transmittance to the outside (`τ̃_00/√4π`). Empty means 0 everywhere (the paper's
    /// equation, without the vacuum correction; module docs).
    pub escape: Vec<f64>,
}

impl Sources {
    /// Zero sources for `n` centers.
    pub fn zeros(n: usize) -> Sources {
        Sources {
            j0: vec![[0.0; 3]; n],
            j1: vec![[[0.0; 3]; 3]; n],
            escape: Vec::new(),
        }
    }

    fn escape(&self, l: usize) -> f64 {
        self.escape.get(l).map_or(0.0, |p| {
            if p.is_finite() {
                p.clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    }

    fn j0(&self, l: usize, c: usize) -> f64 {
        finite_or_zero(self.j0[l][c])
    }

    fn j1(&self, l: usize, c: usize) -> [f64; 3] {
        self.j1[l][c].map(finite_or_zero)
    }
}

fn finite_or_zero(v: f64) -> f64 {
    if v.is_finite() { v } else { 0.0 }
}

/// The coefficients of the diffusion equation that depend on the medium alone.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Coefficients {
    pub(crate) sigma_t: f64,
    /// Scattering `σs = Ω σt`.
    pub(crate) sigma_s: f64,
    /// Absorption `σa = (1 − Ω) σt`.
    pub(crate) sigma_a: f64,
    /// Reduced extinction `σtr = (1 − Ω g) σt`.
    pub(crate) sigma_tr: f64,
}

impl Coefficients {
    /// `None` when the medium does not interact with light (`σt = 0`) or is invalid
    /// (`σtr ≤ 0` or non-finite): then `S ≡ 0` and `L⁰ ≡ 0`.
    pub(crate) fn of(m: &Medium) -> Option<Coefficients> {
        let sigma_tr = (1.0 - m.albedo * m.g) * m.sigma_t;
        let sigma_a = (1.0 - m.albedo) * m.sigma_t;
        let ok = sigma_tr > 0.0 && sigma_tr.is_finite() && sigma_a.is_finite();
        ok.then_some(Coefficients {
            sigma_t: m.sigma_t,
            sigma_s: m.albedo * m.sigma_t,
            sigma_a,
            sigma_tr,
        })
    }
}
