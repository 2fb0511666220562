//! Memory-mapped, verified reading of `.haze` files.

use crate::error::{AssetError, BlockId};
use crate::format::{
    ALIGN, BlockEntry, BlockKind, ENTRY_LEN, FORMAT_VERSION, Header, MAGIC, PREAMBLE_LEN, Scope,
};
use crate::header_dictionary::HEADER_DICTIONARY;
use memmap2::Mmap;
use std::fs::File;
use std::path::{Path, PathBuf};

/// Bytes of an asset: a read-only mapping of the file, or an owned copy (8-byte aligned so
/// that block views can be cast to typed slices like the mapping's).
#[derive(Debug)]
enum Storage {
    Mapped(Mmap),
    Owned { words: Vec<u64>, len: usize },
}

impl Storage {
    fn bytes(&self) -> &[u8] {
        match self {
            Storage::Mapped(m) => m,
            Storage::Owned { words, len } => &bytemuck::cast_slice(words)[..*len],
        }
    }
}

/// The largest header JSON a reader decodes (a few hundred bytes a frame in practice).
const MAX_HEADER: usize = 1 << 28;

/// An opened asset: header and index verified, blocks verified as they are handed out.
#[derive(Debug)]
pub struct Asset {
    path: PathBuf,
    storage: Storage,
    version: u32,
    header: Header,
    entries: Vec<BlockEntry>,
}

/// A verified block: its identity and its payload, borrowed from the asset.
#[derive(Clone, Copy, Debug)]
pub struct BlockView<'a> {
    pub id: BlockId,
    pub bytes: &'a [u8],
}

impl BlockView<'_> {
    pub fn kind(&self) -> BlockKind {
        self.id.kind
    }
}

/// The verified blocks that cover one frame (per-frame blocks and multi-frame blocks such
/// as hash volumes), in file order.
#[derive(Debug)]
pub struct FrameBlocks<'a> {
    pub frame: usize,
    pub blocks: Vec<BlockView<'a>>,
}

impl<'a> FrameBlocks<'a> {
    /// The first block of `kind`, if any.
    pub fn find(&self, kind: BlockKind) -> Option<BlockView<'a>> {
        self.blocks.iter().copied().find(|b| b.kind() == kind)
    }
}

fn u32_at(b: &[u8], i: usize) -> u32 {
    u32::from_le_bytes([b[i], b[i + 1], b[i + 2], b[i + 3]])
}

fn u64_at(b: &[u8], i: usize) -> u64 {
    let mut a = [0u8; 8];
    a.copy_from_slice(&b[i..i + 8]);
    u64::from_le_bytes(a)
}

impl Asset {
    /// Maps `path` and verifies its preamble, header and index.
    pub fn open(path: &Path) -> Result<Asset, AssetError> {
        let io = |source| AssetError::Io {
            path: path.to_path_buf(),
            err: source,
        };
        let file = File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        let storage = if len == 0 {
            Storage::Owned {
                words: Vec::new(),
                len: 0,
            }
        } else {
            // SAFETY: the mapping is read-only and private to this process. Another process
            // truncating the file while it is mapped could fault; assets are written by
            // rename, never in place, so a published asset does not change under a reader.
            Storage::Mapped(unsafe { Mmap::map(&file) }.map_err(io)?)
        };
        Self::parse(path.to_path_buf(), storage)
    }

    /// Verifies an asset held in memory; `label` names it in errors.
    pub fn from_bytes(label: &Path, bytes: &[u8]) -> Result<Asset, AssetError> {
        let mut words = vec![0u64; bytes.len().div_ceil(8)];
        bytemuck::cast_slice_mut::<u64, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        Self::parse(
            label.to_path_buf(),
            Storage::Owned {
                words,
                len: bytes.len(),
            },
        )
    }

