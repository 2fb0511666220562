//! The RBF block: the Gaussian RBFs of one frame, ready for GPU upload.
//!
//! Payload: `count: u32`, `stride: u32` (= 32), 8 reserved bytes, then `count` records of
//! eight little-endian `f32`: center x, y, z, radius, weight, and three zeros (two `vec4`s
//! in a storage buffer). World coordinates and density units. Values are rounded to `f32`
//! here: anything computed from the RBFs after the bake (the residual, lighting) must use
//! the decoded values.

use haze_volume::Rbf;

const PREFIX: usize = 16;
const STRIDE: usize = 32;

/// Encodes RBFs as an RBF-block payload.
pub fn encode_rbfs(rbfs: &[Rbf]) -> Vec<u8> {
    let mut out = Vec::with_capacity(PREFIX + STRIDE * rbfs.len());
    out.extend_from_slice(&(rbfs.len() as u32).to_le_bytes());
    out.extend_from_slice(&(STRIDE as u32).to_le_bytes());
    out.extend_from_slice(&[0u8; 8]);
    for r in rbfs {
        let v = [
            r.center[0],
            r.center[1],
            r.center[2],
            r.radius,
            r.weight,
            0.0,
            0.0,
            0.0,
        ];
        for x in v {
            out.extend_from_slice(&(x as f32).to_le_bytes());
        }
    }
    out
}

/// Decodes an RBF-block payload, checking its length and that every RBF is finite with a
/// positive radius.
pub fn decode_rbfs(bytes: &[u8]) -> Result<Vec<Rbf>, String> {
    if bytes.len() < PREFIX {
        return Err(format!("RBF block of {} bytes has no header", bytes.len()));
    }
    let u = |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let (count, stride) = (u(0) as usize, u(4) as usize);
    if stride != STRIDE {
        return Err(format!("RBF block stride {stride} (expected {STRIDE})"));
    }
    let need = count
        .checked_mul(STRIDE)
        .and_then(|n| n.checked_add(PREFIX));
    if need != Some(bytes.len()) {
        return Err(format!(
            "RBF block of {} bytes cannot hold {count} RBFs of {STRIDE} bytes",
            bytes.len()
        ));
    }
    let f = |i: usize| {
        f64::from(f32::from_le_bytes([
            bytes[i],
            bytes[i + 1],
            bytes[i + 2],
            bytes[i + 3],
        ]))
    };
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let o = PREFIX + k * STRIDE;
        let rbf = Rbf::new([f(o), f(o + 4), f(o + 8)], f(o + 12), f(o + 16));
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rbfs_round_trip_through_f32() {
        let rbfs = vec![
            Rbf::new([0.5, -1.25, 3.0], 0.0625, 0.75),
            Rbf::new([1e-3, 2.0, 4.0], 0.1, 1e-4),
        ];
        let enc = encode_rbfs(&rbfs);
        assert_eq!(enc.len(), 16 + 64);
        assert_eq!(
            decode_rbfs(&enc).unwrap(),
            rbfs.iter()
                .map(|r| {
                    let f = |x: f64| f64::from(x as f32);
                    Rbf::new(r.center.map(f), f(r.radius), f(r.weight))
                })
                .collect::<Vec<_>>()
        );
        assert_eq!(decode_rbfs(&encode_rbfs(&[])).unwrap(), vec![]);
        assert!(decode_rbfs(&enc[..enc.len() - 4]).is_err());
        let mut bad = enc.clone();
        bad[16 + 12..16 + 16].copy_from_slice(&0f32.to_le_bytes());
        assert!(decode_rbfs(&bad).unwrap_err().contains("RBF 0 is invalid"));
        let mut huge = enc;
        huge[0..4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(decode_rbfs(&huge).is_err());
    }
}
