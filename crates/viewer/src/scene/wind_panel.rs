//! The wind of `haze view --scene` for scenes with analytic fog (paper D §5): the fog's
//! time played back live — play/pause, a playback rate, the wind's speed scaled and its
//! horizontal direction overridden, a time slider — and the choice between paper D's
//! composite (the fog's exact depth per pixel over paper C's picture,
//! `haze_scene::gpu::analytic`) and the lit picture (single scattering of the scene's
//! lights through the fog, `haze_scene::gpu::march`).
//!
//! A windy term at time `t` is `γ(x − d(t))`, `d` the drift: `v·t` for a steady wind `v`.
//! The panel changes `v` while the fog plays, so it accumulates the drift instead,
//! `d += v·rate·Δt` per shown picture, and hands each analytic medium the wind `d/t` at
//! time `t` (`haze_fogfn::Fog::shifted` moves by `wind·t = d`): a change of the wind turns
//! the fog's motion from where it is, with no jump. Moving the time slider sets `d = v·t`
//! (the steady wind). Cosines drifting on their own (`ω t`) follow the time.

use eframe::egui;
use haze_gpu::{GpuContext, GpuError};
use haze_scene::Scene;
use haze_scene::gpu::GpuRenderer;
use haze_scene::gpu::analytic::GpuAnalytic;
use haze_scene::media::HeteroMedium;
use haze_scene::media::analytic::AnalyticMedium;
use haze_scene::paper_c::airlight::Limits;
use haze_scene::render::Image;
use std::sync::Arc;

/// Where the time slider reaches (scene seconds).
pub const TIME_RANGE: f64 = 120.0;

/// The panel's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Wind {
    pub playing: bool,
    /// Scene seconds per second of the clock.
    pub rate: f64,
    /// Multiplies every fog's wind speed.
    pub scale: f64,
    /// The wind's horizontal direction (degrees from +x towards +y) instead of the
    /// scene's, its horizontal speed and vertical part kept.
    pub azimuth: Option<f64>,
    /// Scene seconds since the start of the wind.
    pub time: f64,
    /// How far the wind has carried each analytic fog by `time` (module docs).
    drift: Vec<[f64; 3]>,
    /// The lit picture (the march) instead of paper D's composite.
    pub lit: bool,
}

impl Wind {
    /// The wind of `scene`'s analytic fogs at time 0, playing at rate 1; `None` when the
    /// scene has none.
    pub fn of(scene: &Scene) -> Option<Wind> {
        let n = scene.analytic_media().count();
        (n > 0).then(|| Wind {
            playing: true,
            rate: 1.0,
            scale: 1.0,
            azimuth: None,
            time: 0.0,
            drift: vec![[0.0; 3]; n],
            lit: false,
        })
    }

    /// The wind velocity the panel makes of a fog's own `v`.
    pub fn velocity(&self, v: [f64; 3]) -> [f64; 3] {
        let v = match self.azimuth {
            Some(deg) => {
                let speed = v[0].hypot(v[1]);
                let a = deg.to_radians();
                [speed * a.cos(), speed * a.sin(), v[2]]
            }
            None => v,
        };
        v.map(|c| c * self.scale)
    }

    /// Moves the clock on by `seconds` of real time (nothing when paused).
    pub fn advance(&mut self, scene: &Scene, seconds: f64) {
        if !self.playing || seconds.is_nan() || seconds <= 0.0 {
            return;
        }
        let dt = seconds * self.rate;
        let v: Vec<[f64; 3]> = scene
            .analytic_media()
            .map(|m| self.velocity(m.fog.wind))
            .collect();
        for (d, v) in self.drift.iter_mut().zip(v) {
            for k in 0..3 {
                d[k] += v[k] * dt;
            }
        }
        self.time += dt;
    }

    /// Sets the time to `t`, each fog carried by its steady (panel) wind.
    pub fn scrub(&mut self, scene: &Scene, t: f64) {
        self.time = t;
        self.drift = scene
            .analytic_media()
            .map(|m| self.velocity(m.fog.wind).map(|v| v * t))
            .collect();
    }

