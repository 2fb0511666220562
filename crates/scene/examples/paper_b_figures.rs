//! Paper B's figures for BENCHMARKS.md: accuracy against the march reference and frame
//! time against the number of Gaussians and lights; also writes the bundled scene.
//!
//! ```text
//! cargo run --release -p haze-scene --example paper_b_figures -- accuracy [--size 64x48]
//! cargo run --release -p haze-scene --example paper_b_figures -- timing [--size 320x240]
//!     [--counts 10,100,1000,5000] [--lights 1,2,4] [--repeat 3] [--gpu [--prep]]
//!     [--no-environment] [--scene FILE] [--spread R]
//! cargo run --release -p haze-scene --example paper_b_figures -- environment [--size 48x36] [--held-out]
//!     [--theta 8]
//! cargo run --release -p haze-scene --example paper_b_figures -- lamps [--check] [--stride N]
//!     [--target E] FILE...
//! cargo run --release -p haze-scene --example paper_b_figures -- reuse [--counts 1000,5000]
//!     [--lights 1,4] [--spread R] [--size 320x240] [FILE...]
//! cargo run --release -p haze-scene --example paper_b_figures -- scene data/scenes/gaussians.json
//! cargo run --release -p haze-scene --example paper_b_figures -- sky-scene data/scenes/gaussians_sky.json
//! ```
//!
//! Every scene is the same room (a floor, a back wall, a glossy sphere, point lights)
//! with a cloud of Gaussians from `haze_gaussians::cloud::ball` (fixed seed), at a chosen
//! peak optical depth per Gaussian. **Accuracy**: paper B (CPU) against the march through
//! the exact medium (`haze render --scene --reference`'s renderer, step
//! `paper_b::march_step`), relative RMS over the image (docs/conventions.md), for the whole image
//! (where the sphere's shadow in the medium, which paper B does not model, counts
//! against it), the airlight alone (no surfaces, black environment: the factorization's
//! error alone) and the surfaces alone (albedo 0: the direct light through the
//! Gaussians). The march has no light scattered onto
//! surfaces, so paper B's is off in the comparison; its share of paper B's image is
//! printed apart. **Environment**: the built-in sky alone over a floor (§4.2, the average
//! optical depth) against the march integrating it over directions, with the surfaces
//! under the others' exact shadow on the sky where its bound says so and under
//! `e^{−T̄(p)}` alone; `--held-out` takes three denser clouds never tuned on. **Timing**: the median of `--repeat` frames, per-frame preparation
//! (the exponents `Eᵢ` per light, the environment's `Ēᵢ` and `T̄ⱼ(bᵢ)`) included, rayon
//! on every core; with `--gpu` the frame on the GPU (`haze_scene::gpu::paper_b`: the same
//! preparation on the CPU, upload, pass, read-back), the tables uploaded beforehand;
//! `--no-environment` makes the room's environment black (no §4.2 terms, no `T̄(p)`);
//! `--spread R` puts the cloud in a ball of radius R (default 1.4, where every Gaussian
//! overlaps every other on screen; 2.5 fills the picture, each Gaussian a small part);
//! `--scene FILE` times that scene instead (its camera at `--size`). **Lamps**: scene files
//! (`data/scenes/lamps/`: lights inside, at the edge of and outside dense Gaussians)
//! rendered by the paper's closed form everywhere and with the pairs over the bound
//! integrated (`PaperBOptions::target`), both against `--reference`'s march (relative
//! RMS outside 4 pixels of each light's image, `lamp_error`), with the
//! median of 3 frame times; `--check` also holds that march to one of uniform steps of
//! a twentieth of the smallest radius, at 40 × 30. **Reuse**: the CPU's screen-space
//! reuse of the integrated pairs (`paper_b::reuse`) against every pixel integrating them,
//! on the timing room (`--counts`, `--lights`, `--spread`) and on scene files (at their
//! own size): frame times (median of 3) and the reused picture's relative RMS and
//! largest pixel error against the other's. `--stride N` (lamps and reuse) sets the
//! reused frames' coarsest grid (`PaperBOptions::reuse`, 4 by default), `--target E` their
//! pairs' error bound above which a pair is integrated (`PaperBOptions::target`, 0.02).

