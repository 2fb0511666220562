//! The RBF block: the Gaussian RBFs of one frame, quantized and entropy-coded.
//!
//! Payload (little-endian):
//!
//! ```text
//! u32 count, u32 layout (4), u32 coded bytes, u32 bits (5 bits a channel: bits_c at 5c)
//! f64 lo[5], hi[5]         each channel's range: center x, y, z, radius, weight
//! `coded bytes` range-coded (haze_core::adaptive): for each channel in that order, the
//!   `count` values' q = round(L (v − lo) / (hi − lo)), L = 2^bits_c − 1: the top
//!   min(bits_c, 4) bits through a binary tree of adaptive models (one tree a channel),
//!   the rest as equally likely bits
//! ```
//!
//! The top bits follow how the RBFs spread over each range (centers where the smoke is,
//! radii and weights skewed to one end); the low bits are noise.
//!
//! A value decodes to `lo (1 − t) + hi t`, `t = q / L` (the extremes exactly), so it
//! moves by at most `1/(2L)` of its channel's span. The encoder gives each channel the
//! fewest bits (at most 16, [`bits_for`]) that keep that move within a share of the RBFs'
//! own scale: a center within 1/32 of the smallest radius, a radius within 1/32 of the
//! smallest radius, a weight within 1/64 of the largest weight. A Gaussian of weight `w`
//! and radius `r` then changes by at most `0.86 w/32`, `0.74 w/32` and `w_max/64`
//! anywhere (its steepest slopes along the center and the radius are `√2 e^{−1/2} w/r`
//! and `2 e^{−1} w/r`): a few hundredths of the largest weight, well below the RBFs' own
//! misfit to the smoke (a tenth of the density or more), and the residual takes the
//! change: it is taken against the decoded RBFs, so the bake's error bound holds for the
//! reconstruction a reader makes, whatever the grid's size. On held-out frames of 72–104
//! voxels a side this is 9–10 bits a center, 6–7 a radius and 6 a weight (9–10 bytes an
//! RBF become 5.6–6.0); pictures lit from the RBFs move by less than 0.1 % (BENCHMARKS.md,
//! "Against established compressors"), and a 512-voxel grid with one-voxel radii takes 13
//! bits a center. World coordinates and density units. Anything computed from the RBFs
//! after the bake (the residual, lighting) must use the decoded values, which
//! [`decode_rbfs`] of [`encode_rbfs`] gives. Layout 3 (one bit count for every channel, 8
//! low bits raw; haze format 4) and layout 2 (16 bits a channel as zstd-coded byte planes,
//! haze format 3) still read; layout 1 (32-byte `f32` records, haze format 2) is refused
//! with a message to bake again.

use haze_core::adaptive::{Bit, BitIo, BitReader, BitWriter, LEAST_BITS};
use haze_volume::Rbf;

const PREFIX: usize = 16 + 2 * 8 * CHANNELS;
const CHANNELS: usize = 5;
const LAYOUT: u32 = 4;
/// The most bits a channel value is quantized to.
const MOST_BITS: u32 = 16;
/// A center or a radius moves by at most this share of the smallest radius.
const RADIUS_SHARE: f64 = 1.0 / 32.0;
/// A weight moves by at most this share of the largest weight.
const WEIGHT_SHARE: f64 = 1.0 / 64.0;
/// Bits of a value at the top that go through a tree of adaptive models (layout 4); the
/// bits below them are coded as equally likely.
const TREE: u32 = 4;
/// Layout 3's equally likely low bits.
const LAYOUT_3_LOW: u32 = 8;

/// The quantization's largest level at `bits`.
fn levels(bits: u32) -> f64 {
    f64::from((1u32 << bits) - 1)
}

/// The fewest bits (1 to 16; 16 when none suffices, 1 for a span of 0) with which a
/// value of a channel spanning `span` moves by at most `most`.
fn bits_for(span: f64, most: f64) -> u32 {
    (1..=MOST_BITS)
        .find(|&b| span / (2.0 * levels(b)) <= most)
        .unwrap_or(MOST_BITS)
}

