//! Accuracy and cost of the fast renderer against the reference renderer (paper A Fig. 6),
//! and its trade curves, printed as the tables of BENCHMARKS.md.
//!
//! ```text
//! cargo run --release --example crm_accuracy -- VOLUME [--size WxH] [--spp N]
//!     [--sigma-t S] [--albedo A] [--g G] [--rbfs N] [--eye X,Y,Z --target X,Y,Z]
//!     [--sun-map ELEV,AZIM,ANGLE,RATIO | --sky CLASS,ELEV,AZIM [--max-lights N] [--save-sky FILE.exr] [--no-sun-extraction]]
//!     [--table fig6|order|rbfs|slices|cg|sun|ms|reference|all] [--cache DIR]
//!     [--diffusion centers|grid[:F]|orders[:F[:K]]]
//!     [--env centers|grid] [--env-spacing VOXELS] [--env-theta N] [--gpu]
//! ```
//!
//! VOLUME is one density frame (any format `haze` imports). It is fitted with `--rbfs`
//! RBFs as `haze bake` fits a first frame; the residual is kept exact. The camera frames
//! the smoke unless `--eye`/`--target` place it. Lighting is the built-in sky, or with
//! `--sun-map` a 512 × 256 HDR map: a clear sky over a dark ground and a sun disk painted
//! in (elevation and azimuth in degrees, apparent diameter in degrees, radiance RATIO ×
//! the zenith's). The fast renderer gets that map as a user's `--env` would (its sun
//! split off, unless `--no-sun-extraction`); the reference gets the sky without the disk
//! plus the exact sun, the same light sampled without noise from the disk. Errors are
//! `rel_rms` (docs/conventions.md) over the pixels where the smoke blocks at least 2 % of the
//! background, against the reference renderer at `--spp` samples per pixel (its own
//! noise, two seeds, is printed for scale). `--table reference` measures only the
//! reference's own noise under the light the fast renderer gets (no fit), with and
//! without importance sampling of the environment. `--table ms` measures the multiple
//! scattering part alone (final − single of both renderers) and, with `--cache`, writes
//! its images there as PNG. `--cache DIR` keeps the reference images and the fit between
//! runs (raw `f32` files keyed by every argument they depend on). `--env` chooses where
//! the environment's single scattering comes from (the RBF centers, paper A, or the
//! per-voxel grid, with its node spacing and direction rule) in every table but `fig6`,
//! which prints the three source choices side by side. `--gpu` renders the fast
//! renderer's images with `gpu::renderer` (every stage on the GPU adapter, lavapipe
//! will do) instead of `crm_render`; the references are the same.

use haze_fit::{SequenceFitter, SequenceOptions};
use haze_gpu::GpuContext;
use haze_view::diffusion::SolveOptions;
use haze_view::distant::direction;
use haze_view::gpu::renderer::{GpuFrame, GpuRenderer};
use haze_view::gpu::volume_pass::Residual;
use haze_view::lighting::single::SourcePoints;
use haze_view::lights::decompose::{DecomposeOptions, luminance};
use haze_view::reference::{self, RefOptions, rbf_volume};
use haze_view::render::env_pass::{EnvGridOptions, EnvSource};
use haze_view::render::supersample::tau_per_voxel;
use haze_view::render::{CrmOptions, CrmStats, MsDiffusion, crm_render};
use haze_view::{Camera, Environment, Image, LatLong, Medium, Sky, Sun};
use haze_volume::import::{ImportOptions, import};
use haze_volume::{Rbf, Volume};
use std::f64::consts::PI;
use std::time::Instant;

struct Args {
    input: String,
    size: (usize, usize),
    spp: u32,
    sigma_t: f64,
    albedo: f64,
    g: f64,
    rbfs: usize,
    table: String,
    eye: Option<[f64; 3]>,
    target: Option<[f64; 3]>,
    sun_map: Option<[f64; 4]>,
    sky: Option<(String, f64, f64)>,
    max_lights: usize,
    save_sky: Option<std::path::PathBuf>,
    extract: bool,
    cache: Option<std::path::PathBuf>,
    diffusion: MsDiffusion,
    env_source: EnvSource,
    max_bounces: Option<u32>,
    gpu: bool,
}

impl Args {
    /// The fast renderer's defaults with this run's environment source and diffusion
    /// (`--diffusion`; paper A's `centers` unless given, not `haze render`'s default).
    fn base(&self) -> CrmOptions {
        CrmOptions {
            env_source: self.env_source,
            diffusion: self.diffusion,
            ..CrmOptions::default()
        }
    }
}

