//! The fog room (`haze view --fog`): a fogmap's wavelet fog (paper E) flown through in a window,
//! rendered by the GPU fog renderer (`haze_wavelet::gpu::fog`) over its ground and sky.
//!
//! The fly camera starts at the fog's default framing (`haze_wavelet::render::framing`,
//! as `haze fog wavelet` without `--eye`). The panel sets the basis, the levels, µ, the
//! density, the falloff, the wind and the exposure. The fog is decomposed and uploaded
//! again only when the basis, levels, µ, density or falloff change, or a sequence's next
//! fogmap (a directory of numbered fogmaps, shown at `--fps`) differs from the last; the
//! wind moves the uploaded fog by `wind · dt` each frame (nothing uploaded). A picture is
//! rendered on the window's thread whenever the camera, a knob or the fog's animation
//! changed (GPU render, read back, sRGB encoding; BENCHMARKS.md has its time on
//! lavapipe).
//!
//! With `--smoke FILE.haze` a baked smoke frame stands in the fog (`haze_render::fog_smoke`:
//! placement, lighting): whenever the camera moved, its layer (radiance, transmittance
//! and depth per pixel) is rendered on the CPU and uploaded, and the GPU composites it
//! with the fog by depth (`FogRenderer::draw_over`, the twin of
//! `haze_wavelet::render::shade_over`).

mod fly;

use crate::shell::{self, Outcome, Room};
use anyhow::{Context, Result, anyhow, bail};
use eframe::egui;
use fly::Fly;
use haze_camera::LookAt;
use haze_gpu::GpuContext;
use haze_render::fog::FogModel;
use haze_render::fog_smoke::{Smoke, SmokePlacement};
use haze_wavelet::gpu::fog::{FogImage, FogRenderer, GpuFog, SmokeLayer};
use haze_wavelet::render::Scene;
use haze_wavelet::{Basis, Fog, Fogmap};
use std::path::PathBuf;
use std::time::Instant;

/// Everything `haze view --fog` was asked to do.
#[derive(Debug)]
pub struct FogViewArgs {
    /// A fogmap, or a directory of numbered fogmaps (an animation at `fps`).
    pub fogmap: PathBuf,
    pub model: FogModel,
    /// The smoke shown in the fog, if any.
    pub smoke: SmokePlacement,
    /// Fogmaps per second of a sequence.
    pub fps: f64,
    /// Render resolution.
    pub width: usize,
    pub height: usize,
    pub exposure: f64,
    /// Fly for this many seconds, print the figures, exit.
    pub play_for: Option<f64>,
    pub window: bool,
}

/// The panel's knobs.
#[derive(Clone, Debug, PartialEq)]
pub struct FogKnobs {
    pub basis: Basis,
    pub levels: usize,
    pub mu: f64,
    pub density: f64,
    pub falloff: f64,
    /// World units per second the fog drifts.
    pub wind: [f64; 2],
    pub exposure: f64,
}

impl FogKnobs {
    /// What the fog's decomposition and upload depend on (not the wind or the exposure).
    fn model(&self) -> (Basis, usize, [f64; 3]) {
        (
            self.basis,
            self.levels,
            [self.mu, self.density, self.falloff],
        )
    }
}

/// Where the fog is in its animation: how far the wind has moved it, and which fogmap of
/// the sequence it shows (taken modulo their number).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FogAt {
    pub drift: [f64; 2],
    pub map: usize,
}

impl FogAt {
    /// The fog `seconds` into its animation under a constant wind.
    fn after(seconds: f64, wind: [f64; 2], fps: f64) -> FogAt {
        FogAt {
            drift: wind.map(|w| w * seconds),
            map: (seconds * fps).max(0.0) as usize,
        }
    }
}

/// The fogmaps, the device and the fog on it: what every picture needs.
struct Renderer {
    /// One fogmap, or a sequence's (all of one size).
    fogmaps: Vec<Fogmap>,
    model: FogModel,
    scene: Scene,
    ctx: GpuContext,
    gpu: FogRenderer,
    image: FogImage,
    /// The fog on the GPU, of the knobs in `built`, moved by `moved`.
    fog: GpuFog,
    built: (Basis, usize, [f64; 3]),
    /// The fogmap `fog` was decomposed from (or one with the same values).
    built_map: usize,
    moved: [f64; 2],
    /// Decompositions made (the first one included).
    decompositions: usize,
    /// The smoke, its layer on the GPU and the view that layer is of.
    smoke: Option<(Smoke, SmokeLayer, Option<LookAt>)>,
}

