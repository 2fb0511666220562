//! The fast renderer: source radiance at the RBF centers (single scattering in SH, plus
//! multiple scattering by diffusion), then compensated ray marching (paper A §5).

pub mod crm;
pub mod env_pass;
pub mod env_sweep;
pub mod frame_light;
pub mod grid_diffusion;
pub mod ground_shadow;
pub mod lights_pass;
pub mod near_light;
pub mod occupancy;
pub mod peak_rule;
pub mod pixel_reuse;
pub mod plane_sweep;
pub mod ray_planes;
pub mod separable;
pub mod shell;
pub mod supersample;

use crate::diffusion::{DiffusionSolver, Operators, SolveOptions, Sources};
use crate::lighting::direct::add_light_moments;
use crate::lighting::single::moments;
use crate::lighting::single::{RgbSh, ShKit, SourcePoints, single_scattering};
use crate::sh::{self, ExpMethod};
use crate::{Camera, Environment, Image, Medium};
use env_pass::{EnvDepths, EnvGridOptions, EnvSource};
use frame_light::{FrameInput, FrameLight, Kept};
use grid_diffusion::GridSolveOptions;
use haze_volume::{Bbox, Rbf};
use std::time::Instant;

/// Knobs of the fast renderer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CrmOptions {
    /// SH order (bands), 1..=6.
    pub order: usize,
    /// Add multiple scattering (diffusion) to the single-scattering source.
    pub multiple: bool,
    /// Put the residual back in the ray march (compensation).
    pub residual: bool,
    /// View-pass slices per voxel (paper: 2, i.e. Δu = half a voxel).
    pub slices_per_voxel: f64,
    /// The CPU's view pass takes the pixels between its even rows and columns from their
    /// neighbours where the picture's second differences bound that within this share of
    /// it ([`pixel_reuse`]); 0 (the default) marches every pixel. The GPU's view pass
    /// marches every pixel whatever it says.
    pub pixel_reuse: f64,
    /// How `exp*` is computed for the transmittance vectors (`BENCHMARKS.md`, "SH
    /// exponentiation": the optimal linear one is exact at order 2 but breaks down for
    /// thick smoke at higher orders).
    pub exp: ExpMethod,
    /// Where each RBF's transmittance is taken (`lighting::single` module docs): the
    /// single scattering at the centers the diffusion starts from, and the image's with
    /// [`EnvSource::Centers`].
    pub source_points: SourcePoints,
    /// Where the environment's single scattering in the image comes from: the centers
    /// (paper A) or the grid of the transmitted environment per voxel
    /// ([`env_pass`]).
    pub env_source: EnvSource,
    /// Stopping rule of the diffusion solve (the CG iterations knob).
    pub solve: SolveOptions,
    /// Where the diffusion of multiple scattering is solved.
    pub diffusion: MsDiffusion,
    /// Stopping rule of the grid's diffusion solve ([`MsDiffusion::Grid`]).
    pub grid_solve: GridSolveOptions,
    /// A ground under the smoke, seen by the view pass ([`crate::ground`]); none by
    /// default.
    pub ground: Option<crate::ground::Ground>,
    /// The lighting's detail, in `(0, 1]` ([`CrmOptions::check_detail`]): 1 lights as
    /// the other knobs say (the default); below 1 the environment pass's grid is
    /// coarser, its spacing divided by `detail`, and on the CPU its depths taken along
    /// planes of rays ([`CrmOptions::env_grid`]), and the
    /// automatic cells of the explicit orders larger, their work budget times
    /// `detail⁴` and their side at least `2/detail` voxels
    /// ([`grid_diffusion::auto_grid`]) and their count `⌈K·detail⌉`, at least four
    /// ([`grid_diffusion::orders_at_detail`], CPU and GPU), and on the CPU the suns' shadows walked
    /// along planes of rays parallel to each sun instead of marched per voxel
    /// ([`ray_planes::RayPlanes`]), the rays [`lights_pass::SUN_SPACING`] voxels apart at
    /// `1/SUN_SPACING` and below ([`lights_pass::lights_pass_at`]); at
    /// 2/3 and below the environment grid also takes fewer directions
    /// ([`CrmOptions::env_grid`]), and so does the explicit orders' first where HG's peak
    /// allows ([`grid_diffusion::first_theta`], decision 0083: every order then marches
    /// the same rays, kept once). A
    /// new frame's lighting then costs about a third per step of 0.75, 0.5, 0.35; what it
    /// costs in error is measured in BENCHMARKS.md ("Viewer playback: the lighting's
    /// detail"). The viewer lowers it while playback cannot keep up.
    pub detail: f64,
    /// Whether the explicit orders' automatic cells may be one voxel where the smoke is
    /// thick ([`grid_diffusion::auto_grid`]: at full detail, within the gathers' budget;
    /// about 9× the multiple scattering's time on cells of 2³; on the GPU, which cannot
    /// measure the smoke, where its caller resolves them: [`CrmOptions::for_gpu_cells`]).
    /// On by default: `haze render` and the viewer's stills. Off for the viewer's playback
    /// frames, where the step up to full detail would otherwise cost
    /// tens of times the step below it.
    pub thick_cells: bool,
}