fn parse() -> Result<Args, String> {
    let mut it = std::env::args().skip(1);
    let mut a = Args {
        input: String::new(),
        size: (200, 150),
        spp: 256,
        sigma_t: 4.0,
        albedo: 0.8,
        g: 0.3,
        rbfs: 300,
        table: "all".into(),
        diffusion: CrmOptions::default().diffusion,
        eye: None,
        target: None,
        sun_map: None,
        sky: None,
        max_lights: DecomposeOptions::default().max_lights,
        save_sky: None,
        extract: true,
        gpu: false,
        cache: None,
        env_source: CrmOptions::default().env_source,
        max_bounces: None,
    };
    let mut grid = EnvGridOptions::default();
    let list = |s: String, n: usize| -> Result<Vec<f64>, String> {
        let v: Vec<f64> = s
            .split(',')
            .map(|p| p.trim().parse::<f64>().map_err(|e| format!("{p}: {e}")))
            .collect::<Result<_, _>>()?;
        if v.len() == n {
            Ok(v)
        } else {
            Err(format!("{s}: expected {n} numbers"))
        }
    };
    while let Some(k) = it.next() {
        let mut v = || it.next().ok_or(format!("{k} needs a value"));
        let num = |s: String| s.parse::<f64>().map_err(|e| format!("{s}: {e}"));
        match k.as_str() {
            "--size" => {
                let s = v()?;
                let (w, h) = s.split_once('x').ok_or("--size WxH")?;
                a.size = (
                    w.parse().map_err(|_| "--size WxH")?,
                    h.parse().map_err(|_| "--size WxH")?,
                );
            }
            "--spp" => a.spp = num(v()?)? as u32,
            "--sigma-t" => a.sigma_t = num(v()?)?,
            "--albedo" => a.albedo = num(v()?)?,
            "--g" => a.g = num(v()?)?,
            "--rbfs" => a.rbfs = num(v()?)? as usize,
            "--table" => a.table = v()?,
            "--diffusion" => a.diffusion = parse_diffusion(&v()?)?,
            "--eye" => {
                let l = list(v()?, 3)?;
                a.eye = Some([l[0], l[1], l[2]]);
            }
            "--target" => {
                let l = list(v()?, 3)?;
                a.target = Some([l[0], l[1], l[2]]);
            }
            "--sun-map" => {
                let l = list(v()?, 4)?;
                a.sun_map = Some([l[0], l[1], l[2], l[3]]);
            }
            "--sky" => {
                let v = v()?;
                let parts: Vec<&str> = v.split(',').collect();
                if parts.len() != 3 || !SKY_CLASSES.contains(&parts[0]) {
                    return Err(format!(
                        "--sky {v}: CLASS,ELEV,AZIM with CLASS one of {}",
                        SKY_CLASSES.join(", ")
                    ));
                }
                a.sky = Some((
                    parts[0].to_string(),
                    num(parts[1].into())?,
                    num(parts[2].into())?,
                ));
            }
            "--max-lights" => a.max_lights = num(v()?)? as usize,
            "--save-sky" => a.save_sky = Some(v()?.into()),
            "--no-sun-extraction" => a.extract = false,
            "--gpu" => a.gpu = true,
            "--cache" => a.cache = Some(v()?.into()),
            "--max-bounces" => a.max_bounces = Some(num(v()?)? as u32),
            "--env" => {
                a.env_source = match v()?.as_str() {
                    "centers" => EnvSource::Centers,
                    "grid" => EnvSource::Grid(grid),
                    s => return Err(format!("--env {s}: centers or grid")),
                }
            }
            "--env-spacing" => {
                grid.spacing = num(v()?)?;
                grid.follow_smoke = false;
            }
            "--env-theta" => grid.theta = num(v()?)? as usize,
            _ if a.input.is_empty() => a.input = k,
            _ => return Err(format!("unexpected argument {k}")),
        }
    }
    if let EnvSource::Grid(g) = &mut a.env_source {
        *g = grid;
    }
    if a.input.is_empty() {
        return Err("usage: crm_accuracy VOLUME [--size WxH] [--spp N] [--sigma-t S] [--albedo A] [--g G] [--rbfs N] [--eye X,Y,Z --target X,Y,Z] [--sun-map ELEV,AZIM,ANGLE,RATIO | --sky CLASS,ELEV,AZIM [--max-lights N] [--save-sky FILE.exr] [--no-sun-extraction]] [--table fig6|order|rbfs|slices|cg|sun|ms|reference|all] [--cache DIR] [--diffusion centers|grid[:F]|orders[:F[:K]]] [--env centers|grid] [--env-spacing VOXELS] [--env-theta N] [--gpu]".into());
    }
    Ok(a)
}

/// `centers`, `grid[:F]` or `orders[:F[:K]]` (`MsDiffusion`'s syntax).
fn parse_diffusion(s: &str) -> Result<MsDiffusion, String> {
    let d: MsDiffusion = s.parse().map_err(|e| format!("--diffusion {e}"))?;
    d.check().map_err(|e| format!("--diffusion {s}: {e}"))?;
    Ok(d)
}

/// `rel_rms` over the pixels of `mask`.
fn err(a: &Image, r: &Image, mask: &[bool]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((p, q), m) in a.pixels.iter().zip(&r.pixels).zip(mask) {
        if *m {
            for c in 0..3 {
                num += f64::from(p[c] - q[c]).powi(2);
                den += f64::from(q[c]).powi(2);
            }
        }
    }
    (num / den.max(1e-300)).sqrt()
}

struct Scene {
    density: Volume,
    approx: Volume,
    rbfs: Vec<Rbf>,
    residual: Vec<f32>,
    medium: Medium,
    env: Environment,
    /// What the reference is lit by: the same light, the sun given exactly.
    ref_env: Environment,
    camera: Camera,
    mask: Vec<bool>,
    /// Render on this GPU (`--gpu`).
    gpu: Option<GpuContext>,
}

impl Scene {
    fn crm(&self, rbfs: &[Rbf], residual: bool, opts: CrmOptions) -> (Image, CrmStats, f64) {
        self.render(rbfs, residual.then_some(self.residual.as_slice()), opts)
    }

