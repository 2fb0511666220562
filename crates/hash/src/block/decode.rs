//! Decoding the block's layout ([`super`] states it) into the tables a GPU uploads: the
//! whole group, its first frames, or frame after frame as the values' streams pass them.

use super::{
    FIXED, GAMMA, MAX_STREAMS, ONE_STREAM, VERSION, binarization, domain_cell, header_len,
};
use crate::context_coder;
use crate::pack::{self, Width};
use crate::psh::{BuildOptions, MAX_SIDE, PerfectHash};
use crate::quantize::{BITS, largest_value};
use crate::tile::{BRICK_SIDES, GROUP, ResidualGroup, bricks_per_frame, payload};
use haze_core::adaptive::{BitReader, Gamma, LEAST_BITS};
use rayon::prelude::*;
use std::slice::ChunksExact;
use std::sync::mpsc::{Receiver, sync_channel};

/// Decodes a residual-hash block into the group [`super::encode()`] was given, checking every
/// size and index against the block's own header.
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
    let mut o = open(bytes)?;
    // The bricks are listed frame by frame: those of the frames kept are a prefix.
    let kept = o.steps.len().min(through.saturating_add(1));
    let whole = kept == o.steps.len();
    let keys = &o.keys[..o.keys.partition_point(|&k| o.place(k).0 < kept)];
    let mut lists: Vec<Vec<(usize, [u32; 3])>> = vec![Vec::new(); o.readers.len()];
    for &k in keys {
        let (j, at) = o.place(k);
        if o.steps[j] != 0.0 {
            lists[o.stream_of(at)].push((j, at));
        }
    }
    // Where a brick lands in the hash depends on the bricks' places alone, so the hash is
    // built (and each brick's slot found) beside the streams' decoding, and each brick's
    // payload is written to its slot once it is packed.
    let readers = std::mem::take(&mut o.readers);
    let (hash, packed) = rayon::join(
        || hashed(o.domain, keys.iter().map(|&k| domain_cell(k, o.domain))),
        || {
            readers
                .into_par_iter()
                .zip(lists.par_iter())
                .map(|(mut io, list)| {
                    Packed::decode(&mut io, &mut o.decoder(), list.iter().copied(), o.words)
                })
                .collect::<Result<Vec<Packed>, _>>()
        },
    );
    drop(lists);
    let (mut hash, slots) = hash?;
    let places = keys.iter().map(|&k| o.place(k));
    let mut lossless = o.lossless.chunks_exact(4);
    let data = o.assemble(&o.steps, places, &slots, &mut hash, &packed?, &mut lossless)?;
    if whole && data.len() != o.words {
        return Err(format!(
            "residual block's bricks take {} data words of {}",
            data.len(),
            o.words
        ));
    }
    Ok(ResidualGroup {
        dims: o.dims,
        brick: o.brick,
        bits: o.bits,
        steps: o.steps[..kept].to_vec(),
        hash,
        data,
    })
}

