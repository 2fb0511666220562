//! Explicit scattering orders on the GPU (`shaders/orders.wgsl`), the twin of
//! [`crate::render::grid_diffusion::explicit_media_radiance`] fed as
//! [`crate::render::crm_grids`] feeds it with the environment pass's grid: multiple
//! scattering on the coarse grid of `f³`-voxel cells, its first `K` orders gathered along
//! the environment pass's direction rules and the rest by the finite-volume diffusion,
//! then added per voxel, in `f32` and in place on a [`GridBuffer`].
//!
//! Three steps, each submitted without a wait:
//! - [`OrdersPass::gather`]: the coarse density and the first source per cell from what
//!   the GPU passes hold — the environment pass's grid of `S_lm` ([`EnvShadow`], the
//!   sky's single scattering per voxel, [`crate::render::grid_diffusion::env_grid_sources`]), the
//!   point lights' moments and each sun's transmittance from the cell center, marched
//!   through the volume pass's `D` as the lights pass marches
//!   ([`crate::render::grid_diffusion::add_lights`], [`crate::render::grid_diffusion::sun_sources`]) —
//!   then the box of the cells with smoke, where the rays stop (one workgroup), and one
//!   pass per order ([`crate::render::grid_diffusion::gather`]: 72 directions for the first
//!   where HG's peak is broad, up to 288 where it is narrow
//!   ([`crate::render::grid_diffusion::gather_theta`]; 32 at a lighting detail of 2/3 and
//!   below where the peak allows, [`crate::render::grid_diffusion::first_theta`]), 32 for
//!   the later, 8 per dispatch);
//! - [`OrdersPass::diffuse`]: the finite-volume system of the light after the gathered
//!   orders, one invocation per cell, solved by Jacobi-preconditioned conjugate gradients
//!   ([`crate::render::grid_diffusion::solve`]) spread over every cell: per iteration two
//!   cell dispatches that leave a partial dot product per workgroup and two one-workgroup
//!   reductions, from the last solve's solution when it had as many cells (playback's
//!   warm start: the next frame's light is close to this one's); the iterations go in
//!   batches with a look at the state after each (the first batch as long as the last
//!   solve, so most solves wait once), and once every
//!   channel has converged the reductions empty the cell dispatches' indirect arguments,
//!   so a batch's iterations past convergence cost empty dispatches; then `L⁰`, `L¹` per
//!   cell with the flux moment and the clamp `|L¹| ≤ 3L⁰`;
//! - [`OrdersPass::apply`]: `J_ms = Ω ((1 − f) L⁰ − (g − f) L¹·d + Σ_{l=2}^{4} (g^l − f)
//!   c_lm Y_lm(−d))` per voxel towards the eye, with the gathered orders' bands 2–4
//!   `c_lm` and HG's peak `f = g⁵` left to the view pass, which the grid's
//!   [`GridBuffer::eye_peak`] tells ([`crate::render::grid_diffusion::add_to_grids`]).
//!
//! The light travels through the medium's delta-Eddington transport medium, as on the
//! CPU ([`Medium::delta_eddington`]).
//!
//! The cells' `L⁰`, `L¹` and escape probabilities stay on the GPU ([`MediaBuffer`]) and
//! can be read back for tests. Cells of the diffusion that the CPU leaves out (thinner
//! than [`crate::render::grid_diffusion::THIN`]) are identity rows with no source here, which
//! gives the same solution.
//!
//! lavapipe ends the loops nested in an outermost loop once they have run 65535
//! iterations together, silently (`shaders/orders.wgsl`): the split of the directions
//! into dispatches and [`MAX_FACTOR`] keep every invocation within it.

use super::GridBuffer;
use super::env_pass::EnvShadow;
use super::lights_pass::LightsPass;
use crate::env::Environment;
use crate::lighting::single::RgbSh;
use crate::lights::DiskPhase;
use crate::medium::{FOUR_PI, Medium};
use crate::render::MsDiffusion;
use crate::render::env_pass::{directions, phase_factors};
use crate::render::grid_diffusion::{
    GATHER_LATER_THETA, GridSolveOptions, HIGH, first_theta, phase_norm,
};
use haze_gpu::wgsl::Variant;
use haze_gpu::{
    ComputeLayout, GpuContext, GpuError, bind_buffers, buffer_init, compute_layout, timed_pass,
    voxel_groups,
};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// The shader: `crates/view/shaders/orders.wgsl`, importing the fine march
/// (`grid_march`), the phase functions (`disk_phase`) and `sh_basis`.
pub const SHADER: Variant = Variant {
    label: "gathered orders",
    entry: include_str!("../../shaders/orders.wgsl"),
    defines: &[],
};