    fn render(
        &self,
        rbfs: &[Rbf],
        res: Option<&[f32]>,
        opts: CrmOptions,
    ) -> (Image, CrmStats, f64) {
        // The environment grid on the voxel centers where the smoke is thick, as
        // `haze render` lights it.
        let opts = opts.for_smoke(tau_per_voxel(&self.density, self.medium.sigma_t));
        let t = Instant::now();
        if let Some(ctx) = &self.gpu {
            let gpu = |e: haze_gpu::GpuError| -> ! { panic!("--gpu: {e}") };
            let mut r = GpuRenderer::new(ctx, self.env.clone()).unwrap_or_else(|e| gpu(e));
            let frame = GpuFrame {
                key: 0,
                rbfs,
                residual: res.map(Residual::Dense),
                dims: self.density.dims(),
                bbox: *self.density.bbox(),
            };
            let (image, mut stats) = r
                .render(ctx, &frame, &self.medium, &self.camera, &opts)
                .unwrap_or_else(|e| gpu(e));
            let pixels = image.read(ctx).unwrap_or_else(|e| gpu(e));
            r.read_solve(ctx, &mut stats).unwrap_or_else(|e| gpu(e));
            let img = Image {
                width: self.camera.width,
                height: self.camera.height,
                pixels,
            };
            return (img, stats.crm, t.elapsed().as_secs_f64());
        }
        let (img, stats) = crm_render(
            rbfs,
            res,
            self.density.dims(),
            self.density.bbox(),
            &self.medium,
            &self.env,
            &self.camera,
            &opts,
        );
        (img, stats, t.elapsed().as_secs_f64())
    }
}

fn fit(density: &Volume, n: usize) -> Vec<Rbf> {
    let opts = SequenceOptions {
        rbfs: n,
        ..SequenceOptions::default()
    };
    SequenceFitter::new(opts)
        .fit(density)
        .expect("fit")
        .rbfs
        .iter()
        .map(|r| Rbf::new(r.center, r.radius, r.weight))
        .collect()
}

