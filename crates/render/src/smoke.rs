//! A smoke render: one frame of a baked asset, or a density volume, to an image — by
//! compensated ray marching on the CPU (paper A §5) or the GPU (every stage), or by the
//! reference renderer.

use crate::check::{self, ErrorEstimate};
use crate::frame::{self, FitKnobs};
use crate::lights::{GroundChoice, Lights};
use crate::progress;
use anyhow::{Result, anyhow, bail};
use haze_core::number::{rounded, shown};
use haze_gpu::GpuContext;
use haze_view::diffusion::SolveOptions;
use haze_view::gpu::GridBuffer;
use haze_view::gpu::renderer::{GpuFrame, GpuRenderer, LightingOn};
use haze_view::gpu::volume_pass::Residual;
use haze_view::lighting::single::SourcePoints;
use haze_view::reference::{self, RefOptions};
use haze_view::render::env_pass::EnvSource;
use haze_view::render::{CrmOptions, MsDiffusion, crm_render, supersample};
use haze_view::sh::ExpMethod;
use haze_view::{Camera, Image, Medium};
use haze_volume::Volume;
use haze_volume::import::ImportOptions;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Everything a smoke render is asked to do.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub input: PathBuf,
    pub frame: Option<i64>,
    pub out: PathBuf,
    pub width: usize,
    pub height: usize,
    pub eye: Option<[f64; 3]>,
    pub target: Option<[f64; 3]>,
    pub up: [f64; 3],
    pub fov: f64,
    pub env: Lights,
    pub sigma_t: f64,
    pub albedo: f64,
    pub g: f64,
    pub sh_order: usize,
    pub multiple: bool,
    pub residual: bool,
    pub slices: f64,
    /// `CrmOptions::pixel_reuse` (the CPU's view pass).
    pub pixel_reuse: f64,
    pub exp: ExpMethod,
    pub source_points: SourcePoints,
    /// Where multiple scattering's diffusion is solved.
    pub diffusion: MsDiffusion,
    /// Where the environment's single scattering comes from.
    pub env_source: EnvSource,
    pub reference: bool,
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
    /// Pixels of the error check against the reference (0: none; [`crate::check`]).
    pub check: usize,
    /// The error the render was asked to meet (rel RMS): the check warns above it.
    pub target_error: Option<f64>,
    pub exposure: f64,
    /// The tone curve of a PNG output.
    pub tone: haze_core::ToneMap,
    pub import: ImportOptions,
    /// The grid the fast renderer lights on ([`Supersample`]).
    pub supersample: Supersample,
    /// Whether a ground shows under the smoke ([`GroundChoice`]).
    pub ground: GroundChoice,
    /// The fast renderer's lighting detail, `(0, 1]` (`CrmOptions::detail`).
    pub detail: f64,
}

impl RenderOptions {
    /// The render of `input`'s first frame into `out` with every default of `haze render
    /// INPUT --out OUT`: 400 × 300, the camera framing the smoke, the built-in sky, σt 4,
    /// albedo 0.8, g 0.3, the fast renderer on the CPU with its default knobs.
    pub fn new(input: impl Into<PathBuf>, out: impl Into<PathBuf>) -> RenderOptions {
        let crm = CrmOptions::default();
        RenderOptions {
            input: input.into(),
            frame: None,
            out: out.into(),
            width: 400,
            height: 300,
            eye: None,
            target: None,
            up: [0.0, 0.0, 1.0],
            fov: 40.0,
            env: Lights::default(),
            sigma_t: 4.0,
            albedo: 0.8,
            g: 0.3,
            sh_order: crm.order,
            multiple: true,
            residual: true,
            slices: crm.slices_per_voxel,
            pixel_reuse: crm.pixel_reuse,
            exp: crm.exp,
            source_points: crm.source_points,
            diffusion: MsDiffusion::DEFAULT,
            env_source: crm.env_source,
            reference: false,
            solve: crm.solve,
            rbfs: 300,
            teleport: true,
            gpu: false,
            lighting: LightingOn::Auto,
            spp: 64,
            check: 0,
            target_error: None,
            exposure: 1.0,
            tone: haze_core::ToneMap::Filmic,
            import: ImportOptions::default(),
            supersample: Supersample::Auto,
            ground: GroundChoice::Auto,
            detail: crm.detail,
        }
    }
}

