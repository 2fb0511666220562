//! The error bound at every voxel of a real baked frame: fit plume-a frame 24, round the
//! RBFs to f32 as the asset stores them, quantize the residual at several errors, hash
//! it in bricks, and check `D̃ + R̂` against `D` everywhere.

use haze_fit::{FitOptions, SequenceFitter, SequenceOptions};
use haze_hash::tile::ResidualGroup;
use haze_hash::{BuildOptions, QuantOptions, quantize};
use haze_volume::{ImportOptions, Rbf, import, rbf};
use std::path::Path;

#[test]
fn reconstruction_is_within_the_error_everywhere() {
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
    let peak = v.data().iter().fold(0.0f32, |m, &d| m.max(d));
    for (error, brick) in [(0.0, 4), (1.0 / 255.0, 4), (1.0 / 255.0, 2), (0.02, 8)] {
        let q = quantize(&residual, peak, QuantOptions { error, bits: 8 }).unwrap();
        let g = ResidualGroup::build(
            dims,
            brick,
            std::slice::from_ref(&q),
            BuildOptions::default(),
        )
        .unwrap();
        let bound = error * f64::from(peak);
        let mut worst: f64 = 0.0;
        for (i, a) in approx.iter().enumerate() {
            let [x, y, z] = v.coords(i).map(|c| c as u32);
            let rec = a + f64::from(g.lookup(0, [x, y, z]));
            let err = (rec - f64::from(v.data()[i])).abs();
            worst = worst.max(err);
            // The error asked for, plus the f32 rounding of the residual (6e-8 of D).
            assert!(
                err <= bound + 1e-6,
                "error {error}: voxel {i} off by {err} (bound {bound})"
            );
        }
        assert!(worst <= q.max_error + 1e-6);
        if error > 0.0 {
            // Most voxels quantize to exactly zero (nothing is stored for them).
            assert!(q.cells.len() < v.len() / 2, "{} stored", q.cells.len());
        }
    }
}
