//! The residual-hash block of the asset: one [`ResidualGroup`], entropy-coded on disk and
//! decoded into the flat `u32` arrays a GPU uploads.
//!
//! A hash's key and payload tables are mostly empty slots, and every stored brick's slot
//! follows from its key and the offset table `Φ` (`h(p)`, [`crate::psh`]). So the block
//! stores `Φ`, the bricks as a list and their packed values, coded with zstd, and
//! [`decode`] puts every brick back in its slot: the decoded group is the one encoded,
//! table for table.
//!
//! ```text
//! u32 layout version (3), bits, frames (1..=27), brick side
//! u32 dims[3], m̄, r̄, data words, bricks, coded bytes
//! f32 steps[27]                       (unused slots 0)
//! zstd frame of `coded bytes`:
//!   u32 offsets[r̄³]                   Φ, packed x | y << 10 | z << 20
//!   u8  widths[bricks]                each brick's width code (haze_hash::pack)
//!   key deltas[bricks]                zigzag LEB128 varints: each brick's key (linear
//!                                     index in the hash domain + 1) minus the previous
//!                                     brick's (the first: minus 0)
//!   u32 data[data words]              the bricks' packed values, brick after brick
//! ```
//!
//! Bricks are listed in the order of their values in `data`, so a brick's payload (first
//! word, width) is the running sum of the words before it. Layouts 1 (a cell hash, haze
//! format 1) and 2 (the tables uncoded, haze format 2) are refused with a message that
//! says to bake the asset again.

use crate::pack::Width;
use crate::psh::{MAX_SIDE, PerfectHash};
use crate::quantize::BITS;
use crate::tile::{BRICK_SIDES, GROUP, ResidualGroup, bricks_per_frame, payload, unpayload};

const VERSION: u32 = 3;
const HEADER: usize = 4 * 12 + 4 * GROUP;

/// Encodes a hash volume.
pub fn encode(g: &ResidualGroup) -> Vec<u8> {
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
    let mut plain = Vec::with_capacity(4 * h.offsets.len() + 6 * bricks.len() + 4 * g.data.len());
    for o in &h.offsets {
        plain.extend_from_slice(&o.to_le_bytes());
    }
    let parts: Vec<(u32, Width)> = bricks
        .iter()
        .map(|&(p, _)| unpayload(p).unwrap_or((0, Width::F32)))
        .collect();
    plain.extend(parts.iter().map(|&(_, w)| w.code() as u8));
    let mut previous = 0i64;
    for &(_, k) in &bricks {
        let delta = i64::from(k) - previous;
        previous = i64::from(k);
        put_varint(&mut plain, ((delta << 1) ^ (delta >> 63)) as u64);
    }
    let mut words = 0u32;
    for &(first, width) in &parts {
        let n = width.words(per);
        let span = (first as usize)..(first as usize + n).min(g.data.len());
        for v in &g.data[span] {
            plain.extend_from_slice(&v.to_le_bytes());
        }
        words += n as u32;
    }
    let coded = haze_core::coded::deflate(&plain);
    let mut out = Vec::with_capacity(HEADER + coded.len());
    let mut u = |v: u32| out.extend_from_slice(&v.to_le_bytes());
    for v in [VERSION, u32::from(g.bits), g.steps.len() as u32, g.brick] {
        u(v);
    }
    for v in [
        g.dims[0],
        g.dims[1],
        g.dims[2],
        h.m,
        h.r,
        words,
        bricks.len() as u32,
        coded.len() as u32,
    ] {
        u(v);
    }
    for j in 0..GROUP {
        u(g.steps.get(j).copied().unwrap_or(0.0).to_bits());
    }
    out.extend_from_slice(&coded);
    out
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    loop {
        let b = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(b);
            return;
        }
        out.push(b | 0x80);
    }
}

/// A LEB128 varint at `at`, and where the next value starts; `None` past the end or
/// beyond 64 bits.
fn get_varint(bytes: &[u8], mut at: usize) -> Option<(u64, usize)> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let b = *bytes.get(at)?;
        at += 1;
        v |= u64::from(b & 0x7f) << shift;
        if b & 0x80 == 0 {
            return Some((v, at));
        }
    }
    None
}

