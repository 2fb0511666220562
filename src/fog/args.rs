//! `haze fog`'s flags: the fog model, the smoke shown in it and `haze fog wavelet`'s
//! picture, converted into `haze_render::fog`'s options.

use crate::import_args::parse_vec3;
use anyhow::Result;
use clap::{Args, Subcommand, ValueEnum};
use haze_render::fog::FogModel;
use haze_render::fog_smoke::SmokePlacement;
use haze_wavelet::Basis;
use std::path::PathBuf;

#[derive(Debug, Subcommand)]
pub enum FogCommand {
    /// Render a fogmap as a heterogeneous fog on B-spline wavelets (Giroud & Biri).
    ///
    /// The fogmap's pixels are the finest scaling coefficients of a 2-D extinction map
    /// (PNG and EXR greyscale, NumPy .npy, or raw .f32 with a NAME.json sidecar holding
    /// "dims": [width, height]; row 0 is the north edge). It is decomposed over --levels
    /// steps of Mallat's transform and rendered over a ground plane and sky: each pixel's
    /// transmittance τ is integrated exactly along its ray, level by level and cell by cell,
    /// and L = τ·L_ground + (1 − τ)·L_fog. Level l is integrated only up to |OP|·µ^l, so
    /// µ < 1 drops fine detail with distance (µ = 0: the coarsest level only).
    ///
    /// Extinction at height z is density · fogmap(x, y) · exp(−falloff·(z − bottom)) for
    /// bottom ≤ z ≤ top, clear elsewhere. Without --eye the camera frames the fog from
    /// beyond its south edge, a little above it, looking north at the horizon.
    ///
    /// --gpu renders the same image on the GPU (headless, wgpu: Vulkan, Metal or DX12;
    /// Mesa's lavapipe will do), in 32-bit floats: it differs from the CPU's by about 1e-5,
    /// by up to --min-transmittance where a ray stops early, and by the checker's contrast
    /// on a rare ground pixel whose point rounds to the other side of a checker line.
    ///
    /// --wind DX,DY moves the fog DX,DY world units per second; --time T renders it at
    /// time T, and --frames N renders N frames 1/--fps seconds apart (numbered images).
    /// The fogmap is decomposed once: wind only moves the fog over the ground. FOGMAP may
    /// be a directory of numbered fogmaps: frame k shows fogmap k, decomposed again only
    /// when it differs from the previous frame's.
    ///
    /// --smoke FILE.haze shows a baked smoke frame in the fog (placed by --smoke-offset and
    /// --smoke-scale in the fog's world: Z up, ground at z = 0), both media composited by
    /// depth: with the smoke's radiance L_s, transmittance T_s and the opacity-weighted
    /// mean depth d of the smoke along each pixel's ray, L = F(0,d) + T_f(0,d)·(L_s +
    /// T_s·F(d,P)), the fog's two parts integrated exactly on either side of d.
    #[command(after_help = "Examples:\n  \
        haze fog wavelet data/fogmap/fogmap_128.png --out fog.png\n  \
        haze fog wavelet fog.exr --basis quadratic --levels 3 --mu 0.6 --out far.exr\n  \
        haze fog wavelet fog.png --eye 0,-80,6 --target 0,40,0 --density 0.3 --out low.png\n  \
        haze fog wavelet data/fogmap/fogmap_128.png --gpu --width 1920 --height 1080 --out hd.exr\n  \
        haze fog wavelet fog.png --gpu --wind 3,1 --frames 48 --fps 24 --out drift.png\n  \
        haze fog wavelet data/fogmap/fogmap_128.png --smoke plume.haze --smoke-scale 3 --eye 0,-40,10 --target 0,0,5 --out smoke.png")]
    #[command(allow_negative_numbers = true)]
    Wavelet(WaveletArgs),
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum BasisArg {
    /// Box functions (1 cell): fastest, blocky.
    Haar,
    /// Hat functions (2 cells): smooth, the paper's recommended trade-off.
    Linear,
    /// Quadratic B-splines (3 cells): smoothest, slowest.
    Quadratic,
}

/// The fog itself: its basis, levels and level of detail, where its layer lies and how
/// dense it is, its colour and its wind (`haze fog wavelet` and `haze view --fog`).
#[derive(Clone, Debug, Args)]
pub struct FogModelArgs {
    /// Scaling functions and wavelets.
    #[arg(long, value_enum, default_value_t = BasisArg::Linear)]
    pub basis: BasisArg,
    /// Decomposition steps of Mallat's transform (0: render the fogmap as it is).
    #[arg(long, default_value_t = 0)]
    pub levels: usize,
    /// Level l is integrated up to |OP|·µ^l; 1 keeps every level, 0 only the coarsest.
    #[arg(long, default_value_t = 1.0)]
    pub mu: f64,
    /// Stop a ray once its transmittance is below this (0: never); the pixel then differs
    /// from the exact one by less than this fraction of its contrast.
    #[arg(long, default_value_t = 1.0 / 1024.0, value_name = "T")]
    pub min_transmittance: f64,
    /// World size of one fogmap pixel.
    #[arg(long, default_value_t = 1.0)]
    pub cell: f64,
    /// World X,Y of the fogmap's south-west corner (default: the map centred on 0,0).
    #[arg(long, value_name = "X,Y", value_parser = parse_vec2, allow_hyphen_values = true)]
    pub origin: Option<[f64; 2]>,
    /// Extinction per world unit of a fogmap value of 1 at the bottom of the layer (PNG
    /// values are 0–1).
    #[arg(long, default_value_t = 0.12)]
    pub density: f64,
    /// Height of the fog layer's bottom.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub bottom: f64,
    /// Height of the fog layer's top.
    #[arg(long, default_value_t = 8.0, allow_hyphen_values = true)]
    pub top: f64,
    /// Vertical extinction falloff k: density fades as exp(−k·(z − bottom)); 0 keeps it
    /// constant up to the top.
    #[arg(long, default_value_t = 0.3)]
    pub falloff: f64,
    /// Wind: the fog drifts DX,DY world units per second (the ground and the camera stay).
    #[arg(long, value_name = "DX,DY", value_parser = parse_vec2, allow_hyphen_values = true, default_value = "0,0")]
    pub wind: [f64; 2],
    /// Fog colour L_fog (linear RGB).
    #[arg(long, value_name = "R,G,B", value_parser = parse_vec3)]
    pub fog_color: Option<[f64; 3]>,
}

#[derive(Debug, Args)]
pub struct WaveletArgs {
    /// The fogmap: .png, .exr, .npy or .f32 (+ .json sidecar), or a directory of numbered
    /// fogmaps of one size (an animation: frame k shows fogmap k, looping).
    pub(crate) fogmap: PathBuf,
    #[command(flatten)]
    pub(crate) model: FogModelArgs,
    #[command(flatten, next_help_heading = "Smoke in the fog")]
    pub(crate) smoke: SmokeArgs,
    /// Output image: .exr (linear RGB, 32-bit float) or .png (sRGB, 8-bit).
    #[arg(long, short)]
    pub(crate) out: PathBuf,
    /// Integrate the detail bases as wavelets (the paper's Algorithm 1) instead of
    /// re-synthesizing them into one scaling basis per level; same image, slower, no
    /// early exit. CPU only: it is the reference the deconstructed levels (which --gpu
    /// integrates) are tested against.
    #[arg(long)]
    pub(crate) direct: bool,
    /// Render on the GPU (headless; same image as the CPU's within f32 rounding).
    #[arg(long)]
    pub(crate) gpu: bool,
    /// Image width in pixels.
    #[arg(long, default_value_t = 800, value_parser = crate::size_arg::parse_side)]
    pub(crate) width: usize,
    /// Image height in pixels.
    #[arg(long, default_value_t = 600, value_parser = crate::size_arg::parse_side)]
    pub(crate) height: usize,
    /// Camera position (default: framing the fog, see above).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub(crate) eye: Option<[f64; 3]>,
    /// Point looked at (default: framing the fog).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub(crate) target: Option<[f64; 3]>,
    /// Camera up direction.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,0,1")]
    pub(crate) up: [f64; 3],
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 50.0)]
    pub(crate) fov: f64,
    /// Time of the (first) frame in seconds: the fog has drifted by wind × time.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub(crate) time: f64,
    /// Frames to render, 1/fps s apart, written to OUT with the frame number before the
    /// extension (fog.png → fog_0000.png, fog_0001.png …) [default: 1, or the number of
    /// fogmaps when FOGMAP is a directory].
    #[arg(long)]
    pub(crate) frames: Option<usize>,
    /// Frames per second of --frames.
    #[arg(long, default_value_t = 24.0)]
    pub(crate) fps: f64,
}

