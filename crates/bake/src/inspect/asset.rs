//! An asset's report: its header, its blocks by kind, and what each frame holds; every
//! block is decoded, so a report is also a check of the checksums.

use super::Progress;
use anyhow::Result;
use haze_asset::{Asset, BlockKind};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// The blocks of one kind.
#[derive(Debug, Serialize)]
pub struct KindSummary {
    pub blocks: usize,
    /// Bytes in the file.
    pub bytes: u64,
    /// Bytes once decoded, as the GPU holds them: a raw volume as stored, RBFs as two
    /// `vec4<f32>` records each, a residual as its hash's offset, key and payload tables
    /// and packed values.
    pub decoded_bytes: u64,
}

/// Bytes of one RBF on the GPU: two `vec4<f32>` records (center and radius; weight).
const GPU_RBF_BYTES: u64 = 32;

#[derive(Debug, Serialize)]
pub struct AssetReport {
    pub path: String,
    pub format_version: u32,
    pub file_bytes: usize,
    pub header: haze_asset::Header,
    pub blocks: usize,
    pub blocks_by_kind: BTreeMap<String, KindSummary>,
    pub checksums_verified: bool,
    pub frames: Vec<AssetFrame>,
}

/// What an asset holds for one frame.
#[derive(Debug, Serialize)]
pub struct AssetFrame {
    pub frame: i64,
    pub rbfs: Option<usize>,
    pub rel_l2: Option<f64>,
    pub rms_over_max: Option<f64>,
    /// The frame's share of its residual hash volume, in bytes (0: none stored).
    pub hash_bytes: Option<f64>,
}

pub(super) fn report(path: &Path, progress: Progress<'_>) -> Result<AssetReport> {
    let asset = Asset::open(path)?;
    let blocks = asset.entries().len();
    let mut rbfs_per_frame = vec![None; asset.frame_count()];
    let mut decoded = vec![0u64; blocks];
    for (i, size) in decoded.iter_mut().enumerate() {
        progress("verifying", i, blocks);
        let view = asset.block(i)?;
        *size = match view.kind() {
            BlockKind::RawVolume => {
                haze_asset::decode_raw_volume(view.bytes)
                    .map_err(|e| asset.block_error(&view, e))?;
                view.bytes.len() as u64
            }
            BlockKind::Rbfs => {
                let rbfs =
                    haze_asset::decode_rbfs(view.bytes).map_err(|e| asset.block_error(&view, e))?;
                if let haze_asset::Scope::Frames { first, .. } = view.id.scope {
                    rbfs_per_frame[first as usize] = Some(rbfs.len());
                }
                GPU_RBF_BYTES * rbfs.len() as u64
            }
            BlockKind::ResidualHash => {
                let g = haze_hash::block::decode(view.bytes)
                    .map_err(|e| asset.block_error(&view, e))?;
                g.bytes() as u64
            }
            BlockKind::Unknown(_) => view.bytes.len() as u64,
        };
    }
    progress("verifying", blocks, blocks);
    let fits = asset
        .header()
        .settings
        .get("fit")
        .and_then(|f| f.get("frames"));
    let frames = (0..asset.frame_count())
        .map(|k| AssetFrame {
            frame: asset
                .header()
                .source
                .frame_numbers
                .get(k)
                .copied()
                .unwrap_or(k as i64),
            rbfs: rbfs_per_frame[k],
            rel_l2: fits
                .and_then(|f| f.get(k))
                .and_then(|f| f["rel_l2"].as_f64()),
            rms_over_max: fits
                .and_then(|f| f.get(k))
                .and_then(|f| f["rms_over_max"].as_f64()),
            hash_bytes: fits
                .and_then(|f| f.get(k))
                .and_then(|f| f["hash_bytes"].as_f64()),
        })
        .collect();
    let mut by_kind: BTreeMap<String, KindSummary> = BTreeMap::new();
    for (e, size) in asset.entries().iter().zip(decoded) {
        let k = by_kind.entry(e.kind.name()).or_insert(KindSummary {
            blocks: 0,
            bytes: 0,
            decoded_bytes: 0,
        });
        k.blocks += 1;
        k.bytes += e.len;
        k.decoded_bytes += size;
    }
    Ok(AssetReport {
        path: path.display().to_string(),
        format_version: asset.format_version(),
        file_bytes: asset.file_len(),
        header: asset.header().clone(),
        blocks: asset.entries().len(),
        blocks_by_kind: by_kind,
        checksums_verified: true,
        frames,
    })
}