    /// `scene` with its analytic fogs at the panel's time and drift.
    pub fn apply(&self, scene: &Scene) -> Scene {
        let mut s = scene.clone();
        let mut k = 0;
        for m in &mut s.hetero {
            let HeteroMedium::Analytic(a) = m else {
                continue;
            };
            let d = self.drift.get(k).copied().unwrap_or_default();
            k += 1;
            let mut fog = a.fog.clone();
            fog.wind = if self.time != 0.0 {
                d.map(|c| c / self.time)
            } else {
                self.velocity(a.fog.wind)
            };
            *a = Arc::new(AnalyticMedium {
                fog,
                time: self.time,
                ..AnalyticMedium::clone(a)
            });
        }
        s
    }

    /// The panel; whether the fog needs a new picture.
    pub fn ui(&mut self, ui: &mut egui::Ui, scene: &Scene) -> bool {
        let before = self.clone();
        ui.label("analytic fog");
        ui.checkbox(&mut self.lit, "lit by the lights (march)")
            .on_hover_text("off: paper D's composite, the fog's colour over the picture");
        ui.horizontal(|ui| {
            let label = if self.playing { "pause" } else { "play" };
            if ui.button(label).clicked() {
                self.playing = !self.playing;
            }
            if ui.button("restart").clicked() {
                self.scrub(scene, 0.0);
            }
        });
        let mut t = self.time;
        if ui
            .add(egui::Slider::new(&mut t, 0.0..=TIME_RANGE.max(self.time)).text("time (s)"))
            .changed()
        {
            self.scrub(scene, t);
        }
        ui.add(
            egui::Slider::new(&mut self.rate, 0.0..=20.0)
                .logarithmic(true)
                .text("speed ×"),
        );
        ui.add(
            egui::Slider::new(&mut self.scale, 0.0..=10.0)
                .logarithmic(true)
                .text("wind ×"),
        );
        let mut own = self.azimuth.is_none();
        ui.checkbox(&mut own, "the scene's wind direction");
        if own {
            self.azimuth = None;
        } else {
            let mut deg = self.azimuth.unwrap_or(0.0);
            ui.add(egui::Slider::new(&mut deg, -180.0..=180.0).text("wind direction (°)"));
            self.azimuth = Some(deg);
        }
        *self != before
    }
}

/// Paper D's composite, compiled for a scene with analytic fog.
#[derive(Debug)]
pub struct FogRenderer {
    composite: GpuAnalytic,
}

impl FogRenderer {
    pub fn new(ctx: &GpuContext) -> Result<FogRenderer, GpuError> {
        Ok(FogRenderer {
            composite: GpuAnalytic::new(ctx)?,
        })
    }

