//! Command-line interface: arguments and dispatch.

use crate::bake::BakeCli;
use crate::import_args::ImportArgs;
use crate::render::RenderCli;
use crate::tradeoff::TradeoffCli;
use crate::view::ViewCli;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// haze: smoke and fog toolkit.
///
/// Reads smoke simulations (OpenVDB from Blender, Houdini or EmberGen; raw f32 grids with a
/// JSON sidecar; NumPy .npy), single frames or numbered sequences, and packs them into
/// streamable .haze assets.
#[derive(Debug, Parser)]
#[command(name = "haze", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// More log output (-v info, -vv debug, -vvv trace); RUST_LOG overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Only errors: no progress bars, summary lines or warnings (an answer asked for,
    /// such as `inspect`'s report or `--json`, still goes to stdout).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Describe a volume file, a frame sequence, a .haze asset or an environment map.
    ///
    /// PATH may be a .vdb, .f32/.raw (with its .json sidecar) or .npy file; a directory or
    /// a quoted glob of numbered frames ("cache/fluid_data_*.vdb"); or a .haze asset.
    /// Reports dims, world box, voxel size, the grids in a VDB file, frame count and gaps,
    /// value range, active (non-zero) voxels and memory. For an asset, every block's
    /// checksum is verified. For a lat-long map (.exr or .hdr, as --env takes it): its
    /// size, brightest texel and power, and the suns its concentrated light is split into
    /// for the render, each with its direction, width and share of the power — placed by
    /// --env-layout, --env-rotate and --env-strength as the render places it; any other
    /// .exr or .hdr picture (a render) is described as an image: size, brightest value and
    /// mean colour.
    #[command(allow_negative_numbers = true)]
    Inspect {
        /// File, directory, glob, .haze asset, or environment map.
        path: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Frame range of a sequence to inspect, inclusive: A..B, A.., ..B or A.
        #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
        frames: Option<haze_volume::import::FrameRange>,
        #[command(flatten)]
        import: ImportArgs,
        #[command(flatten)]
        placement: crate::light_args::PlacementArgs,
    },
    /// Bake a sequence: fit every frame with Gaussian RBFs and write them to a .haze asset.
    ///
    /// The first frame is fitted from scratch (greedy start, L-BFGS-B with teleportation);
    /// later frames start from the previous frame's RBFs, drop the --delete weakest, and
    /// get up to --max-insert new RBFs while their error exceeds the first frame's by more
    /// than --threshold. Errors: rel_l2 = sqrt(Σ(D−D̃)²/ΣD²), rms_over_max =
    /// sqrt(mean((D−D̃)²))/max D. Radii are fractions of the grid's longest side.
    #[command(allow_negative_numbers = true)]
    Bake(BakeCli),
    /// Join chunks of one sequence baked separately (`haze bake --frames A..B`) into one
    /// asset, in frame order.
    ///
    /// The chunks may be given in any order; they must cover contiguous, non-overlapping
    /// frame ranges and be compatible (same grid, same settings, except the RBF count a
    /// --target-error search picked per chunk). Every block is verified before it is copied.
    #[command(allow_negative_numbers = true)]
    Merge {
        /// The chunk assets.
        #[arg(required = true, value_name = "CHUNK")]
        chunks: Vec<PathBuf>,
        /// The asset to write (its name must end in .haze: the other commands know an asset by it).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Render one frame of a baked asset (or a density volume) to an image.
    ///
    /// By default with compensated ray marching on the CPU (paper A §5): single scattering
    /// at the RBF centers in spherical harmonics, multiple scattering by diffusion, the
    /// residual put back in the march; `--gpu` runs every stage of it on the GPU. `--reference` instead path-traces the density (slow, for accuracy checks). A
    /// volume file is first fitted with 300 RBFs. World units are the volume's; Z is up;
    /// the default camera frames the smoke (voxels above 1 % of the peak density).
    ///
    /// `--scene SCENE.json` renders a scene file instead (camera, lights, homogeneous fog,
    /// planes and spheres; docs/formats.md "Scene file"): paper C's analytic single scattering on the
    /// CPU, on the GPU with `--gpu` (the same model in f32), or with `--reference` the
    /// same model integrated by quadrature.
    #[command(allow_negative_numbers = true)]
    Render(RenderCli),
    /// Play a baked asset in a window, lit and rendered as it plays.
    ///
    /// Every shown frame is rendered by compensated ray marching (paper A §5) on the GPU
    /// (Vulkan, Metal or DX12; Mesa's lavapipe works without a GPU): the lighting (single
    /// and multiple scattering, as `haze render` lights a frame; on the CPU when the
    /// adapter is itself a CPU: --lighting), then the volume and view passes. Frames
    /// stream from the file on a background thread and play at --fps, looping; a frame
    /// that cannot be rendered in time is skipped (dropped). Only what changed is
    /// recomputed: a camera move re-runs the two passes, a new frame or light also the
    /// lighting. The camera starts framing the smoke of the first frame. A packed asset
    /// (`haze pack`) plays as it was packed: no RBFs, its density exact (a lossless
    /// residual, hashed as each frame is read).
    ///
    /// Window: drag the image to orbit, scroll to zoom; the side panel plays, pauses,
    /// steps and scrubs, shows the measured fps, dropped frames and the time of each
    /// stage, and moves the sun, the medium, the SH order, the slices, multiple
    /// scattering, the residual and the exposure; under a map (--env) it also turns the
    /// whole map about the vertical, as --env-rotate does. Space plays or pauses, the left
    /// and right arrow keys step.
    ///
    /// --play-for SECONDS measures playback: it plays that long from the first picture,
    /// prints one line (frames shown, due and dropped, frame times, fps) and exits. A
    /// frame is dropped when its time slot (1/fps long) ends without it on screen.
    ///
    /// `--scene SCENE.json` shows a scene file instead, rendered by paper C's analytic
    /// single scattering on the GPU whenever the camera or a knob changes: drag to orbit,
    /// scroll to zoom, the panel scales the fog's density and albedo, moves the point
    /// lights and scales every light's power. With --play-for it turns the camera a degree
    /// per picture for that long and prints the pictures' median time.
    ///
    /// `--fog FOGMAP` flies through a fogmap's wavelet fog instead (paper E; the "Fog"
    /// options are `haze fog wavelet`'s), rendered by the GPU fog renderer whenever the
    /// camera, a knob or the wind moved it. The fly camera starts at the fog's default
    /// framing: W/S fly ahead and back, A/D sideways, Q/E down and up, dragging the image
    /// looks around, scrolling flies ahead; the panel sets the basis, the levels, µ, the
    /// density, the falloff, the wind (which drifts the fog as time passes) and the
    /// exposure. A directory of numbered fogmaps plays at --fps, each decomposed when it
    /// differs from the last. With --play-for it turns the camera a degree per picture,
    /// the fog drifting with the wind, and prints the pictures' median time.
    #[command(allow_negative_numbers = true)]
    View(ViewCli),
    /// Reconstruct frames of a baked asset (RBFs + dequantized residual, negatives clamped
    /// to 0 as every renderer does) as volumes — OpenVDB, NumPy or raw — to compare a bake
    /// with its input or take it into another tool: one frame (--frame), or every frame as
    /// a numbered sequence; a packed asset's frames come back as they were packed.
    #[command(allow_negative_numbers = true)]
    Export {
        /// The .haze asset (baked, or packed by `haze pack`).
        asset: PathBuf,
        /// Source frame number (as `haze inspect` lists them), written to OUT. Without it,
        /// every frame (or those of --frames), each to OUT with `_NNNN`, its number, before
        /// the extension (vol.npy → vol_0021.npy, …; a name ending in `_`, `-` or `.` takes
        /// the number alone: vol_.npy → vol_0021.npy): a numbered sequence `haze bake`
        /// reads back. An asset of one frame writes OUT itself.
        #[arg(long, allow_hyphen_values = true)]
        frame: Option<i64>,
        /// Frame range to export, inclusive: A..B, A.., ..B or A.
        #[arg(
            long,
            value_name = "A..B",
            allow_hyphen_values = true,
            conflicts_with = "frame"
        )]
        frames: Option<haze_volume::import::FrameRange>,
        /// Output: VOL.vdb (OpenVDB: one float grid, `density`, placed where the asset's box
        /// lies, for Blender, Houdini or any OpenVDB tool), VOL.npy, or VOL.f32 (written with
        /// its VOL.json sidecar).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Pack volumes losslessly into a .haze asset (one raw-volume block per frame).
    ///
    /// The reference asset of a sequence: no fitting, no compression. The asset is written
    /// to a temporary file beside OUT and renamed when complete.
    #[command(allow_negative_numbers = true)]
    Pack {
        /// File, directory or glob of numbered frames, or a packed asset (a frame range
        /// of it).
        input: PathBuf,
        /// The asset to write (its name must end in .haze: the other commands know an asset by it).
        #[arg(long, short)]
        out: PathBuf,
        /// Frame range to pack, inclusive: A..B, A.., ..B or A.
        #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
        frames: Option<haze_volume::import::FrameRange>,
        #[command(flatten)]
        import: ImportArgs,
    },
    /// Time the GPU renderer on fixed synthetic workloads, on whatever adapter is here.
    ///
    /// Seven workloads vary one thing each from 1000 RBFs on a 128 × 128 × 170 grid at
    /// 800 × 600, SH order 4, with multiple scattering: 100 and 4000 RBFs, a 256-class
    /// grid, 1920 × 1080, SH 2, single scattering only. Each is timed as a new frame, as
    /// the next frame of a playback (warm-started) and as a camera orbit (lighting
    /// reused); the table gives medians with the adapter's name, per-pass GPU times
    /// where the adapter has timestamp queries, and fps. On a CPU adapter (lavapipe) the
    /// grids and picture sides are halved unless --full. Paste yours beside
    /// BENCHMARKS.md's.
    Bench(crate::bench::BenchCli),
    /// Fog models: `haze fog wavelet` renders a fogmap as a wavelet fog.
    #[command(subcommand)]
    Fog(crate::fog::FogCommand),
    /// Measure the speed/accuracy trade of every knob on your own data.
    ///
    /// For smoke (a volume, a sequence's --frame or a .haze asset's frame) each setting is
    /// fitted (RBF count, teleportation), its residual stored (--residual-error, bits) and
    /// rendered on the CPU by compensated ray marching (SH order, exp, source placement, CG
    /// iterations, slices, render size, multiple scattering and its model `diffusion` —
    /// centers, orders:4:2, orders:3:3, orders:auto:6 as --diffusion spells them —,
    /// residual) under the lighting
    /// and camera flags of `haze render`; every knob is turned one at a time around the
    /// defaults, then greedy chains of changes from the defaults towards speed and towards
    /// accuracy give the Pareto front its combinations. For a fogmap (.png, .exr, or
    /// --fogmap) every basis × levels × µ of its wavelet fog is rendered. The error of a
    /// setting is the rel RMS of its picture (scaled up to the full size) against the most
    /// accurate setting's, and with --reference also against the reference renderer's.
    ///
    /// Writes DIR/tradeoff.json (`settings`: every setting with its knobs, `ms` per stage
    /// and `error`; `pareto`: the front of render time against error, ordered by time),
    /// DIR/pareto.{svg,png} and DIR/knob-NAME.{svg,png}. `haze render --budget-ms T
    /// --tradeoff DIR/tradeoff.json` then picks from it.
    ///
    /// --extremes instead bakes and renders tiny cases at the edges of every knob and of
    /// the medium and reports NaN/Inf counts, energy against the reference and the
    /// diffusion solve's convergence (DIR/extremes.json).
    #[command(allow_negative_numbers = true)]
    Tradeoff(TradeoffCli),
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Bake(b) => crate::bake::run(b),
        Command::Render(r) => crate::render::run(r),
        Command::View(v) => crate::view::run(v),
        Command::Merge { chunks, out } => crate::merge::run(&chunks, &out),
        Command::Export {
            asset,
            frame,
            frames,
            out,
        } => crate::export::run(&asset, frame, frames, &out),
        Command::Inspect {
            path,
            json,
            frames,
            import,
            placement,
        } => crate::inspect::run(
            &path,
            json,
            frames.unwrap_or_default(),
            &import.options(),
            placement.placement(),
        ),
        Command::Pack {
            input,
            out,
            frames,
            import,
        } => crate::pack::run(&input, &out, frames.unwrap_or_default(), &import.options()),
        Command::Fog(fog) => crate::fog::run(fog),
        Command::Tradeoff(t) => crate::tradeoff::run(t),
        Command::Bench(b) => crate::bench::run(b),
    }
}
