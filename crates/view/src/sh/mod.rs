//! Spherical harmonics (paper A appendix): the real orthonormal basis, projection,
//! zonal harmonics and convolution, the triple product and SH exponentiation.
//!
//! Conventions: "order n" means `n²` coefficients, bands `l = 0..n−1`, stored as
//! `Vec<f64>` at index `l(l+1) + m`, `m ∈ [−l, l]`; `∫ Y_i Y_j dω = δ_ij`; real basis
//! without the Condon–Shortley phase (band 1 is `√(3/4π)·(y, z, x)`; see [`basis`]).
//! Directions are Z-up world directions (`distant::direction`). Orders 1..=[`MAX_ORDER`]
//! are supported everywhere; 4 is the viewer's default.

pub mod basis;
pub mod exp;
pub mod grid;
pub mod project;
pub mod quad;
pub mod triple;
pub mod zonal;

pub use basis::{count, eval, eval_into, index, reconstruct};
pub use exp::{ExpMethod, ShExp, exp_reference, halvings_for, random_optical_depth};
pub use grid::ShGrid;
pub use project::{project_env, project_fn};
pub use triple::TripleProduct;
pub use zonal::{convolve, gaussian_optical_depth_zh, hg_zh, zh_project, zh_rotate};

/// Highest SH order the tables (triple product, exponentiation) are built for.
pub const MAX_ORDER: usize = 6;

/// The order the viewer uses unless told otherwise.
pub const DEFAULT_ORDER: usize = 4;

/// The weight of the first band of a Henyey–Greenstein phase function that SH of `order`
/// bands cut off, relative to band 0: its zonal coefficients are `√(4π(2l+1))·g^l`
/// ([`hg_zh`]), so with the basis' `√(2l+1)` divided out band `order` weighs
/// `|g|^order`. What is cut is the
/// forward peak: the sky's light scattered through small angles is blurred over the
/// smoke. The environment pass takes the peak apart (delta-M, `render::env_pass`) and,
/// above [`PHASE_CUT_WARNING`], integrates it by its shape (`render::peak_rule`); the
/// multiple scattering's light towards the eye keeps its bands 0–4 and leaves the peak
/// beyond them to the eye's ray (`render::grid_diffusion`). Measured (BENCHMARKS.md
/// "Skies of every shape"): at `g` 0.5 and order 4 (`0.06`) sky-lit single scattering is
/// within 1–2 %; at `g` 0.8 (`0.41`) thick front-lit plumes' is within 2.6–3.3 % (8–12 %
/// with the peak as a δ), and the final images of thick smoke are 3–7 % off, front-,
/// side- and back-lit. 0 for `g` 0 or NaN.
pub fn phase_cut(g: f64, order: usize) -> f64 {
    if g.is_nan() {
        return 0.0;
    }
    g.abs()
        .min(1.0)
        .powi(i32::try_from(order).unwrap_or(i32::MAX))
}

/// [`phase_cut`] above which a render warns that its phase function is truncated.
pub const PHASE_CUT_WARNING: f64 = 0.1;

/// The warning for a phase function `g` that SH of `order` bands truncate beyond
/// [`PHASE_CUT_WARNING`], with what to do; `None` when they do not.
pub fn phase_cut_warning(g: f64, order: usize) -> Option<String> {
    let c = phase_cut(g, order);
    (c > PHASE_CUT_WARNING).then(|| {
        format!(
            "HG g {g} is too {} for SH order {order}: the cut band weighs {:.0} % of the phase function's first, so sky-lit multiple scattering is approximate (at g 0.8 and order 4 on held-out plumes: single scattering within 3 %, the final image 3–6 % off; on smoke thicker than a third of an optical depth a voxel, cells of one voxel took it to 2.4–5.1 % at about 10× the multiple scattering's time: automatic while they cost at most the orders' budget, --diffusion orders:1 beyond it); a check against the reference (--check) says how far",
            if g < 0.0 { "backward" } else { "forward" },
            100.0 * c
        )
    })
}

#[cfg(test)]
mod phase_cut_tests {
    use super::*;

    /// The warning names the peak's side: a backward `g` is not "too forward".
    #[test]
    fn the_warning_names_the_peaks_side() {
        let w = |g: f64| phase_cut_warning(g, 4).unwrap_or_default();
        assert!(
            w(0.9).contains("HG g 0.9 is too forward for SH order 4"),
            "{}",
            w(0.9)
        );
        assert!(
            w(-0.9).contains("HG g -0.9 is too backward for SH order 4"),
            "{}",
            w(-0.9)
        );
        assert_eq!(phase_cut_warning(0.3, 4), None);
        assert_eq!(phase_cut_warning(-0.3, 4), None);
    }

    /// The cut band's weight is `|g|^order`: against the HG zonal coefficients
    /// (`hg_zh`), band `order` over band 0 divided by the basis' `√(2l+1)` ratio.
    #[test]
    fn the_cut_band_is_g_to_the_order() {
        for &g in &[0.3, 0.5, -0.8, 0.8] {
            let zh = hg_zh(g, MAX_ORDER + 1);
            for order in 1..=MAX_ORDER {
                let ratio = zh[order] / zh[0] / ((2 * order + 1) as f64).sqrt();
                assert!(
                    (phase_cut(g, order) - ratio.abs()).abs() < 1e-12,
                    "{g} {order}"
                );
            }
        }
        assert_eq!(phase_cut(0.0, 4), 0.0);
        assert_eq!(phase_cut(f64::NAN, 4), 0.0);
        assert!(phase_cut_warning(0.5, 4).is_none());
        let w = phase_cut_warning(0.8, 4).unwrap();
        assert!(w.contains("41 %") && w.contains("--check"), "{w}");
        assert!(phase_cut_warning(0.8, 6).unwrap().contains("--check"));
    }
}