fn main() {
    let a = match parse() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(2);
        }
    };
    let density = import(a.input.as_ref(), &ImportOptions::default()).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(1)
    });
    let peak = density.data().iter().fold(0.0f32, |m, &d| m.max(d));
    let bbox = density
        .occupied_bbox(0.01 * peak)
        .unwrap_or(*density.bbox());
    let camera = match (a.eye, a.target) {
        (Some(e), Some(t)) => Camera::new(e, t, [0.0, 0.0, 1.0], 40.0, a.size.0, a.size.1),
        _ => Camera::framing(bbox.min, bbox.max, 40.0, a.size.0, a.size.1),
    }
    .expect("camera");
    let medium = Medium::new(a.sigma_t, a.albedo, a.g).expect("medium");
    let (env, ref_env) = match (a.sun_map, &a.sky) {
        (None, None) => {
            let sky = Environment::sky(Sky::default());
            (sky.clone(), sky)
        }
        (Some([elev, azim, angle, ratio]), _) => {
            let (map, sky, sun) = sun_map(elev, azim, angle, ratio);
            let env = user_env(map, a.extract, a.max_lights);
            let (c, total) = sun_centroid(&env.suns);
            if total > 0.0 {
                println!(
                    "# {} sun(s) split off: their centroid {:.2}° from the painted one, irradiance {:.4} (painted {:.4})",
                    env.suns.len(),
                    dot(c, sun.direction).clamp(-1.0, 1.0).acos().to_degrees(),
                    total,
                    sun.irradiance[0]
                );
            }
            let mut ref_env = Environment::map(sky);
            ref_env.suns.push(sun);
            (env, ref_env)
        }
        (None, Some((class, elev, azim))) => {
            let map = sky_map(class, *elev, *azim);
            if let Some(path) = &a.save_sky {
                let image = Image {
                    width: map.width,
                    height: map.height,
                    pixels: map.texels.clone(),
                };
                image
                    .write_exr(path)
                    .expect("--save-sky: the map is written");
                println!("# sky written to {}", path.display());
            }
            let t = Instant::now();
            let env = user_env(map.clone(), a.extract, a.max_lights);
            println!(
                "# sky {class} at elevation {elev}°, azimuth {azim}°: {} sun(s) split off ({:.1} ms)",
                env.suns.len(),
                1e3 * t.elapsed().as_secs_f64()
            );
            (env, Environment::map(map))
        }
    };
    if a.table == "reference" {
        let d = density.dims();
        println!(
            "# {} ({}×{}×{}), {}×{}, σt {}, albedo {}, g {}, {}",
            a.input,
            d[0],
            d[1],
            d[2],
            a.size.0,
            a.size.1,
            a.sigma_t,
            a.albedo,
            a.g,
            match (a.sun_map, env.suns.is_empty()) {
                (None, _) => a
                    .sky
                    .as_ref()
                    .map_or("sky".to_string(), |s| format!("sky {}", s.0)),
                (Some(s), whole) => format!(
                    "sun map (elevation {}°, azimuth {}°, {}°, {}× the zenith), {}",
                    s[0],
                    s[1],
                    s[2],
                    s[3],
                    if whole { "whole" } else { "sun split off" }
                ),
            }
        );
        reference_noise(&density, &medium, &env, &camera, a.spp);
        return;
    }
    let rbfs = cached_fit(&a, &density);
    let approx = rbf_volume(&rbfs, density.dims(), *density.bbox()).expect("grid");
    let residual: Vec<f32> = density
        .data()
        .iter()
        .zip(approx.data())
        .map(|(d, x)| d - x)
        .collect();
    let white = Environment::map(LatLong::new(4, 2, vec![[1.0; 3]; 8]).expect("map"));
    let t_only = reference::render(
        &density,
        &Medium::new(a.sigma_t, 0.0, 0.0).expect("medium"),
        &white,
        &camera,
        &RefOptions {
            spp: 1,
            multiple: false,
            ..RefOptions::default()
        },
    );
    let mask: Vec<bool> = t_only.pixels.iter().map(|p| p[0] < 0.98).collect();
    let scene = Scene {
        density,
        approx,
        rbfs,
        residual,
        medium,
        env,
        ref_env,
        camera,
        mask,
        gpu: a
            .gpu
            .then(|| GpuContext::new().unwrap_or_else(|e| panic!("--gpu: {e}"))),
    };
    let d = scene.density.dims();
    println!(
        "# {} ({}×{}×{}), {} RBFs (rms/max {:.4}), {}×{}, σt {}, albedo {}, g {}, {}; {} smoke pixels; reference {} spp",
        a.input,
        d[0],
        d[1],
        d[2],
        scene.rbfs.len(),
        rms_over_max(&scene.density, &scene.approx),
        a.size.0,
        a.size.1,
        a.sigma_t,
        a.albedo,
        a.g,
        match a.sun_map {
            None => a.sky.as_ref().map_or("sky".to_string(), |s| format!(
                "sky class {} at {}°, {}°",
                s.0, s.1, s.2
            )),
            Some(s) => format!(
                "sun map (elevation {}°, azimuth {}°, {}°, {}× the zenith){}",
                s[0],
                s[1],
                s[2],
                s[3],
                if a.extract { "" } else { ", not extracted" }
            ),
        },
        scene.mask.iter().filter(|m| **m).count(),
        a.spp
    );
    let reference = |volume: &Volume, multiple: bool, seed: u64| {
        let t = Instant::now();
        let opts = RefOptions {
            spp: a.spp,
            multiple,
            seed,
            max_bounces: a.max_bounces.unwrap_or(RefOptions::default().max_bounces),
            ..RefOptions::default()
        };
        let key = format!(
            "ref|{}|{:?}|{}|{}|{}|{}|{:?}|{:?}|{:?}|{multiple}|{seed}|{}{}",
            a.input,
            a.size,
            a.spp,
            a.sigma_t,
            a.albedo,
            a.g,
            (a.sun_map, &a.sky),
            a.eye,
            a.target,
            // The density rendered: the original or the fit's approximation.
            volume.data().iter().map(|v| f64::from(*v)).sum::<f64>(),
            // Truncated paths only where asked (the keys of full paths unchanged).
            match a.max_bounces {
                Some(n) if multiple => format!("|bounces {n}"),
                _ => String::new(),
            }
        );
        if let Some(img) = cache_read(&a, &key) {
            return (img, 0.0);
        }
        let img = reference::render(volume, &scene.medium, &scene.ref_env, &scene.camera, &opts);
        cache_write(&a, &key, &img);
        (img, t.elapsed().as_secs_f64())
    };
    let all = a.table == "all";
    let (final_ref, t_ref) = reference(&scene.density, true, 1);
    let (final_ref2, _) = reference(&scene.density, true, 2);
    let noise = err(&final_ref2, &final_ref, &scene.mask) / 2f64.sqrt();
    println!(
        "# reference (multiple, D): {t_ref:.1} s, noise {noise:.4} (rel_rms of two seeds / √2)"
    );
    if all || a.table == "sun" {
        let (ss_ref, t_ss) = reference(&scene.density, false, 1);
        let (ss_ref2, _) = reference(&scene.density, false, 2);
        let ss_noise = err(&ss_ref2, &ss_ref, &scene.mask) / 2f64.sqrt();
        println!("# reference (single, D): {t_ss:.1} s, noise {ss_noise:.4}");
        println!(
            "\n| image (D̃ + R vs reference on D) | rel RMS | mean ratio | CRM s | lights pass s |"
        );
        println!("|---|---|---|---|---|");
        let mut means = Vec::new();
        for (name, multiple, r) in [
            ("single scattering", false, &ss_ref),
            ("final", true, &final_ref),
        ] {
            let (img, s, t) = scene.crm(
                &scene.rbfs,
                true,
                CrmOptions {
                    multiple,
                    ..a.base()
                },
            );
            println!(
                "| {name} | {:.4} | {:.3} | {t:.3} | {:.3} |",
                err(&img, r, &scene.mask),
                mean_ratio(&img, r, &scene.mask),
                s.lights_seconds
            );
            means.push((masked_mean(&img, &scene.mask), masked_mean(r, &scene.mask)));
        }
        // The multiple-scattering part alone, in mean radiance: final − single.
        println!(
            "# multiple scattering part: {:.3} of the reference's (which is {:.1} % of its final image)",
            (means[1].0 - means[0].0) / (means[1].1 - means[0].1),
            100.0 * (means[1].1 - means[0].1) / means[1].1
        );
    }
    if a.table == "ms" {
        multiple_part(
            &a,
            &scene,
            [&final_ref, &final_ref2],
            &reference(&scene.density, false, 1).0,
        );
    }
    if all || a.table == "fig6" {
        let (ss_ref, _) = reference(&scene.approx, false, 1);
        let (ms_ref, _) = reference(&scene.approx, true, 1);
        println!("\n| image | source points | rel RMS | CRM s |");
        println!("|---|---|---|---|");
        let grid = match a.env_source {
            EnvSource::Grid(g) => g,
            EnvSource::Centers => EnvGridOptions::default(),
        };
        for (points, env_source) in [
            (SourcePoints::Center, EnvSource::Centers),
            (SourcePoints::Footprint, EnvSource::Centers),
            (SourcePoints::Footprint, EnvSource::Grid(grid)),
        ] {
            let opts = CrmOptions {
                source_points: points,
                env_source,
                ..a.base()
            };
            let points = match env_source {
                EnvSource::Centers => format!("{points:?}"),
                EnvSource::Grid(g) => format!(
                    "grid ({} voxels, {} directions)",
                    g.spacing,
                    8 * g.theta * g.theta
                ),
            };
            let rows: [(&str, bool, bool, &Image); 3] = [
                ("single scattering in D̃", false, false, &ss_ref),
                ("single + multiple in D̃", true, false, &ms_ref),
                ("final (D̃ + R, multiple)", true, true, &final_ref),
            ];
            for (name, multiple, residual, r) in rows {
                let (img, _, t) = scene.crm(&scene.rbfs, residual, CrmOptions { multiple, ..opts });
                println!(
                    "| {name} | {points} | {:.4} | {t:.3} |",
                    err(&img, r, &scene.mask)
                );
            }
        }
    }
    if all || a.table == "order" {
        println!(
            "\n| SH order | rel RMS (final) | single s | multiple s | volume s | view s | total s |"
        );
        println!("|---|---|---|---|---|---|---|");
        for order in 1..=6 {
            let (img, s, t) = scene.crm(&scene.rbfs, true, CrmOptions { order, ..a.base() });
            println!(
                "| {order} | {:.4} | {:.3} | {:.3} | {:.3} | {:.3} | {t:.3} |",
                err(&img, &final_ref, &scene.mask),
                s.single_seconds,
                s.multiple_seconds,
                s.volume_seconds,
                s.view_seconds
            );
        }
    }
    if all || a.table == "rbfs" {
        println!(
            "\n| RBFs | fit rms/max | rel RMS in D̃ (vs ref. on D) | rel RMS final | single s | multiple s | total s |"
        );
        println!("|---|---|---|---|---|---|---|");
        for n in [50, 100, 200, 400, 800] {
            let rbfs = fit(&scene.density, n);
            let approx = rbf_volume(&rbfs, d, *scene.density.bbox()).expect("grid");
            let residual: Vec<f32> = scene
                .density
                .data()
                .iter()
                .zip(approx.data())
                .map(|(d, x)| d - x)
                .collect();
            let (no_res, _, _) = scene.crm(&rbfs, false, a.base());
            let (img, s, total) = scene.render(&rbfs, Some(&residual), a.base());
            println!(
                "| {} | {:.4} | {:.4} | {:.4} | {:.3} | {:.3} | {total:.3} |",
                rbfs.len(),
                rms_over_max(&scene.density, &approx),
                err(&no_res, &final_ref, &scene.mask),
                err(&img, &final_ref, &scene.mask),
                s.single_seconds,
                s.multiple_seconds
            );
        }
    }
    if all || a.table == "slices" {
        println!("\n| slices per voxel | rel RMS (final) | view s |");
        println!("|---|---|---|");
        for spv in [0.5, 1.0, 2.0, 4.0] {
            let (img, s, _) = scene.crm(
                &scene.rbfs,
                true,
                CrmOptions {
                    slices_per_voxel: spv,
                    ..a.base()
                },
            );
            println!(
                "| {spv} | {:.4} | {:.3} |",
                err(&img, &final_ref, &scene.mask),
                s.view_seconds
            );
        }
    }
    if all || a.table == "cg" {
        println!("\n| CG iterations (max) | used | CG residual | rel RMS (final) | multiple s |");
        println!("|---|---|---|---|---|");
        for it in [0, 5, 10, 20, 50, 100, 500] {
            let (img, s, _) = scene.crm(
                &scene.rbfs,
                true,
                CrmOptions {
                    solve: SolveOptions {
                        max_iterations: it,
                        ..SolveOptions::default()
                    },
                    ..a.base()
                },
            );
            println!(
                "| {it} | {} | {:.2e} | {:.4} | {:.3} |",
                s.cg_iterations,
                s.cg_residual,
                err(&img, &final_ref, &scene.mask),
                s.multiple_seconds
            );
        }
    }
}

