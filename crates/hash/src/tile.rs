//! Hash volumes: up to 27 consecutive frames tiled 3×3×3 into one domain (paper A §5.2),
//! so one hash, and one block of the asset, serves 27 frames — hashed by bricks.
//!
//! Frame `j` of a group occupies the tile at `(j mod 3, ⌊j/3⌋ mod 3, ⌊j/9⌋)` of a domain
//! three frames wide on every axis; a partial last group keeps the same layout.
//!
//! The hash stores bricks of `b³` voxels (b = 4 by default), not voxels: one key and one
//! payload per brick holding at least one stored value, the brick's `b³` values packed at
//! the narrowest width that holds them ([`crate::pack`]). Voxels of a frame tile map to
//! bricks of the tiled *brick* domain, `⌈dims/b⌉` bricks per frame and axis, so bricks
//! never straddle two frames; a brick reaching past the frame's edge holds zeros there.
//! A lookup is one hash probe and one packed read: still exact and O(1).

use crate::pack::{self, Width};
use crate::psh::{BuildOptions, HashError, PerfectHash};
use crate::quantize::Quantized;
use std::collections::BTreeMap;

/// Frames per hash volume.
pub const GROUP: usize = 27;

/// Brick sides the residual may be stored with.
pub const BRICK_SIDES: [u32; 4] = [1, 2, 4, 8];

/// The default brick side (BENCHMARKS.md: the smallest residual on real smoke).
pub const DEFAULT_BRICK: u32 = 4;

/// Index-space origin of frame `j`'s tile in a domain of `dims`-sized frames (voxels, or
/// bricks with the frame's brick counts).
pub fn tile_origin(j: usize, dims: [u32; 3]) -> [u32; 3] {
    let t = [j % 3, (j / 3) % 3, j / 9].map(|v| v as u32);
    [0, 1, 2].map(|a| t[a] * dims[a])
}

/// Bricks per axis of a frame of `dims` voxels.
pub fn bricks_per_frame(dims: [u32; 3], brick: u32) -> [u32; 3] {
    dims.map(|d| d.div_ceil(brick.max(1)))
}

/// Payload of a brick: its first word in [`ResidualGroup::data`] and its width code.
#[inline]
pub fn payload(word: u32, width: Width) -> u32 {
    word << 3 | width.code()
}

/// The parts of a payload (`None` for an unknown width code).
#[inline]
pub fn unpayload(p: u32) -> Option<(u32, Width)> {
    Some((p >> 3, Width::from_code(p & 7)?))
}

/// Largest first word a payload can hold.
pub const MAX_WORD: u32 = u32::MAX >> 3;

/// One hash volume: the quantized residuals of up to 27 frames.
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualGroup {
    /// Voxels per axis of one frame.
    pub dims: [u32; 3],
    /// Brick side, in voxels.
    pub brick: u32,
    /// Widest stored value the frames were quantized for.
    pub bits: u8,
    /// Dequantization step of each frame of the group (its length is the frame count; 0 for
    /// a lossless frame, whose bricks hold `f32` values).
    pub steps: Vec<f32>,
    /// The bricks: keys over the tiled brick domain, payloads into `data`.
    pub hash: PerfectHash,
    /// The bricks' packed values, brick after brick.
    pub data: Vec<u32>,
}

