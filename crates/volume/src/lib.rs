//! Shared vocabulary of haze: dense volumes, Gaussian RBFs and the importers that bring
//! real smoke data in.
//!
//! * [`Volume`]: a dense `f32` grid (x fastest, then y, then z) placed in an axis-aligned
//!   world box, samples at voxel centers.
//! * [`Rbf`]: one Gaussian radial basis function `w·exp(−(|x−c|/r)²)`, cut off at `3r`
//!   (paper A, §5.1), and [`rbf::evaluate_on_grid`] for sums of them.
//! * [`import`]: OpenVDB (via vdb-rs), raw little-endian `f32` with a JSON sidecar, NumPy
//!   `.npy`, and numbered sequences of any of those.
//! * [`export`]: a dense volume as an OpenVDB file.

pub mod error;
pub mod export;
pub mod import;
pub mod rbf;
pub mod stats;
pub mod volume;

pub use error::{ImportError, Problem};
pub use import::{ImportOptions, Sequence};
pub use rbf::Rbf;
pub use stats::VolumeStats;
pub use volume::{Bbox, Volume};