/// Decodes the block frame after frame and hands each frame `j ≥ from` to `each` as a
/// group of its own — the group [`ResidualGroup::build`] makes of that frame alone, the
/// frame in its slot 0 — as soon as every value stream has passed it; a frame before
/// `from` is decoded (its values are the context of those after it) but not packed, and
/// `each` is told of it with `None` (so that a consumer gone can stop a long skip). Stops,
/// with no error, when `each` returns `false`.
///
/// Playback takes its frames this way: a frame waits for no frame after it, a volume's
/// decode is spread over its frames instead of coming at its start, and each frame's
/// tables hold its own bricks alone (a GPU uploads one frame, not the volume). The block's
/// header and keys are checked first, as [`decode`] checks them; values found damaged at a
/// frame are an error there, the frames before it handed over.
pub fn decode_frames(
    bytes: &[u8],
    from: usize,
    mut each: impl FnMut(usize, Option<ResidualGroup>) -> bool,
) -> Result<(), String> {
    let mut o = open(bytes)?;
    let readers = std::mem::take(&mut o.readers);
    let frames = o.steps.len();
    // The bricks are listed frame by frame: frame j's keys are keys[bounds[j]..bounds[j + 1]].
    let bounds: Vec<usize> = (0..=frames)
        .map(|j| o.keys.partition_point(|&k| o.place(k).0 < j))
        .collect();
    let (o, bounds) = (&o, &bounds);
    std::thread::scope(|scope| {
        // Each value stream decodes on a thread of its own, frame after frame, up to
        // `STREAM_AHEAD` frames ahead of the frame being packed: no stream waits for the
        // others at each frame's end.
        let streams: Vec<Receiver<Result<Packed, String>>> = readers
            .into_iter()
            .enumerate()
            .map(|(s, mut io)| {
                let (tx, rx) = sync_channel(STREAM_AHEAD);
                scope.spawn(move || {
                    let mut decoder = o.decoder();
                    for j in 0..frames {
                        let list: Vec<(usize, [u32; 3])> = o.keys[bounds[j]..bounds[j + 1]]
                            .iter()
                            .map(|&k| o.place(k))
                            .filter(|&(j, at)| o.steps[j] != 0.0 && o.stream_of(at) == s)
                            .collect();
                        let values =
                            Packed::decode(&mut io, &mut decoder, list.into_iter(), o.words);
                        let failed = values.is_err();
                        if tx.send(values).is_err() || failed {
                            return;
                        }
                    }
                });
                rx
            })
            .collect();
        let mut lossless = o.lossless.chunks_exact(4);
        let mut used = 0usize;
        for j in 0..frames {
            let mine = &o.keys[bounds[j]..bounds[j + 1]];
            // A frame alone lies in the first tile of its domain: its bricks' cells are
            // their places in the frame. Its hash is built while its values decode.
            let hash = (j >= from)
                .then(|| hashed(o.domain, mine.iter().map(|&k| o.place(k).1)))
                .transpose()?;
            let values = streams
                .iter()
                .map(|rx| {
                    rx.recv()
                        .unwrap_or_else(|_| Err("a value stream ended".into()))
                })
                .collect::<Result<Vec<Packed>, String>>()?;
            let Some(hash) = hash else {
                used += if o.steps[j] != 0.0 {
                    values.iter().map(|p| p.data.len()).sum()
                } else {
                    lossless.by_ref().take(o.per() * mine.len()).for_each(drop);
                    o.per() * mine.len()
                };
                if !each(j, None) {
                    return Ok(());
                }
                continue;
            };
            let g = o.frame_alone(j, mine, hash, &values, &mut lossless)?;
            used += g.data.len();
            if used > o.words {
                return Err(format!(
                    "residual block's bricks take more than its {} data words",
                    o.words
                ));
            }
            if !each(j, Some(g)) {
                return Ok(());
            }
        }
        if used != o.words {
            return Err(format!(
                "residual block's bricks take {used} data words of {}",
                o.words
            ));
        }
        Ok(())
    })
}

/// Frames a value stream decodes ahead of the frame being packed ([`decode_frames`]).
const STREAM_AHEAD: usize = 2;

/// The perfect hash of the bricks at `cells` of `domain`, in list order, and each brick's
/// slot (slots number under 2³²: the table's side is at most `MAX_SIDE`).
fn hashed(
    domain: [u32; 3],
    cells: impl Iterator<Item = [u32; 3]>,
) -> Result<(PerfectHash, Vec<u32>), String> {
    let places: Vec<([u32; 3], u32)> = cells.map(|p| (p, 0)).collect();
    let h = PerfectHash::build(domain, &places, BuildOptions::default())
        .map_err(|e| format!("residual block's bricks do not hash: {e}"))?;
    let slots = places.iter().map(|&(p, _)| h.slot(p) as u32).collect();
    Ok((h, slots))
}

/// A block whose header, streams' table and bricks' keys are read and checked: where every
/// way of decoding its values starts.
struct Opened<'a> {
    dims: [u32; 3],
    brick: u32,
    bits: u8,
    /// Each frame's quantization step (0: a lossless frame).
    steps: Vec<f32>,
    /// The whole group's data words.
    words: usize,
    /// The lossless frames' values, little-endian `f32` words, in list order.
    lossless: Vec<u8>,
    /// Each value stream's `x` end, in brick columns.
    ends: Vec<u32>,
    /// Each value stream's range decoder (the first one past the keys).
    readers: Vec<BitReader<'a>>,
    /// Every brick's key, frame after frame, ascending in each.
    keys: Vec<u32>,
    /// The tiled brick domain (three frames' bricks a side).
    domain: [u32; 3],
    version: u32,
}

