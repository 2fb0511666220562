//! The RBF block: the Gaussian RBFs of one frame, quantized and entropy-coded.
//!
//! Payload (little-endian):
//!
//! ```text
//! u32 count, u32 layout (3), u32 coded bytes, u32 bits (12)
//! f64 lo[5], hi[5]         each channel's range: center x, y, z, radius, weight
//! `coded bytes` range-coded (haze_core::adaptive): for each channel in that order, the
//!   `count` values' q = round(L (v − lo) / (hi − lo)), L = 2^bits − 1: the bits above
//!   the low 8 through a binary tree of adaptive models (one tree a channel), the low 8
//!   as equally likely bits
//! ```
//!
//! The high bits follow how the RBFs spread over each range (centers where the smoke is,
//! radii and weights skewed to one end); the low bits are noise.
//!
//! A value decodes to `lo (1 − t) + hi t`, `t = q / L` (the extremes exactly): a center
//! moves by at most `1/(2L)` of the centers' span (1/8190: a hundredth of a voxel for a
//! 96-voxel span, 0.06 voxel for 512), a radius or weight by as little of its channel's
//! span (a weight in `[0, 1]` by 1.2·10⁻⁴, a thirtieth of the default error bound).
//! Finer levels would not pay: at 16 bits a channel the RBFs of a 96 × 96 × 128 frame
//! take 3.0 kB and its residual 0.1 % fewer bytes than at 12 bits, where they take
//! 2.2 kB. World coordinates and density units. Anything computed from the RBFs after
//! the bake (the residual, lighting) must use the decoded values, which [`decode_rbfs`]
//! of [`encode_rbfs`] gives; the residual is taken against them, so the bake's error
//! bound holds for the reconstruction a reader makes, whatever the grid's size. Layout 2
//! (16 bits a channel as zstd-coded byte planes, haze format 3) still reads; layout 1
//! (32-byte `f32` records, haze format 2) is refused with a message to bake again.

use haze_core::adaptive::{Bit, BitIo, BitReader, BitWriter};
use haze_volume::Rbf;

const PREFIX: usize = 16 + 2 * 8 * CHANNELS;
const CHANNELS: usize = 5;
const LAYOUT: u32 = 3;
/// Bits a channel value is quantized to.
const BITS: u32 = 12;
/// The quantization's largest level.
const LEVELS: f64 = ((1u32 << BITS) - 1) as f64;
/// The low bits of a value, coded as equally likely; the `HIGH` above them go through a
/// tree of adaptive models.
const LOW: u32 = 8;
const HIGH: u32 = BITS - LOW;

fn channels(r: &Rbf) -> [f64; CHANNELS] {
    [r.center[0], r.center[1], r.center[2], r.radius, r.weight]
}

/// Encodes RBFs as an RBF-block payload.
pub fn encode_rbfs(rbfs: &[Rbf]) -> Vec<u8> {
    let n = rbfs.len();
    let mut lo = [f64::INFINITY; CHANNELS];
    let mut hi = [f64::NEG_INFINITY; CHANNELS];
    for r in rbfs {
        for (c, v) in channels(r).into_iter().enumerate() {
            lo[c] = lo[c].min(v);
            hi[c] = hi[c].max(v);
        }
    }
    if n == 0 {
        lo = [0.0; CHANNELS];
        hi = [0.0; CHANNELS];
    }
    let mut io = BitWriter::new();
    for c in 0..CHANNELS {
        let span = hi[c] - lo[c];
        let mut tree = [Bit::default(); (1 << HIGH) - 1];
        for r in rbfs {
            let v = channels(r)[c];
            let q = if span > 0.0 {
                ((v - lo[c]) / span * LEVELS).round().clamp(0.0, LEVELS) as u32
            } else {
                0
            };
            let _ = io.tree(&mut tree, HIGH, q >> LOW);
            let _ = io.raw(LOW, q);
        }
    }
    // A writer fails only on a bit it cannot code, and every bit here has a probability.
    let coded = io.finish().unwrap_or_default();
    let mut out = Vec::with_capacity(PREFIX + coded.len());
    for v in [n as u32, LAYOUT, coded.len() as u32, BITS] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in lo.iter().chain(&hi) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&coded);
    out
}

