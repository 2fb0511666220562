//! Fog models: `haze fog wavelet` renders a fogmap as a wavelet fog over a
//! simple outdoor scene (paper E).

use crate::fog_smoke::SmokePlacement;
use crate::output::{Created, Outputs};
use anyhow::{Context, Result, bail};
use haze_camera::LookAt;
use haze_volume::import::sequence::frame_numbers;
use haze_wavelet::render::Scene;
use haze_wavelet::{Basis, Fog, Fogmap, Mode, Placement, Settings};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The fog itself: its basis, levels and level of detail, where its layer lies and how
/// dense it is, its colour and its wind (`haze fog wavelet` and `haze view --fog`).
#[derive(Clone, Debug)]
pub struct FogModel {
    /// Scaling functions and wavelets.
    pub basis: Basis,
    /// Decomposition steps of Mallat's transform (0: the fogmap as it is).
    pub levels: usize,
    /// Level l is integrated up to |OP|·µ^l; 1 keeps every level, 0 only the coarsest.
    pub mu: f64,
    /// A ray stops once its transmittance is below this (0: never).
    pub min_transmittance: f64,
    /// World size of one fogmap pixel.
    pub cell: f64,
    /// World X,Y of the fogmap's south-west corner (`None`: the map centred on 0,0).
    pub origin: Option<[f64; 2]>,
    /// Extinction per world unit of a fogmap value of 1 at the bottom of the layer.
    pub density: f64,
    /// Height of the fog layer's bottom.
    pub bottom: f64,
    /// Height of the fog layer's top.
    pub top: f64,
    /// Vertical extinction falloff k: density fades as exp(−k·(z − bottom)).
    pub falloff: f64,
    /// Wind: the fog drifts DX,DY world units per second.
    pub wind: [f64; 2],
    /// Fog colour L_fog (linear RGB; `None`: the scene's).
    pub fog_color: Option<[f64; 3]>,
}

impl FogModel {
    /// Where the layer lies: by default a `width × height` fogmap centred on 0,0.
    pub fn placement(&self, width: usize, height: usize) -> Placement {
        Placement {
            origin: self.origin.unwrap_or([
                -(width as f64) * self.cell / 2.0,
                -(height as f64) * self.cell / 2.0,
            ]),
            cell: self.cell,
            density: self.density,
            bottom: self.bottom,
            top: self.top,
            falloff: self.falloff,
        }
    }

    /// µ and the early exit, integrating the deconstructed levels unless `direct`.
    pub fn settings(&self, direct: bool) -> Settings {
        Settings {
            mu: self.mu,
            mode: if direct {
                Mode::Direct
            } else {
                Mode::Deconstructed
            },
            min_transmittance: self.min_transmittance,
        }
    }

    /// The scene under the fog, with `--fog-color`.
    pub fn scene(&self) -> Scene {
        let mut scene = Scene::default();
        if let Some(c) = self.fog_color {
            scene.fog = c;
        }
        scene
    }
}

/// Everything `haze fog wavelet` is asked to do.
#[derive(Clone, Debug)]
pub struct WaveletJob {
    /// The fogmap, or a directory of numbered fogmaps of one size.
    pub fogmap: PathBuf,
    pub model: FogModel,
    pub smoke: SmokePlacement,
    /// Output image: .exr (linear RGB, 32-bit float) or .png (sRGB, 8-bit).
    pub out: PathBuf,
    /// Integrate the detail bases as wavelets (the paper's Algorithm 1; CPU only).
    pub direct: bool,
    /// Render on the GPU.
    pub gpu: bool,
    pub width: usize,
    pub height: usize,
    /// Camera position and the point looked at (`None`: framing the fog).
    pub eye: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: [f64; 3],
    /// Vertical field of view in degrees.
    pub fov: f64,
    /// Time of the (first) frame in seconds.
    pub time: f64,
    /// Frames to render, 1/fps s apart (`None`: 1, or the number of fogmaps).
    pub frames: Option<usize>,
    pub fps: f64,
}

enum Format {
    Exr,
    Png,
}

