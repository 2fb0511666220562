//! The raw-volume block: one dense `f32` frame, uncompressed.
//!
//! Payload: `dims` as three little-endian `u32`, one reserved `u32` (0), then
//! `dims[0]·dims[1]·dims[2]` little-endian `f32`, x fastest. The world box is the asset's
//! (`Header::grid`).

use haze_volume::{Bbox, Volume};
use std::borrow::Cow;

/// Bytes before the samples.
const PREFIX: usize = 16;

/// Encodes a volume as a raw-volume payload.
pub fn encode_raw_volume(v: &Volume) -> Vec<u8> {
    let mut out = Vec::with_capacity(PREFIX + 4 * v.len());
    for d in v.dims() {
        out.extend_from_slice(&(d as u32).to_le_bytes());
    }
    out.extend_from_slice(&0u32.to_le_bytes());
    for x in v.data() {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out
}

/// A decoded raw-volume block; `data` borrows from the asset when it is aligned (always, for
/// files written by haze) and is copied otherwise.
#[derive(Debug)]
pub struct RawVolumeView<'a> {
    pub dims: [usize; 3],
    pub data: Cow<'a, [f32]>,
}

impl RawVolumeView<'_> {
    /// The frame as a volume over `bbox`.
    pub fn to_volume(&self, bbox: Bbox) -> Result<Volume, String> {
        Volume::new(self.dims, bbox, self.data.to_vec()).map_err(|e| e.to_string())
    }
}

/// Decodes a raw-volume payload, checking its length against its dims.
pub fn decode_raw_volume(bytes: &[u8]) -> Result<RawVolumeView<'_>, String> {
    if bytes.len() < PREFIX {
        return Err(format!("raw volume of {} bytes has no dims", bytes.len()));
    }
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let dims = [u(0), u(4), u(8)].map(|d| d as usize);
    let n = dims[0]
        .checked_mul(dims[1])
        .and_then(|n| n.checked_mul(dims[2]))
        .and_then(|n| n.checked_mul(4))
        .ok_or_else(|| format!("raw volume dims {dims:?} overflow"))?;
    let body = &bytes[PREFIX..];
    if body.len() != n {
        return Err(format!(
            "raw volume dims {dims:?} need {n} bytes of samples but the block has {}",
            body.len()
        ));
    }
    let data = if cfg!(target_endian = "little") {
        match bytemuck::try_cast_slice::<u8, f32>(body) {
            Ok(s) => Cow::Borrowed(s),
            Err(_) => Cow::Owned(decode_f32(body)),
        }
    } else {
        Cow::Owned(decode_f32(body))
    };
    Ok(RawVolumeView { dims, data })
}

fn decode_f32(body: &[u8]) -> Vec<f32> {
    body.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_volume_round_trips_and_rejects_bad_lengths() {
        let b = Bbox::new([0.0; 3], [1.0, 2.0, 3.0]);
        let data: Vec<f32> = (0..24).map(|i| i as f32 * 0.5 - 3.0).collect();
        let v = Volume::new([2, 3, 4], b, data).unwrap();
        let enc = encode_raw_volume(&v);
        let dec = decode_raw_volume(&enc).unwrap();
        assert_eq!(dec.dims, [2, 3, 4]);
        assert_eq!(dec.to_volume(b).unwrap(), v);
        assert!(decode_raw_volume(&enc[..enc.len() - 1]).is_err());
        assert!(decode_raw_volume(&enc[..10]).is_err());
        let mut huge = enc.clone();
        huge[0..4].copy_from_slice(&u32::MAX.to_le_bytes());
        huge[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_raw_volume(&huge).is_err());
    }
}