/// Decodes an RBF-block payload, checking its sizes and that every RBF is finite with a
/// positive radius.
pub fn decode_rbfs(bytes: &[u8]) -> Result<Vec<Rbf>, String> {
    if bytes.len() < 8 {
        return Err(format!("RBF block of {} bytes has no header", bytes.len()));
    }
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let (count, layout) = (u(0) as usize, u(4));
    if layout == 32 {
        return Err(
            "RBF block layout 1 (haze format 2) is no longer read: bake the asset again"
                .to_string(),
        );
    }
    if layout != 2 && layout != LAYOUT {
        return Err(format!("RBF block layout {layout} is unknown"));
    }
    if bytes.len() < PREFIX {
        return Err(format!("RBF block of {} bytes has no header", bytes.len()));
    }
    let coded = u(8) as usize;
    if bytes.len() != PREFIX + coded {
        return Err(format!(
            "RBF block of {} bytes does not match its header ({coded} coded bytes)",
            bytes.len()
        ));
    }
    let f = |i: usize| f64::from_le_bytes(bytes[i..i + 8].try_into().unwrap_or([0; 8]));
    let lo: [f64; CHANNELS] = std::array::from_fn(|c| f(16 + 8 * c));
    let hi: [f64; CHANNELS] = std::array::from_fn(|c| f(16 + 8 * (CHANNELS + c)));
    let (levels, q) = if layout == 2 {
        (65535.0, sixteen_bit_planes(&bytes[PREFIX..], count)?)
    } else {
        let bits = u(12);
        if !(LOW + 1..=16).contains(&bits) {
            return Err(format!("RBF block of {bits} bits a channel"));
        }
        // Each value takes at least its LOW equally likely bits: a count the coded
        // bytes cannot hold is corrupt.
        if count.saturating_mul(CHANNELS * LOW as usize) > 8 * coded + 64 {
            return Err(format!(
                "RBF block claims {count} RBFs in {coded} coded bytes"
            ));
        }
        let mut io = BitReader::new(&bytes[PREFIX..]).map_err(|e| format!("RBF block: {e}"))?;
        let mut q = vec![0u32; CHANNELS * count];
        for c in 0..CHANNELS {
            let mut tree = vec![Bit::default(); (1 << (bits - LOW)) - 1];
            for k in 0..count {
                let high = io
                    .tree(&mut tree, bits - LOW, 0)
                    .map_err(|e| format!("RBF block: {e}"))?;
                let low = io.raw(LOW, 0).map_err(|e| format!("RBF block: {e}"))?;
                q[c * count + k] = high << LOW | low;
            }
        }
        (f64::from((1u32 << bits) - 1), q)
    };
    let value = |c: usize, k: usize| {
        let t = f64::from(q[c * count + k]) / levels;
        lo[c] * (1.0 - t) + hi[c] * t
    };
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let rbf = Rbf::new(
            [value(0, k), value(1, k), value(2, k)],
            value(3, k),
            value(4, k),
        );
        let finite = rbf.center.iter().all(|c| c.is_finite()) && rbf.weight.is_finite();
        if !(finite && rbf.radius > 0.0 && rbf.radius.is_finite()) {
            let c = rbf.center;
            return Err(format!(
                "RBF {k} is invalid (center {}, {}, {}, radius {}, weight {})",
                c[0], c[1], c[2], rbf.radius, rbf.weight
            ));
        }
        out.push(rbf);
    }
    Ok(out)
}

