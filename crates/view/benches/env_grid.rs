//! The environment pass's grid on the CPU (`render::env_pass::env_grid`): every node's
//! optical depth towards the rule's 72 directions through the trilinear density, by the
//! sweep (the default and the GPU's rule, `render::env_sweep`), along planes of rays one
//! node apart (`render::ray_planes`, the CPU's rule below full detail) and by a march per
//! node (the reference),
//! what a new frame of the CPU lighting waited for most (BENCHMARKS.md "`haze bench` on
//! lavapipe"). A smooth plume that fills most of a 48 × 48 × 64 box (the marches skip no
//! block), σt 4, the built-in sky, order 4, the default spacing (1.5 voxels) and rule;
//! and the grid playback lights at detail 0.43 (nodes 3.5 voxels apart, 32 directions).

use criterion::{Criterion, criterion_group, criterion_main};
use haze_view::render::env_pass::{EnvDepths, EnvGridOptions, env_grid};
use haze_view::{Environment, Sky};
use haze_volume::{Bbox, Volume};
use std::hint::black_box;

fn plume(dims: [usize; 3]) -> Volume {
    let mut data = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let q = [x, y, z].map(|k| k as f64);
                let c = [0, 1, 2].map(|a| (q[a] + 0.5) / dims[a] as f64 - 0.5);
                let r2 = c[0] * c[0] + c[1] * c[1] + 0.5 * c[2] * c[2];
                data.push((0.8 * (-6.0 * r2).exp() + 0.05 * (13.0 * c[2]).sin().abs()) as f32);
            }
        }
    }
    let bbox = Bbox::new([0.0; 3], dims.map(|n| n as f64 / 48.0));
    Volume::new(dims, bbox, data).expect("dims match the data")
}

fn bench(c: &mut Criterion) {
    let density = plume([48, 48, 64]);
    let env = Environment::sky(Sky::default());
    let mut g = c.benchmark_group("env_grid");
    g.sample_size(10);
    let rules = [
        ("sweep", EnvDepths::Sweep),
        ("planes", EnvDepths::Planes),
        ("march", EnvDepths::March),
    ];
    for (name, depths) in rules {
        let opts = EnvGridOptions {
            depths,
            ..Default::default()
        };
        g.bench_function(format!("48x48x64, sigma_t 4, order 4, {name}"), |b| {
            b.iter(|| black_box(env_grid(black_box(&density), 4.0, &env, 4, &opts)))
        });
    }
    for (name, depths) in &rules[..2] {
        let opts = EnvGridOptions {
            spacing: 1.5 / 0.43,
            theta: 2,
            depths: *depths,
            ..Default::default()
        };
        g.bench_function(format!("48x48x64, detail 0.43, {name}"), |b| {
            b.iter(|| black_box(env_grid(black_box(&density), 4.0, &env, 4, &opts)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
