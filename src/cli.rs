//! Command-line interface: arguments and dispatch.

use crate::import_args::ImportArgs;
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
    /// Only errors.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Describe a volume file, a frame sequence or a .haze asset.
    ///
    /// PATH may be a .vdb, .f32/.raw (with its .json sidecar) or .npy file; a directory or
    /// a quoted glob of numbered frames ("cache/fluid_data_*.vdb"); or a .haze asset.
    /// Reports dims, world box, voxel size, the grids in a VDB file, frame count and gaps,
    /// value range, active (non-zero) voxels and memory. For an asset, every block's
    /// checksum is verified.
    Inspect {
        /// File, directory, glob, or .haze asset.
        path: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
        /// Frame range of a sequence to inspect, inclusive: A..B, A.., ..B or A.
        #[arg(long, value_name = "A..B")]
        frames: Option<haze_volume::import::FrameRange>,
        #[command(flatten)]
        import: ImportArgs,
    },
    /// Bake a sequence: fit every frame with Gaussian RBFs and write them to a .haze asset.
    ///
    /// The first frame is fitted from scratch (greedy start, L-BFGS-B with teleportation);
    /// later frames start from the previous frame's RBFs, drop the --delete weakest, and
    /// get up to --max-insert new RBFs while their error exceeds the first frame's by more
    /// than --threshold. Errors: rel_l2 = sqrt(Σ(D−D̃)²/ΣD²), rms_over_max =
    /// sqrt(mean((D−D̃)²))/max D. Radii are fractions of the grid's longest side.
    Bake(BakeCli),
    /// Join chunks of one sequence baked separately (`haze bake --frames A..B`) into one
    /// asset, in frame order.
    ///
    /// The chunks may be given in any order; they must cover contiguous, non-overlapping
    /// frame ranges and be compatible (same grid, same settings, except the RBF count a
    /// --target-error search picked per chunk). Every block is verified before it is copied.
    Merge {
        /// The chunk assets.
        #[arg(required = true, value_name = "CHUNK")]
        chunks: Vec<PathBuf>,
        /// The .haze file to write.
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
    /// planes and spheres; README "Scenes"): paper C's analytic single scattering on the
    /// CPU, on the GPU with `--gpu` (the same model in f32), or with `--reference` the
    /// same model integrated by quadrature.
    Render(RenderCli),
    /// Play a baked asset in a window, lit and rendered as it plays.
    ///
    /// Every shown frame is rendered by compensated ray marching (paper A §5) on the GPU
    /// (Vulkan, Metal or DX12; Mesa's lavapipe works without a GPU): single scattering at
    /// the RBF centers, multiple scattering by diffusion, the volume and view passes (the
    /// first two on the CPU when the adapter is itself a CPU: --lighting). Frames stream
    /// from the file on a background thread and play at --fps, looping; a frame that cannot be rendered in time is skipped (dropped). Only
    /// what changed is recomputed: a camera move re-runs the two passes, a new frame or
    /// light also the lighting. The camera starts framing the smoke of the first frame.
    ///
    /// Window: drag the image to orbit, scroll to zoom; the side panel plays, pauses,
    /// steps and scrubs, shows the measured fps, dropped frames and the time of each
    /// stage, and moves the sun, the medium, the SH order, the slices, multiple
    /// scattering, the residual and the exposure. Space plays or pauses, the left and right
    /// arrow keys step.
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
    View(ViewCli),
    /// Reconstruct one frame of a baked asset (RBFs + dequantized residual) as a dense
    /// volume, to compare a bake with its input.
    Export {
        /// The baked .haze asset.
        asset: PathBuf,
        /// Source frame number (as `haze inspect` lists them).
        #[arg(long)]
        frame: i64,
        /// Output: VOL.npy, or VOL.f32 (written with its VOL.json sidecar).
        #[arg(long, short)]
        out: PathBuf,
    },
    /// Pack volumes losslessly into a .haze asset (one raw-volume block per frame).
    ///
    /// The reference asset of a sequence: no fitting, no compression. The asset is written
    /// to a temporary file beside OUT and renamed when complete.
    Pack {
        /// File, directory or glob of numbered frames.
        input: PathBuf,
        /// The .haze file to write.
        #[arg(long, short)]
        out: PathBuf,
        /// Frame range to pack, inclusive: A..B, A.., ..B or A.
        #[arg(long, value_name = "A..B")]
        frames: Option<haze_volume::import::FrameRange>,
        #[command(flatten)]
        import: ImportArgs,
    },
    /// Fog models: `haze fog wavelet` renders a fogmap as a wavelet fog.
    #[command(subcommand)]
    Fog(crate::fog::FogCommand),
    /// Measure the speed/accuracy trade of every knob on your own data.
    ///
    /// For smoke (a volume, a sequence's --frame or a .haze asset's frame) each setting is
    /// fitted (RBF count, teleportation), its residual stored (--residual-error, bits) and
    /// rendered on the CPU by compensated ray marching (SH order, exp, source placement, CG
    /// iterations, slices, render size, multiple scattering and its model `diffusion` —
    /// centers, orders:4:2, orders:3:3, orders:auto:4 as --diffusion spells them —,
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
    Tradeoff(TradeoffCli),
}

