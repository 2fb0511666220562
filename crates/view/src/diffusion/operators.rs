//! The parts of the diffusion system that depend on the RBFs alone (paper A §5.4, eq. 12–13).
//!
//! Every medium- and light-dependent factor of `A`, `b` and `J̃ms` is a scalar per center
//! (`κ = (1 − P_h)/(3σtr D̃)`, the sink `σa + σs P_h`, `σt`, `σt/(3σtr)`) multiplying one of three
//! geometric operators on the sparse pattern `{(h, l): v_l(c_h) ≠ 0}`, with `v_l = w_l B_l`:
//!
//! ```text
//! diffusion_hl = [∇²v_l/D̃ − 3 (∇D̃/D̃)·(∇v_l/D̃) + (3|∇D̃/D̃|² − ∇²D̃/D̃)(v_l/D̃)] / D̃
//! v_hl         = v_l(c_h)
//! grad_hl      = ∇(v_l/D̃)(c_h) = (∇v_l/D̃ − (v_l/D̃)∇D̃/D̃)
//! ```
//!
//! (all at `c_h`, `D̃ = D̃(c_h)`), so that (module docs of [`super`], `system`, `radiance`):
//!
//! ```text
//! A_hl = (1 − P_h) diffusion_hl/(3σtr) − (σa + σs P_h) v_hl
//! b_h  = Σ_l (1 − P_l) [−σt v_hl J⁰_l + (σt/(3σtr)) grad_hl · J¹_l]
//! ∇L⁰(c_h) = Σ_l grad_hl L⁰_l
//! ```
//!
//! A frame's operators are computed once (they are what a frame's RBFs cost the diffusion,
//! the rest is multiply-adds) and serve any medium and lighting: the CPU system
//! ([`Operators::system`]), the multiple-scattering source ([`Operators::ms_source_sh`]),
//! and the GPU solve (`gpu::diffusion`), which takes them as they are.

use super::basis::{Neighbours, active, local};
use super::{Coefficients, Csr, Sources, System};
use crate::Medium;
use haze_volume::Rbf;
use nalgebra::{DVector, Vector3};
use rayon::prelude::*;
use std::f64::consts::PI;

/// One stored entry `(h, l)` of the operators: column `l` of row `h`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OperatorEntry {
    pub l: usize,
    /// `diffusion_hl` (module docs).
    pub diffusion: f64,
    /// `v_hl = w_l B_l(c_h)`.
    pub v: f64,
    /// `grad_hl = ∇(v_l/D̃)(c_h)`.
    pub grad: [f64; 3],
}

/// The geometric operators of one frame's RBFs, row `h` for center `c_h`.
#[derive(Clone, Debug, PartialEq)]
pub struct Operators {
    /// Row `h` holds `entries[start[h]..start[h + 1]]`; an inactive center's row is empty.
    start: Vec<usize>,
    entries: Vec<OperatorEntry>,
    /// `D̃(c_h)` at active centers (`≥ w_h > 0`), 0 at inactive ones.
    density: Vec<f64>,
}

impl Operators {
    /// The operators of `rbfs`, row by row in parallel. Inactive RBFs (`basis::active`:
    /// non-finite, zero or negative weight, degenerate radius) get an empty row and
    /// density 0 and appear in no other row.
    pub fn new(rbfs: &[Rbf]) -> Operators {
        let act = active(rbfs);
        let nb = Neighbours::new(rbfs, &act);
        let rows: Vec<(f64, Vec<OperatorEntry>)> = (0..rbfs.len())
            .into_par_iter()
            .map(|h| {
                if !act[h] {
                    return (0.0, Vec::new());
                }
                let loc = local(rbfs, &nb, rbfs[h].center);
                let d = loc.density;
                let g = loc.grad / d;
                let lap = loc.lap / d;
                let entries = loc
                    .terms
                    .iter()
                    .map(|t| {
                        let u = t.v / d;
                        let gu = t.grad / d;
                        let diffusion =
                            t.lap / d - 3.0 * g.dot(&gu) + (3.0 * g.norm_squared() - lap) * u;
                        let grad: Vector3<f64> = gu - g * u;
                        OperatorEntry {
                            l: t.l,
                            diffusion: diffusion / d,
                            v: t.v,
                            grad: grad.into(),
                        }
                    })
                    .collect();
                (d, entries)
            })
            .collect();
        let mut start = Vec::with_capacity(rows.len() + 1);
        start.push(0);
        let mut entries = Vec::with_capacity(rows.iter().map(|r| r.1.len()).sum());
        let mut density = Vec::with_capacity(rows.len());
        for (d, row) in rows {
            density.push(d);
            entries.extend(row);
            start.push(entries.len());
        }
        Operators {
            start,
            entries,
            density,
        }
    }

