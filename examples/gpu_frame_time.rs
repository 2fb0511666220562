//! Frame time of the GPU renderer (`haze_view::gpu::renderer`), per stage and in total.
//!
//! ```text
//! cargo run --release --example gpu_frame_time -- ASSET.haze [ASSET.haze …]
//!     [--sizes 800x600,1920x1080] [--orders 2,4] [--repeat 10] [--lighting auto|cpu|gpu]
//!     [--compare | --playback]
//! ```
//!
//! For every asset (its first frame), image size, SH order, and with and without multiple
//! scattering: one warm-up frame (pipelines, SH tables), then `--repeat` frames from
//! scratch (a new frame key each time, the diffusion solve cold), each timed from the call
//! to the image finished on the GPU (no readback; a viewer displays it where it is). GPU
//! time per pass comes from timestamp queries, the host time of the diffusion operators
//! (computed on the CPU for each new frame) from the renderer; medians are printed.
//! `--lighting cpu|gpu` picks where single scattering and the diffusion run (default
//! `auto`: the CPU when the adapter is a CPU, such as lavapipe; else the GPU). A last row
//! per configuration times a camera move with the isotropic phase function, which reuses
//! the grids (view pass only). `--compare` also renders each configuration's frame on the
//! CPU (`crm_render`) at 400 × 300 and prints the largest pixel difference relative to the
//! brightest pixel. `--playback` instead renders every frame of each asset in order at the
//! first size and order, with multiple scattering, once with the diffusion warm-started
//! from the previous frame (as the viewer plays) and once cold, and prints the medians.

use haze_asset::Asset;
use haze_gpu::GpuContext;
use haze_view::gpu::renderer::{FrameStats, GpuFrame, GpuRenderer, LightingOn, Reuse};
use haze_view::gpu::volume_pass::Residual;
use haze_view::render::{CrmOptions, crm_render};
use haze_view::stream::FrameDecoder;
use haze_view::{Camera, Environment, Medium, Sky};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(1)
}

/// GPU seconds of the passes called `name` in a frame (0 without timestamps).
fn gpu_seconds(stats: &FrameStats, name: &str) -> f64 {
    stats
        .gpu
        .iter()
        .filter(|(s, _)| *s == name)
        .map(|(_, t)| t)
        .sum()
}

