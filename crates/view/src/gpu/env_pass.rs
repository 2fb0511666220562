//! The environment pass on the GPU (`shaders/env_pass.wgsl`), the twin of
//! [`crate::render::env_pass::env_pass`]: the distant environment's single scattering
//! added per voxel to the volume pass's grids, in `f32`, in place on a [`GridBuffer`].
//!
//! Three dispatches: `needed`, one invocation per node of the grid
//! ([`env_pass::grid_frame`]), marks the nodes the pass reads (the CPU's
//! [`env_pass::needed_nodes`] criterion, tested per node on the GPU by a scan of the
//! voxels within a cell) and reduces their domain; `sweep` writes `S_lm` at those nodes
//! from their optical depths towards each direction of the rule, found by the CPU's
//! default sweep ([`EnvDepths::Sweep`]; its dispatches: [`super::env_sweep`]); `apply`,
//! one invocation per voxel with `D > 0`, adds `max(0, Σ Ω g^l (L_j − S_j(u)) Y_j(d))`.
//! The marches (the domain's first planes, the rays that leave it through a side) visit
//! every sample to the box's face (the CPU skips the samples outside the smoke's box,
//! which are zeros: the same sum).
//!
//! A march from every node instead (the CPU's [`EnvDepths::March`]) cost 113 ms a new
//! frame of a 128 × 128 × 170 grid on an NVIDIA H200 (BENCHMARKS "`haze bench` on an
//! NVIDIA H200"): each node's way out, tens to hundreds of voxels, for 72 directions at
//! 843 000 nodes, where the sweep takes a segment of a few samples and four reads.
//!
//! [`EnvDepths::Sweep`]: crate::render::env_pass::EnvDepths::Sweep
//! [`EnvDepths::March`]: crate::render::env_pass::EnvDepths::March
//!
//! Uploads: per direction `ω`, `w·L(ω)` and `Y(ω)` (`8 + order²` words); per coefficient
//! `L_j` and `Ω g^l` (4 words). The nodes' `S` stays on the GPU ([`EnvShadow`]) and can be
//! read back for tests.

use super::env_sweep::{self, SweepBuffers, SweepPlan};
use super::occupancy::OccupancyPass;
use super::{GridBuffer, SourceBuffer};
use crate::distant::Distant;
use crate::env::Environment;
use crate::lighting::single::RgbSh;
use crate::medium::Medium;
use crate::render::env_pass::{self, EnvGridOptions};
use crate::render::peak_rule::PeakRule;
use crate::sh::{self, ShGrid};
use haze_gpu::wgsl::Variant;
use haze_gpu::{
    GpuContext, GpuError, buffer_init, compute_pipeline_at, line_groups, submit_pass, voxel_groups,
};
use haze_volume::Bbox;
use std::sync::atomic::{AtomicBool, Ordering};

/// The shader: `crates/view/shaders/env_pass.wgsl`, importing `sh_basis` and the shadow
/// march shared with the lights pass (`grid_march`).
pub const SHADER: Variant = Variant {
    label: "environment pass",
    entry: include_str!("../../shaders/env_pass.wgsl"),
    defines: &[],
};

/// Voxels per workgroup side of `apply` (`@workgroup_size(4, 4, 4)`).
const SIDE: usize = 4;

/// Nodes per workgroup of `needed` and `sweep` (`@workgroup_size(64)`).
const NODES: usize = 64;

/// The shader's `Params` (a read-only storage buffer) (WGSL layout), 112 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    eye: [f32; 3],
    sigma_t: f32,
    voxel: [f32; 3],
    h0: f32,
    size: [f32; 3],
    order: u32,
    dims: [u32; 3],
    directions: u32,
    node_min: [f32; 3],
    /// `Ω·f` of the forward peak (`env_pass::peak_share`); 0 for none.
    peak: f32,
    cell: [f32; 3],
    /// `apply`: cells of the forward peak's rule (`render::peak_rule`); 0 for none.
    peak_cells: u32,
    nodes: [u32; 3],
    /// `apply`: directions per cell of the peak's rule.
    peak_azimuths: u32,
}

/// Times the environment's grid may be made coarser to fit the device's buffers.
const MAX_WIDENINGS: usize = 8;

/// Whether the widening of the environment's grid was said already (once a process: a
/// viewer would say it every frame).
static WIDENED_SAID: AtomicBool = AtomicBool::new(false);

