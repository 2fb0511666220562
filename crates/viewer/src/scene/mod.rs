//! The scene room (`haze view --scene`): a scene file shown through paper C's renderer on the GPU
//! (`haze_scene::gpu`), with an orbit camera and the medium and lights editable in a side
//! panel. The surfaces are rasterized with a depth buffer (`haze_scene::gpu::raster`), the
//! airlight and shading computed per pixel up to that depth; a panel switch (or
//! `--ray-traced`) shows the ray tracer's picture instead, for comparison. Scenes whose
//! heterogeneous media are all Gaussians are rendered by paper B on the GPU
//! (`haze_scene::gpu::paper_b`, ray-traced surfaces: its raster variant does not exist), and
//! the panel's editing tools (paper B §6, [`edit_tools`]) change their first Gaussian
//! medium, every edit re-lit in the next picture. Scenes with analytic fog (paper D) play
//! its wind live ([`wind_panel`]). Scenes with a smoke asset are marched
//! (`haze_scene::gpu::march`).
//!
//! Beside an adapter that is a CPU (Mesa's lavapipe) every picture is rendered by the CPU
//! renderer of the same model instead, surfaces ray-traced (decisions 0058 and 0059,
//! [`Renderer::on_the_cpu`]): paper B's, paper C's with paper D's fog composited, or the
//! march.
//!
//! The orbit starts at the scene's camera and turns about the point its central ray looks
//! at (the first surface it meets, else the scene's middle at the same distance), Z up.
//! The panel scales the medium's extinction and albedo, moves each point light, and
//! scales each light's power. A picture is rendered on the window's thread whenever the
//! camera or a knob changed (the render, on the GPU its read back, and the sRGB encoding;
//! BENCHMARKS.md has its time on lavapipe), so the window shows the edit it was asked for,
//! never an older one; a slow device makes the window slow to answer rather than late.

pub mod edit_tools;
mod wind_panel;

use crate::orbit::Orbit;
use crate::shell::{self, Outcome, Room};
use anyhow::{Result, anyhow, bail};
use edit_tools::{Editor, ScriptedStroke};
use eframe::egui;
use haze_gpu::GpuContext;
use haze_scene::gpu::GpuRenderer;
use haze_scene::gpu::paper_b::GpuPaperB;
use haze_scene::march::env_smoke;
use haze_scene::paper_b::{self, PaperBOptions, Prepared};
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::{Analytic, Image};
use haze_scene::{Light, Scene, Shape};
use std::ops::RangeInclusive;
use std::path::PathBuf;
use std::time::Instant;
use wind_panel::{FogRenderer, Wind};

/// Where paper B renders a Gaussian scene (decision 0058). On a GPU, its shader. On an
/// adapter that is a CPU (Mesa's lavapipe), paper B's CPU renderer: the device ends an
/// invocation's loops early, so its shader takes at most
/// `haze_scene::gpu::paper_b::CPU_DEVICE_EXACT` Gaussians exact a pair (a held-out scene
/// with lamps among dense Gaussians 35 % off the reference, against 2 % with the CPU's 16)
/// and every pixel integrates its pairs, where the CPU reuses them across the screen (that
/// scene 16.5 s a picture on lavapipe, 1.0 s on the CPU; BENCHMARKS "Paper B and the
/// march on a CPU adapter").
pub(super) enum PaperB {
    Gpu(GpuPaperB),
    Cpu,
}

/// Everything `haze view --scene` was asked to do.
#[derive(Debug)]
pub struct SceneViewArgs {
    pub scene: PathBuf,
    /// Render resolution.
    pub width: usize,
    pub height: usize,
    pub exposure: f64,
    /// Turn the camera for this many seconds, print the figures, exit.
    pub play_for: Option<f64>,
    pub window: bool,
    /// Start with the surfaces ray-traced rather than rasterized.
    pub ray_traced: bool,
    /// Edits of the Gaussian medium made before the first picture.
    pub strokes: Vec<ScriptedStroke>,
    /// Where to save the medium after them.
    pub save_edits: Option<PathBuf>,
}

/// One light's knobs.
#[derive(Clone, Debug, PartialEq)]
pub struct LightKnob {
    /// A point light's position (unused for a sun).
    pub position: [f64; 3],
    /// Multiplies the light's intensity (a sun's radiance).
    pub power: f64,
}

/// The panel's knobs.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneKnobs {
    /// Multiplies the medium's extinction `σt` (every channel).
    pub density: f64,
    /// Multiplies the medium's albedo (every channel; the result is kept ≤ 1).
    pub albedo: f64,
    pub lights: Vec<LightKnob>,
    pub exposure: f64,
    /// Surfaces rasterized with a depth buffer (else ray-traced).
    pub rasterized: bool,
}

