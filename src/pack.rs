//! `haze pack`: volumes → a lossless .haze asset of raw-volume blocks.

use crate::progress;
use anyhow::{Result, bail};
use haze_asset::{AssetWriter, BlockKind, GridInfo, Header, Scope, SourceInfo, encode_raw_volume};
use haze_volume::ImportOptions;
use haze_volume::import::{FrameRange, Sequence};
use std::path::Path;

pub fn run(input: &Path, out: &Path, range: FrameRange, opts: &ImportOptions) -> Result<()> {
    let seq = Sequence::open(input, opts, range)?;
    if seq.dims().contains(&0) {
        bail!("{}: every frame is empty; nothing to pack", input.display());
    }
    if !seq.gaps().is_empty() {
        tracing::warn!(
            "{}: the sequence has gaps {:?}; frames are packed in order",
            input.display(),
            seq.gaps()
        );
    }
    let mut w = AssetWriter::create(out)?;
    let bar = progress::frames(seq.len(), "packing");
    for i in 0..seq.len() {
        let v = seq.load(i)?;
        w.write_block(
            BlockKind::RawVolume,
            Scope::frame(i as u32),
            &encode_raw_volume(&v),
        )?;
        bar.inc(1);
    }
    bar.finish_and_clear();
    let d = seq.dims();
    let header = Header {
        generator: format!("haze {}", env!("CARGO_PKG_VERSION")),
        frame_count: u32::try_from(seq.len())?,
        grid: GridInfo {
            dims: [d[0] as u32, d[1] as u32, d[2] as u32],
            bbox_min: seq.bbox().min,
            bbox_max: seq.bbox().max,
        },
        source: SourceInfo {
            path: input.display().to_string(),
            grid: if seq.format() == haze_volume::import::Format::Vdb {
                opts.grid.clone()
            } else {
                String::new()
            },
            frame_numbers: seq.frames().iter().map(|f| f.number).collect(),
        },
        settings: Default::default(),
        extra: Default::default(),
    };
    w.finish(&header)?;
    tracing::info!("{}: {} frames packed", out.display(), seq.len());
    Ok(())
}