    /// The picture of `scene` (the panel's other edits made) with its fogs carried by
    /// `wind`: paper D's composite, or the march when lit or when the scene holds other
    /// heterogeneous media (a smoke asset).
    pub fn render(
        &self,
        ctx: &GpuContext,
        gpu: &GpuRenderer,
        scene: &Scene,
        wind: &Wind,
        lim: &Limits,
    ) -> Result<Image, GpuError> {
        let s = wind.apply(scene);
        if wind.lit || s.hetero.iter().any(|m| !m.is_analytic()) {
            gpu.render(ctx, &s, lim)
        } else {
            self.composite.render(ctx, gpu, &s, lim)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fog_scene() -> Scene {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/scenes/analytic_fog.json"
        );
        haze_scene::load(std::path::Path::new(path)).unwrap()
    }

    const POINTS: [[f64; 3]; 4] = [
        [0.0, 0.0, 0.5],
        [2.0, 3.0, 1.2],
        [-3.0, 6.0, 0.4],
        [1.0, -2.0, 2.0],
    ];

    /// `K` of every analytic fog of `s` at a few points.
    fn densities(s: &Scene) -> Vec<f64> {
        s.analytic_media()
            .flat_map(|m| POINTS.map(|p| m.fog.density(p, m.time)))
            .collect()
    }

    #[test]
    fn a_steady_wind_is_the_scene_at_that_time() {
        let base = fog_scene();
        let mut w = Wind::of(&base).unwrap();
        // Played in uneven steps or set on the slider: the scene's own `at_time`.
        for dt in [0.3, 1.7, 0.25, 2.0] {
            w.advance(&base, dt);
        }
        let want = densities(&base.at_time(4.25));
        let mut scrubbed = w.clone();
        scrubbed.scrub(&base, 4.25);
        for got in [
            densities(&w.apply(&base)),
            densities(&scrubbed.apply(&base)),
        ] {
            for (g, e) in got.iter().zip(&want) {
                assert!((g - e).abs() <= 1e-12 * e.abs().max(1.0), "{g} vs {e}");
            }
        }
        // Paused, the clock stands still.
        w.playing = false;
        let before = w.clone();
        w.advance(&base, 1.0);
        assert_eq!(w, before);
    }

    #[test]
    fn turning_the_wind_moves_the_fog_on_from_where_it_is() {
        let base = fog_scene();
        let mut w = Wind::of(&base).unwrap();
        w.advance(&base, 2.0);
        let at_turn = densities(&w.apply(&base));
        // A new direction and speed change nothing until time passes, then the fog
        // moves by the new wind: the scene's fog shifted by v₁·2 + v₂·1.
        w.azimuth = Some(90.0);
        w.scale = 3.0;
        assert_eq!(densities(&w.apply(&base)), at_turn);
        w.advance(&base, 1.0);
        let v1 = base.analytic_media().next().unwrap().fog.wind;
        let v2 = [0.0, 3.0 * v1[0].hypot(v1[1]), 3.0 * v1[2]];
        // The bundled fog's windy terms carried by d = v₁·2 + v₂·1 at t = 3: its wind d/3.
        let d: [f64; 3] = [0, 1, 2].map(|k| v1[k] * 2.0 + v2[k]);
        let mut fog = base.analytic_media().next().unwrap().fog.clone();
        fog.wind = d.map(|c| c / 3.0);
        let want: Vec<f64> = POINTS.iter().map(|&p| fog.density(p, 3.0)).collect();
        for (g, e) in densities(&w.apply(&base)).iter().zip(&want) {
            assert!((g - e).abs() <= 1e-12 * e.abs().max(1.0), "{g} vs {e}");
        }
    }

    /// The viewer's pictures of the bundled fog as the wind plays: they change with
    /// time, and paused they do not; the lit picture is the march's (GPU, lavapipe).
    #[test]
    fn the_picture_moves_with_the_wind_and_stands_when_paused() {
        let mut base = fog_scene();
        base.camera = base.camera.with_size(32, 24).unwrap();
        let ctx = GpuContext::new().unwrap_or_else(|e| panic!("{e}"));
        let gpu = GpuRenderer::new(&ctx, &haze_scene::render::Analytic::new(&base)).unwrap();
        let fog = FogRenderer::new(&ctx).unwrap();
        let lim = Limits::default();
        let mut w = Wind::of(&base).unwrap();
        let shot = |w: &Wind| fog.render(&ctx, &gpu, &base, w, &lim).unwrap().pixels;
        let first = shot(&w);
        w.advance(&base, 2.0);
        let moved = shot(&w);
        // Mean |change| over the mean value: the fog's blobs and waves move by ~1.3 units.
        let change = |a: &[[f32; 3]], b: &[[f32; 3]]| {
            let d: f64 = a
                .iter()
                .flatten()
                .zip(b.iter().flatten())
                .map(|(x, y)| f64::from((x - y).abs()))
                .sum();
            let m: f64 = a.iter().flatten().map(|x| f64::from(x.abs())).sum();
            d / m
        };
        let c = change(&first, &moved);
        assert!(c > 1e-3, "the fog did not move: {c:.2e}");
        w.playing = false;
        w.advance(&base, 2.0);
        assert_eq!(shot(&w), moved, "paused, the picture changed");
        // The lit mode: the march through the same fog.
        w.lit = true;
        let lit = shot(&w);
        assert_eq!(lit, gpu.render(&ctx, &w.apply(&base), &lim).unwrap().pixels);
        assert!(
            change(&moved, &lit) > 1e-2,
            "the lit picture is the composite"
        );
    }
}
