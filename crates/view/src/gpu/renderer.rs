//! Frames on the GPU (paper A §5.6): single scattering at the centers, multiple scattering,
//! the volume pass and the view pass, chained — the GPU twin of
//! [`crate::render::crm_render`], frame after frame.
//!
//! Stages and where they run:
//! 1. **Single scattering** at the RBF centers: GPU
//!    ([`SingleScatteringPass`], `shaders/single_scattering.wgsl`).
//! 2. **Multiple scattering** on the centers ([`MsDiffusion::Centers`]): GPU ([`DiffusionPass`], `shaders/diffusion.wgsl`: the
//!    system, CGLS and `J̃ms` added to the sources in place, in one compute pass), from
//!    the frame's geometric [`Operators`], computed on the CPU once per frame and kept
//!    while the frame is unchanged (a new light or medium reuses them); the solve starts
//!    from the previous frame's solution when the RBF count is unchanged.
//!    The suns' and point lights' direct light at the centers enters the diffusion as
//!    source moments computed on the host ([`add_light_moments`], closed form through the
//!    RBFs) and uploaded with the sources ([`DirectBuffer`]).
//! 3. **Volume pass**: GPU ([`VolumePass::run_on`], reading the sources where stage 1
//!    or 2 left them).
//! 4. **Environment pass** (with [`EnvSource::Grid`]): GPU ([`EnvPass::run_on`], in
//!    place on the grids): the distant environment's single scattering per voxel from
//!    the grid of its transmitted SH; the centers then carry `J̃ms` only (on the GPU the
//!    single scattering is copied before the diffusion and subtracted after it,
//!    [`RemoveSingle`]).
//! 5. **Lights pass**: GPU ([`LightsPass::run_on`], in place on the volume pass's grids):
//!    the suns and point lights per voxel, shadows marched through the grid's density;
//!    nothing runs without lights.
//! 6. **Explicit orders** (with [`MsDiffusion::Orders`], which takes the environment
//!    pass's grid): GPU ([`OrdersPass`], in place on the grids): the first scattering
//!    orders gathered on the coarse grid from the environment pass's `S_lm`, the point
//!    lights and the suns, the diffusion after them, `J_ms` added per voxel; the centers
//!    then carry nothing. Their cells are kept while the grids' key without the eye holds
//!    (a camera move adds them to the voxels again, [`OrdersPass::apply`]); a new albedo,
//!    `g` or light gathers again but keeps the environment pass's grid.
//! 7. **View pass**: GPU ([`ViewPass::dispatch`]); the image stays on the GPU until
//!    [`ImageBuffer::read`].
//!
//! On an adapter that is a CPU (lavapipe) stages 1–6 run on the CPU instead
//! ([`LightingOn`], [`HostGrids`]: their `f64` twins on every core, the grids then
//! uploaded), and the GPU runs the view pass.
//!
//! **Reuse** (the paper's): the sources at the centers depend on the frame, the medium,
//! the lighting and the SH knobs, not on the camera, so a new camera reuses them; the
//! grids depend on the eye only through the viewing direction in `J̃(u, d)`, which the
//! isotropic phase function (`g = 0`: every band above 0 of `J̃ss` and `J̃ms` is zero, and
//! the lights pass's phase `p(s·d)` is 1) removes, so a new camera with `g = 0` reuses the
//! grids too and runs the view pass only. The lights belong to the environment, whose
//! generation is part of both keys: new lights recompute the sources and the grids.
//! The environment pass's grid of `S_lm` ([`EnvShadow`], every direction's depth at
//! every node, by the sweep) has a key of its own, `EnvGridKey` —
//! the frame, the residual toggle, σt, the distant environment, the order and the grid's
//! settings — so rebuilt volume grids (a camera move with `g ≠ 0`, a new albedo or `g`,
//! new lights) reuse it and only its per-voxel evaluation runs again. The lights pass's
//! shadow volume ([`LightShadow`], a march toward each light from every voxel) is kept
//! likewise while the frame, the residual toggle, σt and the lights' directions and
//! positions hold.
//! A frame is known by the `key` its caller gives ([`GpuFrame`]).

