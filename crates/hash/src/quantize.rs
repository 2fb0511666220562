//! Uniform quantization of a residual frame.
//!
//! With `b` bits and `q_max = 2^(b−1) − 1`, the step is `s = max|R| / q_max` (one scale
//! per frame: the residual's range differs a lot between frames of a growing plume, and a
//! per-group scale would waste bits on the quiet frames) and `q = round(R / s)`. Rounding
//! is its own dead zone: every `|R| < s/2` becomes exactly 0 — the sparsity the hash
//! exploits — and every voxel is reconstructed within `s/2`.

use serde::Serialize;

/// Smallest and largest supported bit depth.
pub const BITS: std::ops::RangeInclusive<u8> = 4..=16;

/// A quantized residual frame: the non-zero cells only.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Quantized {
    pub bits: u8,
    /// Dequantization step (density units); 0 for an all-zero residual.
    pub step: f32,
    /// `(voxel index, q)` for every `q ≠ 0`, ascending by index.
    #[serde(skip)]
    pub cells: Vec<(u32, i16)>,
    /// Largest and RMS reconstruction error over all voxels.
    pub max_error: f64,
    pub rms_error: f64,
}

/// Quantizes `residual` (x fastest, any length up to 2³² voxels) to `bits` bits.
pub fn quantize(residual: &[f32], bits: u8) -> Result<Quantized, String> {
    if !BITS.contains(&bits) {
        return Err(format!(
            "{bits} quantization bits is out of range ({}..={})",
            BITS.start(),
            BITS.end()
        ));
    }
    if residual.len() > u32::MAX as usize {
        return Err(format!(
            "{} voxels exceed the 2³² a frame may hold",
            residual.len()
        ));
    }
    if let Some(i) = residual.iter().position(|r| !r.is_finite()) {
        return Err(format!("residual voxel {i} is {}", residual[i]));
    }
    let qmax = f64::from((1u32 << (bits - 1)) - 1);
    let peak = residual
        .iter()
        .fold(0.0f64, |m, r| m.max(f64::from(r.abs())));
    let step = if peak > 0.0 {
        (peak / qmax) as f32
    } else {
        0.0
    };
    let mut cells = Vec::new();
    let (mut max_error, mut sq) = (0.0f64, 0.0f64);
    for (i, &r) in residual.iter().enumerate() {
        let q = if step > 0.0 {
            (f64::from(r) / f64::from(step)).round().clamp(-qmax, qmax) as i16
        } else {
            0
        };
        if q != 0 {
            cells.push((i as u32, q));
        }
        let e = (f64::from(r) - f64::from(q) * f64::from(step)).abs();
        max_error = max_error.max(e);
        sq += e * e;
    }
    let rms_error = if residual.is_empty() {
        0.0
    } else {
        (sq / residual.len() as f64).sqrt()
    };
    Ok(Quantized {
        bits,
        step,
        cells,
        max_error,
        rms_error,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_step_bound_and_dead_zone() {
        let r: Vec<f32> = (0..1000)
            .map(|i| ((i as f32) * 0.37).sin() * 0.3 * ((i % 7) as f32 / 7.0))
            .collect();
        for bits in [4, 6, 8, 10, 12, 16] {
            let q = quantize(&r, bits).unwrap();
            let s = f64::from(q.step);
            let mut dense = vec![0.0f64; r.len()];
            for &(i, v) in &q.cells {
                dense[i as usize] = f64::from(v) * s;
                assert!(i64::from(v).abs() < (1 << (bits - 1)));
            }
            for (a, b) in r.iter().zip(&dense) {
                // Half a step, plus f32 rounding of the step itself.
                assert!(
                    (f64::from(*a) - b).abs() <= 0.5 * s * (1.0 + 1e-6),
                    "bits {bits}"
                );
                if f64::from(a.abs()) < 0.5 * s * (1.0 - 1e-6) {
                    assert_eq!(*b, 0.0);
                }
            }
            assert!(q.max_error <= 0.5 * s * (1.0 + 1e-6) && q.rms_error <= q.max_error);
        }
    }

    #[test]
    fn extremes() {
        let z = quantize(&[0.0; 10], 8).unwrap();
        assert_eq!((z.step, z.cells.len(), z.max_error), (0.0, 0, 0.0));
        assert!(quantize(&[], 8).unwrap().cells.is_empty());
        assert!(quantize(&[1.0], 3).unwrap_err().contains("out of range"));
        assert!(quantize(&[1.0], 17).is_err());
        assert!(quantize(&[f32::NAN], 8).is_err());
        let one = quantize(&[-2.5, 0.0, 1e-30], 8).unwrap();
        assert_eq!(one.cells, vec![(0, -127)]);
    }
}
