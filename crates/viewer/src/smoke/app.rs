//! The viewer window (eframe on wgpu): the rendered frame in the middle, orbited by
//! dragging and zoomed by scrolling; playback, timing, light, medium and quality controls
//! in a side panel. Space plays or pauses, the left and right arrow keys step.
//!
//! The window only shows pictures and collects input: rendering happens on the render
//! thread with its own headless GPU device (eframe's device only draws the UI), driven by
//! the [`Player`]. The UI is redrawn on input, when the render thread finishes a job, and
//! when a finished frame falls due.

use super::Knobs;
use super::playback::Playback;
use super::player::{Player, Update, View};
use super::worker::{FrameCursor, Worker};
use crate::orbit::Orbit;
use crate::shell::{self, Outcome, Room};
use anyhow::Result;
use eframe::egui;
use haze_gpu::GpuContext;
use haze_render::lights::TurnableMap;
use haze_view::distant::{angles, direction};
use haze_view::gpu::renderer::LightingOn;
use haze_view::{Distant, Environment};
use std::ops::RangeInclusive;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// What the window starts from.
pub struct Setup {
    pub title: String,
    pub cursor: FrameCursor,
    pub ctx: GpuContext,
    /// Where a frame's light is computed.
    pub lighting: LightingOn,
    /// How much finer than the asset's voxels frames are lit.
    pub supersample: haze_render::smoke::Supersample,
    pub playback: Playback,
    /// When the command started (the first picture is timed from there).
    pub started: Instant,
    pub settings: Settings,
}

/// What the window keeps besides the player: the panel's state and the camera.
pub struct Settings {
    /// The render device, for the panel.
    pub adapter: String,
    /// Source frame numbers.
    pub numbers: Vec<i64>,
    pub orbit: Orbit,
    pub knobs: Knobs,
    pub env: Arc<Environment>,
    /// The map of `--env`, to turn live (none under the built-in skies).
    pub map: Option<TurnableMap>,
    /// The ground the panel's "ground" switch shows (at the floor of the asset's box).
    pub floor: haze_view::ground::Ground,
    /// Render resolution.
    pub size: (usize, usize),
    pub play_for: Option<f64>,
}

/// Opens the window and runs it until it is closed (or `--play-for` has played), then
/// prints the measurement line of `--play-for`.
pub fn run_window(setup: Setup) -> Result<()> {
    let outcome = Outcome::default();
    let out = outcome.clone();
    let title = setup.title.clone();
    shell::open(&title, setup.settings.size, outcome, move |egui_ctx| {
        let repaint = egui_ctx.clone();
        let Setup {
            cursor,
            ctx,
            lighting,
            supersample,
            playback,
            started,
            settings,
            ..
        } = setup;
        let worker = Worker::spawn(
            cursor,
            ctx,
            lighting,
            supersample,
            Box::new(move || repaint.request_repaint()),
        )?;
        Ok(ViewerApp::new(
            Player::new(playback, worker, started),
            settings,
            out,
        ))
    })
}

/// The light of the panel: what its two sun sliders (degrees: azimuth from +X towards
/// +Y, elevation above the horizon) move — see [`move_sun`] — or a fixed map.
enum Light {
    /// The environment's first sun (`--sun`, or a map's sun split off), the real light.
    Sun { azimuth: f64, elevation: f64 },
    /// The built-in sky without suns: its sun glow.
    Sky { azimuth: f64, elevation: f64 },
    /// A map without suns.
    Map,
}

impl Light {
    /// What the sliders of `env` move, starting where that sun is.
    fn of(env: &Environment) -> Light {
        let at = |d: [f64; 3]| {
            let (theta, phi) = angles(d);
            (phi.to_degrees(), 90.0 - theta.to_degrees())
        };
        match (env.suns.first(), &env.distant) {
            (Some(sun), _) => {
                let (azimuth, elevation) = at(sun.direction);
                Light::Sun { azimuth, elevation }
            }
            (None, Distant::Sky(sky)) => {
                let (azimuth, elevation) = at(sky.sun_direction);
                Light::Sky { azimuth, elevation }
            }
            (None, Distant::Map(_)) => Light::Map,
        }
    }

