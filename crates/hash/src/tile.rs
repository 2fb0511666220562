//! Hash volumes: up to 27 consecutive frames tiled 3×3×3 into one domain (paper A §5.2),
//! so one hash, and one block of the asset, serves 27 frames.
//!
//! Frame `j` of a group occupies the tile at `(j mod 3, ⌊j/3⌋ mod 3, ⌊j/9⌋)` of a domain
//! three frames wide on every axis; a partial last group keeps the same layout.

use crate::psh::{BuildOptions, HashError, PerfectHash};
use crate::quantize::Quantized;

/// Frames per hash volume.
pub const GROUP: usize = 27;

/// Index-space origin of frame `j`'s tile.
pub fn tile_origin(j: usize, dims: [u32; 3]) -> [u32; 3] {
    let t = [j % 3, (j / 3) % 3, j / 9].map(|v| v as u32);
    [0, 1, 2].map(|a| t[a] * dims[a])
}

/// One hash volume: the quantized residuals of up to 27 frames.
#[derive(Clone, Debug, PartialEq)]
pub struct ResidualGroup {
    /// Voxels per axis of one frame.
    pub dims: [u32; 3],
    pub bits: u8,
    /// Dequantization step of each frame of the group (its length is the frame count).
    pub steps: Vec<f32>,
    pub hash: PerfectHash,
}

impl ResidualGroup {
    /// Tiles and hashes the quantized frames (at most 27, each of `dims`).
    pub fn build(
        dims: [u32; 3],
        frames: &[Quantized],
        opts: BuildOptions,
    ) -> Result<ResidualGroup, HashError> {
        if frames.is_empty() || frames.len() > GROUP {
            return Err(HashError::Invalid(format!(
                "a hash volume holds 1 to {GROUP} frames, not {}",
                frames.len()
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
        let (nx, nxy) = (dims[0], dims[0] * dims[1]);
        let mut cells = Vec::with_capacity(frames.iter().map(|f| f.cells.len()).sum());
        for (j, f) in frames.iter().enumerate() {
            let o = tile_origin(j, dims);
            for &(i, q) in &f.cells {
                let p = [i % nx, (i % nxy) / nx, i / nxy];
                cells.push(([o[0] + p[0], o[1] + p[1], o[2] + p[2]], q));
            }
        }
        let domain = dims.map(|d| 3 * d);
        Ok(ResidualGroup {
            dims,
            bits,
            steps: frames.iter().map(|f| f.step).collect(),
            hash: PerfectHash::build(domain, &cells, opts)?,
        })
    }

    /// Frames in the group.
    pub fn frames(&self) -> usize {
        self.steps.len()
    }

    /// Dequantized residual of voxel `(x, y, z)` of frame `j` of the group (0 outside).
    #[inline]
    pub fn lookup(&self, j: usize, p: [u32; 3]) -> f32 {
        if j >= self.steps.len() || (0..3).any(|a| p[a] >= self.dims[a]) {
            return 0.0;
        }
        let o = tile_origin(j, self.dims);
        let q = self.hash.get([o[0] + p[0], o[1] + p[1], o[2] + p[2]]);
        f32::from(q) * self.steps[j]
    }
}
