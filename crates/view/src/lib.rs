//! Lighting and rendering of smoke (paper A §3–5.6): environment lighting, spherical
//! harmonics, single scattering at RBF centers, multiple scattering by diffusion,
//! compensated ray marching, and a reference renderer to measure them against. Every
//! stage runs on the CPU (rayon) and is the oracle of its GPU twin.

pub mod diffusion;
pub mod distant;
pub mod env;
pub mod field;
pub mod gpu;
pub mod ground;
pub mod lighting;
pub mod lights;
pub mod medium;
pub mod reference;
pub mod render;
pub mod sh;
pub mod stream;

pub use diffusion::{DiffusionSolver, Solution, SolveOptions, Sources};
pub use distant::{Distant, LatLong, Rgb, Sky};
pub use env::Environment;
pub use haze_camera::Camera;
pub use haze_core::{Image, ImageError, ToneMap};
pub use lights::{PointLight, Sun};
pub use medium::Medium;
