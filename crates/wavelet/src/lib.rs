//! Wavelet fog (paper E: Giroud & Biri, real-time heterogeneous fog on B-spline
//! wavelets).
//!
//! A large outdoor fog is a 2-D extinction function on B-spline scaling functions — a
//! fogmap's pixels are the finest coefficients — decomposed by Mallat's transform into a
//! coarse approximation and layers of details, and rendered by integrating the
//! extinction exactly along each view ray, level by level and cell by cell, with µ
//! dropping fine levels with distance.
//!
//! * [`basis`]: Haar, linear and quadratic B-splines, their wavelets and filter banks
//!   (derivation in the module docs).
//! * [`mallat`]: the lossless 2-D non-standard decomposition, any map size.
//! * [`fogmap`]: fogmaps from PNG, EXR, NumPy or raw float32 files.
//! * [`placement`]: world placement and vertical profile.
//! * [`integrate`]: exact integrals of a level along a ray segment.
//! * [`lod`]: the renderable [`Fog`]: µ, deconstruction, early termination.
//! * [`render`]: camera, a ground-and-sky scene, the per-pixel blend, parallel rendering.
//! * [`gpu`]: the same renderer in WGSL on wgpu (paper E §5), tested against the CPU.

pub mod basis;
pub mod fogmap;
pub mod gpu;
pub mod integrate;
pub mod lod;
pub mod mallat;
pub mod placement;
pub mod render;

pub use basis::Basis;
pub use fogmap::{Fogmap, FogmapError};
pub use lod::{Fog, FogError, Mode, Settings};
pub use mallat::{Decomposition, Grid};
pub use placement::Placement;
