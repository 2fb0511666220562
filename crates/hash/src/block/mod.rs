//! The residual-hash block of the asset: one [`ResidualGroup`](crate::tile::ResidualGroup), entropy-coded on disk and
//! decoded into the flat `u32` arrays a GPU uploads.
//!
//! A hash's key and payload tables are mostly empty slots, and every stored brick's slot
//! follows from its key and the offset table `Φ` (`h(p)`, [`crate::psh`]), which itself
//! follows from the bricks: [`ResidualGroup::build`](crate::tile::ResidualGroup::build) builds it from the brick list alone,
//! deterministically. So the block stores only the bricks, as a list, and their quantized
//! values, range-coded under adaptive models ([`haze_core::adaptive`]; the values under
//! their neighbours' mixed contexts, [`crate::context_coder`]); [`decode()`] packs every
//! brick again and builds the hash again from the same list with the same options: the
//! decoded group is the one encoded, table for table.
//!
//! ```text
//! u32 layout version (7), bits, frames (1..=27), brick side
//! u32 dims[3], m̄, data words, bricks, zstd bytes, range bytes
//! u32 streams S (1..=4), then per stream: its bricks' x end, its range bytes
//! f32 steps[frames]
//! `zstd bytes` (0 when no frame is lossless): a zstd frame of the lossless frames'
//!   bricks' `f32` values, in list order
//! `range bytes`: S range-coded streams, one after the other (their lengths sum to it)
//!   stream 0 starts with
//!   key deltas[bricks]                each brick's key (linear index in the hash domain
//!                                     + 1) minus the previous brick's (the first: minus
//!                                     0), zigzag, as adaptive Elias-gamma codes
//!   stream s: values                  the b³ quantized values of every lossy brick whose
//!                                     x position in its frame is below stream s's x end
//!                                     and not below stream s − 1's, in list order
//!                                     (context_coder, with models of its own)
//! ```
//!
//! The streams cut every frame into slabs of brick columns along `x`, the same for every
//! frame of the group (so a voxel's value in the frame before lies in its own stream).
//! Each stream's coder sees only its own bricks: a neighbour across a cut counts as
//! uncoded (0), and each stream learns its models alone. So the streams decode apart, on
//! as many cores as there are streams. A group is split only where its values are many
//! ([`STREAM_NONZERO`] non-zero values a stream), at cuts that share the non-zero values
//! out evenly. Layout 6 is layout 7 with each value's magnitude binarized as an
//! Elias-gamma code ([`Binarization`]), layout 5 is layout 6 without the streams' table,
//! one stream; both still decode.
//!
//! The values are coded frame after frame, each stream's models carried from one frame
//! to the next: [`decode_through`] decodes a volume's first frames without the rest, and
//! [`decode_frames`] hands each frame over, as a group of its own, as soon as every stream
//! has passed it (each stream on a thread of its own), so that playback never waits for a
//! whole volume. Encoding lives in `encode.rs`, decoding in `decode.rs`.
//!
//! Bricks are listed in the order of their values in `data` (frame by frame, bricks
//! ascending `z, y, x`), so a brick's payload (first word, width) is the running sum of
//! the words before it. A brick's width is not stored: it is the narrowest that holds
//! its values (as [`ResidualGroup::build`](crate::tile::ResidualGroup::build) packs them), or `f32` in a lossless frame.
//! Layouts 1 (a cell hash, haze format 1), 2 (the tables uncoded, haze format 2), 3
//! (values zstd-coded as packed words, haze format 3) and 4 (`Φ` stored, the values under
//! one context each, haze format 4) are refused with a message that says to bake the
//! asset again.

mod decode;
mod encode;

pub use decode::{decode, decode_frames, decode_through};
pub use encode::encode;

use crate::context_coder::Binarization;
use crate::tile::{bricks_per_frame, tile_origin};

const VERSION: u32 = 7;
/// The layout before the values' classes were coded from a pivot: still read, each
/// value's magnitude binarized as an Elias-gamma code.
const GAMMA: u32 = 6;
/// The layout before the values were split into streams: still read, as one stream of
/// gamma-binarized values.
const ONE_STREAM: u32 = 5;
/// The header's fixed words; the streams' table (layout 6) and the frames' steps follow.
const FIXED: usize = 4 * 12;
/// Most value streams a block splits into.
pub const MAX_STREAMS: usize = 4;
/// A group's non-zero values a stream holds at least before the group splits: about
/// 0.2 MB of coded values, a tenth of a second's decode on one core, so groups that
/// decode fast enough on one core stay one stream and pay no bytes for the split.
const STREAM_NONZERO: usize = 1 << 18;

