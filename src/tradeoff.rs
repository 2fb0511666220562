//! `haze tradeoff`'s flags, converted into `haze_tradeoff`'s options.

use crate::camera_medium_args::{CameraArgs, MediumArgs};
use crate::fog::FogModelArgs;
use crate::import_args::ImportArgs;
use crate::light_args::{LightArgs, LightingArg};
use anyhow::Result;
use haze_render::smoke::MAX_CHECK_PIXELS;
use haze_tradeoff::smoke::{Timing, View};
use haze_tradeoff::{SmokeInput, TradeoffArgs};
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
pub struct TradeoffCli {
    /// A volume file, a directory or glob of numbered frames, a .haze asset, or a fogmap.
    #[arg(required_unless_present = "extremes")]
    input: Option<PathBuf>,
    /// Source frame number (default: the first).
    #[arg(long)]
    frame: Option<i64>,
    /// Directory for tradeoff.json and the plots: made if missing (and removed again if the
    /// run fails), never the input's directory of frames.
    #[arg(long, short)]
    out: PathBuf,
    /// Also measure every setting against the reference renderer (path tracing at --spp;
    /// for a fogmap the exact integral of the map).
    #[arg(long)]
    reference: bool,
    /// Samples per pixel of --reference.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Smoke: every error of the sweep is against its best setting; estimate that
    /// setting's own error against the reference renderer on N of its smoke pixels (128
    /// samples each, `haze render --check`), printed and stored as best_estimated_error.
    /// 0: none; --reference measures every setting against the reference instead.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 256,
        conflicts_with = "reference"
    )]
    check: usize,
    /// Sweep only these knobs (comma-separated names, as tradeoff.json lists them); the
    /// others keep their defaults.
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    knobs: Option<Vec<String>>,
    /// Fewer values per knob and shorter chains (seconds instead of minutes).
    #[arg(long)]
    quick: bool,
    /// Treat INPUT as a fogmap (.png and .exr always are).
    #[arg(long)]
    fogmap: bool,
    /// Run the extreme cases instead (no INPUT).
    #[arg(long, conflicts_with_all = ["input", "reference", "knobs", "quick", "gpu"])]
    extremes: bool,
    /// Time the renders with every stage on the GPU (`haze render --gpu`, the viewer's
    /// renderer; each render a new frame) instead of on the CPU.
    #[arg(long)]
    gpu: bool,
    /// With --gpu: where the lighting at the RBF centers is computed (as `haze render`).
    #[arg(long, value_enum, default_value_t = LightingArg::Auto, requires = "gpu")]
    lighting: LightingArg,
    /// Full picture width (the size knob renders fractions of it).
    #[arg(long, default_value_t = 160)]
    width: usize,
    /// Full picture height.
    #[arg(long, default_value_t = 120)]
    height: usize,
    #[command(flatten)]
    camera: CameraArgs,
    #[command(flatten)]
    lights: LightArgs,
    #[command(flatten)]
    medium: MediumArgs,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten, next_help_heading = "Fog (fogmap input)")]
    fog_model: FogModelArgs,
}

impl TradeoffCli {
    /// The flags given (values other than clap's defaults) that the sweep would ignore:
    /// a fogmap's sweep renders the fog alone (no smoke camera, lights, medium or
    /// reference samples), a smoke sweep has no fog, and `--extremes` runs fixed cases.
    fn unused_flags(&self) -> Vec<&'static str> {
        use crate::unused_flags::{defaults, differs, given};
        let Some(d) = defaults::<TradeoffCli>(&["tradeoff", "x.vdb", "--out", "o"]) else {
            return Vec::new();
        };
        let own = [
            ("--spp", differs(&self.spp, &d.spp)),
            ("--check", differs(&self.check, &d.check)),
            ("--gpu", self.gpu),
        ];
        let smoke = [
            &self.camera.given(&d.camera)[..],
            &self.lights.given(&d.lights),
            &self.medium.given(&d.medium),
            &self.import.given(&d.import),
            &own,
        ]
        .concat();
        let fog = self.fog_model.given(&d.fog_model);
        if self.extremes {
            let size = [
                ("--width", differs(&self.width, &d.width)),
                ("--height", differs(&self.height, &d.height)),
            ];
            given(&[&smoke[..], &fog[..], &size[..]].concat())
        } else if self.is_fog() {
            given(&smoke)
        } else {
            given(&fog)
        }
    }

    /// Whether the input is a fogmap (its sweep renders the wavelet fog).
    fn is_fog(&self) -> bool {
        let input = self.input.as_deref().unwrap_or(std::path::Path::new(""));
        haze_tradeoff::is_fogmap(input, self.fogmap)
    }

    fn into_args(self) -> Result<TradeoffArgs> {
        let unused = self.unused_flags();
        if !unused.is_empty() {
            let flags = crate::unused_flags::apply(&unused);
            let input = self.input.as_deref().unwrap_or(std::path::Path::new(""));
            if self.extremes {
                anyhow::bail!("--extremes runs fixed cases: {flags} to a sweep of an input");
            } else if self.is_fog() {
                anyhow::bail!(
                    "{}: a fogmap's sweep renders the fog alone: {flags} to a smoke sweep",
                    input.display()
                );
            } else {
                anyhow::bail!(
                    "{}: a smoke sweep has no fog: {flags} to a fogmap's sweep",
                    input.display()
                );
            }
        }
        if !(1..=4096).contains(&self.width) || !(1..=4096).contains(&self.height) {
            anyhow::bail!(
                "--width {} --height {}: each must be between 1 and 4096",
                self.width,
                self.height
            );
        }
        if self.check > MAX_CHECK_PIXELS {
            anyhow::bail!(
                "--check {} must be at most {MAX_CHECK_PIXELS} pixels",
                self.check
            );
        }
        Ok(TradeoffArgs {
            input: self.input.unwrap_or_default(),
            frame: self.frame,
            out: self.out,
            reference: self.reference,
            spp: self.spp,
            check: self.check,
            knobs: self.knobs,
            quick: self.quick,
            fogmap: self.fogmap,
            extremes: self.extremes,
            smoke: SmokeInput {
                lights: self.lights.into(),
                sigma_t: self.medium.sigma_t,
                albedo: self.medium.albedo,
                g: self.medium.g,
                view: View {
                    eye: self.camera.eye,
                    target: self.camera.target,
                    up: self.camera.up,
                    fov: self.camera.fov,
                    width: self.width,
                    height: self.height,
                },
                import: self.import.options(),
                timing: if self.gpu {
                    Timing::Gpu(self.lighting.into())
                } else {
                    Timing::Cpu
                },
            },
            fog_model: self.fog_model.into(),
        })
    }
}

/// `haze tradeoff`: the sweep (or the extreme cases), its file and plots.
pub fn run(t: TradeoffCli) -> Result<()> {
    haze_tradeoff::run(t.into_args()?)
}