/// Most suns in the first source (the shader's records hold `13 + 8` words).
pub const MAX_SUNS: usize = 8;
/// Directions per gather dispatch (what the parameters buffer holds): lavapipe ends the loops nested
/// in an outermost loop after 65535 iterations together (module docs of the shader), and
/// a cell's march of 8 directions stays within that up to ~2000 cells a side.
const DIRECTIONS_PER_DISPATCH: usize = 8;
/// Most voxels per cell side on the GPU (`cells` visits ≤ 512 voxels per invocation).
pub const MAX_FACTOR: usize = 8;
/// Words per cell of the cells' radiance: `L⁰`, `L¹`, `P`, `D`, two unused, the red
/// channel's bands 2–4.
const MEDIA: usize = 16 + HIGH;
/// Words per cell of the green and blue channels' bands 2–4, in the buffer bound as the
/// shader's `work` while the orders gather and are applied, after [`BOX`] words.
const MORE: usize = 2 * HIGH;
/// Words before the bands of [`MORE`]: the box of the cells with smoke (six used).
const BOX: usize = 8;
/// The cell size [`MsDiffusion::AUTO`] stands for on the GPU (the CPU's measured
/// default; the GPU's march is not bound by the CPU's budget).
pub const AUTO_FACTOR: usize = 2;
const ROW: usize = 43;
/// Words of the CG's state after the rows (the shader's `STATE`).
const STATE: usize = 32;
/// Invocations per group of the CG's cell dispatches (the shader's `WG`).
const CG_GROUP: usize = 256;
/// The least CG iterations between two looks at the state ([`OrdersPass::diffuse`]).
const CG_BATCH: u32 = 32;
/// Invocations per group of the per-cell dispatches, and per side of `apply`.
const CELLS: usize = 64;
const SIDE: usize = 4;

/// The shader's `Params` (WGSL layout), 272 bytes, followed in the parameters buffer by a share of
/// the direction rule ([`DIRECTIONS_PER_DISPATCH`] `vec4`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    eye: [f32; 3],
    sigma_t: f32,
    voxel: [f32; 3],
    h0: f32,
    size: [f32; 3],
    soft: f32,
    dims: [u32; 3],
    factor: u32,
    cells: [u32; 3],
    suns: u32,
    cell: [f32; 3],
    points: u32,
    g: f32,
    albedo: f32,
    k: f32,
    stride: u32,
    first: u32,
    order: u32,
    directions: u32,
    max_iterations: u32,
    node_min: [f32; 3],
    warm: u32,
    node_cell: [f32; 3],
    tolerance: f32,
    nodes: [u32; 3],
    sigma_s: f32,
    sigma_a: f32,
    sigma_tr: f32,
    rec_suns: u32,
    chunk_first: u32,
    transport_sigma_t: f32,
    transport_albedo: f32,
    transport_g: f32,
    first_scale: f32,
    env: [[f32; 4]; 4],
    /// Per sun of the first order, its phase function's factor on the first order's rule
    /// ([`crate::render::grid_diffusion::phase_norm`]), four to a `vec4`.
    sun_norm: [[f32; 4]; 2],
}

/// `L⁰`, `L¹` and the escape probability per coarse cell on the GPU (`MEDIA` `f32` per
/// cell: `L⁰` RGB, `L¹` `[channel][axis]`, `P`, the cell's mean density, two unused, the
/// red channel's bands 2–4 of the gathered orders; the green and blue channels' bands in
/// `more`), with the last gathered order's scattered source (the diffusion's input) and
/// the parameters buffer of the grid they belong to.
#[derive(Debug)]
pub struct MediaBuffer {
    media: wgpu::Buffer,
    /// The box of the cells with smoke ([`BOX`] words), then per cell the green and blue
    /// channels' bands 2–4 ([`MORE`] words): split from `media` so that no binding holds
    /// more words a cell than the diffusion's system ([`max_cells`]).
    more: wgpu::Buffer,
    /// The last gathered order's record, `D·(Ω L⁰, Ω g L¹)` (13 words per cell).
    last: wgpu::Buffer,
    /// The other record buffer (the first source's, then the ping-pong's other half).
    spare: wgpu::Buffer,
    params: Params,
    cells: [usize; 3],
    dims: [usize; 3],
}

/// What [`MediaBuffer::read`] returns: per cell `L⁰`, `L¹`, the escape probability and
/// the mean density.
#[derive(Clone, Debug, Default)]
pub struct CellRadiance {
    pub cells: [usize; 3],
    pub l0: Vec<[f64; 3]>,
    pub l1: Vec<[[f64; 3]; 3]>,
    /// Bands 2–4 of the gathered orders (`grid_diffusion::Gathered::high`).
    pub high: Vec<[[f64; HIGH]; 3]>,
    pub escape: Vec<f64>,
    pub density: Vec<f64>,
}

impl MediaBuffer {
    fn len(&self) -> usize {
        self.cells.iter().product()
    }

    /// Reads the cells back (a wait).
    pub fn read(&self, ctx: &GpuContext) -> Result<CellRadiance, GpuError> {
        let words: Vec<f32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&self.media)?);
        let more: Vec<f32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(&self.more)?);
        let mut out = CellRadiance {
            cells: self.cells,
            ..CellRadiance::default()
        };
        let cells = words.chunks(MEDIA).zip(more[BOX..].chunks(MORE));
        for (c, m) in cells.take(self.len()) {
            let v = |k: usize| f64::from(c[k]);
            let band = |ch: usize, k: usize| match ch {
                0 => v(16 + k),
                _ => f64::from(m[HIGH * (ch - 1) + k]),
            };
            out.l0.push([v(0), v(1), v(2)]);
            out.l1
                .push([0, 1, 2].map(|ch| [0, 1, 2].map(|a| v(3 + 3 * ch + a))));
            out.high
                .push([0, 1, 2].map(|ch| std::array::from_fn(|k| band(ch, k))));
            out.escape.push(v(12));
            out.density.push(v(13));
        }
        Ok(out)
    }
}

/// How a solve on the GPU ended.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OrdersSolve {
    /// Most CG iterations among the channels.
    pub iterations: u32,
    /// Largest relative residual `‖r‖/‖b‖` among the channels (the `f32` recurrence's).
    pub residual: f64,
}

