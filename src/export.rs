//! `haze export`: frames of a baked asset back to dense volumes, `max(D̃ + R̂, 0)` — what
//! every consumer of the asset reconstructs — to check a bake against its input or to
//! take it into another tool; or a packed asset's frames as packed. One frame (`--frame`)
//! goes to `--out` itself; several (every frame, or `--frames`) each to `--out` with
//! `_NNNN`, the frame's number, before the extension (`vol.npy` → `vol_0021.npy`; `vol_.npy`
//! the same, no second `_`): a numbered sequence that `haze bake` and `haze inspect` read
//! back. A `.vdb` output is an OpenVDB file of one float grid, `density`, placed where the
//! asset's box lies (`haze_volume::export::vdb`), for Blender, Houdini or any OpenVDB tool.

use anyhow::{Context, Result, bail};
use haze_asset::Asset;
use haze_bake::export::{Reconstruction, reconstruct_frames};
use haze_bake::inspect::span;
use haze_render::output::{self, Created, Outputs};
use haze_render::progress;
use haze_volume::Volume;
use haze_volume::export::vdb;
use haze_volume::import::FrameRange;
use npyz::WriterBuilder;
use serde_json::json;
use std::path::{Path, PathBuf};

/// The volume types `--out` may name.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Npy,
    /// Raw little-endian f32 with a `.json` sidecar.
    Raw,
    /// OpenVDB: one float grid named `density`.
    Vdb,
}

impl Kind {
    fn of(out: &Path) -> Result<Kind> {
        let ext = out
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "npy" => Ok(Kind::Npy),
            "f32" | "raw" => Ok(Kind::Raw),
            "vdb" => Ok(Kind::Vdb),
            _ => bail!(
                "{}: unknown output type (use .vdb, .npy, or .f32 with a .json sidecar)",
                out.display()
            ),
        }
    }
}

/// Exports frame `frame` of the asset at `path` to `out`, or without it the frames of
/// `range` (module docs).
pub fn run(path: &Path, frame: Option<i64>, range: Option<FrameRange>, out: &Path) -> Result<()> {
    // An output that is an input is named first, whatever its type.
    let kind = Kind::of(out);
    let asset = Asset::open(path)?;
    let numbers = match frame {
        Some(n) => vec![n],
        None => {
            let all = &asset.header().source.frame_numbers;
            let range = range.unwrap_or_default();
            let chosen: Vec<i64> = all.iter().copied().filter(|&n| range.contains(n)).collect();
            if chosen.is_empty() {
                bail!(
                    "{}: no frame in {range} (the asset holds frames {})",
                    path.display(),
                    span(all)
                );
            }
            chosen
        }
    };
    // One file: `out` itself; several: numbered after `out`.
    let targets: Vec<(i64, PathBuf)> = if frame.is_some() || numbers.len() == 1 {
        vec![(numbers[0], out.to_path_buf())]
    } else {
        numbers.iter().map(|&n| (n, numbered(out, n))).collect()
    };
    // The frames the asset was baked from are inputs too: an export named like them (into
    // the cache's own folder, by the cache's own names) would replace them.
    let source = PathBuf::from(&asset.header().source.path);
    let mut files = Outputs::new().input(path).input(&source);
    for (_, file) in &targets {
        files = files.output("--out", file);
        if matches!(kind, Ok(Kind::Raw)) {
            files = files.output("--out's sidecar", &file.with_extension("json"));
        }
    }
    files.check()?;
    let kind = kind?;
    let bar = progress::frames(targets.len(), "exporting");
    let mut created = Created::new();
    // The frames in the asset's order: a hash volume's residual decodes once for all of
    // its frames.
    let mut files = targets.iter().map(|(_, f)| f);
    let order: Vec<i64> = targets.iter().map(|(n, _)| *n).collect();
    reconstruct_frames(path, &order, |n, r| {
        let file = files.next().context("more frames than files")?;
        write(kind, r, file, path, n, &mut created)?;
        tracing::info!("{}: frame {n} written", file.display());
        bar.inc(1);
        Ok(())
    })?;
    bar.finish_and_clear();
    created.keep();
    if targets.len() > 1 {
        haze_render::say!(
            "{} frames ({}) written: {} … {}",
            targets.len(),
            span(&numbers),
            targets[0].1.display(),
            targets[targets.len() - 1].1.display()
        );
    }
    Ok(())
}

/// `out` with `_NNNN` (the frame number, four digits at least) before its extension; a
/// name that already ends in a separator (`vol_.npy`, `vol-.npy`, `vol..npy`) takes the
/// number alone (`vol_0021.npy`).
fn numbered(out: &Path, n: i64) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy())
        .unwrap_or_default();
    let ext = out
        .extension()
        .map(|s| s.to_string_lossy())
        .unwrap_or_default();
    let sep = if stem.ends_with(['_', '-', '.']) {
        ""
    } else {
        "_"
    };
    out.with_file_name(format!("{stem}{sep}{n:04}.{ext}"))
}

/// Writes frame `n`'s reconstruction `r` to `file` (and a raw file's sidecar), each
/// through a temporary file; what was written is added to `created`.
fn write(
    kind: Kind,
    r: Reconstruction,
    file: &Path,
    asset: &Path,
    n: i64,
    created: &mut Created,
) -> Result<()> {
    let Reconstruction { dims, bbox, data } = r;
    match kind {
        Kind::Npy => {
            let mut buf = Vec::new();
            let mut w = npyz::WriteOptions::new()
                .default_dtype()
                .shape(&[dims[2] as u64, dims[1] as u64, dims[0] as u64])
                .writer(&mut buf)
                .begin_nd()
                .context("npy header")?;
            w.extend(data.iter().copied()).context("npy data")?;
            w.finish().context("npy data")?;
            output::write_atomic(file, &buf)?;
            created.push(file.to_path_buf());
        }
        Kind::Raw => {
            let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
            let size = bbox.size();
            let voxel: [f64; 3] = [0, 1, 2].map(|a| size[a] / dims[a] as f64);
            let sidecar = json!({
                "dims": dims,
                "world_bbox_min": bbox.min,
                "world_bbox_max": bbox.max,
                "voxel_size": voxel,
                "dtype": "float32 little-endian",
                "source": asset.display().to_string(),
                "frame": n,
            });
            output::write_atomic(file, &bytes)?;
            created.push(file.to_path_buf());
            let side = file.with_extension("json");
            output::write_json(&side, &sidecar)?;
            created.push(side);
        }
        Kind::Vdb => {
            let volume = Volume::new(dims, bbox, data)
                .with_context(|| format!("frame {n} of {}", asset.display()))?;
            let bytes =
                vdb::to_bytes(&volume).with_context(|| format!("{}: frame {n}", file.display()))?;
            output::write_atomic(file, &bytes)?;
            created.push(file.to_path_buf());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_outputs_carry_the_frame_number() {
        assert_eq!(
            numbered(Path::new("d/vol.npy"), 21),
            Path::new("d/vol_0021.npy")
        );
        assert_eq!(
            numbered(Path::new("vol.f32"), 12345),
            Path::new("vol_12345.f32")
        );
        assert_eq!(
            numbered(Path::new("d/vol_.npy"), 21),
            Path::new("d/vol_0021.npy")
        );
        assert_eq!(
            numbered(Path::new("vol-.vdb"), 3),
            Path::new("vol-0003.vdb")
        );
        assert_eq!(Kind::of(Path::new("x.VDB")).unwrap(), Kind::Vdb);
        assert!(Kind::of(Path::new("x.exr")).is_err());
    }
}
