//! The asset header every command writes for a sequence.

use crate::source::Frames;
use anyhow::Result;
use haze_asset::{GridInfo, Header, SourceInfo};
use haze_volume::ImportOptions;
use std::path::Path;

/// Header of an asset holding every frame of `seq`, read from `input` with `opts`; the
/// caller adds its stage's settings.
pub fn for_sequence(seq: &Frames, input: &Path, opts: &ImportOptions) -> Result<Header> {
    let d = seq.dims();
    Ok(Header {
        generator: format!("haze {}", env!("CARGO_PKG_VERSION")),
        frame_count: u32::try_from(seq.len())?,
        grid: GridInfo {
            dims: [
                u32::try_from(d[0])?,
                u32::try_from(d[1])?,
                u32::try_from(d[2])?,
            ],
            bbox_min: seq.bbox().min,
            bbox_max: seq.bbox().max,
        },
        source: SourceInfo {
            path: input.display().to_string(),
            grid: seq.grid_name(opts),
            frame_numbers: (0..seq.len()).map(|i| seq.number(i)).collect(),
        },
        settings: Default::default(),
        extra: Default::default(),
    })
}
