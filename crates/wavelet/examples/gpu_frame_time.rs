//! Frame times of the wavelet fog on the GPU beside the CPU renderer, per basis, level
//! count and µ, at 800 × 600 and 1920 × 1080 (paper E §5).
//!
//! `cargo run --release -p haze-wavelet --example gpu_frame_time [-- FOGMAP [CELL]]`
//!
//! Default: the bundled 128² fogmap averaged 2 × 2 to 64² (cell 2, the paper's 64² linear
//! anchor), the CLI's default placement and camera (`render::framing`). GPU: the frame
//! submitted and waited for (`FogRenderer::draw` + `GpuContext::finish`, no readback),
//! median of 5 after one warm-up frame. CPU: `render::render` on every core, median of 3.
//! The default early exit (τ < 1/1024) on both. Prints a Markdown table.

use haze_gpu::GpuContext;
use haze_wavelet::gpu::fog::{FogImage, FogRenderer};
use haze_wavelet::render::{self, Scene};
use haze_wavelet::{Basis, Fog, Fogmap, Grid, Placement, Settings};
use std::path::{Path, PathBuf};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (grid, cell) = match args.first() {
        Some(p) => {
            let f = Fogmap::load(&PathBuf::from(p)).unwrap_or_else(|e| panic!("{e}"));
            let cell = args.get(1).map_or(1.0, |c| c.parse().expect("CELL"));
            (f.grid(), cell)
        }
        None => (bundled_64(), 2.0),
    };
    let placement = Placement {
        origin: [
            -(grid.nx as f64) * cell / 2.0,
            -(grid.ny as f64) * cell / 2.0,
        ],
        cell,
        density: 0.12,
        bottom: 0.0,
        top: 8.0,
        falloff: 0.3,
    };
    let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
    let gpu = FogRenderer::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "GPU: {} ({}); CPU: {} threads; fogmap {} × {}, cell {cell}",
        ctx.adapter_name(),
        ctx.backend(),
        rayon::current_num_threads(),
        grid.nx,
        grid.ny
    );
    println!();
    println!("| basis | levels | µ | size | GPU (ms) | GPU fps | CPU (ms) | CPU / GPU |");
    println!("|---|---|---|---|---|---|---|---|");
    let scene = Scene::default();
    for basis in Basis::ALL {
        for (levels, mu) in [(0, 1.0), (3, 1.0), (3, 0.5), (3, 0.0)] {
            let settings = Settings {
                mu,
                ..Settings::default()
            };
            let fog = Fog::new(&grid, basis, levels, placement, settings)
                .unwrap_or_else(|e| panic!("{e}"));
            let camera = render::framing(&fog);
            let up = gpu.upload(&ctx, &fog).unwrap_or_else(|e| panic!("{e}"));
            for (w, h) in [(800, 600), (1920, 1080)] {
                let frame = camera.camera(w, h).unwrap_or_else(|e| panic!("{e}"));
                let image = FogImage::new(&ctx, w, h).unwrap_or_else(|e| panic!("{e}"));
                let mut gpu_times = Vec::new();
                for run in 0..6 {
                    let start = Instant::now();
                    gpu.draw(&ctx, &up, &camera, &scene, &image)
                        .and_then(|()| ctx.finish("frame"))
                        .unwrap_or_else(|e| panic!("{e}"));
                    if run > 0 {
                        gpu_times.push(start.elapsed().as_secs_f64());
                    }
                }
                let mut cpu_times = Vec::new();
                for _ in 0..3 {
                    let start = Instant::now();
                    let px = render::render(&fog, &frame, &scene, &|| {});
                    std::hint::black_box(px);
                    cpu_times.push(start.elapsed().as_secs_f64());
                }
                let (g, c) = (median(gpu_times), median(cpu_times));
                println!(
                    "| {basis} | {levels} | {mu} | {w}×{h} | {:.1} | {:.1} | {:.1} | {:.2} |",
                    g * 1e3,
                    1.0 / g,
                    c * 1e3,
                    c / g
                );
            }
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The bundled 128² fogmap averaged 2 × 2 to 64².
fn bundled_64() -> Grid {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/fogmap/fogmap_128.png");
    let f = Fogmap::load(&path).unwrap_or_else(|e| panic!("{e}"));
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
