//! Media whose extinction is a homogeneous part plus a sum of Gaussians (paper B, Zhou et
//! al. 2007, "Fogshop: real-time design and rendering of inhomogeneous, single-scattering
//! media"):
//!
//! `σt(x) = β0 + Σᵢ cᵢ·exp(−aᵢ²|x − bᵢ|²)`,
//!
//! with `cᵢ = σt·wᵢ`, `aᵢ = 1/rᵢ`, `bᵢ` the centre (the scene file's `weight`, `radius`,
//! `center`) and `β0 = σt·background`. The pure mathematics lives here — the line integral
//! of a Gaussian in closed form ([`line`](mod@line)), the erf it needs ([`erf`]), a bounding-sphere
//! hierarchy to find the Gaussians along a segment ([`bvh`]), the medium ([`medium`]),
//! paper B's per-Gaussian airlight factored at the centre ([`airlight`]) and, where a bound on
//! that factorization's error says so, integrated along the ray ([`integrated`]), the average optical depth that dims the environment ([`average`], summed over many
//! Gaussians by a Barnes–Hut tree in [`mean_tree`]) and its Perlin
//! noise perturbation ([`noise`]). Lights, surfaces and the homogeneous term (paper C)
//! belong to the scene crate, which depends on this one.

pub mod airlight;
pub mod average;
pub mod bvh;
pub mod cloud;
pub mod erf;
pub mod integrated;
pub mod light_view;
pub mod line;
pub mod mean_tree;
pub mod medium;
pub mod noise;

/// Composite Simpson's rule for the tests' independent integrals.
#[cfg(test)]
pub(crate) fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let n = n + n % 2;
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for k in 1..n {
        sum += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

pub use medium::{Gaussian, GaussianMedium};
