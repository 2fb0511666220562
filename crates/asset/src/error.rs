//! Errors of the asset container: each names the file and, for block problems, the block.

use crate::format::{BlockKind, Scope};
use std::fmt;
use std::path::PathBuf;

/// A block by position in the index, with its kind and frames, for error messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlockId {
    pub index: usize,
    pub kind: BlockKind,
    pub scope: Scope,
}

impl fmt::Display for BlockId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "block {} ({}, {})",
            self.index,
            self.kind.name(),
            self.scope
        )
    }
}

/// What went wrong with an asset file.
#[derive(Debug, thiserror::Error)]
pub enum AssetError {
    #[error("{path}: {}", io_words(.err))]
    Io { path: PathBuf, err: std::io::Error },
    #[error("{path}: not a haze asset (bad magic number)")]
    BadMagic { path: PathBuf },
    #[error(
        "{path}: format version {found} is newer than this haze reads (up to {supported}); upgrade haze"
    )]
    FutureVersion {
        path: PathBuf,
        found: u32,
        supported: u32,
    },
    #[error("{path}: file is truncated: {what}")]
    Truncated { path: PathBuf, what: String },
    #[error("{path}: {part} is corrupt: {what}")]
    Corrupt {
        path: PathBuf,
        part: String,
        what: String,
    },
    #[error("{path}: {block}: {what}")]
    Block {
        path: PathBuf,
        block: BlockId,
        what: String,
    },
    #[error("{path}: frame {frame} does not exist (the asset has {count} frames)")]
    NoFrame {
        path: PathBuf,
        frame: usize,
        count: usize,
    },
    #[error("{path}: {what}")]
    Invalid { path: PathBuf, what: String },
}

/// An I/O error in words: a missing file as every reader of haze says it ("no such file or
/// directory", not the system's "No such file or directory (os error 2)"), else the
/// system's message.
fn io_words(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "no such file or directory".to_string(),
        _ => e.to_string(),
    }
}
