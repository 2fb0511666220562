//! `haze inspect`: what is in a volume file, a sequence or an asset
//! (`haze_bake::inspect`), or an environment map (`haze_render::map_report`), as text or
//! JSON.

use anyhow::{Result, bail};
use haze_render::progress;
use haze_volume::ImportOptions;
use haze_volume::import::{Format, FrameRange};
use indicatif::ProgressBar;
use std::path::Path;

pub fn run(path: &Path, json: bool, range: FrameRange, opts: &ImportOptions) -> Result<()> {
    if haze_render::map_report::is_map(path) {
        let report = haze_render::map_report::inspect_map(path)?;
        if json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            print!("{}", report.text());
        }
        return Ok(());
    }
    let asset = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"));
    if path.is_file() && !asset && Format::of(path).is_none() {
        bail!(
            "{}: unknown file type: haze inspect reads volumes (.vdb, .f32/.raw with a .json \
             sidecar, .npy), a directory or glob of them, .haze assets and environment maps \
             (.exr, .hdr)",
            path.display()
        );
    }
    let mut bar: Option<ProgressBar> = None;
    let report = haze_bake::inspect::inspect(path, range, opts, &mut |what, done, total| {
        let b = bar.get_or_insert_with(|| progress::frames(total, what));
        b.set_position(done as u64);
    })?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{}", report.text());
    }
    Ok(())
}
