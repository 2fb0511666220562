//! `haze view --scene`'s editing tools for a scene's Gaussian medium (paper B §6), on top
//! of the library in `haze_scene::edit`: the tool and its settings picked in the panel, a
//! mouse drag on the picture as the stroke, the Gaussians the stroke makes shown (and
//! re-lit) as it goes, one undoable edit when the button is released, undo/redo, save
//! into a scene file and load from one.
//!
//! The tools edit the scene's first Gaussian medium; its `σt`, albedo, background and
//! noise stay as the file gives them. Each stroke draws its random numbers from the
//! tool's seed plus the number of strokes made before it, so a scripted session gives the
//! same Gaussians every time. Airbrush and emitter strokes run in time: the viewer calls
//! [`Editor::tick`] with the seconds between pictures while the button is held.

use eframe::egui;
use haze_gaussians::{Gaussian, GaussianMedium};
use haze_scene::edit::airbrush::{AirParams, Airbrush};
use haze_scene::edit::clipboard::{Clipboard, Rect};
use haze_scene::edit::emitter::{EmitParams, Emitter};
use haze_scene::edit::eraser::{EraseParams, Eraser};
use haze_scene::edit::paintbrush::{PaintParams, Paintbrush};
use haze_scene::edit::{Document, Draft, Target, file, plane};
use haze_scene::media::HeteroMedium;
use haze_scene::media::gaussians::GaussianMediumOf;
use haze_scene::{Camera, Scene};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The longest time step an airbrush or emitter stroke takes at once (a slow picture
/// does not make its particles jump).
const MAX_TICK: f64 = 0.1;

/// What a drag on the picture does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tool {
    /// Turn the camera (no editing).
    Orbit,
    Paint,
    Airbrush,
    Erase,
    Emit,
    /// Drag a rectangle: copy the Gaussians inside.
    Copy,
    /// Drag a rectangle: cut the Gaussians inside.
    Cut,
    /// Click: paste what was copied or cut.
    Paste,
}

impl Tool {
    const ALL: [(Tool, &'static str); 8] = [
        (Tool::Orbit, "orbit"),
        (Tool::Paint, "paintbrush"),
        (Tool::Airbrush, "airbrush"),
        (Tool::Erase, "eraser"),
        (Tool::Emit, "emitter"),
        (Tool::Copy, "copy"),
        (Tool::Cut, "cut"),
        (Tool::Paste, "paste"),
    ];
}

/// A stroke given on the command line (`--stroke TOOL:X,Y:X,Y…`).
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptedStroke {
    pub tool: Tool,
    /// The cursor's picture points, in pixels from the top left.
    pub points: Vec<(f64, f64)>,
}

impl std::fmt::Display for ScriptedStroke {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = SCRIPT_NAMES.iter().find(|n| n.1 == self.tool);
        write!(f, "{}", name.map_or("orbit", |n| n.0))?;
        for (x, y) in &self.points {
            write!(f, ":{x},{y}")?;
        }
        Ok(())
    }
}

/// The tools' names in `--stroke`.
const SCRIPT_NAMES: [(&str, Tool); 7] = [
    ("paint", Tool::Paint),
    ("airbrush", Tool::Airbrush),
    ("erase", Tool::Erase),
    ("emit", Tool::Emit),
    ("copy", Tool::Copy),
    ("cut", Tool::Cut),
    ("paste", Tool::Paste),
];

/// Seconds an airbrush or emitter stroke of `--stroke` runs per point.
const SCRIPT_TICK: f64 = 0.05;

