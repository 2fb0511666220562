//! `haze render --scene`: a scene file rendered on the CPU by paper C's analytic single
//! scattering (crates/scene), or by its quadrature reference (`--reference`).

use crate::render::{OutKind, out_kind};
use anyhow::{Result, bail};
use haze_scene::airlight::Limits;
use haze_scene::render::{Analytic, Model, Reference, render};
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
}

pub fn run(a: SceneRenderArgs) -> Result<()> {
    let start = Instant::now();
    let kind = out_kind(&a.out)?;
    if a.gpu {
        bail!("--scene renders on the CPU only so far (drop --gpu)");
    }
    let mut scene = haze_scene::load(&a.scene)?;
    let (w, h) = (
        a.width.unwrap_or(scene.camera.width),
        a.height.unwrap_or(scene.camera.height),
    );
    scene.camera = scene
        .camera
        .with_size(w, h)
        .map_err(|e| anyhow::anyhow!("{}: {e}", a.scene.display()))?;
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
    let image = render(&scene, model.as_ref(), &Limits::default(), &|rows| {
        bar.set_position(rows as u64)
    });
    bar.finish_and_clear();
    let image = haze_view::Image {
        width: image.width,
        height: image.height,
        pixels: image.pixels,
    };
    match kind {
        OutKind::Exr => image.write_exr(&a.out)?,
        OutKind::Png => image.write_png(&a.out, a.exposure)?,
    }
    eprintln!(
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