/// Whether [`CrmOptions::for_gpu_cells`] has said that the device's buffers kept the GPU
/// from the CPU's one-voxel cells (once a process).
static SMALL_BUFFERS_SAID: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// The fewest latitudes per hemisphere a lower [`CrmOptions::detail`] leaves the
/// environment grid's direction rule (2: 4 × 8 directions, enough for the SH of order 4
/// it projects on: the Gauss–Legendre latitudes integrate `cos θ` polynomials to degree 3
/// per hemisphere exactly, the 8 azimuths `e^{imφ}` up to |m| = 7).
pub const MIN_DETAIL_THETA: usize = 2;

/// The optical depth across one cell of the environment grid that a lower
/// [`CrmOptions::detail`] may reach. On 16 held-out sky cases (BENCHMARKS.md "Viewer
/// playback: the lighting's detail") a detail whose cells stayed within half an optical
/// depth added at most 1.5 points of error against the path tracer; cells of 0.75–1.25
/// optical depths added up to 7, and 20 at detail 0.25 on the thickest smoke.
pub const MAX_CELL_TAU: f64 = 0.5;

/// A direction rule of `theta` latitudes per hemisphere at the lighting's `detail`
/// (`(0, 1]`): `⌈theta·detail⌉`, at least [`MIN_DETAIL_THETA`], at most `theta` (a rule
/// already below the minimum is kept). The environment grid's ([`CrmOptions::env_grid`])
/// and, where HG's peak allows, the explicit orders' first
/// ([`grid_diffusion::first_theta`]).
pub fn theta_at_detail(theta: usize, detail: f64) -> usize {
    ((theta as f64 * detail).ceil() as usize)
        .max(MIN_DETAIL_THETA)
        .min(theta)
}

impl CrmOptions {
    /// The environment pass's grid options at this detail (`None` with
    /// [`EnvSource::Centers`]): the spacing divided by [`CrmOptions::detail`], and the
    /// direction rule's latitudes per hemisphere times the detail, rounded up, at least
    /// [`MIN_DETAIL_THETA`] (the default 3 — 72 directions — stays at 0.75 and becomes 2
    /// — 32 directions — at 0.5 and below; a rule already below the minimum is kept).
    /// Fewer directions cost 0–0.4 points of error at detail 0.5 on the held-out sky
    /// cases of BENCHMARKS.md ("Viewer playback: the lighting's detail") and take about
    /// a third off the environment grid's sweeps. Below full detail the default sweep's
    /// depths come instead along planes of rays per direction ([`EnvDepths::Planes`],
    /// decision 0085: the CPU's; the GPU keeps its sweep); a march asked for stays.
    pub fn env_grid(&self) -> Option<EnvGridOptions> {
        let detail = detail_or_one(self.detail);
        match self.env_source {
            EnvSource::Grid(g) => Some(EnvGridOptions {
                spacing: g.spacing / detail,
                theta: theta_at_detail(g.theta, detail),
                depths: match g.depths {
                    EnvDepths::Sweep if detail < 1.0 => EnvDepths::Planes,
                    d => d,
                },
                ..g
            }),
            EnvSource::Centers => None,
        }
    }

    /// These options for smoke whose lit voxels are `tau` optical depths across: the
    /// environment grid's nodes on the voxel centers where its cells would be too thick
    /// ([`EnvGridOptions::for_smoke`]; the spacing at full detail, which
    /// [`CrmOptions::detail`] then divides). The renderers' callers apply it once they know
    /// the grid they light (`haze render`, the viewer).
    pub fn for_smoke(self, tau: f64) -> Self {
        match self.env_source {
            EnvSource::Grid(g) => CrmOptions {
                env_source: EnvSource::Grid(g.for_smoke(tau)),
                ..self
            },
            EnvSource::Centers => self,
        }
    }