#[derive(Debug, clap::Args)]
pub struct TradeoffCli {
    /// A volume file, a directory or glob of numbered frames, a .haze asset, or a fogmap.
    #[arg(required_unless_present = "extremes")]
    input: Option<PathBuf>,
    /// Source frame number (default: the first).
    #[arg(long)]
    frame: Option<i64>,
    /// Directory for tradeoff.json and the plots (created if missing).
    #[arg(long, short)]
    out: PathBuf,
    /// Also measure every setting against the reference renderer (path tracing at --spp;
    /// for a fogmap the exact integral of the map).
    #[arg(long)]
    reference: bool,
    /// Samples per pixel of --reference.
    #[arg(long, default_value_t = 64)]
    spp: u32,
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
    /// Camera position (world units), with --target.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::import_args::parse_vec3, allow_hyphen_values = true)]
    eye: Option<[f64; 3]>,
    /// Point the camera looks at, with --eye.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::import_args::parse_vec3, allow_hyphen_values = true)]
    target: Option<[f64; 3]>,
    /// Camera up vector.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::import_args::parse_vec3, default_value = "0,0,1", allow_hyphen_values = true)]
    up: [f64; 3],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    fov: f64,
    #[command(flatten)]
    lights: crate::light_args::LightArgs,
    /// Extinction cross-section: κt = σt · density.
    #[arg(long, default_value_t = 4.0)]
    sigma_t: f64,
    /// Single-scattering albedo, 0..1.
    #[arg(long, default_value_t = 0.8)]
    albedo: f64,
    /// Henyey–Greenstein asymmetry, −1..1.
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true)]
    g: f64,
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten, next_help_heading = "Fog (fogmap input)")]
    fog_model: crate::fog::FogModelArgs,
}

impl TradeoffCli {
    fn into_args(self) -> anyhow::Result<crate::tradeoff::TradeoffArgs> {
        if !(1..=4096).contains(&self.width) || !(1..=4096).contains(&self.height) {
            anyhow::bail!(
                "--width {} --height {}: each must be between 1 and 4096",
                self.width,
                self.height
            );
        }
        Ok(crate::tradeoff::TradeoffArgs {
            input: self.input.unwrap_or_default(),
            frame: self.frame,
            out: self.out,
            reference: self.reference,
            spp: self.spp,
            knobs: self.knobs,
            quick: self.quick,
            fogmap: self.fogmap,
            extremes: self.extremes,
            smoke: crate::tradeoff::SmokeInput {
                lights: self.lights,
                sigma_t: self.sigma_t,
                albedo: self.albedo,
                g: self.g,
                view: crate::tradeoff::smoke::View {
                    eye: self.eye,
                    target: self.target,
                    up: self.up,
                    fov: self.fov,
                    width: self.width,
                    height: self.height,
                },
                import: self.import.options(),
                timing: if self.gpu {
                    crate::tradeoff::smoke::Timing::Gpu(self.lighting.into())
                } else {
                    crate::tradeoff::smoke::Timing::Cpu
                },
            },
            fog_model: self.fog_model,
        })
    }
}

