//! `haze render`'s flags, converted into `haze_render`'s options.

use crate::camera_medium_args::{CameraArgs, MediumArgs};
use crate::import_args::ImportArgs;
use crate::light_args::{LightArgs, LightingArg};
use anyhow::Result;
use haze_render::smoke::{RenderOptions, Supersample};
use haze_tradeoff::pareto::Goal;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct RenderCli {
    /// A .haze asset, or a volume file / directory of frames.
    // Not `conflicts_with = "scene"`: clap then waives every `requires = "scene"` when
    // INPUT is given, so the scene-only flags would pass unseen; `run` refuses the pair.
    #[arg(required_unless_present = "scene")]
    pub(crate) input: Option<PathBuf>,
    /// Render a scene file (JSON: camera, environment, lights, media, surfaces) instead.
    #[arg(long, value_name = "SCENE.json")]
    pub(crate) scene: Option<PathBuf>,
    /// Source frame number (default: the first).
    #[arg(long)]
    pub(crate) frame: Option<i64>,
    /// Output image: IMG.exr (linear radiance) or IMG.png (exposure, sRGB).
    #[arg(long, short)]
    pub(crate) out: PathBuf,
    /// Image width [default: 400, or the scene camera's].
    #[arg(long, conflicts_with = "size", value_parser = crate::size_arg::parse_side)]
    width: Option<usize>,
    /// Image height [default: 300, or the scene camera's].
    #[arg(long, conflicts_with = "size", value_parser = crate::size_arg::parse_side)]
    height: Option<usize>,
    /// Image size WxH, as `haze view` takes it (instead of --width and --height).
    #[arg(long, value_name = "WxH", value_parser = crate::size_arg::parse_size)]
    size: Option<(usize, usize)>,
    #[command(flatten)]
    pub(crate) camera: CameraArgs,
    #[command(flatten)]
    pub(crate) lights: LightArgs,
    #[command(flatten)]
    pub(crate) medium: MediumArgs,
    /// Spherical-harmonic order (bands), 1..6.
    #[arg(long, default_value_t = 4)]
    pub(crate) sh_order: usize,
    /// Single scattering only.
    #[arg(long)]
    pub(crate) no_multiple: bool,
    /// Ignore the residual (render the RBF approximation alone).
    #[arg(long)]
    pub(crate) no_residual: bool,
    /// View-pass slices per voxel (2: half a voxel apart, as in the paper).
    #[arg(long, default_value_t = 2.0)]
    pub(crate) slices: f64,
    /// In the CPU's view pass (the default; not with --gpu or --reference), take the
    /// pixels between the even rows and columns as the mean of their neighbours where the
    /// picture's second differences bound that within this share of it, 0 to 0.1 (the
    /// viewer's 0.002 while playing; 0: march every pixel). Faster where the smoke spans
    /// several pixels a voxel; `-v` counts the pixels reused.
    #[arg(long, default_value_t = 0.0)]
    pub(crate) pixel_reuse: f64,
    /// SH exponentiation of the transmittance: scaling and squaring (accurate for thick
    /// smoke) or the paper's optimal linear approximation (faster, thin smoke only).
    #[arg(long, value_enum, default_value_t = ExpArg::Square)]
    pub(crate) exp: ExpArg,
    /// Where the environment's single scattering comes from: a coarse grid of the
    /// transmitted environment's SH marched through the smoke, added per voxel (grid);
    /// or paper A's source at the RBF centers, their transmittance averaged over each
    /// footprint (footprint) or taken at the center (center). The diffusion starts from
    /// the centers' single scattering either way (footprint for grid).
    #[arg(long, value_enum, default_value_t = SourceArg::Grid)]
    pub(crate) source: SourceArg,
    /// How multiple scattering is computed: `orders[:F[:K]]` (the default: the first K
    /// scattering orders gathered explicitly along 72 directions (128 to 288 for g above
    /// 0.74, whose forward peak is narrower), 32 after the first, on
    /// the density averaged over F³ voxels, and the rest by diffusion on that grid; K = 6;
    /// F = auto unless given: on the CPU 2 (1 where the voxels are over a third of an
    /// optical depth thick), or where the cells with smoke times the side of the box
    /// they fill exceed 600 000, the smallest larger F within it, which keeps a frame's
    /// multiple scattering to about 10 s on two cores; with --gpu 1 where the CPU takes
    /// 1 and the device holds that many cells, else 2 (larger, with a warning, where the
    /// device's buffers cannot hold cells of 2); at most 8 there, and lit by the
    /// sky per voxel, so --source grid), `centers` (paper A §5.4's
    /// diffusion on the RBF basis; the default with --gpu and --source footprint or
    /// center) or `grid[:F]` (the diffusion alone on the F³ grid, CPU only, refused with
    /// --gpu). BENCHMARKS.md "Multiple scattering: explicit orders" compares them.
    #[arg(long, value_parser = parse_diffusion)]
    pub(crate) diffusion: Option<haze_view::render::MsDiffusion>,
    /// Voxels between the nodes of `--source grid`'s grid, at least 0.25 (smaller: sharper
    /// self-shadowing, more time and memory; both grow as the inverse cube). A grid of
    /// more than 16 M nodes is widened to fit, with a warning. Default: 1.5, or 1 (the
    /// nodes on the voxel centers) where a cell of 1.5 voxels would be more than half an
    /// optical depth across (σt × density × side, at the 99th percentile of the density):
    /// there the wider grid leaves thick smoke's sky light a few percent bright.
    #[arg(long, value_parser = grid_spacing, value_name = "VOXELS")]
    pub(crate) env_grid_spacing: Option<f64>,
    /// The lighting's detail, above 0 and at most 1: below 1 the environment grid's
    /// spacing is divided by it, the explicit orders' automatic cells grow as 1/detail
    /// and their count falls to ⌈K·detail⌉ (at least 4), the suns' shadows are swept over the voxel planes instead of marched (on a lattice 1.5 voxels apart at 2/3 and below) and at 2/3
    /// and below the sky and the first scattering order take fewer directions (32, the first order more where the phase function's peak is narrow), so a new frame's lighting costs about detail³ as much (BENCHMARKS.md
    /// "Viewer playback: the lighting's detail" measures the error). Below the smoke's
    /// floor (environment-grid cells over half an optical depth across) the render warns
    /// and names the lowest detail to use; the viewer lowers it while playback cannot
    /// keep up, never below that floor.
    #[arg(long, default_value_t = 1.0, value_name = "D")]
    pub(crate) lighting_detail: f64,
    /// Render with the reference path tracer instead (slow).
    #[arg(long, conflicts_with = "gpu")]
    pub(crate) reference: bool,
    /// Compensated ray marching entirely on the CPU (the default).
    #[arg(long, conflicts_with_all = ["gpu", "reference"])]
    pub(crate) cpu: bool,
    /// Render on the GPU: single scattering, multiple scattering (the explicit orders or
    /// the centers' diffusion, --diffusion), the volume and view passes (in f32); with --scene, paper C's airlight and surface
    /// shading. Needs a GPU adapter; Mesa's lavapipe (mesa-vulkan-drivers) works without
    /// a GPU, but its loop limit refuses scenes of many lights and surfaces (at most 158
    /// surfaces with 100 lights, a mesh counting 32) and paper B scenes of many Gaussians
    /// and lights (at most 24 000 Gaussians with one light, 8 500 with four, fewer under a
    /// sky).
    #[arg(long)]
    pub(crate) gpu: bool,
    /// With --gpu: where the lighting at the RBF centers (single scattering and the
    /// diffusion of multiple scattering) is computed. `auto`: on the GPU, unless the
    /// adapter is a CPU (lavapipe), where the CPU's own code is several times faster.
    #[arg(long, value_enum, default_value_t = LightingArg::Auto, requires = "gpu")]
    pub(crate) lighting: LightingArg,
    /// Samples per pixel of --reference.
    #[arg(long, default_value_t = 64)]
    pub(crate) spp: u32,
    /// Choose the knobs automatically: the most accurate setting of a tradeoff sweep's
    /// Pareto front that renders within T milliseconds (the sweep's machine and size).
    /// The choice sets the knobs the sweep turned, the multiple-scattering model
    /// (--diffusion) among them; a sweep written before its `diffusion` knob timed
    /// `centers`, which it then uses.
    #[arg(long, value_name = "T", conflicts_with_all = ["target_error", "reference", "gpu"])]
    pub(crate) budget_ms: Option<f64>,
    /// Choose the knobs automatically: the fastest setting of the front whose error
    /// against the sweep's best setting is at most E (rel RMS, 0.02 = 2 %); the knobs are
    /// set as with --budget-ms.
    #[arg(long, value_name = "E", conflicts_with_all = ["reference", "gpu"])]
    pub(crate) target_error: Option<f64>,
    /// The sweep for --budget-ms/--target-error (`haze tradeoff`'s tradeoff.json); without
    /// it a quick sweep of INPUT is run first, at this render's size.
    #[arg(long, value_name = "FILE")]
    pub(crate) tradeoff: Option<PathBuf>,
    /// Estimate this render's error: compare N of its smoke pixels with the reference
    /// renderer (128 samples each, lit by the environment as given: a map whole) and print
    /// "estimated error x %" (its noise discounted) in the summary line; with
    /// --target-error, warn when the estimate exceeds it. 256 pixels take a second or two.
    /// Default: none, but 256 with --target-error (--check 0 skips it).
    #[arg(long, value_name = "N", conflicts_with = "reference")]
    pub(crate) check: Option<usize>,
    /// Exposure applied before PNG tone mapping.
    #[arg(long, default_value_t = 1.0)]
    pub(crate) exposure: f64,
    /// The tone curve of a PNG: `filmic` (ACES-like: a toe, and highlights rolled off to
    /// white at 7.24× the exposure's white instead of clipped) or `clip` (linear values
    /// clipped at 1/exposure, to read pixel values back). EXR stays linear.
    #[arg(long, value_name = "filmic|clip", default_value = "filmic", value_parser = parse_tone)]
    pub(crate) tone: haze_core::ToneMap,
    /// With --scene: the time in seconds at which the analytic fog is rendered (its wind
    /// has carried it for this long).
    #[arg(
        long,
        default_value_t = 0.0,
        requires = "scene",
        allow_hyphen_values = true
    )]
    pub(crate) time: f64,
    /// With --scene: single scattering of the scene's lights through every medium (the
    /// analytic fog included) by ray marching with exact transmittance, on the CPU (on
    /// the GPU with --gpu), instead of paper C's airlight and paper D's fog colour.
    #[arg(long, requires = "scene", conflicts_with = "reference")]
    pub(crate) march: bool,
    /// With --scene, Gaussian media (paper B): at most this many Gaussians whose shadows
    /// or hosting of a light paper B takes exactly along each integrated (light,
    /// Gaussian) pair (0-16; more is more exact and slower) [default: 16; 4 with --gpu
    /// on a CPU device such as lavapipe, whose shader loops are limited]
    #[arg(long, requires = "scene", value_parser = clap::value_parser!(u8).range(0..=16))]
    pub(crate) exact_per_pair: Option<u8>,
    /// With --scene, Gaussian media (paper B): integrate the (light, Gaussian) pairs
    /// exactly on a grid every N pixels and take each pair's ratio to its unattenuated
    /// integral from that grid at the pixels between, where the grid shows it smooth (an
    /// estimated error of at most 0.5 % of the pixel), through grids of half the stride
    /// that integrate only where the coarser one was not smooth, on the CPU (the GPU
    /// integrates every pixel); the surfaces' exact shadow on the sky (--sky-shadow) on the same
    /// grid, CPU and GPU. 1 takes every pixel exactly (slower). `-v` says how often the
    /// grid served
    #[arg(long, requires = "scene", value_name = "N", default_value_t = 4,
          value_parser = clap::value_parser!(u8).range(1..=16))]
    pub(crate) pair_reuse: u8,
    /// With --scene, Gaussian media (paper B) under an environment: how the Gaussians
    /// shadow the sky's light on the surfaces
    #[arg(long, requires = "scene", value_enum, default_value_t = SkyShadowArg::Exact)]
    pub(crate) sky_shadow: SkyShadowArg,
    /// Light the smoke on a grid N times finer than the volume's voxels (1..4), or `auto`:
    /// fine enough that a voxel is at most one optical depth thick (σt × density × voxel
    /// side, at the 99th percentile of the density), within 16 M voxels. The fast renderer
    /// lights each voxel at its center, so thicker voxels come out too dark; time and
    /// memory grow as N³. A render whose voxels stay thicker says so.
    #[arg(long, value_name = "auto|N", default_value = "auto", value_parser = parse_supersample)]
    pub(crate) supersample: Supersample,
    /// A ground under the smoke: a grey diffuse plane at the floor of the volume's box,
    /// lit by the suns, point lights and sky, carrying the smoke's shadow (the sky's
    /// light on it is not shadowed). `auto`: under the built-in sky (`--env sky` or
    /// `glow`), not under a map, which has its own ground. Camera rays see it; it does
    /// not light the smoke. The reference renders the same ground.
    #[arg(long, value_name = "auto|on|off", default_value = "auto", value_parser = parse_ground)]
    pub(crate) ground: haze_render::lights::GroundChoice,
    #[command(flatten)]
    pub(crate) import: ImportArgs,
}