/// The compiled pass: one bind group layout shared by its entry points.
#[derive(Debug)]
pub struct OrdersPass {
    layout: wgpu::BindGroupLayout,
    cells: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    system: wgpu::ComputePipeline,
    cg_start: wgpu::ComputePipeline,
    cg_product: wgpu::ComputePipeline,
    cg_alpha: wgpu::ComputePipeline,
    cg_update: wgpu::ComputePipeline,
    cg_beta: wgpu::ComputePipeline,
    occupied: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    apply: wgpu::ComputePipeline,
    /// The work buffer of the last solve (rows, vectors, state) and its cell count.
    work: std::sync::Mutex<Option<(usize, wgpu::Buffer)>>,
    /// The CG iterations the last solve took (the next one's first batch).
    expected: AtomicU32,
}

/// How the CG in `work` (of `n` cells) stands, and whether every channel is done (a
/// wait).
fn solve_state(
    ctx: &GpuContext,
    work: &wgpu::Buffer,
    n: usize,
) -> Result<(OrdersSolve, bool), GpuError> {
    let bytes = ctx.read_range(work, (4 * ROW * n) as u64, (4 * 24) as u64)?;
    let words: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
    let mut out = OrdersSolve::default();
    let mut done = true;
    for state in words.chunks(8) {
        out.iterations = out.iterations.max(state[0] as u32);
        out.residual = out.residual.max(f64::from(state[1]));
        done &= state[4] == 1.0;
    }
    Ok((out, done))
}

/// `(σs, σa, σtr)` of a medium that scatters, as the CPU's system takes them.
fn coefficients(m: &Medium) -> Option<(f64, f64, f64)> {
    let sigma_tr = (1.0 - m.albedo * m.g) * m.sigma_t;
    let sigma_a = (1.0 - m.albedo) * m.sigma_t;
    let ok = m.albedo > 0.0
        && m.sigma_t > 0.0
        && sigma_tr > 0.0
        && sigma_tr.is_finite()
        && sigma_a.is_finite();
    ok.then_some((m.albedo * m.sigma_t, sigma_a, sigma_tr))
}

/// Groups of 64 invocations covering `n` cells: `[x, y, 1]` with `x·y·64 ≥ n`.
fn cell_groups(ctx: &GpuContext, n: usize) -> Result<[u32; 3], GpuError> {
    haze_gpu::line_groups(ctx, n.max(1), CELLS, "cells")
}

