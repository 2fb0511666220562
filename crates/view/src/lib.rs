//! Lighting and rendering of smoke (paper A §3–5.6): environment lighting, spherical
//! harmonics, single scattering at RBF centers, multiple scattering by diffusion,
//! compensated ray marching, and a reference renderer to measure them against. Every
//! stage runs on the CPU (rayon) and is the oracle of its GPU twin.

pub mod camera;
pub mod env;
pub mod field;
pub mod medium;
pub mod sh;

pub use camera::Camera;
pub use env::{Environment, LatLong, Rgb, Sky};
pub use medium::Medium;