/// A lighting stage's time in a frame: its GPU pass `pass`, or the host's `cpu` seconds
/// where it ran on the CPU.
fn stage_seconds(stats: &FrameStats, pass: &str, cpu: f64) -> f64 {
    if stats.gpu.iter().any(|(s, _)| *s == pass) {
        gpu_seconds(stats, pass)
    } else {
        cpu
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { 0.0 } else { v[v.len() / 2] }
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mut assets = Vec::new();
    let mut sizes = vec![(800usize, 600usize), (1920, 1080)];
    let mut orders = vec![2usize, 4];
    let mut repeat = 10usize;
    let mut compare = false;
    let mut playback = false;
    let mut lighting = LightingOn::Auto;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--sizes" => {
                let v = args.next().unwrap_or_default();
                sizes = v
                    .split(',')
                    .map(|s| {
                        let (w, h) = s.split_once('x').unwrap_or_else(|| fail("--sizes WxH,…"));
                        let p = |t: &str| t.parse().unwrap_or_else(|_| fail("--sizes WxH,…"));
                        (p(w), p(h))
                    })
                    .collect();
            }
            "--orders" => {
                let v = args.next().unwrap_or_default();
                orders = v
                    .split(',')
                    .map(|s| s.parse().unwrap_or_else(|_| fail("--orders N,…")))
                    .collect();
            }
            "--repeat" => {
                repeat = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or_else(|| fail("--repeat N"));
            }
            "--lighting" => {
                lighting = match args.next().as_deref() {
                    Some("auto") => LightingOn::Auto,
                    Some("cpu") => LightingOn::Cpu,
                    Some("gpu") => LightingOn::Gpu,
                    _ => fail("--lighting auto|cpu|gpu"),
                }
            }
            "--compare" => compare = true,
            "--playback" => playback = true,
            _ => assets.push(PathBuf::from(a)),
        }
    }
    if assets.is_empty() {
        fail(
            "usage: gpu_frame_time ASSET.haze … [--sizes 800x600,1920x1080] [--orders 2,4] [--repeat 10] [--lighting auto|cpu|gpu] [--compare | --playback]",
        );
    }
    let ctx = GpuContext::new().unwrap_or_else(|e| fail(e));
    let timed = ctx.time_stages(true);
    println!(
        "GPU: {} ({}); per-pass GPU times {}",
        ctx.adapter_name(),
        ctx.backend(),
        if timed {
            "from timestamp queries"
        } else {
            "unavailable (no timestamp queries)"
        }
    );
    let on = lighting.resolve(&ctx);
    println!(
        "lighting on the {}: the stages before the view pass are {}",
        if on == LightingOn::Cpu { "CPU" } else { "GPU" },
        if on == LightingOn::Cpu {
            "host times (f64, all cores)"
        } else {
            "GPU times (timestamp queries)"
        }
    );
    if playback {
        play(&ctx, &assets, sizes[0], orders[0], lighting);
        return;
    }
    println!(
        "| RBFs | size | SH | multiple | single (ms) | operators (CPU ms) | diffusion (ms) | volume (GPU ms) | view (GPU ms) | frame (ms) | fps | view only (ms) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let sky = Environment::sky(Sky::default());
    for path in &assets {
        let asset = Arc::new(Asset::open(path).unwrap_or_else(|e| fail(e)));
        let mut decoder = FrameDecoder::new(asset.clone());
        let frame = decoder.decode(0).unwrap_or_else(|e| fail(e));
        let grid = asset.header().grid.clone();
        let dims = grid.dims.map(|d| d as usize);
        let bbox = haze_volume::Bbox::new(grid.bbox_min, grid.bbox_max);
        for &(w, h) in &sizes {
            for &order in &orders {
                for multiple in [true, false] {
                    let opts = CrmOptions {
                        order,
                        multiple,
                        ..CrmOptions::default()
                    };
                    let medium = Medium::new(8.0, 0.9, 0.0).unwrap_or_else(|e| fail(e));
                    let camera =
                        Camera::framing(bbox.min, bbox.max, 40.0, w, h).unwrap_or_else(|e| fail(e));
                    let mut r = GpuRenderer::new(&ctx, sky.clone()).unwrap_or_else(|e| fail(e));
                    r.set_lighting(lighting);
                    let residual = frame.residual.as_ref().map(Residual::Hash);
                    let input = |key| GpuFrame {
                        key,
                        rbfs: &frame.rbfs,
                        residual,
                        dims,
                        bbox,
                    };
                    let mut run = |key: u64, cam: &Camera, cold: bool| {
                        if cold {
                            r.reset();
                        }
                        let t = Instant::now();
                        let (_image, stats) = r
                            .render(&ctx, &input(key), &medium, cam, &opts)
                            .unwrap_or_else(|e| fail(e));
                        ctx.finish("the frame").unwrap_or_else(|e| fail(e));
                        (t.elapsed().as_secs_f64(), stats)
                    };
                    run(0, &camera, true);
                    let mut per: [Vec<f64>; 6] = Default::default();
                    for k in 1..=repeat {
                        let (total, stats) = run(k as u64, &camera, true);
                        let gpu = |name| gpu_seconds(&stats, name);
                        let single = stats.crm.single_seconds;
                        per[0].push(stage_seconds(&stats, "single scattering", single));
                        per[1].push(stats.operators_seconds);
                        let multiple = stats.crm.multiple_seconds;
                        per[2].push(stage_seconds(&stats, "diffusion", multiple));
                        per[3].push(gpu("volume pass"));
                        per[4].push(gpu("view pass"));
                        per[5].push(total);
                    }
                    // A camera move with g = 0: the grids are reused.
                    let mut moved = camera.clone();
                    moved.eye[0] += 1e-3 * (bbox.max[0] - bbox.min[0]);
                    let mut view_only = Vec::new();
                    for _ in 0..repeat {
                        let (t, stats) = run(repeat as u64, &moved, false);
                        if stats.reuse == Reuse::Grids {
                            view_only.push(t);
                        }
                        moved.eye[0] = -moved.eye[0] + 2.0 * camera.eye[0];
                    }
                    let [s, ops, m, v, vp, total] = per.map(|x| median(x) * 1e3);
                    println!(
                        "| {} | {w}×{h} | {order} | {} | {s:.2} | {ops:.2} | {m:.2} | {v:.2} | {vp:.2} | {total:.2} | {:.0} | {:.2} |",
                        frame.rbfs.len(),
                        if multiple { "yes" } else { "no" },
                        1e3 / total,
                        median(view_only) * 1e3
                    );
                    if compare && w == sizes[0].0 && h == sizes[0].1 {
                        let cam = Camera::framing(bbox.min, bbox.max, 40.0, 400, 300)
                            .unwrap_or_else(|e| fail(e));
                        r.reset();
                        let (img, _) = r
                            .render(&ctx, &input(u64::MAX), &medium, &cam, &opts)
                            .unwrap_or_else(|e| fail(e));
                        let gpu = img.read(&ctx).unwrap_or_else(|e| fail(e));
                        let dense = frame.residual.as_ref().map(|s| s.dense());
                        let (cpu, _) = crm_render(
                            &frame.rbfs,
                            dense.as_deref(),
                            dims,
                            &bbox,
                            &medium,
                            &sky,
                            &cam,
                            &opts,
                        );
                        let bright = cpu.pixels.iter().flatten().fold(0.0f32, |a, &b| a.max(b));
                        let diff = gpu
                            .iter()
                            .zip(&cpu.pixels)
                            .flat_map(|(g, c)| (0..3).map(move |k| (g[k] - c[k]).abs()))
                            .fold(0.0f32, f32::max);
                        println!(
                            "GPU vs CPU at 400×300: largest difference {:.2e} of the brightest pixel",
                            diff / bright
                        );
                    }
                }
            }
        }
    }
}

