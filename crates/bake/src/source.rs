//! Where a bake's frames come from: a sequence of volume files (a folder, a pattern or
//! one file, `haze_volume::import::Sequence`), or a packed asset (`haze pack`: raw
//! volumes in a `.haze` file, read bit for bit as they were packed).

use anyhow::{Result, anyhow, bail};
use haze_asset::{Asset, BlockKind, Scope, decode_raw_volume};
use haze_volume::import::{Format, FrameRange, Sequence};
use haze_volume::{Bbox, ImportOptions, Volume};
use serde_json::json;
use std::path::{Path, PathBuf};

/// The frames of a bake, in order.
#[derive(Debug)]
pub enum Frames {
    Files(Sequence),
    Packed(Packed),
}

/// The raw-volume frames of a packed asset within a range.
#[derive(Debug)]
pub struct Packed {
    path: PathBuf,
    asset: Asset,
    /// Per frame of the bake: its index in the asset and its number.
    frames: Vec<(usize, i64)>,
    gaps: Vec<(i64, i64)>,
}

impl Frames {
    /// The frames of `input` within `range`: a packed asset when it ends in `.haze`, else
    /// volume files read with `import`.
    pub fn open(input: &Path, import: &ImportOptions, range: FrameRange) -> Result<Frames> {
        let is_asset = input
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("haze"));
        if is_asset && input.is_file() {
            use haze_volume::import::{VdbOptionsOf, vdb_options_refused};
            vdb_options_refused(input, VdbOptionsOf::Asset, import)?;
            Ok(Frames::Packed(Packed::open(input, range)?))
        } else {
            Ok(Frames::Files(Sequence::open(input, import, range)?))
        }
    }

    pub fn len(&self) -> usize {
        match self {
            Frames::Files(s) => s.len(),
            Frames::Packed(p) => p.frames.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The grid every frame shares.
    pub fn dims(&self) -> [usize; 3] {
        match self {
            Frames::Files(s) => s.dims(),
            Frames::Packed(p) => p.asset.header().grid.dims.map(|d| d as usize),
        }
    }

    pub fn bbox(&self) -> Bbox {
        match self {
            Frames::Files(s) => *s.bbox(),
            Frames::Packed(p) => {
                let g = &p.asset.header().grid;
                Bbox::new(g.bbox_min, g.bbox_max)
            }
        }
    }

    /// Missing frame numbers, as inclusive ranges.
    pub fn gaps(&self) -> &[(i64, i64)] {
        match self {
            Frames::Files(s) => s.gaps(),
            Frames::Packed(p) => &p.gaps,
        }
    }

    /// Frame `i`'s number.
    pub fn number(&self, i: usize) -> i64 {
        match self {
            Frames::Files(s) => s.frames()[i].number,
            Frames::Packed(p) => p.frames[i].1,
        }
    }

    /// Frame `i` for messages: its file (or the asset) and its number, `PATH: frame N`.
    pub fn label(&self, i: usize) -> String {
        match self {
            Frames::Files(s) => format!(
                "{}: frame {}",
                s.frames()[i].path.display(),
                s.frames()[i].number
            ),
            Frames::Packed(p) => format!("{}: frame {}", p.path.display(), p.frames[i].1),
        }
    }

    /// Where frame `i` is read from: its file, or the asset.
    pub fn path(&self, i: usize) -> &Path {
        match self {
            Frames::Files(s) => &s.frames()[i].path,
            Frames::Packed(p) => &p.path,
        }
    }

    /// Reads frame `i` (0-based position in the bake).
    pub fn load(&self, i: usize) -> Result<Volume> {
        match self {
            Frames::Files(s) => Ok(s.load(i)?),
            Frames::Packed(p) => p.load(i),
        }
    }

    /// The VDB grid the frames were read from ("" for raw and NumPy input).
    pub fn grid_name(&self, import: &ImportOptions) -> String {
        match self {
            Frames::Files(s) if s.format() == Format::Vdb => import.grid.clone(),
            Frames::Files(_) => String::new(),
            Frames::Packed(p) => p.asset.header().source.grid.clone(),
        }
    }

    /// What identifies the input frames for a resumed bake: per frame its number, where
    /// it is and its size in bytes (a file's, or the packed block's).
    pub fn identity(&self) -> Result<Vec<serde_json::Value>> {
        (0..self.len())
            .map(|i| {
                let size = match self {
                    Frames::Files(s) => {
                        let path = &s.frames()[i].path;
                        std::fs::metadata(path)
                            .map_err(|e| anyhow!("{}: cannot read ({e})", path.display()))?
                            .len()
                    }
                    Frames::Packed(p) => p.asset.entries()[p.raw_block(i)?].len,
                };
                Ok(json!([
                    self.number(i),
                    self.path(i).display().to_string(),
                    size
                ]))
            })
            .collect()
    }
}

impl Packed {
    fn open(path: &Path, range: FrameRange) -> Result<Packed> {
        let asset = Asset::open(path)?;
        let numbers = asset.header().source.frame_numbers.clone();
        let frames: Vec<(usize, i64)> = numbers
            .iter()
            .copied()
            .enumerate()
            .filter(|&(_, n)| range.contains(n))
            .collect();
        if frames.is_empty() {
            let held = match (numbers.first(), numbers.last()) {
                (Some(a), Some(b)) => format!(" (it holds frames {a}..{b})"),
                _ => " (it holds none)".to_string(),
            };
            bail!("{}: no frames in the range {range}{held}", path.display());
        }
        let gaps = frames
            .windows(2)
            .filter(|w| w[1].1 > w[0].1 + 1)
            .map(|w| (w[0].1 + 1, w[1].1 - 1))
            .collect();
        let packed = Packed {
            path: path.to_path_buf(),
            asset,
            frames,
            gaps,
        };
        // A baked asset has RBFs, not raw volumes: say what to bake instead.
        packed.raw_block(0)?;
        Ok(packed)
    }

    /// The index (in the asset's block index) of frame `i`'s raw volume.
    fn raw_block(&self, i: usize) -> Result<usize> {
        let (k, number) = self.frames[i];
        self.asset
            .entries()
            .iter()
            .position(|e| e.kind == BlockKind::RawVolume && e.scope == Scope::frame(k as u32))
            .ok_or_else(|| {
                anyhow!(
                    "{}: frame {number} has no raw volume (a baked asset: bake its source, {}, instead)",
                    self.path.display(),
                    self.asset.header().source.path
                )
            })
    }

    fn load(&self, i: usize) -> Result<Volume> {
        let number = self.frames[i].1;
        let block = self.asset.block(self.raw_block(i)?)?;
        let view = decode_raw_volume(block.bytes).map_err(|e| self.asset.block_error(&block, e))?;
        let g = &self.asset.header().grid;
        let v = view
            .to_volume(Bbox::new(g.bbox_min, g.bbox_max))
            .map_err(|e| anyhow!("{}: frame {number}: {e}", self.path.display()))?;
        if v.dims() != g.dims.map(|d| d as usize) {
            bail!(
                "{}: frame {number} is {:?} voxels, not the asset's {:?}",
                self.path.display(),
                v.dims(),
                g.dims
            );
        }
        Ok(v)
    }
}
