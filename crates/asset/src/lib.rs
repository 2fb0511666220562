//! The `.haze` asset: one little-endian, versioned, checksummed, memory-mappable file that
//! holds a whole baked sequence.
//!
//! ```text
//! offset 0     preamble (64 bytes): magic, format version, where the header and the
//!              block index are, their CRC-32s, and the preamble's own CRC-32
//! offset 64    blocks, each starting on a 64-byte boundary (so typed views of f32/u32/f64
//!              arrays need no copy, and GPU uploads can come straight from the mapping)
//! then         header (JSON, serde, zstd-coded from format 4 on, against a fixed
//!              dictionary from format 5 on): grid, source, settings of each baking stage
//! then         block index: one 40-byte entry per block: kind, frames covered,
//!              offset, length, CRC-32
//! ```
//!
//! The header and index come last so that a writer can stream blocks out as frames finish;
//! the preamble is written last of all, and the file only appears under its name once
//! complete (temp file + rename). Readers verify the preamble, header and index on
//! [`Asset::open`], and each block's CRC-32 when the block is handed out, so a bit flip is
//! reported with the block it hit. Block kinds are numbered ([`BlockKind`]); readers
//! keep unknown kinds and skip them, so later stages can add kinds without a format bump.

mod error;
mod format;
mod header_dictionary;
mod raw_volume;
mod rbf_block;
mod reader;
mod writer;

pub use error::{AssetError, BlockId};
pub use format::{
    ALIGN, BlockEntry, BlockKind, FORMAT_VERSION, GridInfo, Header, MAGIC, PREAMBLE_LEN, Scope,
    SourceInfo,
};
pub use raw_volume::{RawVolumeView, decode_raw_volume, encode_raw_volume};
pub use rbf_block::{decode_rbfs, encode_rbfs};
pub use reader::{Asset, BlockView, FrameBlocks};
pub use writer::AssetWriter;
