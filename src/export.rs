//! `haze export`: one frame of a baked asset back to a dense volume, `max(D̃ + R̂, 0)` —
//! what every consumer of the asset reconstructs — to check a bake against its input; or a
//! packed asset's frame as packed.

use anyhow::{Context, Result, bail};
use haze_bake::export::reconstruct_frame;
use haze_render::output::{self, Outputs};
use npyz::WriterBuilder;
use serde_json::json;
use std::path::Path;

pub fn run(path: &Path, frame: i64, out: &Path) -> Result<()> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let mut files = Outputs::new().input(path).output("--out", out);
    if matches!(ext.as_str(), "f32" | "raw") {
        files = files.output("--out's sidecar", &out.with_extension("json"));
    }
    files.check()?;
    let r = reconstruct_frame(path, frame)?;
    let (dims, bbox, data) = (r.dims, r.bbox, r.data);
    match ext.as_str() {
        "npy" => {
            let mut buf = Vec::new();
            let mut w = npyz::WriteOptions::new()
                .default_dtype()
                .shape(&[dims[2] as u64, dims[1] as u64, dims[0] as u64])
                .writer(&mut buf)
                .begin_nd()
                .context("npy header")?;
            w.extend(data.iter().copied()).context("npy data")?;
            w.finish().context("npy data")?;
            output::write_atomic(out, &buf)?;
        }
        "f32" | "raw" => {
            let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
            let size = bbox.size();
            let voxel: [f64; 3] = [0, 1, 2].map(|a| size[a] / dims[a] as f64);
            let sidecar = json!({
                "dims": dims,
                "world_bbox_min": bbox.min,
                "world_bbox_max": bbox.max,
                "voxel_size": voxel,
                "dtype": "float32 little-endian",
                "source": path.display().to_string(),
                "frame": frame,
            });
            output::write_atomic(out, &bytes)?;
            output::write_json(&out.with_extension("json"), &sidecar)?;
        }
        _ => bail!(
            "{}: unknown output type (use .npy, or .f32 with a .json sidecar)",
            out.display()
        ),
    }
    tracing::info!("{}: frame {frame} written", out.display());
    Ok(())
}
