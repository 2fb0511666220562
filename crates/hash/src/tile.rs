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
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Frames per hash volume, at most.
pub const GROUP: usize = 27;

/// The decoded size a hash volume stops growing at by default (128 MiB): a bake closes a
/// volume early, with fewer than [`GROUP`] frames, rather than let another frame take it
/// past this ([`GroupBuilder::has_room`]). This bounds the bake's volume waiting to be
/// hashed, and what a reader of single frames holds (a volume decoded up to a frame),
/// whatever the frames' size; playback decodes frame after frame
/// ([`crate::block::decode_frames`]) and holds frames, not volumes. Smooth 128³-class smoke
/// fills 27 frames with a few MiB; turbulent 256³-class smoke takes about 10 MiB a frame.
pub const VOLUME_BYTES: usize = 128 << 20;

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
    /// Tiles, bricks and hashes the quantized frames (at most 27, each of `dims`), as a
    /// [`GroupBuilder`] given them one by one.
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
        let mut group = GroupBuilder::new(dims, brick)?;
        for f in frames {
            group.push(f)?;
        }
        group.finish(opts)
    }

    /// Frames in the group.
    pub fn frames(&self) -> usize {
        self.steps.len()
    }

    /// Bytes of its decoded tables, as the GPU holds them: the hash's arrays and the
    /// packed words.
    pub fn bytes(&self) -> usize {
        self.hash.bytes() + 4 * self.data.len()
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

    /// Dequantized residual of every voxel of frame `j` (what [`ResidualGroup::lookup`]
    /// gives at each, `x` fastest; all zeros for a frame the group does not hold). Decoded
    /// a brick at a time: one hash probe per brick and its packed values read in order,
    /// the layers of bricks along `z` in parallel.
    pub fn dense(&self, j: usize) -> Vec<f32> {
        let [nx, ny, nz] = self.dims.map(|d| d as usize);
        let mut out = vec![0.0f32; nx * ny * nz];
        if nx * ny == 0 || j >= self.steps.len() {
            return out;
        }
        let b = self.brick as usize;
        let nb = bricks_per_frame(self.dims, self.brick);
        let o = tile_origin(j, nb);
        let step = self.steps[j];
        out.par_chunks_mut(nx * ny * b)
            .enumerate()
            .for_each(|(bz, layer)| {
                let depth = layer.len() / (nx * ny);
                for by in 0..nb[1] as usize {
                    for bx in 0..nb[0] as usize {
                        let cell = [o[0] + bx as u32, o[1] + by as u32, o[2] + bz as u32];
                        let Some((word, width)) = self.hash.get(cell).and_then(unpayload) else {
                            continue;
                        };
                        let word = word as usize;
                        let (x0, y0) = (bx * b, by * b);
                        for dz in 0..depth {
                            for dy in 0..b.min(ny - y0) {
                                let row = (dz * ny + y0 + dy) * nx + x0;
                                for dx in 0..b.min(nx - x0) {
                                    let q =
                                        pack::get(&self.data, word, width, dx + b * (dy + b * dz));
                                    layer[row + dx] = if width == Width::F32 {
                                        f32::from_bits(q as u32)
                                    } else {
                                        q as f32 * step
                                    };
                                }
                            }
                        }
                    }
                }
            });
        out
    }
}

/// A hash volume built a frame at a time: each frame's bricks are packed as it is pushed,
/// so its quantized cells (8 bytes a stored voxel, nearly every voxel in turbulent smoke)
/// can go before the next frame is quantized, and the volume waits as its packed words
/// (a byte or less a voxel). [`ResidualGroup::build`] is this over a list of frames.
#[derive(Debug)]
pub struct GroupBuilder {
    dims: [u32; 3],
    brick: u32,
    bits: Option<u8>,
    steps: Vec<f32>,
    /// Each stored brick's cell in the tiled brick domain and its payload.
    cells: Vec<([u32; 3], u32)>,
    data: Vec<u32>,
}