use super::diffusion::{DiffusionPass, DiffusionStats, DirectBuffer, OperatorBuffers};
use super::env_pass::{EnvPass, EnvShadow, RemoveSingle};
use super::host_grids::HostGrids;
use super::lights_pass::{LightShadow, LightsPass};
use super::orders::{MediaBuffer, OrdersPass};
use super::single_scattering::SingleScatteringPass;
use super::view_pass::{EnvBuffer, ImageBuffer, ViewPass};
use super::volume_pass::{Residual, VolumePass};
use super::{GridBuffer, SourceBuffer};
use crate::diffusion::{Operators, Sources};
use crate::lighting::direct::add_light_moments;
use crate::lighting::single::{RgbSh, ShKit};
use crate::render::env_pass::{EnvGridOptions, EnvSource};
use crate::render::{CrmOptions, CrmStats, MsDiffusion, slice_thickness};
use crate::sh;
use crate::{Camera, Environment, Medium};
use haze_gpu::{GpuContext, GpuError};
use haze_volume::{Bbox, Rbf};
use std::time::Instant;

/// One frame to render.
#[derive(Clone, Copy, Debug)]
pub struct GpuFrame<'a> {
    /// Identifies the frame's RBFs, residual and grid: equal keys promise equal frames
    /// (e.g. the frame index within one asset).
    pub key: u64,
    pub rbfs: &'a [Rbf],
    pub residual: Option<Residual<'a>>,
    pub dims: [usize; 3],
    pub bbox: Bbox,
}

/// What a frame could take from the previous one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reuse {
    /// Everything was computed.
    #[default]
    Nothing,
    /// The sources at the centers (a new camera with an anisotropic phase function).
    Sources,
    /// The volume-pass grids (a new camera with `g = 0`): the view pass only.
    Grids,
}

/// Where the renderer computes a frame's light: the stages before the view pass, which
/// always runs on the GPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightingOn {
    /// The GPU, unless the adapter is a CPU (a software rasterizer such as Mesa's
    /// lavapipe), where the CPU's own twins, on all its cores, are several times faster
    /// (`BENCHMARKS.md`, "GPU frame time").
    #[default]
    Auto,
    /// The CPU ([`HostGrids`]: [`crate::render::crm_grids`]'s stages, `f64`), the grids
    /// then uploaded.
    Cpu,
    /// The GPU (the passes of the module docs), in `f32`.
    Gpu,
}

impl LightingOn {
    /// `Cpu` or `Gpu` for the adapter of `ctx`.
    pub fn resolve(self, ctx: &GpuContext) -> LightingOn {
        match self {
            LightingOn::Auto if ctx.is_cpu_adapter() => LightingOn::Cpu,
            LightingOn::Auto => LightingOn::Gpu,
            on => on,
        }
    }
}

/// Where a frame's time went.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// Host seconds per stage, as [`crate::render::crm_render`] reports them. The GPU
    /// stages are submitted, not waited for (the multiple scattering's host time is the
    /// frame's operators, when new, and the submission — or, on the CPU, the twins'
    /// computation); see `gpu` for device times. The diffusion's CG iterations and
    /// residual are set only by a CPU solve: [`GpuRenderer::read_solve`] reads them
    /// wherever it ran.
    pub crm: CrmStats,
    /// The diffusion ran for this frame (else it had none, or reused the sources).
    pub solved: bool,
    /// Host seconds computing the frame's diffusion operators (part of
    /// `crm.multiple_seconds`; 0 when they were the last frame's).
    pub operators_seconds: f64,
    pub reuse: Reuse,
    /// GPU seconds per pass (timestamp queries), when [`GpuContext::time_stages`] is on
    /// and the device has them.
    pub gpu: Vec<(&'static str, f64)>,
}

/// The sources' dependencies besides the frame (the CPU's light, [`HostGrids`], is kept
/// by the same key with the view pass's slices left out).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SourceKey {
    pub(super) frame: u64,
    pub(super) lighting: u64,
    pub(super) medium: Medium,
    pub(super) opts: CrmOptions,
}

/// Where the last multiple-scattering solve ran.
#[derive(Clone, Copy, Debug)]
enum LastSolve {
    /// The multiple scattering on the CPU ([`HostGrids`]), and how it ended.
    Cpu(DiffusionStats),
    /// The centers' diffusion on the GPU ([`DiffusionPass`]).
    Gpu,
    /// The diffusion after the gathered orders on the GPU ([`OrdersPass::diffuse`]), to
    /// this relative residual.
    Orders(f64),
}

