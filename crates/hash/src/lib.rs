//! The residual of paper A §5.2: `R = D − D̃` quantized to the error the user accepts,
//! then stored in a perfect spatial hash of voxel bricks (Lefebvre & Hoppe 2006) so that a
//! GPU can look up any voxel in O(1) with no collisions and no bytes spent on empty space.
//!
//! * [`quantize`](mod@quantize): per-frame uniform quantization whose step follows from the error asked
//!   for (dead zone ±½ step; lossless at error 0).
//! * [`pack`]: a brick's values at the narrowest of 2, 4, 8, 16 (or 32, lossless) bits.
//! * [`PerfectHash`]: the hash of a sparse set of integer cells with exact lookups.
//! * [`tile`]: up to 27 frames tiled 3×3×3 into one hashed domain of bricks, as in the
//!   paper, and the lookup.
//! * [`block`]: the asset block of one hash volume, its values coded by [`context_coder`].

pub mod block;
pub mod context_coder;
pub mod pack;
pub mod psh;
pub mod quantize;
pub mod tile;

pub use psh::{BuildOptions, HashError, PerfectHash};
pub use quantize::{DEFAULT_ERROR, QuantOptions, Quantized, quantize};