/// Parses "x,y" into two finite numbers.
fn parse_vec2(s: &str) -> Result<[f64; 2], String> {
    parse_vec3(&format!("{s},0"))
        .map(|v| [v[0], v[1]])
        .map_err(|_| format!("expected X,Y (two numbers), got '{s}'"))
}

/// The smoke shown with the fog.
#[derive(Clone, Debug, Args)]
pub struct SmokeArgs {
    /// A baked smoke asset (.haze) shown in the fog, composited by depth: fog in front of
    /// the smoke hides it, the smoke hides the fog behind it.
    #[arg(long, value_name = "FILE.haze")]
    pub smoke: Option<PathBuf>,
    /// The asset's frame number to show [default: its first].
    #[arg(long, value_name = "K", requires = "smoke")]
    pub smoke_frame: Option<i64>,
    /// Where the smoke goes: a point p of the asset's world lands at scale·p + offset
    /// (fog world: Z up, ground at z = 0).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true, default_value = "0,0,0", requires = "smoke")]
    pub smoke_offset: [f64; 3],
    /// Uniform scale of the smoke about the asset's world origin; its extinction per world
    /// unit is divided by it, so it looks the same, only larger.
    #[arg(long, value_name = "S", default_value_t = 1.0, requires = "smoke")]
    pub smoke_scale: f64,
    /// The smoke's extinction cross-section per asset unit: κt = σt · density.
    #[arg(long, default_value_t = 4.0, requires = "smoke")]
    pub smoke_sigma_t: f64,
    /// The smoke's single-scattering albedo, 0..1.
    #[arg(long, default_value_t = 0.8, requires = "smoke")]
    pub smoke_albedo: f64,
    /// The smoke's Henyey–Greenstein asymmetry, −1..1.
    #[arg(
        long,
        default_value_t = 0.3,
        allow_hyphen_values = true,
        requires = "smoke"
    )]
    pub smoke_g: f64,
}

