//! The per-voxel work of a new frame's CPU lighting that does not march: the volume pass
//! (`render::crm::volume_pass`: every RBF splatted with its source radiance, then `J̃`
//! towards the eye), the SH basis it and the passes after it evaluate once a voxel
//! (`sh::eval_into`, orders 4 and 5), and the two passes that add a coarse grid's light
//! towards the eye at every lit voxel (`env_pass::add_env_grid`, nodes 4 voxels apart;
//! `grid_diffusion::add_to_grids`, cells of 8³ voxels — what playback's lowest detail
//! uses); and the RBFs' sum alone (`haze_volume::rbf::evaluate_on_grid`, what the bake's
//! residual and the viewer's thickness measure start from). 300 RBFs of radii 2–5 voxels in a 96 × 96 × 128 box (a 128³-class frame),
//! order 4.

use criterion::{Criterion, criterion_group, criterion_main};
use haze_view::render::crm::volume_pass;
use haze_view::render::env_pass::{EnvGridOptions, add_env_grid, env_grid};
use haze_view::render::grid_diffusion::{CoarseGrid, HIGH, MediaRadiance, add_to_grids};
use haze_view::{Environment, Medium, Sky, sh};
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
    g.bench_function("RBFs on the grid, 96x96x128, 300 RBFs", |b| {
        b.iter(|| {
            black_box(haze_volume::rbf::evaluate_on_grid(
                dims,
                &bbox,
                black_box(&rbfs),
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
    let grids = volume_pass(&rbfs, &source, order, dims, &bbox, None, eye);
    let env = Environment::sky(Sky::default());
    let medium = Medium {
        sigma_t: 4.0,
        albedo: 0.9,
        g: 0.0,
    };
    let opts = EnvGridOptions {
        spacing: 4.0,
        ..Default::default()
    };
    let nodes = env_grid(&grids.density, medium.sigma_t, &env, order, &opts);
    let light = sh::project_env(&env, order);
    g.bench_function(
        "environment grid towards the eye, nodes 4 voxels apart",
        |b| {
            b.iter(|| {
                let mut out = grids.clone();
                add_env_grid(&mut out, &nodes, &light, &medium, eye, order, &env.distant);
                black_box(out)
            })
        },
    );
    let cells = CoarseGrid::new(&grids.density, 8);
    let n = cells.len();
    let ms = MediaRadiance {
        l0: (0..n).map(|k| [0.1 + (k % 7) as f64 * 0.01; 3]).collect(),
        l1: (0..n).map(|k| [[0.01 * (k % 3) as f64; 3]; 3]).collect(),
        high: (0..n)
            .map(|k| [[0.001 * (k % 5) as f64; HIGH]; 3])
            .collect(),
        grid: cells,
        iterations: 0,
        residual: 0.0,
    };
    g.bench_function(
        "multiple scattering towards the eye, cells of 8³ voxels",
        |b| {
            b.iter(|| {
                let mut out = grids.clone();
                add_to_grids(&mut out, &ms, &medium, eye);
                black_box(out)
            })
        },
    );
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
