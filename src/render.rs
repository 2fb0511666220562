//! `haze render`: one frame of a baked asset, or a density volume, to an image — by
//! compensated ray marching on the CPU (paper A §5) or the GPU (every stage), or by the
//! reference renderer.

use crate::progress;
use crate::tradeoff::choice;
use crate::tradeoff::pareto::Goal;
use anyhow::{Context, Result, anyhow, bail};
use haze_asset::Asset;
use haze_bake::residual::as_stored;
use haze_fit::{FitOptions, SequenceFitter, SequenceOptions};
use haze_gpu::GpuContext;
use haze_view::diffusion::SolveOptions;
use haze_view::gpu::renderer::{GpuFrame, GpuRenderer, LightingOn};
use haze_view::gpu::volume_pass::Residual;
use haze_view::lighting::single::SourcePoints;
use haze_view::reference::{self, RefOptions};
use haze_view::render::env_pass::{EnvGridOptions, EnvSource};
use haze_view::render::{CrmOptions, MsDiffusion, crm_render};
use haze_view::sh::ExpMethod;
use haze_view::stream::{FrameDecoder, ResidualSlot, StreamFrame};
use haze_view::{Camera, Image, Medium};
use haze_volume::import::{self, ImportOptions};
use haze_volume::{Bbox, Rbf, Volume, rbf};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Everything `haze render` was asked to do.
#[derive(Debug)]
pub struct RenderArgs {
    pub input: PathBuf,
    pub frame: Option<i64>,
    pub out: PathBuf,
    pub width: usize,
    pub height: usize,
    pub eye: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: [f64; 3],
    pub fov: f64,
    pub env: crate::light_args::LightArgs,
    pub sigma_t: f64,
    pub albedo: f64,
    pub g: f64,
    pub sh_order: usize,
    pub multiple: bool,
    pub residual: bool,
    pub slices: f64,
    pub exp: ExpMethod,
    pub source_points: SourcePoints,
    /// Where multiple scattering's diffusion is solved.
    pub diffusion: MsDiffusion,
    /// Where the environment's single scattering comes from.
    pub env_source: EnvSource,
    pub reference: bool,
    /// Choose the knobs from a tradeoff sweep to meet this.
    pub goal: Option<Goal>,
    /// The sweep (`tradeoff.json`); a quick sweep of the input when absent.
    pub tradeoff: Option<PathBuf>,
    /// Stopping rule of the diffusion solve.
    pub solve: SolveOptions,
    /// RBFs of a volume input's fit, and whether it teleports.
    pub rbfs: usize,
    pub teleport: bool,
    /// Render on the GPU (every stage).
    pub gpu: bool,
    /// Where `gpu` solves the diffusion.
    pub lighting: LightingOn,
    pub spp: u32,
    pub exposure: f64,
    pub import: ImportOptions,
}

/// A frame to render: its density, and its RBFs and residual when it has been fitted.
pub(crate) struct FrameData {
    pub(crate) density: Volume,
    pub(crate) rbfs: Vec<Rbf>,
    /// `R` at every voxel (zero for an asset baked without a residual).
    pub(crate) residual: Vec<f32>,
    /// An asset frame's slot in its hash volume, which the GPU looks up itself.
    slot: Option<ResidualSlot>,
    pub(crate) label: String,
}

