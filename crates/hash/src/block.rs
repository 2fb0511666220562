//! The residual-hash block of the asset: one [`ResidualGroup`], entropy-coded on disk and
//! decoded into the flat `u32` arrays a GPU uploads.
//!
//! A hash's key and payload tables are mostly empty slots, and every stored brick's slot
//! follows from its key and the offset table `Φ` (`h(p)`, [`crate::psh`]), which itself
//! follows from the bricks: [`ResidualGroup::build`] builds it from the brick list alone,
//! deterministically. So the block stores only the bricks, as a list, and their quantized
//! values, range-coded under adaptive models ([`haze_core::adaptive`]; the values under
//! their neighbours' mixed contexts, [`crate::context_coder`]); [`decode`] packs every
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
//! Bricks are listed in the order of their values in `data` (frame by frame, bricks
//! ascending `z, y, x`), so a brick's payload (first word, width) is the running sum of
//! the words before it. A brick's width is not stored: it is the narrowest that holds
//! its values (as [`ResidualGroup::build`] packs them), or `f32` in a lossless frame.
//! Layouts 1 (a cell hash, haze format 1), 2 (the tables uncoded, haze format 2), 3
//! (values zstd-coded as packed words, haze format 3) and 4 (`Φ` stored, the values under
//! one context each, haze format 4) are refused with a message that says to bake the
//! asset again.

use crate::context_coder::{self, Binarization};
use crate::pack::{self, Width};
use crate::psh::{BuildOptions, MAX_SIDE, PerfectHash};
use crate::quantize::{BITS, largest_value};
use crate::tile::{
    BRICK_SIDES, GROUP, ResidualGroup, bricks_per_frame, payload, tile_origin, unpayload,
};
use haze_core::adaptive::{BitReader, BitWriter, Gamma, LEAST_BITS};
use rayon::prelude::*;

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

/// Encodes a hash volume (built by [`ResidualGroup::build`]).
pub fn encode(g: &ResidualGroup) -> Result<Vec<u8>, String> {
    encode_streams(g, STREAM_NONZERO, VERSION)
}

