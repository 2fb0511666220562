//! Scenes — a camera, an environment, point and sun lights, participating media and
//! surfaces, read from one JSON file ([`file`](mod@file), docs/formats.md "Scene file") — and the fog models that light them, one
//! room each:
//!
//! - [`scene`]: the scene as the renderers see it, validated; its homogeneous medium is
//!   paper C's, its other media are [`media`].
//! - [`media`]: media whose extinction varies in space, one kind each — a baked smoke
//!   asset on a voxel grid (paper A), a sum of Gaussians (paper B), analytic fog
//!   functions with wind (paper D) — and what every renderer asks of them.
//! - [`mesh`]: triangle meshes with their bounding-volume hierarchy, and glTF models.
//! - [`file`](mod@file): the scene file, its keys and its one-line errors.
//! - [`paper_c`]: analytic single scattering in a homogeneous medium (Sun et al. 2005) —
//!   the airlight and surface tables, the environment's glow — and the quadrature
//!   references of the same model; [`render`] renders a scene with them.
//! - [`march`]: single scattering through every medium by ray marching, the environment's
//!   light on heterogeneous media included: the renderer of smoke assets and the
//!   reference of papers B and D.
//! - [`paper_b`]: Gaussian media (Zhou et al. 2007), their airlight and environment light.
//! - [`analytic`]: paper D's (Biri et al. 2002) picture — paper C's with the analytic fog
//!   composited over it.
//! - [`edit`]: the viewer's editing tools for Gaussian media.
//! - [`gpu`]: the GPU renderers, `f32` twins of the CPU ones — paper C's, the march,
//!   paper B's, paper D's composite, and primary rays by rasterization — with their
//!   shaders composed from WGSL modules.

pub mod analytic;
pub mod edit;
pub mod file;
pub mod gpu;
pub mod march;
pub mod media;
pub mod mesh;
pub mod paper_b;
pub mod paper_c;
pub mod render;
pub mod scene;

pub use file::{SceneError, load};
pub use haze_camera::Camera;
pub use haze_core::vec3;
pub use scene::{Environment, Light, Material, Medium, Rgb, Scene, Shape, Surface};
