//! Ray throughput of the wavelet fog: rays per second on one core for each basis ×
//! levels × µ, on a 64² fogmap (the bundled 128² map averaged 2 × 2) seen by the default
//! camera (`render::framing`) at 800 × 600, one ray in 16 (200 × 150 rays).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use haze_wavelet::render::{Scene, framing, shade};
use haze_wavelet::{Basis, Fog, Fogmap, Grid, Mode, Placement, Settings};
use std::hint::black_box;
use std::path::Path;

fn fogmap_64() -> Grid {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/fogmap/fogmap_128.png");
    let f = Fogmap::load(&path).unwrap();
    let mut g = Grid::zeros(0, 0, 64, 64);
    for j in 0..64 {
        for i in 0..64 {
            let at = |x: usize, y: usize| f.values[y * 128 + x];
            g.data[j * 64 + i] = (at(2 * i, 2 * j)
                + at(2 * i + 1, 2 * j)
                + at(2 * i, 2 * j + 1)
                + at(2 * i + 1, 2 * j + 1))
                / 4.0;
        }
    }
    g
}

/// The CLI's default placement for a 64² map of 2-unit cells (same world size as 128²).
fn placement() -> Placement {
    Placement {
        origin: [-64.0, -64.0],
        cell: 2.0,
        density: 0.12,
        bottom: 0.0,
        top: 8.0,
        falloff: 0.3,
    }
}

fn bench(c: &mut Criterion) {
    let grid = fogmap_64();
    let scene = Scene::default();
    let mut group = c.benchmark_group("rays");
    group.sample_size(10);
    group.measurement_time(std::time::Duration::from_secs(2));
    group.warm_up_time(std::time::Duration::from_millis(500));
    let cases = Basis::ALL.iter().flat_map(|&b| {
        [(0, 1.0), (3, 1.0), (3, 0.5), (3, 0.0)]
            .into_iter()
            .map(move |(l, mu)| (b, l, mu, Mode::Deconstructed))
            .chain([(b, 3, 1.0, Mode::Direct), (b, 3, 0.5, Mode::Direct)])
    });
    for (basis, levels, mu, mode) in cases {
        let settings = Settings {
            mu,
            mode,
            ..Settings::default()
        };
        let fog = Fog::new(&grid, basis, levels, placement(), settings).unwrap();
        let frame = framing(&fog).camera(800, 600).unwrap();
        let dirs: Vec<[f64; 3]> = (0..150)
            .flat_map(|y| (0..200).map(move |x| (4 * x, 4 * y)))
            .map(|(x, y)| frame.pixel_ray(x, y))
            .collect();
        group.throughput(Throughput::Elements(dirs.len() as u64));
        let id = BenchmarkId::new(
            format!(
                "{basis}/{}",
                if mode == Mode::Direct {
                    "direct"
                } else {
                    "deconstructed"
                }
            ),
            format!("L{levels}/mu{mu}"),
        );
        group.bench_function(id, |b| {
            b.iter(|| {
                let mut sum = 0.0;
                for d in &dirs {
                    sum += shade(&fog, &scene, frame.eye, *d)[0];
                }
                black_box(sum)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
