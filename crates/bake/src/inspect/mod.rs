//! What is in a volume file, a sequence of them or a `.haze` asset (`haze inspect`): a
//! [`Report`] built by [`inspect`], printed as text ([`Report::text`]) or JSON (it is
//! `Serialize`).
//!
//! * [`volume`]: a volume file's grid and values; a sequence's frames, gaps and ranges.
//! * [`asset`]: an asset's header and blocks, every block decoded (checksums verified).
//! * [`text`]: the reports as aligned `key: value` lines; byte counts and plurals.

pub mod asset;
pub mod text;
pub mod volume;

pub use asset::AssetReport;
pub use text::{all_zero_clause, all_zero_warning, bytes, count, span};
pub use volume::{FileReport, GridReport, SequenceReport};

use haze_volume::ImportOptions;
use haze_volume::import::{Format, FrameRange};
use serde::Serialize;
use std::path::Path;

/// One report, by what the path is.
#[derive(Debug, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Report {
    File(FileReport),
    Sequence(SequenceReport),
    Asset(AssetReport),
}

/// Progress of a report over frames or blocks: what it is doing (`"reading"`,
/// `"verifying"`), how many are done, and how many there are.
pub type Progress<'a> = &'a mut dyn FnMut(&str, usize, usize);

/// The report of `path`: an asset when it ends in `.haze`, a volume file when it is a
/// file, else a sequence (a folder or a pattern) of which `range` is read. Every frame
/// of a sequence is read and every block of an asset decoded; `progress` hears of each.
pub fn inspect(
    path: &Path,
    range: FrameRange,
    opts: &ImportOptions,
    progress: Progress<'_>,
) -> anyhow::Result<Report> {
    Ok(if is_asset(path) {
        use haze_volume::import::{VdbOptionsOf, vdb_options_refused};
        vdb_options_refused(path, VdbOptionsOf::Asset, opts)?;
        Report::Asset(asset::report(path, progress)?)
    } else if path.is_file() {
        if Format::of(path).is_none() {
            // A volume format haze does not read: the importer's error says how to convert.
            if haze_volume::import::foreign_format(path).is_some() {
                haze_volume::import::format_of(path)?;
            }
            anyhow::bail!(
                "{}: unknown file type: haze inspect reads volumes (.vdb, .f32/.raw with a \
                 .json sidecar, .npy), a directory or glob of them, .haze assets and \
                 environment maps (.exr, .hdr)",
                path.display()
            );
        }
        Report::File(volume::file_report(path, opts)?)
    } else {
        Report::Sequence(volume::sequence_report(path, range, opts, progress)?)
    })
}

fn is_asset(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"))
}