use haze_gaussians::cloud;
use haze_gpu::GpuContext;
use haze_scene::gpu::GpuRenderer;
use haze_scene::gpu::paper_b::{CPU_DEVICE_EXACT, GpuPaperB};
use haze_scene::march;
use haze_scene::paper_b::{self, PaperBOptions, Prepared};
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image};
use haze_scene::{Scene, file};
use std::time::Instant;

fn fail(msg: impl std::fmt::Display) -> ! {
    eprintln!("error: {msg}");
    std::process::exit(1)
}

/// A cloud: how many, ball radius, radius range, peak optical depth; or one Gaussian.
struct Cloud {
    n: usize,
    spread: f64,
    radii: (f64, f64),
    tau: f64,
    centre: [f64; 3],
}

impl Cloud {
    /// The timing room's cloud: `n` Gaussians of radii 0.06–0.2 and peak depth 0.05 in a
    /// ball of radius `spread`.
    fn timing_room(n: usize, spread: f64) -> Cloud {
        Cloud {
            n,
            spread,
            radii: (0.06, 0.2),
            tau: 0.05,
            centre: [0.0, 0.0, 1.2],
        }
    }
}

const LIGHTS: [([f64; 3], [f64; 3]); 4] = [
    ([-1.6, -0.8, 2.6], [8.0, 7.0, 6.0]),
    ([1.8, 1.0, 0.9], [2.0, 3.0, 6.0]),
    ([0.2, -1.5, 3.2], [5.0, 5.0, 5.0]),
    ([-1.0, 1.6, 0.6], [6.0, 3.0, 2.0]),
];

/// The room's JSON with `cloud`, `lights` point lights, `(w, h)` pixels; `black` makes
/// surfaces and environment black, `albedo` is the medium's.
fn scene_text(
    cloud: &Cloud,
    lights: usize,
    size: (usize, usize),
    black: bool,
    albedo: f64,
) -> String {
    let gs = cloud::ball(
        cloud.n,
        2007,
        cloud.centre,
        cloud.spread,
        cloud.radii,
        cloud.tau,
        2.0,
    );
    let list: Vec<String> = gs
        .iter()
        .map(|g| {
            format!(
                "      {{\"center\": [{:.4}, {:.4}, {:.4}], \"radius\": {:.4}, \"weight\": {:.5}}}",
                g.center[0], g.center[1], g.center[2], g.radius, g.weight
            )
        })
        .collect();
    let lights: Vec<String> = LIGHTS
        .iter()
        .cycle()
        .take(lights)
        .enumerate()
        .map(|(i, (p, c))| {
            // Repeated lights move along x so that none coincide.
            let dx = 0.37 * (i / LIGHTS.len()) as f64;
            format!(
                "    {{\"type\": \"point\", \"position\": [{}, {}, {}], \"intensity\": [{}, {}, {}]}}",
                p[0] + dx, p[1], p[2], c[0], c[1], c[2]
            )
        })
        .collect();
    let (diffuse, specular, env) = if black {
        ("[0, 0, 0]", "[0, 0, 0]", "null")
    } else {
        ("[0.6, 0.6, 0.6]", "[0.3, 0.3, 0.3]", "[0.05, 0.06, 0.08]")
    };
    format!(
        r#"{{
  "camera": {{"eye": [0, -6, 1.6], "target": [0, 0, 1.0], "fov": 45, "width": {}, "height": {}}},
  "environment": {env},
  "lights": [
{}
  ],
  "media": [
    {{"type": "gaussians", "sigma_t": 2, "albedo": {albedo}, "gaussians": [
{}
    ]}}
  ],
  "surfaces": [
    {{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "material": {{"diffuse": {diffuse}}}}},
    {{"type": "plane", "point": [0, 3, 0], "normal": [0, -1, 0], "material": {{"diffuse": {diffuse}}}}},
    {{"type": "sphere", "center": [0.9, 0.8, 0.5], "radius": 0.5,
      "material": {{"diffuse": {diffuse}, "specular": {specular}, "shininess": 20}}}}
  ]
}}
"#,
        size.0,
        size.1,
        lights.join(",\n"),
        list.join(",\n")
    )
}