/// Renders the fog (and its frames) and writes the images, printing one line about them.
pub fn wavelet(args: WaveletJob) -> Result<()> {
    let format = match args
        .out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("exr") => Format::Exr,
        Some("png") => Format::Png,
        _ => bail!(
            "{}: the output must be a .exr or .png image",
            args.out.display()
        ),
    };
    if args.width == 0 || args.height == 0 || args.width > 16384 || args.height > 16384 {
        bail!(
            "--width {} --height {}: each must be between 1 and 16384",
            args.width,
            args.height
        );
    }
    if args.gpu && args.direct {
        bail!(
            "--direct is CPU only: --gpu integrates the deconstructed levels, the same image faster (the direct wavelet integration is the CPU's reference)"
        );
    }
    if !(args.time.is_finite() && args.fps.is_finite() && args.fps > 0.0) {
        bail!(
            "--time {} --fps {}: the time must be finite and the rate positive",
            args.time,
            args.fps
        );
    }
    let files = fogmap_files(&args.fogmap)?;
    let frames = args.frames.unwrap_or(files.len());
    if !(1..=100_000).contains(&frames) {
        bail!("--frames {frames}: must be between 1 and 100000");
    }
    let mut check = files.iter().fold(Outputs::new(), |o, f| o.input(f));
    if let Some(smoke) = &args.smoke.smoke {
        check = check.input(smoke);
    }
    (0..frames)
        .fold(check, |o, k| {
            o.output("--out", &frame_path(&args.out, k, frames))
        })
        .check()?;
    let mut fogmap = Fogmap::load(&files[0])?;
    let basis = args.model.basis;
    let placement = args.model.placement(fogmap.width, fogmap.height);
    let settings = args.model.settings(args.direct);
    let setup = Instant::now();
    let fog = Fog::new(
        &fogmap.grid(),
        basis,
        args.model.levels,
        placement,
        settings,
    )
    .with_context(|| format!("{}", files[0].display()))?;
    let mut setup = setup.elapsed().as_secs_f64();
    let framing = haze_wavelet::render::framing(&fog);
    let camera = LookAt {
        eye: args.eye.unwrap_or(framing.eye),
        target: args.target.unwrap_or(framing.target),
        up: args.up,
        fov_deg: args.fov,
    };
    let frame = camera.camera(args.width, args.height).map_err(|e| {
        if args.eye.is_none() || args.target.is_none() {
            // The default view is framed on the fog's box, which a degenerate cell size
            // makes a point.
            anyhow::anyhow!(
                "camera: {e}, framed on the fog at cell size {} (give --eye and --target, or a larger cell)",
                haze_core::number::shown(placement.cell)
            )
        } else {
            anyhow::Error::msg(e)
        }
    })?;
    let scene = args.model.scene();
    // The smoke's layer: one camera for every frame, so computed once.
    let smoke_at = Instant::now();
    let smoke = match args.smoke.load()? {
        Some(smoke) => {
            let layer = smoke.layer(&frame);
            Some((smoke.label, layer, smoke_at.elapsed().as_secs_f64()))
        }
        None => None,
    };
    // The GPU's device, passes and uploaded levels, made once for every frame.
    let mut gpu = if args.gpu {
        Some(GpuFog::new(&fog)?)
    } else {
        None
    };
    let device = match &gpu {
        Some(g) => format!("on the GPU ({})", g.ctx.adapter_name()),
        None => {
            let threads = rayon::current_num_threads();
            format!("{threads} thread{}", if threads == 1 { "" } else { "s" })
        }
    };
    // Wind moves the fog (not the camera, whose default framing is of the fog at rest);
    // the transform is computed once, every frame only moves it.
    // A sequence's fogmap is decomposed again only when it differs from the last one.
    let mut fog = fog;
    let mut moved = [0.0; 2];
    let (mut shown, mut decompositions) = (0, 1);
    // The frames written so far are removed if a later one fails.
    let mut written = Created::new();
    let stage = if gpu.is_some() {
        "the wavelet fog on the GPU"
    } else {
        "the wavelet fog on the CPU"
    };
    let start = Instant::now();
    for k in 0..frames {
        if k % files.len() != shown {
            shown = k % files.len();
            let next = Fogmap::load(&files[shown])?;
            if [next.width, next.height] != [fogmap.width, fogmap.height] {
                bail!(
                    "{}: {} × {}, but the sequence's first fogmap is {} × {}",
                    files[shown].display(),
                    next.width,
                    next.height,
                    fogmap.width,
                    fogmap.height
                );
            }
            if next.values != fogmap.values {
                let at = Instant::now();
                fog = Fog::new(&next.grid(), basis, args.model.levels, placement, settings)
                    .with_context(|| format!("{}", files[shown].display()))?;
                fog.translate(moved);
                setup += at.elapsed().as_secs_f64();
                decompositions += 1;
                if let Some(g) = &mut gpu {
                    g.fog = g.renderer.upload(&g.ctx, &fog)?;
                }
            }
            fogmap = next;
        }
        let t = args.time + k as f64 / args.fps;
        let offset = [args.model.wind[0] * t, args.model.wind[1] * t];
        let by = [offset[0] - moved[0], offset[1] - moved[1]];
        moved = offset;
        fog.translate(by);
        let pixels = match &mut gpu {
            Some(g) => {
                g.fog.translate(by);
                let layer = smoke.as_ref().map(|s| s.1.as_slice());
                g.render(&camera, &scene, layer, args.width, args.height)?
            }
            None => {
                let bar = crate::progress::rows(args.height, "rendering");
                let done = || bar.inc(1);
                let px = match &smoke {
                    Some((_, layer, _)) => {
                        haze_wavelet::render::render_over(&fog, &frame, &scene, layer, &done)
                    }
                    None => haze_wavelet::render::render(&fog, &frame, &scene, &done),
                };
                bar.finish_and_clear();
                px
            }
        };
        let out = frame_path(&args.out, k, frames);
        let picture = haze_view::Image {
            width: args.width,
            height: args.height,
            pixels,
        };
        picture
            .check_finite(stage)
            .with_context(|| format!("{}", out.display()))?;
        let pixels = picture.pixels;
        let bytes = match format {
            Format::Exr => encode_exr(&pixels, args.width, args.height),
            Format::Png => encode_png(&pixels, args.width, args.height),
        }
        .with_context(|| format!("{}: cannot encode", out.display()))?;
        crate::output::write_atomic(&out, &bytes)?;
        written.push(out);
    }
    written.keep();
    let seconds = start.elapsed().as_secs_f64();
    let rays = (args.width * args.height * frames) as f64;
    let mut counts = String::new();
    if frames > 1 {
        counts = format!(" ({frames} frames, {:.3} s each)", seconds / frames as f64);
    }
    if files.len() > 1 {
        counts += &format!(" ({} fogmaps, {decompositions} decomposed)", files.len());
    }
    if let Some((label, _, seconds)) = &smoke {
        counts += &format!(", with {label} (smoke lit and rendered in {seconds:.3} s)");
    }
    crate::say!(
        "{}: {} × {}, {} fogmap {} × {}, {} level{}, µ {}{}, decomposed in {:.3} s, rendered in {:.3} s{} ({:.2} Mrays/s, {})",
        frame_path(&args.out, 0, frames).display(),
        args.width,
        args.height,
        fog.basis(),
        fogmap.width,
        fogmap.height,
        fog.levels(),
        if fog.levels() == 1 { "" } else { "s" },
        args.model.mu,
        if args.direct { ", direct" } else { "" },
        setup,
        seconds,
        counts,
        rays / seconds / 1e6,
        device,
    );
    Ok(())
}