/// What the environment pass's grid of `S_lm` ([`EnvShadow`]) depends on: the density
/// `D = D̃ + R` (the frame and whether the residual is in), σt, the distant environment
/// (its generation), the SH order and the grid's settings — not the camera, the albedo
/// or `g`, which enter only at the per-voxel evaluation ([`EnvPass::apply`]); the CPU's
/// grid ([`HostGrids`]) is kept by the same key.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct EnvGridKey {
    pub(super) frame: u64,
    pub(super) residual: bool,
    pub(super) sigma_t: f64,
    pub(super) distant: u64,
    pub(super) order: usize,
    pub(super) grid: EnvGridOptions,
}

/// A GPU renderer of frames, keeping what carries from one frame to the next: the SH
/// tables of the order, the projected lighting, the frame's diffusion operators, the
/// diffusion's warm start, and the last frame's sources and grids for reuse.
#[derive(Debug)]
pub struct GpuRenderer {
    env: Environment,
    /// `env` on the GPU, for the view pass.
    env_buffer: EnvBuffer,
    /// Bumped when the environment changes.
    lighting: u64,
    /// Bumped when the environment's distant part (sky or map: what is in SH) changes.
    distant: u64,
    /// The order's tables and its single-scattering pass, and the light in SH (projected
    /// when first needed).
    order: Option<(ShKit, SingleScatteringPass, Option<RgbSh>)>,
    volume: VolumePass,
    env_pass: EnvPass,
    remove_single: RemoveSingle,
    lights: LightsPass,
    view: ViewPass,
    lighting_on: LightingOn,
    /// The grids computed on the CPU, for [`LightingOn::Cpu`].
    host: HostGrids,
    diffusion: DiffusionPass,
    /// Where the last diffusion solve ran, and how it ended when that was the CPU.
    last_solve: Option<LastSolve>,
    /// The diffusion operators of the frame with this key.
    operators: Option<(u64, OperatorBuffers)>,
    sources: Option<(SourceKey, SourceBuffer)>,
    grid: Option<(SourceKey, Option<[f64; 3]>, GridBuffer)>,
    /// The environment pass's grid and its key, kept while the key holds (a camera move,
    /// a new albedo or `g`, another slice count rebuild the volume grids, not this).
    env_grid: Option<(EnvGridKey, EnvShadow)>,
    /// How many environment grids were computed (for tests and figures).
    env_grid_builds: u64,
    /// The lights pass's shadow volume, of the frame with this key and residual toggle
    /// (σt and the lights' directions and positions checked by [`LightShadow::fits`]).
    light_shadow: Option<((u64, bool), LightShadow)>,
    /// How many shadow volumes were computed.
    light_shadow_builds: u64,
    orders: OrdersPass,
    /// The gathered orders' cells (after their diffusion) of the grids with this key:
    /// a camera move adds them to the rebuilt grids again ([`OrdersPass::apply`]).
    orders_media: Option<(SourceKey, MediaBuffer)>,
    /// How many times the orders were gathered and diffused.
    orders_builds: u64,
}

impl GpuRenderer {
    /// Compiles the passes; `env` lights the frames and fills the background.
    pub fn new(ctx: &GpuContext, env: Environment) -> Result<GpuRenderer, GpuError> {
        Ok(GpuRenderer {
            env_buffer: EnvBuffer::upload(ctx, &env)?,
            env,
            lighting: 0,
            distant: 0,
            order: None,
            volume: VolumePass::new(ctx)?,
            env_pass: EnvPass::new(ctx)?,
            remove_single: RemoveSingle::new(ctx)?,
            lights: LightsPass::new(ctx)?,
            view: ViewPass::new(ctx)?,
            lighting_on: LightingOn::default(),
            host: HostGrids::default(),
            diffusion: DiffusionPass::new(ctx)?,
            last_solve: None,
            operators: None,
            sources: None,
            grid: None,
            env_grid: None,
            env_grid_builds: 0,
            light_shadow: None,
            light_shadow_builds: 0,
            orders: OrdersPass::new(ctx)?,
            orders_media: None,
            orders_builds: 0,
        })
    }

