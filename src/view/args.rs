//! `haze view`'s flags, converted into `haze_viewer`'s options.

use crate::camera_medium_args::MediumArgs;
use crate::fog::{FogModelArgs, SmokeArgs};
use crate::light_args::{LightArgs, LightingArg};
use anyhow::Result;
use haze_render::smoke::Supersample;
use haze_tradeoff::pareto::Goal;
use haze_view::render::MsDiffusion;
use haze_viewer::smoke::{Knobs, ViewArgs};
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct ViewCli {
    /// A baked .haze asset (`haze bake` makes one).
    #[arg(required_unless_present_any = ["scene", "fog"], conflicts_with_all = ["scene", "fog"])]
    pub(crate) input: Option<PathBuf>,
    /// Show a scene file (docs/formats.md "Scene file") instead: paper C's renderer on the GPU, the
    /// orbit camera starting at the scene's, fog and lights in the panel, the surfaces
    /// rasterized with a depth buffer. Gaussian media are rendered by paper B (surfaces
    /// ray-traced) and edited with the panel's tools (paper B §6): paintbrush, airbrush,
    /// eraser, particle emitter, copy/cut/paste of a dragged rectangle; left drag = stroke,
    /// right drag = orbit, Ctrl+Z / Ctrl+Y undo and redo, Ctrl+S saves the edited medium
    /// into SCENE.edited.json (the panel's file; "load" reads one back). Beside an adapter
    /// that is a CPU (Mesa's lavapipe) every picture is the CPU renderer's, several times
    /// faster there, surfaces ray-traced. Of the options below only --size, --exposure,
    /// --play-for, --no-window and --ray-traced apply.
    #[arg(long, value_name = "SCENE.json", conflicts_with = "fog")]
    pub(crate) scene: Option<PathBuf>,
    /// Fly through a fogmap's wavelet fog instead (as `haze fog wavelet` renders it), on
    /// the GPU: WASD and Q/E fly, dragging looks around; basis, levels, µ, density,
    /// falloff and wind in the panel. FOGMAP may be a directory of numbered fogmaps, shown
    /// at --fps. The "Fog" options below apply, and --fps, --size, --exposure, --play-for
    /// and --no-window.
    #[arg(long, value_name = "FOGMAP")]
    pub(crate) fog: Option<PathBuf>,
    /// Playback rate in frames per second, at most 1000; 0 plays every frame as fast as it
    /// renders.
    #[arg(long, default_value_t = 24.0)]
    pub(crate) fps: f64,
    /// Render resolution (the picture is scaled to the window; larger costs more, in the
    /// view pass mostly).
    #[arg(long, value_name = "WxH", default_value = "400x300", value_parser = crate::size_arg::parse_size)]
    pub(crate) size: (usize, usize),
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    pub(crate) fov: f64,
    #[command(flatten)]
    pub(crate) lights: LightArgs,
    #[command(flatten)]
    pub(crate) medium: MediumArgs,
    /// Spherical-harmonic order (bands), 1..6.
    #[arg(long, default_value_t = 4)]
    pub(crate) sh_order: usize,
    /// View-pass slices per voxel (2: half a voxel apart, as in the paper).
    #[arg(long, default_value_t = 2.0)]
    pub(crate) slices: f64,
    /// Start with single scattering only.
    #[arg(long)]
    pub(crate) no_multiple: bool,
    /// Start without the residual (the RBF approximation alone).
    #[arg(long)]
    pub(crate) no_residual: bool,
    /// Start with the sky's single scattering at the RBF centers (paper A, `haze render
    /// --source footprint`) instead of per voxel by the environment pass: about half the
    /// frame time on lavapipe, 9–11 % darker single scattering on sky-lit smoke
    /// (BENCHMARKS.md, "Environment pass"); a panel switch too.
    #[arg(long)]
    pub(crate) sky_at_centers: bool,
    /// Multiple scattering by paper A's diffusion at the RBF centers (`haze render
    /// --diffusion centers`) instead of the explicit orders on a grid of 2³-voxel cells
    /// (`orders`, the default, which takes the sky per voxel): less than half the frame
    /// time of a new frame on lavapipe, a larger error (BENCHMARKS.md, "Multiple
    /// scattering: explicit orders"); a panel switch too. A setting chosen for a budget
    /// or a target error brings its own model (the sweep's `diffusion` knob).
    #[arg(long)]
    pub(crate) ms_at_centers: bool,
    /// The explicit orders' model an asset's stored choice names (not a flag).
    #[arg(skip)]
    pub(crate) orders_model: Option<MsDiffusion>,
    /// Start with the knobs (SH order, slices, multiple scattering, residual, render
    /// size) of the most accurate setting of a tradeoff sweep's front that renders within
    /// T milliseconds; prints the choice and why.
    #[arg(long, value_name = "T", group = "goal", conflicts_with_all = ["scene", "fog"])]
    pub(crate) budget_ms: Option<f64>,
    /// Start with the fastest front setting whose error against the sweep's best is at
    /// most E (rel RMS, 0.02 = 2 %), the models the scene does not need turned off.
    #[arg(long, value_name = "E", group = "goal", conflicts_with_all = ["scene", "fog"])]
    pub(crate) target_error: Option<f64>,
    /// The sweep for --budget-ms/--target-error (`haze tradeoff`'s tradeoff.json; its
    /// view-pass times are rescaled to --size); without it a quick sweep of the asset is
    /// measured first, at --size on the viewer's GPU renderer.
    #[arg(long, value_name = "FILE", requires = "goal")]
    pub(crate) tradeoff: Option<PathBuf>,
    /// Exposure applied before the tone curve and the sRGB encoding.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) exposure: f64,
    /// With an asset: the picture's tone curve, `filmic` (ACES-like: a toe, highlights
    /// rolled off) or `clip` (linear values clipped at 1/exposure); the panel switches it.
    #[arg(long, value_name = "filmic|clip", default_value = "filmic", value_parser = crate::render::args::parse_tone)]
    pub(crate) tone: haze_core::ToneMap,
    /// Play for SECONDS from the first picture, print one line of playback figures to
    /// stdout and exit.
    #[arg(long, value_name = "SECONDS")]
    pub(crate) play_for: Option<f64>,
    /// With --play-for: play without opening a window (the render thread and the clock
    /// alone, no display needed).
    #[arg(long, requires = "play_for")]
    pub(crate) no_window: bool,
    /// With --no-window and an asset: pause on the first frame and turn the camera a
    /// degree per picture instead of playing (what a camera drag costs); prints the
    /// pictures' median time.
    #[arg(long, requires = "no_window", conflicts_with_all = ["scene", "fog"])]
    pub(crate) orbit: bool,
    /// With --scene: start with the surfaces ray-traced per pixel instead of rasterized
    /// (the panel switches between the two; beside a CPU adapter they are always
    /// ray-traced).
    #[arg(long, requires = "scene")]
    pub(crate) ray_traced: bool,
    /// With --scene: a scripted stroke of the Gaussian editing tools, applied before the
    /// first picture with the scene's camera, at the render size: TOOL (paint, airbrush,
    /// erase, emit, copy, cut, paste) then the cursor's picture points `X,Y` (pixels,
    /// from the top left), e.g. `paint:10,40:50,40`; the panel's default settings;
    /// airbrush and emitter strokes run 0.05 s per point. Repeat for more strokes.
    #[arg(long, value_name = "TOOL:X,Y[:X,Y…]", requires = "scene", value_parser = haze_viewer::scene::edit_tools::parse_stroke)]
    pub(crate) stroke: Vec<haze_viewer::scene::edit_tools::ScriptedStroke>,
    /// With --scene: after the --stroke edits, save the edited Gaussian medium into a copy
    /// of the scene file at FILE (as the panel's "save").
    #[arg(long, value_name = "FILE", requires = "scene")]
    pub(crate) save_edits: Option<PathBuf>,
    /// Where the lighting at the RBF centers (single scattering and the diffusion of
    /// multiple scattering) is computed. `auto`: on the GPU, unless the adapter is a CPU
    /// (lavapipe), where the CPU's own code is several times faster; there the view pass
    /// runs on the CPU too, about twice as fast as its emulated shader.
    #[arg(long, value_enum, default_value_t = LightingArg::Auto)]
    pub(crate) lighting: LightingArg,
    /// With an asset: light each frame on a grid N times finer than its voxels (1..4), or
    /// `auto`: fine enough that a voxel is at most one optical depth thick (σt × density ×
    /// voxel side, at the 99th percentile of the frame's density; it follows the σt
    /// slider), within the GPU's largest grid. Each voxel is lit at its center, so thicker
    /// voxels come out too dark; time grows as N³. The panel and the --play-for line say
    /// which grid, and warn when its voxels stay too thick.
    #[arg(long, value_name = "auto|N", default_value = "auto", value_parser = parse_supersample, conflicts_with_all = ["scene", "fog"])]
    pub(crate) supersample: Supersample,
    /// With an asset: a ground under the smoke, as `haze render --ground` (`auto`: under
    /// the built-in sky); the panel switches it.
    #[arg(long, value_name = "auto|on|off", default_value = "auto", value_parser = crate::render::args::parse_ground, conflicts_with_all = ["scene", "fog"])]
    pub(crate) ground: haze_render::lights::GroundChoice,
    #[command(flatten, next_help_heading = "Fog (with --fog)")]
    pub(crate) fog_model: FogModelArgs,
    #[command(flatten, next_help_heading = "Smoke in the fog (with --fog)")]
    pub(crate) fog_smoke: SmokeArgs,
}

