//! `haze pack`: volumes (or another packed asset's frames) → a lossless .haze asset of
//! raw-volume blocks.

use anyhow::{Result, bail};
use haze_asset::{AssetWriter, BlockKind, Scope, encode_raw_volume};
use haze_bake::inspect::{all_zero_clause, all_zero_warning, bytes, count, span};
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
    let mut all_zero = 0;
    for i in 0..seq.len() {
        let v = seq.load(i)?;
        all_zero += usize::from(v.data().iter().all(|&d| d == 0.0));
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
    if all_zero == seq.len() {
        tracing::warn!("{}", all_zero_warning(input, &seq.grid_name(opts)));
    }
    haze_render::say!("{}", summary(out, &seq, all_zero));
    Ok(())
}

/// "OUT: 8 frames (21..28) of 48 × 48 × 64 packed losslessly, 1.2 MiB", and how many
/// frames were all zero when some were.
fn summary(out: &Path, seq: &Frames, all_zero: usize) -> String {
    let [x, y, z] = seq.dims();
    let numbers = span(&[seq.number(0), seq.number(seq.len() - 1)]);
    let size = std::fs::metadata(out).map(|m| m.len()).unwrap_or(0);
    format!(
        "{}: {} ({numbers}) of {x} × {y} × {z} packed losslessly, {}{}",
        out.display(),
        count(seq.len(), "frame"),
        bytes(size),
        all_zero_clause(all_zero)
    )
}
