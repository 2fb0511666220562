//! The asset header every command writes for a sequence.

use anyhow::Result;
use haze_asset::{GridInfo, Header, SourceInfo};
use haze_volume::ImportOptions;
use haze_volume::import::{Format, Sequence};
use std::path::Path;

/// Header of an asset holding every frame of `seq`, read from `input` with `opts`; the
/// caller adds its stage's settings.
pub fn for_sequence(seq: &Sequence, input: &Path, opts: &ImportOptions) -> Result<Header> {
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
            grid: if seq.format() == Format::Vdb {
                opts.grid.clone()
            } else {
                String::new()
            },
            frame_numbers: seq.frames().iter().map(|f| f.number).collect(),
        },
        settings: Default::default(),
        extra: Default::default(),
    })
}