#[derive(Debug, clap::Args)]
pub struct BakeCli {
    /// File, directory or glob of numbered frames.
    input: PathBuf,
    /// The .haze file to write.
    #[arg(long, short)]
    out: PathBuf,
    /// Frame range to bake, inclusive: A..B, A.., ..B or A. A chunk starts with a full
    /// first-frame fit; `haze merge` joins chunks baked separately (on a render farm, say).
    #[arg(long, value_name = "A..B")]
    frames: Option<haze_volume::import::FrameRange>,
    /// Continue an interrupted bake of --out from its journal (OUT.partial, written as
    /// frames finish), with the same input and settings. Without it, a bake starts over.
    #[arg(long)]
    resume: bool,
    /// RBFs of the first frame (later frames vary by deletions and insertions).
    #[arg(long, value_name = "N", conflicts_with = "target_error")]
    rbfs: Option<usize>,
    /// Instead of --rbfs: the smallest RBF count whose first-frame fit reaches this
    /// rel_l2 (searched by doubling then bisection; each probe is a full fit).
    #[arg(long, value_name = "E")]
    target_error: Option<f64>,
    /// Most RBFs a frame may have: where later frames stop inserting and move RBFs
    /// instead [default: 8 × the first frame's count], and the --target-error search's
    /// ceiling [default: 4096].
    #[arg(long, value_name = "N")]
    max_rbfs: Option<usize>,
    /// Local minimizer.
    #[arg(long, value_enum, default_value_t = OptimizerArg::Lbfgsb)]
    optimizer: OptimizerArg,
    /// Smallest RBF radius, as a fraction of the grid's longest side; never below the
    /// grid's Nyquist radius 2h/π (h the voxel side), which 0 leaves as the floor.
    #[arg(long, default_value_t = 0.0)]
    radius_min: f64,
    /// Largest RBF radius, as a fraction of the grid's longest side.
    #[arg(long, default_value_t = 0.09)]
    radius_max: f64,
    /// Fit first frames without teleportation (faster, usually a higher error).
    #[arg(long)]
    no_teleport: bool,
    /// Iteration budget of a first-frame fit.
    #[arg(long, default_value_t = 1000)]
    max_iterations: u64,
    /// Stop a minimization when an iteration lowers the error by less than this fraction
    /// (larger: faster, slightly less accurate; see BENCHMARKS.md).
    #[arg(long, default_value_t = 1e-6)]
    tolerance: f64,
    /// Iteration budget of each minimization of a warm-started frame.
    #[arg(long, default_value_t = 200)]
    warm_iterations: u64,
    /// Stop a warm-started minimization when its last 10 iterations together lowered the
    /// error by less than this fraction (0: only --tolerance stops it; see BENCHMARKS.md).
    #[arg(long, default_value_t = haze_fit::sequence::WARM_WINDOW_GAIN, value_name = "F")]
    warm_tolerance: f64,
    /// Fit first frames on the half-resolution grid, then polish at full resolution:
    /// `auto` on grids of 64³ voxels or more.
    #[arg(long, value_enum, default_value_t = CoarseArg::Auto)]
    coarse_to_fine: CoarseArg,
    /// RBFs deleted at the start of each later frame.
    #[arg(long, default_value_t = 3)]
    delete: usize,
    /// Most RBFs inserted in a later frame [default: as many as keep the previous frame's
    /// RBFs per voxel of smoke as the smoke grows or as its excess error asks for, at
    /// least an eighth of --rbfs and 16]. A frame that hits it moves its weakest RBFs to
    /// where they lower the error more; if still over --threshold, it is reported.
    #[arg(long, value_name = "M")]
    max_insert: Option<usize>,
    /// How later frames get RBFs where the smoke grew: `batch` sizes each round by the
    /// excess error; `single` inserts one at a time (paper A).
    #[arg(long, value_enum, default_value_t = InsertionArg::Batch)]
    insertion: InsertionArg,
    /// Insert RBFs while a frame's rel_l2 exceeds the first frame's by this ratio.
    #[arg(long, default_value_t = 1.1)]
    threshold: f64,
    /// Insert an RBF only where it is predicted to lower the squared error by at least
    /// this fraction of what the first frame's next RBFs would (its marginal gain); a
    /// frame whose proposals all fall short stops inserting and is reported (0: off).
    #[arg(long, default_value_t = haze_fit::sequence::MARGINAL_GAIN, value_name = "F")]
    marginal_gain: f64,
    /// Seed of the random teleports (same seed, same input: same asset).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Largest error of the stored volume, as a fraction of each frame's peak density: the
    /// residual D − D̃ is quantized with a step of twice that, and nothing is stored where
    /// the RBFs alone are within it. 0 = lossless (the residual's f32 values); the default
    /// 1/255 is what 8-bit density storage promises. With --target-error and without this
    /// flag it is chosen: the largest of 0.5/255 … 16/255 that keeps the stored density
    /// within a quarter of the target (rel_l2, guaranteed by the quantizer's bound on the
    /// first frame), printed and stored in the asset header with why.
    #[arg(long, value_name = "E", value_parser = parse_error_fraction)]
    residual_error: Option<f64>,
    /// Widest stored residual value in bits (4..16); each brick takes the narrowest of 2, 4,
    /// 8, 16 bits that holds its values. If the largest residual needs more at
    /// --residual-error, the step widens (with a warning).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u8).range(4..=16))]
    quant_bits: u8,
    /// Side of the voxel bricks the residual is hashed by (1, 2, 4 or 8).
    #[arg(long, default_value_t = haze_hash::tile::DEFAULT_BRICK, value_parser = parse_brick)]
    residual_brick: u32,
    /// Also write a JSON report of every frame's fit.
    #[arg(long, value_name = "REPORT.json")]
    report: Option<PathBuf>,
    /// Choose the render knobs `haze view` starts with: the most accurate setting of the
    /// --tradeoff sweep's front that rendered within T ms; stored with why in the header.
    #[arg(long, value_name = "T", requires = "tradeoff")]
    view_budget_ms: Option<f64>,
    /// The sweep (`haze tradeoff`'s tradeoff.json) for --view-budget-ms.
    #[arg(long, value_name = "FILE", requires = "view_budget_ms")]
    tradeoff: Option<PathBuf>,
    #[command(flatten)]
    import: ImportArgs,
}

