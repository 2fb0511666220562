//! The half-step bound at every voxel of a real baked frame: fit plume-a frame 24, round
//! the RBFs to f32 as the asset stores them, quantize the residual, hash it, and check
//! `D̃ + R̂` against `D` everywhere.

use haze_fit::{FitOptions, SequenceFitter, SequenceOptions};
use haze_hash::tile::ResidualGroup;
use haze_hash::{BuildOptions, quantize};
use haze_volume::{ImportOptions, Rbf, import, rbf};
use std::path::Path;

#[test]
fn reconstruction_is_within_half_a_step_everywhere() {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/plume-a/vdb/fluid_data_0024.vdb");
    let v = import::import(&p, &ImportOptions::default()).unwrap();
    let mut fitter = SequenceFitter::new(SequenceOptions {
        rbfs: 120,
        fit: FitOptions {
            teleport: false,
            max_iterations: 150,
            ..FitOptions::default()
        },
        ..SequenceOptions::default()
    });
    let fit = fitter.fit(&v).unwrap();
    let f32ed: Vec<Rbf> = fit
        .rbfs
        .iter()
        .map(|r| {
            let f = |x: f64| f64::from(x as f32);
            Rbf::new(r.center.map(f), f(r.radius), f(r.weight))
        })
        .collect();
    let approx = rbf::evaluate_on_grid(v.dims(), v.bbox(), &f32ed);
    let residual: Vec<f32> = v
        .data()
        .iter()
        .zip(&approx)
        .map(|(d, a)| (f64::from(*d) - a) as f32)
        .collect();
    let dims = v.dims().map(|d| d as u32);
    for bits in [4, 8, 12] {
        let q = quantize(&residual, bits).unwrap();
        let g =
            ResidualGroup::build(dims, std::slice::from_ref(&q), BuildOptions::default()).unwrap();
        let half = 0.5 * f64::from(q.step);
        let mut worst: f64 = 0.0;
        for (i, a) in approx.iter().enumerate() {
            let [x, y, z] = v.coords(i).map(|c| c as u32);
            let rec = a + f64::from(g.lookup(0, [x, y, z]));
            let err = (rec - f64::from(v.data()[i])).abs();
            worst = worst.max(err);
            // Half a step, plus the f32 rounding of the residual (relative 6e-8 of D).
            assert!(
                err <= half + 1e-6,
                "bits {bits}: voxel {i} off by {err} (half step {half})"
            );
        }
        assert!(worst <= q.max_error + 1e-6);
        // Most voxels quantize to exactly zero (nothing is stored for them).
        assert!(
            q.cells.len() < v.len() / 2,
            "bits {bits}: {} stored",
            q.cells.len()
        );
    }
}