    /// These options with the explicit orders' automatic cells resolved to one voxel where
    /// the CPU's automatic choice takes one voxel ([`grid_diffusion::one_voxel_cells`] of
    /// the smoke `density`, lit on a grid `n` times finer per axis whose voxels are `tau`
    /// optical depths thick): `MsDiffusion::Orders` at factor 1. For the GPU's gathered
    /// orders, which cannot measure the smoke and otherwise take their own automatic cells
    /// (`gpu::orders::auto_factor`: 2³, larger where the device's buffers need it), so that
    /// `--gpu` lights thick smoke as `--cpu` does. Where the CPU's budget grows its cells
    /// past one voxel, the automatic cells are kept; where only the device's buffers
    /// (`max_cells`, `gpu::orders::max_cells`) cannot hold a cell a voxel, too, with one
    /// warning a process. Unchanged below full detail, without [`CrmOptions::thick_cells`] or multiple scattering, for a given factor and
    /// for thin smoke; `density` is asked for only when the rest holds (it may cost an
    /// evaluation of the frame), and `None` leaves the options as they are.
    pub fn for_gpu_cells<'a>(
        self,
        n: usize,
        tau: f64,
        max_cells: usize,
        density: impl FnOnce() -> Option<&'a haze_volume::Volume>,
    ) -> Self {
        let MsDiffusion::Orders { factor, orders } = self.diffusion else {
            return self;
        };
        let asks = self.multiple
            && self.thick_cells
            && factor == MsDiffusion::AUTO
            && detail_or_one(self.detail) >= 1.0
            && grid_diffusion::thick_for_cells(tau);
        if !asks {
            return self;
        }
        let Some(d) = density() else {
            return self;
        };
        if !grid_diffusion::one_voxel_cells(d, n, tau) {
            return self;
        }
        let voxels = d
            .dims()
            .iter()
            .product::<usize>()
            .saturating_mul(n.saturating_pow(3));
        if voxels > max_cells {
            if !SMALL_BUFFERS_SAID.swap(true, std::sync::atomic::Ordering::Relaxed) {
                tracing::warn!(
                    "the smoke is {} optical depths a voxel: the CPU would gather its scattering orders on cells of one voxel, but the GPU's buffers hold {max_cells} cells and the grid has {voxels} voxels, so they keep cells of 2³ (about 1–2.5 points further from the path tracer on thick held-out plumes; --lighting cpu or --cpu lights them on one voxel)",
                    haze_core::number::shown((tau * 100.0).round() / 100.0)
                );
            }
            return self;
        }
        CrmOptions {
            diffusion: MsDiffusion::Orders { factor: 1, orders },
            ..self
        }
    }

    /// `Err` with a one-line reason when [`CrmOptions::detail`] is outside `(0, 1]`.
    pub fn check_detail(detail: f64) -> Result<(), String> {
        if detail > 0.0 && detail <= 1.0 {
            Ok(())
        } else {
            Err(format!(
                "the lighting detail {} must be above 0 and at most 1",
                haze_core::number::shown(detail)
            ))
        }
    }

    /// The lowest [`CrmOptions::detail`] at which the environment grid's cells stay
    /// within [`MAX_CELL_TAU`] optical depths across, for smoke whose lit voxels are
    /// `tau` optical depths thick ([`supersample::tau_per_voxel`] on the grid the
    /// renderer lights): a cell is `spacing / detail` voxels, so the floor is
    /// `spacing · tau / MAX_CELL_TAU`, at most 1. The spacing is this options' grid's
    /// (the default grid's with [`EnvSource::Centers`], whose orders' cells follow the
    /// same detail). 1 for a `tau` that is not a positive finite number, where no bound
    /// can be given; positive for every positive `tau`.
    pub fn detail_floor(&self, tau: f64) -> f64 {
        let d = self.floor_spacing() * tau / MAX_CELL_TAU;
        if d.is_nan() || d <= 0.0 || !tau.is_finite() {
            return 1.0;
        }
        d.min(1.0)
    }

    /// The optical depth across one cell of the environment grid at this detail, for
    /// lit voxels `tau` thick: `spacing · tau / detail` (the spacing as in
    /// [`CrmOptions::detail_floor`]).
    pub fn env_cell_tau(&self, tau: f64) -> f64 {
        self.floor_spacing() * tau / detail_or_one(self.detail)
    }

    /// The environment grid's spacing in voxels at full detail that the floor bounds.
    fn floor_spacing(&self) -> f64 {
        match self.env_source {
            EnvSource::Grid(g) => g.spacing,
            EnvSource::Centers => EnvGridOptions::default().spacing,
        }
    }
}

/// `detail` where it is valid, else 1 (the renderer never divides by a bad one; the
/// command lines refuse it with [`CrmOptions::check_detail`]).
pub fn detail_or_one(detail: f64) -> f64 {
    if CrmOptions::check_detail(detail).is_ok() {
        detail
    } else {
        1.0
    }
}

/// Where multiple scattering's diffusion is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MsDiffusion {
    /// On the RBF basis, collocated at the centers (paper A §5.4, `crate::diffusion`),
    /// with the escape-probability vacuum correction; its source joins the centers'.
    Centers,
    /// By finite volumes on the volume pass's density averaged over `factor³` voxels,
    /// the first collision kept per cell (`crate::render::grid_diffusion`); added per voxel
    /// after the lights pass. CPU only.
    Grid { factor: usize },
    /// On the same coarse grid, the first `orders` scattering orders gathered explicitly
    /// from every cell (the first along 72 directions, up to 288 for a narrow phase
    /// function's peak: `crate::render::grid_diffusion::gather_theta`; below full
    /// detail `crate::render::grid_diffusion::first_theta`) and the rest by
    /// the grid's diffusion
    /// (`crate::render::grid_diffusion::explicit_media_radiance`; on the GPU
    /// `crate::gpu::orders`, lit by the environment pass's grid); `factor`
    /// [`MsDiffusion::AUTO`] chooses it from the amount of smoke
    /// (`crate::render::grid_diffusion::auto_grid`).
    Orders { factor: usize, orders: usize },
}

impl MsDiffusion {
    /// The cell size of [`MsDiffusion::Orders`] chosen per frame from the smoke.
    pub const AUTO: usize = 0;

