//! `haze view --scene`: a scene file shown through paper C's renderer on the GPU
//! (`haze_scene::gpu`), with an orbit camera and the medium and lights editable in a side
//! panel. The surfaces are rasterized with a depth buffer (`haze_scene::raster`), the
//! airlight and shading computed per pixel up to that depth; a panel switch (or
//! `--ray-traced`) shows the ray tracer's picture instead, for comparison.
//!
//! The orbit starts at the scene's camera and turns about the point its central ray looks
//! at (the first surface it meets, else the scene's middle at the same distance), Z up.
//! The panel scales the medium's extinction and albedo, moves each point light, and
//! scales each light's power. A picture is rendered on the window's thread whenever the
//! camera or a knob changed (the GPU render, its read back and the sRGB encoding;
//! BENCHMARKS.md has its time on lavapipe), so the window shows the edit it was asked for,
//! never an older one; a slow device makes the window slow to answer rather than late.

use super::orbit::Orbit;
use super::wind_panel::{FogRenderer, Wind};
use anyhow::{Result, anyhow, bail};
use eframe::egui;
use haze_scene::airlight::Limits;
use haze_scene::gpu::GpuRenderer;
use haze_scene::render::Analytic;
use haze_scene::{Light, Scene, Shape};
use haze_view::gpu::GpuContext;
use std::ops::RangeInclusive;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

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
struct Renderer {
    base: Scene,
    ctx: GpuContext,
    gpu: GpuRenderer,
    /// Paper D's composite, for a scene with analytic fog.
    fog: Option<FogRenderer>,
    size: (usize, usize),
}

impl Renderer {
    /// Renders the edited scene, its analytic fogs carried by `wind`; the sRGB bytes of
    /// the picture.
    fn picture(
        &self,
        orbit: &Orbit,
        knobs: &SceneKnobs,
        wind: Option<&Wind>,
    ) -> Result<Vec<u8>, String> {
        let scene = edited(&self.base, orbit, knobs, self.size)?;
        let lim = Limits::default();
        let img = if let (Some(fog), Some(wind)) = (&self.fog, wind) {
            fog.render(&self.ctx, &self.gpu, &scene, wind, &lim)
        } else if knobs.rasterized {
            self.gpu.render_rasterized(&self.ctx, &scene, &lim)
        } else {
            self.gpu.render(&self.ctx, &scene, &lim)
        }
        .map_err(|e| e.to_string())?;
        let image = haze_view::Image {
            width: img.width,
            height: img.height,
            pixels: img.pixels,
        };
        Ok(image.to_srgb8(knobs.exposure))
    }
}

pub fn run(a: SceneViewArgs) -> Result<()> {
    if !(a.exposure > 0.0 && a.exposure.is_finite()) {
        bail!("--exposure {} must be positive", a.exposure);
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
    let ctx = GpuContext::new().map_err(|e| anyhow!("GPU: {e}"))?;
    let gpu = GpuRenderer::new(&ctx, &Analytic::new(&base)).map_err(|e| anyhow!("GPU: {e}"))?;
    let wind = Wind::of(&base);
    let fog = match wind {
        Some(_) => Some(FogRenderer::new(&ctx).map_err(|e| anyhow!("GPU: {e}"))?),
        None => None,
    };
    let renderer = Renderer {
        base,
        ctx,
        gpu,
        fog,
        size: (a.width, a.height),
    };
    // The first picture, also the proof that the scene renders.
    renderer
        .picture(&orbit, &knobs, wind.as_ref())
        .map_err(|e| anyhow!("{}: {e}", a.scene.display()))?;
    if !a.window {
        let line = turn_without_window(
            &renderer,
            orbit,
            &knobs,
            wind,
            a.play_for.unwrap_or_default(),
        )
        .map_err(|e| anyhow!("{}: {e}", a.scene.display()))?;
        println!("{line}");
        return Ok(());
    }
    let title = format!("haze view — {}", a.scene.display());
    let (w, h) = renderer.size;
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_title(title.as_str())
            .with_inner_size([(w as f32 + 320.0).max(1000.0), (h as f32 + 40.0).max(720.0)]),
        ..Default::default()
    };
    let (lo, hi) = scene_box(&renderer.base);
    let outcome: Arc<Mutex<Option<String>>> = Arc::default();
    let app = SceneApp {
        renderer,
        orbit: orbit.clone(),
        start: (orbit, knobs.clone()),
        knobs,
        range: (lo.map(|v| v - 2.0), hi.map(|v| v + 2.0)),
        texture: None,
        shown: None,
        frame_ms: 0.0,
        error: None,
        play_for: a.play_for.map(|s| (Instant::now(), s)),
        times: Vec::new(),
        outcome: outcome.clone(),
        wind,
        clock: Instant::now(),
        wind_changed: false,
    };
    eframe::run_native(&title, options, Box::new(move |_| Ok(Box::new(app)))).map_err(|e| {
        anyhow!(
            "cannot open the viewer window: {}",
            one_line(&e.to_string())
        )
    })?;
    if let Some(line) = outcome.lock().ok().and_then(|mut o| o.take()) {
        println!("{line}");
    }
    Ok(())
}

fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// Renders pictures for `seconds`, turning the camera by a degree each (and playing the
/// analytic fog's wind in real time), and gives the measurement line.
fn turn_without_window(
    r: &Renderer,
    mut orbit: Orbit,
    knobs: &SceneKnobs,
    mut wind: Option<Wind>,
    seconds: f64,
) -> Result<String, String> {
    let start = Instant::now();
    let mut times = Vec::new();
    while start.elapsed().as_secs_f64() < seconds || times.is_empty() {
        let t = Instant::now();
        r.picture(&orbit, knobs, wind.as_ref())?;
        let took = t.elapsed().as_secs_f64();
        times.push(took);
        orbit.drag(1f64.to_radians() / super::orbit::RADIANS_PER_PIXEL, 0.0);
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
        "{} picture{} of {}×{} in {:.2} s, median {:.1} ms each (GPU render with {} surfaces{}, read back, sRGB) on {}",
        times.len(),
        if times.len() == 1 { "" } else { "s" },
        r.size.0,
        r.size.1,
        seconds,
        1e3 * median,
        // GpuRenderer::render_rasterized ray-traces scenes with voxel media (the march).
        if knobs.rasterized && r.base.hetero.is_empty() {
            "rasterized"
        } else {
            "ray-traced"
        },
        if r.fog.is_some() {
            ", analytic fog composited as its wind plays"
        } else {
            ""
        },
        r.ctx.adapter_name()
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
    /// What the texture shows.
    shown: Option<(Orbit, SceneKnobs)>,
    frame_ms: f64,
    error: Option<String>,
    /// `--play-for`: close the window that long after it opened.
    play_for: Option<(Instant, f64)>,
    /// Seconds of each picture rendered.
    times: Vec<f64>,
    /// `--play-for`'s measurement line, printed once the window has closed.
    outcome: Arc<Mutex<Option<String>>>,
    /// The analytic fog's wind and lit mode (wind_panel), for a scene with one.
    wind: Option<Wind>,
    /// When the wind last moved on.
    clock: Instant,
    /// The wind panel changed since the last picture.
    wind_changed: bool,
}

impl SceneApp {
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
        ui.checkbox(&mut self.knobs.rasterized, "rasterize surfaces")
            .on_hover_text("off: every pixel's ray traced through the surfaces instead");
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
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        let avail = ui.available_size();
        let (rect, response) = ui.allocate_exact_size(avail, egui::Sense::drag());
        if let Some(tex) = &self.texture {
            let [w, h] = tex.size().map(|n| n as f32);
            let scale = (rect.width() / w).min(rect.height() / h);
            let shown = egui::Rect::from_center_size(rect.center(), egui::vec2(w, h) * scale);
            let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
            ui.painter()
                .image(tex.id(), shown, uv, egui::Color32::WHITE);
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

    /// Renders the current view if the texture shows another (the fog playing: always).
    fn refresh(&mut self, ctx: &egui::Context) {
        let now = (self.orbit.clone(), self.knobs.clone());
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
        match self.renderer.picture(&now.0, &now.1, self.wind.as_ref()) {
            Ok(rgb) => {
                let (w, h) = self.renderer.size;
                super::show_picture(ctx, &mut self.texture, "scene", [w, h], &rgb);
                self.error = None;
            }
            Err(e) => self.error = Some(e),
        }
        let seconds = t.elapsed().as_secs_f64();
        self.frame_ms = 1e3 * seconds;
        self.times.push(seconds);
        self.shown = Some(now);
    }
}

impl eframe::App for SceneApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        self.refresh(&ctx);
        egui::Panel::left("controls")
            .resizable(false)
            .default_size(290.0)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui));
            });
        egui::CentralPanel::default().show(ui, |ui| self.image(ui));
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
                    o.get_or_insert(line);
                }
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            } else {
                ctx.request_repaint_after(std::time::Duration::from_secs_f64(left));
            }
        }
        // A knob or the camera moved during this pass, or the fog plays: the next pass
        // renders it.
        if self.shown.as_ref() != Some(&(self.orbit.clone(), self.knobs.clone()))
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
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/data/scenes/room.json");
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