    fn parse(path: PathBuf, storage: Storage) -> Result<Asset, AssetError> {
        let b = storage.bytes();
        let file_len = b.len() as u64;
        let truncated = |what: String| AssetError::Truncated {
            path: path.clone(),
            what,
        };
        let corrupt = |part: &str, what: String| AssetError::Corrupt {
            path: path.clone(),
            part: part.to_string(),
            what,
        };
        if b.len() < 8 || b[..8] != MAGIC {
            if b.len() < 8 && MAGIC.starts_with(b) && !b.is_empty() {
                return Err(truncated(format!("only {} bytes", b.len())));
            }
            return Err(AssetError::BadMagic { path });
        }
        if b.len() < PREAMBLE_LEN {
            return Err(truncated(format!(
                "only {} bytes, the preamble alone needs {PREAMBLE_LEN}",
                b.len()
            )));
        }
        // Fixed in every version: magic, version, and the CRC-32 of bytes 0..56 at 56.
        let version = u32_at(b, 8);
        let stored = u32_at(b, 56);
        let computed = crc32fast::hash(&b[0..56]);
        if stored != computed {
            return Err(corrupt(
                "preamble",
                format!("checksum mismatch (stored {stored:08x}, computed {computed:08x})"),
            ));
        }
        if version > FORMAT_VERSION {
            return Err(AssetError::FutureVersion {
                path,
                found: version,
                supported: FORMAT_VERSION,
            });
        }
        if version == 0 {
            return Err(corrupt("preamble", "format version 0".to_string()));
        }
        let header_offset = u64_at(b, 16);
        let header_len = u64_at(b, 24);
        let index_offset = u64_at(b, 32);
        let entry_count = u64_at(b, 40);
        let header_crc = u32_at(b, 48);
        let index_crc = u32_at(b, 52);

        let span = |what: &str, off: u64, len: u64| -> Result<(usize, usize), AssetError> {
            let end = off
                .checked_add(len)
                .ok_or_else(|| corrupt("preamble", format!("{what} range overflows")))?;
            if off < PREAMBLE_LEN as u64 {
                return Err(corrupt("preamble", format!("{what} overlaps the preamble")));
            }
            if end > file_len {
                return Err(truncated(format!(
                    "the {what} ends at byte {end} but the file has {file_len} bytes"
                )));
            }
            Ok((off as usize, end as usize))
        };
        let (h0, h1) = span("header", header_offset, header_len)?;
        let index_len = entry_count
            .checked_mul(ENTRY_LEN as u64)
            .ok_or_else(|| corrupt("preamble", "block count overflows".to_string()))?;
        let (i0, i1) = span("block index", index_offset, index_len)?;
        // The writer ends the file with the index: bytes after it are in no checksum.
        if (i1 as u64) < file_len && i1 >= h1 {
            return Err(corrupt(
                "file",
                format!(
                    "trailing data: {} bytes after the block index, which ends at byte {i1}",
                    file_len - i1 as u64
                ),
            ));
        }
        let hc = crc32fast::hash(&b[h0..h1]);
        if hc != header_crc {
            return Err(corrupt(
                "header",
                format!("checksum mismatch (stored {header_crc:08x}, computed {hc:08x})"),
            ));
        }
        // From format 4 on the header's JSON is zstd-coded, from format 5 against the
        // header dictionary.
        let json = if version >= 4 {
            let dictionary = if version >= 5 { HEADER_DICTIONARY } else { &[] };
            std::borrow::Cow::Owned(
                haze_core::coded::inflate_with(&b[h0..h1], MAX_HEADER, dictionary)
                    .map_err(|e| corrupt("header", format!("unreadable: {e}")))?,
            )
        } else {
            std::borrow::Cow::Borrowed(&b[h0..h1])
        };
        let header: Header = serde_json::from_slice(&json)
            .map_err(|e| corrupt("header", format!("unreadable: {e}")))?;
        let ic = crc32fast::hash(&b[i0..i1]);
        if ic != index_crc {
            return Err(corrupt(
                "block index",
                format!("checksum mismatch (stored {index_crc:08x}, computed {ic:08x})"),
            ));
        }
        let entries: Vec<BlockEntry> = b[i0..i1]
            .chunks_exact(ENTRY_LEN)
            .map(BlockEntry::decode)
            .collect();
        for (index, e) in entries.iter().enumerate() {
            let id = BlockId {
                index,
                kind: e.kind,
                scope: e.scope,
            };
            let bad = |what: String| AssetError::Block {
                path: path.clone(),
                block: id,
                what,
            };
            if e.offset % ALIGN != 0 || e.offset < PREAMBLE_LEN as u64 {
                return Err(bad(format!("misplaced at offset {}", e.offset)));
            }
            match e.offset.checked_add(e.len) {
                Some(end) if end <= file_len => {}
                _ => {
                    return Err(bad(format!(
                        "runs past the end of the file ({} + {} > {file_len} bytes)",
                        e.offset, e.len
                    )));
                }
            }
            if !e.scope.fits(header.frame_count) {
                return Err(bad(format!(
                    "covers frames outside the asset's {} frames",
                    header.frame_count
                )));
            }
        }
        Ok(Asset {
            path,
            storage,
            version,
            header,
            entries,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn format_version(&self) -> u32 {
        self.version
    }

    pub fn header(&self) -> &Header {
        &self.header
    }

    pub fn frame_count(&self) -> usize {
        self.header.frame_count as usize
    }

    /// Size of the file in bytes.
    pub fn file_len(&self) -> usize {
        self.storage.bytes().len()
    }

    /// The block index (unverified payloads: use [`Asset::block`] to read one).
    pub fn entries(&self) -> &[BlockEntry] {
        &self.entries
    }

    /// Block `index`, its checksum verified.
    pub fn block(&self, index: usize) -> Result<BlockView<'_>, AssetError> {
        let e = self.entries.get(index).ok_or_else(|| AssetError::Invalid {
            path: self.path.clone(),
            what: format!(
                "block {index} does not exist ({} blocks)",
                self.entries.len()
            ),
        })?;
        let id = BlockId {
            index,
            kind: e.kind,
            scope: e.scope,
        };
        // Bounds were checked against the file length at open.
        let bytes = &self.storage.bytes()[e.offset as usize..(e.offset + e.len) as usize];
        let computed = crc32fast::hash(bytes);
        if computed != e.crc32 {
            return Err(AssetError::Block {
                path: self.path.clone(),
                block: id,
                what: format!(
                    "checksum mismatch (stored {:08x}, computed {computed:08x})",
                    e.crc32
                ),
            });
        }
        Ok(BlockView { id, bytes })
    }

    /// All blocks covering frame `k`, verified.
    pub fn frame(&self, k: usize) -> Result<FrameBlocks<'_>, AssetError> {
        if k >= self.frame_count() {
            return Err(AssetError::NoFrame {
                path: self.path.clone(),
                frame: k,
                count: self.frame_count(),
            });
        }
        let blocks = self
            .entries
            .iter()
            .enumerate()
            .filter(|(_, e)| e.scope.covers(k as u32))
            .map(|(i, _)| self.block(i))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(FrameBlocks { frame: k, blocks })
    }

    /// Asset-wide blocks, verified.
    pub fn asset_blocks(&self) -> Result<Vec<BlockView<'_>>, AssetError> {
        self.entries
            .iter()
            .enumerate()
            .filter(|(_, e)| e.scope == Scope::Asset)
            .map(|(i, _)| self.block(i))
            .collect()
    }

    /// Verifies every block's checksum; the first bad block is the error.
    pub fn verify_all(&self) -> Result<(), AssetError> {
        (0..self.entries.len()).try_for_each(|i| self.block(i).map(|_| ()))
    }

    /// Error for a block whose payload does not decode.
    pub fn block_error(&self, view: &BlockView<'_>, what: impl Into<String>) -> AssetError {
        AssetError::Block {
            path: self.path.clone(),
            block: view.id,
            what: what.into(),
        }
    }
}
