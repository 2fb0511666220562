//! The fit's hot loop: one objective + gradient pass, as RBF·voxel evaluations per second
//! (pairs of an RBF and a voxel inside its 3r sphere), on one and on two threads.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use haze_fit::objective::{PARAMS_PER_RBF, Scratch, cost_and_gradient_with};
use haze_fit::{Bounds, FitGrid, init};
use haze_volume::{ImportOptions, import};
use std::hint::black_box;
use std::path::Path;

fn grid(rel: &str) -> FitGrid {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(rel);
    FitGrid::from_volume(&import::import(&p, &ImportOptions::default()).unwrap()).unwrap()
}

/// RBF·voxel pairs inside the support spheres (counted directly).
fn pairs(g: &FitGrid, params: &[f64]) -> u64 {
    let mut n = 0;
    for p in params.chunks(PARAMS_PER_RBF) {
        for i in 0..g.len() {
            let c = g.center(i);
            let d2: f64 = (0..3).map(|a| (c[a] - p[a]).powi(2)).sum();
            if d2 < 9.0 * p[3] * p[3] {
                n += 1;
            }
        }
    }
    n
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("objective_and_gradient");
    group.sample_size(20);
    for (name, rel, n) in [
        ("plume_f24_48x48x64", "plume-a/vdb/fluid_data_0024.vdb", 300),
        ("ball_102^3", "synthetic/ball_128.vdb", 600),
    ] {
        let g = grid(rel);
        let bounds = Bounds::default();
        let params = init::greedy(&g, n, init::initial_radius(&g, n, &bounds), &bounds);
        let mut grad = vec![0.0; params.len()];
        // The fit keeps one residual buffer per minimization.
        let mut scratch = Scratch::default();
        group.throughput(Throughput::Elements(pairs(&g, &params)));
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            group.bench_function(format!("{name}_{n}rbfs_{threads}thread"), |b| {
                b.iter(|| {
                    pool.install(|| {
                        cost_and_gradient_with(&g, black_box(&params), &mut grad, &mut scratch)
                    })
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