/// [`encode`] in `layout` (this one, or [`GAMMA`] to write what older builds wrote), a
/// stream for every `stream_nonzero` non-zero values.
fn encode_streams(
    g: &ResidualGroup,
    stream_nonzero: usize,
    layout: u32,
) -> Result<Vec<u8>, String> {
    let h = &g.hash;
    // The bricks in the order of their values.
    let mut bricks: Vec<(u32, u32)> = h
        .keys
        .iter()
        .zip(&h.payloads)
        .filter(|(k, _)| **k != 0)
        .map(|(&k, &p)| (p, k))
        .collect();
    bricks.sort_unstable();
    let per = (g.brick * g.brick * g.brick) as usize;
    let mut keys = BitWriter::new();
    let mut deltas = Gamma::default();
    let mut previous = 0i64;
    for &(_, k) in &bricks {
        let delta = i64::from(k) - previous;
        previous = i64::from(k);
        deltas.code(&mut keys, ((delta << 1) ^ (delta >> 63)) as u64)?;
    }
    let mut lossless = Vec::new();
    let mut words = 0u32;
    // Each lossy brick's frame slot, place, first word, width and count of non-zero
    // values: its values are unpacked again as its stream codes them, so that they are
    // never all held as `i32` (a production-size volume holds millions of bricks).
    let mut coded: Vec<LossyBrick> = Vec::new();
    for &(p, k) in &bricks {
        let (first, width) =
            unpayload(p).ok_or_else(|| format!("brick {k} has an unknown width code"))?;
        let first = first as usize;
        let n = width.words(per);
        if first + n > g.data.len() {
            return Err(format!("brick {k} reaches past the group's data"));
        }
        if width == Width::F32 {
            for v in &g.data[first..first + n] {
                lossless.extend_from_slice(&v.to_le_bytes());
            }
        } else {
            let (j, at) = place(k, h.domain, g.dims, g.brick);
            let nonzero = (0..per)
                .filter(|&l| pack::get(&g.data, first, width, l) != 0)
                .count();
            coded.push(LossyBrick {
                j,
                at,
                first,
                width,
                nonzero,
            });
        }
        words += n as u32;
    }
    let nb = bricks_per_frame(g.dims, g.brick);
    let cuts = stream_cuts(&coded, nb[0], stream_nonzero);
    // The keys open the first stream; the streams are coded apart, at once.
    let mut keys = Some(keys);
    let writers: Vec<BitWriter> = (0..cuts.len())
        .map(|_| keys.take().unwrap_or_default())
        .collect();
    let streams = writers
        .into_par_iter()
        .enumerate()
        .map(|(s, mut w)| {
            let start = if s == 0 { 0 } else { cuts[s - 1] };
            let list = coded
                .iter()
                .filter(|c| (start..cuts[s]).contains(&c.at[0]))
                .map(|c| {
                    let values: Vec<i32> = (0..per)
                        .map(|l| pack::get(&g.data, c.first, c.width, l))
                        .collect();
                    (c.j, c.at, values)
                });
            context_coder::encode(
                &mut w,
                nb,
                g.brick,
                largest_value(g.bits),
                binarization(layout),
                list,
            )?;
            Ok((cuts[s], w.finish()?))
        })
        .collect::<Result<Vec<(u32, Vec<u8>)>, String>>()?;
    let ranged: usize = streams.iter().map(|(_, b)| b.len()).sum();
    let zipped = if lossless.is_empty() {
        Vec::new()
    } else {
        haze_core::coded::deflate(&lossless)
    };
    let header = header_len(layout, g.steps.len(), streams.len());
    let mut out = Vec::with_capacity(header + zipped.len() + ranged);
    let mut u = |v: u32| out.extend_from_slice(&v.to_le_bytes());
    for v in [layout, u32::from(g.bits), g.steps.len() as u32, g.brick] {
        u(v);
    }
    for v in [
        g.dims[0],
        g.dims[1],
        g.dims[2],
        h.m,
        words,
        bricks.len() as u32,
        zipped.len() as u32,
        ranged as u32,
        streams.len() as u32,
    ] {
        u(v);
    }
    for (end, bytes) in &streams {
        u(*end);
        u(bytes.len() as u32);
    }
    for s in &g.steps {
        u(s.to_bits());
    }
    out.extend_from_slice(&zipped);
    for (_, bytes) in &streams {
        out.extend_from_slice(bytes);
    }
    Ok(out)
}

/// A lossy brick as the encoder lists it: its frame slot and place in the frame, where its
/// packed values start in the volume's data and at what width, and how many are not zero.
struct LossyBrick {
    j: usize,
    at: [u32; 3],
    first: usize,
    width: Width,
    nonzero: usize,
}

/// The streams' x ends for the lossy bricks `coded` of frames `nbx` brick columns wide:
/// one stream for every `per_stream` non-zero values (at most [`MAX_STREAMS`]), cut
/// between columns where the running count of non-zero values passes each stream's even
/// share (fewer streams where one column holds several shares).
fn stream_cuts(coded: &[LossyBrick], nbx: u32, per_stream: usize) -> Vec<u32> {
    let mut columns = vec![0usize; nbx as usize];
    for c in coded {
        columns[c.at[0] as usize] += c.nonzero;
    }
    let total: usize = columns.iter().sum();
    let streams = (total / per_stream.max(1)).clamp(1, MAX_STREAMS);
    let mut cuts = Vec::with_capacity(streams);
    let mut sum = 0;
    for (c, n) in columns.iter().enumerate() {
        sum += n;
        if cuts.len() + 1 < streams && sum * streams >= (cuts.len() + 1) * total {
            cuts.push(c as u32 + 1);
        }
    }
    cuts.push(nbx);
    cuts.dedup();
    cuts
}

/// Decodes a residual-hash block into the group [`encode`] was given, checking every size
/// and index against the block's own header.
pub fn decode(bytes: &[u8]) -> Result<ResidualGroup, String> {
    decode_through(bytes, usize::MAX)
}

