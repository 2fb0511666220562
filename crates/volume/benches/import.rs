//! Import speed: real Blender frames (OpenVDB zip and Blosc, raw f32) and synthetic 128³
//! frames (raw f32, NumPy). Throughput is in dense voxels per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use haze_volume::{ImportOptions, import};
use std::hint::black_box;
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(rel)
}

/// A smooth synthetic density on an n³ grid, written as raw f32 + sidecar and as .npy.
fn synthetic(dir: &Path, n: usize) -> (PathBuf, PathBuf) {
    let mut v = Vec::with_capacity(n * n * n);
    for z in 0..n {
        for y in 0..n {
            for x in 0..n {
                let p = [x, y, z].map(|i| (i as f32 + 0.5) / n as f32 - 0.5);
                let r2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
                v.push((-(r2 / 0.04)).exp());
            }
        }
    }
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    let raw = dir.join("synthetic.f32");
    std::fs::write(&raw, &bytes).unwrap();
    std::fs::write(
        dir.join("synthetic.json"),
        format!(
            r#"{{"dims": [{n}, {n}, {n}], "world_bbox_min": [0,0,0], "world_bbox_max": [1,1,1]}}"#
        ),
    )
    .unwrap();
    let npy = dir.join("synthetic.npy");
    let mut header =
        format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({n}, {n}, {n}), }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(&bytes);
    std::fs::write(&npy, out).unwrap();
    (raw, npy)
}

fn bench_import(c: &mut Criterion) {
    let opts = ImportOptions::default();
    let mut g = c.benchmark_group("import");
    g.sample_size(20);
    let real = [
        (
            "vdb_zip_48x48x64_f24",
            data("plume-a/vdb/fluid_data_0024.vdb"),
        ),
        (
            "vdb_zip_48x48x64_f28",
            data("plume-a/vdb/fluid_data_0028.vdb"),
        ),
        (
            "vdb_blosc_48x48x64_f24",
            data("plume-a/blosc/fluid_data_0024_openvdb_blosc.vdb"),
        ),
        ("raw_48x48x64_f24", data("plume-a/dense/density_0024.f32")),
    ];
    for (name, path) in real {
        g.throughput(Throughput::Elements(48 * 48 * 64));
        g.bench_function(name, |b| {
            b.iter(|| import::import(black_box(&path), &opts).unwrap())
        });
    }
    let tmp = tempfile::tempdir().unwrap();
    let n = 128;
    let (raw, npy) = synthetic(tmp.path(), n);
    g.throughput(Throughput::Elements((n * n * n) as u64));
    let ball = data("synthetic/ball_128.vdb");
    let voxels = import::import(&ball, &opts).unwrap().len();
    g.throughput(Throughput::Elements(voxels as u64));
    g.bench_function("vdb_blosc_128^3_class_synthetic_ball", |b| {
        b.iter(|| import::import(black_box(&ball), &opts).unwrap())
    });
    g.throughput(Throughput::Elements((n * n * n) as u64));
    g.bench_function("raw_128^3_synthetic", |b| {
        b.iter(|| import::import(black_box(&raw), &opts).unwrap())
    });
    g.bench_function("npy_128^3_synthetic", |b| {
        b.iter(|| import::import(black_box(&npy), &opts).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench_import);
criterion_main!(benches);