/// Decodes and validates a hash volume: every offset inside the table, every key inside
/// the domain and its frames, every brick in a slot of its own, its width matching its
/// frame (`f32` exactly for a lossless frame) and its values inside the data, so lookups
/// cannot leave their arrays.
pub fn decode(bytes: &[u8]) -> Result<ResidualGroup, String> {
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    if bytes.len() >= 4 && (u(0) == 1 || u(0) == 2) {
        return Err(format!(
            "residual block layout {} (haze format {}) is no longer read: bake the asset again",
            u(0),
            u(0)
        ));
    }
    if bytes.len() < HEADER {
        return Err(format!(
            "residual block of {} bytes has no header",
            bytes.len()
        ));
    }
    let (version, bits, frames, brick) = (u(0), u(4), u(8) as usize, u(12));
    if version != VERSION {
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
    let dims = [u(16), u(20), u(24)];
    let (m, r, words, count, coded) = (u(28), u(32), u(36) as usize, u(40) as usize, u(44));
    if dims.iter().any(|&d| d == 0 || d > u32::MAX / 3)
        || m == 0
        || m > MAX_SIDE
        || r == 0
        || r > 1 << 11
        || m != PerfectHash::side_for(count)
    {
        return Err(format!(
            "residual block sizes are invalid (dims {dims:?}, m̄ {m}, r̄ {r}, {count} bricks)"
        ));
    }
    let steps: Vec<f32> = (0..frames).map(|j| f32::from_bits(u(48 + 4 * j))).collect();
    if steps.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err("residual block has an invalid quantization step".to_string());
    }
    if bytes.len() != HEADER + coded as usize {
        return Err(format!(
            "residual block of {} bytes does not match its header ({coded} coded bytes)",
            bytes.len()
        ));
    }
    let (nr, nm) = ((r as usize).pow(3), (m as usize).pow(3));
    // At most 10 bytes a key delta; a longer plain part is corrupt.
    let most = 4 * nr + 11 * count + 4 * words;
    let plain = haze_core::coded::inflate(&bytes[HEADER..], most)
        .map_err(|e| format!("residual block: {e}"))?;
    let word = |i: usize| u32::from_le_bytes([plain[i], plain[i + 1], plain[i + 2], plain[i + 3]]);
    if plain.len() < 4 * nr + count + 4 * words {
        return Err("residual block's coded part is too short".to_string());
    }
    let offsets: Vec<u32> = (0..nr).map(|k| word(4 * k)).collect();
    if offsets.iter().any(|o| {
        [o & 1023, (o >> 10) & 1023, (o >> 20) & 1023]
            .iter()
            .any(|&c| c >= m)
    }) {
        return Err("residual block has an offset outside its table".to_string());
    }
    let widths = &plain[4 * nr..4 * nr + count];
    let domain = bricks_per_frame(dims, brick).map(|d| 3 * d);
    let cells = u64::from(domain[0]) * u64::from(domain[1]) * u64::from(domain[2]);
    let per = (brick * brick * brick) as usize;
    let mut hash = PerfectHash {
        domain,
        m,
        r,
        offsets,
        keys: vec![0; nm],
        payloads: vec![0; nm],
    };
    let (mut at, mut key, mut first) = (4 * nr + count, 0i64, 0usize);
    for &code in widths {
        let (z, next) = get_varint(&plain, at).ok_or("residual block's brick list is cut short")?;
        at = next;
        key += ((z >> 1) as i64) ^ -((z & 1) as i64);
        if key < 1 || key as u64 > cells {
            return Err(format!(
                "residual block has a key ({key}) outside its domain"
            ));
        }
        let k = key as u32;
        let width = Width::from_code(u32::from(code))
            .ok_or(format!("residual block has a brick of width code {code}"))?;
        let j = frame_of(k - 1, domain, dims, brick);
        if j >= frames
            || (width == Width::F32) != (steps[j] == 0.0)
            || first + width.words(per) > words
        {
            return Err(format!(
                "residual block has a brick (key {k}, width {} bits) outside its frames or data",
                width.bits()
            ));
        }
        let slot = hash.slot(hash.cell_of_key(k));
        if hash.keys[slot] != 0 {
            return Err(format!("residual block has two bricks in slot {slot}"));
        }
        hash.keys[slot] = k;
        hash.payloads[slot] = payload(first as u32, width);
        first += width.words(per);
    }
    if first != words || plain.len() != at + 4 * words {
        return Err(format!(
            "residual block's bricks take {first} data words of {words}, in {} coded bytes",
            plain.len()
        ));
    }
    let data = (0..words).map(|k| word(at + 4 * k)).collect();
    Ok(ResidualGroup {
        dims,
        brick,
        bits,
        steps,
        hash,
        data,
    })
}