/// The environment grid's nodes over a `dims` grid on `bbox`, `spacing` voxels apart,
/// made coarser until both its `3·n2` f32 a node and the sweep's rings for `directions`
/// directions ([`env_sweep::ring_bytes`], planes of nodes) fit `limit` bytes: each time by
/// the larger of the cube root of the nodes' excess and the square root of the rings',
/// and a tenth more, at most [`MAX_WIDENINGS`] times. The frame, the nodes' bytes and the
/// spacing it has (a frame still over `limit` is the caller's to refuse).
fn fitting_frame(
    dims: [usize; 3],
    bbox: &Bbox,
    spacing: f64,
    (order, n2): (usize, usize),
    directions: usize,
    limit: u64,
) -> (ShGrid, u64, f64) {
    let at = |spacing: f64| {
        let frame = env_pass::grid_frame(dims, bbox, spacing, order);
        let bytes = (frame.len() * 3 * n2).max(1) as u64 * 4;
        let ring = env_sweep::ring_bytes(frame.nodes, directions);
        (frame, bytes, ring)
    };
    let (mut spacing, (mut frame, mut bytes, mut ring)) = (spacing, at(spacing));
    for _ in 0..MAX_WIDENINGS {
        if bytes <= limit && ring <= limit {
            break;
        }
        let excess = |b: u64| b as f64 / limit.max(1) as f64;
        spacing *= 1.1 * excess(bytes).cbrt().max(excess(ring).sqrt()).max(1.0);
        (frame, bytes, ring) = at(spacing);
    }
    (frame, bytes, spacing)
}

/// `S_lm` at the grid's nodes on the GPU (`3·order²` `f32` per node, channel fastest, as
/// [`crate::sh::ShGrid::coeffs`]), with the grid's frame: what [`EnvPass::grid`] computed,
/// ready for any number of [`EnvPass::apply`] (it depends on the density, σt, the
/// environment, the order and [`EnvGridOptions`], not on the eye, the albedo or `g`).
#[derive(Debug)]
pub struct EnvShadow {
    buffer: wgpu::Buffer,
    len: usize,
    /// The `needed` and `sweep` dispatches' parameters (the eye left at zero): the nodes' frame and
    /// the volume grid's size, which `apply` shares.
    params: Params,
    order: usize,
    dims: [usize; 3],
    bbox: Bbox,
}

impl EnvShadow {
    /// Reads the coefficients back (a wait).
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<f32>, GpuError> {
        let bytes = ctx.read_buffer(&self.buffer)?;
        Ok(bytemuck::cast_slice::<u8, f32>(&bytes)[..self.len].to_vec())
    }

    /// The SH order of the coefficients.
    pub fn order(&self) -> usize {
        self.order
    }

    /// Whether it is the grid of a volume grid of `grid`'s dims and box.
    pub fn is_of(&self, grid: &GridBuffer) -> bool {
        self.dims == grid.dims() && self.bbox == *grid.bbox()
    }

    /// The nodes' frame as the shader takes it: the first node relative to the box's
    /// minimum corner, the distance between nodes, the nodes per axis.
    pub(crate) fn node_frame(&self) -> ([f32; 3], [f32; 3], [u32; 3]) {
        (self.params.node_min, self.params.cell, self.params.nodes)
    }

    /// The storage buffer of the coefficients.
    pub(crate) fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}

/// The compiled environment pass, reusable across frames.
#[derive(Debug)]
pub struct EnvPass {
    occupancy: OccupancyPass,
    needed: wgpu::ComputePipeline,
    sweep: wgpu::ComputePipeline,
    apply: wgpu::ComputePipeline,
}

fn check_order(order: usize) -> Result<usize, GpuError> {
    if !(1..=sh::MAX_ORDER).contains(&order) {
        return Err(GpuError::Input(format!(
            "SH order {order} is outside 1..={}",
            sh::MAX_ORDER
        )));
    }
    Ok(sh::count(order))
}

impl EnvPass {
    /// Compiles the shader and builds its pipelines.
    pub fn new(ctx: &GpuContext) -> Result<EnvPass, GpuError> {
        let source = super::shaders::source(&SHADER)?;
        Ok(EnvPass {
            occupancy: OccupancyPass::new(ctx)?,
            needed: compute_pipeline_at(
                ctx,
                "environment grid nodes pipeline creation",
                &source,
                "needed",
            )?,
            sweep: compute_pipeline_at(
                ctx,
                "environment grid pipeline creation",
                &source,
                "sweep",
            )?,
            apply: compute_pipeline_at(
                ctx,
                "environment pass pipeline creation",
                &source,
                "apply",
            )?,
        })
    }

