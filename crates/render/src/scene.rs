//! A scene file rendered (`haze render --scene`) by paper C's analytic single scattering
//! (crates/scene) on the CPU, or on the GPU with `--gpu` (its `f32` twin,
//! `haze_scene::gpu`), or by its quadrature reference (`--reference`, CPU); analytic fog
//! (paper D) composited over that picture at `--time` (`haze_scene::analytic`). Scenes
//! whose heterogeneous media are all Gaussians are rendered by paper B
//! (`haze_scene::paper_b`, `gpu::paper_b`), with the march as reference; scenes with other
//! heterogeneous media (a smoke asset), and every scene with `--march`, by the
//! single-scattering march through every medium (`haze_scene::march`; on the GPU
//! `haze_scene::gpu::march`), whose reference is the same march at a quarter of the step.

use crate::smoke::{OutKind, out_kind};
use anyhow::{Result, anyhow};
use haze_gpu::{GpuContext, GpuError};
use haze_scene::Scene;
use haze_scene::analytic;
use haze_scene::gpu::GpuRenderer;
use haze_scene::gpu::analytic::GpuAnalytic;
use haze_scene::gpu::paper_b::GpuPaperB;
use haze_scene::march;
use haze_scene::paper_b::{self, PaperBOptions, Prepared};
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image, Model, Reference};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a scene render is asked to do.
#[derive(Debug)]
pub struct SceneJob {
    pub scene: PathBuf,
    pub out: PathBuf,
    /// Overrides of the scene camera's image size.
    pub width: Option<usize>,
    pub height: Option<usize>,
    pub reference: bool,
    pub gpu: bool,
    pub exposure: f64,
    /// The tone curve of a PNG output.
    pub tone: haze_core::ToneMap,
    /// Seconds of wind for the analytic fog.
    pub time: f64,
    /// Single scattering through every medium by `haze_scene::march`.
    pub march: bool,
    /// Paper B's `PaperBOptions::max_exact`; `None`: the device's default.
    pub exact_per_pair: Option<usize>,
    /// Paper B's `PaperBOptions::reuse` on the CPU (the GPU integrates every pixel) and
    /// `PaperBOptions::sky_stride` on both.
    pub pair_reuse: usize,
    /// Paper B's `PaperBOptions::surface_sky`: the surfaces take the others' exact shadow
    /// on the sky where its bound asks.
    pub sky_shadow: bool,
}

/// The default of [`SceneJob::pair_reuse`].
pub const DEFAULT_PAIR_REUSE: usize = haze_scene::paper_b::reuse::DEFAULT_STRIDE;

/// The files a scene file names (its models, maps and assets, relative to its folder):
/// every string in it that is the path of an existing file. Read before a render so
/// that no output replaces one of them; a file that cannot be read names none.
pub fn files_named(scene: &Path) -> Vec<PathBuf> {
    fn walk(v: &serde_json::Value, base: &Path, out: &mut Vec<PathBuf>) {
        match v {
            serde_json::Value::String(s) => {
                let p = base.join(s);
                if p.is_file() {
                    out.push(p);
                }
            }
            serde_json::Value::Array(a) => a.iter().for_each(|v| walk(v, base, out)),
            serde_json::Value::Object(m) => m.values().for_each(|v| walk(v, base, out)),
            _ => {}
        }
    }
    let mut files = Vec::new();
    let text = std::fs::read_to_string(scene).unwrap_or_default();
    if let Ok(v) = serde_json::from_str(&text) {
        walk(&v, scene.parent().unwrap_or(Path::new("")), &mut files);
    }
    files
}