/// The frame slot whose tile holds brick `i` (linear index in the hash domain).
fn frame_of(i: u32, domain: [u32; 3], dims: [u32; 3], brick: u32) -> usize {
    let nb = bricks_per_frame(dims, brick);
    let p = [
        i % domain[0],
        (i / domain[0]) % domain[1],
        i / (domain[0] * domain[1]),
    ];
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

    /// The coded part of a block, decompressed.
    fn plain_of(bytes: &[u8]) -> Vec<u8> {
        zstd::bulk::decompress(&bytes[HEADER..], 1 << 20).unwrap()
    }

    /// `bytes` with its coded part replaced by `plain`, coded again.
    fn with_plain(bytes: &[u8], plain: &[u8]) -> Vec<u8> {
        let coded = zstd::bulk::compress(plain, 3).unwrap();
        let mut out = bytes[..HEADER].to_vec();
        out[44..48].copy_from_slice(&(coded.len() as u32).to_le_bytes());
        out.extend_from_slice(&coded);
        out
    }

    #[test]
    fn groups_round_trip_and_damage_is_refused() {
        let g = group();
        let bytes = encode(&g);
        assert_eq!(decode(&bytes).unwrap(), g);
        assert!(decode(&bytes[..bytes.len() - 4]).is_err());
        assert!(decode(&bytes[..10]).is_err());
        let mut bad = bytes.clone();
        bad[4..8].copy_from_slice(&3u32.to_le_bytes());
        assert!(decode(&bad).is_err());
        // Damaged coded bytes: zstd's frame check or the sizes catch them.
        let mut bad = bytes.clone();
        let mid = HEADER + (bytes.len() - HEADER) / 2;
        bad[mid] ^= 0x5a;
        assert!(decode(&bad).is_err());
        let plain = plain_of(&bytes);
        assert_eq!(decode(&with_plain(&bytes, &plain)).unwrap(), g);
        let nr = (g.hash.r as usize).pow(3);
        let count = g.hash.len();
        // An offset outside the table.
        let mut p = plain.clone();
        p[0..4].copy_from_slice(&0x3ff_u32.to_le_bytes());
        assert!(
            decode(&with_plain(&bytes, &p))
                .unwrap_err()
                .contains("offset outside")
        );
        // A width code that does not exist, and one that does not match its frame.
        let mut p = plain.clone();
        p[4 * nr] = 7;
        assert!(
            decode(&with_plain(&bytes, &p))
                .unwrap_err()
                .contains("width code 7")
        );
        let mut p = plain.clone();
        p[4 * nr] = Width::F32.code() as u8;
        assert!(
            decode(&with_plain(&bytes, &p))
                .unwrap_err()
                .contains("outside its frames")
        );
        // A second brick with the first one's key (delta 0): the same slot.
        let mut p = plain.clone();
        p[4 * nr + count + 1] = 0;
        let e = decode(&with_plain(&bytes, &p)).unwrap_err();
        assert!(e.contains("two bricks") || e.contains("data words"), "{e}");
        // A first key far outside the domain.
        let mut p = plain.clone();
        let at = 4 * nr + count;
        p.splice(at..at + 1, [0xfe, 0xff, 0xff, 0xff, 0x0f]);
        assert!(
            decode(&with_plain(&bytes, &p))
                .unwrap_err()
                .contains("outside its domain")
        );
        // Data words missing.
        let p = &plain[..plain.len() - 4];
        assert!(decode(&with_plain(&bytes, p)).is_err());
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
        let bytes = encode(&g);
        assert_eq!(decode(&bytes).unwrap(), g);
        let tables = g.hash.bytes() + 4 * g.data.len();
        assert!(bytes.len() < tables, "{} ≥ {tables}", bytes.len());
    }

    #[test]
    fn layout_two_is_refused_clearly() {
        let mut old = vec![0u8; 200];
        old[0] = 2;
        assert!(decode(&old).unwrap_err().contains("bake the asset again"));
    }

    #[test]
    fn layout_one_is_refused_clearly() {
        let mut old = vec![0u8; 200];
        old[0] = 1;
        assert!(decode(&old).unwrap_err().contains("bake the asset again"));
    }
}