/// The group's frames `0..=through` (all of them when `through` reaches past its last): the
/// group [`ResidualGroup::build`] makes of those frames alone, its tables built from their
/// bricks. The values are coded frame after frame, so a frame's are decoded without those
/// after it: one frame early in a volume of 27 costs a fraction of the whole volume's
/// decode (`haze render --frame`, `haze export`). The whole block is checked as
/// [`decode`] checks it, but the values past frame `through` are not read.
pub fn decode_through(bytes: &[u8], through: usize) -> Result<ResidualGroup, String> {
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    if bytes.len() >= 4 && (1..=4).contains(&u(0)) {
        return Err(format!(
            "residual block layout {} (haze format {}) is no longer read: bake the asset again",
            u(0),
            u(0)
        ));
    }
    if bytes.len() < FIXED {
        return Err(format!(
            "residual block of {} bytes has no header",
            bytes.len()
        ));
    }
    let (version, bits, frames, brick) = (u(0), u(4), u(8) as usize, u(12));
    if ![VERSION, GAMMA, ONE_STREAM].contains(&version) {
        return Err(format!("residual block layout {version} is unknown"));
    }
    let bits = u8::try_from(bits)
        .ok()
        .filter(|b| BITS.contains(b))
        .ok_or(format!("residual block: {bits} bits"))?;
    if !(1..=GROUP).contains(&frames) {
        return Err(format!("residual block holds {frames} frames"));
    }
    if !BRICK_SIDES.contains(&brick) {
        return Err(format!("residual block: brick side {brick}"));
    }
    let streams = if version == ONE_STREAM {
        1
    } else if bytes.len() < FIXED + 4 {
        return Err("residual block has no streams' table".to_string());
    } else {
        u(FIXED) as usize
    };
    if !(1..=MAX_STREAMS).contains(&streams) {
        return Err(format!("residual block holds {streams} value streams"));
    }
    let header = header_len(version, frames, streams);
    if bytes.len() < header {
        return Err(format!(
            "residual block of {} bytes has no room for its {frames} steps",
            bytes.len()
        ));
    }
    let dims = [u(16), u(20), u(24)];
    let (m, words, count) = (u(28), u(32) as usize, u(36) as usize);
    let (zipped, ranged) = (u(40) as usize, u(44) as usize);
    // Keys are linear indices into the tiled brick domain: it must number under 2³² bricks.
    let tiled = bricks_per_frame(dims, brick).map(|d| 3 * u64::from(d));
    if dims.iter().any(|&d| d == 0 || d > u32::MAX / 3)
        || tiled[0].saturating_mul(tiled[1]).saturating_mul(tiled[2]) >= u64::from(u32::MAX)
        || m == 0
        || m > MAX_SIDE
        || m != PerfectHash::side_for(count)
    {
        return Err(format!(
            "residual block sizes are invalid (dims {dims:?}, m̄ {m}, {count} bricks)"
        ));
    }
    let steps: Vec<f32> = (0..frames)
        .map(|j| f32::from_bits(u(header - 4 * frames + 4 * j)))
        .collect();
    if steps.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err("residual block has an invalid quantization step".to_string());
    }
    if Some(bytes.len())
        != header
            .checked_add(zipped)
            .and_then(|v| v.checked_add(ranged))
    {
        return Err(format!(
            "residual block of {} bytes does not match its header ({zipped} + {ranged} coded bytes)",
            bytes.len()
        ));
    }
    // Every brick codes a key delta and every lossy brick b³ values, and a brick takes a
    // data word at least: what the bytes can hold bounds what the header may claim
    // (adaptive::LEAST_BITS).
    let per = (brick * brick * brick) as usize;
    let bits_held = (8 * ranged + 64) as f64 / LEAST_BITS;
    if count as f64 > bits_held || count > words || words > count * per {
        return Err(format!(
            "residual block claims {count} bricks and {words} data words in {ranged} coded bytes"
        ));
    }
    let lossless = if zipped == 0 {
        Vec::new()
    } else {
        haze_core::coded::inflate(&bytes[header..header + zipped], 4 * words)
            .map_err(|e| format!("residual block: {e}"))?
    };
    let wrap = |e: String| format!("residual block: {e}");
    let nb = bricks_per_frame(dims, brick);
    let table: Vec<(u32, usize)> = if version == ONE_STREAM {
        vec![(nb[0], ranged)]
    } else {
        (0..streams)
            .map(|s| (u(FIXED + 4 + 8 * s), u(FIXED + 8 + 8 * s) as usize))
            .collect()
    };
    let ends: Vec<u32> = table.iter().map(|t| t.0).collect();
    if ends.windows(2).any(|w| w[0] >= w[1])
        || ends[0] == 0
        || ends.last() != Some(&nb[0])
        || table.iter().map(|t| t.1).sum::<usize>() != ranged
    {
        return Err(format!(
            "residual block's streams table is invalid ({table:?} for {} brick columns, {ranged} bytes)",
            nb[0]
        ));
    }
    let mut readers = Vec::with_capacity(streams);
    let mut at = header + zipped;
    for &(_, len) in &table {
        readers.push(BitReader::new(&bytes[at..at + len]).map_err(wrap)?);
        at += len;
    }
    let io = &mut readers[0];
    let domain = bricks_per_frame(dims, brick).map(|d| 3 * d);
    let cells = u64::from(domain[0]) * u64::from(domain[1]) * u64::from(domain[2]);
    let mut deltas = Gamma::default();
    let mut key = 0i64;
    // Each brick's key alone (4 bytes; its frame and place are found from it again where
    // they are needed): a production-size volume holds millions of bricks.
    let mut keys: Vec<u32> = Vec::with_capacity(count);
    let mut last: Option<(usize, u32)> = None;
    for _ in 0..count {
        let z = deltas.code(io, 0).map_err(wrap)?;
        key = key.saturating_add(((z >> 1) as i64) ^ -((z & 1) as i64));
        if key < 1 || key as u64 > cells {
            return Err(format!(
                "residual block has a key ({key}) outside its domain"
            ));
        }
        let k = key as u32;
        let (j, _) = place(k, domain, dims, brick);
        if j >= frames {
            return Err(format!(
                "residual block has a brick (key {k}) outside its frames"
            ));
        }
        // Frame by frame, each frame's bricks ascending: no brick twice.
        if last.is_some_and(|l| (j, k) <= l) {
            return Err(format!("residual block lists brick {k} out of order"));
        }
        last = Some((j, k));
        keys.push(k);
    }
    let place = |k: u32| place(k, domain, dims, brick);
    let lossy = keys.iter().filter(|&&k| steps[place(k).0] != 0.0).count();
    if (lossy * per) as f64 > bits_held {
        return Err(format!(
            "residual block claims {lossy} lossy bricks in {ranged} coded bytes"
        ));
    }
    if lossless.len() != 4 * per * (count - lossy) {
        return Err(format!(
            "residual block holds {} bytes of lossless values for {} lossless bricks",
            lossless.len(),
            count - lossy
        ));
    }
    let limit = largest_value(bits);
    // The bricks are listed frame by frame: those of the frames kept are a prefix.
    let kept = frames.min(through.saturating_add(1));
    let whole = kept == frames;
    keys.truncate(keys.partition_point(|&k| place(k).0 < kept));
    let steps = steps[..kept].to_vec();
    // A lossy brick's stream: the slab of brick columns its `x` falls in.
    let stream_of = |at: [u32; 3]| ends.iter().position(|&e| at[0] < e).unwrap_or(0);
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); streams];
    for &k in &keys {
        let (j, at) = place(k);
        if steps[j] != 0.0 {
            lists[stream_of(at)].push(k);
        }
    }
    let how = binarization(version);
    // Where a brick lands in the hash depends on the bricks' places alone, so the hash is
    // built (and each brick's slot found) beside the streams' decoding, and each brick's
    // payload is written to its slot once it is packed.
    let (hash, packed) = rayon::join(
        || {
            let places: Vec<([u32; 3], u32)> =
                keys.iter().map(|&k| (domain_cell(k, domain), 0)).collect();
            PerfectHash::build(domain, &places, BuildOptions::default()).map(|h| {
                // Slots number under 2³² (the table's side is at most `MAX_SIDE`).
                let slots: Vec<u32> = places.iter().map(|&(p, _)| h.slot(p) as u32).collect();
                (h, slots)
            })
        },
        || {
            readers
                .into_par_iter()
                .zip(lists.par_iter())
                .map(|(mut io, list)| {
                    let list = list.iter().map(|&k| place(k));
                    Packed::decode(&mut io, nb, brick, limit, how, list, words)
                })
                .collect::<Result<Vec<Packed>, _>>()
        },
    );
    drop(lists);
    let (mut hash, slots) =
        hash.map_err(|e| format!("residual block's bricks do not hash: {e}"))?;
    let packed = packed?;
    let mut data = Vec::with_capacity(words);
    let mut next_lossless = lossless.chunks_exact(4);
    let mut next = vec![0usize; streams];
    for (&k, &slot) in keys.iter().zip(&slots) {
        let (j, at) = place(k);
        let first = data.len();
        let width = if steps[j] == 0.0 {
            for _ in 0..per {
                let w = next_lossless
                    .next()
                    .ok_or("residual block's values are cut short")?;
                data.push(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
            }
            Width::F32
        } else {
            let s = stream_of(at);
            let (from, width) = packed[s].bricks[next[s]];
            let from = from as usize;
            next[s] += 1;
            let n = width.words(per);
            if data.len() + n > words {
                return Err(format!(
                    "residual block's bricks take more than its {words} data words"
                ));
            }
            data.extend_from_slice(&packed[s].data[from..from + n]);
            width
        };
        hash.payloads[slot as usize] = payload(first as u32, width);
    }
    if whole && data.len() != words {
        return Err(format!(
            "residual block's bricks take {} data words of {words}",
            data.len()
        ));
    }
    Ok(ResidualGroup {
        dims,
        brick,
        bits,
        steps,
        hash,
        data,
    })
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

/// One stream's bricks decoded and packed, in the stream's list order: each brick's
/// first word in `data` and its width.
struct Packed {
    data: Vec<u32>,
    bricks: Vec<(u32, Width)>,
}

impl Packed {
    /// Decodes the lossy bricks `list` (frame slot, brick position) of one stream from
    /// `io`, refusing more than `words` data words in all.
    fn decode(
        io: &mut BitReader<'_>,
        nb: [u32; 3],
        brick: u32,
        limit: u32,
        how: Binarization,
        list: impl ExactSizeIterator<Item = (usize, [u32; 3])>,
        words: usize,
    ) -> Result<Packed, String> {
        let mut decoder = context_coder::Decoder::new(nb, brick, limit, how);
        let mut out = Packed {
            data: Vec::new(),
            bricks: Vec::with_capacity(list.len()),
        };
        for (j, at) in list {
            let values = decoder
                .brick(io, j, at)
                .map_err(|e| format!("residual block's values: {e}"))?;
            let width = Width::narrowest(values);
            // `data` holds at most `words < 2³²` words (checked below, brick by brick).
            out.bricks.push((out.data.len() as u32, width));
            pack::pack_into(values, width, &mut out.data);
            if out.data.len() > words {
                return Err(format!(
                    "residual block's bricks take more than its {words} data words"
                ));
            }
        }
        Ok(out)
    }
}

/// The frame slot whose tile holds the brick at `p` in the hash domain.
fn frame_of(p: [u32; 3], dims: [u32; 3], brick: u32) -> usize {
    let nb = bricks_per_frame(dims, brick);
    let t = [0, 1, 2].map(|a| (p[a] / nb[a]) as usize);
    t[0] + 3 * t[1] + 9 * t[2]
}

#[cfg(test)]
mod tests {
    use super::*;
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
    #[test]
    fn a_prefix_of_the_frames_decodes_alone() {
        let dims = [40, 12, 12];
        let n = (dims[0] * dims[1] * dims[2]) as usize;
        let frames: Vec<_> = (0..5)
            .map(|f| {
                let r: Vec<f32> = (0..n)
                    .map(|i| match f {
                        3 => 0.0,
                        _ => ((i * 31 + f * 7) % 13) as f32 * 0.002 - 0.01,
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