    /// `haze render`'s choice on the CPU and the GPU, and the viewer's (BENCHMARKS.md,
    /// "Multiple scattering: explicit orders"; six orders since decision 0079, "Six
    /// explicit orders"): six orders gathered on cells of 2³
    /// voxels (on the CPU one voxel where the voxels are over a third of an optical depth
    /// thick, `grid_diffusion::MAX_ORDERS_CELL_TAU`), larger cells where the smoke would
    /// cost more than `grid_diffusion::GATHER_BUDGET`.
    pub const DEFAULT: MsDiffusion = MsDiffusion::Orders {
        factor: MsDiffusion::AUTO,
        orders: MsDiffusion::DEFAULT_ORDERS,
    };

    /// The explicit orders gathered where `orders[:F]` leaves their number out: six
    /// (decision 0079: on thick g 0.8 smoke the diffusion tail after four was dark deep in
    /// dense front-lit columns, 4.6–5.3 % off the path tracer; after six, 4.2–4.7 %).
    pub const DEFAULT_ORDERS: usize = 6;
}

impl MsDiffusion {
    /// `Err` naming the field when the factor is outside 1–16 (or [`MsDiffusion::AUTO`]
    /// for the orders) or the number of orders outside 1–8.
    pub fn check(&self) -> Result<(), String> {
        match *self {
            MsDiffusion::Orders { orders, .. } if !(1..=8).contains(&orders) => {
                Err(format!("{orders} orders: gather 1 to 8 orders explicitly"))
            }
            MsDiffusion::Orders {
                factor: MsDiffusion::AUTO,
                ..
            }
            | MsDiffusion::Centers => Ok(()),
            MsDiffusion::Grid { factor } | MsDiffusion::Orders { factor, .. }
                if !(1..=16).contains(&factor) =>
            {
                Err(format!(
                    "the factor {factor} must be 1 to 16 (voxels per cell side)"
                ))
            }
            _ => Ok(()),
        }
    }
}

impl std::str::FromStr for MsDiffusion {
    type Err = String;

    /// `centers`, `grid[:F]` or `orders[:F[:K]]` (F voxels per cell side, default 2 for
    /// `grid`, `auto` ([`MsDiffusion::AUTO`], the default) or a number for `orders`; K
    /// gathered orders, default [`MsDiffusion::DEFAULT_ORDERS`]); the ranges are
    /// [`MsDiffusion::check`]'s.
    fn from_str(s: &str) -> Result<MsDiffusion, String> {
        let mut parts = s.split(':');
        let kind = parts.next().unwrap_or_default();
        // `auto` only where the field may be chosen automatically.
        let mut number = |what: &str, default: usize, auto: bool| match parts.next() {
            None => Ok(default),
            Some("auto") if auto => Ok(MsDiffusion::AUTO),
            Some(v) => match v.parse::<usize>() {
                Ok(0) if auto => Err(format!("{s}: {what} must be at least 1 (or auto)")),
                Ok(n) => Ok(n),
                Err(_) => Err(format!("{s}: {what} must be a whole number")),
            },
        };
        let out = match kind {
            "centers" => MsDiffusion::Centers,
            "grid" => MsDiffusion::Grid {
                factor: number("the factor", 2, false)?,
            },
            "orders" => MsDiffusion::Orders {
                factor: number("the factor", MsDiffusion::AUTO, true)?,
                orders: number("the number of orders", MsDiffusion::DEFAULT_ORDERS, false)?,
            },
            _ => return Err(format!("{s}: expected centers, grid[:F] or orders[:F[:K]]")),
        };
        match parts.next() {
            None => Ok(out),
            Some(_) => Err(format!("{s}: too many fields")),
        }
    }
}

impl Default for CrmOptions {
    fn default() -> Self {
        CrmOptions {
            order: 4,
            multiple: true,
            residual: true,
            slices_per_voxel: 2.0,
            pixel_reuse: 0.0,
            exp: ExpMethod::ScaleSquareAuto,
            source_points: SourcePoints::Footprint,
            env_source: EnvSource::Grid(EnvGridOptions::default()),
            solve: SolveOptions::default(),
            diffusion: MsDiffusion::Centers,
            grid_solve: GridSolveOptions::default(),
            ground: None,
            detail: 1.0,
            thick_cells: true,
        }
    }
}

/// Where the time went, and how the diffusion solve ended.
#[derive(Clone, Debug, Default)]
pub struct CrmStats {
    /// Building the SH tables of the order and projecting the environment (once per
    /// order and environment in a viewer).
    pub setup_seconds: f64,
    pub single_seconds: f64,
    pub multiple_seconds: f64,
    pub volume_seconds: f64,
    /// The environment pass (its grid marched, then added per voxel).
    pub env_seconds: f64,
    /// The lights pass (suns and point lights per voxel, shadows marched).
    pub lights_seconds: f64,
    pub view_seconds: f64,
    /// Pixels the view pass took from their neighbours ([`CrmOptions::pixel_reuse`]).
    pub reused_pixels: usize,
    pub cg_iterations: u32,
    pub cg_residual: f64,
    /// Voxels per cell side of the gathered orders (0 without them).
    pub ms_factor: usize,
    /// How many orders were gathered (`grid_diffusion::orders_at_detail`; 0 without them).
    pub ms_orders: usize,
    /// Their `grid_diffusion::gather_work` on that grid (0 on the GPU, which does not
    /// count it).
    pub ms_work: f64,
}

