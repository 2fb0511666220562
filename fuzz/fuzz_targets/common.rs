//! What both asset-reader targets do with an input: open it, verify every block, and
//! decode the blocks of every frame (raw volumes, RBFs, residual hash volumes, whole and
//! frame after frame). Never a
//! panic, never an out-of-bounds read.

use haze_asset::{Asset, BlockKind, decode_raw_volume, decode_rbfs};
use std::path::Path;

pub fn exercise(data: &[u8]) {
    let Ok(asset) = Asset::from_bytes(Path::new("fuzz.haze"), data) else {
        return;
    };
    let _ = asset.verify_all();
    for k in 0..asset.frame_count().min(64) + 1 {
        if let Ok(frame) = asset.frame(k) {
            if let Some(raw) = frame.find(BlockKind::RawVolume) {
                let _ = decode_raw_volume(raw.bytes);
            }
            if let Some(rbfs) = frame.find(BlockKind::Rbfs) {
                let _ = decode_rbfs(rbfs.bytes);
            }
            if let Some(residual) = frame.find(BlockKind::ResidualHash) {
                let _ = haze_hash::block::decode(residual.bytes);
                // Playback's way: frame after frame, each stream on a thread.
                let _ = haze_hash::block::decode_frames(residual.bytes, 1, |_, _| true);
            }
        }
    }
    let _ = asset.asset_blocks();
}