impl OrdersPass {
    /// Compiles the shader's entry points.
    pub fn new(ctx: &GpuContext) -> Result<OrdersPass, GpuError> {
        let source = super::shaders::source(&SHADER)?;
        ctx.scoped("orders pipeline creation", || {
            let d = &ctx.device;
            let ComputeLayout {
                layout,
                pipeline_layout,
                module,
            } = compute_layout(
                d,
                "orders",
                &source,
                &[false, false, true, true, false, false, false],
            );
            let pipeline = |entry: &'static str| {
                d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            };
            OrdersPass {
                cells: pipeline("cells"),
                gather: pipeline("gather"),
                system: pipeline("system"),
                cg_start: pipeline("cg_start"),
                cg_product: pipeline("cg_product"),
                cg_alpha: pipeline("cg_alpha"),
                cg_update: pipeline("cg_update"),
                cg_beta: pipeline("cg_beta"),
                occupied: pipeline("occupied"),
                finish: pipeline("finish"),
                apply: pipeline("apply"),
                layout,
                work: std::sync::Mutex::new(None),
                expected: AtomicU32::new(0),
            }
        })
    }

    /// A parameters buffer of `params` and the rule `rule` (`(ω, weight)`).
    fn params_buffer(ctx: &GpuContext, params: &Params, rule: &[([f64; 3], f64)]) -> wgpu::Buffer {
        let mut bytes = bytemuck::bytes_of(params).to_vec();
        let mut table = [[0.0f32; 4]; DIRECTIONS_PER_DISPATCH];
        for (t, (w, wt)) in table.iter_mut().zip(rule) {
            *t = [w[0] as f32, w[1] as f32, w[2] as f32, *wt as f32];
        }
        bytes.extend_from_slice(bytemuck::cast_slice(&table));
        buffer_init(
            ctx,
            "orders parameters",
            &bytes,
            wgpu::BufferUsages::STORAGE,
        )
    }

    /// One compute pass of `pipeline` over `groups` (repeated `times`), binding in order
    /// the parameters, the lights, the grid, the environment's `S`, the record read, the
    /// record written, the cells' radiance and the work buffer. Call inside
    /// [`GpuContext::scoped`].
    fn dispatch(
        &self,
        ctx: &GpuContext,
        label: &'static str,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[&wgpu::Buffer; 8],
        groups: [u32; 3],
        times: u32,
    ) {
        let binds: Vec<_> = (0..times)
            .map(|_| bind_buffers(ctx, label, &self.layout, buffers))
            .collect();
        self.dispatch_each(ctx, label, pipeline, &binds, groups);
    }

    /// One compute pass (one timed stage) of `pipeline` over `groups` per bind group of
    /// `binds`, in order. Call inside [`GpuContext::scoped`].
    /// The bind groups of one order's gather, a chunk of the directions `rule` each (its
    /// parameters: `params` with the chunk's directions, and for the first order
    /// `first_order`'s record stride and sun count); `buffers` are bindings 1–7.
    fn gather_binds(
        &self,
        ctx: &GpuContext,
        params: &Params,
        first_order: Option<(usize, usize)>,
        rule: &[([f64; 3], f64)],
        buffers: [&wgpu::Buffer; 7],
    ) -> Vec<wgpu::BindGroup> {
        rule.chunks(DIRECTIONS_PER_DISPATCH)
            .enumerate()
            .map(|(c, part)| {
                let p = Params {
                    first: u32::from(first_order.is_some()),
                    chunk_first: u32::from(c == 0),
                    stride: first_order.map_or(13, |(stride, _)| stride as u32),
                    rec_suns: first_order.map_or(0, |(_, suns)| suns as u32),
                    directions: part.len() as u32,
                    ..*params
                };
                let params_buffer = OrdersPass::params_buffer(ctx, &p, part);
                let mut all = vec![&params_buffer];
                all.extend(buffers);
                bind_buffers(ctx, "orders gather", &self.layout, &all)
            })
            .collect()
    }

    fn dispatch_each(
        &self,
        ctx: &GpuContext,
        label: &'static str,
        pipeline: &wgpu::ComputePipeline,
        binds: &[wgpu::BindGroup],
        groups: [u32; 3],
    ) {
        timed_pass(ctx, label, |pass| {
            pass.set_pipeline(pipeline);
            for bind in binds {
                pass.set_bind_group(0, bind, &[]);
                pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
            }
        });
    }

    /// The first `orders` scattering orders on the coarse grid of `factor` over `grid`'s
    /// `D` (module docs), lit by the environment's single scattering from `shadow` (the
    /// environment pass's grid of this `D`) and `light` (its projection), `env`'s point
    /// lights and suns (records from `lights`) in `medium` (submitted); the factor
    /// [`MsDiffusion::AUTO`] is [`auto_factor`] ([`AUTO_FACTOR`] where the device holds
    /// its cells). Refuses a factor
    /// outside 1–[`MAX_FACTOR`], orders outside 1–8, more than [`MAX_SUNS`] suns, a `shadow` of
    /// another grid, a `light` of fewer coefficients than its order, and sizes beyond the
    /// device's limits. The first order takes [`first_theta`]'s rule at the lighting's
    /// `detail` (`(0, 1]`, 1 at full detail), as the CPU's
    /// (`grid_diffusion::frame_explicit_media_radiance`).
    #[allow(clippy::too_many_arguments)]
    pub fn gather(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        shadow: &EnvShadow,
        light: &RgbSh,
        env: &Environment,
        lights: &LightsPass,
        medium: &Medium,
        factor: usize,
        orders: usize,
        detail: f64,
    ) -> Result<MediaBuffer, GpuError> {
        let factor = check_gather(ctx, grid, shadow, light, env, factor, orders)?;
        let words = lights.light_words(ctx, grid, env, medium.g)?;
        let first: Vec<_> = directions(first_theta(medium.g, detail)).points().collect();
        let params = gather_params(grid, shadow, light, env, medium, factor, &first);
        let dims = grid.dims();
        let cells = dims.map(|n| n.div_ceil(factor));
        let n = cells.iter().product::<usize>();
        let stride = 13 + env.suns.len();
        let record_bytes = (4 * n.max(1) * stride) as u64;
        let groups = cell_groups(ctx, n)?;
        let later: Vec<_> = directions(GATHER_LATER_THETA).points().collect();
        ctx.scoped("the gathered orders", || {
            let storage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
            let buffer = |label, size: u64| {
                ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: storage,
                    mapped_at_creation: false,
                })
            };
            let media = buffer("cells' radiance", (4 * MEDIA * n.max(1)) as u64);
            // The box of the cells with smoke, where the gathers' rays stop, then the
            // green and blue channels' bands.
            let more = buffer("cells' bands", (4 * (BOX + MORE * n.max(1))) as u64);
            let mut rec = [
                buffer("orders' source", record_bytes),
                buffer("orders' source", record_bytes),
            ];
            let lights_buf = buffer_init(
                ctx,
                "orders' lights",
                bytemuck::cast_slice(&words),
                wgpu::BufferUsages::STORAGE,
            );
            let (ro, rw) = (buffer("orders' unused", 16), buffer("orders' unused", 16));
            let cells_params = OrdersPass::params_buffer(ctx, &params, &[]);
            // `cells` writes the first source into rec[1] (read as the input below).
            self.dispatch(
                ctx,
                "orders cells",
                &self.cells,
                &[
                    &cells_params,
                    &lights_buf,
                    grid.buffer(),
                    shadow.buffer(),
                    &ro,
                    &rec[1],
                    &media,
                    &more,
                ],
                groups,
                1,
            );
            self.dispatch(
                ctx,
                "orders occupied",
                &self.occupied,
                &[
                    &cells_params,
                    &lights_buf,
                    grid.buffer(),
                    shadow.buffer(),
                    &ro,
                    &rw,
                    &media,
                    &more,
                ],
                [1, 1, 1],
                1,
            );
            for k in 0..orders {
                let rule = if k == 0 { &first } else { &later };
                rec.swap(0, 1);
                // rec[0]: this order's source, rec[1]: the next; one pass per order.
                let first_order = (k == 0).then_some((stride, env.suns.len()));
                let binds = self.gather_binds(
                    ctx,
                    &params,
                    first_order,
                    rule,
                    [
                        &lights_buf,
                        grid.buffer(),
                        shadow.buffer(),
                        &rec[0],
                        &rec[1],
                        &media,
                        &more,
                    ],
                );
                self.dispatch_each(ctx, "orders gather", &self.gather, &binds, groups);
            }
            let [spare, last] = rec;
            MediaBuffer {
                media,
                more,
                last,
                spare,
                params,
                cells,
                dims,
            }
        })
    }

    /// Adds to `media` the diffusion of the light after its gathered orders (module docs),
    /// solved with `opts`, from the last solve's solution when it had as many cells and
    /// [`OrdersPass::reset`] came not between. Nothing to add when the medium does not
    /// scatter.
    pub fn diffuse(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        shadow: &EnvShadow,
        media: &MediaBuffer,
        opts: &GridSolveOptions,
    ) -> Result<(), GpuError> {
        if media.params.sigma_tr <= 0.0 || media.params.transport_albedo <= 0.0 {
            return Ok(());
        }
        let n = media.len();
        let words = (ROW * n + STATE + 8 * n.div_ceil(CG_GROUP)) as u64;
        ctx.check_storage_size("the orders' diffusion", 4 * words)?;
        let groups = cell_groups(ctx, n)?;
        let cg_groups = haze_gpu::line_groups(ctx, n.max(1), CG_GROUP, "cells")?;
        let mut kept = self.work.lock().map_err(|_| GpuError::Gpu {
            during: "the orders' diffusion",
            reason: "a previous solve panicked".into(),
        })?;
        // The last solve's x is the start when it had as many cells (module docs).
        let warm = matches!(kept.as_ref(), Some((m, _)) if *m == n);
        let params = Params {
            stride: 13,
            max_iterations: opts.max_iterations,
            tolerance: opts.tolerance as f32,
            warm: u32::from(warm),
            ..media.params
        };
        let (work, args, cells, reduce) = ctx.scoped("the orders' diffusion", || {
            let work = match kept.take() {
                Some((m, w)) if m == n => w,
                _ => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("orders' diffusion"),
                    size: 4 * words,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
            };
            let params_buffer = OrdersPass::params_buffer(ctx, &params, &[]);
            let dummy = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("orders' unused"),
                size: 16,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            });
            // The CG cell dispatches' workgroups, emptied by the reductions once every
            // channel is done.
            let args = buffer_init(
                ctx,
                "orders' CG dispatch",
                bytemuck::cast_slice(&cg_groups),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
            );
            let with = |second: &wgpu::Buffer| {
                bind_buffers(
                    ctx,
                    "orders' diffusion",
                    &self.layout,
                    &[
                        &params_buffer,
                        second,
                        grid.buffer(),
                        shadow.buffer(),
                        &media.last,
                        &media.spare,
                        &media.media,
                        &work,
                    ],
                )
            };
            let (cells, reduce) = (with(&dummy), with(&args));
            self.dispatch_each(
                ctx,
                "orders system",
                &self.system,
                std::slice::from_ref(&cells),
                groups,
            );
            (work, args, cells, reduce)
        })?;
        let solved = self.solve(
            ctx,
            (&work, n),
            opts.max_iterations,
            cg_groups,
            &args,
            [&cells, &reduce],
        );
        let finished = solved.and_then(|()| {
            ctx.scoped("the orders' diffusion", || {
                self.dispatch_each(
                    ctx,
                    "orders finish",
                    &self.finish,
                    std::slice::from_ref(&cells),
                    groups,
                );
            })
        });
        *kept = Some((n, work));
        finished
    }

    /// The CG (module docs) in batches of iterations, each submitted as one timed pass
    /// ("orders cg") and followed by a look at the state (a wait): the first batch the
    /// iterations the last solve took and a quarter more, the later ones half of those
    /// run so far, at least [`CG_BATCH`], until every channel is done or `max`
    /// iterations ran. The cell dispatches go indirect through `args`; `binds`: the bind
    /// group of the cell dispatches and that of the reductions (binding 1: `args`).
    fn solve(
        &self,
        ctx: &GpuContext,
        (work, n): (&wgpu::Buffer, usize),
        max: u32,
        groups: [u32; 3],
        args: &wgpu::Buffer,
        [cells, reduce]: [&wgpu::BindGroup; 2],
    ) -> Result<(), GpuError> {
        let label = "orders cg";
        let expected = self.expected.load(Ordering::Relaxed);
        let mut batch = (expected + expected / 4).max(CG_BATCH);
        let mut ran = 0u32;
        loop {
            let now = batch.min(max - ran);
            ctx.scoped("the orders' diffusion", || {
                timed_pass(ctx, label, |pass| {
                    if ran == 0 {
                        pass.set_pipeline(&self.cg_update);
                        pass.set_bind_group(0, cells, &[]);
                        pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
                        pass.set_pipeline(&self.cg_start);
                        pass.set_bind_group(0, reduce, &[]);
                        pass.dispatch_workgroups(1, 1, 1);
                    }
                    for _ in 0..now {
                        for (cell_step, reduction) in [
                            (&self.cg_product, &self.cg_alpha),
                            (&self.cg_update, &self.cg_beta),
                        ] {
                            pass.set_pipeline(cell_step);
                            pass.set_bind_group(0, cells, &[]);
                            pass.dispatch_workgroups_indirect(args, 0);
                            pass.set_pipeline(reduction);
                            pass.set_bind_group(0, reduce, &[]);
                            pass.dispatch_workgroups(1, 1, 1);
                        }
                    }
                });
            })?;
            ran += now;
            let (solve, done) = solve_state(ctx, work, n)?;
            if done || ran >= max {
                self.expected.store(solve.iterations, Ordering::Relaxed);
                return Ok(());
            }
            batch = CG_BATCH.max(ran / 2);
        }
    }

    /// Forgets the last solve: the next [`OrdersPass::diffuse`] starts from `x = 0`.
    pub fn reset(&self) {
        if let Ok(mut kept) = self.work.lock() {
            *kept = None;
        }
    }

    /// How the last [`OrdersPass::diffuse`] ended (a wait); `None` before the first.
    pub fn solve_stats(&self, ctx: &GpuContext) -> Result<Option<OrdersSolve>, GpuError> {
        let kept = self.work.lock().map_err(|_| GpuError::Gpu {
            during: "the orders' diffusion",
            reason: "a previous solve panicked".into(),
        })?;
        let Some((n, work)) = kept.as_ref() else {
            return Ok(None);
        };
        let (out, _) = solve_state(ctx, work, *n)?;
        Ok(Some(out))
    }

    /// Adds `J_ms = Ω (L⁰ − g L¹·d + Σ_{l=2}^{4} g^l c_lm Y_lm(−d))` of `media` to every voxel of `grid` with smoke, the
    /// camera at `eye` (submitted). Refuses a grid other than `media`'s and a non-finite
    /// eye.
    pub fn apply(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        shadow: &EnvShadow,
        media: &MediaBuffer,
        eye: [f64; 3],
    ) -> Result<(), GpuError> {
        if grid.dims() != media.dims {
            return Err(GpuError::Input(format!(
                "the cells are of a {:?} grid, not of this {:?} one",
                media.dims,
                grid.dims()
            )));
        }
        if !eye.iter().all(|c| c.is_finite()) {
            return Err(GpuError::Input(format!("the eye {eye:?} is not finite")));
        }
        if media.params.albedo == 0.0 || media.dims.contains(&0) {
            return Ok(());
        }
        let groups = voxel_groups(ctx, media.dims, SIDE)?;
        let min = grid.bbox().min;
        let params = Params {
            eye: [0, 1, 2].map(|a| (eye[a] - min[a]) as f32),
            ..media.params
        };
        ctx.scoped("the orders' light per voxel", || {
            let params_buffer = OrdersPass::params_buffer(ctx, &params, &[]);
            let unused = || {
                ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("orders' unused"),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                })
            };
            self.dispatch(
                ctx,
                "orders apply",
                &self.apply,
                &[
                    &params_buffer,
                    &unused(),
                    grid.buffer(),
                    shadow.buffer(),
                    &media.last,
                    &media.spare,
                    &media.media,
                    &media.more,
                ],
                groups,
                1,
            );
        })?;
        let (albedo, g) = (f64::from(media.params.albedo), f64::from(media.params.g));
        grid.eye_peak
            .set(albedo * crate::render::grid_diffusion::eye_peak_share(g));
        Ok(())
    }

    /// The three steps in a row: [`OrdersPass::gather`], [`OrdersPass::diffuse`],
    /// [`OrdersPass::apply`] (what the renderer runs; submitted). Nothing is added when
    /// the medium does not scatter (`σt ≤ 0` or albedo 0).
    #[allow(clippy::too_many_arguments)]
    pub fn run_on(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        shadow: &EnvShadow,
        light: &RgbSh,
        env: &Environment,
        lights: &LightsPass,
        medium: &Medium,
        eye: [f64; 3],
        (factor, orders): (usize, usize),
        opts: &GridSolveOptions,
    ) -> Result<(), GpuError> {
        if coefficients(medium).is_none() || grid.dims().contains(&0) {
            return Ok(());
        }
        let media = self.gather(
            ctx, grid, shadow, light, env, lights, medium, factor, orders, 1.0,
        )?;
        self.diffuse(ctx, grid, shadow, &media, opts)?;
        self.apply(ctx, grid, shadow, &media, eye)
    }
}