/// How much finer than the volume's voxels the fast renderer lights the smoke
/// (`haze_view::render::supersample`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Supersample {
    /// Fine enough that a voxel is at most `TAU_PER_VOXEL` optical depths thick, within
    /// the memory budget.
    Auto,
    /// `n` times finer per axis (1: the volume's own voxels).
    Times(usize),
}

impl std::str::FromStr for Supersample {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        if s == "auto" {
            return Ok(Supersample::Auto);
        }
        match s.parse::<usize>() {
            Ok(n) if (1..=supersample::MAX_FACTOR).contains(&n) => Ok(Supersample::Times(n)),
            _ => Err(format!(
                "{s}: expected auto or a whole number from 1 to {}",
                supersample::MAX_FACTOR
            )),
        }
    }
}

/// Renders the frame `a` names and writes the image, printing one line about it; returns
/// the error check's estimate ([`RenderOptions::check`]), if one was made.
pub fn render(a: RenderOptions) -> Result<Option<ErrorEstimate>> {
    let start = Instant::now();
    let kind = out_kind(&a.out)?;
    check_exposure(a.exposure)?;
    let Rendered {
        image,
        what,
        estimate,
    } = render_image(&a)?;
    match kind {
        OutKind::Exr => image.write_exr(&a.out)?,
        OutKind::Png => image.write_png(&a.out, a.exposure, a.tone)?,
    }
    crate::say!(
        "{}: {}×{}, {}, {:.2} s",
        a.out.display(),
        image.width,
        image.height,
        what,
        start.elapsed().as_secs_f64()
    );
    Ok(estimate)
}

/// A rendered frame, not yet written.
#[derive(Debug)]
pub struct Rendered {
    pub image: Image,
    /// What rendered it (renderer, knobs, the check's estimate), for a summary line.
    pub what: String,
    /// The error check's estimate ([`RenderOptions::check`]), if one was made.
    pub estimate: Option<ErrorEstimate>,
}

