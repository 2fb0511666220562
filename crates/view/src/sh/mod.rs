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