/// Whether a wider automatic factor than [`AUTO_FACTOR`] was said (once a process).
static WIDENED_SAID: AtomicBool = AtomicBool::new(false);

/// The factor [`OrdersPass::gather`] takes for `factor` over a grid of `dims` on `ctx`'s
/// device: a given one as it is; [`MsDiffusion::AUTO`] the smallest from [`AUTO_FACTOR`]
/// up to [`MAX_FACTOR`] whose cells the device holds ([`max_cells`]; [`MAX_FACTOR`] if
/// none does, which `gather` then refuses), with a warning (once) where that is above
/// [`AUTO_FACTOR`].
pub fn auto_factor(ctx: &GpuContext, dims: [usize; 3], factor: usize) -> usize {
    if factor != MsDiffusion::AUTO {
        return factor;
    }
    let f = fitting_factor(dims, max_cells(ctx));
    if f > AUTO_FACTOR && !WIDENED_SAID.swap(true, Ordering::Relaxed) {
        tracing::warn!(
            "the multiple scattering's cells are {f}³ voxels, not {AUTO_FACTOR}³, to fit the device's {} MiB buffers: the scattering orders are coarser (a device with larger buffers, or the CPU, keeps smaller cells)",
            ctx.storage_limit() >> 20
        );
    }
    f
}