/// The multiple-scattering part alone: final − single of the fast renderer against the
/// same difference of the reference (both on the original density), as `rel_rms` and mean
/// ratio over the smoke pixels, with the images (same exposure) in the cache directory.
/// The multiple-scattering part (final − single) of the fast renderer against the
/// reference's (`finals`: two seeds; the first is the table's reference, their mean, at
/// twice the samples and `1/√2` the noise, is printed beside it).
fn multiple_part(a: &Args, scene: &Scene, finals: [&Image; 2], single_ref: &Image) {
    let final_ref = finals[0];
    let (single, _, _) = scene.crm(
        &scene.rbfs,
        true,
        CrmOptions {
            multiple: false,
            ..a.base()
        },
    );
    let (fin, stats, _) = scene.crm(
        &scene.rbfs,
        true,
        CrmOptions {
            diffusion: a.diffusion,
            ..a.base()
        },
    );
    let diff = |x: &Image, y: &Image| Image {
        width: x.width,
        height: x.height,
        pixels: x
            .pixels
            .iter()
            .zip(&y.pixels)
            .map(|(p, q)| [0, 1, 2].map(|c| p[c] - q[c]))
            .collect(),
    };
    let ms = diff(&fin, &single);
    let ms_ref = diff(final_ref, single_ref);
    println!(
        "single {:.4} (ratio {:.3}) | final {:.4} (ratio {:.3}) | ms part {:.4} (ratio {:.3}, {:.1} % of the reference's final) | CG {} it",
        err(&single, single_ref, &scene.mask),
        mean_ratio(&single, single_ref, &scene.mask),
        err(&fin, final_ref, &scene.mask),
        mean_ratio(&fin, final_ref, &scene.mask),
        err(&ms, &ms_ref, &scene.mask),
        mean_ratio(&ms, &ms_ref, &scene.mask),
        100.0 * masked_mean(&ms_ref, &scene.mask) / masked_mean(final_ref, &scene.mask),
        stats.cg_iterations
    );
    let both = Image {
        width: final_ref.width,
        height: final_ref.height,
        pixels: finals[0]
            .pixels
            .iter()
            .zip(&finals[1].pixels)
            .map(|(p, q)| [0, 1, 2].map(|c| 0.5 * (p[c] + q[c])))
            .collect(),
    };
    println!(
        "final against both seeds' mean ({} spp) {:.4} | ms part {:.4} | {:.3} s multiple",
        2 * a.spp,
        err(&fin, &both, &scene.mask),
        err(&ms, &diff(&both, single_ref), &scene.mask),
        stats.multiple_seconds
    );
    if let Some(dir) = &a.cache {
        let exposure = 0.5 / masked_mean(&ms_ref, &scene.mask).max(1e-12);
        // Side by side: haze's multiple scattering, the reference's, the reference's final
        // image at half the exposure and the difference, scaled up 3× for viewing.
        // The fourth panel: haze − reference, red where haze is brighter, blue where darker
        // (green channel mean of the two), at 2× the exposure.
        let signed = Image {
            width: ms.width,
            height: ms.height,
            pixels: ms
                .pixels
                .iter()
                .zip(&ms_ref.pixels)
                .map(|(p, q)| {
                    let d = (p[0] + p[1] + p[2] - q[0] - q[1] - q[2]) / 3.0;
                    [2.0 * d.max(0.0), 0.0, 2.0 * (-d).max(0.0)]
                })
                .collect(),
        };
        let panels = [
            (&ms, 1.0f32),
            (&ms_ref, 1.0),
            (final_ref, 0.5),
            (&signed, 1.0),
        ];
        let (w, h, k) = (ms.width, ms.height, 3);
        let mut side = Image::new(4 * w * k, h * k);
        for y in 0..h * k {
            for x in 0..4 * w * k {
                let (panel, scale) = panels[x / (w * k)];
                let p = panel.get((x % (w * k)) / k, y / k);
                side.pixels[y * 4 * w * k + x] = p.map(|c| c * scale);
            }
        }
        side.write_png(&dir.join("ms.png"), exposure, haze_view::ToneMap::Clip)
            .expect("png");
    }
}