impl Renderer {
    /// The fog of `knobs`, decomposed on the CPU.
    fn decompose(fogmap: &Fogmap, model: &FogModel, knobs: &FogKnobs) -> Result<Fog, String> {
        let mut placement = model.placement(fogmap.width, fogmap.height);
        placement.density = knobs.density;
        placement.falloff = knobs.falloff;
        let mut settings = model.settings(false);
        settings.mu = knobs.mu;
        Fog::new(
            &fogmap.grid(),
            knobs.basis,
            knobs.levels,
            placement,
            settings,
        )
        .map_err(|e| e.to_string())
    }

    fn new(
        fogmaps: Vec<Fogmap>,
        model: FogModel,
        knobs: &FogKnobs,
        (width, height): (usize, usize),
        smoke: Option<Smoke>,
    ) -> Result<(Renderer, Fog)> {
        let fog = Renderer::decompose(&fogmaps[0], &model, knobs).map_err(|e| anyhow!(e))?;
        let ctx = GpuContext::new().map_err(|e| anyhow!("GPU: {e}"))?;
        let gpu = FogRenderer::new(&ctx).map_err(|e| anyhow!("GPU: {e}"))?;
        let image = FogImage::new(&ctx, width, height).map_err(|e| anyhow!("{e}"))?;
        let uploaded = gpu.upload(&ctx, &fog).map_err(|e| anyhow!("GPU: {e}"))?;
        let scene = model.scene();
        let smoke = match smoke {
            Some(smoke) => {
                let none = vec![haze_wavelet::render::SmokeSample::default(); width * height];
                let layer =
                    SmokeLayer::new(&ctx, &none, width, height).map_err(|e| anyhow!("{e}"))?;
                Some((smoke, layer, None))
            }
            None => None,
        };
        let r = Renderer {
            fogmaps,
            model,
            scene,
            ctx,
            gpu,
            image,
            fog: uploaded,
            built: knobs.model(),
            built_map: 0,
            moved: [0.0; 2],
            decompositions: 1,
            smoke,
        };
        Ok((r, fog))
    }

    /// Renders the fog of `knobs` at `at`, seen from `look`; the sRGB bytes. The fog is
    /// decomposed again only when a knob of its model changed or the fogmap shown differs
    /// from the last one decomposed.
    fn picture(&mut self, look: &LookAt, knobs: &FogKnobs, at: FogAt) -> Result<Vec<u8>, String> {
        let map = at.map % self.fogmaps.len();
        let same_map = self.fogmaps[map].values == self.fogmaps[self.built_map].values;
        if knobs.model() != self.built || !same_map {
            let fog = Renderer::decompose(&self.fogmaps[map], &self.model, knobs)?;
            self.decompositions += 1;
            self.fog = self
                .gpu
                .upload(&self.ctx, &fog)
                .map_err(|e| e.to_string())?;
            self.built = knobs.model();
            self.moved = [0.0; 2];
        }
        self.built_map = map;
        let drift = at.drift;
        self.fog
            .translate([drift[0] - self.moved[0], drift[1] - self.moved[1]]);
        self.moved = drift;
        match &mut self.smoke {
            Some((smoke, layer, of)) => {
                // The smoke's layer depends on the camera only.
                if of.as_ref() != Some(look) {
                    let [w, h] = self.image.size();
                    let camera = look.camera(w, h)?;
                    layer
                        .write(&self.ctx, &smoke.layer(&camera))
                        .map_err(|e| e.to_string())?;
                    *of = Some(*look);
                }
                self.gpu
                    .draw_over(&self.ctx, &self.fog, look, &self.scene, layer, &self.image)
            }
            None => self
                .gpu
                .draw(&self.ctx, &self.fog, look, &self.scene, &self.image),
        }
        .map_err(|e| e.to_string())?;
        let pixels = self.image.read(&self.ctx).map_err(|e| e.to_string())?;
        let [width, height] = self.image.size();
        let image = haze_view::Image {
            width,
            height,
            pixels: pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        };
        Ok(image.to_srgb8(knobs.exposure, haze_core::ToneMap::Clip))
    }