    /// Number of centers.
    pub fn n(&self) -> usize {
        self.density.len()
    }

    /// Stored entries of all rows.
    pub fn nnz(&self) -> usize {
        self.entries.len()
    }

    /// The entries of row `h`.
    pub fn row(&self, h: usize) -> &[OperatorEntry] {
        &self.entries[self.start[h]..self.start[h + 1]]
    }

    /// `D̃(c_h)`, 0 at an inactive center.
    pub fn density(&self, h: usize) -> f64 {
        self.density[h]
    }

    /// The system `A L⁰ = b` of the medium and the single-scattering `sources` (the
    /// `system` module's docs, which also list the degenerate cases: inactive rows and a
    /// medium that does not interact give rows of the identity and `b = 0`).
    ///
    /// # Panics
    /// If `sources` does not hold one entry per center.
    pub fn system(&self, medium: &Medium, sources: &Sources) -> System {
        let n = self.n();
        assert!(
            sources.j0.len() == n && sources.j1.len() == n,
            "sources for {} / {} centers, {n} RBFs",
            sources.j0.len(),
            sources.j1.len()
        );
        let coefficients = Coefficients::of(medium);
        let mut b = [(); 3].map(|_| DVector::zeros(n));
        let rows = (0..n)
            .map(|h| match coefficients {
                Some(k) if self.density[h] > 0.0 => {
                    let inv_3_sigma_tr = 1.0 / (3.0 * k.sigma_tr);
                    let j1_factor = k.sigma_t * inv_3_sigma_tr;
                    let p_h = sources.escape(h);
                    let sink = k.sigma_a + k.sigma_s * p_h;
                    // The flux of the light that collides again (module docs).
                    let kappa = (1.0 - p_h) * inv_3_sigma_tr;
                    self.row(h)
                        .iter()
                        .map(|e| {
                            let grad = Vector3::from(e.grad);
                            for (c, bc) in b.iter_mut().enumerate() {
                                let kept = 1.0 - sources.escape(e.l);
                                let j1 = Vector3::from(sources.j1(e.l, c)) * kept;
                                let j0 = kept * sources.j0(e.l, c);
                                bc[h] += -k.sigma_t * e.v * j0 + j1_factor * grad.dot(&j1);
                            }
                            (e.l, e.diffusion * kappa - sink * e.v)
                        })
                        .collect()
                }
                _ => vec![(h, 1.0)],
            })
            .collect();
        System {
            a: Csr::from_rows(rows),
            b,
        }
    }

    /// `J_ms` at every center, per channel, as 4 SH coefficients (the `radiance` module's
    /// docs), from the solution `l0`. Inactive centers and a medium with `σt = 0` give
    /// zeros.
    ///
    /// # Panics
    /// If `sources` or `l0` do not hold one entry per center.
    pub fn ms_source_sh(
        &self,
        medium: &Medium,
        sources: &Sources,
        l0: &[[f64; 3]],
    ) -> Vec<[[f64; 4]; 3]> {
        let n = self.n();
        assert!(
            sources.j1.len() == n && l0.len() == n,
            "sources for {} and L⁰ for {} centers, {n} RBFs",
            sources.j1.len(),
            l0.len()
        );
        let Some(k) = Coefficients::of(medium) else {
            return vec![[[0.0; 4]; 3]; n];
        };
        let band0 = medium.albedo * 2.0 * PI.sqrt();
        let band1 = medium.albedo * medium.g * (4.0 * PI / 3.0).sqrt();
        (0..n)
            .map(|h| {
                let d = self.density[h];
                if d <= 0.0 {
                    return [[0.0; 4]; 3];
                }
                [0, 1, 2].map(|c| {
                    let grad_l0: Vector3<f64> = self
                        .row(h)
                        .iter()
                        .map(|e| Vector3::from(e.grad) * l0[e.l][c])
                        .sum();
                    let j1 = Vector3::from(sources.j1(h, c)) * (1.0 - sources.escape(h));
                    let l1 = (j1 * (k.sigma_t * d) - grad_l0) / (k.sigma_tr * d);
                    [band0 * l0[h][c], band1 * l1.y, band1 * l1.z, band1 * l1.x]
                })
            })
            .collect()
    }
}