impl FogModelArgs {
    /// Each flag with whether it differs from `defaults` ([`crate::unused_flags`]).
    pub fn given(&self, defaults: &FogModelArgs) -> [(&'static str, bool); 12] {
        use crate::unused_flags::differs;
        let d = defaults;
        [
            ("--basis", differs(&self.basis, &d.basis)),
            ("--levels", differs(&self.levels, &d.levels)),
            ("--mu", differs(&self.mu, &d.mu)),
            (
                "--min-transmittance",
                differs(&self.min_transmittance, &d.min_transmittance),
            ),
            ("--cell", differs(&self.cell, &d.cell)),
            ("--origin", self.origin.is_some()),
            ("--density", differs(&self.density, &d.density)),
            ("--bottom", differs(&self.bottom, &d.bottom)),
            ("--top", differs(&self.top, &d.top)),
            ("--falloff", differs(&self.falloff, &d.falloff)),
            ("--wind", differs(&self.wind, &d.wind)),
            ("--fog-color", self.fog_color.is_some()),
        ]
    }
}

impl From<FogModelArgs> for FogModel {
    fn from(a: FogModelArgs) -> FogModel {
        FogModel {
            basis: match a.basis {
                BasisArg::Haar => Basis::Haar,
                BasisArg::Linear => Basis::Linear,
                BasisArg::Quadratic => Basis::Quadratic,
            },
            levels: a.levels,
            mu: a.mu,
            min_transmittance: a.min_transmittance,
            cell: a.cell,
            origin: a.origin,
            density: a.density,
            bottom: a.bottom,
            top: a.top,
            falloff: a.falloff,
            wind: a.wind,
            fog_color: a.fog_color,
        }
    }
}

impl From<SmokeArgs> for SmokePlacement {
    fn from(a: SmokeArgs) -> SmokePlacement {
        SmokePlacement {
            smoke: a.smoke,
            smoke_frame: a.smoke_frame,
            smoke_offset: a.smoke_offset,
            smoke_scale: a.smoke_scale,
            smoke_sigma_t: a.smoke_sigma_t,
            smoke_albedo: a.smoke_albedo,
            smoke_g: a.smoke_g,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec2_parsing() {
        assert_eq!(parse_vec2("-64, 3.5").unwrap(), [-64.0, 3.5]);
        assert!(parse_vec2("1").is_err());
        assert!(parse_vec2("1,2,3").is_err());
    }
}