#[derive(Debug, clap::Args)]
pub struct RenderCli {
    /// A .haze asset, or a volume file / directory of frames.
    #[arg(required_unless_present = "scene", conflicts_with = "scene")]
    input: Option<PathBuf>,
    /// Render a scene file (JSON: camera, environment, lights, media, surfaces) instead.
    #[arg(long, value_name = "SCENE.json")]
    scene: Option<PathBuf>,
    /// Source frame number (default: the first).
    #[arg(long)]
    frame: Option<i64>,
    /// Output image: IMG.exr (linear radiance) or IMG.png (exposure, sRGB).
    #[arg(long, short)]
    out: PathBuf,
    /// Image width [default: 400, or the scene camera's].
    #[arg(long)]
    width: Option<usize>,
    /// Image height [default: 300, or the scene camera's].
    #[arg(long)]
    height: Option<usize>,
    /// Camera position (world units), with --target.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::import_args::parse_vec3, allow_hyphen_values = true)]
    eye: Option<[f64; 3]>,
    /// Point the camera looks at, with --eye.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::import_args::parse_vec3, allow_hyphen_values = true)]
    target: Option<[f64; 3]>,
    /// Camera up vector.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::import_args::parse_vec3, default_value = "0,0,1", allow_hyphen_values = true)]
    up: [f64; 3],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    fov: f64,
    #[command(flatten)]
    lights: crate::light_args::LightArgs,
    /// Extinction cross-section: κt = σt · density.
    #[arg(long, default_value_t = 4.0)]
    sigma_t: f64,
    /// Single-scattering albedo, 0..1.
    #[arg(long, default_value_t = 0.8)]
    albedo: f64,
    /// Henyey–Greenstein asymmetry, −1..1.
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true)]
    g: f64,
    /// Spherical-harmonic order (bands), 1..6.
    #[arg(long, default_value_t = 4)]
    sh_order: usize,
    /// Single scattering only.
    #[arg(long)]
    no_multiple: bool,
    /// Ignore the residual (render the RBF approximation alone).
    #[arg(long)]
    no_residual: bool,
    /// View-pass slices per voxel (2: half a voxel apart, as in the paper).
    #[arg(long, default_value_t = 2.0)]
    slices: f64,
    /// SH exponentiation of the transmittance: scaling and squaring (accurate for thick
    /// smoke) or the paper's optimal linear approximation (faster, thin smoke only).
    #[arg(long, value_enum, default_value_t = ExpArg::Square)]
    exp: ExpArg,
    /// Where the environment's single scattering comes from: a coarse grid of the
    /// transmitted environment's SH marched through the smoke, added per voxel (grid);
    /// or paper A's source at the RBF centers, their transmittance averaged over each
    /// footprint (footprint) or taken at the center (center). The diffusion starts from
    /// the centers' single scattering either way (footprint for grid).
    #[arg(long, value_enum, default_value_t = SourceArg::Grid)]
    source: SourceArg,
    /// How multiple scattering is computed: `orders[:F[:K]]` (the default: the first K
    /// scattering orders gathered explicitly along 72 directions, 32 after the first, on
    /// the density averaged over F³ voxels, and the rest by diffusion on that grid; K = 4;
    /// F = auto unless given: on the CPU 2, or where the cells with smoke times the side
    /// of the box they fill exceed 600 000, the smallest larger F within it, which keeps
    /// a frame's multiple scattering to about 10 s on two cores; with --gpu 2, at most 8,
    /// and lit by the sky per voxel, so --source grid), `centers` (paper A §5.4's
    /// diffusion on the RBF basis; the default with --gpu and --source footprint or
    /// center) or `grid[:F]` (the diffusion alone on the F³ grid, CPU only, refused with
    /// --gpu). BENCHMARKS.md "Multiple scattering: explicit orders" compares them.
    #[arg(long, value_parser = parse_diffusion)]
    diffusion: Option<haze_view::render::MsDiffusion>,
    /// Voxels between the nodes of `--source grid`'s grid (smaller: sharper self-shadowing,
    /// more time; the time grows as the inverse cube).
    #[arg(long, default_value_t = haze_view::render::env_pass::EnvGridOptions::default().spacing, value_parser = positive_f64)]
    env_grid_spacing: f64,
    /// Render with the reference path tracer instead (slow).
    #[arg(long, conflicts_with = "gpu")]
    reference: bool,
    /// Compensated ray marching entirely on the CPU (the default).
    #[arg(long, conflicts_with_all = ["gpu", "reference"])]
    cpu: bool,
    /// Render on the GPU: single scattering, multiple scattering (the explicit orders or
    /// the centers' diffusion, --diffusion), the volume and view passes (in f32); with --scene, paper C's airlight and surface
    /// shading. Needs a GPU adapter; Mesa's lavapipe (mesa-vulkan-drivers) works without
    /// a GPU.
    #[arg(long)]
    gpu: bool,
    /// With --gpu: where the lighting at the RBF centers (single scattering and the
    /// diffusion of multiple scattering) is computed. `auto`: on the GPU, unless the
    /// adapter is a CPU (lavapipe), where the CPU's own code is several times faster.
    #[arg(long, value_enum, default_value_t = LightingArg::Auto, requires = "gpu")]
    lighting: LightingArg,
    /// Samples per pixel of --reference.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Choose the knobs automatically: the most accurate setting of a tradeoff sweep's
    /// Pareto front that renders within T milliseconds (the sweep's machine and size).
    /// The choice sets the knobs the sweep turned, the multiple-scattering model
    /// (--diffusion) among them; a sweep written before its `diffusion` knob timed
    /// `centers`, which it then uses.
    #[arg(long, value_name = "T", conflicts_with_all = ["target_error", "reference", "gpu"])]
    budget_ms: Option<f64>,
    /// Choose the knobs automatically: the fastest setting of the front whose error
    /// against the sweep's best setting is at most E (rel RMS, 0.02 = 2 %); the knobs are
    /// set as with --budget-ms.
    #[arg(long, value_name = "E", conflicts_with_all = ["reference", "gpu"])]
    target_error: Option<f64>,
    /// The sweep for --budget-ms/--target-error (`haze tradeoff`'s tradeoff.json); without
    /// it a quick sweep of INPUT is run first, at this render's size.
    #[arg(long, value_name = "FILE")]
    tradeoff: Option<PathBuf>,
    /// Exposure applied before PNG tone mapping.
    #[arg(long, default_value_t = 1.0)]
    exposure: f64,
    /// With --scene: the time in seconds at which the analytic fog is rendered (its wind
    /// has carried it for this long).
    #[arg(
        long,
        default_value_t = 0.0,
        requires = "scene",
        allow_hyphen_values = true
    )]
    time: f64,
    /// With --scene: single scattering of the scene's lights through every medium (the
    /// analytic fog included) by ray marching with exact transmittance, on the CPU (on
    /// the GPU with --gpu), instead of paper C's airlight and paper D's fog colour.
    #[arg(long, requires = "scene", conflicts_with = "reference")]
    march: bool,
    #[command(flatten)]
    import: ImportArgs,
}