impl SceneKnobs {
    /// The knobs that leave `scene` as it is.
    pub fn of(scene: &Scene, exposure: f64) -> SceneKnobs {
        SceneKnobs {
            density: 1.0,
            albedo: 1.0,
            lights: scene
                .lights
                .iter()
                .map(|l| LightKnob {
                    position: match l {
                        Light::Point { position, .. } => *position,
                        Light::Sun { .. } => [0.0; 3],
                    },
                    power: 1.0,
                })
                .collect(),
            exposure,
            rasterized: true,
        }
    }
}

/// The point the scene camera's central ray looks at: the first surface it meets, else
/// the point as far along it as the middle of the scene's lights and shapes.
pub fn look_target(scene: &Scene) -> [f64; 3] {
    let cam = &scene.camera;
    let f = cam.forward();
    let along = |t: f64| [0, 1, 2].map(|a| cam.eye[a] + t * f[a]);
    if let Some(hit) = scene.intersect(cam.eye, f, 0.0, f64::INFINITY) {
        return along(hit.t);
    }
    let (lo, hi) = scene_box(scene);
    let mid = [0, 1, 2].map(|a| 0.5 * (lo[a] + hi[a]));
    let d = [0, 1, 2].map(|a| mid[a] - cam.eye[a]);
    let t = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    along(if t > 0.0 { t } else { 1.0 })
}

/// A box holding the camera, the point lights and the spheres (planes: their points).
pub fn scene_box(scene: &Scene) -> ([f64; 3], [f64; 3]) {
    let mut lo = scene.camera.eye;
    let mut hi = lo;
    let mut add = |p: [f64; 3], r: f64| {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a] - r);
            hi[a] = hi[a].max(p[a] + r);
        }
    };
    for l in &scene.lights {
        if let Light::Point { position, .. } = l {
            add(*position, 0.0);
        }
    }
    for s in &scene.surfaces {
        match &s.shape {
            Shape::Plane { point, .. } => add(*point, 0.0),
            Shape::Sphere { center, radius } => add(*center, *radius),
            Shape::Mesh(mesh) => {
                let b = mesh.nodes[0].bounds;
                add(b.min, 0.0);
                add(b.max, 0.0);
            }
        }
    }
    (lo, hi)
}

/// The scene the panel and the orbit describe, for a `width × height` picture.
pub fn edited(
    base: &Scene,
    orbit: &Orbit,
    knobs: &SceneKnobs,
    (width, height): (usize, usize),
) -> Result<Scene, String> {
    let mut s = base.clone();
    s.camera = orbit.camera(width, height)?;
    s.medium.sigma_t = base.medium.sigma_t.map(|t| t * knobs.density);
    s.medium.albedo = base.medium.albedo.map(|a| (a * knobs.albedo).min(1.0));
    for (light, k) in s.lights.iter_mut().zip(&knobs.lights) {
        match light {
            Light::Point {
                position,
                intensity,
            } => {
                *position = k.position;
                *intensity = intensity.map(|i| i * k.power);
            }
            Light::Sun { radiance, .. } => *radiance = radiance.map(|r| r * k.power),
        }
    }
    Ok(s)
}

/// The scene file, the renderer and its device: what every picture needs.
pub(super) struct Renderer {
    pub(super) base: Scene,
    pub(super) ctx: GpuContext,
    gpu: GpuRenderer,
    /// Paper C's tables (paper B's CPU side uses them too).
    pub(super) analytic: Analytic,
    /// Paper B's renderer, for a scene whose heterogeneous media are all Gaussians.
    paper_b: Option<PaperB>,
    /// Paper D's composite on the GPU, for a scene with analytic fog (none on the CPU).
    fog: Option<FogRenderer>,
    /// Whether the pictures are the CPU's ([`Renderer::on_the_cpu`]).
    cpu: bool,
    /// The environment's light on the media of a scene marched on the CPU, kept while
    /// what it depends on holds.
    march_env: env_smoke::Cache,
    pub(super) size: (usize, usize),
}

impl Renderer {
    /// The renderers of `base` on a new GPU context, for `size` pictures.
    pub(super) fn new(base: Scene, size: (usize, usize)) -> Result<Renderer> {
        let ctx = GpuContext::new().map_err(|e| anyhow!("GPU: {e}"))?;
        let analytic = Analytic::new(&base);
        let gpu = GpuRenderer::new(&ctx, &analytic).map_err(|e| anyhow!("GPU: {e}"))?;
        let cpu = ctx.is_cpu_adapter();
        let fog = match Wind::of(&base) {
            Some(_) if !cpu => Some(FogRenderer::new(&ctx).map_err(|e| anyhow!("GPU: {e}"))?),
            _ => None,
        };
        let gaussian = !base.hetero.is_empty() && base.hetero.iter().all(|m| m.is_gaussians());
        let paper_b = match (gaussian, cpu) {
            (false, _) => None,
            (true, true) => Some(PaperB::Cpu),
            (true, false) => Some(PaperB::Gpu(
                GpuPaperB::new(&ctx).map_err(|e| anyhow!("GPU: {e}"))?,
            )),
        };
        Ok(Renderer {
            base,
            ctx,
            gpu,
            analytic,
            paper_b,
            fog,
            cpu,
            march_env: env_smoke::Cache::default(),
            size,
        })
    }

