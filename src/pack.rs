//! `haze pack`: volumes (or another packed asset's frames) → a lossless .haze asset of
//! raw-volume blocks.

use anyhow::{Result, bail};
use haze_asset::{AssetWriter, BlockKind, Scope, encode_raw_volume};
use haze_bake::source::Frames;
use haze_render::output::Outputs;
use haze_render::progress;
use haze_volume::ImportOptions;
use haze_volume::import::FrameRange;
use std::path::Path;

pub fn run(input: &Path, out: &Path, range: FrameRange, opts: &ImportOptions) -> Result<()> {
    Outputs::new().input(input).asset("--out", out).check()?;
    let seq = Frames::open(input, opts, range)?;
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
    let header = haze_bake::header::for_sequence(&seq, input, opts)?;
    w.finish(&header)?;
    tracing::info!(
        "{}: {} packed",
        out.display(),
        haze_bake::inspect::count(seq.len(), "frame")
    );
    Ok(())
}
