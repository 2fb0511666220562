//! The analytic gradient against central finite differences, on a real frame.

use haze_fit::FitGrid;
use haze_fit::objective::{cost, cost_and_gradient};
use haze_volume::{ImportOptions, import};
use std::path::Path;

fn frame24() -> FitGrid {
    let p =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/plume-a/vdb/fluid_data_0024.vdb");
    FitGrid::from_volume(&import::import(&p, &ImportOptions::default()).unwrap()).unwrap()
}

#[test]
fn gradient_matches_central_differences_on_every_parameter_kind() {
    let g = frame24();
    // Eight RBFs on the densest voxels, varied radii and weights.
    let mut idx: Vec<usize> = (0..g.len()).collect();
    idx.sort_by(|a, b| g.density[*b].total_cmp(&g.density[*a]));
    let mut params = Vec::new();
    for (k, &i) in idx.iter().step_by(997).take(8).enumerate() {
        let c = g.center(i);
        // Off-grid centers so that no voxel sits on a symmetry plane.
        params.extend_from_slice(&[
            c[0] + 0.0031 * k as f64,
            c[1] - 0.0017,
            c[2] + 0.0023,
            0.03 + 0.008 * k as f64,
            0.2 + 0.09 * k as f64,
        ]);
    }
    let mut grad = vec![0.0; params.len()];
    let f0 = cost_and_gradient(&g, &params, &mut grad);
    assert!((f0 - cost(&g, &params)).abs() < 1e-14);
    // The 3r cut-off makes f jump by O(w·e⁻⁹) where a voxel center crosses a support
    // sphere; a difference step that straddles such a crossing measures the jump, not the
    // slope. Steps of three sizes are tried: a smooth point agrees at every size, and at
    // most one can straddle a crossing of a given voxel.
    let mut worst: f64 = 0.0;
    for j in 0..params.len() {
        let err = [1e-6, 3e-7, 1e-7]
            .iter()
            .map(|&h| {
                let mut p = params.clone();
                p[j] += h;
                let fp = cost(&g, &p);
                p[j] -= 2.0 * h;
                let fm = cost(&g, &p);
                let fd = (fp - fm) / (2.0 * h);
                (fd - grad[j]).abs() / grad[j].abs().max(1e-3)
            })
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(err);
        assert!(
            err < 1e-6,
            "parameter {j} (kind {}): analytic {} disagrees with finite differences ({err:.2e})",
            ["cx", "cy", "cz", "r", "w"][j % 5],
            grad[j]
        );
    }
    eprintln!("worst relative gradient error {worst:.2e}");
}
