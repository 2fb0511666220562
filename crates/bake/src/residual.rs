//! The residual stage of a bake (paper A §5.2): per frame, `R = D − D̃` against the RBFs
//! exactly as stored (f32), quantized to the error asked for; every 27 frames (and at the
//! end), one hash volume of bricks — or none, when the RBFs alone met the error on every
//! frame of the group.
//!
//! Each frame's bricks are packed into its hash volume as soon as it is quantized
//! ([`GroupBuilder`]), so a volume waits as packed words, not as the frames' cells. A
//! volume closes early, with fewer frames, where another frame would take its decoded
//! tables past the bake's `volume_bytes` ([`haze_hash::tile::VOLUME_BYTES`] unless set).

use anyhow::{Result, anyhow};
use haze_asset::{Scope, decode_rbfs, encode_rbfs};
use haze_hash::tile::{GroupBuilder, ResidualGroup};
use haze_hash::{BuildOptions, QuantOptions, block, quantize};
use haze_volume::{Rbf, Volume, rbf};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// A frame's residual figures, as the report shows them.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct ResidualRecord {
    /// Voxels whose quantized residual is not zero (the values that matter).
    pub residual_nonzero: usize,
    /// Bricks stored for the frame (each holds its voxels' values at one width).
    #[serde(default)]
    pub residual_bricks: usize,
    /// The largest error asked for, in density units (`--residual-error` × peak density).
    #[serde(default)]
    pub residual_target: f64,
    /// Largest `|D − D̃|` over the frame's peak density: the error of the RBFs alone.
    #[serde(default)]
    pub rbf_max_error: f64,
    /// The RBFs alone meet the error everywhere: nothing stored for the frame.
    #[serde(default)]
    pub rbfs_meet_error: bool,
    /// Share of the frame's smoke voxels (where `D` or `D̃` is not zero) that the RBFs
    /// alone reconstruct within the error: how much of the budget they already meet.
    #[serde(default)]
    pub rbf_share_within_error: f64,
    /// The step had to widen past the asked error for the values to fit `--quant-bits`.
    #[serde(default)]
    pub quant_widened: bool,
    /// The frame's share of its hash volume's block, by its share of the cells.
    pub hash_bytes: f64,
    /// Quantization and packing time plus the frame's share of the hash volume's build
    /// time.
    pub hash_seconds: f64,
    /// Dequantization step, largest and RMS reconstruction error (density units).
    pub quant_step: f32,
    pub quant_max_error: f64,
    pub quant_rms_error: f64,
}

/// Collects quantized frames and makes a hash volume of every 27.
#[derive(Debug)]
pub struct ResidualStage {
    opts: QuantOptions,
    brick: u32,
    dims: [u32; 3],
    first: usize,
    /// The decoded size a hash volume closes before ([`GroupBuilder::has_room`]).
    volume_bytes: usize,
    /// The hash volume being filled: each frame's bricks packed as it is quantized.
    group: GroupBuilder,
    /// Each pending frame's seconds (its quantization and packing).
    seconds: Vec<f64>,
}

/// A finished hash volume: its block and its frames' shares of bytes and seconds.
#[derive(Debug)]
pub struct HashVolume {
    /// Asset index of its first frame, and its frame count.
    pub first: usize,
    pub count: usize,
    /// The encoded block (haze_hash::block); empty when no frame stores anything (the
    /// asset then has no residual block for these frames).
    pub bytes: Vec<u8>,
    /// Per frame: bytes (its share of the block, by its share of the packed values and
    /// bricks) and seconds (its quantization plus its share of the build).
    pub shares: Vec<(f64, f64)>,
    /// Per frame: bricks stored.
    pub bricks: Vec<usize>,
}

impl HashVolume {
    pub fn scope(&self) -> Scope {
        Scope::Frames {
            first: self.first as u32,
            count: self.count as u32,
        }
    }

    /// Puts the shares into the records of the asset's frames (`records[k]` is frame `k`).
    pub fn share_into(&self, records: &mut [ResidualRecord]) {
        for (j, &(bytes, secs)) in self.shares.iter().enumerate() {
            let rec = &mut records[self.first + j];
            rec.hash_bytes = bytes;
            rec.hash_seconds = secs;
            rec.residual_bricks = self.bricks[j];
        }
    }
}

/// The RBFs as a reader of the asset sees them (quantized by the block encoding,
/// `haze_asset::rbf_block`): the residual is taken against these.
pub fn as_stored(rbfs: &[Rbf]) -> Result<Vec<Rbf>> {
    decode_rbfs(&encode_rbfs(rbfs)).map_err(|e| anyhow!("RBFs do not encode: {e}"))
}