/// The smallest factor from [`AUTO_FACTOR`] to [`MAX_FACTOR`] whose cells over `dims`
/// (`⌈n/f⌉` a side) are at most `max_cells`; [`MAX_FACTOR`] if none.
fn fitting_factor(dims: [usize; 3], max_cells: usize) -> usize {
    let cells = |f: usize| dims.iter().map(|n| n.div_ceil(f)).product::<usize>();
    (AUTO_FACTOR..=MAX_FACTOR)
        .find(|&f| cells(f) <= max_cells)
        .unwrap_or(MAX_FACTOR)
}

/// The most cells [`OrdersPass::gather`] and [`OrdersPass::diffuse`] can hold on
/// `ctx`'s device ([`cells_within`] its largest storage binding).
pub fn max_cells(ctx: &GpuContext) -> usize {
    cells_within(ctx.storage_limit())
}

/// The most cells whose every per-cell buffer fits in a binding of `bytes`: the cells'
/// radiance ([`MEDIA`] words a cell), the green and blue bands after the box ([`BOX`] +
/// [`MORE`] a cell), the records (at most 13 + [`MAX_SUNS`] a cell) and the diffusion's
/// system ([`ROW`] a cell, [`STATE`] words and 8 a workgroup of [`CG_GROUP`] cells), the
/// largest of them a cell.
fn cells_within(bytes: u64) -> usize {
    let words = bytes / 4;
    let per_cell = |fixed: u64, per: u64| words.saturating_sub(fixed) / per;
    // 8·⌈n/G⌉ ≤ 8n/G + 8, so n(ROW·G + 8) ≤ G(words − STATE − 8) keeps the system within.
    let (g, row) = (CG_GROUP as u64, ROW as u64);
    let system = words.saturating_sub(STATE as u64 + 8) * g / (row * g + 8);
    let n = [
        per_cell(0, MEDIA as u64),
        per_cell(BOX as u64, MORE as u64),
        per_cell(0, (13 + MAX_SUNS) as u64),
        system,
    ]
    .into_iter()
    .min()
    .unwrap_or(0);
    usize::try_from(n).unwrap_or(usize::MAX)
}