/// Layout 2's values: each channel's 16-bit levels as two zstd-coded byte planes.
fn sixteen_bit_planes(coded: &[u8], count: usize) -> Result<Vec<u32>, String> {
    let want = count
        .checked_mul(2 * CHANNELS)
        .ok_or(format!("RBF block claims {count} RBFs"))?;
    let planes = haze_core::coded::inflate(coded, want).map_err(|e| format!("RBF block: {e}"))?;
    if planes.len() != want {
        return Err(format!(
            "RBF block holds {} bytes of values for {count} RBFs",
            planes.len()
        ));
    }
    Ok((0..CHANNELS * count)
        .map(|i| {
            let (c, k) = (i / count, i % count);
            u32::from(u16::from_le_bytes([
                planes[2 * c * count + k],
                planes[(2 * c + 1) * count + k],
            ]))
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decoded RBFs lie within half a level of each channel's span of the encoded ones,
    /// the channels' extremes exactly; damage and the old layout are refused.
    #[test]
    fn rbfs_round_trip_within_half_a_level() {
        let rbfs: Vec<Rbf> = (0..50)
            .map(|i| {
                let t = i as f64 / 49.0;
                Rbf::new(
                    [0.5 + 2.0 * t, -1.25 + (7.0 * t).sin(), 3.0 - t * t],
                    0.0625 + 0.5 * (3.0 * t).cos().abs(),
                    -0.2 + 1.1 * (5.0 * t).sin().abs(),
                )
            })
            .collect();
        let enc = encode_rbfs(&rbfs);
        let dec = decode_rbfs(&enc).unwrap();
        assert_eq!(dec.len(), rbfs.len());
        for c in 0..CHANNELS {
            let v: Vec<f64> = rbfs.iter().map(|r| channels(r)[c]).collect();
            let (lo, hi) = v
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            let half = 0.5 * (hi - lo) / LEVELS * (1.0 + 1e-9);
            for (r, d) in rbfs.iter().zip(&dec) {
                let (x, y) = (channels(r)[c], channels(d)[c]);
                assert!(
                    (x - y).abs() <= half,
                    "channel {c}: {x} → {y} (half a level {half})"
                );
                if x == lo || x == hi {
                    assert_eq!(x, y, "an extreme of channel {c} is kept exactly");
                }
            }
        }
        // Decoding is a function of the bytes: a second round trip changes nothing.
        assert_eq!(decode_rbfs(&encode_rbfs(&dec)).unwrap(), dec);
        assert_eq!(decode_rbfs(&encode_rbfs(&[])).unwrap(), vec![]);
        let one = [Rbf::new([1.0, 2.0, 3.0], 0.25, 0.5)];
        assert_eq!(decode_rbfs(&encode_rbfs(&one)).unwrap(), one.to_vec());
        assert!(decode_rbfs(&enc[..enc.len() - 4]).is_err());
        assert!(decode_rbfs(&enc[..10]).is_err());
        let mut huge = enc.clone();
        huge[0..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_rbfs(&huge).is_err());
        // A radius range reaching zero gives an RBF of radius 0.
        let mut bad = enc.clone();
        bad[16 + 8 * 3..16 + 8 * 4].copy_from_slice(&0f64.to_le_bytes());
        assert!(decode_rbfs(&bad).unwrap_err().contains("is invalid"));
        let mut bits = enc.clone();
        bits[12..16].copy_from_slice(&17u32.to_le_bytes());
        assert!(decode_rbfs(&bits).unwrap_err().contains("17 bits"));
        let mut old = vec![0u8; 16 + 32];
        old[4..8].copy_from_slice(&32u32.to_le_bytes());
        assert!(
            decode_rbfs(&old)
                .unwrap_err()
                .contains("bake the asset again")
        );
    }

    /// A layout-2 block (16 bits a channel, haze format 3) still decodes.
    #[test]
    fn layout_two_reads_at_sixteen_bits() {
        let (lo, hi) = ([0.0, 1.0, 2.0, 0.1, 0.0], [1.0, 3.0, 4.0, 0.5, 2.0]);
        // One RBF at level 0x8000 of every channel: just past the middle.
        let planes = [0x00u8, 0x80].repeat(CHANNELS);
        let coded = haze_core::coded::deflate(&planes);
        let mut b = Vec::new();
        for v in [1u32, 2, coded.len() as u32, 0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in lo.iter().chain(&hi) {
            b.extend_from_slice(&f64::to_le_bytes(*v));
        }
        b.extend_from_slice(&coded);
        let r = decode_rbfs(&b).unwrap();
        let t = 32768.0 / 65535.0;
        let want: Vec<f64> = (0..CHANNELS)
            .map(|c| lo[c] * (1.0 - t) + hi[c] * t)
            .collect();
        let got = channels(&r[0]);
        for c in 0..CHANNELS {
            assert!(
                (got[c] - want[c]).abs() < 1e-12,
                "channel {c}: {} vs {}",
                got[c],
                want[c]
            );
        }
    }
}
