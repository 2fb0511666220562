//! The volume pass of compensated ray marching on the GPU (`shaders/volume_pass.wgsl`),
//! the twin of [`crate::render::crm::volume_pass`]: the same grids, computed in `f32`.
//!
//! At every voxel center `u`: `D̃(u) = Σ w_ℓ B_ℓ(u)`, the source towards the eye
//! `J̃(u, d) = y(d)·Σ w_ℓ B_ℓ(u) J̃(c_ℓ) / D̃(u)` (clamped ≥ 0; `y` the real SH basis of
//! [`crate::sh::eval_into`], ported to WGSL for orders 1–6), and `D = max(D̃ + R, 0)`;
//! where `D̃ < MIN_DENSITY` the residual is ignored and `J̃ = 0`. The grids stay on the GPU
//! as a [`GridBuffer`], the input of [`ViewPass::run_on`](super::view_pass::ViewPass::run_on);
//! [`volume_pass`] reads them back as [`VolumeGrids`] (the tests compare them with the
//! CPU's).
//!
//! Uploads: per RBF its center relative to the box's minimum corner, `1/r`, `w` and a
//! culling radius; per center its source `J̃(c_ℓ)` as `f32` RGB SH; the residual as a
//! dense `f32` grid or — what a baked asset holds — the frame's hash volume of bricks
//! (offset table, keys, payloads and the packed values, one `u32` array), looked up on
//! the GPU exactly as [`ResidualGroup::lookup`](haze_hash::tile::ResidualGroup::lookup)
//! does, so `R` is the CPU's to the bit.
//!
//! Cost: every voxel visits the RBFs whose support meets its 4×4×4 tile. A tile tests the
//! RBFs 64 at a time, one per invocation, against the box of its voxel centers (`L/64`
//! rounds of a barrier and one sphere–box test per invocation), so a voxel's work is
//! `L/64` rounds plus `3n²` multiply-adds per RBF of its tile — the CPU's
//! `Σ_ℓ (voxels in the support of ℓ)·3n²`, up to the tile's rounding, plus the culling's
//! `O(voxels·L/64)`.

use super::{GridBuffer, SourceBuffer};
use crate::lighting::single::RgbSh;
use crate::render::crm::VolumeGrids;
use crate::stream::ResidualSlot;
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline, submit_pass, voxel_groups};
use haze_hash::tile::{bricks_per_frame, tile_origin};
use haze_volume::{Bbox, Rbf};

/// The shader: `crates/view/shaders/volume_pass.wgsl`, importing `sh_basis`.
pub const SHADER: Variant = Variant {
    label: "volume pass",
    entry: include_str!("../../shaders/volume_pass.wgsl"),
    defines: &[],
};

/// Voxels per workgroup side (`@workgroup_size(4, 4, 4)` in the shader).
const SIDE: usize = 4;

/// Relative margin of the culling radius `(3r)²`: the tile test must keep every RBF that
/// the per-voxel test `|(u − c)/r|² < 9`, rounded in `f32`, accepts (a few ulp apart).
const CULL_MARGIN: f64 = 1e-4;

/// The residual of the frame, as the volume pass takes it.
#[derive(Clone, Copy, Debug)]
pub enum Residual<'a> {
    /// `R` at every voxel (x fastest).
    Dense(&'a [f32]),
    /// The frame's slot in a hash volume, looked up on the GPU.
    Hash(&'a ResidualSlot),
}

/// The shader's `Params` (a read-only storage buffer): WGSL's layout (a `vec3` is 16-byte aligned and the
/// scalar after it fills its fourth slot), 112 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    eye: [f32; 3],
    count: u32,
    voxel: [f32; 3],
    order: u32,
    dims: [u32; 3],
    residual_kind: u32,
    hash_domain: [u32; 3],
    hash_m: u32,
    tile: [u32; 3],
    hash_r: u32,
    keys_at: u32,
    payloads_at: u32,
    data_at: u32,
    brick: u32,
    step: f32,
    _pad: [u32; 3],
}

/// The residual's binding: its kind for the shader and its words.
struct ResidualWords {
    kind: u32,
    words: Vec<u32>,
}