    /// Paper B's options where it renders ([`PaperB`]): the device's
    /// (`haze_scene::gpu::paper_b::options`) on a GPU, the CPU renderer's defaults on the
    /// CPU.
    pub(super) fn paper_b_options(&self) -> PaperBOptions {
        match self.paper_b {
            Some(PaperB::Gpu(_)) => haze_scene::gpu::paper_b::options(&self.ctx),
            _ => PaperBOptions::default(),
        }
    }

    /// Whether the pictures are rendered on the CPU: beside an adapter that is a CPU,
    /// where the emulated shaders are several times slower than the CPU renderers of the
    /// same models (decisions 0058, 0059; BENCHMARKS "Paper B and the march on a CPU
    /// adapter", "Paper C and paper D on a CPU adapter").
    fn on_the_cpu(&self) -> bool {
        self.cpu
    }

    /// Whether the scene has analytic fog, whose wind the panel plays.
    fn has_fog(&self) -> bool {
        self.base.analytic_media().next().is_some()
    }

    /// The scene the panel, the orbit and the editor (if any) describe.
    pub(super) fn scene(
        &self,
        orbit: &Orbit,
        knobs: &SceneKnobs,
        editor: Option<&Editor>,
    ) -> Result<Scene, String> {
        let mut scene = edited(&self.base, orbit, knobs, self.size)?;
        if let Some(e) = editor {
            e.apply(&mut scene)?;
        }
        Ok(scene)
    }

    /// Renders the edited scene, its analytic fogs carried by `wind`; the sRGB bytes of
    /// the picture and where it may be wrong ([`Renderer::image`]).
    pub(super) fn picture(
        &self,
        orbit: &Orbit,
        knobs: &SceneKnobs,
        editor: Option<&Editor>,
        wind: Option<&Wind>,
    ) -> Result<(Vec<u8>, Vec<String>), String> {
        let (img, warnings) = self.image(orbit, knobs, editor, wind)?;
        let image = haze_view::Image {
            width: img.width,
            height: img.height,
            pixels: img.pixels,
        };
        Ok((
            image.to_srgb8(knobs.exposure, haze_core::ToneMap::Filmic),
            warnings,
        ))
    }

    /// Renders the edited scene, its analytic fogs carried by `wind`; its linear radiance,
    /// and where paper B's picture may be wrong ([`Prepared::warnings`]; none otherwise).
    pub(super) fn image(
        &self,
        orbit: &Orbit,
        knobs: &SceneKnobs,
        editor: Option<&Editor>,
        wind: Option<&Wind>,
    ) -> Result<(Image, Vec<String>), String> {
        let scene = self.scene(orbit, knobs, editor)?;
        let lim = Limits::default();
        let mut warnings = Vec::new();
        let img = if let Some(pb) = &self.paper_b {
            let prep = Prepared::new(&scene, &self.analytic, self.paper_b_options())?;
            warnings = prep.warnings();
            match pb {
                PaperB::Gpu(r) => r.render(&self.ctx, &self.gpu, &prep, &lim),
                PaperB::Cpu => Ok(paper_b::render(&prep, &lim, &|_| {})),
            }
        } else if self.cpu {
            Ok(self.cpu_image(scene, wind, &lim))
        } else if let (Some(fog), Some(wind)) = (&self.fog, wind) {
            fog.render(&self.ctx, &self.gpu, &scene, wind, &lim)
        } else if knobs.rasterized {
            self.gpu.render_rasterized(&self.ctx, &scene, &lim)
        } else {
            self.gpu.render(&self.ctx, &scene, &lim)
        }
        .map_err(|e| e.to_string())?;
        Ok((img, warnings))
    }

    /// The CPU's picture of a scene without Gaussian media ([`Renderer::on_the_cpu`]), its
    /// analytic fogs carried by `wind`: paper C's (`haze_scene::render::render`, surfaces
    /// ray-traced) with paper D's fog composited over it (`haze_scene::analytic::render`),
    /// or the march when the fog is lit or other heterogeneous media are there
    /// (`haze_scene::march::render`, the steps of the GPU's march) — what the GPU's
    /// renderers compute, their twins.
    fn cpu_image(&self, scene: Scene, wind: Option<&Wind>, lim: &Limits) -> Image {
        let scene = match wind {
            Some(w) => w.apply(&scene),
            None => scene,
        };
        let lit = wind.is_some_and(|w| w.lit);
        if !lit && scene.hetero.iter().all(|m| m.is_analytic()) {
            haze_scene::analytic::render(&scene, &self.analytic, lim, &|_| {})
        } else {
            let mut opt = haze_scene::march::march_steps(&scene, false);
            opt.env = self.march_env.light(&scene);
            haze_scene::march::render(&scene, lim, &opt, &|_| {})
        }
    }
}