impl GroupBuilder {
    /// An empty volume of frames of `dims` voxels, in bricks of side `brick`.
    pub fn new(dims: [u32; 3], brick: u32) -> Result<GroupBuilder, HashError> {
        if !BRICK_SIDES.contains(&brick) {
            return Err(HashError::Invalid(format!(
                "brick side {brick} is not one of {BRICK_SIDES:?}"
            )));
        }
        if dims.iter().any(|&d| d == 0 || d > u32::MAX / 3) {
            return Err(HashError::Invalid(format!(
                "frame dims {dims:?} cannot be tiled"
            )));
        }
        Ok(GroupBuilder {
            dims,
            brick,
            bits: None,
            steps: Vec::new(),
            cells: Vec::new(),
            data: Vec::new(),
        })
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> usize {
        self.steps.len()
    }

    /// Whether no pushed frame stores a brick.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The bytes the volume's decoded tables will take ([`ResidualGroup::bytes`]) if no
    /// frame is added: its packed words, and a key and a payload for each of the `m³`
    /// slots ([`PerfectHash::side_for`] its bricks) plus the offset table, whose side is
    /// at least `∛(bricks/5)` (the build's first try).
    pub fn decoded_bytes(&self) -> usize {
        let k = self.cells.len();
        let m = PerfectHash::side_for(k) as usize;
        4 * self.data.len() + 8 * m * m * m + 4 * k.div_ceil(5)
    }

    /// Whether one more frame fits: fewer than [`GROUP`] frames, and one more of the
    /// frames' mean decoded size keeps the volume within `limit` bytes. An empty volume
    /// always has room (a frame larger than `limit` makes a volume of its own).
    pub fn has_room(&self, limit: usize) -> bool {
        let n = self.frames();
        if n == 0 {
            return true;
        }
        let d = self.decoded_bytes();
        n < GROUP && d + d / n <= limit
    }

    /// Packs frame `f` (the next of the volume) brick by brick, in ascending brick order.
    pub fn push(&mut self, f: &Quantized) -> Result<(), HashError> {
        let j = self.steps.len();
        if j == GROUP {
            return Err(HashError::Invalid(format!(
                "a hash volume holds 1 to {GROUP} frames, not {}",
                j + 1
            )));
        }
        if self.bits.is_some_and(|b| b != f.bits) {
            return Err(HashError::Invalid(
                "frames of a hash volume differ in bits".into(),
            ));
        }
        self.bits = Some(f.bits);
        let (brick, dims) = (self.brick, self.dims);
        let per = (brick * brick * brick) as usize;
        let (nx, nxy) = (dims[0], dims[0] * dims[1]);
        // The frame's bricks in ascending brick order (deterministic layout).
        let mut bricks: BTreeMap<[u32; 3], Vec<i32>> = BTreeMap::new();
        for &(i, q) in &f.cells {
            let p = [i % nx, (i % nxy) / nx, i / nxy];
            let b = [p[2] / brick, p[1] / brick, p[0] / brick];
            let l = p[0] % brick + brick * (p[1] % brick + brick * (p[2] % brick));
            bricks.entry(b).or_insert_with(|| vec![0; per])[l as usize] = q;
        }
        let o = tile_origin(j, bricks_per_frame(dims, brick));
        for (zyx, values) in bricks {
            let width = if f.lossless {
                Width::F32
            } else {
                Width::narrowest(&values)
            };
            let word = u32::try_from(self.data.len())
                .ok()
                .filter(|&w| w <= MAX_WORD)
                .ok_or_else(|| {
                    HashError::Invalid(format!(
                        "{} words of packed residual exceed the {MAX_WORD} a block can index",
                        self.data.len()
                    ))
                })?;
            pack::pack_into(&values, width, &mut self.data);
            let b = [o[0] + zyx[2], o[1] + zyx[1], o[2] + zyx[0]];
            self.cells.push((b, payload(word, width)));
        }
        self.steps.push(f.step);
        Ok(())
    }

    /// Hashes the packed bricks into the volume.
    pub fn finish(self, opts: BuildOptions) -> Result<ResidualGroup, HashError> {
        let Some(bits) = self.bits else {
            return Err(HashError::Invalid(format!(
                "a hash volume holds 1 to {GROUP} frames, not 0"
            )));
        };
        let domain = bricks_per_frame(self.dims, self.brick).map(|d| 3 * d);
        let hash = PerfectHash::build(domain, &self.cells, opts)?;
        Ok(ResidualGroup {
            dims: self.dims,
            brick: self.brick,
            bits,
            steps: self.steps,
            hash,
            data: self.data,
        })
    }
}