#[derive(Debug, clap::Args)]
pub struct ViewCli {
    /// A baked .haze asset (`haze bake` makes one).
    #[arg(required_unless_present_any = ["scene", "fog"], conflicts_with_all = ["scene", "fog"])]
    input: Option<PathBuf>,
    /// Show a scene file (README "Scenes") instead: paper C's renderer on the GPU, the
    /// orbit camera starting at the scene's, fog and lights in the panel, the surfaces
    /// rasterized with a depth buffer. Gaussian media are rendered by paper B (surfaces
    /// ray-traced) and edited with the panel's tools (paper B §6): paintbrush, airbrush,
    /// eraser, particle emitter, copy/cut/paste of a dragged rectangle; left drag = stroke,
    /// right drag = orbit, Ctrl+Z / Ctrl+Y undo and redo, Ctrl+S saves the edited medium
    /// into SCENE.edited.json (the panel's file; "load" reads one back). Of the options
    /// below only --size, --exposure, --play-for, --no-window and --ray-traced apply.
    #[arg(long, value_name = "SCENE.json", conflicts_with = "fog")]
    scene: Option<PathBuf>,
    /// Fly through a fogmap's wavelet fog instead (as `haze fog wavelet` renders it), on
    /// the GPU: WASD and Q/E fly, dragging looks around; basis, levels, µ, density,
    /// falloff and wind in the panel. FOGMAP may be a directory of numbered fogmaps, shown
    /// at --fps. The "Fog" options below apply, and --fps, --size, --exposure, --play-for
    /// and --no-window.
    #[arg(long, value_name = "FOGMAP")]
    fog: Option<PathBuf>,
    /// Playback rate in frames per second; 0 plays every frame as fast as it renders.
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// Render resolution (the picture is scaled to the window; larger costs more, in the
    /// view pass mostly).
    #[arg(long, value_name = "WxH", default_value = "400x300", value_parser = crate::viewer::parse_size)]
    size: (usize, usize),
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 40.0)]
    fov: f64,
    #[command(flatten)]
    lights: crate::light_args::LightArgs,
    /// Extinction cross-section: κt = σt · density.
    #[arg(long, default_value_t = 4.0)]
    sigma_t: f64,
    /// Single-scattering albedo, 0..1.
    #[arg(long, default_value_t = 0.8)]
    albedo: f64,
    /// Henyey–Greenstein asymmetry, −1..1.
    #[arg(long, default_value_t = 0.3, allow_hyphen_values = true)]
    g: f64,
    /// Spherical-harmonic order (bands), 1..6.
    #[arg(long, default_value_t = 4)]
    sh_order: usize,
    /// View-pass slices per voxel (2: half a voxel apart, as in the paper).
    #[arg(long, default_value_t = 2.0)]
    slices: f64,
    /// Start with single scattering only.
    #[arg(long)]
    no_multiple: bool,
    /// Start without the residual (the RBF approximation alone).
    #[arg(long)]
    no_residual: bool,
    /// Start with the sky's single scattering at the RBF centers (paper A, `haze render
    /// --source footprint`) instead of per voxel by the environment pass: about half the
    /// frame time on lavapipe, 9–11 % darker single scattering on sky-lit smoke
    /// (BENCHMARKS.md, "Environment pass"); a panel switch too.
    #[arg(long)]
    sky_at_centers: bool,
    /// Multiple scattering by paper A's diffusion at the RBF centers (`haze render
    /// --diffusion centers`) instead of the explicit orders on a grid of 2³-voxel cells
    /// (`orders`, the default, which takes the sky per voxel): less than half the frame
    /// time of a new frame on lavapipe, a larger error (BENCHMARKS.md, "Multiple
    /// scattering: explicit orders"); a panel switch too. A setting chosen for a budget
    /// or a target error brings its own model (the sweep's `diffusion` knob).
    #[arg(long)]
    ms_at_centers: bool,
    /// The explicit orders' model an asset's stored choice names (not a flag).
    #[arg(skip)]
    orders_model: Option<haze_view::render::MsDiffusion>,
    /// Start with the knobs (SH order, slices, multiple scattering, residual, render
    /// size) of the most accurate setting of a tradeoff sweep's front that renders within
    /// T milliseconds; prints the choice and why.
    #[arg(long, value_name = "T", group = "goal", conflicts_with_all = ["scene", "fog"])]
    budget_ms: Option<f64>,
    /// Start with the fastest front setting whose error against the sweep's best is at
    /// most E (rel RMS, 0.02 = 2 %), the models the scene does not need turned off.
    #[arg(long, value_name = "E", group = "goal", conflicts_with_all = ["scene", "fog"])]
    target_error: Option<f64>,
    /// The sweep for --budget-ms/--target-error (`haze tradeoff`'s tradeoff.json; its
    /// view-pass times are rescaled to --size); without it a quick sweep of the asset is
    /// measured first, at --size on the viewer's GPU renderer.
    #[arg(long, value_name = "FILE", requires = "goal")]
    tradeoff: Option<PathBuf>,
    /// Exposure applied before the sRGB encoding.
    #[arg(long, default_value_t = 1.0)]
    exposure: f64,
    /// Play for SECONDS from the first picture, print one line of playback figures to
    /// stdout and exit.
    #[arg(long, value_name = "SECONDS")]
    play_for: Option<f64>,
    /// With --play-for: play without opening a window (the render thread and the clock
    /// alone, no display needed).
    #[arg(long, requires = "play_for")]
    no_window: bool,
    /// With --no-window and an asset: pause on the first frame and turn the camera a
    /// degree per picture instead of playing (what a camera drag costs); prints the
    /// pictures' median time.
    #[arg(long, requires = "no_window", conflicts_with_all = ["scene", "fog"])]
    orbit: bool,
    /// With --scene: start with the surfaces ray-traced per pixel instead of rasterized
    /// (the panel switches between the two).
    #[arg(long, requires = "scene")]
    ray_traced: bool,
    /// With --scene: a scripted stroke of the Gaussian editing tools, applied before the
    /// first picture with the scene's camera, at the render size: TOOL (paint, airbrush,
    /// erase, emit, copy, cut, paste) then the cursor's picture points `X,Y` (pixels,
    /// from the top left), e.g. `paint:10,40:50,40`; the panel's default settings;
    /// airbrush and emitter strokes run 0.05 s per point. Repeat for more strokes.
    #[arg(long, value_name = "TOOL:X,Y[:X,Y…]", requires = "scene", value_parser = crate::viewer::edit_tools::parse_stroke)]
    stroke: Vec<crate::viewer::edit_tools::ScriptedStroke>,
    /// With --scene: after the --stroke edits, save the edited Gaussian medium into a copy
    /// of the scene file at FILE (as the panel's "save").
    #[arg(long, value_name = "FILE", requires = "scene")]
    save_edits: Option<PathBuf>,
    /// Where the lighting at the RBF centers (single scattering and the diffusion of
    /// multiple scattering) is computed. `auto`: on the GPU, unless the adapter is a CPU
    /// (lavapipe), where the CPU's own code is several times faster.
    #[arg(long, value_enum, default_value_t = LightingArg::Auto)]
    lighting: LightingArg,
    #[command(flatten, next_help_heading = "Fog (with --fog)")]
    fog_model: crate::fog::FogModelArgs,
    #[command(flatten, next_help_heading = "Smoke in the fog (with --fog)")]
    fog_smoke: crate::fog_smoke::SmokeArgs,
}

