//! Encoding a [`ResidualGroup`] into the block's layout ([`super`] states it).

use super::{MAX_STREAMS, STREAM_NONZERO, VERSION, binarization, header_len, place};
use crate::context_coder;
use crate::pack::{self, Width};
use crate::quantize::largest_value;
use crate::tile::{ResidualGroup, bricks_per_frame, unpayload};
use haze_core::adaptive::{BitWriter, Gamma};
use rayon::prelude::*;

/// Encodes a hash volume (built by [`ResidualGroup::build`]).
pub fn encode(g: &ResidualGroup) -> Result<Vec<u8>, String> {
    encode_streams(g, STREAM_NONZERO, VERSION)
}

/// [`encode`] in `layout` (this one, or [`GAMMA`](super::GAMMA) to write what older builds wrote), a
/// stream for every `stream_nonzero` non-zero values.
pub(super) fn encode_streams(
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