pub fn run(a: SceneViewArgs) -> Result<()> {
    if !(a.exposure > 0.0 && a.exposure.is_finite()) {
        bail!(
            "--exposure {} must be positive",
            haze_core::number::shown(a.exposure)
        );
    }
    if let Some(s) = a.play_for
        && !(s > 0.0 && s.is_finite())
    {
        bail!("--play-for {s} must be a positive number of seconds");
    }
    if !a.window && a.play_for.is_none() {
        bail!("--no-window plays only for a while: give --play-for SECONDS");
    }
    let base = haze_scene::load(&a.scene)?;
    let fov = 2.0 * base.camera.tan_half().atan().to_degrees();
    let orbit = Orbit::looking(base.camera.eye, look_target(&base), fov)
        .map_err(|e| anyhow!("{}: camera: {e}", a.scene.display()))?;
    let knobs = SceneKnobs {
        rasterized: !a.ray_traced,
        ..SceneKnobs::of(&base, a.exposure)
    };
    let mut editor = Editor::new(&base, &a.scene);
    if !a.strokes.is_empty() || a.save_edits.is_some() {
        let e = editor.as_mut().ok_or_else(|| {
            anyhow!(
                "{}: --stroke and --save-edits edit a Gaussian medium, and the scene has none",
                a.scene.display()
            )
        })?;
        let cam = orbit
            .camera(a.width, a.height)
            .map_err(|e| anyhow!("{}: camera: {e}", a.scene.display()))?;
        let before = e.gaussians().len();
        for s in &a.strokes {
            e.script(&base, &cam, s)
                .map_err(|e| anyhow!("{}: --stroke {s}: {e}", a.scene.display()))?;
        }
        haze_render::say!(
            "{} stroke{}: {before} → {} Gaussians",
            a.strokes.len(),
            if a.strokes.len() == 1 { "" } else { "s" },
            e.gaussians().len()
        );
        if let Some(out) = &a.save_edits {
            e.path = out.display().to_string();
            e.save();
            let said = e.message.take().unwrap_or_default();
            if !said.starts_with("saved") {
                bail!("--save-edits: {said}");
            }
            haze_render::say!("{said}");
        }
    }
    let wind = Wind::of(&base);
    let renderer = Renderer::new(base, (a.width, a.height))?;
    // The first picture, also the proof that the scene renders; where it may be wrong.
    let (_, warnings) = renderer
        .picture(&orbit, &knobs, editor.as_ref(), wind.as_ref())
        .map_err(|e| anyhow!("{}: {e}", a.scene.display()))?;
    for w in &warnings {
        tracing::warn!("{w}");
    }
    if !a.window {
        let line = turn_without_window(
            &renderer,
            orbit,
            &knobs,
            editor.as_ref(),
            wind,
            a.play_for.unwrap_or_default(),
        )
        .map_err(|e| anyhow!("{}: {e}", a.scene.display()))?;
        println!("{line}");
        return Ok(());
    }
    let title = format!("haze view — {}", a.scene.display());
    let (w, h) = renderer.size;
    let (lo, hi) = scene_box(&renderer.base);
    let outcome = Outcome::default();
    let app = SceneApp {
        renderer,
        orbit: orbit.clone(),
        start: (orbit, knobs.clone()),
        knobs,
        range: (lo.map(|v| v - 2.0), hi.map(|v| v + 2.0)),
        texture: None,
        shown: None,
        editor,
        last_tick: Instant::now(),
        frame_ms: 0.0,
        error: None,
        warnings,
        play_for: a.play_for.map(|s| (Instant::now(), s)),
        times: Vec::new(),
        outcome: outcome.clone(),
        wind,
        clock: Instant::now(),
        wind_changed: false,
    };
    shell::open(&title, (w, h), outcome, move |_| Ok(app))
}

/// Renders pictures for `seconds`, turning the camera by a degree each (and playing the
/// analytic fog's wind in real time), and gives the measurement line.
fn turn_without_window(
    r: &Renderer,
    mut orbit: Orbit,
    knobs: &SceneKnobs,
    editor: Option<&Editor>,
    mut wind: Option<Wind>,
    seconds: f64,
) -> Result<String, String> {
    let start = Instant::now();
    let mut times = Vec::new();
    while start.elapsed().as_secs_f64() < seconds || times.is_empty() {
        let t = Instant::now();
        r.picture(&orbit, knobs, editor, wind.as_ref())?;
        let took = t.elapsed().as_secs_f64();
        times.push(took);
        orbit.drag(1f64.to_radians() / crate::orbit::RADIANS_PER_PIXEL, 0.0);
        if let Some(w) = &mut wind {
            w.advance(&r.base, took);
        }
    }
    Ok(summary(r, knobs, times, start.elapsed().as_secs_f64()))
}