impl RenderCli {
    /// The flags of a smoke render given beside `--scene`, which would be ignored: a scene
    /// file holds its own camera, lights and media (`--cpu`, the scene's default too, is
    /// not counted).
    pub(crate) fn smoke_flags_given(&self) -> Vec<&'static str> {
        use crate::unused_flags::{defaults, differs, given};
        let Some(d) = defaults::<RenderCli>(&["render", "--scene", "s.json", "--out", "o.png"])
        else {
            return Vec::new();
        };
        let own = [
            ("--frame", differs(&self.frame, &d.frame)),
            ("--sh-order", differs(&self.sh_order, &d.sh_order)),
            ("--no-multiple", self.no_multiple),
            ("--no-residual", self.no_residual),
            ("--slices", differs(&self.slices, &d.slices)),
            ("--pixel-reuse", differs(&self.pixel_reuse, &d.pixel_reuse)),
            ("--exp", differs(&self.exp, &d.exp)),
            ("--source", differs(&self.source, &d.source)),
            ("--diffusion", self.diffusion.is_some()),
            ("--env-grid-spacing", self.env_grid_spacing.is_some()),
            (
                "--lighting-detail",
                differs(&self.lighting_detail, &d.lighting_detail),
            ),
            ("--lighting", differs(&self.lighting, &d.lighting)),
            ("--spp", differs(&self.spp, &d.spp)),
            ("--budget-ms", self.budget_ms.is_some()),
            ("--target-error", self.target_error.is_some()),
            ("--tradeoff", self.tradeoff.is_some()),
            ("--check", self.check.is_some()),
            ("--supersample", differs(&self.supersample, &d.supersample)),
            ("--ground", differs(&self.ground, &d.ground)),
        ];
        given(
            &[
                &self.camera.given(&d.camera)[..],
                &self.lights.given(&d.lights),
                &self.medium.given(&d.medium),
                &self.import.given(&d.import),
                &own,
            ]
            .concat(),
        )
    }

    /// The width asked for, by --width or --size.
    pub(crate) fn width(&self) -> Option<usize> {
        self.width.or(self.size.map(|s| s.0))
    }

    /// The height asked for, by --height or --size.
    pub(crate) fn height(&self) -> Option<usize> {
        self.height.or(self.size.map(|s| s.1))
    }

    /// The render's options, and the goal (with its sweep) its knobs are chosen for.
    pub(crate) fn into_args(self) -> (RenderOptions, Option<Goal>, Option<PathBuf>) {
        let goal = match (self.budget_ms, self.target_error) {
            (Some(t), _) => Some(Goal::BudgetMs(t)),
            (None, Some(e)) => Some(Goal::TargetError(e)),
            (None, None) => None,
        };
        let tradeoff = self.tradeoff.clone();
        let (width, height) = (self.width(), self.height());
        let options = RenderOptions {
            // clap requires the input without --scene.
            input: self.input.unwrap_or_default(),
            frame: self.frame,
            width: width.unwrap_or(400),
            height: height.unwrap_or(300),
            out: self.out,
            eye: self.camera.eye,
            target: self.camera.target,
            up: self.camera.up,
            fov: self.camera.fov,
            env: self.lights.into(),
            sigma_t: self.medium.sigma_t,
            albedo: self.medium.albedo,
            g: self.medium.g,
            sh_order: self.sh_order,
            multiple: !self.no_multiple,
            residual: !self.no_residual,
            slices: self.slices,
            pixel_reuse: self.pixel_reuse,
            exp: match self.exp {
                ExpArg::Square => haze_view::sh::ExpMethod::ScaleSquareAuto,
                ExpArg::Linear => haze_view::sh::ExpMethod::OptimalLinear,
            },
            source_points: match self.source {
                SourceArg::Footprint | SourceArg::Grid => {
                    haze_view::lighting::single::SourcePoints::Footprint
                }
                SourceArg::Center => haze_view::lighting::single::SourcePoints::Center,
            },
            env_source: match self.source {
                SourceArg::Grid => haze_view::render::env_pass::EnvSource::Grid(
                    haze_view::render::env_pass::EnvGridOptions {
                        spacing: self.env_grid_spacing.unwrap_or(
                            haze_view::render::env_pass::EnvGridOptions::default().spacing,
                        ),
                        // A spacing given stays; the default follows the smoke's thickness.
                        follow_smoke: self.env_grid_spacing.is_none(),
                        ..Default::default()
                    },
                ),
                SourceArg::Footprint | SourceArg::Center => {
                    haze_view::render::env_pass::EnvSource::Centers
                }
            },
            reference: self.reference,
            // The GPU's orders are lit by the environment pass's grid (`--source grid`);
            // a knob chosen for a budget brings its own diffusion (the sweep's knob).
            diffusion: self.diffusion.unwrap_or(
                if self.gpu && !matches!(self.source, SourceArg::Grid) {
                    haze_view::render::MsDiffusion::Centers
                } else {
                    haze_view::render::MsDiffusion::DEFAULT
                },
            ),
            solve: haze_view::diffusion::SolveOptions::default(),
            rbfs: 300,
            teleport: true,
            // `--cpu` is the default, spelled out; clap refuses it with `--gpu`.
            gpu: self.gpu && !self.cpu,
            lighting: self.lighting.into(),
            spp: self.spp,
            check: self.check.unwrap_or(if self.target_error.is_some() {
                TARGET_CHECK
            } else {
                0
            }),
            target_error: self.target_error,
            exposure: self.exposure,
            tone: self.tone,
            import: self.import.options(),
            supersample: self.supersample,
            ground: self.ground,
            detail: self.lighting_detail,
        };
        (options, goal, tradeoff)
    }
}