impl std::fmt::Display for CrmStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "setup {:.3} s, single scattering {:.3} s, multiple {:.3} s ({}{} CG iterations, residual {:.2e}), volume pass {:.3} s, environment pass {:.3} s, lights pass {:.3} s, view pass {:.3} s",
            self.setup_seconds,
            self.single_seconds,
            self.multiple_seconds,
            match (self.ms_factor, self.ms_orders) {
                (0, _) => String::new(),
                (f, k) => format!(
                    "cells of {f}³ voxels, {}{}",
                    match k {
                        0 => String::new(),
                        k => format!("{k} orders, "),
                    },
                    match self.ms_work {
                        w if w > 0.0 => format!("work {w:.2e}, "),
                        _ => String::new(),
                    }
                ),
            },
            self.cg_iterations,
            self.cg_residual,
            self.volume_seconds,
            self.env_seconds,
            self.lights_seconds,
            self.view_seconds
        )?;
        if self.reused_pixels > 0 {
            write!(f, " ({} pixels from their neighbours)", self.reused_pixels)?;
        }
        Ok(())
    }
}

/// The view pass of `grids` (slice thickness `du`) as `opts` asks for it: over its ground
/// lit by `env` if it has one, its pixels reused at [`CrmOptions::pixel_reuse`].
pub fn view_pass_as(
    grids: &crm::VolumeGrids,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    du: f64,
    opts: &CrmOptions,
) -> (Vec<[f32; 3]>, pixel_reuse::ReuseCount) {
    let ground = opts.ground.map(|g| g.lit(env));
    crm::view_pass_reused(
        grids,
        medium,
        env,
        camera,
        du,
        ground.as_ref(),
        opts.pixel_reuse,
    )
}

/// Source radiance `J̃ = J̃ss + J̃ms` at every center (RGB SH of `kit.order`, functions of
/// the viewing direction), with the diffusion solve warm-started by `solver`: `J̃ss` of
/// the environment's projection `light`; the suns and point lights of `env` feed the
/// diffusion only (`lighting::direct`), their single scattering is added per voxel by
/// [`lights_pass::lights_pass`]. With [`EnvSource::Grid`] the centers' single scattering
/// feeds the diffusion but is left out of `J̃` ([`env_pass::env_pass`] adds it per voxel).
#[allow(clippy::too_many_arguments)]
pub fn source_radiance(
    kit: &ShKit,
    rbfs: &[Rbf],
    medium: &Medium,
    light: &RgbSh,
    env: &Environment,
    opts: &CrmOptions,
    solver: &mut DiffusionSolver,
    stats: &mut CrmStats,
) -> Vec<RgbSh> {
    let grid = matches!(opts.env_source, EnvSource::Grid(_));
    // Nothing at the centers: the environment pass lights the voxels, and the grid's
    // diffusions take their own sources.
    if grid && !(opts.multiple && opts.diffusion == MsDiffusion::Centers) {
        let n2 = sh::count(kit.order);
        return vec![[vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]]; rbfs.len()];
    }
    let t = Instant::now();
    let ss = single_scattering(kit, rbfs, medium, light, opts.exp, opts.source_points);
    let mut source = ss.source;
    stats.single_seconds = t.elapsed().as_secs_f64();
    let single = grid.then(|| source.clone());
    if opts.multiple && opts.diffusion == MsDiffusion::Centers {
        let t = Instant::now();
        add_multiple_scattering(
            rbfs,
            medium,
            env,
            &mut source,
            ss.escape,
            opts,
            solver,
            stats,
        );
        stats.multiple_seconds = t.elapsed().as_secs_f64();
    }
    if let Some(single) = single {
        // J̃ms alone: the environment pass lights each voxel instead.
        for (j, s) in source.iter_mut().zip(&single) {
            for (jc, sc) in j.iter_mut().zip(s) {
                for (v, w) in jc.iter_mut().zip(sc) {
                    *v -= w;
                }
            }
        }
    }
    source
}

/// Adds `J̃ms` to the single-scattering source `source` at the centers of `rbfs` (whose
/// escape probabilities are `escape`): the diffusion solve (§5.4, warm-started by
/// `solver`; its iterations and residual go to `stats`) with the direct light of `env`'s
/// suns and point lights added to its sources, then the multiple-scattering source as
/// bands 0–1, turned from the direction of propagation to the viewing direction. Nothing
/// to add without RBFs.
#[allow(clippy::too_many_arguments)]
pub fn add_multiple_scattering(
    rbfs: &[Rbf],
    medium: &Medium,
    env: &Environment,
    source: &mut [RgbSh],
    escape: Vec<f64>,
    opts: &CrmOptions,
    solver: &mut DiffusionSolver,
    stats: &mut CrmStats,
) {
    if rbfs.is_empty() {
        return;
    }
    let mut sources = Sources {
        escape,
        ..moments(source)
    };
    add_light_moments(&mut sources, rbfs, env, medium);
    let ops = Operators::new(rbfs);
    let sol = solver.solve_with(&ops, rbfs, medium, &sources, &opts.solve);
    stats.cg_iterations = sol.iterations;
    stats.cg_residual = sol.residual;
    let ms = ops.ms_source_sh(medium, &sources, &sol.l0);
    for (j, m) in source.iter_mut().zip(&ms) {
        for c in 0..3 {
            // Propagation → viewing direction: band 1 changes sign.
            let add = [m[c][0], -m[c][1], -m[c][2], -m[c][3]];
            for (k, v) in add.iter().enumerate().take(j[c].len()) {
                j[c][k] += v;
            }
        }
    }
}