    /// Adds the environment's single scattering to the grids on the GPU (those a
    /// [`VolumePass`](super::volume_pass::VolumePass) wrote, or an upload), camera at
    /// `eye`, as [`env_pass::env_pass`] does on the CPU (submitted, not waited for):
    /// [`EnvPass::grid`] then [`EnvPass::apply`]; `light` is the environment's projection
    /// at `order`. Returns the nodes' `S`. With albedo 0 the grid is computed and nothing
    /// added. Refuses an order outside 1..=6, a `light` of another order, a non-finite eye
    /// and sizes beyond the device's limits.
    #[allow(clippy::too_many_arguments)]
    pub fn run_on(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        env: &Environment,
        light: &RgbSh,
        medium: &Medium,
        eye: [f64; 3],
        order: usize,
        opts: &EnvGridOptions,
    ) -> Result<EnvShadow, GpuError> {
        let n2 = check_order(order)?;
        if light.iter().any(|c| c.len() < n2) {
            return Err(GpuError::Input(format!(
                "the environment's projection has fewer than {n2} coefficients"
            )));
        }
        if !eye.iter().all(|c| c.is_finite()) {
            return Err(GpuError::Input(format!("the eye {eye:?} is not finite")));
        }
        let shadow = self.grid(ctx, grid, env, medium.sigma_t, order, opts)?;
        self.apply(ctx, grid, &shadow, light, medium, eye, &env.distant)?;
        Ok(shadow)
    }

