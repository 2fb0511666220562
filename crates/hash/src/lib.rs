//! The residual of paper A §5.2: `R = D − D̃` quantized to a few bits, then stored
//! losslessly in a perfect spatial hash (Lefebvre & Hoppe 2006) so that a GPU can look up
//! any voxel in O(1) with no collisions and no wasted space on zeros.
//!
//! * [`quantize`]: per-frame uniform quantization with rounding (dead zone ±½ step).
//! * [`PerfectHash`]: the hash of a sparse set of integer cells with exact lookups.
//! * [`tile`]: up to 27 frames tiled 3×3×3 into one hashed domain, as in the paper.

pub mod block;
pub mod psh;
pub mod quantize;
pub mod tile;

pub use psh::{BuildOptions, HashError, PerfectHash};
pub use quantize::{Quantized, quantize};
