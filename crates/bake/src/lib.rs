//! The bake as a library: a sequence of density volumes (OpenVDB, raw, NumPy) → Gaussian
//! RBFs fitted frame by frame with temporal coherence (paper A §5.1, `haze-fit`) → the
//! residual quantized to the error asked for and hashed in bricks (§5.2, `haze-hash`) →
//! one streamable `.haze` asset (`haze-asset`), journaled so that an interrupted bake
//! resumes where it stopped. The `haze` command-line tool only wraps this crate.
//!
//! ```no_run
//! use haze_bake::{Bake, BakeOptions, Count, Event};
//! # fn main() -> anyhow::Result<()> {
//! // `haze bake cache/ --out smoke.haze --rbfs 400`: the command line's defaults but one.
//! let mut options = BakeOptions::new("cache/", "smoke.haze");
//! options.count = Count::Fixed(400);
//! let mut bake = Bake::new(options, |e: Event<'_>| eprintln!("{e:?}"))?;
//! for frame in bake.by_ref() {
//!     let f = frame?;
//!     println!("frame {}: rel_l2 {:.4}", f.frame, f.fit.rel_l2);
//! }
//! let baked = bake.finish()?;
//! println!("{} bytes", baked.bytes);
//! # Ok(()) }
//! ```
//!
//! * [`pipeline`]: [`Bake`] — open, fit, hash, journal, finish.
//! * [`residual`]: the residual stage (quantize, hash volumes of 27 frames).
//! * [`journal`]: the append-only journal of finished frames and hash volumes.
//! * [`merge`](mod@merge): chunks baked separately joined into one asset.
//! * [`export`]: a frame read back, reconstructed as a dense volume.
//! * [`source`]: the frames of a bake: volume files, or a packed asset's raw volumes.
//! * [`header`]: the asset header of a sequence.
//! * [`inspect`]: what is in a volume file, a sequence or an asset (`haze inspect`).
//! * [`choice`]: automatic choices (the residual error of a `--target-error` bake) and why.

pub mod choice;
pub mod export;
pub mod header;
pub mod inspect;
pub mod journal;
pub mod merge;
pub mod pipeline;
pub mod residual;
pub mod source;

pub use export::{
    AssetFrame, Reconstruction, read_frame, read_rbfs, reconstruct_frame, reconstruct_frames,
};
pub use merge::{Merged, merge};
pub use pipeline::{Bake, BakeOptions, Baked, Count, Event, FrameRecord, MAX_RBFS, baseline};