/// `D̃ + R̂` of one frame: the reconstruction every consumer of the asset gets (`D̃`
/// alone where the frame has no residual block).
pub fn reconstruct(
    v_dims: [usize; 3],
    bbox: &haze_volume::Bbox,
    rbfs: &[Rbf],
    residual: Option<(&ResidualGroup, usize)>,
) -> Vec<f32> {
    let approx = rbf::evaluate_on_grid(v_dims, bbox, rbfs);
    let (nx, nxy) = (v_dims[0], v_dims[0] * v_dims[1]);
    approx
        .iter()
        .enumerate()
        .map(|(i, a)| {
            let p = [i % nx, (i % nxy) / nx, i / nxy].map(|c| c as u32);
            let r = residual.map_or(0.0, |(g, j)| g.lookup(j, p));
            (a + f64::from(r)) as f32
        })
        .collect()
}

impl ResidualStage {
    /// A stage whose next frame is asset frame `first`, the start of a hash volume, and
    /// whose volumes close at 27 frames or before their decoded tables would pass
    /// `volume_bytes`.
    pub fn new(
        opts: QuantOptions,
        brick: u32,
        volume_bytes: usize,
        dims: [usize; 3],
        first: usize,
    ) -> Result<Self> {
        let dims = dims.map(|d| d as u32);
        opts.validate().map_err(|e| anyhow!("{e}"))?;
        Ok(ResidualStage {
            opts,
            brick,
            dims,
            first,
            volume_bytes,
            group: GroupBuilder::new(dims, brick).map_err(|e| anyhow!("residual: {e}"))?,
            seconds: Vec::new(),
        })
    }

    /// Quantizes frame `v`'s residual against `rbfs` (as stored).
    pub fn push(&mut self, v: &Volume, rbfs: &[Rbf]) -> Result<ResidualRecord> {
        let t = Instant::now();
        let stored = as_stored(rbfs)?;
        let approx = rbf::evaluate_on_grid(v.dims(), v.bbox(), &stored);
        let r: Vec<f32> = v
            .data()
            .iter()
            .zip(&approx)
            .map(|(d, a)| (f64::from(*d) - a) as f32)
            .collect();
        let peak = v.data().iter().fold(0.0f32, |m, &d| m.max(d));
        let smoke = v
            .data()
            .iter()
            .zip(&approx)
            .filter(|&(d, a)| *d != 0.0 || *a != 0.0)
            .count();
        let q = quantize(&r, peak, self.opts).map_err(|e| anyhow!("residual: {e}"))?;
        let record = ResidualRecord {
            residual_nonzero: q.cells.len(),
            residual_target: q.target,
            rbf_max_error: if peak > 0.0 {
                q.rbf_error / f64::from(peak)
            } else {
                0.0
            },
            rbfs_meet_error: q.cells.is_empty(),
            // Stored voxels are a subset of the smoke voxels (R ≠ 0 needs D or D̃ ≠ 0).
            rbf_share_within_error: if smoke > 0 {
                1.0 - q.cells.len() as f64 / smoke as f64
            } else {
                1.0
            },
            quant_widened: q.widened,
            quant_step: q.step,
            quant_max_error: q.max_error,
            quant_rms_error: q.rms_error,
            ..ResidualRecord::default()
        };
        // Packed now and let go: the volume waits as packed words, not as cells.
        self.group.push(&q).map_err(|e| anyhow!("residual: {e}"))?;
        self.seconds.push(t.elapsed().as_secs_f64());
        Ok(record)
    }

    /// Whether a hash volume is complete: 27 frames, or no room for another frame of
    /// its frames' mean size.
    pub fn full(&self) -> bool {
        !self.group.has_room(self.volume_bytes)
    }

    /// Hashes the pending frames into one hash volume (`None` when none are pending).
    pub fn flush(&mut self) -> Result<Option<HashVolume>> {
        if self.seconds.is_empty() {
            return Ok(None);
        }
        let t = Instant::now();
        let secs = std::mem::take(&mut self.seconds);
        let next =
            GroupBuilder::new(self.dims, self.brick).map_err(|e| anyhow!("residual: {e}"))?;
        let group = std::mem::replace(&mut self.group, next);
        let count = secs.len();
        let (bytes, bricks, weights) = if group.is_empty() {
            // Nothing to store: no block at all.
            (Vec::new(), vec![0; count], vec![0.0; count])
        } else {
            let g = group.finish(BuildOptions::default())?;
            let bricks: Vec<usize> = (0..count).map(|j| g.bricks_of(j)).collect();
            // A frame's share of the block: its packed words plus its bricks' list
            // entries (a key delta of about a byte: a quarter word each), an estimate.
            let weights = (0..count)
                .map(|j| g.words_of(j) as f64 + 0.25 * bricks[j] as f64)
                .collect();
            let bytes = block::encode(&g).map_err(|e| anyhow!("residual block: {e}"))?;
            (bytes, bricks, weights)
        };
        let build = t.elapsed().as_secs_f64();
        let total: f64 = weights.iter().sum();
        let shares = secs
            .iter()
            .zip(&weights)
            .map(|(secs, w)| {
                let share = if total > 0.0 {
                    w / total
                } else {
                    1.0 / count as f64
                };
                (share * bytes.len() as f64, secs + share * build)
            })
            .collect();
        let out = HashVolume {
            first: self.first,
            count,
            bytes,
            shares,
            bricks,
        };
        self.first += count;
        Ok(Some(out))
    }
}
