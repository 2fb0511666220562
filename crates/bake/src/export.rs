//! One frame of a baked asset reconstructed as a dense volume, `D̃ + R̂`: what every
//! consumer of the asset computes (`haze export`, and tests of a bake against its input).

use crate::residual::reconstruct;
use anyhow::{Result, anyhow, bail};
use haze_asset::{Asset, BlockKind, Scope, decode_rbfs};
use haze_volume::Bbox;
use std::path::Path;

/// A reconstructed frame: x fastest, then y, then z, over the asset's grid.
#[derive(Clone, Debug)]
pub struct Reconstruction {
    pub dims: [usize; 3],
    pub bbox: Bbox,
    pub data: Vec<f32>,
}

/// Frame `frame` (its number in the input) of the asset at `path`: its RBFs evaluated as
/// stored, plus the dequantized residual of its hash volume (none when the RBFs alone met
/// the error on every frame of that volume).
pub fn reconstruct_frame(path: &Path, frame: i64) -> Result<Reconstruction> {
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
    Ok(Reconstruction { dims, bbox, data })
}
