//! The speed/accuracy trade of the wavelet fog: for each basis × levels × µ (and direct
//! vs deconstructed integration), single-thread rays per second and the transmittance
//! error against the exact integral of the fogmap.
//!
//! `cargo run --release -p haze-wavelet --example lod_tradeoff [-- FOGMAP [CELL]]`
//!
//! Default: the bundled 128² fogmap averaged 2 × 2 to 64² (cell 2), the CLI's default
//! placement, at 800 × 600, one ray in 16 (200 × 150 rays), seen by two cameras: the
//! CLI's default (above the layer, looking down over it to the horizon) and a low one
//! (inside the layer, 2 units above the ground at the map's south edge, looking north
//! along it: long grazing rays). Errors are over
//! those rays: `τ` exact is levels 0, µ = 1, no early exit; "mean" and "max" are
//! `|τ − τ_exact|`; "rms/rms" is the RMS error over the RMS of `1 − τ_exact` (the fog's
//! opacity, what the image shows).

use haze_camera::LookAt;
use haze_wavelet::{Basis, Fog, Fogmap, Grid, Mode, Placement, Settings};
use std::path::PathBuf;
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
    let exact = Fog::new(&grid, Basis::Linear, 0, placement, Settings::default()).unwrap();
    let high = haze_wavelet::render::framing(&exact);
    let [x0, x1, y0, y1] = exact.map_box();
    let cx = (x0 + x1) / 2.0;
    let low = LookAt {
        eye: [cx, y0 + 0.02 * (y1 - y0), 2.0],
        target: [cx, y1, 2.0],
        ..high
    };
    for (view, camera) in [("default camera", high), ("low camera", low)] {
        table(&grid, cell, placement, view, camera);
    }
}

fn table(grid: &Grid, cell: f64, placement: Placement, view: &str, camera: LookAt) {
    let exact_settings = Settings {
        min_transmittance: 0.0,
        ..Settings::default()
    };
    let frame = camera.camera(800, 600).unwrap();
    let dirs: Vec<[f64; 3]> = (0..150)
        .flat_map(|y| (0..200).map(move |x| (4 * x, 4 * y)))
        .map(|(x, y)| frame.pixel_ray(x, y))
        .collect();
    println!(
        "\n{} × {} fogmap, cell {cell}, {} rays, {view} (eye {:?})\n",
        grid.nx,
        grid.ny,
        dirs.len(),
        camera.eye
    );
    println!(
        "| basis | levels | µ | mode | rays/s (1 core) | 800×600 on 2 cores | mean abs Δτ | max abs Δτ | rms/rms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for basis in Basis::ALL {
        let exact = Fog::new(grid, basis, 0, placement, exact_settings).unwrap();
        let want: Vec<f64> = dirs.iter().map(|d| tau(&exact, frame.eye, *d)).collect();
        let opacity_rms =
            (want.iter().map(|t| (1.0 - t).powi(2)).sum::<f64>() / want.len() as f64).sqrt();
        let mut cases = vec![(0, 1.0, Mode::Deconstructed)];
        for levels in 1..=3 {
            cases.push((levels, 1.0, Mode::Direct));
            for mu in [1.0, 0.8, 0.6, 0.4, 0.2, 0.0] {
                cases.push((levels, mu, Mode::Deconstructed));
            }
        }
        for (levels, mu, mode) in cases {
            let settings = Settings {
                mu,
                mode,
                ..Settings::default()
            };
            let fog = Fog::new(grid, basis, levels, placement, settings).unwrap();
            let mut got = Vec::new();
            let mut best = f64::INFINITY;
            for _ in 0..5 {
                let start = Instant::now();
                got = dirs.iter().map(|d| tau(&fog, frame.eye, *d)).collect();
                best = best.min(start.elapsed().as_secs_f64());
            }
            let rate = dirs.len() as f64 / best;
            let errs: Vec<f64> = got.iter().zip(&want).map(|(a, b)| (a - b).abs()).collect();
            let mean = errs.iter().sum::<f64>() / errs.len() as f64;
            let max = errs.iter().copied().fold(0.0, f64::max);
            let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
            println!(
                "| {basis} | {levels} | {mu} | {} | {:.2} M | {:.2} s | {mean:.1e} | {max:.1e} | {:.1e} |",
                if mode == Mode::Direct {
                    "direct"
                } else {
                    "deconstructed"
                },
                rate / 1e6,
                480_000.0 / (2.0 * rate),
                rms / opacity_rms
            );
        }
    }
}

/// Transmittance of the pixel ray: to the ground if it goes down, else out of the fog.
fn tau(fog: &Fog, eye: [f64; 3], d: [f64; 3]) -> f64 {
    let depth = if d[2] < 0.0 && eye[2] > 0.0 {
        let t = -eye[2] / d[2];
        fog.optical_depth(eye, [eye[0] + t * d[0], eye[1] + t * d[1], 0.0])
    } else {
        fog.optical_depth_ray(eye, d)
    };
    (-depth).exp()
}

fn bundled_64() -> Grid {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/fogmap/fogmap_128.png");
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