/// The measurement line: pictures rendered in `seconds`, their median time.
fn summary(r: &Renderer, knobs: &SceneKnobs, mut times: Vec<f64>, seconds: f64) -> String {
    times.sort_by(f64::total_cmp);
    let median = times.get(times.len() / 2).copied().unwrap_or(0.0);
    format!(
        "{} picture{} of {}×{} in {:.2} s, median {:.1} ms each ({} render with {} surfaces{}{}, sRGB) {}",
        times.len(),
        if times.len() == 1 { "" } else { "s" },
        r.size.0,
        r.size.1,
        seconds,
        1e3 * median,
        if r.on_the_cpu() { "CPU" } else { "GPU" },
        // GpuRenderer::render_rasterized ray-traces scenes with voxel media (the march);
        // paper B and the CPU ray-trace.
        if r.paper_b.is_some() {
            "paper B's Gaussians and ray-traced"
        } else if knobs.rasterized && r.base.hetero.is_empty() && !r.on_the_cpu() {
            "rasterized"
        } else {
            "ray-traced"
        },
        if r.has_fog() {
            ", analytic fog composited as its wind plays"
        } else {
            ""
        },
        if r.on_the_cpu() { "" } else { ", read back" },
        if r.on_the_cpu() {
            format!("beside {}, a CPU adapter", r.ctx.adapter_name())
        } else {
            format!("on {}", r.ctx.adapter_name())
        }
    )
}

/// The window.
struct SceneApp {
    renderer: Renderer,
    orbit: Orbit,
    knobs: SceneKnobs,
    /// The first view, for "reset".
    start: (Orbit, SceneKnobs),
    /// Where the light sliders reach.
    range: ([f64; 3], [f64; 3]),
    texture: Option<egui::TextureHandle>,
    /// What the texture shows (the editor's generation last).
    shown: Option<(Orbit, SceneKnobs, u64)>,
    /// The Gaussian medium's editing tools, when the scene has one.
    editor: Option<Editor>,
    /// When the running airbrush or emitter stroke last advanced.
    last_tick: Instant,
    frame_ms: f64,
    error: Option<String>,
    /// Where the picture shown may be wrong (paper B's [`Prepared::warnings`]).
    warnings: Vec<String>,
    /// `--play-for`: close the window that long after it opened.
    play_for: Option<(Instant, f64)>,
    /// Seconds of each picture rendered.
    times: Vec<f64>,
    /// `--play-for`'s measurement line, printed once the window has closed.
    outcome: Outcome,
    /// The analytic fog's wind and lit mode (wind_panel), for a scene with one.
    wind: Option<Wind>,
    /// When the wind last moved on.
    clock: Instant,
    /// The wind panel changed since the last picture.
    wind_changed: bool,
}

impl SceneApp {
    /// What the picture should show now.
    fn view(&self) -> (Orbit, SceneKnobs, u64) {
        let generation = self.editor.as_ref().map_or(0, Editor::generation);
        (self.orbit.clone(), self.knobs.clone(), generation)
    }