/// Every frame of each asset in order, the diffusion warm-started and then cold.
fn play(
    ctx: &GpuContext,
    assets: &[PathBuf],
    (w, h): (usize, usize),
    order: usize,
    lighting: LightingOn,
) {
    println!(
        "| asset | frames | RBFs (mean) | diffusion start | CG iterations (median) | single (ms) | operators (CPU ms) | diffusion (ms) | volume (GPU ms) | view (GPU ms) | frame (ms) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let sky = Environment::sky(Sky::default());
    let medium = Medium::new(8.0, 0.9, 0.0).unwrap_or_else(|e| fail(e));
    let opts = CrmOptions {
        order,
        ..CrmOptions::default()
    };
    for path in assets {
        let asset = Arc::new(Asset::open(path).unwrap_or_else(|e| fail(e)));
        let grid = asset.header().grid.clone();
        let dims = grid.dims.map(|d| d as usize);
        let bbox = haze_volume::Bbox::new(grid.bbox_min, grid.bbox_max);
        let mut decoder = FrameDecoder::new(asset.clone());
        let frames: Vec<_> = (0..asset.frame_count())
            .map(|k| decoder.decode(k).unwrap_or_else(|e| fail(e)))
            .collect();
        let camera = Camera::framing(bbox.min, bbox.max, 40.0, w, h).unwrap_or_else(|e| fail(e));
        for warm in [true, false] {
            let mut r = GpuRenderer::new(ctx, sky.clone()).unwrap_or_else(|e| fail(e));
            r.set_lighting(lighting);
            let mut per: [Vec<f64>; 7] = Default::default();
            for (k, f) in frames.iter().enumerate() {
                if !warm {
                    r.reset();
                }
                let input = GpuFrame {
                    key: k as u64,
                    rbfs: &f.rbfs,
                    residual: f.residual.as_ref().map(Residual::Hash),
                    dims,
                    bbox,
                };
                let t = Instant::now();
                let (_image, stats) = r
                    .render(ctx, &input, &medium, &camera, &opts)
                    .unwrap_or_else(|e| fail(e));
                ctx.finish("the frame").unwrap_or_else(|e| fail(e));
                let total = t.elapsed().as_secs_f64();
                let gpu = |name| gpu_seconds(&stats, name);
                // The first frame has nothing to start from either way.
                if k > 0 {
                    let cg = r.diffusion_stats(ctx).unwrap_or_else(|e| fail(e));
                    per[0].push(f64::from(cg.map_or(0, |d| d.iterations)));
                    let single = stats.crm.single_seconds;
                    per[1].push(stage_seconds(&stats, "single scattering", single) * 1e3);
                    per[2].push(stats.operators_seconds * 1e3);
                    let multiple = stats.crm.multiple_seconds;
                    per[3].push(stage_seconds(&stats, "diffusion", multiple) * 1e3);
                    per[4].push(gpu("volume pass") * 1e3);
                    per[5].push(gpu("view pass") * 1e3);
                    per[6].push(total * 1e3);
                }
            }
            let rbfs = frames.iter().map(|f| f.rbfs.len()).sum::<usize>() as f64
                / frames.len().max(1) as f64;
            let [it, s, ops, m, v, vp, total] = per.map(median);
            println!(
                "| {} | {} | {rbfs:.0} | {} | {it:.0} | {s:.2} | {ops:.2} | {m:.2} | {v:.2} | {vp:.2} | {total:.2} |",
                path.file_name()
                    .map_or(String::new(), |n| n.to_string_lossy().into_owned()),
                frames.len(),
                if warm { "previous frame" } else { "zero" },
            );
        }
    }
}