pub fn render_scene(a: SceneJob) -> Result<()> {
    let start = Instant::now();
    let kind = out_kind(&a.out)?;
    crate::smoke::check_exposure(a.exposure)?;
    if !a.time.is_finite() {
        anyhow::bail!("--time {} must be finite", a.time);
    }
    let mut scene = haze_scene::load(&a.scene)?.at_time(a.time);
    let (w, h) = (
        a.width.unwrap_or(scene.camera.width),
        a.height.unwrap_or(scene.camera.height),
    );
    scene.camera = scene
        .camera
        .with_size(w, h)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.scene.display()))?;
    if a.march && !a.gpu {
        return run_march(&a, &scene, kind, start);
    }
    // Gaussian media alone: paper B; analytic fog: paper C's picture with paper D's fog
    // composited; any other heterogeneous medium: the march.
    if !a.march && !scene.hetero.is_empty() && scene.hetero.iter().all(|m| m.is_gaussians()) {
        return run_hetero(&a, &scene, kind, start);
    }
    if a.gpu {
        return run_gpu(&a, &scene, kind, start);
    }
    if scene.hetero.iter().any(|m| !m.is_analytic()) {
        return run_march(&a, &scene, kind, start);
    }
    let model: Box<dyn Model> = if a.reference {
        Box::new(Reference::default())
    } else {
        Box::new(Analytic::new(&scene))
    };
    let bar = crate::progress::rows(h, "rendering");
    let progress = |rows: usize| bar.set_position(rows as u64);
    let image = analytic::render(&scene, model.as_ref(), &Limits::default(), &progress);
    bar.finish_and_clear();
    write(&a, image, kind, &model.name())?;
    crate::say!(
        "{}: {}×{}, scene {} ({} lights, {} surfaces), {}, {:.2} s",
        a.out.display(),
        w,
        h,
        a.scene.display(),
        scene.lights.len(),
        scene.surfaces.len(),
        model.name(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// A scene with heterogeneous media other than Gaussians alone (a smoke asset, or a mix):
/// the single-scattering march through
/// every medium (`haze_scene::march`), shadows of the media on the surfaces included, at
/// half a voxel per step, or a quarter of that for `--reference`.
fn run_march(a: &SceneJob, scene: &Scene, kind: OutKind, start: Instant) -> Result<()> {
    let opt = haze_scene::march::march_options(scene, a.reference);
    let (w, h) = (scene.camera.width, scene.camera.height);
    let bar = crate::progress::rows(h, "marching");
    let frame = Instant::now();
    let image = haze_scene::march::render(scene, &Limits::default(), &opt, &|rows| {
        bar.set_position(rows as u64)
    });
    let frame = frame.elapsed().as_secs_f64();
    bar.finish_and_clear();
    write(a, image, kind, "the single-scattering march")?;
    let media: Vec<String> = scene.hetero.iter().map(|m| m.name()).collect();
    crate::say!(
        "{}: {}×{}, scene {} ({} lights, {} surfaces, {}), single-scattering march at step {:.4}, frame {:.3} s, {:.2} s in all",
        a.out.display(),
        w,
        h,
        a.scene.display(),
        scene.lights.len(),
        scene.surfaces.len(),
        media.join(", "),
        opt.step,
        frame,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `--gpu`: the tables built on the CPU, the image rendered by `haze_scene::gpu` (analytic
/// fog composited over it by `haze_scene::gpu::analytic`, or marched through with the other
/// media by `haze_scene::gpu::march`).
fn run_gpu(a: &SceneJob, scene: &Scene, kind: OutKind, start: Instant) -> Result<()> {
    let gpu_err = |e: GpuError| anyhow!("--gpu: {e}");
    let ctx = GpuContext::new().map_err(gpu_err)?;
    let analytic = Analytic::new(scene);
    let renderer = GpuRenderer::new(&ctx, &analytic).map_err(gpu_err)?;
    // Analytic fog alone: paper C's picture with paper D's fog composited on the GPU, or
    // with --march the lit picture (the march, as every scene with other heterogeneous
    // media: smoke assets alone or in analytic fog).
    let fog = !a.march && !scene.hetero.is_empty() && scene.hetero.iter().all(|m| m.is_analytic());
    let composite = if fog {
        Some(GpuAnalytic::new(&ctx).map_err(gpu_err)?)
    } else {
        None
    };
    if ctx.is_cpu_adapter() && !fog && !scene.hetero.is_empty() {
        tracing::warn!(
            "--gpu: {} is a CPU adapter, where the march runs as an emulated shader; without --gpu the CPU marches the same steps several times faster",
            ctx.adapter_name()
        );
    }
    let frame = Instant::now();
    let image = match &composite {
        Some(c) => c.render(&ctx, &renderer, scene, &Limits::default()),
        None => renderer.render(&ctx, scene, &Limits::default()),
    }
    .map_err(|e| anyhow!("--gpu: {}: {e}", a.scene.display()))?;
    let frame = frame.elapsed().as_secs_f64();
    let (w, h) = (image.width, image.height);
    write(a, image, kind, "the GPU renderer")?;
    crate::say!(
        "{}: {}×{}, scene {} ({} lights, {} surfaces), {} on the GPU ({}), frame {:.3} s, {:.2} s in all",
        a.out.display(),
        w,
        h,
        a.scene.display(),
        scene.lights.len(),
        scene.surfaces.len(),
        if scene.hetero.is_empty() {
            analytic.name()
        } else if fog {
            format!("{} with analytic fog composited", analytic.name())
        } else {
            "single-scattering march".to_string()
        },
        ctx.adapter_name(),
        frame,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Scenes with heterogeneous media: Gaussian media by paper B (CPU, or GPU with
/// `--gpu`), or by the march
/// through every medium with `--reference` (a step of a fifth of the smallest Gaussian
/// radius, at most 0.02; the environment integrated over directions at every sample and
/// surface point, `paper_b::reference_options`).
fn run_hetero(a: &SceneJob, scene: &Scene, kind: OutKind, start: Instant) -> Result<()> {
    let fail = |e: String| anyhow!("{}: {e}", a.scene.display());
    let bar = crate::progress::rows(scene.camera.height, "rendering");
    let progress = |rows: usize| bar.set_position(rows as u64);
    let (image, what) = if a.reference {
        let opt = paper_b::reference_options(scene, paper_b::REFERENCE_THETA);
        let image = march::render(scene, &Limits::default(), &opt, &progress);
        let env = if opt.env == haze_scene::march::env_smoke::EnvLight::None {
            String::new()
        } else {
            format!(
                ", the environment over {} directions",
                2 * paper_b::REFERENCE_THETA * paper_b::REFERENCE_THETA
            )
        };
        (
            image,
            format!("single-scattering march, step {}{env}", opt.step),
        )
    } else if a.gpu {
        let gpu_err = |e: GpuError| anyhow!("--gpu: {}: {e}", a.scene.display());
        let ctx = GpuContext::new().map_err(gpu_err)?;
        // Before the preparation, which takes seconds at such counts.
        let gaussians = scene
            .gaussian_media()
            .map(|m| m.medium.gaussians().len())
            .sum();
        haze_scene::gpu::cpu_device::check_gaussians(
            ctx.is_cpu_adapter(),
            gaussians,
            scene.lights.len(),
            !matches!(scene.environment, haze_scene::Environment::Black),
        )
        .map_err(gpu_err)?;
        let analytic = Analytic::new(scene);
        let mut options = PaperBOptions {
            surface_sky: a.sky_shadow,
            sky_stride: a.pair_reuse.max(1),
            ..haze_scene::gpu::paper_b::options(&ctx)
        };
        if let Some(n) = a.exact_per_pair {
            options.max_exact = n;
        }
        let prep = Prepared::new(scene, &analytic, options).map_err(fail)?;
        log_integrated(&prep);
        if ctx.is_cpu_adapter() && !prep.integrated_list().is_empty() {
            tracing::warn!(
                "--gpu: {} is a CPU adapter, where paper B's shader takes at most {} Gaussians exact an integrated pair and integrates every pixel; without --gpu the CPU renderer takes {} and is faster on this machine",
                ctx.adapter_name(),
                options.max_exact,
                paper_b::MAX_EXACT
            );
        }
        let tables = GpuRenderer::new(&ctx, &analytic).map_err(gpu_err)?;
        let frame = Instant::now();
        let image = GpuPaperB::new(&ctx)
            .and_then(|r| r.render(&ctx, &tables, &prep, &Limits::default()))
            .map_err(gpu_err)?;
        let what = format!(
            "{} on the GPU ({}), frame {:.3} s",
            prep.name(),
            ctx.adapter_name(),
            frame.elapsed().as_secs_f64()
        );
        (image, what)
    } else {
        let analytic = Analytic::new(scene);
        let mut options = PaperBOptions {
            reuse: a.pair_reuse.max(1),
            surface_sky: a.sky_shadow,
            sky_stride: a.pair_reuse.max(1),
            ..PaperBOptions::default()
        };
        if let Some(n) = a.exact_per_pair {
            options.max_exact = n;
        }
        let prep = Prepared::new(scene, &analytic, options).map_err(fail)?;
        log_integrated(&prep);
        let image = paper_b::render(&prep, &Limits::default(), &progress);
        (image, prep.name())
    };
    bar.finish_and_clear();
    let (w, h) = (image.width, image.height);
    write(a, image, kind, &what)?;
    crate::say!(
        "{}: {}×{}, scene {} ({} lights, {} surfaces, {} heterogeneous media), {}, {:.2} s",
        a.out.display(),
        w,
        h,
        a.scene.display(),
        scene.lights.len(),
        scene.surfaces.len(),
        scene.hetero.len(),
        what,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// With `-v`: each (light, Gaussian) pair paper B integrates along the ray and its bound
/// on the factorization's error (the summary line gives their count). Always: where the
/// picture may be wrong ([`Prepared::warnings`]).
fn log_integrated(prep: &Prepared<'_>) {
    for w in prep.warnings() {
        tracing::warn!("{w}");
    }
    for (l, i, bound) in prep.integrated_list() {
        let why = if bound.is_finite() {
            format!("error bound {:.1} %", 100.0 * bound)
        } else {
            "the light is inside it".to_string()
        };
        tracing::info!("paper B: light {l}, gaussian {i} integrated along the ray ({why})");
    }
}

/// Writes the image as `kind` (temp file + rename); a picture with a NaN or an infinite
/// value is refused, naming `stage`, the renderer that made it, and the scene file.
fn write(a: &SceneJob, image: Image, kind: OutKind, stage: &str) -> Result<()> {
    image
        .check_finite(stage)
        .map_err(|e| anyhow!("{}: {e}", a.scene.display()))?;
    match kind {
        OutKind::Exr => image.write_exr(&a.out)?,
        OutKind::Png => image.write_png(&a.out, a.exposure, a.tone)?,
    }
    Ok(())
}