/// The fogmaps to render: `path` itself, or the numbered fogmaps (`.png`, `.exr`, `.npy`,
/// `.f32`) of the directory `path`, ordered by their frame numbers
/// ([`frame_numbers`]: the last number that differs between their names).
pub fn fogmap_files(path: &Path) -> Result<Vec<PathBuf>> {
    if !path.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let mut paths = Vec::new();
    for entry in std::fs::read_dir(path).with_context(|| format!("{}", path.display()))? {
        let p = entry.with_context(|| format!("{}", path.display()))?.path();
        let ext = p
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if p.is_file() && matches!(ext.as_deref(), Some("png" | "exr" | "npy" | "f32")) {
            paths.push(p);
        }
    }
    let mut files = Vec::with_capacity(paths.len());
    for (n, p) in frame_numbers(&paths).into_iter().zip(paths) {
        let n = n.with_context(|| {
            format!(
                "{}: a fogmap of a sequence needs a frame number in its name",
                p.display()
            )
        })?;
        files.push((n, p));
    }
    files.sort();
    if let Some(w) = files.windows(2).find(|w| w[0].0 == w[1].0) {
        bail!(
            "{}: frame {} also comes from {}",
            w[1].1.display(),
            w[0].0,
            w[0].1.display()
        );
    }
    if files.is_empty() {
        bail!(
            "{}: no fogmaps (.png, .exr, .npy, .f32) in the directory",
            path.display()
        );
    }
    Ok(files.into_iter().map(|(_, p)| p).collect())
}