/// The pixels `--target-error` checks when `--check` is not given: a render asked to meet
/// an error says whether it did (a second or two, `--check`'s help).
const TARGET_CHECK: usize = 256;

/// `filmic` or `clip`.
pub(crate) fn parse_tone(s: &str) -> Result<haze_core::ToneMap, String> {
    s.parse()
}

/// `auto`, `on` or `off`.
pub(crate) fn parse_ground(s: &str) -> Result<haze_render::lights::GroundChoice, String> {
    s.parse()
}

/// `auto` or a whole number 1..4.
fn parse_supersample(s: &str) -> Result<Supersample, String> {
    s.parse()
}

/// `centers`, `grid[:F]` or `orders[:F[:K]]` (`MsDiffusion`'s syntax).
fn parse_diffusion(s: &str) -> Result<haze_view::render::MsDiffusion, String> {
    s.parse()
}

#[derive(Clone, Copy, Debug, PartialEq, clap::ValueEnum)]
pub(crate) enum SkyShadowArg {
    /// Over 72 directions through the Gaussians where the average depth could be more
    /// than 2 % off (on the --pair-reuse grid, interpolated on the same surface)
    Exact,
    /// Dimmed by the average optical depth around the point, as paper B does (faster; the
    /// floor under a dense cloud can be 5 % off)
    Mean,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub(crate) enum SourceArg {
    /// Per voxel, from a grid of the transmitted environment's SH.
    Grid,
    /// At the RBF centers, mean over six cubature points of each RBF's footprint.
    Footprint,
    /// At the RBF centers, each RBF's center only.
    Center,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub(crate) enum ExpArg {
    /// exp(f/2^k)^(2^k) with ‖f̂‖/2^k ≤ 1, by triple products.
    Square,
    /// a(‖f̂‖) + b(‖f̂‖)·f̂ (paper A §5.3).
    Linear,
}

/// `--env-grid-spacing`: a finite number of voxels, at least
/// [`env_pass::MIN_SPACING`](haze_view::render::env_pass::MIN_SPACING).
fn grid_spacing(s: &str) -> Result<f64, String> {
    use haze_view::render::env_pass::MIN_SPACING;
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v >= MIN_SPACING {
        Ok(v)
    } else {
        Err(format!(
            "{s} must be a number of voxels, at least {MIN_SPACING} (nodes closer than that hold no more detail)"
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use haze_view::render::MsDiffusion;

    /// `haze render`'s flags alone.
    #[derive(Parser)]
    struct Flags {
        #[command(flatten)]
        render: RenderCli,
    }

    /// The options of `haze render smoke.vdb --out out.png EXTRA…`.
    fn render_args(extra: &[&str]) -> RenderOptions {
        let argv = [&["render", "smoke.vdb", "--out", "out.png"][..], extra].concat();
        Flags::try_parse_from(argv).unwrap().render.into_args().0
    }

    /// `haze render` without flags renders as `RenderOptions::new` does (the Python
    /// package's `haze.render` defaults), knob for knob.
    #[test]
    fn the_command_lines_defaults_are_the_librarys() {
        let from_cli = render_args(&[]);
        let library = RenderOptions::new("smoke.vdb", "out.png");
        assert_eq!(format!("{from_cli:?}"), format!("{library:?}"));
    }

    /// A render asked for a target error checks itself unless told not to.
    #[test]
    fn a_target_error_checks_the_render() {
        assert_eq!(render_args(&[]).check, 0);
        assert_eq!(render_args(&["--check", "64"]).check, 64);
        assert_eq!(render_args(&["--target-error", "0.05"]).check, TARGET_CHECK);
        assert_eq!(
            render_args(&["--target-error", "0.05", "--check", "0"]).check,
            0
        );
        assert_eq!(
            render_args(&["--target-error", "0.05", "--check", "32"]).check,
            32
        );
    }

    /// The CPU and the GPU render with the gathered orders by default (the GPU's with the
    /// sky per voxel, `--source grid`, which lights them), and so does a render for a
    /// budget or a target error until the choice sets the sweep's `diffusion` knob
    /// (`haze_tradeoff::render_choice`); an explicit `--diffusion` is parsed as given.
    #[test]
    fn the_diffusion_follows_the_renderer_and_the_goal() {
        assert_eq!(render_args(&[]).diffusion, MsDiffusion::DEFAULT);
        assert_ne!(MsDiffusion::DEFAULT, MsDiffusion::Centers);
        assert_eq!(render_args(&["--gpu"]).diffusion, MsDiffusion::DEFAULT);
        assert_eq!(
            render_args(&["--gpu", "--source", "footprint"]).diffusion,
            MsDiffusion::Centers
        );
        assert_eq!(
            render_args(&["--source", "footprint"]).diffusion,
            MsDiffusion::DEFAULT
        );
        assert_eq!(
            render_args(&["--budget-ms", "500"]).diffusion,
            MsDiffusion::DEFAULT
        );
        assert_eq!(
            render_args(&["--target-error", "0.02"]).diffusion,
            MsDiffusion::DEFAULT
        );
        assert_eq!(
            render_args(&["--budget-ms", "500", "--diffusion", "centers"]).diffusion,
            MsDiffusion::Centers
        );
    }
}