    /// The `needed` and `sweep` dispatches alone (one timed pass, submitted): `S_lm` at
    /// the nodes of the environment's grid over `grid`'s `D`, for σt `sigma_t` (module
    /// docs); none without extinction or light (`S = 0`). Refuses an order outside 1..=6
    /// and sizes beyond the device's limits.
    pub fn grid(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        env: &Environment,
        sigma_t: f64,
        order: usize,
        opts: &EnvGridOptions,
    ) -> Result<EnvShadow, GpuError> {
        let n2 = check_order(order)?;
        let dims = grid.dims();
        let bbox = *grid.bbox();
        let rule = env_pass::lit_directions(env, opts.theta, order);
        let (frame, bytes, spacing) = fitting_frame(
            dims,
            &bbox,
            opts.spacing,
            (order, n2),
            rule.len(),
            ctx.storage_limit(),
        );
        if spacing != opts.spacing && !WIDENED_SAID.swap(true, Ordering::Relaxed) {
            tracing::warn!(
                "the environment's grid is spaced {spacing:.2} voxels, not {}, to fit the device's {} MiB buffers: the sky's light through the smoke is coarser (a device with larger buffers, or the CPU, keeps {})",
                opts.spacing,
                ctx.storage_limit() >> 20,
                opts.spacing
            );
        }
        let total = frame.len();
        let len = total * 3 * n2;
        ctx.check_storage_size("the environment's grid", bytes)?;
        let plan = SweepPlan::new(ctx, &frame, &rule, NODES)?;
        let vs = grid.voxel_size();
        let params = Params {
            eye: [0.0; 3],
            sigma_t: sigma_t as f32,
            voxel: vs.map(|v| v as f32),
            h0: vs[0].min(vs[1]).min(vs[2]) as f32,
            size: bbox.size().map(|v| v as f32),
            order: order as u32,
            dims: dims.map(|n| n as u32),
            directions: plan.directions(),
            node_min: [0, 1, 2].map(|k| (frame.min[k] - bbox.min[k]) as f32),
            peak: 0.0,
            cell: frame.cell.map(|c| c as f32),
            peak_cells: 0,
            nodes: frame.nodes.map(|n| n as u32),
            peak_azimuths: 0,
        };
        // Nothing is taken away without extinction or light: the grid stays zero.
        let sweeps = params.sigma_t > 0.0 && !rule.is_empty();
        let block_groups = OccupancyPass::groups(ctx, dims)?;
        ctx.scoped("the environment grid", || {
            let shadow = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("environment grid"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            if sweeps {
                let params_buffer = buffer_init(
                    ctx,
                    "environment grid parameters",
                    bytemuck::bytes_of(&params),
                    wgpu::BufferUsages::STORAGE,
                );
                let occupancy = self
                    .occupancy
                    .submit(ctx, grid, block_groups, "grid occupancy");
                plan.submit(
                    ctx,
                    [&self.needed, &self.sweep],
                    SweepBuffers {
                        params: &params_buffer,
                        grid: grid.buffer(),
                        shadow: &shadow,
                        occupancy: &occupancy,
                    },
                );
            }
            EnvShadow {
                buffer: shadow,
                len,
                params,
                order,
                dims,
                bbox,
            }
        })
    }

    /// The `apply` dispatch alone (submitted): adds to `grid`'s `J̃`, camera at `eye`,
    /// the environment's single scattering from `shadow` (an [`EnvPass::grid`] of a grid
    /// with the same `D`), `light`, the environment's projection at `shadow`'s order, and
    /// `distant`, whose radiance HG's forward peak sees (`env_pass`'s module docs);
    /// nothing with albedo 0. Refuses a grid of other dims or box than `shadow`'s, a
    /// `light` of another order, a non-finite eye and sizes beyond the device's limits.
    #[allow(clippy::too_many_arguments)]
    pub fn apply(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        shadow: &EnvShadow,
        light: &RgbSh,
        medium: &Medium,
        eye: [f64; 3],
        distant: &Distant,
    ) -> Result<(), GpuError> {
        let order = shadow.order;
        let n2 = check_order(order)?;
        if light.iter().any(|c| c.len() < n2) {
            return Err(GpuError::Input(format!(
                "the environment's projection has fewer than {n2} coefficients"
            )));
        }
        if !eye.iter().all(|c| c.is_finite()) {
            return Err(GpuError::Input(format!("the eye {eye:?} is not finite")));
        }
        let dims = grid.dims();
        let bbox = *grid.bbox();
        if dims != shadow.dims || bbox != shadow.bbox {
            return Err(GpuError::Input(format!(
                "the environment's grid is of a {:?} grid, not of this {dims:?} one",
                shadow.dims
            )));
        }
        let a = env_pass::env_phase_factors(medium, order);
        let f = env_pass::peak_share(medium, order);
        let mut factors: Vec<f32> = Vec::with_capacity(4 * n2);
        for (j, aj) in a.iter().enumerate() {
            factors.extend([light[0][j], light[1][j], light[2][j], *aj].map(|v| v as f32));
        }
        // The forward peak's sky after the factors (`env_pass.wgsl`'s PEAK_*), then its
        // rule's cells: cos θ, sin θ, Ω·weight, 0.
        let rule = PeakRule::new(medium.g, order, f);
        if f > 0.0 {
            for t in env_pass::peak_sky(distant).texels {
                factors.extend(t);
            }
            for c in &rule.cells {
                factors.extend([c.cos, c.sin, medium.albedo * c.weight, 0.0].map(|v| v as f32));
            }
        } else {
            factors.extend([0.0; 3]);
        }
        let params = Params {
            eye: [0, 1, 2].map(|k| (eye[k] - bbox.min[k]) as f32),
            peak: (medium.albedo * f) as f32,
            peak_cells: rule.cells.len() as u32,
            peak_azimuths: rule.azimuths as u32,
            ..shadow.params
        };
        let groups = voxel_groups(ctx, dims, SIDE)?;
        if medium.albedo == 0.0 || dims.contains(&0) {
            return Ok(());
        }
        ctx.scoped("the environment pass", || {
            let params_buffer = buffer_init(
                ctx,
                "environment pass parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::STORAGE,
            );
            let factors = buffer_init(
                ctx,
                "environment projection",
                bytemuck::cast_slice(&factors),
                wgpu::BufferUsages::STORAGE,
            );
            submit_pass(
                ctx,
                &self.apply,
                "environment pass",
                &[&params_buffer, &factors, grid.buffer(), &shadow.buffer],
                groups,
            );
        })
    }
}

/// `shaders/remove_single.wgsl`.
pub const REMOVE_SHADER: Variant = Variant {
    label: "single scattering removal",
    entry: include_str!("../../shaders/remove_single.wgsl"),
    defines: &[],
};

/// The centers' single scattering taken out of their sources on the GPU (the renderer's
/// GPU lighting with [`crate::render::env_pass::EnvSource::Grid`]): a copy of the sources
/// taken before the diffusion adds `J̃ms`, subtracted after it.
#[derive(Debug)]
pub struct RemoveSingle {
    pipeline: wgpu::ComputePipeline,
}

impl RemoveSingle {
    /// Compiles the shader.
    pub fn new(ctx: &GpuContext) -> Result<RemoveSingle, GpuError> {
        Ok(RemoveSingle {
            pipeline: haze_gpu::compute_pipeline(
                ctx,
                "remove single pipeline creation",
                &super::shaders::source(&REMOVE_SHADER)?,
            )?,
        })
    }