/// Frame `k` of `frames`: `out` itself for a single frame, else `out` with `_KKKK`
/// before the extension (`fog.png` → `fog_0000.png`).
fn frame_path(out: &Path, k: usize, frames: usize) -> PathBuf {
    if frames == 1 {
        return out.to_path_buf();
    }
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy())
        .unwrap_or_default();
    let ext = out
        .extension()
        .map(|s| s.to_string_lossy())
        .unwrap_or_default();
    out.with_file_name(format!("{stem}_{k:04}.{ext}"))
}

/// A fog on the GPU: the device, the compiled passes and the fog's levels.
struct GpuFog {
    ctx: haze_gpu::GpuContext,
    renderer: haze_wavelet::gpu::fog::FogRenderer,
    fog: haze_wavelet::gpu::fog::GpuFog,
}

impl GpuFog {
    fn new(fog: &Fog) -> Result<GpuFog> {
        let ctx = haze_gpu::GpuContext::new()?;
        let renderer = haze_wavelet::gpu::fog::FogRenderer::new(&ctx)?;
        let fog = renderer.upload(&ctx, fog)?;
        Ok(GpuFog { ctx, renderer, fog })
    }

    /// One frame's linear RGB pixels, with a smoke layer composited by depth when given.
    fn render(
        &self,
        camera: &LookAt,
        scene: &Scene,
        smoke: Option<&[haze_wavelet::render::SmokeSample]>,
        width: usize,
        height: usize,
    ) -> Result<Vec<[f32; 3]>> {
        let pixels = match smoke {
            Some(layer) => self
                .renderer
                .render_over(&self.ctx, &self.fog, camera, scene, layer, width, height)?,
            None => self
                .renderer
                .render(&self.ctx, &self.fog, camera, scene, width, height)?,
        };
        Ok(pixels.iter().map(|p| [p[0], p[1], p[2]]).collect())
    }
}

fn encode_exr(pixels: &[[f32; 3]], w: usize, h: usize) -> Result<Vec<u8>> {
    use exr::prelude::*;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = pixels[p.y() * w + p.x()];
        (c[0], c[1], c[2])
    });
    let image = Image::from_channels((w, h), channels);
    let mut buf = std::io::Cursor::new(Vec::new());
    image.write().to_buffered(&mut buf)?;
    Ok(buf.into_inner())
}

/// Linear to sRGB-encoded 8 bits.
fn srgb8(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

fn encode_png(pixels: &[[f32; 3]], w: usize, h: usize) -> Result<Vec<u8>> {
    let raw: Vec<u8> = pixels.iter().flat_map(|p| p.map(srgb8)).collect();
    let img = image::RgbImage::from_raw(w as u32, h as u32, raw)
        .context("image size does not match its pixels")?;
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)?;
    Ok(buf.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_encoding_endpoints_and_midtone() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(2.0), 255);
        assert_eq!(srgb8(-1.0), 0);
        // Linear 0.18 (mid grey) is sRGB 0.4614 (255 × 0.4614 = 117.7); 0.001 is on the
        // linear segment: 12.92 × 0.001 × 255 = 3.3.
        assert_eq!(srgb8(0.18), 118);
        assert_eq!(srgb8(0.001), 3);
    }

    #[test]
    fn images_encode() {
        let px = vec![[0.5f32, 0.25, 1.0]; 6];
        let png = encode_png(&px, 3, 2).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        let exr = encode_exr(&px, 3, 2).unwrap();
        assert_eq!(&exr[..4], &[0x76, 0x2f, 0x31, 0x01]);
    }
}
