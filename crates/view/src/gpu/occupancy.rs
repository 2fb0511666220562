//! Which blocks of [`BLOCK`]³ voxels of a [`GridBuffer`] hold density within one voxel of
//! them (`crates/view/shaders/occupancy.wgsl`, one word a block, x fastest). The trilinear
//! `D` at any point of an empty block's closed region reads only voxels of that range, so
//! it is exactly 0 there: a march that passes over the samples in empty blocks sums the
//! same values in the same order. The environment grid's march (`env_pass.wgsl`) and the
//! view pass (`view_pass.wgsl`) skip by it; the CPU's rule is
//! [`crate::render::occupancy::Occupancy`].

use super::GridBuffer;
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline_at, line_groups, submit_pass};

/// The shader, `crates/view/shaders/occupancy.wgsl`.
pub const SHADER: Variant = Variant {
    label: "grid occupancy",
    entry: include_str!("../../shaders/occupancy.wgsl"),
    defines: &[],
};

/// Voxels per block side (`occupancy.wgsl`'s `BLOCK`).
pub const BLOCK: usize = 4;

/// Blocks per workgroup (`@workgroup_size(64)`).
const BLOCKS_PER_GROUP: usize = 64;

/// `occupancy.wgsl`'s parameters.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    dims: [u32; 3],
    _pad0: u32,
    blocks: [u32; 3],
    _pad1: u32,
}

/// Blocks per axis of a grid of `dims` voxels: `⌈dims / BLOCK⌉`.
pub fn blocks(dims: [usize; 3]) -> [usize; 3] {
    dims.map(|n| n.div_ceil(BLOCK))
}

/// The compiled occupancy pass, reusable across frames.
#[derive(Debug)]
pub struct OccupancyPass {
    pipeline: wgpu::ComputePipeline,
}

impl OccupancyPass {
    /// Compiles the shader and builds the pipeline.
    pub fn new(ctx: &GpuContext) -> Result<OccupancyPass, GpuError> {
        Ok(OccupancyPass {
            pipeline: compute_pipeline_at(
                ctx,
                "grid occupancy pipeline creation",
                &super::shaders::source(&SHADER)?,
                "main",
            )?,
        })
    }

    /// The workgroups [`OccupancyPass::submit`] dispatches for a grid of `dims` voxels;
    /// refuses a grid whose blocks the device cannot dispatch.
    pub fn groups(ctx: &GpuContext, dims: [usize; 3]) -> Result<[u32; 3], GpuError> {
        let count = blocks(dims).iter().product::<usize>();
        line_groups(ctx, count, BLOCKS_PER_GROUP, "occupancy blocks")
    }

    /// The occupancy of `grid`'s blocks (submitted as the pass `label`, the name its
    /// timestamps report; at least one word), dispatched as `groups`
    /// ([`OccupancyPass::groups`] of its dims).
    pub fn submit(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        groups: [u32; 3],
        label: &'static str,
    ) -> wgpu::Buffer {
        let dims = grid.dims();
        let blocks = blocks(dims);
        let count = blocks.iter().product::<usize>();
        let params = Params {
            dims: dims.map(|n| n as u32),
            _pad0: 0,
            blocks: blocks.map(|n| n as u32),
            _pad1: 0,
        };
        let params_buffer = buffer_init(
            ctx,
            "grid occupancy parameters",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("grid occupancy"),
            size: (count.max(1) * 4) as u64,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        submit_pass(
            ctx,
            &self.pipeline,
            label,
            &[&params_buffer, grid.buffer(), &buffer],
            groups,
        );
        buffer
    }
}
