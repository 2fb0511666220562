//! `haze export`: one frame of a baked asset back to a dense volume, `D̃ + R̂` — what every
//! consumer of the asset reconstructs — to check a bake against its input.

use crate::output;
use crate::residual::reconstruct;
use anyhow::{Context, Result, anyhow, bail};
use haze_asset::{Asset, BlockKind, Scope, decode_rbfs};
use haze_volume::Bbox;
use npyz::WriterBuilder;
use serde_json::json;
use std::path::Path;

pub fn run(path: &Path, frame: i64, out: &Path) -> Result<()> {
    let asset = Asset::open(path)?;
    let h = asset.header();
    let numbers = &h.source.frame_numbers;
    let k = numbers.iter().position(|&n| n == frame).ok_or_else(|| {
        let range = match (numbers.first(), numbers.last()) {
            (Some(a), Some(b)) => format!("frames {a}..{b}"),
            _ => "no frames".to_string(),
        };
        anyhow!(
            "{}: frame {frame} is not in the asset ({range})",
            path.display()
        )
    })?;
    let blocks = asset.frame(k)?;
    let rbf_block = blocks.find(BlockKind::Rbfs).ok_or_else(|| {
        anyhow!(
            "{}: frame {frame} has no RBF block (not a baked asset?)",
            path.display()
        )
    })?;
    let rbfs = decode_rbfs(rbf_block.bytes).map_err(|e| asset.block_error(&rbf_block, e))?;
    // No residual block: the RBFs alone met the error on every frame of its hash volume.
    let residual = match blocks.find(BlockKind::ResidualHash) {
        Some(res_block) => {
            let group = haze_hash::block::decode(res_block.bytes)
                .map_err(|e| asset.block_error(&res_block, e))?;
            let Scope::Frames { first, .. } = res_block.id.scope else {
                bail!(
                    "{}: the residual block of frame {frame} is not per frame",
                    path.display()
                );
            };
            if group.dims != h.grid.dims {
                bail!(
                    "{}: residual block dims {:?} differ from the grid's",
                    path.display(),
                    group.dims
                );
            }
            Some((group, k - first as usize))
        }
        None => None,
    };
    let dims = h.grid.dims.map(|d| d as usize);
    let bbox = Bbox::new(h.grid.bbox_min, h.grid.bbox_max);
    let data = reconstruct(dims, &bbox, &rbfs, residual.as_ref().map(|(g, j)| (g, *j)));
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
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