    /// A copy of `sources` (submitted).
    pub fn copy(&self, ctx: &GpuContext, sources: &SourceBuffer) -> Result<wgpu::Buffer, GpuError> {
        let src = sources.buffer();
        ctx.scoped("copying the single scattering", || {
            let copy = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("single scattering at the centers"),
                size: src.size(),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("copying the single scattering"),
                });
            enc.copy_buffer_to_buffer(src, 0, &copy, 0, src.size());
            ctx.queue.submit([enc.finish()]);
            copy
        })
    }

    /// `sources −= copy` word by word (the escape words kept; submitted).
    pub fn run(
        &self,
        ctx: &GpuContext,
        sources: &SourceBuffer,
        copy: &wgpu::Buffer,
    ) -> Result<(), GpuError> {
        let words = (sources.buffer().size() / 4) as usize;
        let groups = line_groups(ctx, words.max(1), NODES, "source words")?;
        ctx.scoped("removing the single scattering", || {
            submit_pass(
                ctx,
                &self.pipeline,
                "remove single",
                &[sources.buffer(), copy],
                groups,
            );
        })
    }
}

#[cfg(test)]
mod tests {
    use super::fitting_frame;

    /// A grid over the device's buffers gets the coarsest spacing it needs and not much
    /// more: lavapipe's 128 MiB and a 128 × 128 × 170 grid at 1.5 voxels, SH order 4
    /// (162 MB), land between 1.5 and 1.5 · 1.1 · ∛(162/128) ≈ 1.78; a grid that fits
    /// keeps its spacing; a limit nothing meets stops after the widenings, finite.
    #[test]
    fn the_environment_grid_widens_just_enough_to_fit() {
        let bbox = haze_volume::Bbox::new([0.0; 3], [1.0, 1.0, 1.33]);
        let dims = [128, 128, 170];
        let (_, full, same) = fitting_frame(dims, &bbox, 1.5, (4, 16), 72, u64::MAX);
        assert_eq!(same, 1.5);
        assert!(full > 128 << 20, "{full}");
        let (frame, bytes, spacing) = fitting_frame(dims, &bbox, 1.5, (4, 16), 72, 128 << 20);
        assert!(bytes <= 128 << 20 && bytes == frame.len() as u64 * 3 * 16 * 4);
        let most = 1.5 * 1.1 * (full as f64 / (128u64 << 20) as f64).cbrt();
        assert!(
            spacing > 1.5 && spacing <= most * 1.0001,
            "{spacing} (at most {most})"
        );
        let (_, tiny, wide) = fitting_frame(dims, &bbox, 1.5, (4, 16), 72, 4);
        assert!(tiny > 4 && wide.is_finite());
    }

    /// A wide flat grid at SH order 1: its nodes' 3 words fit 128 MiB at 1.5 voxels, the
    /// sweep's rings (8 planes of 1000 × 1000-odd nodes for 72 directions, ~2 GB) do not;
    /// the grid widens until they do, by about the square root of their excess.
    #[test]
    fn the_sweeps_rings_widen_a_flat_grid_too() {
        let bbox = haze_volume::Bbox::new([0.0; 3], [10.0, 10.0, 0.1]);
        let dims = [1500, 1500, 15];
        let limit = 128u64 << 20;
        let (frame, bytes, same) = fitting_frame(dims, &bbox, 1.5, (1, 1), 72, u64::MAX);
        let full = crate::gpu::env_sweep::ring_bytes(frame.nodes, 72);
        assert!(
            same == 1.5 && bytes <= limit && full > limit,
            "{bytes} {full}"
        );
        let (frame, bytes, spacing) = fitting_frame(dims, &bbox, 1.5, (1, 1), 72, limit);
        let ring = crate::gpu::env_sweep::ring_bytes(frame.nodes, 72);
        assert!(bytes <= limit && ring <= limit, "{bytes} {ring}");
        let most = 1.5 * 1.1 * (full as f64 / limit as f64).sqrt();
        assert!(
            spacing > 1.5 && spacing <= most * 1.0001,
            "{spacing} (at most {most})"
        );
    }

    use super::*;

    #[test]
    fn params_match_the_wgsl_layout() {
        assert_eq!(std::mem::size_of::<Params>(), 112);
        assert_eq!(std::mem::offset_of!(Params, dims), 48);
        assert_eq!(std::mem::offset_of!(Params, node_min), 64);
        assert_eq!(std::mem::offset_of!(Params, cell), 80);
        assert_eq!(std::mem::offset_of!(Params, nodes), 96);
    }
}
