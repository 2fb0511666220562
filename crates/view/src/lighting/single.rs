//! Single scattering at the RBF centers (paper A §5.3, eqs. 10–11).
//!
//! At each center `c_ℓ`, the optical depth towards every direction is the sum over RBFs
//! `h` of `w_h · r_h · T(|c_h − c_ℓ| / r_h)` rotated onto the axis `c_h − c_ℓ`
//! ([`ZhTable`]); times `−σt`, exponentiated in SH (`exp*`), it is the transmittance
//! vector `τ̃(c_ℓ)`. The source radiance is then
//!
//! ```text
//! J̃ss(c_ℓ) = (Ω/4π) · [(L_in ∗ τ̃(c_ℓ)) ⋆ p],   i.e.
//! J_lm = (Ω/4π) · √(4π/(2l+1)) · p_l · (L_in ∗ τ̃)_lm
//! ```
//!
//! with `∗` the SH triple product and `⋆` the convolution with the HG phase function's
//! zonal coefficients `p_l` (docs/derivations.md, eq. 11; for `p ≡ 1` it is `Ω · avg(L_in τ̃)`).
//!
//! **Where τ̃ is taken** ([`SourcePoints`]). The volume pass spreads `J̃(c_ℓ)` over the
//! RBF's whole footprint (eq. 14), so the value that represents RBF `ℓ` best is the
//! `B_ℓ`-weighted mean of `τ̃` over the footprint, not its value at the center: in dense
//! smoke the center is the most shadowed point and, the transmittance being convex in
//! depth, the center value is biased dark (measured: −8 % of the image at a peak optical
//! depth of ≈ 3, −26 % at ≈ 9; `BENCHMARKS.md`). [`SourcePoints::Footprint`] averages `τ̃`
//! over the degree-3 cubature of the Gaussian weight `exp(−|x − c|²/r²)` (variance `r²/2`
//! per axis): the six points `c ± r√(3/2)·e_i`, weights 1/6, exact for cubic `τ̃`.
//! [`SourcePoints::Center`] is the paper's choice, six times cheaper.
//!
//! Direction convention: `L_in(ω)` is the radiance arriving *from* `ω`; with the unflipped
//! `p_l`, `J` is a function of the direction `d` a viewer looks along (the light scattered
//! towards the viewer travels along `−d`): forward scattering peaks when `d` points at the
//! light. Evaluate `J` at the view ray's direction.

use crate::diffusion::Sources;
use crate::lighting::zh_table::ZhTable;
use crate::medium::Medium;
use crate::sh::{self, ExpMethod, ShExp, TripleProduct};
use haze_volume::Rbf;
use rayon::prelude::*;
use std::f64::consts::PI;

/// The SH machinery of one order, built once and reused while the order is unchanged.
#[derive(Debug)]
pub struct ShKit {
    pub order: usize,
    pub table: ZhTable,
    pub triple: TripleProduct,
    pub exp: ShExp,
}

impl ShKit {
    pub fn new(order: usize) -> ShKit {
        ShKit {
            order,
            table: ZhTable::new(order),
            triple: TripleProduct::new(order),
            exp: ShExp::new(order),
        }
    }
}

/// RGB SH vectors.
pub type RgbSh = [Vec<f64>; 3];

/// Where each RBF's transmittance vector is evaluated (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SourcePoints {
    /// At the center `c_ℓ` only (paper A §5.3).
    Center,
    /// The mean over the six-point Gaussian cubature of the RBF's footprint.
    Footprint,
}

impl SourcePoints {
    /// The evaluation points of `rbf` (all with equal weight).
    pub fn points(self, rbf: &Rbf) -> Vec<[f64; 3]> {
        match self {
            SourcePoints::Center => vec![rbf.center],
            SourcePoints::Footprint => {
                let a = rbf.radius.max(0.0) * 1.5f64.sqrt();
                (0..6)
                    .map(|i| {
                        let mut p = rbf.center;
                        p[i / 2] += if i % 2 == 0 { a } else { -a };
                        p
                    })
                    .collect()
            }
        }
    }
}