/// The factor [`OrdersPass::gather`] takes on `ctx`'s device (the automatic one resolved
/// by [`auto_factor`]), or why it cannot gather: a factor or order count out of range, too
/// many suns, an environment grid of another volume, a projection with too few
/// coefficients, cells (their sources, radiance, bands or system) beyond the device's
/// buffers.
fn check_gather(
    ctx: &GpuContext,
    grid: &GridBuffer,
    shadow: &EnvShadow,
    light: &RgbSh,
    env: &Environment,
    factor: usize,
    orders: usize,
) -> Result<usize, GpuError> {
    let factor = auto_factor(ctx, grid.dims(), factor);
    if !(1..=MAX_FACTOR).contains(&factor) || !(1..=8).contains(&orders) {
        return Err(GpuError::Input(format!(
            "orders:{factor}:{orders}: on the GPU the factor must be 1 to {MAX_FACTOR} and the orders 1 to 8"
        )));
    }
    if env.suns.len() > MAX_SUNS {
        return Err(GpuError::Input(format!(
            "{} suns: the gathered orders on the GPU take at most {MAX_SUNS}",
            env.suns.len()
        )));
    }
    if !shadow.is_of(grid) {
        return Err(GpuError::Input(
            "the environment's grid is of another volume grid".into(),
        ));
    }
    let order = shadow.order();
    let n2 = (order * order).min(4);
    if light.iter().any(|c| c.len() < n2) {
        return Err(GpuError::Input(format!(
            "the environment's projection has fewer than {n2} coefficients"
        )));
    }
    let n = grid
        .dims()
        .map(|n| n.div_ceil(factor))
        .iter()
        .product::<usize>()
        .max(1);
    let record_bytes = (4 * n * (13 + env.suns.len())) as u64;
    ctx.check_storage_size("the gathered orders' sources", record_bytes)?;
    ctx.check_storage_size("the gathered orders' cells", (4 * MEDIA * n) as u64)?;
    ctx.check_storage_size("the gathered orders' bands", (4 * (BOX + MORE * n)) as u64)?;
    let system = ROW * n + STATE + 8 * n.div_ceil(CG_GROUP);
    ctx.check_storage_size("the orders' diffusion", (4 * system) as u64)?;
    Ok(factor)
}