    fn size(&self) -> (usize, usize) {
        let [w, h] = self.image.size();
        (w, h)
    }
}

pub fn run(a: FogViewArgs) -> Result<()> {
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
    let files = haze_render::fog::fogmap_files(&a.fogmap)?;
    let most = crate::smoke::playback::MAX_FPS;
    if files.len() > 1 && !(a.fps > 0.0 && a.fps <= most) {
        bail!(
            "--fps {}: a sequence of fogmaps needs a rate above 0, at most {most}",
            haze_core::number::shown(a.fps)
        );
    }
    let mut fogmaps: Vec<Fogmap> = Vec::with_capacity(files.len());
    for f in &files {
        let next = Fogmap::load(f)?;
        if let Some(first) = fogmaps.first()
            && [next.width, next.height] != [first.width, first.height]
        {
            bail!(
                "{}: {} × {}, but the sequence's first fogmap is {} × {}",
                f.display(),
                next.width,
                next.height,
                first.width,
                first.height
            );
        }
        fogmaps.push(next);
    }
    let knobs = FogKnobs {
        basis: a.model.basis,
        levels: a.model.levels,
        mu: a.model.mu,
        density: a.model.density,
        falloff: a.model.falloff,
        wind: a.model.wind,
        exposure: a.exposure,
    };
    let name = a.fogmap.display().to_string();
    let smoke = a.smoke.load()?;
    let (mut renderer, fog) = Renderer::new(fogmaps, a.model, &knobs, (a.width, a.height), smoke)
        .with_context(|| name.clone())?;
    let [x0, x1, y0, y1] = fog.map_box();
    // Flying speed: a tenth of the fog's width per second.
    let speed = 0.1 * (x1 - x0).max(y1 - y0);
    let fly = Fly::looking(&haze_wavelet::render::framing(&fog))
        .map_err(|e| anyhow!("{name}: camera: {e}"))?;
    // The first picture, also the proof that the fog renders.
    renderer
        .picture(&fly.look_at(), &knobs, FogAt::after(0.0, knobs.wind, a.fps))
        .map_err(|e| anyhow!("{name}: {e}"))?;
    if !a.window {
        let seconds = a.play_for.unwrap_or_default();
        let line = fly_without_window(&mut renderer, fly, &knobs, a.fps, seconds)
            .map_err(|e| anyhow!("{name}: {e}"))?;
        println!("{line}");
        return Ok(());
    }
    let title = format!("haze view — {name}");
    let (w, h) = renderer.size();
    let max_levels =
        haze_wavelet::lod::max_levels(renderer.fogmaps[0].width, renderer.fogmaps[0].height);
    let outcome = Outcome::default();
    let app = FogApp {
        renderer,
        fly: fly.clone(),
        start: (fly, knobs.clone()),
        knobs,
        max_levels,
        speed,
        fps: a.fps,
        at: FogAt::after(0.0, [0.0; 2], a.fps),
        clock: 0.0,
        drifting: true,
        last: Instant::now(),
        texture: None,
        shown: None,
        frame_ms: 0.0,
        error: None,
        play_for: a.play_for.map(|s| (Instant::now(), s)),
        times: Vec::new(),
        outcome: outcome.clone(),
    };
    shell::open(&title, (w, h), outcome, move |_| Ok(app))
}

/// Renders pictures for `seconds`, turning the camera by a degree and letting the fog
/// drift with the wind (and a sequence play at `fps`) by the time elapsed, and gives the
/// measurement line.
fn fly_without_window(
    r: &mut Renderer,
    mut fly: Fly,
    knobs: &FogKnobs,
    fps: f64,
    seconds: f64,
) -> Result<String, String> {
    let start = Instant::now();
    let mut times = Vec::new();
    while start.elapsed().as_secs_f64() < seconds || times.is_empty() {
        let t = Instant::now();
        let at = start.elapsed().as_secs_f64();
        r.picture(&fly.look_at(), knobs, FogAt::after(at, knobs.wind, fps))?;
        times.push(t.elapsed().as_secs_f64());
        fly.turn(1f64.to_radians() / fly::RADIANS_PER_PIXEL, 0.0);
    }
    Ok(summary(r, times, start.elapsed().as_secs_f64()))
}

