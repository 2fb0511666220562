//! Media whose extinction is a homogeneous part plus a sum of Gaussians (paper B, Zhou et
//! al. 2007, "Fogshop: real-time design and rendering of inhomogeneous, single-scattering
//! media"):
//!
//! `σt(x) = β0 + Σᵢ cᵢ·exp(−aᵢ²|x − bᵢ|²)`,
//!
//! with `cᵢ = σt·wᵢ`, `aᵢ = 1/rᵢ`, `bᵢ` the centre (the scene file's `weight`, `radius`,
//! `center`) and `β0 = σt·background`. The pure mathematics lives here — the line integral
//! of a Gaussian in closed form ([`line`]), the erf it needs ([`erf`]), a bounding-sphere
//! hierarchy to find the Gaussians along a segment ([`bvh`]), the medium ([`medium`]),
//! paper B's per-Gaussian airlight factored at the centre ([`airlight`]) and, where a bound on
//! that factorization's error says so, integrated along the ray ([`integrated`]), the average optical depth that dims the environment ([`average`]) and its Perlin
//! noise perturbation ([`noise`]). Lights, surfaces and the homogeneous term (paper C)
//! belong to the scene crate, which depends on this one.

pub mod airlight;
pub mod average;
pub mod bvh;
pub mod cloud;
pub mod erf;
pub mod integrated;
pub mod line;
pub mod medium;
pub mod noise;

pub use medium::{Gaussian, GaussianMedium};