/// Renders the frame `a` names (`a.out` only names the image in warnings).
pub fn render_image(a: &RenderOptions) -> Result<Rendered> {
    if a.check > MAX_CHECK_PIXELS {
        bail!(
            "--check {} must be at most {MAX_CHECK_PIXELS} pixels",
            a.check
        );
    }
    if a.reference && !(1..=MAX_SPP).contains(&a.spp) {
        bail!("--spp {} must be between 1 and {MAX_SPP}", a.spp);
    }
    let medium = Medium::new(a.sigma_t, a.albedo, a.g).map_err(|e| anyhow!("{e}"))?;
    check_knobs(a.sh_order, a.slices)?;
    if !(0.0..=MAX_PIXEL_REUSE).contains(&a.pixel_reuse) {
        bail!(
            "--pixel-reuse {} must be between 0 (every pixel marched) and {MAX_PIXEL_REUSE}",
            shown(a.pixel_reuse)
        );
    }
    CrmOptions::check_detail(a.detail).map_err(|e| anyhow!("--lighting-detail: {e}"))?;
    // The reference lights with a map whole (the truth); the fast renderers with its
    // concentrated light split off into suns.
    let env = if a.reference {
        a.env.environment_whole()?
    } else {
        a.env.environment()?
    };
    a.diffusion
        .check()
        .map_err(|e| anyhow!("--diffusion {}: {e}", diffusion_name(a.diffusion)))?;
    if (a.gpu || a.reference) && a.pixel_reuse > 0.0 {
        bail!(
            "--pixel-reuse takes pixels in the CPU's fast view pass only; leave out --gpu and --reference"
        );
    }
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
    let fit = (!a.reference).then_some(FitKnobs {
        rbfs: a.rbfs,
        teleport: a.teleport,
    });
    let frame = frame::load(&a.input, a.frame, &a.import, fit)?;
    let camera = match (a.eye, a.target) {
        (Some(e), Some(t)) => Camera::new(e, t, a.up, a.fov, a.width, a.height),
        (None, None) => {
            let b = frame::smoke_bbox(&frame.density);
            Camera::framing(b.min, b.max, a.fov, a.width, a.height)
        }
        _ => bail!("give both --eye and --target, or neither (to frame the volume)"),
    }
    .map_err(|e| anyhow!("camera: {e}"))?;
    let ground = a.ground.ground(&a.env, frame.density.bbox().min[2]);
    // The smoke above a ground does not see the lights below it.
    let env = match ground.and_then(|g| g.hiding(&env)) {
        Some((seen, said)) => {
            for line in said {
                tracing::warn!("{}: {line}", frame.label);
            }
            seen
        }
        None => env,
    };
    if !a.reference
        && let Some(w) = haze_view::sh::phase_cut_warning(a.g, a.sh_order)
    {
        tracing::warn!("{}: {w}", frame.label);
    }
    if !a.reference {
        for (i, light) in env.points.iter().enumerate() {
            use haze_view::render::near_light;
            let share = near_light::near_share(&frame.density, a.sigma_t, light.position);
            match near_light::describe(i + 1, light.position, share) {
                (w, true) => tracing::warn!("{}: {w}", frame.label),
                (said, false) => tracing::info!("{said}"),
            }
        }
    }
    // The path tracer shows its rows with an ETA (it can take minutes); the others spin.
    let spinner = (!a.reference).then(|| progress::spinner(&format!("rendering {}", frame.label)));
    let (image, what) = if a.reference {
        let opts = RefOptions {
            spp: a.spp,
            multiple: a.multiple,
            ground,
            ..RefOptions::default()
        };
        let bar = progress::rows(
            reference::rows_to_render(&camera, opts.spp),
            &format!("path tracing {}", frame.label),
        );
        let (img, noise) = reference::render_with_noise_rows(
            &frame.density,
            &medium,
            &env,
            &camera,
            &opts,
            &|| bar.inc(1),
        );
        bar.finish_and_clear();
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
            pixel_reuse: a.pixel_reuse,
            exp: a.exp,
            source_points: a.source_points,
            env_source: a.env_source,
            solve: a.solve,
            diffusion: a.diffusion,
            ground,
            detail: a.detail,
            ..CrmOptions::default()
        };
        let (dims, bbox) = (frame.density.dims(), frame.density.bbox());
        let (n, tau) = refinement(
            a.supersample,
            &frame.density,
            a.sigma_t,
            gpu.as_ref(),
            &frame.label,
        )?;
        // The environment grid's nodes on the voxel centers where the smoke is thick.
        let thick = opts.for_smoke(tau / n as f64);
        if let (Some(was), Some(now)) = (opts.env_grid(), thick.env_grid())
            && was.spacing != now.spacing
        {
            tracing::info!(
                "{}: voxels {} optical depths thick: the environment grid's spacing {} instead of {} voxels (--env-grid-spacing sets it)",
                frame.label,
                rounded(tau / n as f64, 2),
                shown(now.spacing),
                shown(was.spacing)
            );
        }
        let opts = thick;
        warn_below_detail_floor(&opts, tau / n as f64, &frame.label);
        // Lit on the grid `n` times finer: the RBFs are evaluated at its voxel centers,
        // the residual resampled to them (`supersample` module docs).
        let refined = (n > 1).then(|| supersample::refine(&frame.residual, dims, bbox, n));
        let dense = refined.as_deref().unwrap_or(&frame.residual);
        let dims = supersample::fine_dims(dims, n);
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
                Some(slot) if n == 1 => Residual::Hash(slot),
                _ => Residual::Dense(dense),
            };
            let input = GpuFrame {
                key: 0,
                rbfs: &frame.rbfs,
                residual: Some(residual),
                dims,
                bbox: *bbox,
            };
            // The orders' cells of one voxel where the CPU would take them on this smoke.
            let opts = opts.for_gpu_cells(n, tau / n as f64, renderer.orders_cells(ctx), || {
                Some(&frame.density)
            });
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
            let residual = a.residual.then_some(dense);
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
            "compensated ray marching{}{}, SH order {}, {}{}",
            match &gpu {
                Some(ctx) => format!(
                    " on the GPU ({}; lighting on the {})",
                    ctx.adapter_name(),
                    match a.lighting.resolve(ctx) {
                        LightingOn::Cpu => "CPU",
                        _ => "GPU",
                    }
                ),
                None => String::new(),
            },
            if n > 1 {
                format!(
                    " on a {n}× finer grid ({} optical depths per voxel)",
                    rounded(tau, 1)
                )
            } else {
                String::new()
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
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    image.check_finite(&what)?;
    let (checked, estimate) = check_error(a, &image, &frame.density, &medium, ground, &camera)?;
    let what = match checked {
        Some(e) => format!("{what}, {e}"),
        None => what,
    };
    Ok(Rendered {
        image,
        what,
        estimate,
    })
}

