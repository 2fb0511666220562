//! The residual block's coding (`haze_hash::block`, asset format 7): encoding and decoding
//! one hash volume of 27 frames of 96 × 96 × 128 voxels, what a bake writes every 27
//! frames and what playback decodes ahead (BENCHMARKS.md "Against established
//! compressors"), the frames up to one of them (a single frame's render or export), and
//! one frame's residual at every voxel, what the CPU's lighting reads of each new frame.
//! The residual is a misfit of the kind RBFs leave: a smooth field of both signs over a
//! plume-shaped region, reaching a few dozen quantization steps, plus noise of about a
//! step, drifting from frame to frame; quantized at 1/255 of the peak.

use criterion::{Criterion, criterion_group, criterion_main};
use haze_hash::tile::ResidualGroup;
use haze_hash::{BuildOptions, QuantOptions, quantize};
use std::hint::black_box;

const DIMS: [u32; 3] = [96, 96, 128];

fn residual(frame: usize) -> Vec<f32> {
    let [nx, ny, nz] = DIMS.map(|d| d as usize);
    let mut out = Vec::with_capacity(nx * ny * nz);
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let c = [x, y, z].map(|k| k as f64);
                let t = frame as f64;
                let d2 = ((c[0] - 48.0 - 0.3 * t) / 20.0).powi(2)
                    + ((c[1] - 48.0) / 20.0).powi(2)
                    + ((c[2] - 50.0 - 0.5 * t) / 35.0).powi(2);
                let blob = (-d2).exp();
                let wave =
                    (0.21 * c[0] + 0.05 * t).sin() * (0.17 * c[1]).cos() * (0.13 * c[2]).sin();
                let h =
                    ((x * 73_856_093) ^ (y * 19_349_663) ^ (z * 83_492_791) ^ (frame * 2_654_435))
                        % 1000;
                let noise = h as f64 / 1000.0 - 0.5;
                out.push((blob * (0.15 * wave + 0.008 * noise)) as f32);
            }
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let frames: Vec<_> = (0..27)
        .map(|k| quantize(&residual(k), 1.0, QuantOptions::default()).expect("finite residual"))
        .collect();
    let group = ResidualGroup::build(DIMS, 4, &frames, BuildOptions::default()).expect("hashes");
    let bytes = haze_hash::block::encode(&group).expect("encodes");
    println!(
        "27 frames: {} bricks, {} coded bytes ({:.1} kB a frame)",
        group.hash.len(),
        bytes.len(),
        bytes.len() as f64 / 27e3
    );
    let mut g = c.benchmark_group("residual block, 27 frames of 96x96x128");
    g.sample_size(10);
    g.bench_function("encode", |b| {
        b.iter(|| haze_hash::block::encode(black_box(&group)))
    });
    g.bench_function("decode", |b| {
        b.iter(|| haze_hash::block::decode(black_box(&bytes)))
    });
    // A single frame's render or export decodes only the frames up to its own.
    for through in [0, 13] {
        g.bench_function(format!("decode through frame {through}"), |b| {
            b.iter(|| haze_hash::block::decode_through(black_box(&bytes), through))
        });
    }
    // One frame's residual at every voxel, as the CPU's lighting and the viewer's
    // thickness measure take it: brick by brick, against a lookup per voxel.
    g.bench_function("dense frame", |b| b.iter(|| black_box(&group).dense(13)));
    let [nx, ny, nz] = DIMS;
    g.bench_function("lookup every voxel", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        sum += black_box(&group).lookup(13, [x, y, z]);
                    }
                }
            }
            sum
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