/// The header's bytes for a block of `frames` frames and `streams` value streams in
/// layout `version`.
fn header_len(version: u32, frames: usize, streams: usize) -> usize {
    let table = if version == ONE_STREAM {
        0
    } else {
        4 + 8 * streams
    };
    FIXED + table + 4 * frames
}

/// How layout `version`'s values are binarized.
fn binarization(version: u32) -> Binarization {
    if version == VERSION {
        Binarization::Pivot
    } else {
        Binarization::Gamma
    }
}

/// Where brick `key` lies: its frame slot and its brick position in that frame.
fn place(key: u32, domain: [u32; 3], dims: [u32; 3], brick: u32) -> (usize, [u32; 3]) {
    let p = domain_cell(key, domain);
    let j = frame_of(p, dims, brick);
    let o = tile_origin(j, bricks_per_frame(dims, brick));
    (j, [0, 1, 2].map(|a| p[a] - o[a]))
}

/// The cell of the tiled brick domain whose key (linear index plus one) is `k`.
fn domain_cell(k: u32, domain: [u32; 3]) -> [u32; 3] {
    let i = k - 1;
    [
        i % domain[0],
        (i / domain[0]) % domain[1],
        i / (domain[0] * domain[1]),
    ]
}

/// The frame slot whose tile holds the brick at `p` in the hash domain.
fn frame_of(p: [u32; 3], dims: [u32; 3], brick: u32) -> usize {
    let nb = bricks_per_frame(dims, brick);
    let t = [0, 1, 2].map(|a| (p[a] / nb[a]) as usize);
    t[0] + 3 * t[1] + 9 * t[2]
}

#[cfg(test)]
mod tests {
    use super::encode::encode_streams;
    use super::*;
    use crate::psh::PerfectHash;
    use crate::tile::ResidualGroup;
    use crate::{BuildOptions, QuantOptions, quantize};

    fn group() -> ResidualGroup {
        let r: Vec<f32> = (0..60)
            .map(|i| if i % 4 == 0 { i as f32 * 0.01 } else { 0.0 })
            .collect();
        let q = quantize(
            &r,
            1.0,
            QuantOptions {
                error: 0.004,
                bits: 8,
            },
        )
        .unwrap();
        let exact = quantize(
            &r,
            1.0,
            QuantOptions {
                error: 0.0,
                bits: 8,
            },
        )
        .unwrap();
        ResidualGroup::build([5, 4, 3], 2, &[q, exact], BuildOptions::default()).unwrap()
    }

    /// The header's length of a coded block.
    fn header_of(bytes: &[u8]) -> usize {
        let streams = if u32_at(bytes, 0) == ONE_STREAM {
            1
        } else {
            u32_at(bytes, FIXED) as usize
        };
        header_len(u32_at(bytes, 0), u32_at(bytes, 8) as usize, streams)
    }

    /// The zstd part of a block (the lossless values), decompressed.
    fn plain_of(bytes: &[u8]) -> Vec<u8> {
        let (h, zipped) = (header_of(bytes), u32_at(bytes, 40) as usize);
        zstd::bulk::decompress(&bytes[h..h + zipped], 1 << 20).unwrap()
    }

