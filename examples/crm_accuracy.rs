//! Accuracy and cost of the fast renderer against the reference renderer (paper A Fig. 6),
//! and its trade curves, printed as the tables of BENCHMARKS.md.
//!
//! ```text
//! cargo run --release --example crm_accuracy -- VOLUME [--size WxH] [--spp N]
//!     [--sigma-t S] [--albedo A] [--g G] [--rbfs N] [--table fig6|order|rbfs|slices|cg|all]
//! ```
//!
//! VOLUME is one density frame (any format `haze` imports). It is fitted with `--rbfs`
//! RBFs as `haze bake` fits a first frame; the residual is kept exact. The camera frames
//! the smoke; lighting is the built-in sky. Errors are `rel_rms` (DESIGN.md) over the
//! pixels where the smoke blocks at least 2 % of the background, against the reference
//! renderer at `--spp` samples per pixel (its own noise is printed for scale).

use haze_fit::{SequenceFitter, SequenceOptions};
use haze_view::diffusion::SolveOptions;
use haze_view::lighting::single::SourcePoints;
use haze_view::reference::{self, RefOptions, rbf_volume};
use haze_view::render::{CrmOptions, CrmStats, crm_render};
use haze_view::{Camera, Environment, Image, LatLong, Medium, Sky};
use haze_volume::import::{ImportOptions, import};
use haze_volume::{Rbf, Volume};
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
            _ if a.input.is_empty() => a.input = k,
            _ => return Err(format!("unexpected argument {k}")),
        }
    }
    if a.input.is_empty() {
        return Err("usage: crm_accuracy VOLUME [--size WxH] [--spp N] [--sigma-t S] [--albedo A] [--g G] [--rbfs N] [--table fig6|order|rbfs|slices|cg|all]".into());
    }
    Ok(a)
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
    camera: Camera,
    mask: Vec<bool>,
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
        let t = Instant::now();
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
    let rbfs = fit(&density, a.rbfs);
    let approx = rbf_volume(&rbfs, density.dims(), *density.bbox()).expect("grid");
    let residual: Vec<f32> = density
        .data()
        .iter()
        .zip(approx.data())
        .map(|(d, x)| d - x)
        .collect();
    let peak = density.data().iter().fold(0.0f32, |m, &d| m.max(d));
    let bbox = density
        .occupied_bbox(0.01 * peak)
        .unwrap_or(*density.bbox());
    let camera = Camera::framing(&bbox, 40.0, a.size.0, a.size.1).expect("camera");
    let medium = Medium::new(a.sigma_t, a.albedo, a.g).expect("medium");
    let env = Environment::Sky(Sky::default());
    let white = Environment::Map(LatLong::new(4, 2, vec![[1.0; 3]; 8]).expect("map"));
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
        camera,
        mask,
    };
    let d = scene.density.dims();
    println!(
        "# {} ({}×{}×{}), {} RBFs (rms/max {:.4}), {}×{}, σt {}, albedo {}, g {}, sky; {} smoke pixels; reference {} spp",
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
        scene.mask.iter().filter(|m| **m).count(),
        a.spp
    );
    let reference = |volume: &Volume, multiple: bool, seed: u64| {
        let t = Instant::now();
        let opts = RefOptions {
            spp: a.spp,
            multiple,
            seed,
            ..RefOptions::default()
        };
        let img = reference::render(volume, &scene.medium, &scene.env, &scene.camera, &opts);
        (img, t.elapsed().as_secs_f64())
    };
    let all = a.table == "all";
    let (final_ref, t_ref) = reference(&scene.density, true, 1);
    let (final_ref2, _) = reference(&scene.density, true, 2);
    let noise = err(&final_ref2, &final_ref, &scene.mask) / 2f64.sqrt();
    println!(
        "# reference (multiple, D): {t_ref:.1} s, noise {noise:.4} (rel_rms of two seeds / √2)"
    );
    if all || a.table == "fig6" {
        let (ss_ref, _) = reference(&scene.approx, false, 1);
        let (ms_ref, _) = reference(&scene.approx, true, 1);
        println!("\n| image | source points | rel RMS | CRM s |");
        println!("|---|---|---|---|");
        for points in [SourcePoints::Center, SourcePoints::Footprint] {
            let opts = CrmOptions {
                source_points: points,
                ..CrmOptions::default()
            };
            let rows: [(&str, bool, bool, &Image); 3] = [
                ("single scattering in D̃", false, false, &ss_ref),
                ("single + multiple in D̃", true, false, &ms_ref),
                ("final (D̃ + R, multiple)", true, true, &final_ref),
            ];
            for (name, multiple, residual, r) in rows {
                let (img, _, t) = scene.crm(&scene.rbfs, residual, CrmOptions { multiple, ..opts });
                println!(
                    "| {name} | {points:?} | {:.4} | {t:.3} |",
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
            let (img, s, t) = scene.crm(
                &scene.rbfs,
                true,
                CrmOptions {
                    order,
                    ..CrmOptions::default()
                },
            );
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
            let (no_res, _, _) = scene.crm(&rbfs, false, CrmOptions::default());
            let (img, s, total) = scene.render(&rbfs, Some(&residual), CrmOptions::default());
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
                    ..CrmOptions::default()
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
                    ..CrmOptions::default()
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