/// The hash volume of `slot` as one `u32` array (Φ, keys, payloads, packed values) and the
/// parameter fields that find its parts; a slot past the group's frames reads 0 everywhere,
/// as `ResidualGroup::lookup` does.
fn hash_words(
    slot: &ResidualSlot,
    dims: [usize; 3],
    params: &mut Params,
) -> Result<ResidualWords, GpuError> {
    let g = &slot.group;
    if g.dims.map(|d| d as usize) != dims {
        return Err(GpuError::Input(format!(
            "the residual's frames are {:?} voxels, the grid {dims:?}",
            g.dims
        )));
    }
    if slot.slot >= g.frames() {
        return Ok(ResidualWords {
            kind: 0,
            words: vec![0],
        });
    }
    let h = &g.hash;
    let (offsets, keys) = (h.offsets.len(), h.keys.len());
    let total = offsets + 2 * keys + g.data.len();
    let index = |n: usize| {
        u32::try_from(n).map_err(|_| {
            GpuError::Input(format!(
                "the residual hash ({offsets} offsets, {keys} slots, {} data words) is too large to index with 32 bits",
                g.data.len()
            ))
        })
    };
    index(total)?;
    let mut words = Vec::with_capacity(total);
    words.extend_from_slice(&h.offsets);
    words.extend_from_slice(&h.keys);
    words.extend_from_slice(&h.payloads);
    words.extend_from_slice(&g.data);
    *params = Params {
        hash_domain: h.domain,
        hash_m: h.m,
        tile: tile_origin(slot.slot, bricks_per_frame(g.dims, g.brick)),
        hash_r: h.r,
        keys_at: index(offsets)?,
        payloads_at: index(offsets + keys)?,
        data_at: index(offsets + 2 * keys)?,
        brick: g.brick,
        step: g.steps[slot.slot],
        ..*params
    };
    Ok(ResidualWords { kind: 2, words })
}

/// The compiled volume pass, reusable across frames.
#[derive(Debug)]
pub struct VolumePass {
    pipeline: wgpu::ComputePipeline,
}

impl VolumePass {
    /// Compiles the shader and builds the pipeline.
    pub fn new(ctx: &GpuContext) -> Result<VolumePass, GpuError> {
        let pipeline = compute_pipeline(
            ctx,
            "volume pass pipeline creation",
            &super::shaders::source(&SHADER)?,
        )?;
        Ok(VolumePass { pipeline })
    }