    fn u32_at(bytes: &[u8], i: usize) -> u32 {
        u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap())
    }

    /// `bytes` with its zstd part replaced by `plain`, coded again (the rest kept).
    fn with_plain(bytes: &[u8], plain: &[u8]) -> Vec<u8> {
        let (h, zipped) = (header_of(bytes), u32_at(bytes, 40) as usize);
        let coded = zstd::bulk::compress(plain, 3).unwrap();
        let mut out = bytes[..h].to_vec();
        out[40..44].copy_from_slice(&(coded.len() as u32).to_le_bytes());
        out.extend_from_slice(&coded);
        out.extend_from_slice(&bytes[h + zipped..]);
        out
    }

    #[test]
    fn groups_round_trip_and_damage_is_refused() {
        let g = group();
        let bytes = encode(&g).unwrap();
        assert_eq!(decode(&bytes).unwrap(), g);
        assert!(decode(&bytes[..bytes.len() - 4]).is_err());
        assert!(decode(&bytes[..10]).is_err());
        let mut bad = bytes.clone();
        bad[4..8].copy_from_slice(&3u32.to_le_bytes());
        assert!(decode(&bad).is_err());
        // Damaged zstd bytes: zstd's frame check or the sizes catch them.
        let mut bad = bytes.clone();
        bad[header_of(&bytes) + 6] ^= 0x5a;
        assert!(decode(&bad).is_err());
        let plain = plain_of(&bytes);
        assert_eq!(decode(&with_plain(&bytes, &plain)).unwrap(), g);
        // Lossless words missing.
        let p = &plain[..plain.len() - 4];
        assert!(
            decode(&with_plain(&bytes, p))
                .unwrap_err()
                .contains("lossless")
        );
        // Damaged range-coded bytes decode to an error or to another group, never a
        // panic (the asset's CRC catches them before this is reached); the last word
        // holds the coder's slack, whose bits may decode the same.
        let zipped = u32_at(&bytes, 40) as usize;
        for at in header_of(&bytes) + zipped..bytes.len() - 4 {
            for flip in [0x01, 0x80, 0xff] {
                let mut bad = bytes.clone();
                bad[at] ^= flip;
                if let Ok(other) = decode(&bad) {
                    assert_ne!(other, g, "byte {at} ^ {flip:#x} changed nothing");
                }
            }
        }
    }

    /// What the decoder checks that the encoder can still write: a brick in a frame the
    /// block does not hold.
    #[test]
    fn impossible_tables_are_refused() {
        // The lossless second frame's bricks, in a block that says it holds one frame.
        let mut g = group();
        g.steps.truncate(1);
        assert!(
            decode(&encode(&g).unwrap())
                .unwrap_err()
                .contains("outside its frames")
        );
    }

    /// A header claiming more than its bytes can hold is refused before anything that
    /// size is allocated: a frame of 688 million bricks' rows (what a fuzzer found to
    /// exhaust memory), a hundred million bricks or data words in a few coded bytes.
    #[test]
    fn claims_beyond_the_bytes_are_refused_without_allocating() {
        let bytes = encode(&group()).unwrap();
        let mut tall = bytes.clone();
        tall[20..24].copy_from_slice(&0x2900_0008u32.to_le_bytes());
        assert!(decode(&tall).is_err());
        let mut many = bytes.clone();
        let count = 100_000_000u32;
        many[36..40].copy_from_slice(&count.to_le_bytes());
        many[28..32].copy_from_slice(&PerfectHash::side_for(count as usize).to_le_bytes());
        assert!(decode(&many).unwrap_err().contains("claims"));
        let mut words = bytes.clone();
        words[32..36].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&words).unwrap_err().contains("claims"));
        // Three sides each within the bound alone whose tiled domain overflows 64 bits
        // (what a fuzzer found: the product overflowed before it was compared).
        let mut wide = bytes.clone();
        for at in [16, 20, 24] {
            wide[at..at + 4].copy_from_slice(&(u32::MAX / 3).to_le_bytes());
        }
        assert!(decode(&wide).unwrap_err().contains("sizes are invalid"));
    }

    /// Values beyond what the group's bits allow cannot be encoded.
    #[test]
    fn values_beyond_the_bits_are_refused() {
        let mut g = group();
        g.bits = 4;
        assert!(encode(&g).unwrap_err().contains("exceeds"));
    }

    /// Every slot of the decoded tables matches the built ones on real-sized groups,
    /// lossless frames (f32 bricks) included, and the coded block is smaller than the
    /// tables it replaces.
    #[test]
    fn sparse_groups_decode_to_their_tables_and_code_smaller() {
        let dims = [24, 20, 16];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let frames: Vec<_> = (0..5)
            .map(|f| {
                let r: Vec<f32> = (0..n)
                    .map(|i| {
                        let hot = (i * 7 + f * 13) % 29 == 0 || (i / 97) % 11 == f;
                        if hot {
                            ((i % 23) as f32 - 11.0) * 0.003
                        } else {
                            0.0
                        }
                    })
                    .collect();
                let error = if f == 2 { 0.0 } else { 0.004 };
                quantize(&r, 1.0, QuantOptions { error, bits: 8 }).unwrap()
            })
            .collect();
        let g = ResidualGroup::build(dims, 4, &frames, BuildOptions::default()).unwrap();
        let bytes = encode(&g).unwrap();
        assert_eq!(decode(&bytes).unwrap(), g);
        let tables = g.bytes();
        assert!(bytes.len() < tables, "{} ≥ {tables}", bytes.len());
    }

    /// The frames up to each slot decode to the group built of those frames alone, table
    /// for table, in one stream and in four, a lossless frame and an empty one among
    /// them; past the last slot the whole group comes back.
    /// Five frames of a 40 × 12 × 12 grid in bricks of 4 — frame 1 lossless, frame 3 empty,
    /// the others' values `((i·a + f·b) mod m)·0.002 − c` — their group, and its block
    /// coded in one stream and in four.
    struct Five {
        dims: [u32; 3],
        frames: Vec<crate::Quantized>,
        g: ResidualGroup,
        one: Vec<u8>,
        split: Vec<u8>,
    }

    fn five((a, b, m, c): (usize, usize, usize, f32)) -> Five {
        let dims = [40, 12, 12];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let frames: Vec<_> = (0..5)
            .map(|f| {
                let r: Vec<f32> = (0..n)
                    .map(|i| match f {
                        3 => 0.0,
                        _ => ((i * a + f * b) % m) as f32 * 0.002 - c,
                    })
                    .collect();
                let error = if f == 1 { 0.0 } else { 0.004 };
                quantize(&r, 1.0, QuantOptions { error, bits: 8 }).unwrap()
            })
            .collect();
        let g = ResidualGroup::build(dims, 4, &frames, BuildOptions::default()).unwrap();
        let one = encode_streams(&g, usize::MAX, VERSION).unwrap();
        let split = encode_streams(&g, g.data.len() / 8, VERSION).unwrap();
        assert_eq!((u32_at(&one, FIXED), u32_at(&split, FIXED)), (1, 4));
        Five {
            dims,
            frames,
            g,
            one,
            split,
        }
    }

    #[test]
    fn a_prefix_of_the_frames_decodes_alone() {
        let Five {
            dims,
            frames,
            g,
            one,
            split,
        } = five((31, 7, 13, 0.01));
        for bytes in [&one, &split] {
            for j in 0..frames.len() {
                let want =
                    ResidualGroup::build(dims, 4, &frames[..=j], BuildOptions::default()).unwrap();
                let got = decode_through(bytes, j).unwrap();
                assert_eq!(got, want, "frames 0..={j}");
                assert_eq!(got.dense(j), g.dense(j), "slot {j}");
            }
            assert_eq!(decode_through(bytes, usize::MAX).unwrap(), g);
            assert_eq!(decode_through(bytes, frames.len()).unwrap(), g);
            // The whole block is still checked: a cut block is refused for any prefix.
            assert!(decode_through(&bytes[..bytes.len() - 4], 0).is_err());
        }
    }

    /// Frame after frame, each frame decodes to the group built of it alone (its slot 0),
    /// table for table, in one stream and in four, a lossless frame and an empty one among
    /// them; frames before `from` are passed over, the consumer can stop, and a block whose
    /// words do not add up is refused after the frames it does hold.
    #[test]
    fn frames_decode_one_after_another_each_alone() {
        let Five {
            dims,
            frames,
            g,
            one,
            split,
        } = five((37, 5, 11, 0.008));
        let alone: Vec<ResidualGroup> = frames
            .iter()
            .map(|f| {
                ResidualGroup::build(dims, 4, std::slice::from_ref(f), BuildOptions::default())
                    .unwrap()
            })
            .collect();
        for bytes in [&one, &split] {
            for from in [0, 3] {
                let (mut got, mut told) = (Vec::new(), Vec::new());
                decode_frames(bytes, from, |j, f| {
                    match f {
                        Some(f) => got.push((j, f)),
                        None => told.push(j),
                    }
                    true
                })
                .unwrap();
                assert_eq!(told, (0..from).collect::<Vec<_>>(), "passed over");
                assert_eq!(got.len(), frames.len() - from);
                for (j, f) in got {
                    assert_eq!(f, alone[j], "frame {j} from {from}");
                    assert_eq!(f.dense(0), g.dense(j), "frame {j} from {from}");
                }
            }
            let mut asked = Vec::new();
            decode_frames(bytes, 1, |j, f| {
                asked.push((j, f.is_some()));
                j < 2
            })
            .unwrap();
            assert_eq!(
                asked,
                [(0, false), (1, true), (2, true)],
                "stops after frame 2"
            );
            let mut asked = 0;
            decode_frames(bytes, 4, |_, _| {
                asked += 1;
                false
            })
            .unwrap();
            assert_eq!(asked, 1, "stops while passing over the first frames");
            assert!(decode_frames(&bytes[..bytes.len() - 4], 0, |_, _| true).is_err());
            let mut bad = bytes.clone();
            bad[32..36].copy_from_slice(&(u32_at(bytes, 32) + 1).to_le_bytes());
            let mut held = 0;
            let e = decode_frames(&bad, 0, |_, _| {
                held += 1;
                true
            })
            .unwrap_err();
            assert!(e.contains("data words"), "{e}");
            assert_eq!(held, frames.len(), "the frames before the fault");
            // Damage anywhere past the header: an error or frames, never a panic (on the
            // streams' threads either); where the whole decode refuses, so does this one
            // by its end.
            for at in (header_of(bytes)..bytes.len()).step_by(7) {
                let mut bad = bytes.clone();
                bad[at] ^= 0x5a;
                let whole = decode(&bad);
                let frames = decode_frames(&bad, 0, |_, _| true);
                assert!(whole.is_ok() || frames.is_err(), "byte {at}");
            }
        }
    }

    /// A group split into value streams decodes to the same tables as one stream, its
    /// streams cut where the non-zero values share out, and a damaged streams' table is
    /// refused; a layout 5 block (one stream, no table) still decodes.
    #[test]
    fn streams_decode_apart_to_the_same_group() {
        let dims = [40, 12, 12];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let frames: Vec<_> = (0..3)
            .map(|f| {
                let r: Vec<f32> = (0..n)
                    .map(|i| ((i * 31 + f * 7) % 13) as f32 * 0.002 - 0.01)
                    .collect();
                quantize(
                    &r,
                    1.0,
                    QuantOptions {
                        error: 0.004,
                        bits: 8,
                    },
                )
                .unwrap()
            })
            .collect();
        let g = ResidualGroup::build(dims, 4, &frames, BuildOptions::default()).unwrap();
        let one = encode_streams(&g, usize::MAX, VERSION).unwrap();
        assert_eq!(u32_at(&one, FIXED), 1);
        let nonzero = g.data.len(); // more than the non-zero values: 4 streams at a quarter
        let split = encode_streams(&g, nonzero / 8, VERSION).unwrap();
        assert_eq!(u32_at(&split, FIXED), 4);
        let ends: Vec<u32> = (0..4).map(|s| u32_at(&split, FIXED + 4 + 8 * s)).collect();
        assert_eq!(ends[3], 10, "{ends:?}");
        assert!(ends.windows(2).all(|w| w[0] < w[1]), "{ends:?}");
        assert_eq!(decode(&one).unwrap(), g);
        assert_eq!(decode(&split).unwrap(), g);
        // Streams learn apart and lose the neighbours across the cuts: more bytes (on a
        // group this small, 22 % more; BENCHMARKS.md has real groups).
        assert!(split.len() > one.len(), "{} vs {}", split.len(), one.len());
        for (at, value) in [(FIXED, 0u32), (FIXED, 5), (FIXED + 4, 0), (FIXED + 4, 11)] {
            let mut bad = split.clone();
            bad[at..at + 4].copy_from_slice(&value.to_le_bytes());
            assert!(decode(&bad).is_err(), "word {at} = {value}");
        }
        let mut bad = split.clone();
        let len = u32_at(&split, FIXED + 8);
        bad[FIXED + 8..FIXED + 12].copy_from_slice(&(len + 4).to_le_bytes());
        assert!(decode(&bad).unwrap_err().contains("streams table"));
        // Layout 6 (values binarized as gamma codes) and layout 5 (its one-stream block
        // without the table) still decode.
        let gamma = encode_streams(&g, nonzero / 8, GAMMA).unwrap();
        assert_eq!(u32_at(&gamma, 0), GAMMA);
        assert_eq!(decode(&gamma).unwrap(), g);
        let one = encode_streams(&g, usize::MAX, GAMMA).unwrap();
        let mut old = one[..FIXED].to_vec();
        old[0..4].copy_from_slice(&ONE_STREAM.to_le_bytes());
        old.extend_from_slice(&one[FIXED + 12..]);
        assert_eq!(decode(&old).unwrap(), g);
    }

    #[test]
    fn layouts_two_to_four_are_refused_clearly() {
        for layout in [2, 3, 4] {
            let mut old = vec![0u8; 200];
            old[0] = layout;
            assert!(decode(&old).unwrap_err().contains("bake the asset again"));
        }
    }

    #[test]
    fn layout_one_is_refused_clearly() {
        let mut old = vec![0u8; 200];
        old[0] = 1;
        assert!(decode(&old).unwrap_err().contains("bake the asset again"));
    }
}