fn cache_path(a: &Args, key: &str) -> Option<std::path::PathBuf> {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    key.hash(&mut h);
    a.cache
        .as_ref()
        .map(|d| d.join(format!("{:016x}.f32", h.finish())))
}

/// A cached image: width, height (u32 LE), then RGB `f32` LE.
fn cache_read(a: &Args, key: &str) -> Option<Image> {
    let bytes = std::fs::read(cache_path(a, key)?).ok()?;
    let word = |i: usize| f32::from_le_bytes(bytes[4 * i..4 * i + 4].try_into().expect("4"));
    let (w, h) = (
        u32::from_le_bytes(bytes[0..4].try_into().ok()?) as usize,
        u32::from_le_bytes(bytes[4..8].try_into().ok()?) as usize,
    );
    (bytes.len() == 8 + 12 * w * h).then(|| Image {
        width: w,
        height: h,
        pixels: (0..w * h)
            .map(|p| [0, 1, 2].map(|c| word(2 + 3 * p + c)))
            .collect(),
    })
}

fn cache_write(a: &Args, key: &str, img: &Image) {
    let Some(path) = cache_path(a, key) else {
        return;
    };
    let mut bytes = Vec::with_capacity(8 + 12 * img.pixels.len());
    bytes.extend((img.width as u32).to_le_bytes());
    bytes.extend((img.height as u32).to_le_bytes());
    for p in &img.pixels {
        for c in p {
            bytes.extend(c.to_le_bytes());
        }
    }
    std::fs::create_dir_all(path.parent().expect("dir")).expect("cache dir");
    std::fs::write(path, bytes).expect("cache write");
}

/// `fit` with its RBFs kept in the cache (center, radius, weight: 5 numbers per line).
fn cached_fit(a: &Args, density: &Volume) -> Vec<Rbf> {
    let path = cache_path(a, &format!("fit|{}|{}", a.input, a.rbfs));
    if let Some(text) = path.as_ref().and_then(|p| std::fs::read_to_string(p).ok()) {
        return text
            .lines()
            .map(|l| {
                let v: Vec<f64> = l
                    .split(' ')
                    .map(|x| x.parse().expect("cached fit"))
                    .collect();
                Rbf::new([v[0], v[1], v[2]], v[3], v[4])
            })
            .collect();
    }
    let rbfs = fit(density, a.rbfs);
    if let Some(p) = path {
        let text: String = rbfs
            .iter()
            .map(|r| {
                format!(
                    "{:e} {:e} {:e} {:e} {:e}\n",
                    r.center[0], r.center[1], r.center[2], r.radius, r.weight
                )
            })
            .collect();
        std::fs::create_dir_all(p.parent().expect("dir")).expect("cache dir");
        std::fs::write(p, text).expect("cache write");
    }
    rbfs
}