impl ViewCli {
    /// The flags given (values other than clap's defaults) that the mode chosen would
    /// ignore: a scene file holds its own camera, lights and media, a fog has its own
    /// flags, and a smoke asset uses neither the fog's nor, at their defaults, the others.
    pub(crate) fn unused_flags(&self) -> Vec<&'static str> {
        use crate::unused_flags::{defaults, differs, given};
        let Some(d) = defaults::<ViewCli>(&["view", "--scene", "s.json"]) else {
            return Vec::new();
        };
        let own = [
            ("--fov", differs(&self.fov, &d.fov)),
            ("--sh-order", differs(&self.sh_order, &d.sh_order)),
            ("--slices", differs(&self.slices, &d.slices)),
            ("--no-multiple", self.no_multiple),
            ("--no-residual", self.no_residual),
            ("--sky-at-centers", self.sky_at_centers),
            ("--ms-at-centers", self.ms_at_centers),
            ("--tone", differs(&self.tone, &d.tone)),
            ("--lighting", differs(&self.lighting, &d.lighting)),
        ];
        let smoke = [
            &self.lights.given(&d.lights)[..],
            &self.medium.given(&d.medium),
            &own,
        ]
        .concat();
        let fog = self.fog_model.given(&d.fog_model);
        let fps = [("--fps", differs(&self.fps, &d.fps))];
        if self.scene.is_some() {
            given(&[&smoke[..], &fog[..], &fps[..]].concat())
        } else if self.fog.is_some() {
            given(&smoke)
        } else {
            given(&fog)
        }
    }

    /// The knobs an asset's header chose for the viewer (`haze bake --view-budget-ms`),
    /// applied where the command line left the default.
    pub(crate) fn apply_stored_choice(&mut self) {
        let Some(input) = &self.input else { return };
        let Some((knobs, why)) = haze_tradeoff::choice::stored_view_knobs(input) else {
            return;
        };
        let d = haze_view::render::CrmOptions::default();
        let mut used = Vec::new();
        if let Some(v) = knobs.get("sh_order").and_then(|v| v.as_u64())
            && self.sh_order == d.order
            && v as usize != d.order
        {
            self.sh_order = v as usize;
            used.push(format!("SH order {v}"));
        }
        if let Some(v) = knobs.get("slices").and_then(|v| v.as_f64())
            && self.slices == d.slices_per_voxel
            && v != d.slices_per_voxel
        {
            self.slices = v;
            used.push(format!("{v} slices per voxel"));
        }
        if knobs.get("multiple").and_then(|v| v.as_bool()) == Some(false) && !self.no_multiple {
            self.no_multiple = true;
            used.push("no multiple scattering".to_string());
        }
        if knobs.get("residual").and_then(|v| v.as_bool()) == Some(false) && !self.no_residual {
            self.no_residual = true;
            used.push("no residual".to_string());
        }
        // The multiple-scattering model (with multiple scattering on), unless the command
        // line asked for the centers'.
        let multiple = knobs.get("multiple").and_then(|v| v.as_bool()) != Some(false);
        let model = knobs
            .get("diffusion")
            .filter(|_| multiple)
            .and_then(|v| v.as_str())
            .and_then(|v| v.parse::<MsDiffusion>().ok());
        match model {
            Some(MsDiffusion::Centers) if !self.ms_at_centers => {
                self.ms_at_centers = true;
                used.push("multiple scattering by the centers' diffusion".to_string());
            }
            Some(m @ MsDiffusion::Orders { .. })
                if !self.ms_at_centers && m != MsDiffusion::DEFAULT =>
            {
                self.orders_model = Some(m);
                used.push(format!(
                    "multiple scattering by {}",
                    haze_render::smoke::diffusion_name(m)
                ));
            }
            _ => {}
        }
        if !used.is_empty() {
            haze_render::say!(
                "{}: starting with the asset's choice ({}): {why}",
                input.display(),
                used.join(", ")
            );
        }
    }

    pub(crate) fn into_args(mut self) -> ViewArgs {
        let goal = match (self.budget_ms, self.target_error) {
            (Some(t), _) => Some(Goal::BudgetMs(t)),
            (None, Some(e)) => Some(Goal::TargetError(e)),
            (None, None) => None,
        };
        // A goal on the command line replaces the choice stored in the asset.
        if goal.is_none() {
            self.apply_stored_choice();
        }
        ViewArgs {
            // clap requires the input without --scene.
            input: self.input.unwrap_or_default(),
            fps: self.fps,
            width: self.size.0,
            height: self.size.1,
            fov: self.fov,
            env: self.lights.into(),
            knobs: Knobs {
                sigma_t: self.medium.sigma_t,
                albedo: self.medium.albedo,
                g: self.medium.g,
                sh_order: self.sh_order,
                slices: self.slices,
                multiple: !self.no_multiple,
                residual: !self.no_residual,
                sky_per_voxel: !self.sky_at_centers,
                orders: !self.ms_at_centers,
                orders_model: self.orders_model.unwrap_or(MsDiffusion::DEFAULT),
                exposure: self.exposure,
                tone: self.tone,
                ground: None,
            },
            play_for: self.play_for,
            window: !self.no_window,
            orbit: self.orbit,
            lighting: self.lighting.into(),
            supersample: self.supersample,
            ground: self.ground,
            goal,
            tradeoff: self.tradeoff,
        }
    }
}

/// `auto` or a whole number 1..4.
fn parse_supersample(s: &str) -> Result<Supersample, String> {
    s.parse()
}