/// Optical depth SH vector at `p` through all `rbfs` (before `× −σt`): Σ w_h r_h T_h.
pub fn optical_depth_sh(kit: &ShKit, rbfs: &[Rbf], p: [f64; 3]) -> Vec<f64> {
    let n = kit.order;
    let mut f = vec![0.0; n * n];
    let mut zh = vec![0.0; n];
    let mut y = vec![0.0; n * n];
    let band_scale: Vec<f64> = (0..n)
        .map(|l| (4.0 * PI / (2 * l + 1) as f64).sqrt())
        .collect();
    for h in rbfs {
        if h.radius <= 0.0 || h.weight == 0.0 || !h.radius.is_finite() {
            continue;
        }
        let a = [h.center[0] - p[0], h.center[1] - p[1], h.center[2] - p[2]];
        let dist = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        kit.table.lookup_into(dist / h.radius, &mut zh);
        let s = h.weight * h.radius;
        if dist <= 1e-12 * h.radius {
            // At the center the depth is isotropic: band 0 only, no axis needed.
            f[0] += s * zh[0];
            continue;
        }
        sh::eval_into(n, a, &mut y);
        for l in 0..n {
            let k = s * band_scale[l] * zh[l];
            for m in 0..(2 * l + 1) {
                let i = l * l + m;
                f[i] += k * y[i];
            }
        }
    }
    f
}

/// The result of [`single_scattering`].
#[derive(Clone, Debug, Default)]
pub struct SingleScattering {
    /// `J̃ss(c_ℓ)`, RGB SH of the viewing direction.
    pub source: Vec<RgbSh>,
    /// Escape probability at each center, `τ̃_00/√4π ∈ [0, 1]` (the mean transmittance
    /// to the outside over all directions; the diffusion's vacuum correction).
    pub escape: Vec<f64>,
}

/// `J̃ss` at every RBF center, for lighting `light` (RGB SH of `L_in`).
pub fn single_scattering(
    kit: &ShKit,
    rbfs: &[Rbf],
    medium: &Medium,
    light: &RgbSh,
    method: ExpMethod,
    points: SourcePoints,
) -> SingleScattering {
    let phase = sh::hg_zh(medium.g, kit.order);
    let (source, escape) = rbfs
        .par_iter()
        .map(|c| {
            let pts = points.points(c);
            let mut tau = vec![0.0; kit.order * kit.order];
            for p in &pts {
                let mut f = optical_depth_sh(kit, rbfs, *p);
                for v in &mut f {
                    *v *= -medium.sigma_t;
                }
                let t = kit.exp.exp(&f, method, &kit.triple);
                for (a, b) in tau.iter_mut().zip(&t) {
                    *a += b / pts.len() as f64;
                }
            }
            let j = [0, 1, 2].map(|ch| {
                let lt = kit.triple.product(&light[ch], &tau);
                let mut j = sh::convolve(&lt, &phase);
                for v in &mut j {
                    *v *= medium.albedo / (4.0 * PI);
                }
                j
            });
            let p = tau[0] / (4.0 * PI).sqrt();
            (
                j,
                if p.is_finite() {
                    p.clamp(0.0, 1.0)
                } else {
                    0.0
                },
            )
        })
        .unzip();
    SingleScattering { source, escape }
}

/// `J⁰` and `J¹` (direction of propagation) of each center's single-scattering source,
/// from its SH vector, which is a function of the viewing direction `d = −ω`:
/// `J⁰ = J_00/√(4π)`, `J¹ = (3/4π)∫J(ω)ω dω = −√(3/4π)·(J_11, J_1−1, J_10)`.
pub fn moments(source: &[RgbSh]) -> Sources {
    let mut s = Sources::zeros(source.len());
    let k1 = -(3.0 / (4.0 * PI)).sqrt();
    for (l, j) in source.iter().enumerate() {
        for (c, jc) in j.iter().enumerate() {
            s.j0[l][c] = jc[0] / (4.0 * PI).sqrt();
            if jc.len() >= 4 {
                s.j1[l][c] = [k1 * jc[3], k1 * jc[1], k1 * jc[2]];
            }
        }
    }
    s
}
