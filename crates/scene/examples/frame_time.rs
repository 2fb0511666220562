//! Frame time of a scene on the GPU (`haze_scene::gpu`) and on the CPU
//! (`render::render` with the `Analytic` model), for BENCHMARKS.md.
//!
//! ```text
//! cargo run --release -p haze-scene --example frame_time -- data/scenes/room.json
//!     [--sizes 800x600,1920x1080] [--lights 1,4,16] [--repeat 5] [--cpu-repeat 3]
//! ```
//!
//! The scene's lights are replaced by `n` point lights spread through the box of its
//! other lights and surfaces' points (a Halton sequence, the same for every run), sharing
//! the original lights' total intensity. Tables are built once (their time is printed
//! apart). Per configuration: one warm-up frame, then the median of `--repeat` GPU frames
//! — the compute pass alone (timestamp queries, where the adapter has them) and the whole
//! call from upload to the image read back on the host — and of `--cpu-repeat` CPU frames
//! (rayon on every core). As a check, the share of pixels where GPU and CPU differ beyond
//! crates/scene's test tolerance is printed.

use haze_gpu::GpuContext;
use haze_scene::gpu::GpuRenderer;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image, render};
use haze_scene::{Light, Scene};
use std::time::Instant;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(1)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { 0.0 } else { v[v.len() / 2] }
}

/// The `i`-th point of the base-`b` van der Corput sequence.
fn halton(mut i: usize, b: usize) -> f64 {
    let (mut f, mut r) = (1.0, 0.0);
    while i > 0 {
        f /= b as f64;
        r += f * (i % b) as f64;
        i /= b;
    }
    r
}

/// The scene with `n` point lights in place of its lights (module docs).
fn with_lights(scene: &Scene, n: usize) -> Scene {
    let mut total = [0.0; 3];
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for l in &scene.lights {
        if let Light::Point {
            position,
            intensity,
        } = l
        {
            for c in 0..3 {
                total[c] += intensity[c];
                lo[c] = lo[c].min(position[c]);
                hi[c] = hi[c].max(position[c]);
            }
        }
    }
    if total.iter().all(|&t| t <= 0.0) {
        fail("the scene has no point light to spread");
    }
    // Widen a flat box (two lights share a coordinate) to a unit.
    for c in 0..3 {
        if hi[c] - lo[c] < 1.0 {
            let m = 0.5 * (hi[c] + lo[c]);
            (lo[c], hi[c]) = (m - 0.5, m + 0.5);
        }
    }
    let mut s = scene.clone();
    s.lights = (1..=n)
        .map(|i| Light::Point {
            position: [0, 1, 2]
                .map(|c| lo[c] + [halton(i, 2), halton(i, 3), halton(i, 5)][c] * (hi[c] - lo[c])),
            intensity: total.map(|t| t / n as f64),
        })
        .collect();
    s
}

/// The share of pixels where the GPU and the CPU differ by more than crates/scene's test
/// tolerance (`5·10⁻⁴` relative plus `10⁻⁵` of the mean) in some channel.
fn share_outside(gpu: &Image, cpu: &Image) -> f64 {
    let mean = cpu
        .pixels
        .iter()
        .flatten()
        .map(|v| f64::from(*v))
        .sum::<f64>()
        / (3 * cpu.pixels.len()).max(1) as f64;
    let outside = gpu
        .pixels
        .iter()
        .zip(&cpu.pixels)
        .filter(|(g, c)| {
            (0..3).any(|k| {
                let (g, c) = (f64::from(g[k]), f64::from(c[k]));
                (g - c).abs() > 5e-4 * c.abs() + 1e-5 * mean
            })
        })
        .count();
    outside as f64 / cpu.pixels.len().max(1) as f64
}