/// The refinement the fast renderer lights `density` on (`choice`; σt `sigma_t`) and the
/// optical depth of its voxels ([`supersample::tau_per_voxel`]), warning when even the
/// refined voxels are thicker than [`supersample::TAU_PER_VOXEL`]: the picture is then too
/// dark (BENCHMARKS.md "Thick voxels").
fn refinement(
    choice: Supersample,
    density: &Volume,
    sigma_t: f64,
    gpu: Option<&GpuContext>,
    label: &str,
) -> Result<(usize, f64)> {
    let tau = supersample::tau_per_voxel(density, sigma_t);
    let dims = density.dims();
    let budget = gpu.map_or(usize::MAX, GridBuffer::max_voxels);
    let n = match choice {
        Supersample::Auto => supersample::factor_for(tau, dims, budget).0,
        Supersample::Times(n) if supersample::fits(dims, n, budget) => n,
        Supersample::Times(n) => bail!(
            "--supersample {n}: {label}'s {} × {} × {} voxels refined {n}× exceed the {:.1} M voxels the renderer allows{}",
            dims[0],
            dims[1],
            dims[2],
            supersample::MAX_FINE_VOXELS.min(budget) as f64 / 1048576.0,
            if gpu.is_some() { " on this GPU" } else { "" }
        ),
    };
    let fine = tau / n as f64;
    if !supersample::thin_enough(fine) {
        let advice = if n < supersample::MAX_FACTOR && choice != Supersample::Auto {
            "--supersample auto refines further"
        } else {
            "no finer grid fits: a lower --sigma-t, smaller voxels, or --reference"
        };
        tracing::warn!(
            "{label}: the smoke is {} optical depths per voxel (σt × density × voxel side){}: the fast renderer lights each voxel at its center, so thick voxels come out too dark (about 12 % at 4 on a plume's single scattering); {advice}",
            rounded(tau, 1),
            if n > 1 {
                format!(", {} on the {n}× finer grid", rounded(fine, 1))
            } else {
                String::new()
            }
        );
    }
    Ok((n, tau))
}

/// Warns when `--lighting-detail` lies below [`CrmOptions::detail_floor`] for lit voxels
/// `tau` optical depths thick: the environment grid's cells are then thicker than
/// [`haze_view::render::MAX_CELL_TAU`], where a lower detail's error grew to several
/// points (BENCHMARKS.md "Viewer playback: the lighting's detail"). Returns whether it
/// warned.
fn warn_below_detail_floor(opts: &CrmOptions, tau: f64, label: &str) -> bool {
    let floor = opts.detail_floor(tau);
    if opts.detail >= floor {
        return false;
    }
    tracing::warn!(
        "{label}: --lighting-detail {} makes the environment grid's cells {:.2} optical depths across (voxels {tau:.2} thick); on held-out smoke cells over {} added up to 7 points of error: use at least {:.2}",
        opts.detail,
        opts.env_cell_tau(tau),
        haze_view::render::MAX_CELL_TAU,
        (floor * 100.0).ceil() / 100.0
    );
    true
}