/// The reference renderer's own noise (`render_with_noise`: two half-runs, docs/conventions.md's
/// mask, what `haze render --reference` prints) under the light the user gives (`env`:
/// the sky, or the map with its sun split off or, with `--no-sun-extraction`, whole),
/// both estimators, with the environment importance-sampled (MIS) and without.
fn reference_noise(
    density: &Volume,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    spp: u32,
) {
    println!("\n| estimator | environment sampling | spp | noise | s |");
    println!("|---|---|---|---|---|");
    for multiple in [false, true] {
        for env_sampling in [false, true] {
            let opts = RefOptions {
                spp,
                multiple,
                env_sampling,
                ..RefOptions::default()
            };
            let t = Instant::now();
            let (_, noise) = reference::render_with_noise(density, medium, env, camera, &opts);
            println!(
                "| {} | {} | {spp} | {} | {:.1} |",
                if multiple { "paths" } else { "single" },
                if env_sampling { "MIS" } else { "phase only" },
                noise.map_or("-".to_string(), |n| format!("{:.2} %", 100.0 * n)),
                t.elapsed().as_secs_f64()
            );
        }
    }
}

/// Mean radiance of `a` over that of `r` on the mask (energy; 1 is right).
fn mean_ratio(a: &Image, r: &Image, mask: &[bool]) -> f64 {
    let (mut x, mut y) = (0.0, 0.0);
    for ((p, q), m) in a.pixels.iter().zip(&r.pixels).zip(mask) {
        if *m {
            for c in 0..3 {
                x += f64::from(p[c]);
                y += f64::from(q[c]);
            }
        }
    }
    x / y.max(1e-300)
}