    /// How many environment-pass grids ([`EnvPass::grid`], the march of every direction
    /// from every node; on the CPU with [`LightingOn::Cpu`]) this renderer has computed:
    /// it grows when the frame, the
    /// residual toggle, σt, the distant environment, the order or the grid's settings
    /// change, not with the camera, the albedo or `g`.
    pub fn env_grid_builds(&self) -> u64 {
        self.env_grid_builds + self.host.env_grid_builds()
    }

    /// How many shadow volumes of the lights pass ([`LightsPass::shadow`]) this renderer
    /// has computed: it grows when the frame, the residual toggle, σt or a light's
    /// direction or position changes, not with the camera, `g`, the albedo or the
    /// lights' power.
    pub fn light_shadow_builds(&self) -> u64 {
        self.light_shadow_builds
    }

    /// How many times this renderer has gathered the explicit orders and solved their
    /// diffusion ([`OrdersPass::gather`], [`OrdersPass::diffuse`]): it grows with
    /// everything that changes the grids' light except the camera, which only adds the
    /// kept cells to the voxels again.
    pub fn orders_builds(&self) -> u64 {
        self.orders_builds
    }

    /// The environment.
    pub fn environment(&self) -> &Environment {
        &self.env
    }

    /// Lights the next frames with `env` (and shows it behind the smoke). Refuses what
    /// [`EnvBuffer::upload`] refuses, keeping the environment it had.
    pub fn set_environment(&mut self, ctx: &GpuContext, env: Environment) -> Result<(), GpuError> {
        self.env_buffer = EnvBuffer::upload(ctx, &env)?;
        if env.distant != self.env.distant {
            // The projection and the environment grid see the distant part only; new
            // suns or point lights keep them.
            self.distant += 1;
            if let Some((_, _, light)) = &mut self.order {
                *light = None;
            }
        }
        self.env = env;
        self.lighting += 1;
        Ok(())
    }

    /// Forgets the previous frame: no reuse and no warm start for the next one.
    pub fn reset(&mut self) {
        self.diffusion.reset();
        self.host.reset();
        self.sources = None;
        self.grid = None;
        self.env_grid = None;
        self.light_shadow = None;
        self.orders_media = None;
        self.orders.reset();
    }

    /// Where the next frames compute their light (everything is recomputed).
    pub fn set_lighting(&mut self, on: LightingOn) {
        if on != self.lighting_on {
            self.lighting_on = on;
            self.reset();
        }
    }

    /// The most cells this renderer's explicit orders hold (the `max_cells` of
    /// [`CrmOptions::for_gpu_cells`]): any number where its lighting runs on the CPU,
    /// else the device's ([`crate::gpu::orders::max_cells`]).
    pub fn orders_cells(&self, ctx: &GpuContext) -> usize {
        match self.lighting_on.resolve(ctx) {
            LightingOn::Cpu => usize::MAX,
            _ => crate::gpu::orders::max_cells(ctx),
        }
    }

    /// Puts how this frame's diffusion solve ended (iterations, residual) into `stats`
    /// when it had one; a solve on the GPU is read back (a wait).
    pub fn read_solve(&self, ctx: &GpuContext, stats: &mut FrameStats) -> Result<(), GpuError> {
        if stats.solved
            && let Some(d) = self.diffusion_stats(ctx)?
        {
            stats.crm.cg_iterations = d.iterations;
            stats.crm.cg_residual = d.residual;
        }
        Ok(())
    }

    /// How the last diffusion solve ended (waits for the GPU when it ran there); `None`
    /// before the first.
    pub fn diffusion_stats(&self, ctx: &GpuContext) -> Result<Option<DiffusionStats>, GpuError> {
        match self.last_solve {
            None => Ok(None),
            Some(LastSolve::Cpu(stats)) => Ok(Some(stats)),
            Some(LastSolve::Gpu) => self.diffusion.stats(ctx),
            Some(LastSolve::Orders(tolerance)) => {
                Ok(self.orders.solve_stats(ctx)?.map(|s| DiffusionStats {
                    iterations: s.iterations,
                    residual: s.residual,
                    converged: s.residual <= tolerance,
                }))
            }
        }
    }