impl ResidualGroup {
    /// Tiles, bricks and hashes the quantized frames (at most 27, each of `dims`).
    pub fn build(
        dims: [u32; 3],
        brick: u32,
        frames: &[Quantized],
        opts: BuildOptions,
    ) -> Result<ResidualGroup, HashError> {
        if frames.is_empty() || frames.len() > GROUP {
            return Err(HashError::Invalid(format!(
                "a hash volume holds 1 to {GROUP} frames, not {}",
                frames.len()
            )));
        }
        if !BRICK_SIDES.contains(&brick) {
            return Err(HashError::Invalid(format!(
                "brick side {brick} is not one of {BRICK_SIDES:?}"
            )));
        }
        let bits = frames[0].bits;
        if frames.iter().any(|f| f.bits != bits) {
            return Err(HashError::Invalid(
                "frames of a hash volume differ in bits".into(),
            ));
        }
        if dims.iter().any(|&d| d == 0 || d > u32::MAX / 3) {
            return Err(HashError::Invalid(format!(
                "frame dims {dims:?} cannot be tiled"
            )));
        }
        let nb = bricks_per_frame(dims, brick);
        let per = (brick * brick * brick) as usize;
        let (nx, nxy) = (dims[0], dims[0] * dims[1]);
        let mut cells = Vec::new();
        let mut data = Vec::new();
        for (j, f) in frames.iter().enumerate() {
            // The frame's bricks in ascending brick order (deterministic layout).
            let mut bricks: BTreeMap<[u32; 3], Vec<i32>> = BTreeMap::new();
            for &(i, q) in &f.cells {
                let p = [i % nx, (i % nxy) / nx, i / nxy];
                let b = [p[2] / brick, p[1] / brick, p[0] / brick];
                let l = p[0] % brick + brick * (p[1] % brick + brick * (p[2] % brick));
                bricks.entry(b).or_insert_with(|| vec![0; per])[l as usize] = q;
            }
            let o = tile_origin(j, nb);
            for (zyx, values) in bricks {
                let width = if f.lossless {
                    Width::F32
                } else {
                    Width::narrowest(&values)
                };
                let word = u32::try_from(data.len())
                    .ok()
                    .filter(|&w| w <= MAX_WORD)
                    .ok_or_else(|| {
                        HashError::Invalid(format!(
                            "{} words of packed residual exceed the {MAX_WORD} a block can index",
                            data.len()
                        ))
                    })?;
                pack::pack_into(&values, width, &mut data);
                let b = [o[0] + zyx[2], o[1] + zyx[1], o[2] + zyx[0]];
                cells.push((b, payload(word, width)));
            }
        }
        let domain = nb.map(|d| 3 * d);
        Ok(ResidualGroup {
            dims,
            brick,
            bits,
            steps: frames.iter().map(|f| f.step).collect(),
            hash: PerfectHash::build(domain, &cells, opts)?,
            data,
        })
    }

    /// Frames in the group.
    pub fn frames(&self) -> usize {
        self.steps.len()
    }

    /// Bricks stored for frame `j`.
    pub fn bricks_of(&self, j: usize) -> usize {
        let nb = bricks_per_frame(self.dims, self.brick);
        let o = tile_origin(j, nb);
        let d = self.hash.domain;
        self.hash
            .keys
            .iter()
            .filter(|&&k| k != 0)
            .filter(|&&k| {
                let i = k - 1;
                let p = [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])];
                (0..3).all(|a| p[a] >= o[a] && p[a] < o[a] + nb[a])
            })
            .count()
    }

    /// Data words of frame `j`'s bricks (its share of the packed values).
    pub fn words_of(&self, j: usize) -> usize {
        let nb = bricks_per_frame(self.dims, self.brick);
        let o = tile_origin(j, nb);
        let d = self.hash.domain;
        let per = (self.brick * self.brick * self.brick) as usize;
        self.hash
            .keys
            .iter()
            .zip(&self.hash.payloads)
            .filter(|&(&k, _)| k != 0)
            .filter(|&(&k, _)| {
                let i = k - 1;
                let p = [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])];
                (0..3).all(|a| p[a] >= o[a] && p[a] < o[a] + nb[a])
            })
            .filter_map(|(_, &p)| unpayload(p))
            .map(|(_, w)| w.words(per))
            .sum()
    }

    /// Dequantized residual of voxel `(x, y, z)` of frame `j` of the group (0 outside, and
    /// where nothing is stored).
    #[inline]
    pub fn lookup(&self, j: usize, p: [u32; 3]) -> f32 {
        if j >= self.steps.len() || (0..3).any(|a| p[a] >= self.dims[a]) {
            return 0.0;
        }
        let b = self.brick;
        let o = tile_origin(j, bricks_per_frame(self.dims, b));
        let Some(pl) = self.hash.get([0, 1, 2].map(|a| o[a] + p[a] / b)) else {
            return 0.0;
        };
        let Some((word, width)) = unpayload(pl) else {
            return 0.0;
        };
        let l = p[0] % b + b * (p[1] % b + b * (p[2] % b));
        let q = pack::get(&self.data, word as usize, width, l as usize);
        if width == Width::F32 {
            f32::from_bits(q as u32)
        } else {
            q as f32 * self.steps[j]
        }
    }
}
