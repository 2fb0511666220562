//! On-disk layout: preamble, block index entries, header and block kinds.

use serde::{Deserialize, Serialize};

/// File magic: "HAZE", a NUL, CR LF and ^Z, so that text-mode transfers and `type`
/// corrupt it visibly.
pub const MAGIC: [u8; 8] = *b"HAZE\0\r\n\x1a";
/// Format version this build writes and the newest it reads. Version 7 codes each
/// residual value's magnitude class stepped to from its scale context's likeliest class
/// (`haze_hash::block` layout 7: fewer coded bits, a faster decode); version 6 splits a
/// large hash volume's residual values into streams that decode apart (layout 6, still
/// read); version 5 codes the header's JSON against a fixed zstd dictionary and the
/// residual's values under mixed context models in one stream (layout 5, still read);
/// version 4 range-coded the residual's values under
/// one context model (layout 4) and the RBFs (layout 3). Files of versions 1 to 4 still
/// open (raw volumes and RBF blocks of layout 2 and 3 read as before), and the blocks they
/// hold in an older layout are refused with a message to bake again.
pub const FORMAT_VERSION: u32 = 7;
/// Alignment of every block, in bytes.
pub const ALIGN: u64 = 64;
/// Size of the preamble.
pub const PREAMBLE_LEN: usize = 64;
/// Size of one index entry.
pub const ENTRY_LEN: usize = 40;

/// Which frames a block belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scope {
    /// The whole asset (e.g. a fogmap).
    Asset,
    /// Frames `first .. first + count` (one frame for per-frame data; 27 for a hash volume).
    Frames { first: u32, count: u32 },
}

impl Scope {
    pub fn frame(k: u32) -> Scope {
        Scope::Frames { first: k, count: 1 }
    }

    /// Whether the scope names only frames of an asset with `frame_count` frames (and at
    /// least one).
    pub fn fits(&self, frame_count: u32) -> bool {
        match *self {
            Scope::Asset => true,
            Scope::Frames { first, count } => {
                count > 0 && u64::from(first) + u64::from(count) <= u64::from(frame_count)
            }
        }
    }

    pub fn covers(&self, k: u32) -> bool {
        match *self {
            Scope::Asset => false,
            Scope::Frames { first, count } => k >= first && k - first < count,
        }
    }
}

impl std::fmt::Display for Scope {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Scope::Asset => write!(f, "asset-wide"),
            Scope::Frames { first, count: 1 } => write!(f, "frame {first}"),
            Scope::Frames { first, count } => {
                write!(
                    f,
                    "frames {first}..{}",
                    u64::from(first) + u64::from(count) - 1
                )
            }
        }
    }
}

/// Kinds of block. Numbers are part of the format; new kinds take new numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BlockKind {
    /// A dense `f32` volume (see [`crate::encode_raw_volume`]).
    RawVolume,
    /// The Gaussian RBFs of one frame (see [`crate::encode_rbfs`]).
    Rbfs,
    /// The quantized, hashed residual of up to 27 frames (layout: `haze_hash::block`).
    ResidualHash,
    /// A kind this build does not know: kept and skipped.
    Unknown(u32),
}

impl BlockKind {
    pub fn code(self) -> u32 {
        match self {
            BlockKind::RawVolume => 1,
            BlockKind::Rbfs => 2,
            BlockKind::ResidualHash => 3,
            BlockKind::Unknown(c) => c,
        }
    }

    pub fn from_code(c: u32) -> BlockKind {
        match c {
            1 => BlockKind::RawVolume,
            2 => BlockKind::Rbfs,
            3 => BlockKind::ResidualHash,
            other => BlockKind::Unknown(other),
        }
    }

    pub fn name(self) -> String {
        match self {
            BlockKind::RawVolume => "raw-volume".to_string(),
            BlockKind::Rbfs => "rbfs".to_string(),
            BlockKind::ResidualHash => "residual-hash".to_string(),
            BlockKind::Unknown(c) => format!("kind-{c}"),
        }
    }
}

