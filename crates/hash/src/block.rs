//! The residual-hash block of the asset: one [`ResidualGroup`] as flat little-endian
//! arrays, ready for a GPU upload.
//!
//! ```text
//! u32 layout version (1), bits, frames (1..=27), reserved
//! u32 dims[3], m̄, r̄, reserved
//! f32 steps[27]                       (unused slots 0), then 4 bytes of padding
//! u32 offsets[r̄³]                     Φ, packed x | y << 10 | z << 20
//! u32 keys[m̄³]                        linear domain index + 1, 0 = empty
//! values[m̄³]: i8 when bits ≤ 8, else i16; zero-padded to 4 bytes
//! ```

use crate::psh::{MAX_SIDE, PerfectHash};
use crate::quantize::BITS;
use crate::tile::{GROUP, ResidualGroup};

const VERSION: u32 = 1;
const HEADER: usize = 4 * 10 + 4 * GROUP + 4;

/// Encodes a hash volume.
pub fn encode(g: &ResidualGroup) -> Vec<u8> {
    let h = &g.hash;
    let mut out = Vec::with_capacity(HEADER + h.bytes() + 2);
    let mut u = |v: u32| out.extend_from_slice(&v.to_le_bytes());
    for v in [VERSION, u32::from(g.bits), g.steps.len() as u32, 0] {
        u(v);
    }
    for v in [g.dims[0], g.dims[1], g.dims[2], h.m, h.r, 0] {
        u(v);
    }
    for j in 0..GROUP {
        u(g.steps.get(j).copied().unwrap_or(0.0).to_bits());
    }
    u(0);
    for v in h.offsets.iter().chain(&h.keys) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in &h.values {
        if g.bits <= 8 {
            // |q| ≤ 127 at 8 bits or fewer.
            out.push(*v as i8 as u8);
        } else {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    while out.len() % 4 != 0 {
        out.push(0);
    }
    out
}

/// Decodes and validates a hash volume (every offset inside the table, so lookups cannot
/// leave their arrays).
pub fn decode(bytes: &[u8]) -> Result<ResidualGroup, String> {
    if bytes.len() < HEADER {
        return Err(format!(
            "residual block of {} bytes has no header",
            bytes.len()
        ));
    }
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let (version, bits, frames) = (u(0), u(4), u(8) as usize);
    if version != VERSION {
        return Err(format!("residual block layout {version} is unknown"));
    }
    let bits = u8::try_from(bits)
        .ok()
        .filter(|b| BITS.contains(b))
        .ok_or(format!("{bits} bits"))?;
    if !(1..=GROUP).contains(&frames) {
        return Err(format!("residual block holds {frames} frames"));
    }
    let dims = [u(16), u(20), u(24)];
    let (m, r) = (u(28), u(32));
    if dims.iter().any(|&d| d == 0 || d > u32::MAX / 3) || m == 0 || m > MAX_SIDE || r == 0 {
        return Err(format!(
            "residual block sizes are invalid (dims {dims:?}, m̄ {m}, r̄ {r})"
        ));
    }
    let steps: Vec<f32> = (0..frames).map(|j| f32::from_bits(u(40 + 4 * j))).collect();
    if steps.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err("residual block has an invalid quantization step".to_string());
    }
    let (nr, nm) = ((r as usize).pow(3), (m as usize).pow(3));
    let vbytes = if bits <= 8 { 1 } else { 2 };
    let body = (nr + nm) * 4 + nm * vbytes;
    let need = HEADER + body.div_ceil(4) * 4;
    if r as usize > 1 << 11 || bytes.len() != need {
        return Err(format!(
            "residual block of {} bytes does not match its tables (m̄ {m}, r̄ {r}: {need} bytes)",
            bytes.len()
        ));
    }
    let words = |start: usize, n: usize| -> Vec<u32> { (0..n).map(|k| u(start + 4 * k)).collect() };
    let offsets = words(HEADER, nr);
    if offsets.iter().any(|o| {
        [o & 1023, (o >> 10) & 1023, (o >> 20) & 1023]
            .iter()
            .any(|&c| c >= m)
    }) {
        return Err("residual block has an offset outside its table".to_string());
    }
    let keys = words(HEADER + 4 * nr, nm);
    let vstart = HEADER + 4 * (nr + nm);
    let values = (0..nm)
        .map(|k| match vbytes {
            1 => i16::from(bytes[vstart + k] as i8),
            _ => i16::from_le_bytes([bytes[vstart + 2 * k], bytes[vstart + 2 * k + 1]]),
        })
        .collect();
    Ok(ResidualGroup {
        dims,
        bits,
        steps,
        hash: PerfectHash {
            domain: dims.map(|d| 3 * d),
            m,
            r,
            offsets,
            keys,
            values,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BuildOptions, quantize};

    #[test]
    fn groups_round_trip_and_damage_is_refused() {
        let r: Vec<f32> = (0..60)
            .map(|i| if i % 4 == 0 { i as f32 * 0.01 } else { 0.0 })
            .collect();
        let q = quantize(&r, 8).unwrap();
        let g = ResidualGroup::build([5, 4, 3], &[q.clone(), q], BuildOptions::default()).unwrap();
        let bytes = encode(&g);
        assert_eq!(bytes.len() % 4, 0);
        assert_eq!(decode(&bytes).unwrap(), g);
        assert!(decode(&bytes[..bytes.len() - 4]).is_err());
        assert!(decode(&bytes[..10]).is_err());
        let mut bad = bytes.clone();
        bad[HEADER..HEADER + 4].copy_from_slice(&0x3ff_u32.to_le_bytes());
        assert!(decode(&bad).unwrap_err().contains("offset outside"));
        let mut bad = bytes;
        bad[4..8].copy_from_slice(&3u32.to_le_bytes());
        assert!(decode(&bad).is_err());
    }
}
