//! `haze inspect`: what is in a volume file, a sequence or an asset
//! (`haze_bake::inspect`), or an environment map (`haze_render::map_report`, placed as
//! `haze render --env` places it), as text or JSON.

use anyhow::Result;
use haze_render::lights::MapPlacement;
use haze_render::progress;
use haze_volume::ImportOptions;
use haze_volume::import::FrameRange;
use indicatif::ProgressBar;
use std::path::Path;

pub fn run(
    path: &Path,
    json: bool,
    range: FrameRange,
    opts: &ImportOptions,
    placement: MapPlacement,
) -> Result<()> {
    if haze_render::map_report::is_map(path) {
        let report = haze_render::map_report::inspect_map(path, placement)?;
        if json {
            println!("{}", serde_json::to_string_pretty(&report)?);
        } else {
            print!("{}", report.text());
        }
        return Ok(());
    }
    placement.only_for_maps(path)?;
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