/// The measurement line: pictures rendered in `seconds`, their median time.
fn summary(r: &Renderer, mut times: Vec<f64>, seconds: f64) -> String {
    times.sort_by(f64::total_cmp);
    let median = times.get(times.len() / 2).copied().unwrap_or(0.0);
    let (w, h) = r.size();
    let mut line = format!(
        "{} picture{} of {}×{} in {:.2} s, median {:.1} ms each (GPU render, read back, sRGB) on {}",
        times.len(),
        if times.len() == 1 { "" } else { "s" },
        w,
        h,
        seconds,
        1e3 * median,
        r.ctx.adapter_name()
    );
    if let Some((smoke, ..)) = &r.smoke {
        line += &format!("; with {} (smoke layer on the CPU)", smoke.label);
    }
    if r.fogmaps.len() > 1 {
        line += &format!(
            "; {} fogmaps, {} decomposition{}",
            r.fogmaps.len(),
            r.decompositions,
            if r.decompositions == 1 { "" } else { "s" }
        );
    }
    line
}

/// The window.
struct FogApp {
    renderer: Renderer,
    fly: Fly,
    knobs: FogKnobs,
    /// The first view, for "reset".
    start: (Fly, FogKnobs),
    max_levels: usize,
    /// World units per second of WASD.
    speed: f64,
    /// Fogmaps per second of a sequence.
    fps: f64,
    /// Where the fog is in its animation.
    at: FogAt,
    /// Seconds the fog has moved (the sequence's clock).
    clock: f64,
    /// Whether the fog moves: the wind blows and a sequence plays (the panel can hold it).
    drifting: bool,
    /// When the last pass ran (the clock of flying and drifting).
    last: Instant,
    texture: Option<egui::TextureHandle>,
    /// What the texture shows.
    shown: Option<(Fly, FogKnobs, FogAt)>,
    frame_ms: f64,
    error: Option<String>,
    /// `--play-for`: close the window that long after it opened.
    play_for: Option<(Instant, f64)>,
    /// Seconds of each picture rendered.
    times: Vec<f64>,
    /// `--play-for`'s measurement line, printed once the window has closed.
    outcome: Outcome,
}

/// Widens `range` to hold `v`.
fn holding(v: f64, lo: f64, hi: f64) -> std::ops::RangeInclusive<f64> {
    lo.min(v)..=hi.max(v)
}