/// Mean radiance over the mask.
fn masked_mean(a: &Image, mask: &[bool]) -> f64 {
    let (mut x, mut n) = (0.0, 0usize);
    for (p, m) in a.pixels.iter().zip(mask) {
        if *m {
            x += p.iter().map(|c| f64::from(*c)).sum::<f64>();
            n += 3;
        }
    }
    x / n.max(1) as f64
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A 512 × 256 clear sky (the built-in sky's colours without its glow) over a dark
/// ground, with a sun disk of apex `angle` degrees at elevation `elev`, azimuth `azim`,
/// radiance `ratio` × the zenith's, each texel the mean of 4 × 4 subsamples (partly
/// covered edge texels, as in a photographed map). Returns the map, the same map
/// without the disk, and the sun.
fn sun_map(elev: f64, azim: f64, angle: f64, ratio: f64) -> (LatLong, LatLong, Sun) {
    let (w, h) = (512, 256);
    let sky = Sky {
        sun: [0.0; 3],
        ground: [0.05, 0.045, 0.04],
        ..Sky::default()
    };
    let radiance = sky.zenith.map(|c| c * ratio);
    let sun = Sun::from_radiance(
        direction((90.0 - elev).to_radians(), azim.to_radians()),
        radiance,
        angle,
    )
    .expect("sun");
    let (mut with, mut without) = (Vec::with_capacity(w * h), Vec::with_capacity(w * h));
    for y in 0..h {
        for x in 0..w {
            let (mut acc, mut disk, mut wsum) = ([0.0f64; 3], 0.0, 0.0);
            for sy in 0..4 {
                for sx in 0..4 {
                    let theta = PI * (y as f64 + (sy as f64 + 0.5) / 4.0) / h as f64;
                    let phi = 2.0 * PI * (x as f64 + (sx as f64 + 0.5) / 4.0) / w as f64;
                    let d = direction(theta, phi);
                    let wt = theta.sin();
                    let l = sky.radiance(d);
                    for c in 0..3 {
                        acc[c] += wt * l[c];
                    }
                    if sun.covers(d) {
                        disk += wt;
                    }
                    wsum += wt;
                }
            }
            let base = acc.map(|c| c / wsum);
            let f = disk / wsum;
            without.push(base.map(|c| c as f32));
            with.push([0, 1, 2].map(|c| (base[c] + f * radiance[c]) as f32));
        }
    }
    (
        LatLong::new(w, h, with).expect("map"),
        LatLong::new(w, h, without).expect("map"),
        sun,
    )
}

fn rms_over_max(d: &Volume, x: &Volume) -> f64 {
    let peak = d.data().iter().fold(0.0f32, |m, &v| m.max(v));
    let se: f64 = d
        .data()
        .iter()
        .zip(x.data())
        .map(|(a, b)| f64::from(a - b).powi(2))
        .sum();
    (se / d.len() as f64).sqrt() / f64::from(peak).max(1e-30)
}

/// The environment a user's `--env` map gives the fast renderer: its concentrated light
/// split off into at most `max_lights` suns, or (`extract` false) whole.
fn user_env(map: LatLong, extract: bool, max_lights: usize) -> Environment {
    if extract {
        let opts = DecomposeOptions {
            max_lights,
            ..DecomposeOptions::default()
        };
        Environment::map_decomposed(&map, &opts).0
    } else {
        Environment::map(map)
    }
}

/// The suns' luminance-weighted mean direction and total red irradiance.
fn sun_centroid(suns: &[Sun]) -> ([f64; 3], f64) {
    let (mut c, mut total) = ([0.0; 3], 0.0);
    for s in suns {
        let y = luminance(s.irradiance);
        for (v, d) in c.iter_mut().zip(s.direction) {
            *v += y * d;
        }
        total += s.irradiance[0];
    }
    let n = dot(c, c).sqrt().max(1e-300);
    (c.map(|v| v / n), total)
}

/// The sky classes of `--sky`.
const SKY_CLASSES: [&str; 7] = ["sharp", "soft6", "soft8", "two", "cloud", "overcast", "low"];

/// A 1024 × 512 lat-long map of a sky class, its main light at elevation `elev`, azimuth
/// `azim` (degrees), over a clear sky (the built-in sky's colours without its glow) and a
/// dark ground; each texel the mean of 2 × 2 subsamples:
/// - `sharp`: a sun disk 0.75° wide at 40 000× the zenith;
/// - `soft6`, `soft8`: a hazy sun, a Gaussian lobe of σ 6° / 8° at 840× / 450× the zenith;
/// - `two`: a sun (a lobe of σ 1°) and, 110° away in azimuth and 20° lower, a bright window
///   (15° × 10° at 40×), a key and a fill;
/// - `cloud`: a sun (σ 0.5°) and a bright cloud edge, an arc 25° long and 3° thick at 60×,
///   curving 10° from it;
/// - `overcast`: an even grey sky (1 + 2 cos θ above the horizon), no sun;
/// - `low`: a sharp sun (σ 0.3°) at the given elevation beside a glowing horizon (4× the
///   zenith) and a broad bluish lobe (σ 20°) above it.
fn sky_map(class: &str, elev: f64, azim: f64) -> LatLong {
    let (w, h) = (1024, 512);
    let sky = Sky {
        sun: [0.0; 3],
        ground: [0.05, 0.045, 0.04],
        ..Sky::default()
    };
    let z = sky.zenith;
    let main = direction((90.0 - elev).to_radians(), azim.to_radians());
    let other = direction(
        (90.0 - (elev - 20.0).max(2.0)).to_radians(),
        (azim + 110.0).to_radians(),
    );
    let lobe = |d: [f64; 3], at: [f64; 3], sigma_deg: f64| {
        let a = dot(d, at).clamp(-1.0, 1.0).acos();
        (-0.5 * (a / sigma_deg.to_radians()).powi(2)).exp()
    };
    let radiance = |d: [f64; 3]| -> [f64; 3] {
        let base = if class == "overcast" {
            let v = if d[2] >= 0.0 {
                0.4 * (1.0 + 2.0 * d[2])
            } else {
                0.06
            };
            [v, v, v]
        } else {
            sky.radiance(d)
        };
        let add = |k: f64, tint: [f64; 3]| [0, 1, 2].map(|c| base[c] + k * tint[c]);
        let warm = [1.0, 0.93, 0.85].map(|c| c * z[2]);
        match class {
            "sharp" => {
                let inside = dot(d, main) >= (0.375f64).to_radians().cos();
                add(if inside { 40_000.0 } else { 0.0 }, warm)
            }
            "soft6" => add(840.0 * lobe(d, main, 6.0), warm),
            "soft8" => add(450.0 * lobe(d, main, 8.0), warm),
            "two" => {
                let (theta, phi) = haze_view::distant::angles(d);
                let (t0, p0) = haze_view::distant::angles(other);
                let dp = (phi - p0 + PI).rem_euclid(2.0 * PI) - PI;
                let window = ((theta - t0).abs() < 5f64.to_radians()
                    && (dp * theta.sin()).abs() < 7.5f64.to_radians())
                    as u8 as f64;
                let k = 6000.0 * lobe(d, main, 1.0);
                [0, 1, 2].map(|c| base[c] + k * warm[c] + 40.0 * window * z[2])
            }
            "cloud" => {
                // The arc: directions 10° from the sun, within ±12.5° of azimuth about it
                // around the sun, 3° thick.
                let a = dot(d, main).clamp(-1.0, 1.0).acos().to_degrees();
                let (_, phi) = haze_view::distant::angles(d);
                let near = ((phi - azim.to_radians() + PI).rem_euclid(2.0 * PI) - PI).abs() < 0.6;
                let arc = (((a - 10.0) / 1.5).powi(2) < 1.0 && near && d[2] > main[2]) as u8 as f64;
                let k = 25_000.0 * lobe(d, main, 0.5);
                [0, 1, 2].map(|c| base[c] + k * warm[c] + 60.0 * arc * z[2])
            }
            "overcast" => base,
            _ => {
                // low: a sharp sun, a glowing horizon, a broad bluish lobe above the sun.
                let (theta, _) = haze_view::distant::angles(d);
                let glow = if d[2] >= 0.0 {
                    4.0 * (-((theta - 0.5 * PI) / 0.1).powi(2)).exp()
                } else {
                    0.0
                };
                let up = direction((90.0 - elev - 25.0).to_radians(), azim.to_radians());
                let k = 100_000.0 * lobe(d, main, 0.3);
                [0, 1, 2].map(|c| {
                    base[c]
                        + k * warm[c]
                        + glow * z[2]
                        + 6.0 * lobe(d, up, 20.0) * [0.6, 0.8, 1.0][c]
                })
            }
        }
    };
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let (mut acc, mut wsum) = ([0.0f64; 3], 0.0);
            for sy in 0..2 {
                for sx in 0..2 {
                    let theta = PI * (y as f64 + (sy as f64 + 0.5) / 2.0) / h as f64;
                    let phi = 2.0 * PI * (x as f64 + (sx as f64 + 0.5) / 2.0) / w as f64;
                    let wt = theta.sin();
                    let l = radiance(direction(theta, phi));
                    for c in 0..3 {
                        acc[c] += wt * l[c];
                    }
                    wsum += wt;
                }
            }
            texels.push(acc.map(|c| (c / wsum) as f32));
        }
    }
    LatLong::new(w, h, texels).expect("map")
}
