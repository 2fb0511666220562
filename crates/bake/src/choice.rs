//! Automatic choices of a bake and why, stored in the asset header (`extra.choices`)
//! for every reader: with `--target-error E` the residual error is chosen too.

use haze_volume::Volume;
use serde::Serialize;

/// The residual errors a choice considers, largest first (fractions of the peak).
pub const CANDIDATES: [f64; 6] = [
    16.0 / 255.0,
    8.0 / 255.0,
    4.0 / 255.0,
    2.0 / 255.0,
    1.0 / 255.0,
    0.5 / 255.0,
];

/// The share of the target error the stored residual may add.
pub const SHARE: f64 = 0.25;

/// A chosen residual error and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResidualChoice {
    /// `--residual-error`: a fraction of each frame's peak density.
    pub residual_error: f64,
    /// The bound on the stored density's rel_l2 it guarantees on the frame it was chosen on.
    pub bound: f64,
    pub why: String,
}

/// The largest candidate residual error `E_r` whose stored density `D̃ + R̂` is within
/// `SHARE · target` rel_l2 of `D` on frame `v`, by the quantizer's contract that every
/// voxel is reconstructed within `E_r · peak` (haze-hash `quantize`, unless its step had to
/// widen to fit the bits, which it warns of): `rel_l2 ≤ E_r · peak · √N / ‖D‖` over the
/// frame's `N` voxels. The residual then costs at most a quarter of the error the RBF
/// count was chosen for, and no finer steps (bytes) than that needs. The smallest
/// candidate when none meets it; `None` for an all-zero frame (any error is exact).
pub fn residual_error_for(v: &Volume, target: f64) -> Option<ResidualChoice> {
    let peak = f64::from(v.data().iter().fold(0.0f32, |m, &d| m.max(d)));
    let norm = v
        .data()
        .iter()
        .map(|&d| f64::from(d) * f64::from(d))
        .sum::<f64>()
        .sqrt();
    if !(peak > 0.0 && norm > 0.0) {
        return None;
    }
    let factor = peak * (v.len() as f64).sqrt() / norm;
    let goal = SHARE * target;
    let (error, met) = CANDIDATES
        .iter()
        .find(|&&e| e * factor <= goal)
        .map_or((CANDIDATES[CANDIDATES.len() - 1], false), |&e| (e, true));
    let bound = error * factor;
    let why = if met {
        format!(
            "target error {target}: residual error {:.1}/255 keeps the stored density within rel_l2 {bound:.4} ≤ {goal:.4} (a quarter of the target); {}",
            error * 255.0,
            match CANDIDATES.iter().rev().find(|&&e| e > error) {
                Some(&e) => format!("{:.1}/255 could reach {:.4}", e * 255.0, e * factor),
                None => "the coarsest considered".to_string(),
            }
        )
    } else {
        format!(
            "target error {target}: even residual error {:.1}/255 only guarantees rel_l2 {bound:.4} > {goal:.4}; the finest considered is used",
            error * 255.0
        )
    };
    Some(ResidualChoice {
        residual_error: error,
        bound,
        why,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_hash::{QuantOptions, quantize};
    use haze_volume::Bbox;

    fn puff(n: usize) -> Volume {
        let mut data = Vec::with_capacity(n * n * n);
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let c = |i: usize| -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                    let r2 = c(x) * c(x) + c(y) * c(y) + c(z) * c(z);
                    data.push((-r2 / 0.2).exp() as f32);
                }
            }
        }
        Volume::new([n; 3], Bbox::new([-1.0; 3], [1.0; 3]), data).unwrap()
    }

    /// The stored density's real rel_l2, quantizing the whole density as the residual of
    /// zero RBFs (the worst case: every voxel stored or dropped).
    fn stored_rel_l2(v: &Volume, error: f64) -> f64 {
        let peak = v.data().iter().fold(0.0f32, |m, &d| m.max(d));
        let q = quantize(v.data(), peak, QuantOptions { error, bits: 16 }).unwrap();
        let mut rec = vec![0.0f32; v.len()];
        for &(i, c) in &q.cells {
            rec[i as usize] = q.value(c);
        }
        let (mut diff, mut norm) = (0.0, 0.0);
        for (a, b) in rec.iter().zip(v.data()) {
            diff += (f64::from(*a) - f64::from(*b)).powi(2);
            norm += f64::from(*b).powi(2);
        }
        (diff / norm).sqrt()
    }

    #[test]
    fn the_choice_keeps_its_promise_and_is_the_largest_that_does() {
        let v = puff(16);
        for target in [0.05, 0.2, 0.5, 1.0] {
            let c = residual_error_for(&v, target).unwrap();
            let real = stored_rel_l2(&v, c.residual_error);
            assert!(
                real <= c.bound * (1.0 + 1e-6),
                "{target}: {real} > {}",
                c.bound
            );
            if c.bound <= SHARE * target {
                // The next coarser candidate's bound would break the promise.
                if let Some(&e) = CANDIDATES.iter().rev().find(|&&e| e > c.residual_error) {
                    assert!(e * c.bound / c.residual_error > SHARE * target);
                }
            } else {
                assert_eq!(c.residual_error, CANDIDATES[CANDIDATES.len() - 1]);
            }
        }
        // A looser target never asks for a finer residual.
        let a = residual_error_for(&v, 0.1).unwrap().residual_error;
        let b = residual_error_for(&v, 0.8).unwrap().residual_error;
        assert!(b >= a);
        let empty = Volume::new([4; 3], Bbox::new([0.0; 3], [1.0; 3]), vec![0.0; 64]).unwrap();
        assert!(residual_error_for(&empty, 0.1).is_none());
    }
}