pub fn run(mut a: RenderArgs) -> Result<()> {
    if let Some(goal) = a.goal {
        choose_knobs(&mut a, goal)?;
    }
    let start = Instant::now();
    let kind = out_kind(&a.out)?;
    let medium = Medium::new(a.sigma_t, a.albedo, a.g).map_err(|e| anyhow!("{e}"))?;
    check_knobs(a.sh_order, a.slices)?;
    let env = a.env.environment()?;
    a.diffusion
        .check()
        .map_err(|e| anyhow!("--diffusion {}: {e}", diffusion_name(a.diffusion)))?;
    if a.gpu && !a.reference && matches!(a.diffusion, MsDiffusion::Grid { .. }) {
        bail!(
            "--diffusion grid runs on the CPU only; use --diffusion orders or centers with --gpu"
        );
    }
    if a.gpu
        && !a.reference
        && a.multiple
        && matches!(a.diffusion, MsDiffusion::Orders { .. })
        && !matches!(a.env_source, EnvSource::Grid(_))
    {
        bail!(
            "--diffusion orders with --gpu is lit by the sky per voxel (--source grid); use --diffusion centers with --source footprint or center"
        );
    }
    // Before any fitting: a machine without an adapter is told at once.
    let gpu = if a.gpu && !a.reference {
        let ctx = GpuContext::new().map_err(|e| anyhow!("--gpu: {e}"))?;
        tracing::info!("GPU: {} ({})", ctx.adapter_name(), ctx.backend());
        Some(ctx)
    } else {
        None
    };
    let frame = load(&a)?;
    let camera = match (a.eye, a.target) {
        (Some(e), Some(t)) => Camera::new(e, t, a.up, a.fov, a.width, a.height),
        (None, None) => {
            let b = smoke_bbox(&frame.density);
            Camera::framing(b.min, b.max, a.fov, a.width, a.height)
        }
        _ => bail!("give both --eye and --target, or neither (to frame the volume)"),
    }
    .map_err(|e| anyhow!("camera: {e}"))?;
    let spinner = progress::spinner(&format!("rendering {}", frame.label));
    let (image, what) = if a.reference {
        let opts = RefOptions {
            spp: a.spp.max(1),
            multiple: a.multiple,
            ..RefOptions::default()
        };
        let (img, noise) =
            reference::render_with_noise(&frame.density, &medium, &env, &camera, &opts);
        let what = format!(
            "reference {} scattering, {} spp{}",
            if a.multiple { "multiple" } else { "single" },
            opts.spp.div_ceil(2) * if opts.spp > 1 { 2 } else { 1 },
            match noise {
                Some(n) => format!(", noise ≈ {:.1} % (two seeds)", 100.0 * n),
                None => String::new(),
            }
        );
        (img, what)
    } else {
        let opts = CrmOptions {
            order: a.sh_order,
            multiple: a.multiple,
            residual: a.residual,
            slices_per_voxel: a.slices,
            exp: a.exp,
            source_points: a.source_points,
            env_source: a.env_source,
            solve: a.solve,
            diffusion: a.diffusion,
            ..CrmOptions::default()
        };
        let (dims, bbox) = (frame.density.dims(), frame.density.bbox());
        let img = if let Some(ctx) = &gpu {
            // Every stage on the GPU (`gpu::renderer`). The
            // residual: an asset frame's hash volume, looked up on the GPU; a fitted
            // volume's dense residual, uploaded.
            let gpu_err = |e| anyhow!("--gpu: {e}");
            let t = Instant::now();
            ctx.time_stages(true);
            let mut renderer = GpuRenderer::new(ctx, env.clone()).map_err(gpu_err)?;
            renderer.set_lighting(a.lighting);
            let setup = t.elapsed().as_secs_f64();
            let residual = match &frame.slot {
                Some(slot) => Residual::Hash(slot),
                None => Residual::Dense(&frame.residual),
            };
            let input = GpuFrame {
                key: 0,
                rbfs: &frame.rbfs,
                residual: Some(residual),
                dims,
                bbox: *bbox,
            };
            let (image, mut stats) = renderer
                .render(ctx, &input, &medium, &camera, &opts)
                .map_err(gpu_err)?;
            let pixels = image.read(ctx).map_err(gpu_err)?;
            renderer.read_solve(ctx, &mut stats).map_err(gpu_err)?;
            stats.crm.setup_seconds += setup;
            tracing::info!("host: {}", stats.crm);
            if !stats.gpu.is_empty() {
                let times: Vec<String> = stats
                    .gpu
                    .iter()
                    .map(|(stage, s)| format!("{stage} {:.2} ms", s * 1e3))
                    .collect();
                tracing::info!("GPU: {}", times.join(", "));
            }
            Image {
                width: camera.width,
                height: camera.height,
                pixels,
            }
        } else {
            let residual = a.residual.then_some(frame.residual.as_slice());
            let (img, stats) = crm_render(
                &frame.rbfs,
                residual,
                dims,
                bbox,
                &medium,
                &env,
                &camera,
                &opts,
            );
            tracing::info!("{stats}");
            img
        };
        let what = format!(
            "compensated ray marching{}, SH order {}, {}{}",
            match &gpu {
                Some(ctx) => format!(
                    " on the GPU ({}; lighting at the centers on the {})",
                    ctx.adapter_name(),
                    match a.lighting.resolve(ctx) {
                        LightingOn::Cpu => "CPU",
                        _ => "GPU",
                    }
                ),
                None => String::new(),
            },
            a.sh_order,
            if a.multiple {
                format!(
                    "single + multiple scattering ({})",
                    diffusion_name(a.diffusion)
                )
            } else {
                "single scattering".into()
            },
            if a.residual { ", residual" } else { "" }
        );
        (img, what)
    };
    spinner.finish_and_clear();
    match kind {
        OutKind::Exr => image.write_exr(&a.out)?,
        OutKind::Png => image.write_png(&a.out, a.exposure)?,
    }
    eprintln!(
        "{}: {}×{}, {}, {:.2} s",
        a.out.display(),
        image.width,
        image.height,
        what,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `--budget-ms`/`--target-error`: picks the setting from the sweep (read, or a quick
/// one run here) and sets the knobs of `a` to it, printing the choice and why. A sweep
/// measured at another picture size has its view-pass times rescaled (with a warning).
fn choose_knobs(a: &mut RenderArgs, goal: Goal) -> Result<()> {
    choice::check_goal(goal)?;
    let (doc, source) = match &a.tradeoff {
        Some(path) => {
            let mut doc = choice::read(path)?;
            if doc.get("kind").and_then(|k| k.as_str()) == Some("fogmap") {
                bail!(
                    "{}: a fogmap's sweep cannot choose a smoke render's knobs",
                    path.display()
                );
            }
            if let Some(warning) = choice::rescale(&mut doc, a.width, a.height)
                .map_err(|e| anyhow!("{}: {e}", path.display()))?
            {
                eprintln!("warning: {}: {warning}", path.display());
            }
            if let Some(warning) = choice::timing_mismatch(&doc, false) {
                eprintln!("warning: {}: {warning}", path.display());
            }
            (doc, path.display().to_string())
        }
        None => {
            let input = crate::tradeoff::SmokeInput {
                lights: a.env.clone(),
                sigma_t: a.sigma_t,
                albedo: a.albedo,
                g: a.g,
                view: crate::tradeoff::smoke::View {
                    eye: a.eye,
                    target: a.target,
                    up: a.up,
                    fov: a.fov,
                    width: a.width,
                    height: a.height,
                },
                import: a.import.clone(),
                timing: crate::tradeoff::smoke::Timing::Cpu,
            };
            // An asset's bake knobs are its own: only the render's are swept.
            let doc = crate::tradeoff::quick_sweep(
                &a.input,
                a.frame,
                &input,
                is_asset(&a.input).then_some(&RENDER_KNOBS[..]),
            )?;
            (doc, format!("a quick sweep of {}", a.input.display()))
        }
    };
    let c = choice::choose(&doc, goal).map_err(|e| anyhow!("{source}: {e}"))?;
    let asset = is_asset(&a.input);
    apply_choice(a, &c, !asset);
    let note = if asset {
        " (RBF count, teleportation and residual error are the asset's own: bake with them to get the measured error)"
    } else {
        ""
    };
    eprintln!("choice from {source}: {}{note}", c.reason);
    Ok(())
}

/// The knobs of a render (the others are the bake's).
const RENDER_KNOBS: [&str; 9] = [
    "sh_order",
    "exp",
    "source",
    "cg_iterations",
    "slices",
    "size",
    "multiple",
    "residual",
    "diffusion",
];

fn is_asset(input: &Path) -> bool {
    input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"))
}

/// Sets the knobs of `a` that choice `c` names; the fit's (RBF count, teleportation)
/// only when `fit` (a volume input, fitted here).
fn apply_choice(a: &mut RenderArgs, c: &choice::Choice, fit: bool) {
    if let Some(v) = choice::f64_knob(c, "sh_order") {
        a.sh_order = v as usize;
    }
    if let Some(v) = choice::str_knob(c, "exp") {
        a.exp = if v == "linear" {
            ExpMethod::OptimalLinear
        } else {
            ExpMethod::ScaleSquareAuto
        };
    }
    if let Some(v) = choice::str_knob(c, "source") {
        // "grid": the environment pass (at the spacing asked for, else the default);
        // "footprint" and "center": paper A's sources at the centers.
        a.source_points = if v == "center" {
            SourcePoints::Center
        } else {
            SourcePoints::Footprint
        };
        if v != "grid" {
            a.env_source = EnvSource::Centers;
        } else if a.env_source == EnvSource::Centers {
            a.env_source = EnvSource::Grid(EnvGridOptions::default());
        }
    }
    if let Some(v) = choice::f64_knob(c, "cg_iterations") {
        a.solve.max_iterations = v as u32;
    }
    if let Some(v) = choice::f64_knob(c, "slices") {
        a.slices = v;
    }
    if let Some(v) = choice::bool_knob(c, "multiple") {
        a.multiple = v;
    }
    if let Some(v) = choice::bool_knob(c, "residual") {
        a.residual = v;
    }
    // The multiple-scattering model the chosen setting was measured with; a sweep
    // without the knob (written before it) timed the centers' diffusion.
    a.diffusion = match choice::str_knob(c, "diffusion") {
        Some(v) => v.parse().unwrap_or(a.diffusion),
        None => MsDiffusion::Centers,
    };
    if let Some(v) = choice::f64_knob(c, "size") {
        a.width = ((a.width as f64 * v).round() as usize).max(8);
        a.height = ((a.height as f64 * v).round() as usize).max(8);
    }
    if fit {
        if let Some(v) = choice::f64_knob(c, "rbfs") {
            a.rbfs = v as usize;
        }
        if let Some(v) = choice::bool_knob(c, "teleport") {
            a.teleport = v;
        }
    }
}

pub(crate) enum OutKind {
    Exr,
    Png,
}

pub(crate) fn out_kind(out: &Path) -> Result<OutKind> {
    match out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("exr") => Ok(OutKind::Exr),
        Some("png") => Ok(OutKind::Png),
        _ => bail!(
            "{}: unknown image type (use .exr for linear radiance or .png, tone-mapped)",
            out.display()
        ),
    }
}

/// Refuses an SH order outside 1..=6 and a slice count per voxel that is not positive.
pub(crate) fn check_knobs(sh_order: usize, slices: f64) -> Result<()> {
    if !(1..=haze_view::sh::MAX_ORDER).contains(&sh_order) {
        bail!(
            "--sh-order {sh_order} must be between 1 and {}",
            haze_view::sh::MAX_ORDER
        );
    }
    if !(slices > 0.0 && slices.is_finite()) {
        bail!("--slices {slices} must be a positive number of slices per voxel");
    }
    Ok(())
}

/// The frame's data: from an asset (RBFs + dequantized residual) or from a volume file
/// (fitted here with 300 RBFs; the residual is then exact).
fn load(a: &RenderArgs) -> Result<FrameData> {
    let is_asset = a
        .input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"));
    if is_asset {
        return load_asset(&a.input, a.frame);
    }
    let path = volume_path(&a.input, a.frame, &a.import)?;
    let density = import::import(&path, &a.import)?;
    let mut rbfs = Vec::new();
    let mut residual = vec![0.0f32; density.len()];
    if !a.reference {
        let spinner =
            progress::spinner(&format!("fitting {} with {} RBFs", path.display(), a.rbfs));
        let opts = SequenceOptions {
            rbfs: a.rbfs,
            fit: FitOptions {
                teleport: a.teleport,
                ..FitOptions::default()
            },
            ..SequenceOptions::default()
        };
        let fit = SequenceFitter::new(opts)
            .fit(&density)
            .map_err(|e| anyhow!("{}: {e}", path.display()))?;
        spinner.finish_and_clear();
        rbfs = as_stored(&fit.rbfs)?;
        let approx = rbf::evaluate_on_grid(density.dims(), density.bbox(), &rbfs);
        for ((r, d), x) in residual.iter_mut().zip(density.data()).zip(&approx) {
            *r = (f64::from(*d) - x) as f32;
        }
    }
    Ok(FrameData {
        density,
        rbfs,
        residual,
        slot: None,
        label: path.display().to_string(),
    })
}

/// The file of frame `frame` of `input` (a volume file, or a directory or glob of
/// numbered frames: its first frame by default).
fn volume_path(input: &Path, frame: Option<i64>, opts: &ImportOptions) -> Result<PathBuf> {
    if frame.is_some() && input.is_file() {
        tracing::warn!("--frame is ignored for a single volume file");
    }
    if input.is_file() {
        return Ok(input.to_path_buf());
    }
    let seq = haze_volume::Sequence::open(input, opts, Default::default())?;
    let i = match frame {
        Some(k) => seq
            .frames()
            .iter()
            .position(|f| f.number == k)
            .ok_or_else(|| anyhow!("{}: no frame {k}", input.display()))?,
        None => 0,
    };
    Ok(seq.frames()[i].path.clone())
}

/// The density of one frame: a volume file's, a sequence's frame, or an asset's
/// reconstruction `max(D̃ + R̂, 0)` (`haze tradeoff`'s input).
pub(crate) fn load_density(
    input: &Path,
    frame: Option<i64>,
    opts: &ImportOptions,
) -> Result<Volume> {
    let is_asset = input
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("haze"));
    if is_asset {
        return Ok(load_asset(input, frame)?.density);
    }
    Ok(import::import(&volume_path(input, frame, opts)?, opts)?)
}

pub(crate) fn load_asset(path: &Path, frame: Option<i64>) -> Result<FrameData> {
    let asset = Asset::open(path)?;
    let numbers = &asset.header().source.frame_numbers;
    let k = match frame {
        Some(f) => numbers
            .iter()
            .position(|&n| n == f)
            .ok_or_else(|| anyhow!("{}: frame {f} is not in the asset", path.display()))?,
        None if numbers.is_empty() => bail!("{}: the asset has no frames", path.display()),
        None => 0,
    };
    let mut decoder = FrameDecoder::new(Arc::new(asset));
    let f = decoder.decode(k)?;
    let g = &decoder.asset().header().grid;
    let dims = g.dims.map(|d| d as usize);
    let bbox = Bbox::new(g.bbox_min, g.bbox_max);
    let (density, residual) = asset_density(dims, bbox, &f)?;
    Ok(FrameData {
        density,
        rbfs: f.rbfs,
        residual,
        slot: f.residual,
        label: format!("{} frame {}", path.display(), f.number),
    })
}

/// A baked frame's density on the asset's `dims` grid over `bbox`, `D = max(D̃ + R, 0)`
/// with the RBFs as stored and the dequantized residual, and that residual (zero when the
/// asset stores none).
pub(crate) fn asset_density(
    dims: [usize; 3],
    bbox: Bbox,
    frame: &StreamFrame,
) -> Result<(Volume, Vec<f32>)> {
    let approx = rbf::evaluate_on_grid(dims, &bbox, &frame.rbfs);
    let residual = match &frame.residual {
        Some(slot) => slot.dense(),
        None => vec![0.0f32; approx.len()],
    };
    let data: Vec<f32> = approx
        .iter()
        .zip(&residual)
        .map(|(a, r)| (a + f64::from(*r)).max(0.0) as f32)
        .collect();
    let density = Volume::new(dims, bbox, data).context("asset grid")?;
    Ok((density, residual))
}

/// The box a default camera frames: the voxels above 1 % of the peak density (the smoke,
/// not the whole domain), or the whole box when the volume is empty.
pub(crate) fn smoke_bbox(density: &Volume) -> Bbox {
    let peak = density.data().iter().fold(0.0f32, |m, &d| m.max(d));
    density
        .occupied_bbox(0.01 * peak)
        .unwrap_or(*density.bbox())
}

/// `--diffusion`'s spelling of `d`.
pub(crate) fn diffusion_name(d: MsDiffusion) -> String {
    match d {
        MsDiffusion::Centers => "centers".into(),
        MsDiffusion::Grid { factor } => format!("grid:{factor}"),
        MsDiffusion::Orders {
            factor: MsDiffusion::AUTO,
            orders,
        } => format!("orders:auto:{orders}"),
        MsDiffusion::Orders { factor, orders } => format!("orders:{factor}:{orders}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{Value, json};

    fn args() -> RenderArgs {
        RenderArgs {
            input: PathBuf::from("smoke.vdb"),
            frame: None,
            out: PathBuf::from("out.png"),
            width: 400,
            height: 300,
            eye: None,
            target: None,
            up: [0.0, 0.0, 1.0],
            fov: 40.0,
            env: crate::light_args::LightArgs {
                env: "sky".into(),
                no_sun_extraction: false,
                sun: Vec::new(),
                light: Vec::new(),
            },
            sigma_t: 4.0,
            albedo: 0.8,
            g: 0.3,
            sh_order: 4,
            multiple: true,
            diffusion: MsDiffusion::DEFAULT,
            env_source: EnvSource::Grid(EnvGridOptions::default()),
            residual: true,
            slices: 2.0,
            exp: ExpMethod::ScaleSquareAuto,
            source_points: SourcePoints::Footprint,
            reference: false,
            goal: None,
            tradeoff: None,
            solve: SolveOptions::default(),
            rbfs: 300,
            teleport: true,
            gpu: false,
            lighting: LightingOn::Auto,
            spp: 64,
            exposure: 1.0,
            import: ImportOptions::default(),
        }
    }

    /// A sweep of the `exp`, `source` and `cg_iterations` knobs where changing `knob` to
    /// `value` alone is the fastest setting: the best (slow, exact), the defaults, and
    /// that change.
    fn front_decided_by(knob: &str, value: Value) -> Value {
        let defaults = json!({"exp": "square", "source": "footprint", "cg_iterations": 20,
                              "diffusion": "orders:auto:4"});
        let best = json!({"exp": "square", "source": "footprint", "cg_iterations": 500,
                          "diffusion": "orders:auto:4"});
        let mut changed = defaults.clone();
        changed[knob] = value;
        json!({
            "kind": "smoke",
            "size": [400, 300],
            "knobs": [
                {"name": "exp", "values": ["square", "linear"], "default": "square", "best": "square"},
                {"name": "source", "values": ["footprint", "center"], "default": "footprint", "best": "footprint"},
                {"name": "cg_iterations", "values": [5, 20, 500], "default": 20, "best": 500},
                {"name": "diffusion", "values": ["centers", "orders:3:3", "orders:auto:4"],
                 "default": "orders:auto:4", "best": "orders:auto:4"},
            ],
            "settings": [
                {"knobs": best, "ms": {"render": 300.0, "view": 100.0}, "error": 0.0},
                {"knobs": defaults, "ms": {"render": 100.0, "view": 100.0}, "error": 0.01},
                {"knobs": changed, "ms": {"render": 50.0, "view": 50.0}, "error": 0.02},
            ],
        })
    }

    /// Each of the exp variant, the source placement, the CG iterations and the
    /// multiple-scattering model, when it is the knob that meets the budget, is chosen and
    /// reaches the render's options; a sweep without the `diffusion` knob (which timed
    /// the centers' diffusion) renders with the centers.
    #[test]
    fn exp_source_cg_and_diffusion_choices_reach_the_render() {
        type Applied = fn(&RenderArgs) -> bool;
        let cases: [(&str, Value, Applied); 5] = [
            ("exp", json!("linear"), |a| {
                a.exp == ExpMethod::OptimalLinear
            }),
            ("source", json!("center"), |a| {
                a.source_points == SourcePoints::Center
            }),
            ("cg_iterations", json!(5), |a| a.solve.max_iterations == 5),
            ("diffusion", json!("centers"), |a| {
                a.diffusion == MsDiffusion::Centers
            }),
            ("diffusion", json!("orders:3:3"), |a| {
                a.diffusion
                    == MsDiffusion::Orders {
                        factor: 3,
                        orders: 3,
                    }
            }),
        ];
        for (knob, value, applied) in cases {
            let doc = front_decided_by(knob, value.clone());
            let mut a = args();
            assert!(!applied(&a), "{knob}: already at the choice");
            // Within 60 ms only the change is; within 150 ms the defaults are better.
            let c = choice::choose(&doc, Goal::BudgetMs(60.0)).unwrap();
            assert_eq!(c.knobs[knob], value);
            apply_choice(&mut a, &c, true);
            assert!(applied(&a), "{knob}: {a:?}");
            assert!(c.reason.contains("50.0 ms at 2.00 %"), "{}", c.reason);
            let mut a = args();
            let c = choice::choose(&doc, Goal::BudgetMs(150.0)).unwrap();
            apply_choice(&mut a, &c, true);
            assert!(!applied(&a), "{knob}: {a:?}");
            // A target of 1.5 % is met by the defaults alone.
            let c = choice::choose(&doc, Goal::TargetError(0.015)).unwrap();
            assert_ne!(c.knobs[knob], value);
        }
        let mut old = front_decided_by("exp", json!("linear"));
        for s in old["settings"].as_array_mut().unwrap() {
            s["knobs"].as_object_mut().unwrap().remove("diffusion");
        }
        let mut a = args();
        apply_choice(
            &mut a,
            &choice::choose(&old, Goal::BudgetMs(150.0)).unwrap(),
            true,
        );
        assert_eq!(a.diffusion, MsDiffusion::Centers);
        // The reason names the model in words.
        let c = choice::choose(
            &front_decided_by("diffusion", json!("orders:3:3")),
            Goal::BudgetMs(60.0),
        )
        .unwrap();
        assert!(
            c.reason.contains(
                "multiple scattering by explicit orders (3 orders on cells of 3³ voxels)"
            ),
            "{}",
            c.reason
        );
    }
}
