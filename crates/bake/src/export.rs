//! One frame of a baked asset read back: its RBFs as stored and its residual's slot in the
//! hash volume, reconstructed as a dense volume `max(D̃ + R̂, 0)` — what every consumer of the
//! asset computes (`haze export`, `haze render`, the viewer, `haze tradeoff`, and tests of
//! a bake against its input).

use crate::residual::reconstruct;
use anyhow::{Context, Result, anyhow, bail};
use haze_asset::{Asset, BlockKind, BlockView, Scope, decode_raw_volume, decode_rbfs};
use haze_hash::tile::ResidualGroup;
use haze_volume::{Bbox, Rbf, Volume, rbf};
use std::path::Path;
use std::sync::Arc;

/// A reconstructed frame: x fastest, then y, then z, over the asset's grid.
#[derive(Clone, Debug)]
pub struct Reconstruction {
    pub dims: [usize; 3],
    pub bbox: Bbox,
    pub data: Vec<f32>,
}

/// One frame of an asset as stored: its RBFs and the hash volume holding its residual.
#[derive(Clone, Debug)]
pub struct AssetFrame {
    /// The source frame number.
    pub number: i64,
    /// The asset's grid.
    pub dims: [usize; 3],
    pub bbox: Bbox,
    pub rbfs: Vec<Rbf>,
    /// The frame's hash volume and its slot in it (none when the RBFs alone met the error
    /// on every frame of that volume).
    pub residual: Option<(Arc<ResidualGroup>, usize)>,
}

impl AssetFrame {
    /// `max(D̃ + R̂, 0)` at every voxel, the density every consumer renders (`haze
    /// export`'s volume; a lossless bake's rounding, −10⁻¹¹ where the input is 0, would
    /// otherwise make `haze bake` refuse the export as input).
    pub fn reconstruction(&self) -> Reconstruction {
        let residual = self.residual.as_ref().map(|(g, j)| (&**g, *j));
        let mut data = reconstruct(self.dims, &self.bbox, &self.rbfs, residual);
        for x in &mut data {
            *x = x.max(0.0);
        }
        Reconstruction {
            dims: self.dims,
            bbox: self.bbox,
            data,
        }
    }

    /// The frame's density `D = max(D̃ + R̂, 0)` and its dequantized residual.
    pub fn density(&self) -> Result<(Volume, Vec<f32>)> {
        let residual = self.residual.as_ref().map(|(g, j)| (&**g, *j));
        frame_density(self.dims, self.bbox, &self.rbfs, residual)
    }
}

/// A baked frame's density on the asset's `dims` grid over `bbox`, `D = max(D̃ + R̂, 0)`
/// with the RBFs as stored and the dequantized residual of slot `j` of its hash volume,
/// and that residual (zero when the asset stores none).
pub fn frame_density(
    dims: [usize; 3],
    bbox: Bbox,
    rbfs: &[Rbf],
    residual: Option<(&ResidualGroup, usize)>,
) -> Result<(Volume, Vec<f32>)> {
    let approx = rbf::evaluate_on_grid(dims, &bbox, rbfs);
    let residual = match residual {
        Some((group, j)) => group.dense(j),
        None => vec![0.0f32; approx.len()],
    };
    let data: Vec<f32> = approx
        .iter()
        .zip(&residual)
        .map(|(a, r)| (a + f64::from(*r)).max(0.0) as f32)
        .collect();
    let density = Volume::new(dims, bbox, data).context("asset grid")?;
    Ok((density, residual))
}

/// Frame `frame` (its number in the input; the first frame when `None`) of the asset at
/// `path`: a baked frame (an error for a packed asset: see [`read_raw_frame`]).
pub fn read_frame(path: &Path, frame: Option<i64>) -> Result<AssetFrame> {
    let asset = Asset::open(path)?;
    let (k, number) = frame_index(&asset, path, frame)?;
    baked_frame(&asset, path, k, number)
}

/// Frame `frame`'s RBFs as stored (its number in the input; the first frame when `None`),
/// its residual left undecoded: [`read_frame`]'s RBFs, at the cost of one small block.
pub fn read_rbfs(path: &Path, frame: Option<i64>) -> Result<Vec<Rbf>> {
    let asset = Asset::open(path)?;
    let (k, number) = frame_index(&asset, path, frame)?;
    let block = rbf_block(&asset, path, k, number)?;
    Ok(decode_rbfs(block.bytes).map_err(|e| asset.block_error(&block, e))?)
}