fn scene(cloud: &Cloud, lights: usize, size: (usize, usize), black: bool, albedo: f64) -> Scene {
    file::parse(&scene_text(cloud, lights, size, black, albedo)).unwrap_or_else(|e| fail(e))
}

fn paper_b(s: &Scene, analytic: &Analytic, surface_scattering: bool) -> Image {
    let options = PaperBOptions {
        surface_scattering,
        ..Default::default()
    };
    paper_b_with(s, analytic, options)
}

fn paper_b_with(s: &Scene, analytic: &Analytic, options: PaperBOptions) -> Image {
    let prep = Prepared::new(s, analytic, options).unwrap_or_else(|e| fail(e));
    paper_b::render(&prep, &Limits::default(), &|_| {})
}

/// Clouds made after the environment terms' choices, never tuned on (`environment
/// --held-out`): denser than [`cases`]' around each Gaussian.
fn held_out_skies() -> Vec<(&'static str, Cloud)> {
    let cloud = |n, spread, radii, tau| Cloud {
        n,
        spread,
        radii,
        tau,
        centre: [0.0, 0.0, 1.2],
    };
    vec![
        (
            "2000 gaussians, peak depth 0.05, ball of 1.4",
            cloud(2000, 1.4, (0.06, 0.2), 0.05),
        ),
        (
            "300 gaussians, peak depth 0.2, ball of 1.2",
            cloud(300, 1.2, (0.1, 0.25), 0.2),
        ),
        (
            "30 gaussians, peak depth 1, ball of 1.0",
            cloud(30, 1.0, (0.2, 0.4), 1.0),
        ),
    ]
}

/// `--reference`'s march: the environment integrated over directions at every sample and
/// surface point (`paper_b::reference_options`).
fn reference(s: &Scene) -> Image {
    let opt = paper_b::reference_options(s, paper_b::REFERENCE_THETA);
    march::render(s, &Limits::default(), &opt, &|_| {})
}

fn arg<'a>(args: &'a [String], key: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == key)
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
}

fn size(args: &[String], default: (usize, usize)) -> (usize, usize) {
    match arg(args, "--size") {
        None => default,
        Some(s) => {
            let (w, h) = s.split_once('x').unwrap_or_else(|| fail("--size WxH"));
            (
                w.parse().unwrap_or_else(|_| fail("--size WxH")),
                h.parse().unwrap_or_else(|_| fail("--size WxH")),
            )
        }
    }
}

fn list(args: &[String], key: &str, default: &[usize]) -> Vec<usize> {
    match arg(args, key) {
        None => default.to_vec(),
        Some(s) => s
            .split(',')
            .map(|x| x.parse().unwrap_or_else(|_| fail(format!("{key} N,N,…"))))
            .collect(),
    }
}

fn cases() -> Vec<(&'static str, Cloud)> {
    vec![
        (
            "1 gaussian, peak depth 0.15",
            Cloud {
                n: 1,
                spread: 0.0,
                radii: (0.6, 0.6),
                tau: 0.15,
                centre: [0.0, 0.3, 1.2],
            },
        ),
        (
            "100 gaussians, peak depth 0.05",
            Cloud {
                n: 100,
                spread: 1.2,
                radii: (0.15, 0.3),
                tau: 0.05,
                centre: [0.0, 0.0, 1.2],
            },
        ),
        (
            "1000 gaussians, peak depth 0.03",
            Cloud {
                n: 1000,
                spread: 1.4,
                radii: (0.06, 0.12),
                tau: 0.03,
                centre: [0.0, 0.0, 1.2],
            },
        ),
        (
            "100 gaussians, peak depth 0.5",
            Cloud {
                n: 100,
                spread: 1.2,
                radii: (0.15, 0.3),
                tau: 0.5,
                centre: [0.0, 0.0, 1.2],
            },
        ),
        (
            "1 gaussian, peak depth 2, light 0.6 r from it",
            Cloud {
                n: 1,
                spread: 0.0,
                radii: (0.8, 0.8),
                tau: 2.0,
                centre: [-1.2, -0.6, 2.2],
            },
        ),
    ]
}