impl FogApp {
    fn controls(&mut self, ui: &mut egui::Ui) {
        ui.heading("wavelet fog");
        let (w, h) = self.renderer.size();
        ui.label(format!("{w} × {h}, {:.1} ms per picture", self.frame_ms));
        ui.label(format!("GPU: {}", self.renderer.ctx.adapter_name()));
        if let Some((smoke, ..)) = &self.renderer.smoke {
            ui.label(format!("smoke: {}", smoke.label));
        }
        if let Some(e) = &self.error {
            ui.colored_label(egui::Color32::RED, e);
        }
        ui.separator();
        let k = &mut self.knobs;
        egui::ComboBox::from_label("basis")
            .selected_text(k.basis.name())
            .show_ui(ui, |ui| {
                for b in [Basis::Haar, Basis::Linear, Basis::Quadratic] {
                    ui.selectable_value(&mut k.basis, b, b.name());
                }
            });
        ui.add(egui::Slider::new(&mut k.levels, 0..=self.max_levels).text("levels"));
        ui.add(egui::Slider::new(&mut k.mu, 0.0..=1.0).text("µ"));
        let range = holding(k.density, 1e-3, 10.0);
        ui.add(
            egui::Slider::new(&mut k.density, range)
                .logarithmic(true)
                .text("density"),
        );
        let range = holding(k.falloff, 0.0, 2.0);
        ui.add(egui::Slider::new(&mut k.falloff, range).text("falloff"));
        ui.separator();
        ui.label("wind (units per second)");
        for (a, name) in ["dx", "dy"].iter().enumerate() {
            let range = holding(k.wind[a], -20.0, 20.0);
            ui.add(egui::Slider::new(&mut k.wind[a], range).text(*name));
        }
        if self.renderer.fogmaps.len() > 1 {
            ui.label(format!(
                "fogmap {} of {} at {} per second",
                self.at.map % self.renderer.fogmaps.len() + 1,
                self.renderer.fogmaps.len(),
                self.fps
            ));
        }
        ui.checkbox(&mut self.drifting, "fog moves (wind, sequence)");
        ui.separator();
        ui.add(
            egui::Slider::new(&mut k.exposure, 0.01..=100.0)
                .logarithmic(true)
                .text("exposure"),
        );
        if ui.button("reset").clicked() {
            (self.fly, self.knobs) = self.start.clone();
            self.at = FogAt::after(0.0, [0.0; 2], self.fps);
            self.clock = 0.0;
        }
        ui.small(
            "W A S D fly, Q E down and up, drag the image to look around, scroll to fly ahead",
        );
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        let (response, _) = shell::fitted_picture(ui, self.texture.as_ref());
        if response.dragged() {
            let d = response.drag_delta();
            self.fly.turn(f64::from(d.x), f64::from(d.y));
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.fly
                    .fly(self.speed * f64::from(scroll) / 200.0, 0.0, 0.0);
            }
        }
    }

    /// Moves the camera by the keys held and the fog by the wind over the time since the
    /// last pass; whether anything moves (so that another pass must follow).
    fn advance(&mut self, ctx: &egui::Context) -> bool {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f64().min(0.1);
        self.last = now;
        let typing = ctx.memory(|m| m.focused().is_some());
        let held = |key| !typing && ctx.input(|i| i.key_down(key));
        let axis = |plus, minus| f64::from(u8::from(held(plus))) - f64::from(u8::from(held(minus)));
        let (ahead, aside, rise) = (
            axis(egui::Key::W, egui::Key::S),
            axis(egui::Key::D, egui::Key::A),
            axis(egui::Key::E, egui::Key::Q),
        );
        let step = self.speed * dt;
        self.fly.fly(ahead * step, aside * step, rise * step);
        let sequence = self.renderer.fogmaps.len() > 1;
        let moves = self.drifting && (sequence || self.knobs.wind != [0.0; 2]);
        if moves {
            // The wind may change on the way: the drift adds up its steps.
            for a in 0..2 {
                self.at.drift[a] += self.knobs.wind[a] * dt;
            }
            self.clock += dt;
            self.at.map = FogAt::after(self.clock, [0.0; 2], self.fps).map;
        }
        moves || ahead != 0.0 || aside != 0.0 || rise != 0.0
    }

    /// Renders the current view if the texture shows another.
    fn refresh(&mut self, ctx: &egui::Context) {
        let now = (self.fly.clone(), self.knobs.clone(), self.at);
        if self.shown.as_ref() == Some(&now) {
            return;
        }
        let t = Instant::now();
        match self.renderer.picture(&now.0.look_at(), &now.1, now.2) {
            Ok(rgb) => {
                let (w, h) = self.renderer.size();
                shell::show_picture(ctx, &mut self.texture, "fog", [w, h], &rgb);
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

impl Room for FogApp {
    /// Whether the fog or the camera is moving.
    type Pass = bool;

    fn begin(&mut self, ctx: &egui::Context) -> bool {
        let moving = self.advance(ctx);
        self.refresh(ctx);
        moving
    }

    fn controls(&mut self, ui: &mut egui::Ui, _: &bool) {
        self.controls(ui);
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        self.image(ui);
    }

    fn end(&mut self, ctx: &egui::Context, moving: bool) {
        if let Some((opened, seconds)) = self.play_for {
            let left = seconds - opened.elapsed().as_secs_f64();
            if left <= 0.0 {
                let line = summary(&self.renderer, self.times.clone(), seconds - left);
                if let Ok(mut o) = self.outcome.lock() {
                    o.get_or_insert(Ok(line));
                }
                ctx.send_viewport_cmd(egui::ViewportCommand::Close);
            } else {
                ctx.request_repaint_after(std::time::Duration::from_secs_f64(left));
            }
        }
        // The wind, a held key or a knob moved: the next pass renders it.
        let now = (self.fly.clone(), self.knobs.clone(), self.at);
        if moving || self.shown.as_ref() != Some(&now) {
            ctx.request_repaint();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The model `haze view --fog --levels 2` asks for (every other flag at its default).
    fn levels_2() -> FogModel {
        FogModel {
            basis: Basis::Linear,
            levels: 2,
            mu: 1.0,
            min_transmittance: 1.0 / 1024.0,
            cell: 1.0,
            origin: None,
            density: 0.12,
            bottom: 0.0,
            top: 8.0,
            falloff: 0.3,
            wind: [0.0; 2],
            fog_color: None,
        }
    }

    fn fogmap() -> Fogmap {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/fogmap/fogmap_128.png"
        );
        Fogmap::load(std::path::Path::new(path)).unwrap()
    }

    /// The viewer's picture is the CPU renderer's image of the fog its knobs describe,
    /// after a knob change (a new decomposition), a drift (a move of the uploaded fog) and
    /// a sequence's next fogmap: the CPU's fog is built from scratch with the same knobs
    /// and fogmap and translated once. A fogmap with the last one's values is not
    /// decomposed again.
    /// Tolerance: one sRGB step (8-bit rounding of values that differ by f32 rounding,
    /// about 1e-5), on all but a few pixels (ground points that round to the other side
    /// of a checker line, as `haze fog wavelet --gpu` documents).
    #[test]
    fn pictures_are_the_cpu_render_of_the_knobs() {
        let model = levels_2();
        let mut knobs = FogKnobs {
            basis: model.basis,
            levels: 2,
            mu: 1.0,
            density: model.density,
            falloff: model.falloff,
            wind: [0.0; 2],
            exposure: 1.0,
        };
        let (w, h) = (48, 36);
        // A sequence of three fogmaps: the bundled one twice, then the bundled one
        // mirrored east to west.
        let mut mirrored = fogmap();
        for row in mirrored.values.chunks_mut(mirrored.width) {
            row.reverse();
        }
        let maps = vec![fogmap(), fogmap(), mirrored.clone()];
        let (mut r, fog) = Renderer::new(maps, model.clone(), &knobs, (w, h), None)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut fly = Fly::looking(&haze_wavelet::render::framing(&fog)).unwrap();
        fly.fly(20.0, 5.0, -4.0);
        fly.turn(30.0, 10.0);
        let at = |map, drift| FogAt { drift, map };
        r.picture(&fly.look_at(), &knobs, at(0, [0.0; 2])).unwrap();
        knobs.basis = Basis::Quadratic;
        knobs.mu = 0.6;
        knobs.density = 0.3;
        knobs.falloff = 0.1;
        let drift = [7.5, -3.0];
        let got = r.picture(&fly.look_at(), &knobs, at(1, drift)).unwrap();
        // The knobs changed: decomposed again; fogmap 1 has fogmap 0's values: not again.
        assert_eq!(r.decompositions, 2);

        let mut cpu = Renderer::decompose(&fogmap(), &model, &knobs).unwrap();
        assert_eq!(cpu.basis(), Basis::Quadratic);
        cpu.translate(drift);
        let camera = fly.look_at().camera(w, h).unwrap();
        let px = haze_wavelet::render::render(&cpu, &camera, &model.scene(), &|| {});
        let want = haze_view::Image {
            width: w,
            height: h,
            pixels: px,
        }
        .to_srgb8(1.0, haze_core::ToneMap::Clip);
        let off = got
            .iter()
            .zip(&want)
            .filter(|(g, c)| g.abs_diff(**c) > 1)
            .count();
        assert!(off <= w * h / 100, "{off} of {} bytes differ", got.len());
        // The drift and the knobs did change the picture.
        let still = r.picture(&fly.look_at(), &knobs, at(4, [0.0; 2])).unwrap();
        assert_ne!(still, got);
        assert_eq!(r.decompositions, 2, "fogmap 4 is fogmap 1 (4 mod 3)");

        // Fogmap 2 differs: decomposed again, and the picture is the CPU's of the mirror.
        let got = r.picture(&fly.look_at(), &knobs, at(2, drift)).unwrap();
        assert_eq!(r.decompositions, 3);
        let mut cpu = Renderer::decompose(&mirrored, &model, &knobs).unwrap();
        cpu.translate(drift);
        let px = haze_wavelet::render::render(&cpu, &camera, &model.scene(), &|| {});
        let want = haze_view::Image {
            width: w,
            height: h,
            pixels: px,
        }
        .to_srgb8(1.0, haze_core::ToneMap::Clip);
        let off = got
            .iter()
            .zip(&want)
            .filter(|(g, c)| g.abs_diff(**c) > 1)
            .count();
        assert!(off <= w * h / 100, "{off} of {} bytes differ", got.len());
        assert_ne!(got, still);
    }
}