/// Frame `k` (number `number`)'s RBF block; a packed frame's error says to bake it.
fn rbf_block<'a>(asset: &'a Asset, path: &Path, k: usize, number: i64) -> Result<BlockView<'a>> {
    let blocks = asset.frame(k)?;
    blocks.find(BlockKind::Rbfs).ok_or_else(|| {
        if blocks.find(BlockKind::RawVolume).is_some() {
            anyhow!(
                "{}: frame {number} is a raw volume (a packed asset, `haze pack`): bake its \
                 source ({}) with `haze bake` to play it",
                path.display(),
                asset.header().source.path
            )
        } else {
            anyhow!(
                "{}: frame {number} has no RBF block (not a baked asset?)",
                path.display()
            )
        }
    })
}

/// Frame `frame` (its number in the input; the first when `None`) of a packed asset
/// (`haze pack`: the frames' raw volumes, lossless) as its volume over the asset's grid,
/// with its number; `None` when that frame holds no raw volume (a baked asset).
pub fn read_raw_frame(path: &Path, frame: Option<i64>) -> Result<Option<(i64, Volume)>> {
    let asset = Asset::open(path)?;
    let h = asset.header();
    let (k, number) = frame_index(&asset, path, frame)?;
    let blocks = asset.frame(k)?;
    let Some(block) = blocks.find(BlockKind::RawVolume) else {
        return Ok(None);
    };
    let view = decode_raw_volume(block.bytes).map_err(|e| asset.block_error(&block, e))?;
    let volume = view
        .to_volume(Bbox::new(h.grid.bbox_min, h.grid.bbox_max))
        .map_err(|e| anyhow!("{}: frame {number}: {e}", path.display()))?;
    Ok(Some((number, volume)))
}

/// The index of frame `frame` (its number; the first when `None`) in the asset, and its
/// number.
fn frame_index(asset: &Asset, path: &Path, frame: Option<i64>) -> Result<(usize, i64)> {
    let numbers = &asset.header().source.frame_numbers;
    let k = match frame {
        Some(frame) => numbers.iter().position(|&n| n == frame).ok_or_else(|| {
            let range = match (numbers.first(), numbers.last()) {
                (Some(a), Some(b)) => format!("frames {a}..{b}"),
                _ => "no frames".to_string(),
            };
            anyhow!(
                "{}: frame {frame} is not in the asset ({range})",
                path.display()
            )
        })?,
        None if numbers.is_empty() => bail!("{}: the asset has no frames", path.display()),
        None => 0,
    };
    Ok((k, numbers[k]))
}

/// Frame `k` (number `number`) of a baked asset from its RBF block and its hash volume
/// (decoded up to the frame: the values after it are not needed).
fn baked_frame(asset: &Asset, path: &Path, k: usize, number: i64) -> Result<AssetFrame> {
    // No residual block: the RBFs alone met the error on every frame of its hash volume.
    let residual = match asset.frame(k)?.find(BlockKind::ResidualHash) {
        Some(res_block) => {
            let Scope::Frames { first, .. } = res_block.id.scope else {
                bail!(
                    "{}: the residual block of frame {number} is not per frame",
                    path.display()
                );
            };
            let slot = k - first as usize;
            let group = haze_hash::block::decode_through(res_block.bytes, slot)
                .map_err(|e| asset.block_error(&res_block, e))?;
            Some((group, slot))
        }
        None => None,
    };
    frame_with(asset, path, k, number, residual)
}

/// Frame `k` (number `number`) of a baked asset: its RBF block decoded, beside `residual`
/// (frames of its hash volume decoded and the frame's slot among them; none when the
/// asset stores none for it), whose grid must be the asset's.
fn frame_with(
    asset: &Asset,
    path: &Path,
    k: usize,
    number: i64,
    residual: Option<(ResidualGroup, usize)>,
) -> Result<AssetFrame> {
    let h = asset.header();
    if let Some((group, _)) = residual.as_ref().filter(|(g, _)| g.dims != h.grid.dims) {
        bail!(
            "{}: residual block dims {:?} differ from the grid's",
            path.display(),
            group.dims
        );
    }
    let block = rbf_block(asset, path, k, number)?;
    let rbfs = decode_rbfs(block.bytes).map_err(|e| asset.block_error(&block, e))?;
    Ok(AssetFrame {
        number,
        dims: h.grid.dims.map(|d| d as usize),
        bbox: Bbox::new(h.grid.bbox_min, h.grid.bbox_max),
        rbfs,
        residual: residual.map(|(g, slot)| (Arc::new(g), slot)),
    })
}