fn list<T: std::str::FromStr>(s: &str, what: &str) -> Vec<T> {
    s.split(',')
        .map(|x| {
            x.trim()
                .parse()
                .unwrap_or_else(|_| fail(format!("bad {what}: {x}")))
        })
        .collect()
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mut path = None;
    let mut sizes = vec![(800, 600), (1920, 1080)];
    let mut lights = vec![1, 4, 16];
    let (mut repeat, mut cpu_repeat) = (5, 3);
    while let Some(a) = args.next() {
        let mut value = || {
            args.next()
                .unwrap_or_else(|| fail(format!("{a} needs a value")))
        };
        match a.as_str() {
            "--sizes" => {
                sizes = value()
                    .split(',')
                    .map(|s| {
                        let (w, h) = s
                            .split_once('x')
                            .unwrap_or_else(|| fail(format!("bad size {s}")));
                        (list::<usize>(w, "width")[0], list::<usize>(h, "height")[0])
                    })
                    .collect()
            }
            "--lights" => lights = list(&value(), "light count"),
            "--repeat" => repeat = list(&value(), "repeat")[0],
            "--cpu-repeat" => cpu_repeat = list(&value(), "cpu repeat")[0],
            _ if path.is_none() => path = Some(a),
            _ => fail(format!("unexpected argument {a}")),
        }
    }
    let path = path.unwrap_or_else(|| "data/scenes/room.json".to_string());
    let scene = haze_scene::load(std::path::Path::new(&path)).unwrap_or_else(|e| fail(e));
    let ctx = GpuContext::new().unwrap_or_else(|e| fail(e));
    ctx.time_stages(true);
    let t = Instant::now();
    let analytic = Analytic::new(&scene);
    let tables = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let gpu = GpuRenderer::new(&ctx, &analytic).unwrap_or_else(|e| fail(e));
    let setup = t.elapsed().as_secs_f64();
    println!(
        "{path}: {} surfaces; tables {tables:.2} s on the CPU, GPU pipeline + upload {setup:.2} s; adapter {} ({:?}), timestamps {}; CPU {} threads",
        scene.surfaces.len(),
        ctx.adapter_name(),
        ctx.backend(),
        if ctx.has_timestamps() { "yes" } else { "no" },
        rayon::current_num_threads()
    );
    println!(
        "| size | point lights | GPU pass | GPU frame (upload → read back) | CPU frame | pixels GPU ≠ CPU |"
    );
    println!("|---|---|---|---|---|---|");
    let lim = Limits::default();
    for &(w, h) in &sizes {
        for &n in &lights {
            let mut s = with_lights(&scene, n);
            s.camera = s.camera.with_size(w, h).unwrap_or_else(|e| fail(e));
            let mut pass = Vec::new();
            let mut frame = Vec::new();
            let mut image = None;
            for i in 0..=repeat {
                let _ = ctx.take_stage_times();
                let t = Instant::now();
                let img = gpu.render(&ctx, &s, &lim).unwrap_or_else(|e| fail(e));
                let dt = t.elapsed().as_secs_f64();
                let stages = ctx.take_stage_times().unwrap_or_else(|e| fail(e));
                if i > 0 {
                    frame.push(dt);
                    pass.push(stages.iter().map(|(_, s)| s).sum::<f64>());
                }
                image = Some(img);
            }
            let mut cpu_times = Vec::new();
            let mut cpu_image = None;
            for _ in 0..cpu_repeat.max(1) {
                let t = Instant::now();
                cpu_image = Some(render(&s, &analytic, &lim, &|_| {}));
                cpu_times.push(t.elapsed().as_secs_f64());
            }
            let diff = match (&image, &cpu_image) {
                (Some(g), Some(c)) => 100.0 * share_outside(g, c),
                _ => f64::NAN,
            };
            let ms = |s: f64| format!("{:.1} ms", 1e3 * s);
            println!(
                "| {w} × {h} | {n} | {} | {} | {} | {diff:.2} % |",
                if ctx.has_timestamps() {
                    ms(median(pass))
                } else {
                    "—".to_string()
                },
                ms(median(frame)),
                ms(median(cpu_times)),
            );
        }
    }
}