fn accuracy(args: &[String]) {
    let sz = size(args, (64, 48));
    println!(
        "paper B against the march reference, {}×{}, 2 point lights (relative RMS over the image)",
        sz.0, sz.1
    );
    println!(
        "| scene | image | airlight only | surfaces only (albedo 0) | surface scattering's share | paper B s | reference s |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (name, cloud) in cases() {
        let s = scene(&cloud, 2, sz, false, 0.9);
        let analytic = Analytic::new(&s);
        let t = Instant::now();
        let b = paper_b(&s, &analytic, false);
        let tb = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let r = reference(&s);
        let tr = t.elapsed().as_secs_f64();
        let with = paper_b(&s, &analytic, true);
        let share = with.rel_rms(&b);
        // No surfaces: nothing shadows the medium (neither paper B nor C has volume
        // shadows; the march has), so this measures the factorization alone.
        let mut air = scene(&cloud, 2, sz, true, 0.9);
        air.surfaces.clear();
        let air_e = paper_b(&air, &analytic, false).rel_rms(&reference(&air));
        let surf = scene(&cloud, 2, sz, false, 0.0);
        let surf_e = paper_b(&surf, &analytic, false).rel_rms(&reference(&surf));
        println!(
            "| {name} | {:.2} % | {:.2} % | {:.2e} | {:.1} % | {tb:.2} | {tr:.1} |",
            100.0 * b.rel_rms(&r),
            100.0 * air_e,
            surf_e,
            100.0 * share
        );
    }
}

