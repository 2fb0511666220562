//! The residual-hash block of the asset: one [`ResidualGroup`] as flat little-endian
//! `u32` arrays, ready for a GPU upload.
//!
//! ```text
//! u32 layout version (2), bits, frames (1..=27), brick side
//! u32 dims[3], m̄, r̄, data words
//! f32 steps[27]                       (unused slots 0)
//! u32 offsets[r̄³]                     Φ, packed x | y << 10 | z << 20
//! u32 keys[m̄³]                        linear brick index in the hash domain + 1, 0 = empty
//! u32 payloads[m̄³]                    first data word << 3 | width code (haze_hash::pack)
//! u32 data[words]                     the bricks' packed values
//! ```
//!
//! Layout 1 (haze format 1: one hashed cell per voxel, `i8`/`i16` values) is refused with a
//! message that says to bake the asset again.

use crate::pack::Width;
use crate::psh::{MAX_SIDE, PerfectHash};
use crate::quantize::BITS;
use crate::tile::{BRICK_SIDES, GROUP, ResidualGroup, bricks_per_frame, unpayload};

const VERSION: u32 = 2;
const HEADER: usize = 4 * 10 + 4 * GROUP;

/// Encodes a hash volume.
pub fn encode(g: &ResidualGroup) -> Vec<u8> {
    let h = &g.hash;
    let mut out = Vec::with_capacity(HEADER + h.bytes() + 4 * g.data.len());
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
        g.data.len() as u32,
    ] {
        u(v);
    }
    for j in 0..GROUP {
        u(g.steps.get(j).copied().unwrap_or(0.0).to_bits());
    }
    for v in h
        .offsets
        .iter()
        .chain(&h.keys)
        .chain(&h.payloads)
        .chain(&g.data)
    {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

/// Decodes and validates a hash volume: every offset inside the table, every key inside
/// the domain and every brick's values inside the data, so lookups cannot leave their
/// arrays.
pub fn decode(bytes: &[u8]) -> Result<ResidualGroup, String> {
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    if bytes.len() >= 4 && u(0) == 1 {
        return Err(
            "residual block layout 1 (a cell hash, from haze format 1) is no longer read: bake the asset again"
                .to_string(),
        );
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
    let (m, r, words) = (u(28), u(32), u(36) as usize);
    if dims.iter().any(|&d| d == 0 || d > u32::MAX / 3)
        || m == 0
        || m > MAX_SIDE
        || r == 0
        || r > 1 << 11
    {
        return Err(format!(
            "residual block sizes are invalid (dims {dims:?}, m̄ {m}, r̄ {r})"
        ));
    }
    let steps: Vec<f32> = (0..frames).map(|j| f32::from_bits(u(40 + 4 * j))).collect();
    if steps.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err("residual block has an invalid quantization step".to_string());
    }
    let (nr, nm) = ((r as usize).pow(3), (m as usize).pow(3));
    let need = HEADER + 4 * (nr + 2 * nm + words);
    if bytes.len() != need {
        return Err(format!(
            "residual block of {} bytes does not match its tables (m̄ {m}, r̄ {r}, {words} data words: {need} bytes)",
            bytes.len()
        ));
    }
    let array = |start: usize, n: usize| -> Vec<u32> { (0..n).map(|k| u(start + 4 * k)).collect() };
    let offsets = array(HEADER, nr);
    if offsets.iter().any(|o| {
        [o & 1023, (o >> 10) & 1023, (o >> 20) & 1023]
            .iter()
            .any(|&c| c >= m)
    }) {
        return Err("residual block has an offset outside its table".to_string());
    }
    let keys = array(HEADER + 4 * nr, nm);
    let payloads = array(HEADER + 4 * (nr + nm), nm);
    let data = array(HEADER + 4 * (nr + 2 * nm), words);
    let domain = bricks_per_frame(dims, brick).map(|d| 3 * d);
    let cells = u64::from(domain[0]) * u64::from(domain[1]) * u64::from(domain[2]);
    let per = (brick * brick * brick) as usize;
    for (&k, &p) in keys.iter().zip(&payloads) {
        if k == 0 {
            continue;
        }
        if u64::from(k) > cells {
            return Err(format!("residual block has a key ({k}) outside its domain"));
        }
        let j = frame_of(k - 1, domain, dims, brick);
        let ok = j < frames
            && unpayload(p).is_some_and(|(w, width)| {
                (width == Width::F32) == (steps[j] == 0.0) && w as usize + width.words(per) <= words
            });
        if !ok {
            return Err(format!(
                "residual block has a brick payload ({p:#x}) outside its data"
            ));
        }
    }
    Ok(ResidualGroup {
        dims,
        brick,
        bits,
        steps,
        hash: PerfectHash {
            domain,
            m,
            r,
            offsets,
            keys,
            payloads,
        },
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

    #[test]
    fn groups_round_trip_and_damage_is_refused() {
        let g = group();
        let bytes = encode(&g);
        assert_eq!(decode(&bytes).unwrap(), g);
        assert!(decode(&bytes[..bytes.len() - 4]).is_err());
        assert!(decode(&bytes[..10]).is_err());
        let mut bad = bytes.clone();
        bad[HEADER..HEADER + 4].copy_from_slice(&0x3ff_u32.to_le_bytes());
        assert!(decode(&bad).unwrap_err().contains("offset outside"));
        let mut bad = bytes.clone();
        bad[4..8].copy_from_slice(&3u32.to_le_bytes());
        assert!(decode(&bad).is_err());
        // A payload pointing past the data.
        let nr = (g.hash.r as usize).pow(3);
        let nm = (g.hash.m as usize).pow(3);
        let slot = g.hash.keys.iter().position(|&k| k != 0).unwrap();
        let at = HEADER + 4 * (nr + nm + slot);
        let mut bad = bytes.clone();
        bad[at..at + 4].copy_from_slice(&(u32::MAX - 7).to_le_bytes());
        assert!(decode(&bad).unwrap_err().contains("outside its data"));
        // A key outside the domain.
        let at = HEADER + 4 * (nr + slot);
        let mut bad = bytes;
        bad[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode(&bad).unwrap_err().contains("outside its domain"));
    }

    #[test]
    fn layout_one_is_refused_clearly() {
        let mut old = vec![0u8; 200];
        old[0] = 1;
        assert!(decode(&old).unwrap_err().contains("bake the asset again"));
    }
}