impl Opened<'_> {
    /// Values a brick holds.
    fn per(&self) -> usize {
        self.brick.pow(3) as usize
    }

    /// Brick `k`'s frame slot and brick position in that frame.
    fn place(&self, k: u32) -> (usize, [u32; 3]) {
        super::place(k, self.domain, self.dims, self.brick)
    }

    /// The value stream of a lossy brick at brick position `at`: the slab of brick
    /// columns its `x` falls in.
    fn stream_of(&self, at: [u32; 3]) -> usize {
        self.ends.iter().position(|&e| at[0] < e).unwrap_or(0)
    }

    /// A value stream's decoder, its models fresh.
    fn decoder(&self) -> context_coder::Decoder {
        context_coder::Decoder::new(
            bricks_per_frame(self.dims, self.brick),
            self.brick,
            largest_value(self.bits),
            binarization(self.version),
        )
    }

    /// Frame `j` alone as [`ResidualGroup::build`] lays out a group of one frame: its
    /// bricks' keys `mine`, their hash over their places in the frame (the first tile of
    /// the domain) and each one's slot, its lossy bricks' values `packed` (its lossless
    /// ones' taken from `lossless`).
    fn frame_alone(
        &self,
        j: usize,
        mine: &[u32],
        (mut hash, slots): (PerfectHash, Vec<u32>),
        packed: &[Packed],
        lossless: &mut ChunksExact<'_, u8>,
    ) -> Result<ResidualGroup, String> {
        let places = mine.iter().map(|&k| (0, self.place(k).1));
        let steps = vec![self.steps[j]];
        let data = self.assemble(&steps, places, &slots, &mut hash, packed, lossless)?;
        Ok(ResidualGroup {
            dims: self.dims,
            brick: self.brick,
            bits: self.bits,
            steps,
            hash,
            data,
        })
    }

    /// The group's data: the bricks at `places` (frame slot in `steps`, brick position;
    /// list order) one after the other — a lossy brick's packed words taken from its
    /// stream's [`Packed`] in turn, a lossless one's `f32` words from `lossless` — each
    /// brick's payload written to its hash slot.
    fn assemble(
        &self,
        steps: &[f32],
        places: impl Iterator<Item = (usize, [u32; 3])>,
        slots: &[u32],
        hash: &mut PerfectHash,
        packed: &[Packed],
        lossless: &mut ChunksExact<'_, u8>,
    ) -> Result<Vec<u32>, String> {
        let per = self.per();
        let mut data = Vec::with_capacity(packed.iter().map(|p| p.data.len()).sum());
        let mut next = vec![0usize; packed.len()];
        for ((j, at), &slot) in places.zip(slots) {
            let first = data.len();
            let width = if steps[j] == 0.0 {
                for _ in 0..per {
                    let w = lossless
                        .next()
                        .ok_or("residual block's values are cut short")?;
                    data.push(u32::from_le_bytes([w[0], w[1], w[2], w[3]]));
                }
                Width::F32
            } else {
                let s = self.stream_of(at);
                let (from, width) = *packed[s]
                    .bricks
                    .get(next[s])
                    .ok_or("residual block's values are cut short")?;
                let from = from as usize;
                next[s] += 1;
                let n = width.words(per);
                if data.len() + n > self.words {
                    return Err(format!(
                        "residual block's bricks take more than its {} data words",
                        self.words
                    ));
                }
                data.extend_from_slice(&packed[s].data[from..from + n]);
                width
            };
            hash.payloads[slot as usize] = payload(first as u32, width);
        }
        Ok(data)
    }
}

/// Reads and checks a block's header, streams' table and keys, and inflates its lossless
/// values.
fn open(bytes: &[u8]) -> Result<Opened<'_>, String> {
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
        let (j, _) = super::place(k, domain, dims, brick);
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
    let place = |k: u32| super::place(k, domain, dims, brick);
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

    Ok(Opened {
        dims,
        brick,
        bits,
        steps,
        words,
        lossless,
        ends,
        readers,
        keys,
        domain,
        version,
    })
}

/// One stream's bricks decoded and packed, in the stream's list order: each brick's
/// first word in `data` and its width.
struct Packed {
    data: Vec<u32>,
    bricks: Vec<(u32, Width)>,
}

impl Packed {
    /// Decodes the lossy bricks `list` (frame slot, brick position) of one stream from
    /// `io` with `decoder` (its models carried from the stream's bricks before), refusing
    /// more than `words` data words in all.
    fn decode(
        io: &mut BitReader<'_>,
        decoder: &mut context_coder::Decoder,
        list: impl ExactSizeIterator<Item = (usize, [u32; 3])>,
        words: usize,
    ) -> Result<Packed, String> {
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