/// The most pixels `--check` compares (each costs 128 reference paths).
pub const MAX_CHECK_PIXELS: usize = 65_536;

/// The render's estimate of its own error (`--check`), warned about above
/// `--target-error`: what the summary line says of it (nothing without a check) and the
/// estimate (none without a check or where no pixel shows smoke).
fn check_error(
    a: &RenderOptions,
    image: &Image,
    density: &haze_volume::Volume,
    medium: &Medium,
    ground: Option<haze_view::ground::Ground>,
    camera: &Camera,
) -> Result<(Option<String>, Option<ErrorEstimate>)> {
    if a.check == 0 || a.reference {
        return Ok((None, None));
    }
    let env = a.env.environment_whole()?;
    // The lights the ground hides, as the render saw them (`render`).
    let env = ground
        .and_then(|g| g.hiding(&env))
        .map_or(env, |(seen, _)| seen);
    let spinner = progress::spinner(&format!(
        "checking {} pixels against the reference",
        a.check
    ));
    let est = check::estimate(
        image,
        density,
        medium,
        &env,
        ground,
        camera,
        a.multiple,
        a.check,
        check::CHECK_SAMPLES,
    );
    spinner.finish_and_clear();
    let Some(est) = est else {
        return Ok((Some("no smoke pixel to check".into()), None));
    };
    if let Some(target) = a.target_error
        && let Some(surely) = est.above(target)
    {
        tracing::warn!(
            "{}: estimated error {:.1} % ± {:.1} % {} the target {:.1} %{}",
            a.out.display(),
            100.0 * est.error,
            100.0 * est.spread,
            if surely { "is above" } else { "may be above" },
            100.0 * target,
            if surely {
                ""
            } else {
                " (a larger --check narrows it)"
            }
        );
    }
    Ok((Some(est.to_string()), Some(est)))
}

/// The image types a render writes.
#[derive(Clone, Copy, Debug)]
pub enum OutKind {
    Exr,
    Png,
}

/// The image type of `out` by its extension.
pub fn out_kind(out: &Path) -> Result<OutKind> {
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

/// The most samples per pixel `--reference` takes (a 400 × 300 picture at this many is
/// hours of path tracing already).
pub const MAX_SPP: u32 = 1 << 16;

/// The largest exposure a PNG is tone-mapped with: beyond it a radiance of 1e-6 is
/// already white.
pub const MAX_EXPOSURE: f64 = 1e6;

/// Refuses an exposure that is not a finite number in (0, 1e6] (NaN would make every
/// pixel black, 0 every pixel black, infinity every lit pixel white).
pub fn check_exposure(exposure: f64) -> Result<()> {
    if !(exposure > 0.0 && exposure <= MAX_EXPOSURE) {
        bail!(
            "--exposure {} must be a number in (0, {MAX_EXPOSURE:e}]",
            shown(exposure)
        );
    }
    Ok(())
}

/// The most view-pass slices per voxel: 2 is the paper's, 8 is already within rounding of
/// the exact march; beyond 64 only the time grows.
pub const MAX_SLICES: f64 = 64.0;

/// Refuses an SH order outside 1..=6 and a slice count per voxel outside (0, 64].
/// The largest `--pixel-reuse`: a pixel's mean of its neighbours then within a tenth of
/// the picture's light by the reuse's test (`haze_view::render::pixel_reuse`).
pub const MAX_PIXEL_REUSE: f64 = 0.1;

pub fn check_knobs(sh_order: usize, slices: f64) -> Result<()> {
    if !(1..=haze_view::sh::MAX_ORDER).contains(&sh_order) {
        bail!(
            "--sh-order {sh_order} must be between 1 and {}",
            haze_view::sh::MAX_ORDER
        );
    }
    if !(slices > 0.0 && slices <= MAX_SLICES) {
        bail!(
            "--slices {} must be in (0, {MAX_SLICES}] slices per voxel",
            shown(slices)
        );
    }
    Ok(())
}

/// `--diffusion`'s spelling of `d`.
pub fn diffusion_name(d: MsDiffusion) -> String {
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