/// The source radiance at the centers of a frame's RBFs (RGB SH of `opts.order`, functions
/// of the viewing direction): the SH tables of the order, the environment projected, then
/// [`source_radiance`] with a fresh diffusion solver; the first stages of [`crm_grids`],
/// and what a volume pass on the GPU takes. The stats hold the time so far.
pub fn crm_sources(
    rbfs: &[Rbf],
    medium: &Medium,
    env: &Environment,
    opts: &CrmOptions,
) -> (Vec<RgbSh>, CrmStats) {
    let t = Instant::now();
    let kit = ShKit::new(opts.order);
    let light = sh::project_env(env, opts.order);
    let mut stats = CrmStats {
        setup_seconds: t.elapsed().as_secs_f64(),
        ..CrmStats::default()
    };
    let mut solver = DiffusionSolver::new();
    let source = source_radiance(
        &kit,
        rbfs,
        medium,
        &light,
        env,
        opts,
        &mut solver,
        &mut stats,
    );
    (source, stats)
}

/// The view pass's slice thickness `Δu` for `opts` (world units): the default half voxel
/// at the paper's 2 slices per voxel.
pub fn slice_thickness(dims: [usize; 3], bbox: &Bbox, opts: &CrmOptions) -> f64 {
    crm::default_slice(dims, bbox) * 2.0 / opts.slices_per_voxel.max(1e-3)
}

/// The volume pass of a frame (RBFs over a `dims` grid on `bbox`, optional residual per
/// voxel) after the source radiance at the centers ([`crm_sources`]): the grids a view
/// pass renders, the slice thickness `Δu` of `opts` (world units), and the time so far.
#[allow(clippy::too_many_arguments)]
pub fn crm_grids(
    rbfs: &[Rbf],
    residual: Option<&[f32]>,
    dims: [usize; 3],
    bbox: &Bbox,
    medium: &Medium,
    env: &Environment,
    eye: [f64; 3],
    opts: &CrmOptions,
) -> (crm::VolumeGrids, f64, CrmStats) {
    let frame = FrameInput {
        rbfs,
        residual,
        dims,
        bbox,
    };
    let t = Instant::now();
    let kit = ShKit::new(opts.order);
    let light = sh::project_env(env, opts.order);
    let setup_seconds = t.elapsed().as_secs_f64();
    let mut solver = DiffusionSolver::new();
    let kept = Kept {
        kit: &kit,
        projected: &light,
        env_grid: None,
    };
    let (_, grids, stats) = FrameLight::new(&frame, medium, env, eye, opts, kept, &mut solver);
    let stats = CrmStats {
        setup_seconds,
        ..stats
    };
    (grids, slice_thickness(dims, bbox, opts), stats)
}

/// The centers' single scattering (RGB SH, viewing direction) that the grid's diffusion
/// starts from: `source` itself with [`EnvSource::Centers`]; with the environment pass,
/// which leaves it out of the image's source, computed again as paper A's.
fn centers_single(
    rbfs: &[Rbf],
    medium: &Medium,
    env: &Environment,
    opts: &CrmOptions,
    source: Vec<RgbSh>,
) -> Vec<RgbSh> {
    match opts.env_source {
        EnvSource::Grid(_) => {
            let paper_a = CrmOptions {
                env_source: EnvSource::Centers,
                ..*opts
            };
            crm_sources(rbfs, medium, env, &paper_a).0
        }
        EnvSource::Centers => source,
    }
}

/// Renders a frame (RBFs over a `dims` grid on `bbox`, optional residual per voxel) by
/// compensated ray marching: [`crm_grids`], then [`crm::view_pass`].
#[allow(clippy::too_many_arguments)]
pub fn crm_render(
    rbfs: &[Rbf],
    residual: Option<&[f32]>,
    dims: [usize; 3],
    bbox: &Bbox,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    opts: &CrmOptions,
) -> (Image, CrmStats) {
    let (grids, du, mut stats) =
        crm_grids(rbfs, residual, dims, bbox, medium, env, camera.eye, opts);
    let t = Instant::now();
    let (pixels, reuse) = view_pass_as(&grids, medium, env, camera, du, opts);
    stats.reused_pixels = reuse.reused;
    stats.view_seconds = t.elapsed().as_secs_f64();
    (
        Image {
            width: camera.width,
            height: camera.height,
            pixels,
        },
        stats,
    )
}

#[cfg(test)]
mod tests {
    use super::{
        CrmOptions, EnvDepths, EnvGridOptions, EnvSource, MAX_CELL_TAU, MIN_DETAIL_THETA,
        MsDiffusion, detail_or_one, env_pass,
    };

