//! Error-driven quantization of a residual frame (paper A §5.2, with the step chosen from
//! the error the user accepts rather than from a bit count).
//!
//! The user states `E`, the largest reconstruction error they accept as a fraction of the
//! frame's peak density `P`. With the target `t = E·P`, the step is `s = 2t` (rounded down
//! to the nearest `f32`) and `q = round(R / s)`: every voxel is reconstructed within
//! `s/2 ≤ t`, and every `|R| < s/2` becomes exactly 0 — the dead zone that makes the
//! residual sparse. Nothing is stored for those voxels, so a frame whose RBFs alone are
//! within `t` everywhere stores nothing at all.
//!
//! `bits` is the widest stored value (`|q| ≤ 2^(bits−1) − 1`). When the residual's
//! largest value needs more, the step widens to `max|R| / q_max` and the error bound with
//! it; [`Quantized::widened`] says so (the bake warns). `E = 0`, or a frame whose peak is
//! 0, is lossless: the non-zero residuals are kept as their `f32` values.

use serde::Serialize;

/// Smallest and largest supported storage width, in bits.
pub const BITS: std::ops::RangeInclusive<u8> = 4..=16;

/// The default error: 1/255 of the peak, what 8-bit density storage promises.
pub const DEFAULT_ERROR: f64 = 1.0 / 255.0;

/// What a frame's residual may cost in accuracy.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct QuantOptions {
    /// Largest absolute reconstruction error, as a fraction of the frame's peak density
    /// (`0` = lossless; `≥ 1` keeps hardly anything).
    pub error: f64,
    /// Widest stored value, in bits (4..=16).
    pub bits: u8,
}

impl Default for QuantOptions {
    fn default() -> Self {
        QuantOptions {
            error: DEFAULT_ERROR,
            bits: 8,
        }
    }
}

impl QuantOptions {
    /// Checks the ranges (one-line messages naming the flag's quantity).
    pub fn validate(&self) -> Result<(), String> {
        if !BITS.contains(&self.bits) {
            return Err(format!(
                "{} quantization bits is out of range ({}..={})",
                self.bits,
                BITS.start(),
                BITS.end()
            ));
        }
        if !(self.error.is_finite() && self.error >= 0.0) {
            return Err(format!(
                "residual error {} must be a finite fraction ≥ 0 of the peak density",
                self.error
            ));
        }
        Ok(())
    }
}

/// A quantized residual frame: the non-zero cells only.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Quantized {
    /// Widest stored value, in bits.
    pub bits: u8,
    /// Dequantization step (density units); 0 for a lossless frame.
    pub step: f32,
    /// The values are the residuals' `f32` bit patterns (`E = 0` or a zero peak).
    pub lossless: bool,
    /// `(voxel index, q)` for every stored voxel, ascending by index: `q ≠ 0`, or the
    /// `f32` bits of a non-zero residual when lossless.
    #[serde(skip)]
    pub cells: Vec<(u32, i32)>,
    /// The error asked for, in density units (`E` times the peak).
    pub target: f64,
    /// Largest `|R|`: the error of the RBFs alone.
    pub rbf_error: f64,
    /// The step had to widen past `2·target` for the values to fit `bits`.
    pub widened: bool,
    /// Largest and RMS reconstruction error over all voxels.
    pub max_error: f64,
    pub rms_error: f64,
}

/// The largest `|q|` a frame quantized for `bits` stores: `2^(bits−1) − 1`.
pub fn largest_value(bits: u8) -> u32 {
    (1u32 << (bits.clamp(1, 32) - 1)) - 1
}

/// The largest `f32` not above `x` (`x ≥ 0`, finite).
fn f32_at_most(x: f64) -> f32 {
    let s = x as f32;
    if f64::from(s) > x { s.next_down() } else { s }
}

/// Quantizes `residual` (x fastest, up to 2³² voxels) of a frame whose peak density is
/// `peak`.
pub fn quantize(residual: &[f32], peak: f32, opts: QuantOptions) -> Result<Quantized, String> {
    opts.validate()?;
    if residual.len() > u32::MAX as usize {
        return Err(format!(
            "{} voxels exceed the 2³² a frame may hold",
            residual.len()
        ));
    }
    if let Some(i) = residual.iter().position(|r| !r.is_finite()) {
        return Err(format!("residual voxel {i} is {}", residual[i]));
    }
    if !(peak.is_finite() && peak >= 0.0) {
        return Err(format!("peak density {peak} is not a finite value ≥ 0"));
    }
    let rbf_error = residual
        .iter()
        .fold(0.0f64, |m, r| m.max(f64::from(r.abs())));
    let target = opts.error * f64::from(peak);
    // A target too small to be a step (E = 0, a zero peak, or under f32's range): lossless.
    let step = f32_at_most(2.0 * target);
    if !(step.is_normal()) {
        let cells = residual
            .iter()
            .enumerate()
            .filter(|(_, r)| **r != 0.0)
            .map(|(i, r)| (i as u32, r.to_bits() as i32))
            .collect();
        return Ok(Quantized {
            bits: opts.bits,
            step: 0.0,
            lossless: true,
            cells,
            target,
            rbf_error,
            widened: false,
            max_error: 0.0,
            rms_error: 0.0,
        });
    }
    let qmax = f64::from(largest_value(opts.bits));
    let (step, widened) = if rbf_error / f64::from(step) > qmax + 0.5 {
        // The widest value cannot hold the largest residual at this step.
        ((rbf_error / qmax) as f32, true)
    } else {
        (step, false)
    };
    let s = f64::from(step);
    let mut cells = Vec::new();
    let (mut max_error, mut sq) = (0.0f64, 0.0f64);
    for (i, &r) in residual.iter().enumerate() {
        let q = (f64::from(r) / s).round().clamp(-qmax, qmax);
        if q != 0.0 {
            cells.push((i as u32, q as i32));
        }
        let e = (f64::from(r) - q * s).abs();
        max_error = max_error.max(e);
        sq += e * e;
    }
    let rms_error = if residual.is_empty() {
        0.0
    } else {
        (sq / residual.len() as f64).sqrt()
    };
    Ok(Quantized {
        bits: opts.bits,
        step,
        lossless: false,
        cells,
        target,
        rbf_error,
        widened,
        max_error,
        rms_error,
    })
}