    /// Adds `J̃ms` to `sources` on the GPU ([`DiffusionPass`]) from the frame's operators,
    /// computed when the frame is new, with the direct light of the environment's suns and
    /// point lights at the centers (computed here, on the host) in its source.
    fn diffusion_gpu(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        medium: &Medium,
        sources: &SourceBuffer,
        opts: &CrmOptions,
        stats: &mut FrameStats,
    ) -> Result<(), GpuError> {
        let t = Instant::now();
        let ops = match self.operators.take() {
            Some((k, ops)) if k == frame.key => self.operators.insert((k, ops)),
            _ => {
                let t = Instant::now();
                let ops = Operators::new(frame.rbfs);
                stats.operators_seconds = t.elapsed().as_secs_f64();
                let ops = OperatorBuffers::upload(ctx, &ops)?;
                self.operators.insert((frame.key, ops))
            }
        };
        let direct = if self.env.has_lights() && medium.albedo != 0.0 {
            let mut moments = Sources::zeros(frame.rbfs.len());
            add_light_moments(&mut moments, frame.rbfs, &self.env, medium);
            Some(DirectBuffer::upload(ctx, &moments)?)
        } else {
            None
        };
        self.diffusion
            .run_with(ctx, &ops.1, medium, sources, direct.as_ref(), &opts.solve)?;
        self.last_solve = Some(LastSolve::Gpu);
        stats.crm.multiple_seconds = t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Renders `frame` seen by `camera` on the host alone: the lighting as
    /// [`LightingOn::Cpu`] computes it, then the CPU's view pass
    /// ([`crate::render::crm::view_pass`], the twin of the GPU's) — for an adapter that is
    /// a CPU, where the view pass's shader runs emulated on the same cores (the viewer's
    /// choice there). The picture is [`crate::render::crm_render`]'s; the grids and the
    /// frame's light are kept and reused as for [`GpuRenderer::render`], and a GPU render
    /// after it reuses them too. Refuses what [`GpuRenderer::render`] refuses.
    pub fn render_on_host(
        &mut self,
        frame: &GpuFrame<'_>,
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
    ) -> Result<(Vec<[f32; 3]>, FrameStats), GpuError> {
        check_options(opts)?;
        let mut stats = FrameStats::default();
        let env = &self.env;
        let grids = self.host.volume_grids(
            frame,
            env,
            (self.lighting, self.distant),
            medium,
            camera,
            opts,
            &mut stats,
        );
        let t = Instant::now();
        let du = slice_thickness(frame.dims, &frame.bbox, opts);
        let (pixels, reuse) = crate::render::view_pass_as(grids, medium, env, camera, du, opts);
        stats.crm.view_seconds = t.elapsed().as_secs_f64();
        stats.crm.reused_pixels = reuse.reused;
        if stats.solved
            && let Some(solve) = self.host.last_solve()
        {
            self.last_solve = Some(LastSolve::Cpu(solve));
        }
        Ok((pixels, stats))
    }

    /// Renders `frame` seen by `camera` into an image on the GPU (submitted; read it with
    /// [`ImageBuffer::read`]). Refuses what the stages refuse (an order outside 1..=6, a
    /// residual of other dims, sizes beyond the device's limits, multiple scattering by
    /// the grid's diffusion alone — [`MsDiffusion::Grid`] is CPU only — and the explicit
    /// orders without the environment pass's grid, which lights their cells).
    pub fn render(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
    ) -> Result<(ImageBuffer, FrameStats), GpuError> {
        let mut stats = FrameStats::default();
        if self.lighting_on.resolve(ctx) == LightingOn::Cpu {
            check_options(opts)?;
            let grid = self.host.grids(
                ctx,
                frame,
                &self.env,
                (self.lighting, self.distant),
                medium,
                camera,
                opts,
                &mut stats,
            )?;
            let view = (&self.view, &self.env, &self.env_buffer);
            let image = view_frame(ctx, view, grid, frame, medium, camera, opts, &mut stats)?;
            if stats.solved
                && let Some(solve) = self.host.last_solve()
            {
                self.last_solve = Some(LastSolve::Cpu(solve));
            }
            return Ok((image, stats));
        }
        let (key, source, sources_fresh, env_light) =
            self.sources(ctx, frame, medium, opts, &mut stats)?;
        // The grids: the eye matters unless the phase function is isotropic (the lights
        // pass's phase too: `p = 1` at g = 0; the one voxel it skips, a voxel center the
        // eye sits on exactly, is left out of this reasoning). The lights are in the key
        // through the lighting generation.
        let eye = (medium.g != 0.0).then_some(camera.eye);
        let grid_key = (
            SourceKey {
                opts: CrmOptions {
                    residual: opts.residual,
                    ..key.opts
                },
                ..key
            },
            eye,
        );
        let grid_fresh = matches!(&self.grid, Some((k, e, _)) if (*k, *e) == grid_key);
        let built = match self.grid.take() {
            Some(g) if grid_fresh => Ok(g.2),
            _ => self.build_grid(
                ctx,
                frame,
                &source,
                medium,
                camera,
                opts,
                grid_key.0,
                env_light.as_ref(),
                &mut stats,
            ),
        };
        self.sources = Some((key, source));
        let grid = &self.grid.insert((grid_key.0, grid_key.1, built?)).2;
        stats.reuse = match (sources_fresh, grid_fresh) {
            (_, true) => Reuse::Grids,
            (true, false) => Reuse::Sources,
            (false, false) => Reuse::Nothing,
        };

        let view = (&self.view, &self.env, &self.env_buffer);
        let image = view_frame(ctx, view, grid, frame, medium, camera, opts, &mut stats)?;
        Ok((image, stats))
    }

    /// The sources at the centers for `frame` (the last frame's when their key holds):
    /// their key, the buffer, whether it was kept, and the environment pass's copy of the
    /// light in SH. Checks `opts` first ([`check_options`]).
    fn sources(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        medium: &Medium,
        opts: &CrmOptions,
        stats: &mut FrameStats,
    ) -> Result<(SourceKey, SourceBuffer, bool, Option<RgbSh>), GpuError> {
        let t = Instant::now();
        check_options(opts)?;
        let (kit, single, light) = match self.order.take() {
            Some(o) if o.0.order == opts.order => self.order.insert(o),
            _ => {
                let kit = ShKit::new(opts.order);
                let pass = SingleScatteringPass::new(ctx, &kit)?;
                self.order.insert((kit, pass, None))
            }
        };
        let light = light.get_or_insert_with(|| sh::project_env(&self.env, opts.order));
        // The environment pass's copy of the light (the borrow of `self.order` ends
        // before the diffusion).
        let env_light = matches!(opts.env_source, EnvSource::Grid(_)).then(|| light.clone());
        stats.crm.setup_seconds = t.elapsed().as_secs_f64();

        // The knobs that do not change the sources are left out of their key.
        let key = SourceKey {
            frame: frame.key,
            lighting: self.lighting,
            medium: *medium,
            opts: CrmOptions {
                residual: false,
                slices_per_voxel: 0.0,
                pixel_reuse: 0.0,
                ..*opts
            },
        };
        let sources_fresh = matches!(&self.sources, Some((k, _)) if *k == key);
        let source = match self.sources.take() {
            Some((_, buffer)) if sources_fresh => buffer,
            _ => {
                let grid_env = matches!(opts.env_source, EnvSource::Grid(_));
                let diffuse = opts.multiple
                    && opts.diffusion == MsDiffusion::Centers
                    && !frame.rbfs.is_empty();
                let t = Instant::now();
                let buffer = if grid_env && !diffuse {
                    // No diffusion to feed: the centers carry nothing.
                    let n2 = opts.order * opts.order;
                    let zero =
                        vec![[vec![0.0; n2], vec![0.0; n2], vec![0.0; n2]]; frame.rbfs.len()];
                    SourceBuffer::upload(ctx, &zero, opts.order)?
                } else {
                    single.run(
                        ctx,
                        kit,
                        frame.rbfs,
                        medium,
                        light,
                        opts.exp,
                        opts.source_points,
                    )?
                };
                stats.crm.single_seconds = t.elapsed().as_secs_f64();
                if diffuse {
                    let copy = if grid_env {
                        Some(self.remove_single.copy(ctx, &buffer)?)
                    } else {
                        None
                    };
                    self.diffusion_gpu(ctx, frame, medium, &buffer, opts, stats)?;
                    if let Some(copy) = copy {
                        self.remove_single.run(ctx, &buffer, &copy)?;
                    }
                    stats.solved = true;
                }
                self.grid = None;
                buffer
            }
        };
        Ok((key, source, sources_fresh, env_light))
    }

    /// The volume pass's grids of `frame` from `source`, with the environment's single
    /// scattering, the suns and point lights, and the gathered orders added.
    #[allow(clippy::too_many_arguments)]
    fn build_grid(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        source: &SourceBuffer,
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        key: SourceKey,
        env_light: Option<&RgbSh>,
        stats: &mut FrameStats,
    ) -> Result<GridBuffer, GpuError> {
        let t = Instant::now();
        let residual = if opts.residual { frame.residual } else { None };
        let grid = self.volume.run_on(
            ctx,
            frame.rbfs,
            source,
            frame.dims,
            &frame.bbox,
            residual,
            camera.eye,
        )?;
        stats.crm.volume_seconds = t.elapsed().as_secs_f64();
        self.apply_env(ctx, frame, &grid, medium, camera, opts, env_light, stats)?;
        self.apply_lights(ctx, frame, &grid, medium, camera, opts, stats)?;
        self.apply_orders(
            ctx, frame, &grid, medium, camera, opts, key, env_light, stats,
        )?;
        Ok(grid)
    }

    /// Adds the environment's single scattering to `grid` (with [`EnvSource::Grid`]),
    /// its grid of the sky per voxel kept while its key holds.
    #[allow(clippy::too_many_arguments)]
    fn apply_env(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        grid: &GridBuffer,
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        env_light: Option<&RgbSh>,
        stats: &mut FrameStats,
    ) -> Result<(), GpuError> {
        if let (Some(g), Some(light)) = (&opts.env_grid(), env_light) {
            let t = Instant::now();
            let key = EnvGridKey {
                frame: frame.key,
                residual: opts.residual,
                sigma_t: medium.sigma_t,
                distant: self.distant,
                order: opts.order,
                grid: *g,
            };
            let shadow = match self.env_grid.take() {
                Some((k, shadow)) if k == key => &self.env_grid.insert((k, shadow)).1,
                _ => {
                    let shadow =
                        self.env_pass
                            .grid(ctx, grid, &self.env, medium.sigma_t, opts.order, g)?;
                    self.env_grid_builds += 1;
                    &self.env_grid.insert((key, shadow)).1
                }
            };
            self.env_pass.apply(
                ctx,
                grid,
                shadow,
                light,
                medium,
                camera.eye,
                &self.env.distant,
            )?;
            stats.crm.env_seconds = t.elapsed().as_secs_f64();
        }
        Ok(())
    }

    /// Adds the suns' and point lights' single scattering to `grid`, their shadow volume
    /// kept while the frame, the residual toggle and the lights hold.
    #[allow(clippy::too_many_arguments)]
    fn apply_lights(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        grid: &GridBuffer,
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        stats: &mut FrameStats,
    ) -> Result<(), GpuError> {
        let t = Instant::now();
        if self.env.has_lights() && medium.albedo != 0.0 && !frame.dims.contains(&0) {
            let key = (frame.key, opts.residual);
            let kept = matches!(&self.light_shadow,
                Some((k, s)) if *k == key && s.fits(grid, &self.env, medium.sigma_t));
            let shadow = match self.light_shadow.take() {
                Some(kept_shadow) if kept => &self.light_shadow.insert(kept_shadow).1,
                _ => {
                    let shadow = self.lights.shadow(ctx, grid, &self.env, medium.sigma_t)?;
                    self.light_shadow_builds += 1;
                    &self.light_shadow.insert((key, shadow)).1
                }
            };
            self.lights
                .apply(ctx, grid, shadow, &self.env, medium, camera.eye)?;
        }
        stats.crm.lights_seconds = t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Adds the gathered orders of multiple scattering to `grid` ([`MsDiffusion::Orders`]),
    /// the cells' radiance kept for the grids of `key`.
    #[allow(clippy::too_many_arguments)]
    fn apply_orders(
        &mut self,
        ctx: &GpuContext,
        frame: &GpuFrame<'_>,
        grid: &GridBuffer,
        medium: &Medium,
        camera: &Camera,
        opts: &CrmOptions,
        key: SourceKey,
        env_light: Option<&RgbSh>,
        stats: &mut FrameStats,
    ) -> Result<(), GpuError> {
        let t = Instant::now();
        if let (true, MsDiffusion::Orders { factor, orders }, Some((_, shadow)), Some(light)) =
            (opts.multiple, opts.diffusion, &self.env_grid, env_light)
            && medium.albedo > 0.0
            && medium.sigma_t > 0.0
            && !frame.dims.contains(&0)
        {
            let kept = matches!(&self.orders_media, Some((k, _)) if *k == key);
            let factor = gpu_orders_factor(factor, opts.detail);
            let orders = crate::render::grid_diffusion::orders_at_detail(orders, opts.detail);
            stats.crm.ms_factor = crate::gpu::orders::auto_factor(ctx, grid.dims(), factor);
            stats.crm.ms_orders = orders;
            let media = match self.orders_media.take() {
                Some(m) if kept => &self.orders_media.insert(m).1,
                _ => {
                    let media = self.orders.gather(
                        ctx,
                        grid,
                        shadow,
                        light,
                        &self.env,
                        &self.lights,
                        medium,
                        factor,
                        orders,
                        opts.detail,
                    )?;
                    self.orders
                        .diffuse(ctx, grid, shadow, &media, &opts.grid_solve)?;
                    self.orders_builds += 1;
                    self.last_solve = Some(LastSolve::Orders(opts.grid_solve.tolerance));
                    stats.solved = true;
                    &self.orders_media.insert((key, media)).1
                }
            };
            self.orders.apply(ctx, grid, shadow, media, camera.eye)?;
            stats.crm.multiple_seconds = t.elapsed().as_secs_f64();
        }
        Ok(())
    }
}

/// The view pass of `grid` (the grids of `frame`) seen by `camera`, through the view
/// pass, environment and environment buffer of `view`; its time and the frame's GPU
/// stage times go to `stats`.
#[allow(clippy::too_many_arguments)]
fn view_frame(
    ctx: &GpuContext,
    (view, env, env_buffer): (&ViewPass, &Environment, &EnvBuffer),
    grid: &GridBuffer,
    frame: &GpuFrame<'_>,
    medium: &Medium,
    camera: &Camera,
    opts: &CrmOptions,
    stats: &mut FrameStats,
) -> Result<ImageBuffer, GpuError> {
    let t = Instant::now();
    let du = slice_thickness(frame.dims, &frame.bbox, opts);
    let ground = opts.ground.map(|g| g.lit(env));
    let image = view.dispatch_in(ctx, grid, medium, env_buffer, camera, du, ground.as_ref())?;
    stats.crm.view_seconds = t.elapsed().as_secs_f64();
    stats.gpu = ctx.take_stage_times()?;
    Ok(image)
}

/// Refuses options the GPU renderer cannot follow: an SH order outside 1..=6, the grid's
/// diffusion (CPU only), the explicit orders without the environment pass's grid, and
/// diffusion settings out of range.
fn check_options(opts: &CrmOptions) -> Result<(), GpuError> {
    if !(1..=sh::MAX_ORDER).contains(&opts.order) {
        return Err(GpuError::Input(format!(
            "SH order {} is outside 1..={}",
            opts.order,
            sh::MAX_ORDER
        )));
    }
    if opts.multiple && matches!(opts.diffusion, MsDiffusion::Grid { .. }) {
        return Err(GpuError::Input(
            "the grid diffusion runs on the CPU only; the GPU gathers orders or solves on the centers"
                .into(),
        ));
    }
    if opts.multiple
        && matches!(opts.diffusion, MsDiffusion::Orders { .. })
        && !matches!(opts.env_source, EnvSource::Grid(_))
    {
        return Err(GpuError::Input(
            "the explicit orders on the GPU are lit by the environment pass's grid (the sky per voxel), not by the centers"
                .into(),
        ));
    }
    if let Err(e) = opts.diffusion.check() {
        return Err(GpuError::Input(e));
    }
    Ok(())
}

/// The gathered orders' factor on the GPU at the lighting's `detail`
/// (`CrmOptions::detail`): a given factor as it is; [`MsDiffusion::AUTO`] at detail 1 as
/// it is (the pass's own choice), below 1 the CPU's smallest automatic side there
/// (`grid_diffusion::auto_min_factor`), at most the pass's largest.
fn gpu_orders_factor(factor: usize, detail: f64) -> usize {
    let detail = crate::render::detail_or_one(detail);
    if factor != MsDiffusion::AUTO || detail >= 1.0 {
        return factor;
    }
    crate::render::grid_diffusion::auto_min_factor(detail).min(crate::gpu::orders::MAX_FACTOR)
}
