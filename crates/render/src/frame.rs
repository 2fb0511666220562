//! The frame a render, a sweep or the viewer starts from: a baked asset's frame (read by
//! `haze_bake::export`), or a volume file, a sequence's frame or a packed asset's frame,
//! fitted here.

use crate::progress;
use anyhow::{Result, anyhow};
use haze_bake::export::{read_frame, read_raw_frame};
use haze_bake::residual::as_stored;
use haze_fit::{FitOptions, SequenceFitter, SequenceOptions};
use haze_view::stream::ResidualSlot;
use haze_volume::import::{self, ImportOptions};
use haze_volume::{Bbox, Rbf, Volume, rbf};
use std::path::{Path, PathBuf};

/// A frame to render: its density, and its RBFs and residual when it has been fitted.
#[derive(Debug)]
pub struct FrameData {
    pub density: Volume,
    pub rbfs: Vec<Rbf>,
    /// `R` at every voxel (zero for an asset baked without a residual).
    pub residual: Vec<f32>,
    /// An asset frame's slot in its hash volume, which the GPU looks up itself.
    pub slot: Option<ResidualSlot>,
    pub label: String,
}

/// Whether `input` is a baked asset (`.haze`).
pub fn is_asset(input: &Path) -> bool {
    input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"))
}

/// The fit of a volume input: its RBF count and whether it teleports.
#[derive(Clone, Copy, Debug)]
pub struct FitKnobs {
    pub rbfs: usize,
    pub teleport: bool,
}

/// The frame's data: from an asset (RBFs + dequantized residual) or from a volume file
/// (fitted here with `fit`; the residual is then exact; not fitted without it).
pub fn load(
    input: &Path,
    frame: Option<i64>,
    opts: &ImportOptions,
    fit: Option<FitKnobs>,
) -> Result<FrameData> {
    // A packed asset's frame (`haze pack`'s raw volume) is taken as a volume file is.
    let (density, label) = if is_asset(input) {
        use haze_volume::import::{VdbOptionsOf, vdb_options_refused};
        vdb_options_refused(input, VdbOptionsOf::Asset, opts)?;
        match read_raw_frame(input, frame)? {
            Some((n, v)) => (v, format!("{} frame {n}", input.display())),
            None => return load_asset(input, frame).map(|f| warn_if_empty(f, None)),
        }
    } else {
        let path = volume_path(input, frame, opts)?;
        (import::import(&path, opts)?, path.display().to_string())
    };
    let mut rbfs = Vec::new();
    let mut residual = vec![0.0f32; density.len()];
    if let Some(knobs) = fit {
        let spinner = progress::spinner(&format!("fitting {label} with {} RBFs", knobs.rbfs));
        let opts = SequenceOptions {
            rbfs: knobs.rbfs,
            fit: FitOptions {
                teleport: knobs.teleport,
                ..FitOptions::default()
            },
            ..SequenceOptions::default()
        };
        let fit = SequenceFitter::new(opts)
            .fit(&density)
            .map_err(|e| anyhow!("{label}: {e}"))?;
        spinner.finish_and_clear();
        rbfs = as_stored(&fit.rbfs)?;
        let approx = rbf::evaluate_on_grid(density.dims(), density.bbox(), &rbfs);
        for ((r, d), x) in residual.iter_mut().zip(density.data()).zip(&approx) {
            *r = (f64::from(*d) - x) as f32;
        }
    }
    let grid = (import::format_of(input).ok() == Some(import::Format::Vdb)).then_some(&opts.grid);
    Ok(warn_if_empty(
        FrameData {
            density,
            rbfs,
            residual,
            slot: None,
            label,
        },
        grid.map(String::as_str),
    ))
}

/// `f`, after a warning when its density is zero everywhere (the picture then shows no
/// smoke; from an OpenVDB file, often the wrong `grid`).
fn warn_if_empty(f: FrameData, grid: Option<&str>) -> FrameData {
    if f.density.data().iter().all(|&d| d <= 0.0) {
        let which = grid
            .map(|g| format!(" (OpenVDB grid '{g}'; --grid picks another)"))
            .unwrap_or_default();
        tracing::warn!(
            "{}: the density is zero everywhere{which}: the picture shows no smoke",
            f.label
        );
    }
    f
}

/// The file of frame `frame` of `input` (a volume file, or a directory or glob of
/// numbered frames: its first frame by default).
fn volume_path(input: &Path, frame: Option<i64>, opts: &ImportOptions) -> Result<PathBuf> {
    if frame.is_some() && input.is_file() {
        tracing::warn!("--frame is ignored for a single volume file");
    }
    if input.is_file() {
        return Ok(input.to_path_buf());
    }
    let seq = haze_volume::Sequence::open(input, opts, Default::default())?;
    let i = match frame {
        Some(k) => seq
            .frames()
            .iter()
            .position(|f| f.number == k)
            .ok_or_else(|| anyhow!("{}: no frame {k}", input.display()))?,
        None => 0,
    };
    Ok(seq.frames()[i].path.clone())
}

/// The density of one frame: a volume file's, a sequence's frame, a packed asset's raw
/// volume or a baked asset's reconstruction `max(D̃ + R̂, 0)` (`haze tradeoff`'s input).
pub fn load_density(input: &Path, frame: Option<i64>, opts: &ImportOptions) -> Result<Volume> {
    if is_asset(input) {
        use haze_volume::import::{VdbOptionsOf, vdb_options_refused};
        vdb_options_refused(input, VdbOptionsOf::Asset, opts)?;
        if let Some((_, v)) = read_raw_frame(input, frame)? {
            return Ok(v);
        }
        return Ok(load_asset(input, frame)?.density);
    }
    Ok(import::import(&volume_path(input, frame, opts)?, opts)?)
}

/// Frame `frame` of the asset at `path` (its first when `None`).
pub fn load_asset(path: &Path, frame: Option<i64>) -> Result<FrameData> {
    let f = read_frame(path, frame)?;
    let (density, residual) = f.density()?;
    Ok(FrameData {
        density,
        residual,
        slot: f.residual.map(|(group, slot)| ResidualSlot { group, slot }),
        label: format!("{} frame {}", path.display(), f.number),
        rbfs: f.rbfs,
    })
}

/// The box a default camera frames: the voxels above 1 % of the peak density (the smoke,
/// not the whole domain), or the whole box when the volume is empty.
pub fn smoke_bbox(density: &Volume) -> Bbox {
    let peak = density.data().iter().fold(0.0f32, |m, &d| m.max(d));
    density
        .occupied_bbox(0.01 * peak)
        .unwrap_or(*density.bbox())
}