/// Each channel's bits for RBFs whose channels span `lo..hi`.
fn channel_bits(lo: &[f64; CHANNELS], hi: &[f64; CHANNELS]) -> [u32; CHANNELS] {
    let center_span = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
    let center = bits_for(center_span, RADIUS_SHARE * lo[3]);
    [
        center,
        center,
        center,
        bits_for(hi[3] - lo[3], RADIUS_SHARE * lo[3]),
        bits_for(hi[4] - lo[4], WEIGHT_SHARE * hi[4].abs().max(lo[4].abs())),
    ]
}

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
    let bits = channel_bits(&lo, &hi);
    let mut io = BitWriter::new();
    for c in 0..CHANNELS {
        let span = hi[c] - lo[c];
        let top = levels(bits[c]);
        let high = bits[c].min(TREE);
        let mut tree = vec![Bit::default(); (1 << high) - 1];
        for r in rbfs {
            let v = channels(r)[c];
            let q = if span > 0.0 {
                ((v - lo[c]) / span * top).round().clamp(0.0, top) as u32
            } else {
                0
            };
            let _ = io.tree(&mut tree, high, q >> (bits[c] - high));
            let _ = io.raw(bits[c] - high, q);
        }
    }
    // A writer fails only on a bit it cannot code, and every bit here has a probability.
    let coded = io.finish().unwrap_or_default();
    let mut out = Vec::with_capacity(PREFIX + coded.len());
    let packed = (0..CHANNELS).fold(0, |w, c| w | bits[c] << (5 * c));
    for v in [n as u32, LAYOUT, coded.len() as u32, packed] {
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
    if !(2..=LAYOUT).contains(&layout) {
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
        (
            [65535.0; CHANNELS],
            sixteen_bit_planes(&bytes[PREFIX..], count)?,
        )
    } else {
        // Each channel's (tree bits, equally likely bits).
        let split: [(u32, u32); CHANNELS] = if layout == 3 {
            let bits = u(12);
            if !(LAYOUT_3_LOW + 1..=MOST_BITS).contains(&bits) {
                return Err(format!("RBF block of {bits} bits a channel"));
            }
            [(bits - LAYOUT_3_LOW, LAYOUT_3_LOW); CHANNELS]
        } else {
            let mut split = [(0, 0); CHANNELS];
            for (c, s) in split.iter_mut().enumerate() {
                let bits = (u(12) >> (5 * c)) & 31;
                if !(1..=MOST_BITS).contains(&bits) {
                    return Err(format!("RBF block of {bits} bits in channel {c}"));
                }
                *s = (bits.min(TREE), bits - bits.min(TREE));
            }
            split
        };
        // Every value codes one bit at least: a count the coded bytes cannot hold is
        // corrupt.
        if (count.saturating_mul(CHANNELS) as f64) * LEAST_BITS > (8 * coded + 64) as f64 {
            return Err(format!(
                "RBF block claims {count} RBFs in {coded} coded bytes"
            ));
        }
        let mut io = BitReader::new(&bytes[PREFIX..]).map_err(|e| format!("RBF block: {e}"))?;
        let mut q = vec![0u32; CHANNELS * count];
        for (c, &(high, low)) in split.iter().enumerate() {
            let mut tree = vec![Bit::default(); (1 << high) - 1];
            for k in 0..count {
                let top = io
                    .tree(&mut tree, high, 0)
                    .map_err(|e| format!("RBF block: {e}"))?;
                let rest = io.raw(low, 0).map_err(|e| format!("RBF block: {e}"))?;
                q[c * count + k] = top << low | rest;
            }
        }
        (split.map(|(high, low)| levels(high + low)), q)
    };
    let value = |c: usize, k: usize| {
        let t = f64::from(q[c * count + k]) / levels[c];
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
        for (c, bits) in bits_of(&enc).into_iter().enumerate() {
            let v: Vec<f64> = rbfs.iter().map(|r| channels(r)[c]).collect();
            let (lo, hi) = v
                .iter()
                .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
            let half = 0.5 * (hi - lo) / levels(bits) * (1.0 + 1e-9);
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
        bits[12..16].copy_from_slice(&(17u32 << 15 | 9 << 5).to_le_bytes());
        assert!(
            decode_rbfs(&bits)
                .unwrap_err()
                .contains("0 bits in channel 0")
        );
        let nine_but_17 = (0..5).fold(0u32, |w, c| w | if c == 2 { 17 } else { 9 } << (5 * c));
        bits[12..16].copy_from_slice(&nine_but_17.to_le_bytes());
        assert!(
            decode_rbfs(&bits)
                .unwrap_err()
                .contains("17 bits in channel 2")
        );
        let mut old = vec![0u8; 16 + 32];
        old[4..8].copy_from_slice(&32u32.to_le_bytes());
        assert!(
            decode_rbfs(&old)
                .unwrap_err()
                .contains("bake the asset again")
        );
    }

    /// Each channel's bits, as the block's header packs them.
    fn bits_of(enc: &[u8]) -> [u32; CHANNELS] {
        let w = u32::from_le_bytes(enc[12..16].try_into().unwrap());
        std::array::from_fn(|c| (w >> (5 * c)) & 31)
    }

    /// The encoder gives each channel the fewest bits that keep every decoded center and
    /// radius within 1/32 of the smallest radius and every weight within 1/64 of the
    /// largest, whatever the grid's span: checked on the decoded values, and one bit fewer
    /// would not do.
    #[test]
    fn channels_move_by_at_most_a_share_of_the_rbfs_scale() {
        for (span, radius, want) in [(2.0, 0.0625, 10), (64.0, 1.0, 11), (511.0, 1.0, 13)] {
            // Centers over [0, span]³ (both ends), radii from `radius` to `radius + 1`,
            // weights over [0, 1].
            let rbfs: Vec<Rbf> = (0..300)
                .map(|i| {
                    let t = (f64::from(i) * 0.618_034).fract();
                    let u = (f64::from(i) * 0.414_214).fract();
                    Rbf::new([span * t, span * u, span * (1.0 - t)], radius + u, t)
                })
                .chain([Rbf::new([span; 3], radius + 1.0, 1.0)])
                .collect();
            let enc = encode_rbfs(&rbfs);
            let bits = bits_of(&enc);
            assert_eq!(
                bits[..3],
                [want; 3],
                "span {span}, smallest radius {radius}"
            );
            let dec = decode_rbfs(&enc).unwrap();
            let worst = |c: usize| {
                rbfs.iter()
                    .zip(&dec)
                    .map(|(r, d)| (channels(r)[c] - channels(d)[c]).abs())
                    .fold(0.0, f64::max)
            };
            let most = [radius * RADIUS_SHARE; 4]
                .into_iter()
                .chain([WEIGHT_SHARE])
                .collect::<Vec<_>>();
            let spans = [span, span, span, 1.0, 1.0];
            for c in 0..CHANNELS {
                assert!(
                    worst(c) <= most[c],
                    "channel {c}: {} at {} bits",
                    worst(c),
                    bits[c]
                );
                assert!(spans[c] / (2.0 * levels(bits[c] - 1)) > most[c]);
            }
        }
        assert_eq!(bits_for(1.0, 0.0), 16);
        assert_eq!(bits_for(0.0, 0.0), 1);
        // One RBF: every span is 0, and it comes back exactly.
        let one = [Rbf::new([0.5, 1.5, 2.5], 0.125, 0.75)];
        assert_eq!(bits_of(&encode_rbfs(&one)), [1; CHANNELS]);
    }

    /// An RBF block of `count`, `layout` and the `bits` word, the channels' ranges and the
    /// coded values, as an older writer laid it out.
    fn block(
        [count, layout, bits]: [u32; 3],
        lo: &[f64; CHANNELS],
        hi: &[f64; CHANNELS],
        coded: &[u8],
    ) -> Vec<u8> {
        let mut b = Vec::new();
        for v in [count, layout, coded.len() as u32, bits] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in lo.iter().chain(hi) {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(coded);
        b
    }

    /// A layout-3 block (haze format 4: 12 bits a channel, the top 4 through a tree, the
    /// low 8 equally likely) still decodes.
    #[test]
    fn layout_three_reads() {
        let (lo, hi) = ([0.0, 1.0, 2.0, 0.1, 0.0], [1.0, 3.0, 4.0, 0.5, 2.0]);
        let levels_12 = [0u32, 4095, 1234];
        let mut io = BitWriter::new();
        for _ in 0..CHANNELS {
            let mut tree = vec![Bit::default(); 15];
            for &q in &levels_12 {
                io.tree(&mut tree, 4, q >> 8).unwrap();
                io.raw(8, q).unwrap();
            }
        }
        let mut b = block([3, 3, 12], &lo, &hi, &io.finish().unwrap());
        let r = decode_rbfs(&b).unwrap();
        for (k, &q) in levels_12.iter().enumerate() {
            let t = f64::from(q) / 4095.0;
            for c in 0..CHANNELS {
                let want = lo[c] * (1.0 - t) + hi[c] * t;
                assert!((channels(&r[k])[c] - want).abs() < 1e-12);
            }
        }
        b[12..16].copy_from_slice(&8u32.to_le_bytes());
        assert!(decode_rbfs(&b).unwrap_err().contains("8 bits a channel"));
    }

    /// A layout-2 block (16 bits a channel, haze format 3) still decodes.
    #[test]
    fn layout_two_reads_at_sixteen_bits() {
        let (lo, hi) = ([0.0, 1.0, 2.0, 0.1, 0.0], [1.0, 3.0, 4.0, 0.5, 2.0]);
        // One RBF at level 0x8000 of every channel: just past the middle.
        let planes = [0x00u8, 0x80].repeat(CHANNELS);
        let b = block([1, 2, 0], &lo, &hi, &haze_core::coded::deflate(&planes));
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