/// The environment's light alone (§4.2): the built-in sky over a floor, no point lights,
/// the cases' clouds; paper B against the march with the environment integrated over
/// `2·θ²` directions at every sample and surface point (`paper_b::reference_options`).
fn environment(args: &[String]) {
    let sz = size(args, (48, 36));
    let theta = list(args, "--theta", &[paper_b::REFERENCE_THETA])[0];
    println!(
        "paper B lit by the sky against the march ({} directions per point), {}×{} (relative RMS)",
        2 * theta * theta,
        sz.0,
        sz.1
    );
    println!(
        "| scene | image | image, surfaces under e^(-T̄) | airlight only | surfaces only (albedo 0) | surfaces only, under e^(-T̄) | surface scattering's share | paper B s | reference s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mean_sky = PaperBOptions {
        surface_scattering: false,
        surface_sky: false,
        ..Default::default()
    };
    let sky = |cloud: &Cloud, albedo: f64, floor: bool| {
        let mut s = scene(cloud, 0, sz, false, albedo);
        s.environment = haze_scene::Environment::Sky;
        s.surfaces.truncate(usize::from(floor));
        s
    };
    let reference = |s: &Scene| {
        march::render(
            s,
            &Limits::default(),
            &paper_b::reference_options(s, theta),
            &|_| {},
        )
    };
    let clouds = if args.iter().any(|a| a == "--held-out") {
        held_out_skies()
    } else {
        cases().into_iter().take(4).collect()
    };
    for (name, cloud) in clouds {
        let s = sky(&cloud, 0.9, true);
        let analytic = Analytic::new(&s);
        let t = Instant::now();
        let b = paper_b(&s, &analytic, false);
        let tb = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let r = reference(&s);
        let tr = t.elapsed().as_secs_f64();
        let share = paper_b(&s, &analytic, true).rel_rms(&b);
        // The airlight alone: no surfaces, less the same scene at albedo 0 (the sky seen
        // through the medium).
        let air = sky(&cloud, 0.9, false);
        let air_b = paper_b(&air, &analytic, false);
        let air_r = reference(&air);
        let surf = sky(&cloud, 0.0, true);
        let surf_r = reference(&surf);
        let surf_e = paper_b(&surf, &analytic, false).rel_rms(&surf_r);
        let surf_mean = paper_b_with(&surf, &analytic, mean_sky).rel_rms(&surf_r);
        let image_mean = paper_b_with(&s, &analytic, mean_sky).rel_rms(&r);
        let air_only = |img: &Image, no_albedo: &Image| Image {
            width: img.width,
            height: img.height,
            pixels: img
                .pixels
                .iter()
                .zip(&no_albedo.pixels)
                .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
                .collect(),
        };
        let dark = sky(&cloud, 0.0, false);
        let dark_b = paper_b(&dark, &analytic, false);
        let dark_r = reference(&dark);
        let air_e = air_only(&air_b, &dark_b).rel_rms(&air_only(&air_r, &dark_r));
        println!(
            "| {name} | {:.2} % | {:.2} % | {:.2} % | {:.2} % | {:.2} % | {:.1} % | {tb:.2} | {tr:.1} |",
            100.0 * b.rel_rms(&r),
            100.0 * image_mean,
            100.0 * air_e,
            100.0 * surf_e,
            100.0 * surf_mean,
            100.0 * share
        );
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One timed frame (ms) of `s`: on the GPU when given, else on the CPU; `prep` prints
/// the preparation's share.
fn frame(
    s: &Scene,
    analytic: &Analytic,
    gpu: Option<&(GpuContext, GpuPaperB)>,
    tables: Option<&GpuRenderer>,
    prep: bool,
) -> f64 {
    let t = Instant::now();
    let p = Prepared::new(s, analytic, PaperBOptions::default()).unwrap_or_else(|e| fail(e));
    if prep {
        let (k, n) = p.integrated_pairs();
        eprintln!(
            "{} gaussians, {} lights: preparation {:.0} ms, {k} of {n} pairs integrated, {} \
             shadows on the sky exact",
            p.gaussian_count(),
            s.lights.len(),
            t.elapsed().as_secs_f64() * 1e3,
            p.exact_sky(),
        );
    }
    match (gpu, tables) {
        (Some((ctx, pipeline)), Some(tables)) => {
            pipeline
                .render(ctx, tables, &p, &Limits::default())
                .unwrap_or_else(|e| fail(e));
        }
        _ => {
            let _ = paper_b::render(&p, &Limits::default(), &|_| {});
        }
    }
    t.elapsed().as_secs_f64() * 1e3
}

fn timing(args: &[String]) {
    let sz = size(args, (320, 240));
    let counts = list(args, "--counts", &[10, 100, 1000, 5000]);
    let lights = list(args, "--lights", &[1, 2, 4]);
    let repeat = list(args, "--repeat", &[3])[0].max(1);
    let no_environment = args.iter().any(|a| a == "--no-environment");
    let spread = arg(args, "--spread").map_or(1.4, |s| {
        s.parse::<f64>()
            .ok()
            .filter(|r| *r > 0.0 && r.is_finite())
            .unwrap_or_else(|| fail("--spread R: a positive radius"))
    });
    let gpu = args.iter().any(|a| a == "--gpu").then(|| {
        let ctx = GpuContext::new().unwrap_or_else(|e| fail(e));
        let pipeline = GpuPaperB::new(&ctx).unwrap_or_else(|e| fail(e));
        (ctx, pipeline)
    });
    match &gpu {
        Some((ctx, _)) => println!(
            "paper B on the GPU ({}), {}×{}, cloud of radius {spread}, median of {repeat} frames (ms)",
            ctx.adapter_name(),
            sz.0,
            sz.1
        ),
        None => println!(
            "paper B on the CPU ({} threads), {}×{}, cloud of radius {spread}, median of {repeat} frames (ms)",
            rayon::current_num_threads(),
            sz.0,
            sz.1
        ),
    }
    if let Some(path) = arg(args, "--scene") {
        // A scene file at its own lights and Gaussians, the camera resized.
        let mut s = file::load(std::path::Path::new(path)).unwrap_or_else(|e| fail(e));
        s.camera = s
            .camera
            .clone()
            .with_size(sz.0, sz.1)
            .unwrap_or_else(|e| fail(e));
        let analytic = Analytic::new(&s);
        let tables = gpu
            .as_ref()
            .map(|(ctx, _)| GpuRenderer::new(ctx, &analytic).unwrap_or_else(|e| fail(e)));
        let times: Vec<f64> = (0..repeat)
            .map(|_| frame(&s, &analytic, gpu.as_ref(), tables.as_ref(), false))
            .collect();
        println!("{path}: {:.0} ms", median(times));
        return;
    }
    print!("| gaussians |");
    for l in &lights {
        print!(" {l} light{} |", if *l == 1 { "" } else { "s" });
    }
    println!();
    println!("|---|{}", "---|".repeat(lights.len()));
    for &n in &counts {
        let cloud = Cloud::timing_room(n, spread);
        print!("| {n} |");
        for &l in &lights {
            let s = if no_environment {
                let text = scene_text(&cloud, l, sz, false, 0.9).replacen(
                    "\"environment\": [0.05, 0.06, 0.08]",
                    "\"environment\": null",
                    1,
                );
                file::parse(&text).unwrap_or_else(|e| fail(e))
            } else {
                scene(&cloud, l, sz, false, 0.9)
            };
            let analytic = Analytic::new(&s);
            let tables = gpu
                .as_ref()
                .map(|(ctx, _)| GpuRenderer::new(ctx, &analytic).unwrap_or_else(|e| fail(e)));
            let prep_flag = args.iter().any(|a| a == "--prep");
            let times: Vec<f64> = (0..repeat)
                .map(|_| frame(&s, &analytic, gpu.as_ref(), tables.as_ref(), prep_flag))
                .collect();
            print!(" {:.0} |", median(times));
        }
        println!();
    }
}

/// Pixels this close to a point light's image are left out of [`lamp_error`] (pixels).
const LIGHT_MASK: f64 = 4.0;

/// Relative RMS of `a` against the reference `r` over the pixels farther than
/// [`LIGHT_MASK`] from every point light's image: there the glow's `1/γ` peak is paper C's
/// mean over the pixel's disc of rays and the march's centre ray, a few pixels that would
/// otherwise decide the figure (docs/conventions.md's relative RMS otherwise).
fn lamp_error(s: &Scene, a: &Image, r: &Image) -> f64 {
    let lights: Vec<(f64, f64)> = s
        .lights
        .iter()
        .filter_map(|l| match l {
            haze_scene::scene::Light::Point { position, .. } => s.camera.project(*position),
            _ => None,
        })
        .collect();
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for y in 0..r.height {
        for x in 0..r.width {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            if lights
                .iter()
                .any(|&(lx, ly)| (px - lx).hypot(py - ly) < LIGHT_MASK)
            {
                continue;
            }
            let k = y * r.width + x;
            for c in 0..3 {
                let (p, q) = (f64::from(a.pixels[k][c]), f64::from(r.pixels[k][c]));
                diff += (p - q) * (p - q);
                norm += q * q;
            }
        }
    }
    if norm > 0.0 {
        (diff / norm).sqrt()
    } else {
        0.0
    }
}

/// The median of 3 CPU frames of `s` with `options` (ms), and the last image. The march
/// has no light scattered onto surfaces, so neither do these.
fn timed(s: &Scene, analytic: &Analytic, options: PaperBOptions) -> (f64, Image, (usize, usize)) {
    let options = PaperBOptions {
        surface_scattering: false,
        ..options
    };
    let mut times = Vec::new();
    let mut last = None;
    for _ in 0..3 {
        let t = Instant::now();
        let prep = Prepared::new(s, analytic, options).unwrap_or_else(|e| fail(e));
        let image = paper_b::render(&prep, &Limits::default(), &|_| {});
        times.push(t.elapsed().as_secs_f64() * 1e3);
        last = Some((image, prep.integrated_pairs()));
    }
    let (image, pairs) = last.unwrap_or_else(|| fail("no frame"));
    (median(times), image, pairs)
}

/// `--stride N` and `--target E`: the reused frames' coarsest grid and pair error bound
/// (`PaperBOptions::reuse`, `PaperBOptions::target`).
fn reuse_options(args: &[String]) -> PaperBOptions {
    let reuse = arg(args, "--stride").map_or(paper_b::reuse::DEFAULT_STRIDE, |s| {
        s.parse::<usize>()
            .ok()
            .filter(|n| *n >= 1)
            .unwrap_or_else(|| fail("--stride N: a whole number of pixels, at least 1"))
    });
    let target = arg(args, "--target").map_or(paper_b::DEFAULT_TARGET, |s| {
        s.parse::<f64>()
            .ok()
            .filter(|t| *t > 0.0)
            .unwrap_or_else(|| fail("--target E: a positive relative error"))
    });
    PaperBOptions {
        reuse,
        target,
        ..Default::default()
    }
}

fn lamps(args: &[String]) {
    let check = args.iter().any(|a| a == "--check");
    let reused_options = reuse_options(args);
    println!(
        "| scene | closed form | integrated pairs | every pixel | reused | {CPU_DEVICE_EXACT} exact | closed form ms | every pixel ms | reused ms | {CPU_DEVICE_EXACT} exact ms | reference s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let closed = PaperBOptions {
        target: f64::INFINITY,
        ..Default::default()
    };
    let every = PaperBOptions {
        reuse: 1,
        ..Default::default()
    };
    let device = PaperBOptions {
        max_exact: CPU_DEVICE_EXACT,
        ..every
    };
    for path in args[1..].iter().filter(|a| a.ends_with(".json")) {
        let s = file::load(std::path::Path::new(path)).unwrap_or_else(|e| fail(e));
        let analytic = Analytic::new(&s);
        let t = Instant::now();
        let r = reference(&s);
        let tr = t.elapsed().as_secs_f64();
        let (t0, closed, _) = timed(&s, &analytic, closed);
        let (t1, acc, (k, n)) = timed(&s, &analytic, every);
        let (t2, reused, _) = timed(&s, &analytic, reused_options);
        let (t4, four, _) = timed(&s, &analytic, device);
        println!(
            "| {path} | {:.2} % | {k} of {n} | {:.2} % | {:.2} % | {:.2} % | {t0:.0} | {t1:.0} | {t2:.0} | {t4:.0} | {tr:.1} |",
            100.0 * lamp_error(&s, &closed, &r),
            100.0 * lamp_error(&s, &acc, &r),
            100.0 * lamp_error(&s, &reused, &r),
            100.0 * lamp_error(&s, &four, &r)
        );
        if check {
            let mut s = s.clone();
            s.camera = s
                .camera
                .clone()
                .with_size(40, 30)
                .unwrap_or_else(|e| fail(e));
            let r = reference(&s);
            let mut opt = paper_b::reference_options(&s, paper_b::REFERENCE_THETA);
            opt.steps = None;
            opt.step = 0.25 * paper_b::march_step(&s);
            let t = Instant::now();
            let fine = march::render(&s, &Limits::default(), &opt, &|_| {});
            println!(
                "  reference against uniform steps of {:.4}: {:.3} % ({:.1} s)",
                opt.step,
                100.0 * lamp_error(&s, &r, &fine),
                t.elapsed().as_secs_f64()
            );
        }
    }
}

/// The reused picture against every pixel integrating: `(rel. RMS, largest relative
/// pixel error over pixels above a tenth of the image's mean)` (a lamp's glow makes the
/// peak no measure).
fn reuse_error(a: &Image, every: &Image) -> (f64, f64) {
    let values = every.pixels.iter().flat_map(|p| p.iter());
    let mean = values.clone().sum::<f32>() / values.count().max(1) as f32;
    let mut worst = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&every.pixels) {
        for c in 0..3 {
            if q[c] > 0.1 * mean {
                worst = worst.max(f64::from((p[c] - q[c]).abs() / q[c]));
            }
        }
    }
    (a.rel_rms(every), worst)
}

fn reuse(args: &[String]) {
    let sz = size(args, (320, 240));
    let counts = list(args, "--counts", &[1000, 5000]);
    let lights = list(args, "--lights", &[1, 4]);
    let spread = arg(args, "--spread").map_or(1.4, |s| {
        s.parse::<f64>()
            .ok()
            .filter(|r| *r > 0.0 && r.is_finite())
            .unwrap_or_else(|| fail("--spread R: a positive radius"))
    });
    let reused_options = reuse_options(args);
    println!(
        "| scene | pairs integrated | every pixel ms | reused ms | rel. RMS | largest pixel error |"
    );
    println!("|---|---|---|---|---|---|");
    let row = |name: &str, s: &Scene| {
        let analytic = Analytic::new(s);
        let every = PaperBOptions {
            reuse: 1,
            ..Default::default()
        };
        let (t1, a, (k, n)) = timed(s, &analytic, every);
        let (t2, b, _) = timed(s, &analytic, reused_options);
        let (rms, worst) = reuse_error(&b, &a);
        println!(
            "| {name} | {k} of {n} | {t1:.0} | {t2:.0} | {:.3} % | {:.2} % |",
            100.0 * rms,
            100.0 * worst
        );
    };
    let files: Vec<&String> = args[1..].iter().filter(|a| a.ends_with(".json")).collect();
    for path in &files {
        let s = file::load(std::path::Path::new(path.as_str())).unwrap_or_else(|e| fail(e));
        row(path, &s);
    }
    if !files.is_empty() && arg(args, "--counts").is_none() {
        return;
    }
    for &n in &counts {
        let cloud = Cloud::timing_room(n, spread);
        for &l in &lights {
            row(
                &format!("room, {n} gaussians, {l} lights"),
                &scene(&cloud, l, sz, false, 0.9),
            );
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("accuracy") => accuracy(&args),
        Some("timing") => timing(&args),
        Some("environment") => environment(&args),
        Some("lamps") => lamps(&args),
        Some("reuse") => reuse(&args),
        Some("scene") => {
            let path = args.get(1).unwrap_or_else(|| fail("scene PATH"));
            let cloud = Cloud {
                n: 150,
                spread: 1.3,
                radii: (0.15, 0.35),
                tau: 0.12,
                centre: [0.0, 0.0, 1.2],
            };
            let text = scene_text(&cloud, 2, (320, 240), false, 0.9).replacen(
                "\"gaussians\": [",
                "\"noise\": {\"seed\": 7, \"gain\": 1.5, \"frequency\": 2},\n      \"gaussians\": [",
                1,
            );
            let tmp = format!("{path}.tmp");
            std::fs::write(&tmp, text).unwrap_or_else(|e| fail(format!("{tmp}: {e}")));
            std::fs::rename(&tmp, path).unwrap_or_else(|e| fail(format!("{path}: {e}")));
            println!("{path}: 150 gaussians with noise, 2 point lights");
        }
        Some("sky-scene") => {
            // 100 Gaussians under the built-in sky and a sun along its glow, over a floor
            // and a glossy sphere (no back wall: it would hide half the sky).
            let path = args.get(1).unwrap_or_else(|| fail("sky-scene PATH"));
            let cloud = Cloud {
                n: 100,
                spread: 1.3,
                radii: (0.15, 0.35),
                tau: 0.08,
                centre: [0.0, 0.0, 1.2],
            };
            let text = scene_text(&cloud, 1, (320, 240), false, 0.9);
            let lights = text
                .split_once("  \"lights\": [\n")
                .and_then(|(_, rest)| rest.split_once("\n  ],"))
                .map(|(l, _)| l.to_string())
                .unwrap_or_else(|| fail("the room's lights"));
            let wall = text
                .lines()
                .find(|l| l.contains("\"point\": [0, 3, 0]"))
                .unwrap_or_else(|| fail("the room's wall"))
                .to_string();
            let text = text
                .replacen("\"environment\": [0.05, 0.06, 0.08]", "\"environment\": \"sky\"", 1)
                .replacen(
                    &lights,
                    "    {\"type\": \"sun\", \"direction\": [0.5, 0.3, 0.8], \"radiance\": [40, 36, 30], \"angle\": 0.0093}",
                    1,
                )
                .replacen(&format!("{wall}\n"), "", 1);
            let tmp = format!("{path}.tmp");
            std::fs::write(&tmp, text).unwrap_or_else(|e| fail(format!("{tmp}: {e}")));
            std::fs::rename(&tmp, path).unwrap_or_else(|e| fail(format!("{path}: {e}")));
            println!("{path}: 100 gaussians under the sky and a sun");
        }
        _ => fail(
            "usage: paper_b_figures accuracy|environment|timing|scene PATH|sky-scene PATH [options]",
        ),
    }
}