/// The gathers' parameters for `grid` in cells of `factor` voxels a side (the first
/// order's: its records carry the suns): `medium`'s σt, Ω, g (the lights'
/// transmittance, the first source, the light towards the eye), its delta-Eddington
/// transport medium's with the diffusion's coefficients, and the first source's factor.
fn gather_params(
    grid: &GridBuffer,
    shadow: &EnvShadow,
    light: &RgbSh,
    env: &Environment,
    medium: &Medium,
    factor: usize,
    first_rule: &[([f64; 3], f64)],
) -> Params {
    let dims = grid.dims();
    let bbox = *grid.bbox();
    let order = shadow.order();
    let n2 = (order * order).min(4);
    let cells = dims.map(|n| n.div_ceil(factor));
    let vs = grid.voxel_size();
    let h = vs.map(|v| v * factor as f64);
    let hmin = h[0].min(h[1]).min(h[2]);
    let (node_min, node_cell, nodes) = shadow.node_frame();
    let a = phase_factors(medium, order);
    let mut env_coeffs = [[0.0f32; 4]; 4];
    for (j, e) in env_coeffs.iter_mut().enumerate().take(n2) {
        *e = [light[0][j], light[1][j], light[2][j], a[j]].map(|v| v as f32);
    }
    let stride = 13 + env.suns.len();
    let mut sun_norm = [[0.0f32; 4]; 2];
    for (k, sun) in env.suns.iter().enumerate().take(MAX_SUNS) {
        let phase = DiskPhase::shared(medium.g, sun.angle);
        sun_norm[k / 4][k % 4] = phase_norm(&phase, sun.direction, first_rule) as f32;
    }
    let (transport, first_scale) = medium.delta_eddington();
    let (sigma_s, sigma_a, sigma_tr) = coefficients(&transport).unwrap_or_default();
    Params {
        eye: [0.0; 3],
        sigma_t: medium.sigma_t as f32,
        voxel: vs.map(|v| v as f32),
        h0: vs[0].min(vs[1]).min(vs[2]) as f32,
        size: bbox.size().map(|v| v as f32),
        soft: ((0.5 * hmin).powi(2) / 3.0) as f32,
        dims: dims.map(|v| v as u32),
        factor: factor as u32,
        cells: cells.map(|v| v as u32),
        suns: env.suns.len() as u32,
        cell: h.map(|v| v as f32),
        points: env.points.len() as u32,
        g: medium.g as f32,
        albedo: medium.albedo as f32,
        k: (medium.albedo / FOUR_PI) as f32,
        stride: stride as u32,
        first: 1,
        order: order as u32,
        directions: 0,
        max_iterations: 0,
        node_min,
        warm: 0,
        node_cell,
        tolerance: 0.0,
        nodes,
        sigma_s: sigma_s as f32,
        sigma_a: sigma_a as f32,
        sigma_tr: sigma_tr as f32,
        rec_suns: env.suns.len() as u32,
        chunk_first: 1,
        transport_sigma_t: transport.sigma_t as f32,
        transport_albedo: transport.albedo as f32,
        transport_g: transport.g as f32,
        first_scale: first_scale as f32,
        env: env_coeffs,
        sun_norm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `n` cells fit in a binding of `bytes`, buffer by buffer as `gather` and
    /// `diffuse` size them.
    fn fits(n: usize, bytes: usize) -> bool {
        let system = ROW * n + STATE + 8 * n.div_ceil(CG_GROUP);
        [MEDIA * n, BOX + MORE * n, (13 + MAX_SUNS) * n, system]
            .iter()
            .all(|&words| 4 * words <= bytes)
    }

    /// The cells within a binding are the most that fit, buffer by buffer (within one cell:
    /// the system's partial sums are bounded, not counted), from lavapipe's 128 MiB to
    /// bindings of a few words.
    #[test]
    fn the_cells_within_a_binding_are_the_most_that_fit() {
        let lavapipe = 128usize << 20;
        assert_eq!(cells_within(lavapipe as u64), 779_768);
        for bytes in [
            lavapipe,
            1 << 20,
            4 << 30,
            1000,
            4 * (STATE + 8 + ROW),
            172,
            0,
        ] {
            let n = cells_within(bytes as u64);
            assert!(n == 0 || fits(n, bytes), "{bytes} B: {n} cells do not fit");
            assert!(!fits(n + 2, bytes), "{bytes} B: {} cells fit too", n + 2);
        }
    }

    /// The automatic factor grows until the cells fit: 2 where 2 fits, the first that
    /// fits beyond it (counted here cell by cell), the largest where none does.
    #[test]
    fn the_automatic_factor_grows_to_fit_the_device() {
        // Lavapipe's 128 MiB.
        let max = cells_within(128 << 20);
        assert_eq!(fitting_factor([64, 64, 96], max), 2);
        // 112 × 70 × 98 cells of 2 are 768 320; 100³ are 1 000 000, over it, and 67³
        // cells of 3 are 300 763.
        assert_eq!(fitting_factor([224, 140, 196], max), 2);
        assert_eq!(fitting_factor([200; 3], max), 3);
        // 10⁴ voxels a side: even cells of 8 are 1250³.
        assert_eq!(fitting_factor([10_000; 3], max), MAX_FACTOR);
        assert_eq!(fitting_factor([0; 3], 0), AUTO_FACTOR);
    }

    #[test]
    fn params_match_the_wgsl_layout() {
        assert_eq!(std::mem::offset_of!(Params, chunk_first), 188);
        assert_eq!(std::mem::offset_of!(Params, transport_sigma_t), 192);
        assert_eq!(std::mem::size_of::<Params>(), 208 + 64 + 32);
        assert_eq!(std::mem::offset_of!(Params, dims), 48);
        assert_eq!(std::mem::offset_of!(Params, cell), 80);
        assert_eq!(std::mem::offset_of!(Params, g), 96);
        assert_eq!(std::mem::offset_of!(Params, node_min), 128);
        assert_eq!(std::mem::offset_of!(Params, nodes), 160);
        assert_eq!(std::mem::offset_of!(Params, env), 208);
    }

    #[test]
    fn the_shader_keeps_the_cpu_constants() {
        use crate::render::grid_diffusion::{T_MIN, THIN};
        assert!(
            SHADER
                .entry
                .contains(&format!("const T_MIN: f32 = {T_MIN:e};"))
        );
        assert!(
            SHADER
                .entry
                .contains(&format!("const THIN: f32 = {THIN:e};"))
        );
        assert!(SHADER.entry.contains(&format!(
            "rule: array<vec4<f32>, {DIRECTIONS_PER_DISPATCH}>"
        )));
        assert!(
            SHADER
                .entry
                .contains(&format!("const HIGH: u32 = {HIGH}u;"))
        );
        assert_eq!(
            SHADER
                .entry
                .matches(&format!("var high: array<array<f32, {HIGH}>, 3>;"))
                .count(),
            2
        );
    }
}