    /// `(azimuth, elevation)` of the sliders (zeros for a map, which has none).
    fn sliders(&self) -> (f64, f64) {
        match self {
            Light::Sun { azimuth, elevation } | Light::Sky { azimuth, elevation } => {
                (*azimuth, *elevation)
            }
            Light::Map => (0.0, 0.0),
        }
    }
}

/// `env` with its sun towards `azimuth`, `elevation` (degrees), or `None` when that
/// changes nothing. With suns, the first one — the real light, lit exactly — and, under
/// the built-in sky, the sky's glow with it (the sky's picture of that sun); under a map,
/// every sun turns with the first (the suns split off a map are one light, a soft sun a
/// cluster of them); without suns, the built-in sky's glow (a map without suns has
/// nothing to move). Everything else (under the sky the other suns; the point lights,
/// the map) is kept, but a map's backdrop (`Environment::backdrop`, the map as given with
/// its sun where it was) is dropped once its suns turn.
pub(super) fn move_sun(env: &Environment, azimuth: f64, elevation: f64) -> Option<Environment> {
    let d = direction((90.0 - elevation).to_radians(), azimuth.to_radians());
    let mut out = env.clone();
    let mut changed = false;
    if let Some(first) = out.suns.first().map(|s| s.direction)
        && first != d
    {
        if matches!(out.distant, Distant::Map(_)) {
            // The suns split off a map are one light (a soft sun is a cluster): they
            // turn together, by the rotation taking the first to `d`.
            for sun in &mut out.suns {
                sun.direction = rotate_towards(first, d, sun.direction);
            }
            out.suns[0].direction = d;
            // The map as given shows its sun where it was: the background now shows
            // the suns where they are (their disks over the rest of the map).
            out.backdrop = None;
        } else {
            out.suns[0].direction = d;
        }
        changed = true;
    }
    if let Distant::Sky(sky) = &mut out.distant
        && sky.sun_direction != d
    {
        sky.sun_direction = d;
        changed = true;
    }
    changed.then_some(out)
}

/// `degrees` as the "map turn" slider shows it: the same turn within −180° to 180°.
fn slider_degrees(degrees: f64) -> f64 {
    (degrees + 180.0).rem_euclid(360.0) - 180.0
}

/// What the panel says of the suns split off a map: a count, then per sun its elevation,
/// azimuth, width and share of the map's light (luminance). Nothing under the built-in
/// sky.
fn suns_found(env: &Environment) -> Vec<String> {
    let Distant::Map(rest) = &env.distant else {
        return Vec::new();
    };
    if env.suns.is_empty() {
        return vec!["no sun split off the map".into()];
    }
    let y = haze_view::lights::decompose::luminance;
    let total = y(haze_view::lights::decompose::map_power(rest))
        + env.suns.iter().map(|s| y(s.irradiance)).sum::<f64>();
    let mut out = vec![format!("{} sun(s) split off the map:", env.suns.len())];
    for s in &env.suns {
        let (theta, phi) = angles(s.direction);
        out.push(format!(
            "  elev {:.1}°, azim {:.1}°, {:.1}° wide, {:.0} %",
            90.0 - theta.to_degrees(),
            phi.to_degrees(),
            s.angle.to_degrees(),
            if total > 0.0 {
                100.0 * y(s.irradiance) / total
            } else {
                0.0
            }
        ));
    }
    out
}