    fn controls(&mut self, ui: &mut egui::Ui) {
        ui.heading("scene");
        ui.label(format!(
            "{} × {}, {:.1} ms per picture",
            self.renderer.size.0, self.renderer.size.1, self.frame_ms
        ));
        ui.label(format!("GPU: {}", self.renderer.ctx.adapter_name()));
        if let Some(e) = &self.error {
            ui.colored_label(egui::Color32::RED, e);
        }
        for w in &self.warnings {
            ui.colored_label(egui::Color32::YELLOW, w);
        }
        if self.renderer.on_the_cpu() {
            ui.small("rendered on the CPU (the adapter is a CPU), surfaces ray-traced");
        } else {
            ui.checkbox(&mut self.knobs.rasterized, "rasterize surfaces")
                .on_hover_text("off: every pixel's ray traced through the surfaces instead");
        }
        if self.renderer.paper_b.is_some() {
            ui.small("Gaussian media: paper B, surfaces ray-traced");
        }
        ui.separator();
        ui.label("medium");
        let k = &mut self.knobs;
        ui.add(
            egui::Slider::new(&mut k.density, 0.0..=10.0)
                .logarithmic(true)
                .text("σt ×"),
        );
        let max_albedo = self
            .renderer
            .base
            .medium
            .albedo
            .iter()
            .fold(0.0f64, |m, &a| m.max(a));
        let top = if max_albedo > 0.0 {
            1.0 / max_albedo
        } else {
            1.0
        };
        ui.add(egui::Slider::new(&mut k.albedo, 0.0..=top).text("albedo ×"));
        ui.separator();
        let (lo, hi) = self.range;
        let span = |a: usize| -> RangeInclusive<f64> { lo[a]..=hi[a] };
        for (i, (light, knob)) in self
            .renderer
            .base
            .lights
            .iter()
            .zip(k.lights.iter_mut())
            .enumerate()
        {
            match light {
                Light::Point { .. } => {
                    ui.label(format!("point light {i}"));
                    for (a, name) in ["x", "y", "z"].iter().enumerate() {
                        ui.add(egui::Slider::new(&mut knob.position[a], span(a)).text(*name));
                    }
                }
                Light::Sun { .. } => {
                    ui.label(format!("sun {i}"));
                }
            }
            ui.add(
                egui::Slider::new(&mut knob.power, 0.0..=10.0)
                    .logarithmic(true)
                    .text("power ×"),
            );
        }
        ui.separator();
        ui.add(
            egui::Slider::new(&mut k.exposure, 0.01..=100.0)
                .logarithmic(true)
                .text("exposure"),
        );
        if let Some(w) = &mut self.wind {
            ui.separator();
            self.wind_changed |= w.ui(ui, &self.renderer.base);
        }
        if ui.button("reset").clicked() {
            (self.orbit, self.knobs) = self.start.clone();
        }
        ui.small("drag the image to orbit, scroll to zoom");
        if let Some(e) = &mut self.editor {
            ui.separator();
            ui.heading("edit the Gaussians");
            e.panel(ui);
        }
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        let (response, placed) = shell::fitted_picture(ui, self.texture.as_ref());
        if let Some((shown, scale)) = placed
            && self.edit_drag(&response, shown, scale)
        {
            return;
        }
        if response.dragged() {
            let d = response.drag_delta();
            self.orbit.drag(f64::from(d.x), f64::from(d.y));
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.orbit.zoom(f64::from(scroll) / 40.0);
            }
        }
    }

    /// Hands a drag on the picture (shown in `shown` at `scale` screen points per pixel)
    /// to the editing tool, if one is picked: the primary button's drags are strokes, the
    /// other buttons' still orbit. Whether the editor took it.
    fn edit_drag(&mut self, response: &egui::Response, shown: egui::Rect, scale: f32) -> bool {
        let Some(editor) = &mut self.editor else {
            return false;
        };
        if editor.tool == edit_tools::Tool::Orbit {
            return false;
        }
        let primary = egui::PointerButton::Primary;
        let pixel = response.interact_pointer_pos().map(|p| {
            (
                f64::from((p.x - shown.min.x) / scale),
                f64::from((p.y - shown.min.y) / scale),
            )
        });
        let Ok(cam) = self
            .orbit
            .camera(self.renderer.size.0, self.renderer.size.1)
        else {
            return false;
        };
        let scene = &self.renderer.base;
        let mut took = false;
        if let Some((px, py)) = pixel {
            if response.drag_started_by(primary) || response.clicked_by(primary) {
                if let Err(e) = editor.press(scene, &cam, px, py) {
                    editor.message = Some(e);
                }
                self.last_tick = Instant::now();
                took = true;
            } else if response.dragged_by(primary) {
                editor.drag(scene, &cam, px, py);
                took = true;
            }
        }
        if response.drag_stopped_by(primary) || response.clicked_by(primary) {
            editor.release(&cam);
            took = true;
        }
        if let Some(r) = editor.selection() {
            let at = |(x, y): (f64, f64)| shown.min + egui::vec2(x as f32, y as f32) * scale;
            let rect = egui::Rect::from_two_pos(at(r.a), at(r.b));
            let stroke = egui::Stroke::new(1.0, egui::Color32::YELLOW);
            response.ctx.layer_painter(response.layer_id).rect_stroke(
                rect,
                0.0,
                stroke,
                egui::StrokeKind::Middle,
            );
        }
        took
    }

    /// Advances a running airbrush or emitter stroke by the time since the last picture.
    fn tick(&mut self) {
        let Some(editor) = &mut self.editor else {
            return;
        };
        let now = Instant::now();
        if editor.running()
            && let Ok(cam) = self
                .orbit
                .camera(self.renderer.size.0, self.renderer.size.1)
        {
            let dt = now.duration_since(self.last_tick).as_secs_f64();
            editor.tick(&self.renderer.base, &cam, dt);
        }
        self.last_tick = now;
    }

    /// Renders the current view if the texture shows another (the fog playing: always).
    fn refresh(&mut self, ctx: &egui::Context) {
        let now = self.view();
        let elapsed = self.clock.elapsed().as_secs_f64();
        self.clock = Instant::now();
        let playing = match &mut self.wind {
            Some(w) if w.playing => {
                w.advance(&self.renderer.base, elapsed);
                true
            }
            _ => false,
        };
        if !playing && self.shown.as_ref() == Some(&now) && !self.wind_changed {
            return;
        }
        self.wind_changed = false;
        let t = Instant::now();
        match self
            .renderer
            .picture(&now.0, &now.1, self.editor.as_ref(), self.wind.as_ref())
        {
            Ok((rgb, warnings)) => {
                let (w, h) = self.renderer.size;
                shell::show_picture(ctx, &mut self.texture, "scene", [w, h], &rgb);
                self.error = None;
                self.warnings = warnings;
            }
            Err(e) => self.error = Some(e),
        }
        let seconds = t.elapsed().as_secs_f64();
        self.frame_ms = 1e3 * seconds;
        self.times.push(seconds);
        self.shown = Some(now);
    }
}