    /// `orders` chooses its cell size unless given one; `auto` only where allowed.
    #[test]
    fn diffusion_spellings() {
        let p = |s: &str| s.parse::<MsDiffusion>().and_then(|d| d.check().map(|()| d));
        let orders = |factor, orders| Ok(MsDiffusion::Orders { factor, orders });
        assert_eq!(p("orders"), orders(MsDiffusion::AUTO, 6));
        assert_eq!(p("orders:auto:5"), orders(MsDiffusion::AUTO, 5));
        assert_eq!(p("orders:3"), orders(3, 6));
        assert_eq!(p("orders:2:3"), orders(2, 3));
        assert_eq!(Ok(MsDiffusion::DEFAULT), orders(MsDiffusion::AUTO, 6));
        for bad in [
            "orders:0",
            "orders:auto:0",
            "orders:17",
            "grid:auto",
            "grid:0",
        ] {
            assert!(p(bad).is_err(), "{bad}");
        }
        // An automatic factor with a bad count names the count.
        for bad in ["orders:auto:0", "orders:auto:9"] {
            assert!(p(bad).unwrap_err().contains("orders"), "{bad}");
        }
        assert_eq!(p("grid"), Ok(MsDiffusion::Grid { factor: 2 }));
    }

    /// The GPU's cells resolved to one voxel where the CPU's automatic choice takes one:
    /// thick smoke within the budget at full detail, the lit grid within the device's
    /// cells; every other case unchanged, and the density not asked for where nothing
    /// else holds.
    #[test]
    fn the_gpu_takes_one_voxel_where_the_cpu_does() {
        use haze_volume::{Bbox, Volume};
        let n = 16usize;
        let blob = Volume::new(
            [n; 3],
            Bbox::new([0.0; 3], [1.0; 3]),
            (0..n.pow(3))
                .map(|i| if i % 2 == 0 { 1.0 } else { 0.0 })
                .collect(),
        )
        .unwrap();
        let voxels = n.pow(3);
        let factor = |opts: CrmOptions, tau: f64, refine: usize, cells: usize| match opts
            .for_gpu_cells(refine, tau, cells, || Some(&blob))
            .diffusion
        {
            MsDiffusion::Orders { factor, orders } => {
                assert_eq!(orders, MsDiffusion::DEFAULT_ORDERS);
                factor
            }
            other => panic!("{other:?}"),
        };
        let auto = MsDiffusion::AUTO;
        let base = CrmOptions {
            multiple: true,
            diffusion: MsDiffusion::DEFAULT,
            ..CrmOptions::default()
        };
        assert_eq!(factor(base, 0.5, 1, voxels), 1);
        assert_eq!(factor(base, 0.5, 2, 8 * voxels), 1);
        // Too many cells for the device, thin smoke, a lower detail, thick cells off,
        // no multiple scattering, a given factor.
        assert_eq!(factor(base, 0.5, 1, voxels - 1), auto);
        assert_eq!(factor(base, 0.5, 2, 8 * voxels - 1), auto);
        assert_eq!(factor(base, 0.3, 1, voxels), auto);
        assert_eq!(factor(base, f64::NAN, 1, voxels), auto);
        let with = |f: fn(&mut CrmOptions)| {
            let mut o = base;
            f(&mut o);
            o
        };
        assert_eq!(factor(with(|o| o.detail = 0.5), 0.5, 1, voxels), auto);
        assert_eq!(
            factor(with(|o| o.thick_cells = false), 0.5, 1, voxels),
            auto
        );
        assert_eq!(factor(with(|o| o.multiple = false), 0.5, 1, voxels), auto);
        let given = with(|o| {
            o.diffusion = MsDiffusion::Orders {
                factor: 3,
                orders: MsDiffusion::DEFAULT_ORDERS,
            }
        });
        assert_eq!(factor(given, 0.5, 1, voxels), 3);
        // Nothing asks: the density is not evaluated.
        let thin = base.for_gpu_cells(1, 0.1, voxels, || panic!("asked for the density"));
        assert_eq!(thin.diffusion, base.diffusion);
        // No density (it could not be evaluated): unchanged.
        assert_eq!(
            base.for_gpu_cells(1, 0.5, voxels, || None).diffusion,
            base.diffusion
        );
    }