impl ViewCli {
    /// The knobs an asset's header chose for the viewer (`haze bake --view-budget-ms`),
    /// applied where the command line left the default.
    fn apply_stored_choice(&mut self) {
        let Some(input) = &self.input else { return };
        let Some((knobs, why)) = crate::tradeoff::choice::stored_view_knobs(input) else {
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
            .and_then(|v| v.parse::<haze_view::render::MsDiffusion>().ok());
        match model {
            Some(haze_view::render::MsDiffusion::Centers) if !self.ms_at_centers => {
                self.ms_at_centers = true;
                used.push("multiple scattering by the centers' diffusion".to_string());
            }
            Some(m @ haze_view::render::MsDiffusion::Orders { .. })
                if !self.ms_at_centers && m != haze_view::render::MsDiffusion::DEFAULT =>
            {
                self.orders_model = Some(m);
                used.push(format!(
                    "multiple scattering by {}",
                    crate::render::diffusion_name(m)
                ));
            }
            _ => {}
        }
        if !used.is_empty() {
            eprintln!(
                "{}: starting with the asset's choice ({}): {why}",
                input.display(),
                used.join(", ")
            );
        }
    }

    fn into_args(mut self) -> crate::viewer::ViewArgs {
        let goal = match (self.budget_ms, self.target_error) {
            (Some(t), _) => Some(crate::tradeoff::pareto::Goal::BudgetMs(t)),
            (None, Some(e)) => Some(crate::tradeoff::pareto::Goal::TargetError(e)),
            (None, None) => None,
        };
        // A goal on the command line replaces the choice stored in the asset.
        if goal.is_none() {
            self.apply_stored_choice();
        }
        crate::viewer::ViewArgs {
            // clap requires the input without --scene.
            input: self.input.unwrap_or_default(),
            fps: self.fps,
            width: self.size.0,
            height: self.size.1,
            fov: self.fov,
            env: self.lights,
            knobs: crate::viewer::Knobs {
                sigma_t: self.sigma_t,
                albedo: self.albedo,
                g: self.g,
                sh_order: self.sh_order,
                slices: self.slices,
                multiple: !self.no_multiple,
                residual: !self.no_residual,
                sky_per_voxel: !self.sky_at_centers,
                orders: !self.ms_at_centers,
                orders_model: self
                    .orders_model
                    .unwrap_or(haze_view::render::MsDiffusion::DEFAULT),
                exposure: self.exposure,
            },
            play_for: self.play_for,
            window: !self.no_window,
            orbit: self.orbit,
            lighting: self.lighting.into(),
            goal,
            tradeoff: self.tradeoff,
        }
    }
}

impl RenderCli {
    fn into_args(self) -> crate::render::RenderArgs {
        crate::render::RenderArgs {
            // clap requires the input without --scene.
            input: self.input.unwrap_or_default(),
            frame: self.frame,
            out: self.out,
            width: self.width.unwrap_or(400),
            height: self.height.unwrap_or(300),
            eye: self.eye,
            target: self.target,
            up: self.up,
            fov: self.fov,
            env: self.lights,
            sigma_t: self.sigma_t,
            albedo: self.albedo,
            g: self.g,
            sh_order: self.sh_order,
            multiple: !self.no_multiple,
            residual: !self.no_residual,
            slices: self.slices,
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
                        spacing: self.env_grid_spacing,
                        ..Default::default()
                    },
                ),
                SourceArg::Footprint | SourceArg::Center => {
                    haze_view::render::env_pass::EnvSource::Centers
                }
            },
            reference: self.reference,
            goal: match (self.budget_ms, self.target_error) {
                (Some(t), _) => Some(crate::tradeoff::pareto::Goal::BudgetMs(t)),
                (None, Some(e)) => Some(crate::tradeoff::pareto::Goal::TargetError(e)),
                (None, None) => None,
            },
            tradeoff: self.tradeoff,
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
            exposure: self.exposure,
            import: self.import.options(),
        }
    }
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum LightingArg {
    /// The GPU, or the CPU when the adapter is a CPU.
    Auto,
    /// The CPU, in f64 (the sources are then uploaded).
    Cpu,
    /// The GPU, in f32.
    Gpu,
}