impl Quantized {
    /// The dequantized value of a stored `q` (`f32(q)·step`, or the `f32` itself when
    /// lossless): what every reader of the asset computes.
    #[inline]
    pub fn value(&self, q: i32) -> f32 {
        if self.lossless {
            f32::from_bits(q as u32)
        } else {
            q as f32 * self.step
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts(error: f64, bits: u8) -> QuantOptions {
        QuantOptions { error, bits }
    }

    /// A residual with values over several orders of magnitude, both signs.
    fn wavy(n: usize) -> Vec<f32> {
        (0..n)
            .map(|i| ((i as f32) * 0.37).sin() * 0.3 * ((i % 7) as f32 / 7.0))
            .collect()
    }

    #[test]
    fn error_bound_and_dead_zone() {
        let r = wavy(1000);
        for e in [1e-4, 1.0 / 255.0, 0.01, 0.05] {
            let q = quantize(&r, 1.0, opts(e, 16)).unwrap();
            assert!(!q.widened && !q.lossless);
            assert!(f64::from(q.step) <= 2.0 * e && f64::from(q.step) > 2.0 * e * (1.0 - 1e-6));
            let mut dense = vec![0.0f64; r.len()];
            for &(i, v) in &q.cells {
                assert_ne!(v, 0);
                dense[i as usize] = f64::from(v) * f64::from(q.step);
            }
            let mut worst: f64 = 0.0;
            for (a, b) in r.iter().zip(&dense) {
                let err = (f64::from(*a) - b).abs();
                worst = worst.max(err);
                // The stated error, exactly (the step is rounded down to an f32).
                assert!(err <= e, "error {e}: {err}");
                if f64::from(a.abs()) < e * (1.0 - 1e-6) {
                    assert_eq!(*b, 0.0, "inside the dead zone");
                }
            }
            assert!((q.max_error - worst).abs() < 1e-12 && q.rms_error <= q.max_error);
        }
    }

    #[test]
    fn a_narrow_width_widens_the_step() {
        let r = wavy(1000);
        // max|R| ≈ 0.26; at E = 1e-3 the step 2e-3 needs |q| up to ~128: too wide for 4 bits.
        let q = quantize(&r, 1.0, opts(1e-3, 4)).unwrap();
        assert!(q.widened);
        assert!(q.cells.iter().all(|&(_, v)| v.abs() <= 7));
        assert!((f64::from(q.step) - q.rbf_error / 7.0).abs() < 1e-7);
        assert!(q.max_error <= 0.5 * f64::from(q.step) * (1.0 + 1e-6));
        // 16 bits hold it at the asked step (8 bits just miss: 0.257 / 2e-3 ≈ 128.5 steps).
        assert!(!quantize(&r, 1.0, opts(1e-3, 16)).unwrap().widened);
        assert!(quantize(&r, 1.0, opts(1e-3, 8)).unwrap().widened);
    }

    #[test]
    fn extremes() {
        // An all-zero residual stores nothing, at any error.
        for e in [0.0, 1.0 / 255.0, 2.0] {
            let z = quantize(&[0.0; 10], 1.0, opts(e, 8)).unwrap();
            assert!(z.cells.is_empty() && z.max_error == 0.0);
        }
        assert!(quantize(&[], 1.0, opts(0.01, 8)).unwrap().cells.is_empty());
        // E ≥ 1 with residuals under the peak: nothing stored, the RBFs meet the budget.
        let big = quantize(&[0.5, -0.9, 0.2], 1.0, opts(1.0, 8)).unwrap();
        assert!(big.cells.is_empty() && big.rbf_error <= big.target);
        // E = 0: lossless, the f32 values themselves.
        let exact = quantize(&[0.1, 0.0, -3e-9, 1e-30], 1.0, opts(0.0, 8)).unwrap();
        assert!(exact.lossless && exact.max_error == 0.0);
        let back: Vec<(u32, f32)> = exact
            .cells
            .iter()
            .map(|&(i, q)| (i, exact.value(q)))
            .collect();
        assert_eq!(back, vec![(0, 0.1), (2, -3e-9), (3, 1e-30)]);
        // A zero peak (empty frame) cannot scale an error: lossless too.
        assert!(quantize(&[1e-3], 0.0, opts(0.01, 8)).unwrap().lossless);
        // One non-zero voxel.
        let one = quantize(&[0.0, 0.0, 0.5], 1.0, opts(0.01, 8)).unwrap();
        assert_eq!(one.cells, vec![(2, 25)]);
        // Refused inputs.
        assert!(
            quantize(&[1.0], 1.0, opts(0.01, 3))
                .unwrap_err()
                .contains("out of range")
        );
        assert!(quantize(&[1.0], 1.0, opts(0.01, 17)).is_err());
        assert!(quantize(&[1.0], 1.0, opts(-0.1, 8)).is_err());
        assert!(quantize(&[1.0], 1.0, opts(f64::NAN, 8)).is_err());
        assert!(quantize(&[f32::NAN], 1.0, opts(0.01, 8)).is_err());
        assert!(quantize(&[1.0], f32::INFINITY, opts(0.01, 8)).is_err());
    }
}
