//! Scenes — a camera, an environment, point and sun lights, participating media and
//! surfaces, read from one JSON file (DESIGN.md "Scene file") — and the fog models that
//! light them. Today: paper C (Sun et al. 2005), analytic single scattering of point
//! lights in a homogeneous isotropic medium — airlight from a precomputed table of its
//! special function, surfaces lit through the medium (diffuse `G0` and specular `Gn`
//! tables) — with a reference renderer that integrates the same single-scattering model
//! by quadrature, independent of every table.

pub mod airlight;
pub mod analytic;
pub mod asset_medium;
pub mod edit;
pub mod env_smoke;
pub mod envglow;
pub mod envref;
pub mod file;
pub mod gaussian_env;
pub mod gaussian_medium;
pub mod gpu;
pub mod gpu_analytic;
pub mod gpu_march;
pub mod gpu_paper_b;
pub mod gtable;
pub mod hfunc;
pub mod htable;
pub mod march;
pub mod media;
pub mod mesh;
pub mod model;
pub mod paper_b;
pub mod quad;
pub mod raster;
pub mod reference;
pub mod render;
pub mod scene;
pub mod special;
pub mod table;
pub mod voxel_grid;

pub use file::{SceneError, load};
pub use haze_camera::Camera;
pub use haze_core::vec3;
pub use scene::{Environment, Light, Material, Medium, Rgb, Scene, Shape, Surface};
