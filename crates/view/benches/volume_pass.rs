//! The per-voxel work of a new frame's CPU lighting that does not march: the volume pass
//! (`render::crm::volume_pass`: every RBF splatted with its source radiance, then `J̃`
//! towards the eye) and the SH basis it and the passes after it evaluate once a voxel
//! (`sh::eval_into`, orders 4 and 5). 300 RBFs of radii 2–5 voxels in a 96 × 96 × 128
//! box (a 128³-class frame), order 4.

use criterion::{Criterion, criterion_group, criterion_main};
use haze_view::render::crm::volume_pass;
use haze_view::sh;
use haze_volume::{Bbox, Rbf};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let dims = [96, 96, 128];
    let bbox = Bbox::new([0.0; 3], [0.96, 0.96, 1.28]);
    let order = 4;
    let n2 = order * order;
    // A deterministic spread: a golden-ratio walk through the box.
    let (rbfs, source): (Vec<Rbf>, Vec<[Vec<f64>; 3]>) = (0..300)
        .map(|i| {
            let f = i as f64;
            let u = [0.618_034, 0.754_878, 0.569_840].map(|g: f64| (0.1 + f * g).fract());
            let c = [0.96 * u[0], 0.96 * u[1], 1.28 * u[2]];
            let rbf = Rbf::new(c, 0.02 + 0.03 * u[0], 0.5 + u[1]);
            let j = [0, 1, 2].map(|ch| (0..n2).map(|k| 1.0 / (1.0 + (k + ch) as f64)).collect());
            (rbf, j)
        })
        .unzip();
    let eye = [0.5, -2.0, 0.6];
    let mut g = c.benchmark_group("per_voxel");
    g.sample_size(10);
    g.bench_function("volume pass, 96x96x128, 300 RBFs, order 4", |b| {
        b.iter(|| {
            black_box(volume_pass(
                black_box(&rbfs),
                &source,
                order,
                dims,
                &bbox,
                None,
                eye,
            ))
        })
    });
    let dirs: Vec<[f64; 3]> = (0..10_000)
        .map(|i| {
            let f = i as f64;
            [
                (0.37 * f).sin(),
                (0.11 * f).cos(),
                0.3 - (f * 0.013).fract(),
            ]
        })
        .collect();
    for order in [4, 5] {
        g.bench_function(format!("SH basis, order {order}, 10 000 directions"), |b| {
            let mut y = vec![0.0; order * order];
            b.iter(|| {
                for &d in &dirs {
                    sh::eval_into(order, black_box(d), &mut y);
                    black_box(&y);
                }
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
