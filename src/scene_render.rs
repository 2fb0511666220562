//! `haze render --scene`: a scene file rendered by paper C's analytic single scattering
//! (crates/scene) on the CPU, or on the GPU with `--gpu` (its `f32` twin,
//! `haze_scene::gpu`), or by its quadrature reference (`--reference`, CPU); analytic fog
//! (paper D) composited over the picture at `--time` (`haze_scene::analytic`), or every
//! medium lit by the march with `--march` (`haze_scene::march`).

use crate::render::{OutKind, out_kind};
use anyhow::{Result, anyhow};
use haze_scene::Scene;
use haze_scene::airlight::Limits;
use haze_scene::analytic;
use haze_scene::gpu::GpuRenderer;
use haze_scene::march::{self, MarchOptions};
use haze_scene::render::{Analytic, Image, Model, Reference};
use haze_view::gpu::{GpuContext, GpuError};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Instant;

/// What `haze render --scene` was asked to do.
#[derive(Debug)]
pub struct SceneRenderArgs {
    pub scene: PathBuf,
    pub out: PathBuf,
    /// Overrides of the scene camera's image size.
    pub width: Option<usize>,
    pub height: Option<usize>,
    pub reference: bool,
    pub gpu: bool,
    pub exposure: f64,
    /// Seconds of wind for the analytic fog.
    pub time: f64,
    /// Single scattering through every medium by `haze_scene::march`.
    pub march: bool,
}

pub fn run(a: SceneRenderArgs) -> Result<()> {
    let start = Instant::now();
    let kind = out_kind(&a.out)?;
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
    if a.gpu {
        if scene.analytic_media().next().is_some() {
            anyhow::bail!(
                "{}: --gpu does not composite analytic media yet; render them without --gpu",
                a.scene.display()
            );
        }
        return run_gpu(&a, &scene, kind, start);
    }
    let model: Box<dyn Model> = if a.reference {
        Box::new(Reference::default())
    } else {
        Box::new(Analytic::new(&scene))
    };
    let bar = ProgressBar::new(h as u64);
    bar.set_style(
        ProgressStyle::with_template("rendering [{bar:30}] {pos}/{len} rows, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let progress = |rows: usize| bar.set_position(rows as u64);
    let image = if a.march {
        march::render(
            &scene,
            &Limits::default(),
            &MarchOptions::default(),
            &progress,
        )
    } else {
        analytic::render(&scene, model.as_ref(), &Limits::default(), &progress)
    };
    bar.finish_and_clear();
    write(&a, image, kind)?;
    eprintln!(
        "{}: {}×{}, scene {} ({} lights, {} surfaces), {}, {:.2} s",
        a.out.display(),
        w,
        h,
        a.scene.display(),
        scene.lights.len(),
        scene.surfaces.len(),
        if a.march {
            "single scattering by ray marching".to_string()
        } else {
            model.name()
        },
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `--gpu`: the tables built on the CPU, the image rendered by `haze_scene::gpu`.
fn run_gpu(a: &SceneRenderArgs, scene: &Scene, kind: OutKind, start: Instant) -> Result<()> {
    let gpu_err = |e: GpuError| anyhow!("--gpu: {e}");
    let ctx = GpuContext::new().map_err(gpu_err)?;
    let analytic = Analytic::new(scene);
    let renderer = GpuRenderer::new(&ctx, &analytic).map_err(gpu_err)?;
    let frame = Instant::now();
    let image = renderer
        .render(&ctx, scene, &Limits::default())
        .map_err(|e| anyhow!("--gpu: {}: {e}", a.scene.display()))?;
    let frame = frame.elapsed().as_secs_f64();
    let (w, h) = (image.width, image.height);
    write(a, image, kind)?;
    eprintln!(
        "{}: {}×{}, scene {} ({} lights, {} surfaces), {} on the GPU ({}), frame {:.3} s, {:.2} s in all",
        a.out.display(),
        w,
        h,
        a.scene.display(),
        scene.lights.len(),
        scene.surfaces.len(),
        analytic.name(),
        ctx.adapter_name(),
        frame,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Writes the image as `kind` (temp file + rename).
fn write(a: &SceneRenderArgs, image: Image, kind: OutKind) -> Result<()> {
    let image = haze_view::Image {
        width: image.width,
        height: image.height,
        pixels: image.pixels,
    };
    match kind {
        OutKind::Exr => image.write_exr(&a.out)?,
        OutKind::Png => image.write_png(&a.out, a.exposure)?,
    }
    Ok(())
}