impl Room for SceneApp {
    type Pass = ();

    fn begin(&mut self, ctx: &egui::Context) {
        if let Some(e) = &mut self.editor {
            e.keys(ctx);
        }
        self.tick();
        self.refresh(ctx);
    }

    fn controls(&mut self, ui: &mut egui::Ui, _: &()) {
        self.controls(ui);
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        self.image(ui);
    }

    fn end(&mut self, ctx: &egui::Context, _: ()) {
        if let Some((opened, seconds)) = self.play_for {
            let left = seconds - opened.elapsed().as_secs_f64();
            if left <= 0.0 {
                let line = summary(
                    &self.renderer,
                    &self.knobs,
                    self.times.clone(),
                    seconds - left,
                );
                if let Ok(mut o) = self.outcome.lock() {
                    o.get_or_insert(Ok(line));
                }
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            } else {
                ctx.request_repaint_after(std::time::Duration::from_secs_f64(left));
            }
        }
        // A knob, the camera or the Gaussians moved during this pass, particles are
        // flying or the fog plays: the next pass renders it.
        let running = self.editor.as_ref().is_some_and(Editor::running);
        if running
            || self.shown.as_ref() != Some(&self.view())
            || self.wind_changed
            || self.wind.as_ref().is_some_and(|w| w.playing)
        {
            ctx.request_repaint();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_scene::render::render;

    fn room() -> Scene {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/scenes/room.json");
        haze_scene::load(std::path::Path::new(path)).unwrap()
    }

    #[test]
    fn the_orbit_starts_at_the_scene_camera() {
        let s = room();
        let fov = 2.0 * s.camera.tan_half().atan().to_degrees();
        let o = Orbit::looking(s.camera.eye, look_target(&s), fov).unwrap();
        let c = o.camera(s.camera.width, s.camera.height).unwrap();
        for a in 0..3 {
            assert!((c.eye[a] - s.camera.eye[a]).abs() < 1e-12);
            assert!((c.forward()[a] - s.camera.forward()[a]).abs() < 1e-12);
            assert!((c.up()[a] - s.camera.up()[a]).abs() < 1e-12);
        }
        assert!((c.tan_half() - s.camera.tan_half()).abs() < 1e-12);
        // The room's central ray meets a surface: the orbit turns about that point.
        let hit = s
            .intersect(s.camera.eye, s.camera.forward(), 0.0, f64::INFINITY)
            .unwrap();
        assert!((o.distance - hit.t).abs() < 1e-9);
    }

    /// A scene with a smoke asset is the march's picture wherever the viewer renders it:
    /// marched on the CPU beside a CPU adapter (decision 0058; then the CPU march's own
    /// picture), by the shader's march on a GPU (its twin: within 10⁻³ relative of the
    /// brightest pixel, but for 1 % of the pixels).
    #[test]
    fn a_smoke_scene_is_the_marchs_picture() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/scenes/smoke.json");
        let base = haze_scene::load(std::path::Path::new(path)).unwrap();
        let fov = 2.0 * base.camera.tan_half().atan().to_degrees();
        let orbit = Orbit::looking(base.camera.eye, look_target(&base), fov).unwrap();
        let knobs = SceneKnobs::of(&base, 1.0);
        let r = Renderer::new(base, (40, 30)).unwrap();
        assert_eq!(r.on_the_cpu(), r.ctx.is_cpu_adapter());
        let shown = r.image(&orbit, &knobs, None, None).unwrap().0;
        let scene = r.scene(&orbit, &knobs, None).unwrap();
        let opt = haze_scene::march::march_options(&scene, false);
        let cpu = haze_scene::march::render(&scene, &Limits::default(), &opt, &|_| {});
        let peak = cpu.pixels.iter().flatten().fold(0.0f32, |m, v| m.max(*v));
        assert!(peak > 0.0);
        let off = shown
            .pixels
            .iter()
            .zip(&cpu.pixels)
            .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3 * peak))
            .count();
        assert!(off <= cpu.pixels.len() / 100, "{off} pixels off");
        if r.on_the_cpu() {
            assert_eq!(shown.pixels, cpu.pixels);
        }
    }

    /// Pixels of `shown` more than `rel` of the brightest pixel of `want` away from it.
    fn pixels_off(shown: &Image, want: &Image, rel: f32) -> usize {
        let peak = want.pixels.iter().flatten().fold(0.0f32, |m, v| m.max(*v));
        assert!(peak > 0.0);
        shown
            .pixels
            .iter()
            .zip(&want.pixels)
            .filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > rel * peak))
            .count()
    }

    /// Paper C's picture and paper D's fog, composited or lit, are their CPU renderers'
    /// wherever the viewer renders them: the CPU's own pictures beside a CPU adapter
    /// (decision 0059), the shaders' on a GPU (their twins: within 10⁻³ of the brightest
    /// pixel but for 1 % of the pixels, silhouettes and shadow edges).
    #[test]
    fn paper_c_and_the_fog_are_their_cpu_renderers_pictures() {
        let fog_path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/scenes/analytic_fog.json"
        );
        let fog = haze_scene::load(std::path::Path::new(fog_path)).unwrap();
        for base in [room(), fog] {
            let fov = 2.0 * base.camera.tan_half().atan().to_degrees();
            let orbit = Orbit::looking(base.camera.eye, look_target(&base), fov).unwrap();
            let knobs = SceneKnobs {
                rasterized: false,
                ..SceneKnobs::of(&base, 1.0)
            };
            let mut wind = Wind::of(&base);
            let r = Renderer::new(base, (40, 30)).unwrap();
            assert_eq!(r.on_the_cpu(), r.ctx.is_cpu_adapter());
            let scene = r.scene(&orbit, &knobs, None).unwrap();
            // The composite, the fog carried 3 s by its wind; then the lit fog (the march).
            if let Some(w) = &mut wind {
                w.advance(&scene, 3.0);
            }
            let moved = wind.as_ref().map_or(scene.clone(), |w| w.apply(&scene));
            let composite =
                haze_scene::analytic::render(&moved, &r.analytic, &Limits::default(), &|_| {});
            let shown = r.image(&orbit, &knobs, None, wind.as_ref()).unwrap().0;
            let mut cases = vec![(shown, composite)];
            if let Some(w) = &mut wind {
                w.lit = true;
                let opt = haze_scene::march::march_options(&moved, false);
                let march = haze_scene::march::render(&moved, &Limits::default(), &opt, &|_| {});
                cases.push((
                    r.image(&orbit, &knobs, None, wind.as_ref()).unwrap().0,
                    march,
                ));
            }
            for (shown, want) in cases {
                if r.on_the_cpu() {
                    assert_eq!(shown.pixels, want.pixels);
                } else {
                    let off = pixels_off(&shown, &want, 1e-3);
                    assert!(off <= want.pixels.len() / 100, "{off} pixels off");
                }
            }
        }
    }

    /// The panel's edits reach the scene, and its GPU pictures, rasterized and ray-traced,
    /// are the CPU's render of that scene (within crates/scene's GPU tolerance, 5·10⁻⁴
    /// relative, but for 1 % of the pixels: silhouettes and shadow edges).
    #[test]
    fn edits_make_the_scene_the_gpu_renders() {
        let base = room();
        let fov = 2.0 * base.camera.tan_half().atan().to_degrees();
        let mut orbit = Orbit::looking(base.camera.eye, look_target(&base), fov).unwrap();
        orbit.drag(20.0, -10.0);
        orbit.zoom(1.5);
        let mut k = SceneKnobs::of(&base, 1.0);
        assert_eq!(
            edited(&base, &orbit, &k, (8, 6)).unwrap().lights,
            base.lights
        );
        k.density = 2.5;
        k.albedo = 2.0;
        k.lights[0].position = [0.5, -1.0, 1.5];
        k.lights[1].power = 0.25;
        let s = edited(&base, &orbit, &k, (40, 30)).unwrap();
        assert_eq!(s.medium.sigma_t, base.medium.sigma_t.map(|t| t * 2.5));
        assert_eq!(s.medium.albedo, [1.0; 3], "albedo kept ≤ 1");
        let Light::Point { position, .. } = &s.lights[0] else {
            panic!()
        };
        assert_eq!(*position, [0.5, -1.0, 1.5]);
        let (Light::Point { intensity: a, .. }, Light::Point { intensity: b, .. }) =
            (&s.lights[1], &base.lights[1])
        else {
            panic!()
        };
        assert_eq!(*a, b.map(|i| i * 0.25));
        assert_eq!(s.camera.eye, orbit.eye());

        let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
        let analytic = Analytic::new(&base);
        let gpu = GpuRenderer::new(&ctx, &analytic).unwrap();
        let c = render(&s, &analytic, &Limits::default(), &|_| {});
        let mean = c
            .pixels
            .iter()
            .flatten()
            .map(|v| f64::from(*v))
            .sum::<f64>()
            / (3 * c.pixels.len()) as f64;
        // Both the panel's paths: rasterized (the default) and ray-traced.
        let traced = gpu.render(&ctx, &s, &Limits::default()).unwrap();
        let rasterized = gpu.render_rasterized(&ctx, &s, &Limits::default()).unwrap();
        for (name, g) in [("ray-traced", traced), ("rasterized", rasterized)] {
            let outside = g
                .pixels
                .iter()
                .flatten()
                .zip(c.pixels.iter().flatten())
                .filter(|(g, c)| {
                    f64::from(*g - *c).abs() > 5e-4 * f64::from(**c).abs() + 1e-5 * mean
                })
                .count();
            assert!(
                mean > 0.0 && outside <= c.pixels.len() / 100,
                "{name}: {outside} differ"
            );
        }
    }
}