    /// The volume pass of a frame — RBFs over a `dims` grid on `bbox`, per-center source
    /// `source[ℓ]` (RGB SH of `order`), optional residual, the camera at `eye` — into a
    /// grid buffer on the GPU (submitted, not waited for). Refuses an order outside
    /// 1..=6, a source per RBF that is missing or has more than `order²` coefficients per
    /// channel (fewer are zero-padded, as the CPU sums them), a dense residual of the
    /// wrong length, a hash volume of other dims, and buffers or dispatches beyond the
    /// device's limits.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &self,
        ctx: &GpuContext,
        rbfs: &[Rbf],
        source: &[RgbSh],
        order: usize,
        dims: [usize; 3],
        bbox: &Bbox,
        residual: Option<Residual<'_>>,
        eye: [f64; 3],
    ) -> Result<GridBuffer, GpuError> {
        let source = SourceBuffer::upload(ctx, source, order)?;
        self.run_on(ctx, rbfs, &source, dims, bbox, residual, eye)
    }

    /// The volume pass with the sources at the centers already on the GPU (those a
    /// [`SingleScatteringPass`](super::single_scattering::SingleScatteringPass) wrote, or
    /// an upload), as [`VolumePass::run`].
    #[allow(clippy::too_many_arguments)]
    pub fn run_on(
        &self,
        ctx: &GpuContext,
        rbfs: &[Rbf],
        source: &SourceBuffer,
        dims: [usize; 3],
        bbox: &Bbox,
        residual: Option<Residual<'_>>,
        eye: [f64; 3],
    ) -> Result<GridBuffer, GpuError> {
        if source.count() != rbfs.len() {
            return Err(GpuError::Input(format!(
                "{} source vectors for {} RBFs",
                source.count(),
                rbfs.len()
            )));
        }
        let order = source.order();
        let count = u32::try_from(rbfs.len())
            .map_err(|_| GpuError::Input(format!("{} RBFs are too many", rbfs.len())))?;
        let voxels = dims.iter().product::<usize>();
        let groups = voxel_groups(ctx, dims, SIDE)?;

        // Positions relative to the box's minimum corner, as the view pass.
        let size = bbox.size();
        let voxel = [0, 1, 2].map(|a| size[a] / dims[a].max(1) as f64);
        let mut params = Params {
            eye: [0, 1, 2].map(|a| (eye[a] - bbox.min[a]) as f32),
            count,
            voxel: voxel.map(|v| v as f32),
            order: order as u32,
            dims: dims.map(|n| n as u32),
            ..Params::default()
        };
        let resid = match residual {
            None => ResidualWords {
                kind: 0,
                words: vec![0],
            },
            Some(Residual::Dense(r)) => {
                if r.len() != voxels {
                    return Err(GpuError::Input(format!(
                        "the residual has {} voxels, the grid {voxels}",
                        r.len()
                    )));
                }
                let mut words: Vec<u32> = bytemuck::cast_slice(r).to_vec();
                if words.is_empty() {
                    words.push(0);
                }
                ResidualWords { kind: 1, words }
            }
            Some(Residual::Hash(slot)) => hash_words(slot, dims, &mut params)?,
        };
        params.residual_kind = resid.kind;

        // Per RBF: (center, 1/r), (w, culling radius², 0, 0); an RBF without support (a
        // radius that is not positive and finite, or 0 in f32) has a negative culling
        // radius² and is never visited, as `Rbf::eval` is zero everywhere for it.
        let mut rbf_data: Vec<[f32; 4]> = Vec::with_capacity(2 * rbfs.len().max(1));
        for b in rbfs {
            let r = b.radius as f32;
            let supported = b.radius > 0.0 && b.radius.is_finite() && r > 0.0 && r.is_finite();
            let c = [0, 1, 2].map(|a| (b.center[a] - bbox.min[a]) as f32);
            let s = b.support_radius();
            let (inv_r, cull2) = if supported {
                (
                    (1.0 / b.radius) as f32,
                    (s * s * (1.0 + CULL_MARGIN)) as f32,
                )
            } else {
                (0.0, -1.0)
            };
            rbf_data.push([c[0], c[1], c[2], inv_r]);
            rbf_data.push([b.weight as f32, cull2, 0.0, 0.0]);
        }
        if rbf_data.is_empty() {
            rbf_data.push([0.0; 4]);
        }
        ctx.check_storage_size(
            "the residual",
            std::mem::size_of_val(resid.words.as_slice()) as u64,
        )?;
        let grid = GridBuffer::create(ctx, dims, *bbox)?;

        ctx.scoped("the volume pass", || {
            let storage = wgpu::BufferUsages::STORAGE;
            let params_buffer = buffer_init(
                ctx,
                "volume pass parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::STORAGE,
            );
            let rbf_buf = buffer_init(
                ctx,
                "volume pass RBFs",
                bytemuck::cast_slice(&rbf_data),
                storage,
            );
            let residual_buf = buffer_init(
                ctx,
                "volume pass residual",
                bytemuck::cast_slice(&resid.words),
                storage,
            );
            let buffers = [
                &params_buffer,
                &rbf_buf,
                source.buffer(),
                &residual_buf,
                grid.buffer(),
            ];
            submit_pass(ctx, &self.pipeline, "volume pass", &buffers, groups);
        })?;
        Ok(grid)
    }
}

/// [`crate::render::crm::volume_pass`] on the GPU, read back: compiles the pass, runs it
/// once and copies the grids to the host (keep a [`VolumePass`] and chain
/// [`VolumePass::run`] into the view pass to render frames).
#[allow(clippy::too_many_arguments)]
pub fn volume_pass(
    ctx: &GpuContext,
    rbfs: &[Rbf],
    source: &[RgbSh],
    order: usize,
    dims: [usize; 3],
    bbox: &Bbox,
    residual: Option<Residual<'_>>,
    eye: [f64; 3],
) -> Result<VolumeGrids, GpuError> {
    VolumePass::new(ctx)?
        .run(ctx, rbfs, source, order, dims, bbox, residual, eye)?
        .read(ctx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_match_the_wgsl_layout() {
        assert_eq!(std::mem::size_of::<Params>(), 112);
        assert_eq!(std::mem::offset_of!(Params, dims), 32);
        assert_eq!(std::mem::offset_of!(Params, tile), 64);
        assert_eq!(std::mem::offset_of!(Params, keys_at), 80);
        assert_eq!(std::mem::offset_of!(Params, brick), 92);
        assert_eq!(std::mem::offset_of!(Params, step), 96);
    }
}