/// One entry of the block index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockEntry {
    pub kind: BlockKind,
    pub scope: Scope,
    /// Byte offset of the payload in the file (a multiple of [`ALIGN`]).
    pub offset: u64,
    /// Payload length in bytes.
    pub len: u64,
    /// CRC-32 (IEEE) of the payload.
    pub crc32: u32,
}

/// `frame_count` value that marks an asset-wide block.
const ASSET_SCOPE: u32 = u32::MAX;

impl BlockEntry {
    pub(crate) fn encode(&self) -> [u8; ENTRY_LEN] {
        let mut b = [0u8; ENTRY_LEN];
        let (first, count) = match self.scope {
            Scope::Asset => (0, ASSET_SCOPE),
            Scope::Frames { first, count } => (first, count),
        };
        b[0..4].copy_from_slice(&self.kind.code().to_le_bytes());
        b[4..8].copy_from_slice(&first.to_le_bytes());
        b[8..12].copy_from_slice(&count.to_le_bytes());
        b[12..16].copy_from_slice(&self.crc32.to_le_bytes());
        b[16..24].copy_from_slice(&self.offset.to_le_bytes());
        b[24..32].copy_from_slice(&self.len.to_le_bytes());
        b
    }

    pub(crate) fn decode(b: &[u8]) -> BlockEntry {
        let u32_at = |i: usize| u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]]);
        let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap_or([0; 8]));
        let (first, count) = (u32_at(4), u32_at(8));
        BlockEntry {
            kind: BlockKind::from_code(u32_at(0)),
            scope: if count == ASSET_SCOPE {
                Scope::Asset
            } else {
                Scope::Frames { first, count }
            },
            crc32: u32_at(12),
            offset: u64_at(16),
            len: u64_at(24),
        }
    }
}

/// The source grid every frame shares.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridInfo {
    pub dims: [u32; 3],
    pub bbox_min: [f64; 3],
    pub bbox_max: [f64; 3],
}

/// Where the frames came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct SourceInfo {
    /// The input path as given.
    pub path: String,
    /// VDB grid name (empty for raw/npy input).
    #[serde(default)]
    pub grid: String,
    /// Source frame number of each asset frame, in order.
    pub frame_numbers: Vec<i64>,
}

/// The asset header (JSON). Unknown keys are kept in `extra` so that a file written by a
/// newer minor revision passes through tools unchanged.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// The program that wrote the file, e.g. "haze 0.1.0".
    pub generator: String,
    pub frame_count: u32,
    pub grid: GridInfo,
    pub source: SourceInfo,
    /// Settings of each baking stage, keyed by stage ("fit", "quantization", ...).
    #[serde(default)]
    pub settings: serde_json::Map<String, serde_json::Value>,
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_round_trip() {
        for e in [
            BlockEntry {
                kind: BlockKind::RawVolume,
                scope: Scope::frame(7),
                offset: 64,
                len: 1 << 40,
                crc32: 0xdead_beef,
            },
            BlockEntry {
                kind: BlockKind::Unknown(99),
                scope: Scope::Asset,
                offset: 1 << 33,
                len: 0,
                crc32: 1,
            },
            BlockEntry {
                kind: BlockKind::RawVolume,
                scope: Scope::Frames {
                    first: 27,
                    count: 27,
                },
                offset: 128,
                len: 5,
                crc32: 0,
            },
        ] {
            assert_eq!(BlockEntry::decode(&e.encode()), e);
        }
    }

    #[test]
    fn scopes_cover_their_frames() {
        let s = Scope::Frames {
            first: 27,
            count: 27,
        };
        assert!(!s.covers(26) && s.covers(27) && s.covers(53) && !s.covers(54));
        assert!(!Scope::Asset.covers(0));
        let edge = Scope::Frames {
            first: u32::MAX - 1,
            count: 1,
        };
        assert!(edge.covers(u32::MAX - 1) && !edge.covers(u32::MAX));
        assert_eq!(s.to_string(), "frames 27..53");
    }
}