/// Frames `numbers` (numbers in the input) of the asset at `path`, each as
/// [`reconstruct_frame`] gives it, handed to `each` in turn (an error of `each` ends the
/// walk). Where the numbers follow the asset's order, a hash volume's residual is decoded
/// once, frame after frame ([`haze_hash::block::decode_frames`], from the volume's first
/// frame asked for), where a frame at a time decodes the volume's earlier frames again
/// for each one (held-out plume-d's 26 frames, one volume: 12.1 s that way).
pub fn reconstruct_frames(
    path: &Path,
    numbers: &[i64],
    mut each: impl FnMut(i64, Reconstruction) -> Result<()>,
) -> Result<()> {
    let asset = Asset::open(path)?;
    let ks = numbers
        .iter()
        .map(|&n| Ok(frame_index(&asset, path, Some(n))?.0))
        .collect::<Result<Vec<usize>>>()?;
    let mut at = 0;
    while at < ks.len() {
        let blocks = asset.frame(ks[at])?;
        let baked = blocks.find(BlockKind::Rbfs).is_some();
        let volume = blocks.find(BlockKind::ResidualHash).filter(|_| baked);
        let Some((block, Scope::Frames { first, count })) = volume.map(|b| (b, b.id.scope)) else {
            each(numbers[at], reconstruct_frame(path, numbers[at])?)?;
            at += 1;
            continue;
        };
        // The frames asked for next that lie in this volume, in its order.
        let span = first as usize..(first + count) as usize;
        let mut end = at + 1;
        while end < ks.len() && span.contains(&ks[end]) && ks[end] > ks[end - 1] {
            end += 1;
        }
        let asked: Vec<(usize, i64)> = (at..end).map(|i| (ks[i], numbers[i])).collect();
        walk_volume(&asset, path, block, first as usize, &asked, &mut each)?;
        at = end;
    }
    Ok(())
}

/// The frames `asked` (asset index ascending, number) of the hash volume `block` whose
/// first frame is `first`, reconstructed as its residual decodes frame after frame.
fn walk_volume(
    asset: &Asset,
    path: &Path,
    block: BlockView<'_>,
    first: usize,
    asked: &[(usize, i64)],
    each: &mut impl FnMut(i64, Reconstruction) -> Result<()>,
) -> Result<()> {
    let mut next = 0;
    let mut failed = None;
    let mut frame = |k: usize, number: i64, group: ResidualGroup| -> Result<()> {
        let f = frame_with(asset, path, k, number, Some((group, 0)))?;
        each(number, f.reconstruction())
    };
    let walked = haze_hash::block::decode_frames(block.bytes, asked[0].0 - first, |j, g| {
        let (Some(g), Some(&(k, number))) = (g, asked.get(next)) else {
            return true;
        };
        if first + j != k {
            return true;
        }
        if let Err(e) = frame(k, number, g) {
            failed = Some(e);
            return false;
        }
        next += 1;
        next < asked.len()
    });
    if let Some(e) = failed {
        return Err(e);
    }
    walked.map_err(|e| asset.block_error(&block, e))?;
    Ok(())
}

/// Frame `frame` (its number in the input) of the asset at `path`: its RBFs evaluated as
/// stored, plus the dequantized residual of its hash volume (none when the RBFs alone met
/// the error on every frame of that volume).
/// A packed asset's frame is its raw volume, as packed.
pub fn reconstruct_frame(path: &Path, frame: i64) -> Result<Reconstruction> {
    if let Some((_, v)) = read_raw_frame(path, Some(frame))? {
        return Ok(Reconstruction {
            dims: v.dims(),
            bbox: *v.bbox(),
            data: v.data().to_vec(),
        });
    }
    Ok(read_frame(path, Some(frame))?.reconstruction())
}