/// `v` turned by the rotation that takes the unit `from` to the unit `to` about their
/// common normal (Rodrigues' formula); `v` itself when they are equal, a half-turn about
/// a normal of `from` when they are opposite.
fn rotate_towards(from: [f64; 3], to: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let axis = cross(from, to);
    let s = dot(axis, axis).sqrt();
    let c = dot(from, to);
    if s < 1e-12 {
        if c > 0.0 {
            return v;
        }
        // Opposite: a half-turn about a normal of `from`.
        let n = if from[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let k = cross(from, n);
        let kn = dot(k, k).sqrt();
        let k = k.map(|x| x / kn);
        let kv = dot(k, v);
        return [0, 1, 2].map(|i| 2.0 * kv * k[i] - v[i]);
    }
    let k = axis.map(|x| x / s);
    let kxv = cross(k, v);
    let kv = dot(k, v);
    [0, 1, 2].map(|i| v[i] * c + kxv[i] * s + k[i] * kv * (1.0 - c))
}

/// The sliders' ranges: the usual span, widened to hold the value given on the command
/// line (a slider clamps its value into its range).
struct Ranges {
    sigma_t: RangeInclusive<f64>,
    g: RangeInclusive<f64>,
    slices: RangeInclusive<f64>,
    exposure: RangeInclusive<f64>,
}

fn span(lo: f64, hi: f64, value: f64) -> RangeInclusive<f64> {
    lo.min(value)..=hi.max(value)
}

struct ViewerApp {
    player: Player,
    settings: Settings,
    initial_orbit: Orbit,
    light: Light,
    /// The suns split off the map, one line each (empty under the built-in sky).
    found: Vec<String>,
    /// The sliders' values last applied to the environment: it changes only when they
    /// move (the light given on the command line stays as given until then).
    light_applied: (f64, f64),
    /// The "map turn" slider (degrees, −180 to 180) and its value last applied, under a
    /// map.
    map_turn: (f64, f64),
    texture: Option<egui::TextureHandle>,
    /// The source frame number of the picture on screen.
    showing: Option<i64>,
    /// The frame rate of the rate field (kept while playing as fast as possible).
    target_fps: f64,
    ranges: Ranges,
    /// Where `--play-for` leaves its line (or its error).
    outcome: Outcome,
    done: bool,
}

impl ViewerApp {
    fn new(player: Player, settings: Settings, outcome: Outcome) -> ViewerApp {
        let light = Light::of(&settings.env);
        let found = suns_found(&settings.env);
        let turn = settings
            .map
            .as_ref()
            .map_or(0.0, |m| slider_degrees(m.given_turn()));
        let fps = player.playback.fps();
        let k = &settings.knobs;
        let ranges = Ranges {
            sigma_t: span(0.0, 64.0, k.sigma_t),
            g: span(-0.99, 0.99, k.g),
            slices: span(0.5, 4.0, k.slices),
            exposure: span(0.05, 20.0, k.exposure),
        };
        ViewerApp {
            ranges,
            target_fps: if fps > 0.0 {
                fps.clamp(1.0, 240.0)
            } else {
                24.0
            },
            player,
            initial_orbit: settings.orbit.clone(),
            settings,
            light_applied: light.sliders(),
            light,
            map_turn: (turn, turn),
            found,
            texture: None,
            showing: None,
            outcome,
            done: false,
        }
    }

    /// The view of the current camera, knobs, light and exposure (the orbit keeps the
    /// camera valid, and the sliders' ranges the medium).
    fn view(&self) -> View {
        let (w, h) = self.settings.size;
        let camera = self
            .settings
            .orbit
            .camera(w, h)
            .expect("the orbit keeps the camera valid");
        let scene = self
            .settings
            .knobs
            .scene(self.settings.env.clone())
            .expect("the sliders keep the medium valid");
        View {
            camera,
            scene,
            exposure: self.settings.knobs.exposure,
            tone: self.settings.knobs.tone,
        }
    }

    /// Turns the map to the "map turn" slider: the whole map — its rest, its suns, the
    /// background — as `--env-rotate` would, split again; the sun sliders then start
    /// from the first sun found.
    fn update_map_turn(&mut self) {
        let (turn, applied) = self.map_turn;
        let Some(map) = &self.settings.map else {
            return;
        };
        if turn == applied {
            return;
        }
        self.map_turn.1 = turn;
        match map.environment(turn) {
            Ok(env) => {
                self.light = Light::of(&env);
                self.light_applied = self.light.sliders();
                self.found = suns_found(&env);
                self.settings.env = Arc::new(env);
            }
            Err(e) => tracing::warn!("{e:#}"),
        }
    }

    /// Moves the sun to the sliders' direction ([`move_sun`]).
    fn update_light(&mut self) {
        let at = self.light.sliders();
        if at == self.light_applied {
            return;
        }
        self.light_applied = at;
        if let Some(env) = move_sun(&self.settings.env, at.0, at.1) {
            self.settings.env = Arc::new(env);
        }
    }

    /// `--play-for`: once it has played that long, leaves the line and closes.
    fn check_play_for(&mut self, ctx: &egui::Context, now: Instant) {
        let Some(limit) = self.settings.play_for else {
            return;
        };
        if self.done {
            return;
        }
        let result = if let Some(e) = &self.player.first_failure {
            Some(Err(e.clone()))
        } else if self.player.first_picture.is_some() && self.player.report(now).seconds >= limit {
            let (w, h) = self.settings.size;
            Some(Ok(self.player.summary(now, w, h)))
        } else {
            None
        };
        if let Some(r) = result {
            if let Ok(mut o) = self.outcome.lock() {
                *o = Some(r);
            }
            self.done = true;
            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    fn keys(&mut self, ctx: &egui::Context) {
        if ctx.egui_wants_keyboard_input() {
            return;
        }
        let (space, left, right) = ctx.input(|i| {
            (
                i.key_pressed(egui::Key::Space),
                i.key_pressed(egui::Key::ArrowLeft),
                i.key_pressed(egui::Key::ArrowRight),
            )
        });
        let p = &mut self.player.playback;
        if space {
            if p.playing() {
                p.pause();
            } else {
                p.play();
            }
        }
        if left {
            p.step(-1);
        }
        if right {
            p.step(1);
        }
    }

    fn controls(&mut self, ui: &mut egui::Ui, now: Instant) {
        ui.heading("haze view");
        ui.small(format!("GPU: {}", self.settings.adapter));
        ui.separator();

        let r = self.player.report(now);
        let count = self.player.playback.frame_count();
        let p = &mut self.player.playback;
        ui.horizontal(|ui| {
            if ui.button("step back").clicked() {
                p.step(-1);
            }
            let label = if p.playing() { "pause" } else { "play" };
            if ui.button(label).clicked() {
                if p.playing() {
                    p.pause();
                } else {
                    p.play();
                }
            }
            if ui.button("step forward").clicked() {
                p.step(1);
            }
        });
        let mut k = p.current();
        let number = self.settings.numbers.get(k).copied().unwrap_or(k as i64);
        if ui
            .add(egui::Slider::new(&mut k, 0..=count - 1).text(format!("frame ({number})")))
            .changed()
        {
            p.seek(k);
        }
        let mut fastest = p.fps() == 0.0;
        let target = &mut self.target_fps;
        ui.horizontal(|ui| {
            let changed_rate = ui
                .add_enabled(
                    !fastest,
                    egui::DragValue::new(target)
                        .range(1.0..=240.0)
                        .suffix(" fps"),
                )
                .changed();
            let changed_mode = ui.checkbox(&mut fastest, "as fast as possible").changed();
            if changed_rate || changed_mode {
                // The range keeps the rate valid.
                let _ = p.set_fps(if fastest { 0.0 } else { *target });
            }
        });

        if p.playing() {
            ui.label(format!("measured {:.1} fps", r.fps));
            ui.label(format!("dropped {} of {} due", r.dropped, r.due));
            ui.label(format!(
                "frame time mean {:.1} ms, max {:.1} ms",
                r.mean_frame_seconds * 1e3,
                r.max_frame_seconds * 1e3
            ));
        } else {
            ui.label("paused");
        }
        if let Some(n) = self.showing {
            ui.small(format!("showing frame {n}"));
        }
        ui.separator();

        ui.label("render (ms; host, then GPU per pass)");
        match &self.player.times {
            Some(t) => {
                let s = &t.crm;
                let reused = if t.sources_reused { " (reused)" } else { "" };
                let grids = if t.grids_reused { " (reused)" } else { "" };
                egui::Grid::new("times").num_columns(2).show(ui, |ui| {
                    let mut row = |name: &str, v: String| {
                        ui.label(name);
                        ui.monospace(v);
                        ui.end_row();
                    };
                    row(
                        "single scattering",
                        format!("{:.1}{reused}", s.single_seconds * 1e3),
                    );
                    row(
                        "multiple scattering",
                        format!("{:.1} ({} CG)", s.multiple_seconds * 1e3, s.cg_iterations),
                    );
                    row(
                        "volume pass",
                        format!("{:.1}{grids}", s.volume_seconds * 1e3),
                    );
                    row(
                        "environment pass",
                        format!("{:.1}{grids}", s.env_seconds * 1e3),
                    );
                    if self.settings.env.has_lights() {
                        row(
                            "lights pass",
                            format!("{:.1}{grids}", s.lights_seconds * 1e3),
                        );
                    }
                    row("view pass", format!("{:.1}", s.view_seconds * 1e3));
                    for (stage, seconds) in &t.gpu {
                        row(&format!("GPU: {stage}"), format!("{:.2}", seconds * 1e3));
                    }
                    row(
                        "whole job, mean",
                        format!("{:.1}", self.player.mean_render_seconds() * 1e3),
                    );
                });
            }
            None => {
                ui.small("rendering the first frame…");
            }
        }
        if self.player.shown_detail < 1.0 {
            ui.small(format!(
                "lit at detail {:.2}, at most one slice per voxel (on a CPU adapter smooth pixels from their neighbours), to keep up with playback (full detail when paused)",
                self.player.shown_detail
            ));
        }
        if let Some(g) = &self.player.grid {
            match g.warning() {
                Some(w) => ui.colored_label(egui::Color32::LIGHT_RED, w),
                None => ui.small(g.describe()),
            };
        }
        for (line, warning) in self.player.lamps.lines() {
            if warning {
                ui.colored_label(egui::Color32::LIGHT_RED, line);
            } else {
                ui.small(line);
            }
        }
        if let Some(e) = &self.player.error {
            ui.colored_label(egui::Color32::LIGHT_RED, e);
        }
        ui.separator();

        if self.settings.map.is_some() {
            ui.add(egui::Slider::new(&mut self.map_turn.0, -180.0..=180.0).text("map turn °"))
                .on_hover_text(
                    "Turn the whole map about the vertical, counter-clockwise seen from above, as --env-rotate does",
                );
            self.update_map_turn();
        }
        let sun = matches!(self.light, Light::Sun { .. });
        match &mut self.light {
            Light::Sun { azimuth, elevation } | Light::Sky { azimuth, elevation } => {
                ui.label(if sun {
                    "sun (lit exactly)"
                } else {
                    "sun (sky glow)"
                });
                ui.add(egui::Slider::new(azimuth, 0.0..=360.0).text("azimuth °"));
                ui.add(egui::Slider::new(elevation, -10.0..=90.0).text("elevation °"));
            }
            Light::Map => {
                ui.label("light: environment map (--env)");
            }
        }
        for line in &self.found {
            ui.small(line);
        }
        if let Some(g) = self.settings.knobs.ground {
            for line in g.hidden(&self.settings.env) {
                ui.colored_label(egui::Color32::LIGHT_RED, line);
            }
        }
        self.update_light();
        ui.separator();

        let k = &mut self.settings.knobs;
        let r = &self.ranges;
        ui.label("medium");
        ui.add(
            egui::Slider::new(&mut k.sigma_t, r.sigma_t.clone())
                .logarithmic(true)
                .text("σt"),
        );
        ui.add(egui::Slider::new(&mut k.albedo, 0.0..=1.0).text("albedo"));
        ui.add(egui::Slider::new(&mut k.g, r.g.clone()).text("HG g"));
        if let Some(w) = haze_view::sh::phase_cut_warning(k.g, k.sh_order) {
            ui.colored_label(egui::Color32::LIGHT_RED, w);
        }
        ui.separator();
        ui.label("quality");
        ui.add(egui::Slider::new(&mut k.sh_order, 1..=6).text("SH order"));
        ui.add(egui::Slider::new(&mut k.slices, r.slices.clone()).text("slices per voxel"));
        ui.checkbox(&mut k.multiple, "multiple scattering");
        ui.checkbox(&mut k.residual, "residual");
        ui.checkbox(&mut k.sky_per_voxel, "sky per voxel (environment pass)");
        ui.checkbox(&mut k.orders, "multiple scattering by explicit orders");
        ui.add(
            egui::Slider::new(&mut k.exposure, r.exposure.clone())
                .logarithmic(true)
                .text("exposure"),
        );
        let mut ground = k.ground.is_some();
        ui.checkbox(&mut ground, "ground (with the smoke's shadow)");
        k.ground = ground.then_some(self.settings.floor);
        let mut filmic = k.tone == haze_core::ToneMap::Filmic;
        ui.checkbox(&mut filmic, "filmic tone map (off: clipped)");
        k.tone = if filmic {
            haze_core::ToneMap::Filmic
        } else {
            haze_core::ToneMap::Clip
        };
        ui.separator();
        if ui.button("reset camera").clicked() {
            self.settings.orbit = self.initial_orbit.clone();
        }
        ui.small("drag the image to orbit, scroll to zoom; space: play/pause, left/right arrow keys: step");
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        let (response, _) = shell::fitted_picture(ui, self.texture.as_ref());
        if response.dragged() {
            let d = response.drag_delta();
            self.settings.orbit.drag(f64::from(d.x), f64::from(d.y));
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.settings.orbit.zoom(f64::from(scroll) / 40.0);
            }
        }
    }
}

/// What the start of a pass hands the rest of it.
struct SmokePass {
    now: Instant,
    /// The view before this pass's keys and knobs.
    before: View,
    update: Update,
}

impl Room for ViewerApp {
    type Pass = SmokePass;

    fn begin(&mut self, ctx: &egui::Context) -> SmokePass {
        let now = Instant::now();
        self.keys(ctx);
        let before = self.view();
        let update = self.player.update(now, &before);
        if let Some(p) = &update.shown {
            shell::show_picture(ctx, &mut self.texture, "smoke", [p.width, p.height], &p.rgb);
            self.showing = Some(p.number);
        }
        self.check_play_for(ctx, now);
        SmokePass {
            now,
            before,
            update,
        }
    }

    fn controls(&mut self, ui: &mut egui::Ui, pass: &SmokePass) {
        self.controls(ui, pass.now);
    }

    fn image(&mut self, ui: &mut egui::Ui) {
        self.image(ui);
    }

    fn end(&mut self, ctx: &egui::Context, pass: SmokePass) {
        let SmokePass {
            now,
            before,
            update,
        } = pass;
        // A knob or the camera moved during this pass: the next pass hands the new view
        // to the render thread. Otherwise the next pass comes when a picture falls due,
        // when `--play-for` ends, or after a moment while playing (to keep the figures
        // moving); the render thread wakes the window when it finishes a job.
        if self.view() != before {
            ctx.request_repaint();
        } else {
            let mut next = update.wake_at;
            if let (Some(limit), false) = (self.settings.play_for, self.done) {
                let left = limit - self.player.report(now).seconds;
                if self.player.first_picture.is_some() {
                    let end = now + Duration::from_secs_f64(left.max(0.0));
                    next = Some(next.map_or(end, |n| n.min(end)));
                }
            }
            if self.player.playback.playing() {
                let soon = now + Duration::from_millis(250);
                next = Some(next.map_or(soon, |n| n.min(soon)));
            }
            if let Some(at) = next {
                ctx.request_repaint_after(at.saturating_duration_since(now));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_view::{LatLong, PointLight, Sky, Sun};

    fn sun_towards(d: [f64; 3]) -> Sun {
        Sun::from_radiance(d, [1e4; 3], 0.53).unwrap()
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-12)
    }

    /// The "map turn" slider turns the whole map as `--env-rotate` does, and the sun
    /// sliders then start from the sun where the turn took it.
    #[test]
    fn the_map_turn_takes_the_sun_and_the_sliders_with_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sun.exr");
        let mut map = haze_core::Image::new(64, 32);
        for p in &mut map.pixels {
            *p = [0.3, 0.4, 0.6];
        }
        // A sun at column 11, row 12: azimuth 360°·11.5/64, elevation 90° − 180°·12.5/32.
        map.pixels[12 * 64 + 11] = [900.0, 850.0, 800.0];
        map.write_exr(&path).unwrap();
        let lights = haze_render::lights::Lights {
            env: path.to_str().unwrap().into(),
            ..Default::default()
        };
        let turnable = lights.turnable().unwrap().unwrap();
        let (azimuth0, elevation0) = (360.0 * 11.5 / 64.0, 90.0 - 180.0 * 12.5 / 32.0);
        for (turn, want) in [
            (0.0, azimuth0),
            (45.0, azimuth0 + 45.0),
            (-90.0, azimuth0 + 270.0),
        ] {
            let env = turnable.environment(turn).unwrap();
            let Light::Sun { azimuth, elevation } = Light::of(&env) else {
                panic!("the map's sun is split off");
            };
            assert!((azimuth - want).abs() < 1e-9, "{turn}: {azimuth} vs {want}");
            assert!((elevation - elevation0).abs() < 1e-9, "{elevation}");
            assert_eq!(suns_found(&env).len(), 2, "{:?}", suns_found(&env));
        }
        assert_eq!(slider_degrees(400.0), 40.0);
        assert_eq!(slider_degrees(180.0), -180.0);
        assert_eq!(slider_degrees(-190.0), 170.0);
    }

    #[test]
    fn the_sliders_move_the_real_sun_when_there_is_one() {
        let d = direction(30f64.to_radians(), 40f64.to_radians());
        // The built-in sky with a --sun and a point light: the sliders start at the sun
        // and move it, the sky's glow with it, and keep the point light.
        let mut env = Environment::sky(Sky::default());
        env.suns.push(sun_towards([0.0, -1.0, 1.0]));
        env.suns.push(sun_towards([1.0, 0.0, 0.2]));
        env.points
            .push(PointLight::new([1.0, 2.0, 3.0], [1.0; 3]).unwrap());
        let Light::Sun { azimuth, elevation } = Light::of(&env) else {
            panic!("a sun to move");
        };
        assert!((azimuth - 270.0).abs() < 1e-9 && (elevation - 45.0).abs() < 1e-9);
        let moved = move_sun(&env, 40.0, 60.0).unwrap();
        assert!(close(moved.suns[0].direction, d));
        let Distant::Sky(sky) = &moved.distant else {
            panic!("the sky stays");
        };
        assert!(close(sky.sun_direction, d));
        assert_eq!(moved.suns[1], env.suns[1]);
        assert_eq!(moved.points, env.points);
        assert_eq!(moved.suns[0].irradiance, env.suns[0].irradiance);

        // A map with its sun split off: the sun moves, the map stays.
        let map = LatLong::new(2, 1, vec![[0.5; 3]; 2]).unwrap();
        let mut env = Environment::map(map.clone());
        env.suns.push(sun_towards([0.0, 0.0, 1.0]));
        assert!(matches!(Light::of(&env), Light::Sun { .. }));
        let moved = move_sun(&env, 40.0, 60.0).unwrap();
        assert!(close(moved.suns[0].direction, d));
        assert_eq!(moved.distant, Distant::Map(map.clone()));
        assert!(move_sun(&moved, 40.0, 60.0).is_none());
        // A cluster split off a map turns as one: the angles between its suns are kept.
        let mut env = Environment::map(map.clone());
        env.suns.push(sun_towards([0.0, -1.0, 1.0]));
        env.suns.push(sun_towards([0.1, -1.0, 0.9]));
        // Seen as the map as given until its suns turn.
        env.backdrop = Some(haze_view::env::Backdrop {
            map: map.clone(),
            suns: 2,
        });
        let moved = move_sun(&env, 40.0, 60.0).unwrap();
        assert!(close(moved.suns[0].direction, d));
        assert_eq!(moved.backdrop, None);
        let angle = |s: &[Sun]| {
            let (a, b) = (s[0].direction, s[1].direction);
            let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            ((a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / (n(a) * n(b))).acos()
        };
        assert!((angle(&moved.suns) - angle(&env.suns)).abs() < 1e-9);
        // Opposite directions and the identity.
        let v = [0.3, -0.4, 0.5];
        let flipped = rotate_towards([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], v);
        assert!((flipped[2] + 0.5).abs() < 1e-12);
        assert_eq!(rotate_towards([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], v), v);

        // No suns: the sky's glow, as before; a map has nothing to move.
        let env = Environment::sky(Sky::default());
        assert!(matches!(Light::of(&env), Light::Sky { .. }));
        let moved = move_sun(&env, 40.0, 60.0).unwrap();
        assert!(moved.suns.is_empty());
        let Distant::Sky(sky) = &moved.distant else {
            panic!("the sky stays");
        };
        assert!(close(sky.sun_direction, d));
        let env = Environment::map(map);
        assert!(matches!(Light::of(&env), Light::Map));
        assert!(move_sun(&env, 40.0, 60.0).is_none());
    }
}