    /// The detail divides the environment grid's spacing; a bad one is refused by the
    /// check and lights as detail 1; without the grid there is nothing to scale.
    #[test]
    fn the_detail_widens_the_environment_grid() {
        let opts = |detail| CrmOptions {
            detail,
            ..CrmOptions::default()
        };
        let base = EnvGridOptions::default();
        assert_eq!(opts(1.0).env_grid(), Some(base));
        let half = opts(0.5).env_grid().unwrap();
        assert_eq!(half.spacing, 2.0 * base.spacing);
        assert_eq!((half.theta, half.depths), (2, EnvDepths::Planes));
        // A march asked for is kept at any detail.
        let march = CrmOptions {
            env_source: EnvSource::Grid(EnvGridOptions {
                depths: EnvDepths::March,
                ..base
            }),
            ..opts(0.5)
        };
        assert_eq!(march.env_grid().unwrap().depths, EnvDepths::March);
        // The directions follow the detail, rounded up, never below the minimum nor
        // above the rule given.
        let theta = |detail, theta| {
            CrmOptions {
                env_source: EnvSource::Grid(EnvGridOptions { theta, ..base }),
                ..opts(detail)
            }
            .env_grid()
            .unwrap()
            .theta
        };
        assert_eq!(base.theta, 3);
        assert_eq!(theta(0.75, 3), 3);
        assert_eq!(theta(0.25, 3), MIN_DETAIL_THETA);
        assert_eq!(theta(0.5, 8), 4);
        assert_eq!(theta(0.6, 8), 5);
        assert_eq!(theta(1.0, 8), 8);
        assert_eq!(theta(0.25, 1), 1);
        for bad in [0.0, -0.5, 1.5, f64::NAN, f64::INFINITY] {
            assert!(CrmOptions::check_detail(bad).is_err(), "{bad}");
            assert_eq!(detail_or_one(bad), 1.0);
            assert_eq!(opts(bad).env_grid(), Some(base));
        }
        for good in [1e-9, 0.25, 1.0] {
            assert_eq!(CrmOptions::check_detail(good), Ok(()));
        }
        let centers = CrmOptions {
            env_source: EnvSource::Centers,
            ..opts(0.5)
        };
        assert_eq!(centers.env_grid(), None);
    }

    /// Thick smoke moves the environment grid's nodes onto the voxel centers: from the
    /// `tau` where a default cell passes [`MAX_CELL_TAU`] (1/3), not before; a finer
    /// spacing, a user's spacing (`follow_smoke` off), paper A's centers and a `tau` that
    /// is not a positive number stay as they are; infinitely thick smoke is thick; the
    /// rule is idempotent, and the detail floor then follows the finer grid.
    #[test]
    fn thick_smoke_puts_the_environment_grid_on_the_voxel_centers() {
        let base = EnvGridOptions::default();
        let spacing = |g: EnvGridOptions, tau| g.for_smoke(tau).spacing;
        let edge = MAX_CELL_TAU / base.spacing;
        for tau in [0.0, 1e-9, 0.1, edge, -1.0, f64::NAN, f64::NEG_INFINITY] {
            assert_eq!(spacing(base, tau), base.spacing, "{tau}");
        }
        for tau in [edge * (1.0 + 1e-9), 0.45, 4.0, f64::INFINITY] {
            assert_eq!(spacing(base, tau), env_pass::THICK_SPACING, "{tau}");
            let once = base.for_smoke(tau);
            assert_eq!(once.for_smoke(tau), once, "{tau}");
        }
        let fine = EnvGridOptions {
            spacing: 0.5,
            ..base
        };
        assert_eq!(spacing(fine, 4.0), 0.5);
        let given = EnvGridOptions {
            follow_smoke: false,
            ..base
        };
        assert_eq!(spacing(given, 4.0), base.spacing);
        let centers = CrmOptions {
            env_source: EnvSource::Centers,
            ..CrmOptions::default()
        };
        assert_eq!(centers.for_smoke(4.0).env_source, EnvSource::Centers);
        let thick = CrmOptions::default().for_smoke(0.45);
        assert_eq!(
            thick.env_grid().map(|g| g.spacing),
            Some(env_pass::THICK_SPACING)
        );
        // Cells of one voxel at 0.45 optical depths reach the bound at detail 0.9.
        assert!((thick.detail_floor(0.45) - 0.45 / MAX_CELL_TAU).abs() < 1e-12);
        assert_eq!(CrmOptions::default().detail_floor(0.45), 1.0);
    }

    /// The detail's floor: at the floor a cell of the environment grid (`spacing /
    /// detail` voxels) is exactly [`MAX_CELL_TAU`] optical depths across; thick smoke
    /// keeps full detail, a bad or zero `tau` gives no bound (1), and a tiny `tau` a
    /// tiny positive floor (a valid detail).
    #[test]
    fn detail_floor_bounds_the_cells_optical_depth() {
        let opts = CrmOptions::default();
        let spacing = EnvGridOptions::default().spacing;
        for tau in [1e-6, 0.05, 0.1, 0.2] {
            let d = opts.detail_floor(tau);
            assert!((spacing / d * tau - MAX_CELL_TAU).abs() < 1e-12, "{tau}");
            let at = CrmOptions { detail: d, ..opts };
            assert!((at.env_cell_tau(tau) - MAX_CELL_TAU).abs() < 1e-12, "{tau}");
            assert_eq!(CrmOptions::check_detail(d), Ok(()));
        }
        assert_eq!(opts.detail_floor(0.5), 1.0);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(opts.detail_floor(bad), 1.0, "{bad}");
        }
        // A user's coarser grid reaches the bound at a higher detail.
        let coarse = CrmOptions {
            env_source: EnvSource::Grid(EnvGridOptions {
                spacing: 2.0 * spacing,
                ..EnvGridOptions::default()
            }),
            ..CrmOptions::default()
        };
        assert!((coarse.detail_floor(0.05) - 2.0 * opts.detail_floor(0.05)).abs() < 1e-15);
        let centers = CrmOptions {
            env_source: EnvSource::Centers,
            ..CrmOptions::default()
        };
        assert_eq!(centers.detail_floor(0.05), opts.detail_floor(0.05));
    }
}