/// Parses `TOOL:X,Y[:X,Y…]`.
pub fn parse_stroke(s: &str) -> Result<ScriptedStroke, String> {
    let mut parts = s.split(':');
    let name = parts.next().unwrap_or_default().trim();
    let tool = SCRIPT_NAMES
        .iter()
        .find(|n| n.0 == name)
        .map(|n| n.1)
        .ok_or_else(|| {
            let known: Vec<&str> = SCRIPT_NAMES.iter().map(|n| n.0).collect();
            format!("unknown tool '{name}' (known: {})", known.join(", "))
        })?;
    let points = parts
        .map(|p| {
            let xy = p.split_once(',').and_then(|(x, y)| {
                let (x, y) = (x.trim().parse::<f64>().ok()?, y.trim().parse::<f64>().ok()?);
                (x.is_finite() && y.is_finite()).then_some((x, y))
            });
            xy.ok_or_else(|| format!("'{p}' is not a picture point X,Y"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if points.is_empty() {
        return Err(format!("'{s}' has no points: give TOOL:X,Y[:X,Y…]"));
    }
    Ok(ScriptedStroke { tool, points })
}

/// The tools' settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ToolKnobs {
    pub paint: PaintParams,
    /// Paint spacing as a multiple of the radius (the paper's default 0.75).
    pub spacing: f64,
    /// Paintbrush and emitter: on the surface under the cursor, else on the plane
    /// `z = plane_z`.
    pub on_surface: bool,
    pub plane_z: f64,
    pub air: AirParams,
    pub erase: EraseParams,
    pub emit: EmitParams,
}

impl ToolKnobs {
    /// Settings scaled to a scene whose Gaussians have the typical radius `r`.
    pub fn scaled(r: f64) -> ToolKnobs {
        ToolKnobs {
            paint: PaintParams::new(r, 0.15),
            spacing: 0.75,
            on_surface: true,
            plane_z: 0.0,
            air: AirParams {
                rate: 60.0,
                speed: 20.0 * r,
                spread: 0.3,
                diffusion: 10.0 * r,
                start: 20.0 * r,
                radius: r,
                weight: 0.1,
                seed: 1,
            },
            erase: EraseParams {
                radius: 20.0,
                strength: 0.05,
            },
            emit: EmitParams {
                rate: 20.0,
                velocity: [0.0, 0.0, 10.0 * r],
                spread: 0.2,
                acceleration: [0.0; 3],
                lifetime: 1.5,
                radius: r,
                weight: 0.2,
                seed: 1,
            },
        }
    }

    fn target(&self) -> Target {
        if self.on_surface {
            Target::Surface
        } else {
            plane([0.0, 0.0, self.plane_z], [0.0, 0.0, 1.0]).expect("a finite horizontal plane")
        }
    }
}

/// A stroke under way.
#[derive(Debug)]
enum Stroke {
    Paint(Paintbrush),
    Air(Airbrush),
    Erase(Eraser),
    Emit(Emitter),
    Select { from: (f64, f64), cut: bool },
}

/// The edited medium and the tools.
#[derive(Debug)]
pub struct Editor {
    /// The medium as the scene file gives it (its Gaussians aside).
    template: Arc<GaussianMediumOf>,
    doc: Document,
    pub tool: Tool,
    pub knobs: ToolKnobs,
    stroke: Option<(Draft, Stroke)>,
    /// The cursor during a stroke, in picture pixels.
    cursor: (f64, f64),
    strokes: u64,
    clipboard: Clipboard,
    /// Counts changes of what [`Editor::gaussians`] gives (the picture is stale when it
    /// moved).
    generation: u64,
    /// Where "save" writes and "load" reads.
    pub path: String,
    /// The scene file the editor started from.
    source: PathBuf,
    /// What the last save or load said.
    pub message: Option<String>,
}

impl Editor {
    /// The editor of the scene's first Gaussian medium (`None` when it has none), saving
    /// to `SCENE.edited.json` beside `source`, the scene's file.
    pub fn new(scene: &Scene, source: &Path) -> Option<Editor> {
        let m = scene.gaussian_media().next()?;
        let gs = m.medium.gaussians();
        let r = if gs.is_empty() {
            0.1
        } else {
            gs.iter().map(|g| g.radius).sum::<f64>() / gs.len() as f64
        };
        let template = GaussianMediumOf {
            medium: GaussianMedium::new(
                m.medium.sigma_t,
                m.medium.albedo,
                m.medium.background,
                Vec::new(),
            )
            .ok()?,
            noise: m.noise.clone(),
        };
        let stem = source
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy());
        Some(Editor {
            template: Arc::new(template),
            doc: Document::new(gs.to_vec()),
            tool: Tool::Orbit,
            knobs: ToolKnobs::scaled(r),
            stroke: None,
            cursor: (0.0, 0.0),
            strokes: 0,
            clipboard: Clipboard::default(),
            generation: 0,
            path: source
                .with_file_name(format!("{stem}.edited.json"))
                .display()
                .to_string(),
            source: source.to_path_buf(),
            message: None,
        })
    }

    /// The Gaussians to show: the document's, as the stroke under way leaves them.
    pub fn gaussians(&self) -> Vec<Gaussian> {
        match &self.stroke {
            None => self.doc.gaussians().to_vec(),
            Some((draft, Stroke::Air(a))) => {
                let mut gs = draft.gaussians();
                gs.extend(a.gaussians());
                gs
            }
            Some((draft, Stroke::Emit(e))) => {
                let mut gs = draft.gaussians();
                gs.extend(e.gaussians());
                gs
            }
            Some((draft, _)) => draft.gaussians(),
        }
    }

    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// `scene` with its first Gaussian medium made of [`Editor::gaussians`].
    pub fn apply(&self, scene: &mut Scene) -> Result<(), String> {
        let t = &self.template.medium;
        let medium = GaussianMediumOf {
            medium: GaussianMedium::new(t.sigma_t, t.albedo, t.background, self.gaussians())?,
            noise: self.template.noise.clone(),
        };
        if let Some(slot) = scene.hetero.iter_mut().find(|m| m.is_gaussians()) {
            *slot = HeteroMedium::Gaussians(Arc::new(medium));
        }
        Ok(())
    }

    /// Whether a stroke that runs in time (airbrush, emitter) is under way.
    pub fn running(&self) -> bool {
        matches!(self.stroke, Some((_, Stroke::Air(_) | Stroke::Emit(_))))
    }

    /// The rectangle being dragged, in picture pixels.
    pub fn selection(&self) -> Option<Rect> {
        match &self.stroke {
            Some((_, Stroke::Select { from, .. })) => Some(Rect {
                a: *from,
                b: self.cursor,
            }),
            _ => None,
        }
    }

    /// The button goes down at picture point `(px, py)` seen by `cam`.
    pub fn press(&mut self, scene: &Scene, cam: &Camera, px: f64, py: f64) -> Result<(), String> {
        if self.stroke.is_some() {
            self.release(cam);
        }
        self.cursor = (px, py);
        let seed = |s: u64| s.wrapping_add(self.strokes);
        let k = &self.knobs;
        let mut draft = self.doc.draft();
        let stroke = match self.tool {
            Tool::Orbit => return Ok(()),
            Tool::Paint => {
                let p = PaintParams {
                    spacing: k.spacing * k.paint.radius,
                    seed: seed(k.paint.seed),
                    ..k.paint
                };
                let mut b = Paintbrush::new(p, k.target())?;
                b.stroke_to(scene, cam, px, py, &mut draft);
                Stroke::Paint(b)
            }
            Tool::Airbrush => Stroke::Air(Airbrush::new(AirParams {
                seed: seed(k.air.seed),
                ..k.air
            })?),
            Tool::Erase => {
                let mut e = Eraser::new(k.erase)?;
                e.stroke_to(cam, px, py, &mut draft);
                Stroke::Erase(e)
            }
            Tool::Emit => {
                let Some((at, _)) = k.target().hit(scene, cam, px, py) else {
                    return Err("the emitter needs a point on the surface or plane".into());
                };
                let p = EmitParams {
                    seed: seed(k.emit.seed),
                    ..k.emit
                };
                Stroke::Emit(Emitter::new(p, at)?)
            }
            Tool::Copy | Tool::Cut => Stroke::Select {
                from: (px, py),
                cut: self.tool == Tool::Cut,
            },
            Tool::Paste => {
                if self.clipboard.is_empty() {
                    return Err("nothing to paste: copy or cut first".into());
                }
                self.clipboard.paste(&mut draft, cam, px, py);
                self.doc.commit(draft.into_edit());
                self.strokes += 1;
                self.generation += 1;
                return Ok(());
            }
        };
        self.stroke = Some((draft, stroke));
        self.generation += 1;
        Ok(())
    }

    /// The cursor moves to `(px, py)` with the button down.
    pub fn drag(&mut self, scene: &Scene, cam: &Camera, px: f64, py: f64) {
        self.cursor = (px, py);
        let target = self.knobs.target();
        match &mut self.stroke {
            Some((d, Stroke::Paint(b))) => b.stroke_to(scene, cam, px, py, d),
            Some((d, Stroke::Erase(e))) => e.stroke_to(cam, px, py, d),
            Some((_, Stroke::Emit(e))) => {
                if let Some((at, _)) = target.hit(scene, cam, px, py) {
                    e.move_to(at);
                }
            }
            Some(_) => {}
            None => return,
        }
        self.generation += 1;
    }

    /// `dt` seconds pass with the button down (airbrush, emitter).
    pub fn tick(&mut self, scene: &Scene, cam: &Camera, dt: f64) {
        let dt = dt.clamp(0.0, MAX_TICK);
        let (px, py) = self.cursor;
        match &mut self.stroke {
            Some((_, Stroke::Air(a))) => a.step(scene, cam.eye, cam.ray(px, py), dt),
            Some((_, Stroke::Emit(e))) => e.advance(dt),
            _ => return,
        }
        self.generation += 1;
    }

    /// The button comes up: the stroke becomes one edit.
    pub fn release(&mut self, cam: &Camera) {
        let Some((mut draft, stroke)) = self.stroke.take() else {
            return;
        };
        match stroke {
            Stroke::Paint(mut b) => b.finish(&mut draft),
            Stroke::Air(a) => a.finish(&mut draft),
            Stroke::Emit(e) => e.finish(&mut draft),
            Stroke::Erase(_) => {}
            Stroke::Select { from, cut } => {
                let rect = Rect {
                    a: from,
                    b: self.cursor,
                };
                self.clipboard = Clipboard::take(&mut draft, cam, rect, cut);
                self.message = Some(format!(
                    "{} {} Gaussians",
                    if cut { "cut" } else { "copied" },
                    self.clipboard.gaussians.len()
                ));
            }
        }
        self.doc.commit(draft.into_edit());
        self.strokes += 1;
        self.generation += 1;
    }

    /// Plays a scripted stroke with the tool it names and the current settings: the
    /// button pressed at its first point, dragged through the others (airbrush and
    /// emitter strokes running [`SCRIPT_TICK`] before each, and once more at the end),
    /// released.
    pub fn script(
        &mut self,
        scene: &Scene,
        cam: &Camera,
        s: &ScriptedStroke,
    ) -> Result<(), String> {
        self.tool = s.tool;
        let (x, y) = s.points[0];
        self.press(scene, cam, x, y)?;
        for &(x, y) in &s.points[1..] {
            self.tick(scene, cam, SCRIPT_TICK);
            self.drag(scene, cam, x, y);
        }
        self.tick(scene, cam, SCRIPT_TICK);
        self.release(cam);
        self.tool = Tool::Orbit;
        Ok(())
    }

    pub fn undo(&mut self) {
        if self.stroke.is_none() && self.doc.undo() {
            self.generation += 1;
        }
    }

    pub fn redo(&mut self) {
        if self.stroke.is_none() && self.doc.redo() {
            self.generation += 1;
        }
    }

    /// Saves the edited medium into a copy of the scene file at [`Editor::path`].
    pub fn save(&mut self) {
        let dest = PathBuf::from(&self.path);
        self.message = Some(
            match file::save(&self.source, &dest, 0, self.doc.gaussians()) {
                Ok(()) => format!(
                    "saved {} Gaussians to {}",
                    self.doc.gaussians().len(),
                    dest.display()
                ),
                Err(e) => e,
            },
        );
    }

    /// Replaces the Gaussians by those of the scene file at [`Editor::path`] (undoable).
    pub fn load(&mut self) {
        self.message = Some(match file::load(Path::new(&self.path), 0) {
            Ok(gs) => {
                let n = gs.len();
                if self.doc.replace_all(gs) {
                    self.generation += 1;
                }
                format!("loaded {n} Gaussians from {}", self.path)
            }
            Err(e) => e,
        });
    }

    /// The panel: the tool, its settings, undo/redo, save and load.
    pub fn panel(&mut self, ui: &mut egui::Ui) {
        ui.label(format!(
            "Gaussian medium: {} Gaussians",
            self.gaussians().len()
        ));
        egui::ComboBox::from_label("tool")
            .selected_text(
                Tool::ALL
                    .iter()
                    .find(|t| t.0 == self.tool)
                    .map_or("", |t| t.1),
            )
            .show_ui(ui, |ui| {
                for (t, name) in Tool::ALL {
                    ui.selectable_value(&mut self.tool, t, name);
                }
            });
        let k = &mut self.knobs;
        let size = |ui: &mut egui::Ui, v: &mut f64, name: &str| {
            ui.add(
                egui::Slider::new(v, 0.01..=2.0)
                    .logarithmic(true)
                    .text(name),
            );
        };
        let weight = |ui: &mut egui::Ui, v: &mut f64| {
            ui.add(egui::Slider::new(v, 0.0..=2.0).text("weight"));
        };
        let target = |ui: &mut egui::Ui, on_surface: &mut bool, z: &mut f64| {
            ui.checkbox(on_surface, "on the surface under the cursor");
            if !*on_surface {
                ui.add(egui::Slider::new(z, -5.0..=5.0).text("plane z"));
            }
        };
        match self.tool {
            Tool::Orbit => {
                ui.small("drag to orbit, scroll to zoom");
            }
            Tool::Paint => {
                size(ui, &mut k.paint.radius, "radius");
                weight(ui, &mut k.paint.weight);
                ui.add(egui::Slider::new(&mut k.spacing, 0.25..=3.0).text("spacing × radius"));
                ui.add(egui::Slider::new(&mut k.paint.jitter, 0.0..=1.0).text("jitter × radius"));
                ui.add(egui::Slider::new(&mut k.paint.lift, 0.0..=2.0).text("lift"));
                target(ui, &mut k.on_surface, &mut k.plane_z);
            }
            Tool::Airbrush => {
                ui.add(
                    egui::Slider::new(&mut k.air.rate, 1.0..=500.0)
                        .logarithmic(true)
                        .text("particles/s"),
                );
                size(ui, &mut k.air.speed, "speed");
                ui.add(egui::Slider::new(&mut k.air.spread, 0.0..=1.0).text("spread"));
                size(ui, &mut k.air.diffusion, "diffusion");
                ui.add(egui::Slider::new(&mut k.air.start, 0.0..=20.0).text("start distance"));
                size(ui, &mut k.air.radius, "radius");
                weight(ui, &mut k.air.weight);
            }
            Tool::Erase => {
                ui.add(egui::Slider::new(&mut k.erase.radius, 2.0..=200.0).text("radius (pixels)"));
                ui.add(
                    egui::Slider::new(&mut k.erase.strength, 0.005..=1.0)
                        .logarithmic(true)
                        .text("strength"),
                );
            }
            Tool::Emit => {
                ui.add(
                    egui::Slider::new(&mut k.emit.rate, 1.0..=200.0)
                        .logarithmic(true)
                        .text("particles/s"),
                );
                for (a, name) in ["vx", "vy", "vz"].iter().enumerate() {
                    ui.add(egui::Slider::new(&mut k.emit.velocity[a], -5.0..=5.0).text(*name));
                }
                ui.add(
                    egui::Slider::new(&mut k.emit.acceleration[2], -10.0..=10.0)
                        .text("acceleration z"),
                );
                ui.add(egui::Slider::new(&mut k.emit.spread, 0.0..=1.0).text("spread"));
                ui.add(
                    egui::Slider::new(&mut k.emit.lifetime, 0.1..=10.0)
                        .logarithmic(true)
                        .text("lifetime (s)"),
                );
                size(ui, &mut k.emit.radius, "radius");
                weight(ui, &mut k.emit.weight);
                target(ui, &mut k.on_surface, &mut k.plane_z);
            }
            Tool::Copy | Tool::Cut => {
                ui.small("drag a rectangle over the Gaussians");
            }
            Tool::Paste => {
                ui.small(format!(
                    "click to paste {} Gaussians",
                    self.clipboard.gaussians.len()
                ));
            }
        }
        let (undo, redo) = self.doc.depth();
        ui.horizontal(|ui| {
            if ui
                .add_enabled(undo > 0, egui::Button::new("undo"))
                .clicked()
            {
                self.undo();
            }
            if ui
                .add_enabled(redo > 0, egui::Button::new("redo"))
                .clicked()
            {
                self.redo();
            }
        });
        ui.horizontal(|ui| {
            ui.label("file");
            ui.text_edit_singleline(&mut self.path);
        });
        ui.horizontal(|ui| {
            if ui.button("save").clicked() {
                self.save();
            }
            if ui.button("load").clicked() {
                self.load();
            }
        });
        if let Some(m) = &self.message {
            ui.small(m.as_str());
        }
        ui.small("editing: left drag = stroke, right drag = orbit; Ctrl+Z / Ctrl+Y, Ctrl+S");
    }

    /// The keys: Ctrl+Z undo, Ctrl+Y or Ctrl+Shift+Z redo, Ctrl+S save.
    pub fn keys(&mut self, ctx: &egui::Context) {
        use egui::{Key, Modifiers};
        // Ctrl+Shift+Z first: Ctrl+Z would match it too.
        let (redo2, undo, redo, save) = ctx.input_mut(|i| {
            (
                i.consume_key(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z),
                i.consume_key(Modifiers::COMMAND, Key::Z),
                i.consume_key(Modifiers::COMMAND, Key::Y),
                i.consume_key(Modifiers::COMMAND, Key::S),
            )
        });
        if redo || redo2 {
            self.redo();
        } else if undo {
            self.undo();
        }
        if save {
            self.save();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::orbit::Orbit;
    use crate::scene::{Renderer, SceneKnobs, look_target};
    use haze_scene::Light;
    use haze_scene::paper_b::{self, Prepared};
    use haze_scene::render::Image;

    fn scene_path() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes/gaussians.json")
    }

    /// Where the ray through pixel `(px, py)` meets the floor `z = 0`.
    fn floor(cam: &Camera, px: f64, py: f64) -> [f64; 3] {
        let d = cam.ray(px, py);
        let t = -cam.eye[2] / d[2];
        [0, 1, 2].map(|a| cam.eye[a] + t * d[a])
    }

    /// Pixels of `a` off `b` by more than `rel` of `b` plus `1e-4` of `b`'s mean.
    fn differ(a: &Image, b: &Image, rel: f64) -> usize {
        let px = |i: &Image| {
            i.pixels
                .iter()
                .flatten()
                .map(|v| f64::from(*v))
                .collect::<Vec<_>>()
        };
        let (a, b) = (px(a), px(b));
        let mean = b.iter().sum::<f64>() / b.len() as f64;
        a.iter()
            .zip(&b)
            .filter(|(x, y)| (*x - *y).abs() > rel * y.abs() + 1e-4 * mean)
            .count()
    }

    /// `--stroke` values: every tool's name, points in pixels, written back as given;
    /// bad ones say why.
    #[test]
    fn scripted_strokes_parse_and_print_back() {
        for (name, tool) in SCRIPT_NAMES {
            let text = format!("{name}:1.5,2:30,-4");
            let s = parse_stroke(&text).unwrap();
            assert_eq!(s.tool, tool);
            assert_eq!(s.points, vec![(1.5, 2.0), (30.0, -4.0)]);
            assert_eq!(s.to_string(), text);
        }
        for (bad, why) in [
            ("brush:1,2", "unknown tool 'brush'"),
            ("paint", "has no points"),
            ("paint:1,2:3", "'3' is not a picture point"),
            ("erase:1,nan", "'1,nan' is not a picture point"),
        ] {
            let e = parse_stroke(bad).unwrap_err();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }

    /// The viewer's editing path on the bundled Gaussian scene: one scripted
    /// paintbrush stroke across the floor (press, ten moves, release through the hooks
    /// the window calls) adds the Gaussians the stroke implies — one every 0.75 radius of
    /// the floor segment under the cursor, on it — the next picture is paper B's render
    /// of the edited medium (where it renders, against the CPU renderer with the same
    /// options: 10⁻³ relative but for 1 % of the pixels) and differs from the picture before; a light moved re-lights the edit; undo
    /// gives back the first Gaussians and the first picture, bit for bit.
    #[test]
    fn a_paint_stroke_is_shown_relit_and_undone() {
        let base = haze_scene::load(&scene_path()).unwrap();
        let fov = 2.0 * base.camera.tan_half().atan().to_degrees();
        let orbit = Orbit::looking(base.camera.eye, look_target(&base), fov).unwrap();
        let mut knobs = SceneKnobs::of(&base, 1.0);
        let mut editor = Editor::new(&base, &scene_path()).unwrap();
        let first = editor.gaussians();
        let r = Renderer::new(base, (64, 48)).unwrap();
        let before = r.image(&orbit, &knobs, Some(&editor), None).unwrap().0;

        editor.tool = Tool::Paint;
        editor.knobs.paint = PaintParams {
            radius: 0.2,
            weight: 0.5,
            jitter: 0.0,
            ..editor.knobs.paint
        };
        let cam = orbit.camera(64, 48).unwrap();
        editor.press(&r.base, &cam, 10.0, 40.0).unwrap();
        for k in 1..=10 {
            editor.drag(&r.base, &cam, 10.0 + 4.0 * k as f64, 40.0);
        }
        editor.release(&cam);
        let (a, b) = (floor(&cam, 10.0, 40.0), floor(&cam, 50.0, 40.0));
        let len = (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt();
        let spacing = 0.75 * 0.2;
        let now = editor.gaussians();
        let added = &now[first.len()..];
        assert_eq!(&now[..first.len()], first.as_slice());
        assert_eq!(added.len(), (len / spacing).floor() as usize + 1, "{len}");
        for (k, g) in added.iter().enumerate() {
            let f = k as f64 * spacing / len;
            for c in 0..3 {
                assert!(
                    (g.center[c] - (a[c] + f * (b[c] - a[c]))).abs() < 1e-9,
                    "{k}"
                );
            }
        }

        let after = r.image(&orbit, &knobs, Some(&editor), None).unwrap().0;
        let cpu = |knobs: &SceneKnobs, editor: &Editor| {
            let scene = r.scene(&orbit, knobs, Some(editor)).unwrap();
            let prep = Prepared::new(&scene, &r.analytic, r.paper_b_options()).unwrap();
            paper_b::render(
                &prep,
                &haze_scene::paper_c::airlight::Limits::default(),
                &|_| {},
            )
        };
        let n = after.pixels.len();
        assert!(differ(&after, &cpu(&knobs, &editor), 1e-3) <= n / 100);
        let changed = differ(&after, &before, 0.02);
        assert!(changed > n / 50, "{changed} pixels changed");

        let Light::Point { position, .. } = &r.base.lights[0] else {
            panic!("the scene's first light is a point")
        };
        knobs.lights[0].position = [position[0] + 1.0, position[1], position[2] - 1.5];
        let moved = r.image(&orbit, &knobs, Some(&editor), None).unwrap().0;
        assert!(differ(&moved, &cpu(&knobs, &editor), 1e-3) <= n / 100);
        assert!(differ(&moved, &after, 0.02) > n / 50);
        knobs.lights[0].position = *position;

        editor.undo();
        assert_eq!(editor.gaussians(), first);
        let undone = r.image(&orbit, &knobs, Some(&editor), None).unwrap().0;
        assert_eq!(undone.pixels, before.pixels);
        editor.redo();
        assert_eq!(editor.gaussians(), now);
    }
}