impl From<LightingArg> for haze_view::gpu::renderer::LightingOn {
    fn from(a: LightingArg) -> Self {
        match a {
            LightingArg::Auto => Self::Auto,
            LightingArg::Cpu => Self::Cpu,
            LightingArg::Gpu => Self::Gpu,
        }
    }
}

/// `centers`, `grid[:F]` or `orders[:F[:K]]` (`MsDiffusion`'s syntax).
fn parse_diffusion(s: &str) -> Result<haze_view::render::MsDiffusion, String> {
    s.parse()
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum SourceArg {
    /// Per voxel, from a grid of the transmitted environment's SH.
    Grid,
    /// At the RBF centers, mean over six cubature points of each RBF's footprint.
    Footprint,
    /// At the RBF centers, each RBF's center only.
    Center,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum ExpArg {
    /// exp(f/2^k)^(2^k) with ‖f̂‖/2^k ≤ 1, by triple products.
    Square,
    /// a(‖f̂‖) + b(‖f̂‖)·f̂ (paper A §5.3).
    Linear,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum CoarseArg {
    Auto,
    On,
    Off,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum InsertionArg {
    /// Rounds sized by the excess error, placed where they lower the error most.
    Batch,
    /// One RBF and a joint minimization per round (paper A).
    Single,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
enum OptimizerArg {
    /// L-BFGS-B with exact bounds (paper A).
    Lbfgsb,
    /// L-BFGS on a smooth (logistic) reparameterization of the bounds.
    LbfgsReparam,
}

impl BakeCli {
    fn into_args(self) -> anyhow::Result<crate::bake::BakeArgs> {
        use anyhow::bail;
        use haze_fit::{Bounds, Coarse, FitOptions, Insertion, Optimizer, SequenceOptions, Stop};
        let bounds = Bounds {
            radius: (self.radius_min, self.radius_max),
            ..Bounds::default()
        };
        bounds.validate().map_err(anyhow::Error::msg)?;
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            bail!("--tolerance {} must be in (0, 1)", self.tolerance);
        }
        if !(self.warm_tolerance >= 0.0 && self.warm_tolerance < 1.0) {
            bail!("--warm-tolerance {} must be in [0, 1)", self.warm_tolerance);
        }
        if self.max_insert == Some(0) {
            bail!("--max-insert must be at least 1 (--threshold 1e9 turns insertion off)");
        }
        if self.threshold.is_nan() || self.threshold < 1.0 {
            bail!("--threshold {} must be at least 1", self.threshold);
        }
        if !(self.marginal_gain.is_finite() && self.marginal_gain >= 0.0) {
            bail!(
                "--marginal-gain {} must be a finite number ≥ 0 (0 turns the test off)",
                self.marginal_gain
            );
        }
        let count = match (self.rbfs, self.target_error) {
            (Some(0), _) => bail!("--rbfs must be at least 1"),
            (Some(n), _) => haze_bake::Count::Fixed(n),
            (None, Some(e)) if e > 0.0 && e <= 1.0 => haze_bake::Count::Target {
                rel_l2: e,
                cap: self.max_rbfs.unwrap_or(4096).max(1),
            },
            (None, Some(e)) => bail!("--target-error {e} must be in (0, 1]"),
            (None, None) => haze_bake::Count::Fixed(300),
        };
        let fit = FitOptions {
            bounds,
            optimizer: match self.optimizer {
                OptimizerArg::Lbfgsb => Optimizer::Lbfgsb,
                OptimizerArg::LbfgsReparam => Optimizer::LbfgsReparam,
            },
            teleport: !self.no_teleport,
            max_iterations: self.max_iterations,
            stop: Stop {
                relative_reduction: self.tolerance,
                ..Stop::default()
            },
            seed: self.seed,
            coarse: match self.coarse_to_fine {
                CoarseArg::Auto => Coarse::Auto,
                CoarseArg::On => Coarse::Always,
                CoarseArg::Off => Coarse::Never,
            },
            ..FitOptions::default()
        };
        let defaults = SequenceOptions::default();
        let mut choices = serde_json::Map::new();
        let residual_error = match (self.residual_error, &count) {
            (Some(e), _) => e,
            (None, haze_bake::Count::Target { rel_l2, .. }) => {
                let import = self.import.options();
                let range = self.frames.unwrap_or_default();
                let seq = haze_volume::Sequence::open(&self.input, &import, range)?;
                let first = seq.load(0)?;
                match haze_bake::choice::residual_error_for(&first, *rel_l2) {
                    Some(c) => {
                        eprintln!("residual error chosen: {}", c.why);
                        choices.insert("residual_error".into(), serde_json::to_value(&c)?);
                        c.residual_error
                    }
                    None => haze_hash::DEFAULT_ERROR,
                }
            }
            (None, _) => haze_hash::DEFAULT_ERROR,
        };
        if let (Some(t), Some(file)) = (self.view_budget_ms, &self.tradeoff) {
            let c = crate::tradeoff::choice::for_view(file, t)?;
            eprintln!("view settings chosen: {}", c.reason);
            choices.insert("view".into(), c.to_json());
        }
        Ok(crate::bake::BakeArgs {
            report: self.report,
            options: haze_bake::BakeOptions {
                input: self.input,
                out: self.out,
                range: self.frames.unwrap_or_default(),
                import: self.import.options(),
                count,
                fit: SequenceOptions {
                    fit,
                    delete: self.delete,
                    max_insert: self.max_insert,
                    max_rbfs: self.max_rbfs.map(|n| n.max(1)),
                    threshold: self.threshold,
                    marginal_gain: self.marginal_gain,
                    insertion: match self.insertion {
                        InsertionArg::Batch => Insertion::Batch,
                        InsertionArg::Single => Insertion::Single,
                    },
                    warm: Stop {
                        max_iterations: self.warm_iterations,
                        // The windowed test replaces the per-iteration one, as in the
                        // library's defaults; without it, --tolerance stops a warm frame.
                        relative_reduction: if self.warm_tolerance > 0.0 {
                            defaults.warm.relative_reduction
                        } else {
                            self.tolerance
                        },
                        window: if self.warm_tolerance > 0.0 {
                            defaults.warm.window
                        } else {
                            0
                        },
                        window_gain: self.warm_tolerance,
                    },
                    ..defaults
                },
                quant: haze_hash::QuantOptions {
                    error: residual_error,
                    bits: self.quant_bits,
                },
                brick: self.residual_brick,
                resume: self.resume,
                choices,
            },
        })
    }
}

/// `--residual-error`: a finite fraction ≥ 0.
fn parse_error_fraction(s: &str) -> Result<f64, String> {
    let e: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if e.is_finite() && e >= 0.0 {
        Ok(e)
    } else {
        Err(format!("{s} is not a fraction ≥ 0 of the peak density"))
    }
}

/// `--env-grid-spacing`: a finite number of voxels > 0.
fn positive_f64(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{s} must be a finite number > 0"))
    }
}

/// `--residual-brick`: one of the supported sides.
fn parse_brick(s: &str) -> Result<u32, String> {
    s.parse()
        .ok()
        .filter(|b| haze_hash::tile::BRICK_SIDES.contains(b))
        .ok_or_else(|| format!("'{s}' is not one of {:?}", haze_hash::tile::BRICK_SIDES))
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Bake(b) => crate::bake::run(b.into_args()?),
        Command::Render(r) => match r.scene {
            Some(scene) => crate::scene_render::run(crate::scene_render::SceneRenderArgs {
                scene,
                out: r.out,
                width: r.width,
                height: r.height,
                reference: r.reference,
                gpu: r.gpu,
                exposure: r.exposure,
                time: r.time,
                march: r.march,
            }),
            None => crate::render::run(r.into_args()),
        },
        Command::View(v) if v.fog.is_some() => {
            crate::viewer::fog_view::run(crate::viewer::fog_view::FogViewArgs {
                // Present: the guard above.
                fogmap: v.fog.unwrap_or_default(),
                model: v.fog_model,
                smoke: v.fog_smoke,
                fps: v.fps,
                width: v.size.0,
                height: v.size.1,
                exposure: v.exposure,
                play_for: v.play_for,
                window: !v.no_window,
            })
        }
        Command::View(v) if v.fog_smoke.smoke.is_some() => anyhow::bail!(
            "--smoke shows a smoke asset in a fog: give --fog FOGMAP too (`haze view FILE.haze` shows the asset alone)"
        ),
        Command::View(v) => match v.scene {
            Some(scene) => {
                crate::viewer::scene_view::run(crate::viewer::scene_view::SceneViewArgs {
                    scene,
                    width: v.size.0,
                    height: v.size.1,
                    exposure: v.exposure,
                    play_for: v.play_for,
                    window: !v.no_window,
                    ray_traced: v.ray_traced,
                    strokes: v.stroke,
                    save_edits: v.save_edits,
                })
            }
            None => crate::viewer::run(v.into_args()),
        },
        Command::Merge { chunks, out } => crate::merge::run(&chunks, &out),
        Command::Export { asset, frame, out } => crate::export::run(&asset, frame, &out),
        Command::Inspect {
            path,
            json,
            frames,
            import,
        } => crate::inspect::run(&path, json, frames.unwrap_or_default(), &import.options()),
        Command::Pack {
            input,
            out,
            frames,
            import,
        } => crate::pack::run(&input, &out, frames.unwrap_or_default(), &import.options()),
        Command::Fog(fog) => crate::fog::run(fog),
        Command::Tradeoff(t) => crate::tradeoff::run(t.into_args()?),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haze_view::render::MsDiffusion;

    fn render_args(extra: &[&str]) -> crate::render::RenderArgs {
        let argv = [
            &["haze", "render", "smoke.vdb", "--out", "out.png"][..],
            extra,
        ]
        .concat();
        match Cli::try_parse_from(argv).unwrap().command {
            Command::Render(r) => r.into_args(),
            _ => unreachable!("parsed a render command"),
        }
    }

    /// The CPU and the GPU render with the gathered orders by default (the GPU's with the
    /// sky per voxel, `--source grid`, which lights them), and so does a render for a
    /// budget or a target error until the choice sets the sweep's `diffusion` knob
    /// (`render::apply_choice`); an explicit `--diffusion` is parsed as given.
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
