//! Streaming, atomic writing of `.haze` files.

use crate::error::AssetError;
use crate::format::{
    ALIGN, BlockEntry, BlockKind, FORMAT_VERSION, Header, MAGIC, PREAMBLE_LEN, Scope,
};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use tempfile::NamedTempFile;

/// Writes blocks as they are produced into a temporary file beside the destination; the
/// destination appears, complete, only when [`AssetWriter::finish`] succeeds. Dropping the
/// writer (an error, a crash, Ctrl-C) leaves no partial file under the destination name.
#[derive(Debug)]
pub struct AssetWriter {
    path: PathBuf,
    out: BufWriter<NamedTempFile>,
    pos: u64,
    entries: Vec<BlockEntry>,
}

impl AssetWriter {
    /// Starts writing `path`.
    pub fn create(path: &Path) -> Result<Self, AssetError> {
        let io = |source| AssetError::Io {
            path: path.to_path_buf(),
            err: source,
        };
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "asset".to_string());
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(io)?;
        let mut out = BufWriter::with_capacity(1 << 20, tmp);
        out.write_all(&[0u8; PREAMBLE_LEN]).map_err(io)?;
        Ok(Self {
            path: path.to_path_buf(),
            out,
            pos: PREAMBLE_LEN as u64,
            entries: Vec::new(),
        })
    }

    fn io(&self, source: std::io::Error) -> AssetError {
        AssetError::Io {
            path: self.path.clone(),
            err: source,
        }
    }

    fn pad_to_alignment(&mut self) -> Result<(), AssetError> {
        let pad = (ALIGN - self.pos % ALIGN) % ALIGN;
        if pad > 0 {
            self.out
                .write_all(&[0u8; ALIGN as usize][..pad as usize])
                .map_err(|e| self.io(e))?;
            self.pos += pad;
        }
        Ok(())
    }

    /// Appends one block, aligned to [`ALIGN`], and records it in the index.
    pub fn write_block(
        &mut self,
        kind: BlockKind,
        scope: Scope,
        payload: &[u8],
    ) -> Result<(), AssetError> {
        self.pad_to_alignment()?;
        let entry = BlockEntry {
            kind,
            scope,
            offset: self.pos,
            len: payload.len() as u64,
            crc32: crc32fast::hash(payload),
        };
        self.out.write_all(payload).map_err(|e| self.io(e))?;
        self.pos += payload.len() as u64;
        self.entries.push(entry);
        Ok(())
    }

    /// Blocks written so far.
    pub fn entries(&self) -> &[BlockEntry] {
        &self.entries
    }

    /// Writes header, index and preamble, syncs, and moves the file into place.
    pub fn finish(mut self, header: &Header) -> Result<(), AssetError> {
        for (i, e) in self.entries.iter().enumerate() {
            if !e.scope.fits(header.frame_count) {
                return Err(AssetError::Invalid {
                    path: self.path.clone(),
                    what: format!(
                        "block {i} covers {} but the header has {} frames",
                        e.scope, header.frame_count
                    ),
                });
            }
        }
        let header_json = serde_json::to_vec(header).map_err(|e| AssetError::Invalid {
            path: self.path.clone(),
            what: format!("header not serializable: {e}"),
        })?;
        let header_coded = haze_core::coded::deflate_with(
            &header_json,
            crate::header_dictionary::HEADER_DICTIONARY,
        );
        self.pad_to_alignment()?;
        let header_offset = self.pos;
        self.out.write_all(&header_coded).map_err(|e| self.io(e))?;
        self.pos += header_coded.len() as u64;
        self.pad_to_alignment()?;
        let index_offset = self.pos;
        let mut index = Vec::with_capacity(self.entries.len() * crate::format::ENTRY_LEN);
        for e in &self.entries {
            index.extend_from_slice(&e.encode());
        }
        self.out.write_all(&index).map_err(|e| self.io(e))?;

        let mut pre = [0u8; PREAMBLE_LEN];
        pre[0..8].copy_from_slice(&MAGIC);
        pre[8..12].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        // 12..16: flags, none defined.
        pre[16..24].copy_from_slice(&header_offset.to_le_bytes());
        pre[24..32].copy_from_slice(&(header_coded.len() as u64).to_le_bytes());
        pre[32..40].copy_from_slice(&index_offset.to_le_bytes());
        pre[40..48].copy_from_slice(&(self.entries.len() as u64).to_le_bytes());
        pre[48..52].copy_from_slice(&crc32fast::hash(&header_coded).to_le_bytes());
        pre[52..56].copy_from_slice(&crc32fast::hash(&index).to_le_bytes());
        let pre_crc = crc32fast::hash(&pre[0..56]);
        pre[56..60].copy_from_slice(&pre_crc.to_le_bytes());

        let path = self.path.clone();
        let io = |source| AssetError::Io {
            path: path.clone(),
            err: source,
        };
        let mut tmp = self.out.into_inner().map_err(|e| io(e.into_error()))?;
        tmp.seek(SeekFrom::Start(0)).map_err(io)?;
        tmp.write_all(&pre).map_err(io)?;
        tmp.as_file().sync_all().map_err(io)?;
        // Temporary files are created private (0600); a published asset is a normal file.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            tmp.as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644))
                .map_err(io)?;
        }
        tmp.persist(&path).map_err(|e| io(e.error))?;
        Ok(())
    }
}
