//! The view pass of compensated ray marching on the GPU (`shaders/view_pass.wgsl`), the
//! twin of [`crate::render::crm::view_pass`]: the same image, computed in `f32`.
//!
//! Per pixel, slices perpendicular to the camera axis `Δu` apart meet the ray at `u_i`,
//! `Δs = Δu / cos γ`, `Δτ_i = exp(−σt D(u_i) Δs)`, and front to back
//!
//! ```text
//! L = L_env(d) · Π Δτ_j  +  Σ_i J̃(u_i) (1 − Δτ_i) · Π_{j<i} Δτ_j
//! ```
//!
//! stopping once the transmittance is below [`crm::OPAQUE`](crate::render::crm::OPAQUE).
//!
//! Inputs on the GPU: `D` and `J̃` interleaved in one storage buffer (`vec4` per voxel,
//! trilinear by hand with the CPU's stencil and exact `f32` weights: the filtering units
//! of GPUs interpolate with 8-bit weights, and 32-bit float textures are not filterable
//! everywhere); the environment as the CPU has it — the built-in sky evaluated
//! analytically, a lat-long map uploaded texel for texel and looked up bilinearly with
//! `LatLong::radiance`'s convention — so the background differs from the CPU's by `f32`
//! rounding only. Coordinates are relative to the box's minimum corner.

use super::{GpuContext, GpuError};
use crate::camera::Camera;
use crate::env::Environment;
use crate::medium::Medium;
use crate::render::crm::VolumeGrids;
use wgpu::util::DeviceExt;

/// The shader, `crates/view/shaders/view_pass.wgsl`.
pub const SHADER: &str = include_str!("../../shaders/view_pass.wgsl");

/// Pixels per workgroup side (`@workgroup_size(8, 8)` in the shader).
const TILE: u32 = 8;

/// The shader's `Params` uniform: WGSL's layout (a `vec3` is 16-byte aligned and the
/// scalar after it fills its fourth slot), 208 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    eye: [f32; 3],
    tan_half: f32,
    forward: [f32; 3],
    aspect: f32,
    right: [f32; 3],
    sigma_t: f32,
    up: [f32; 3],
    du: f32,
    size: [f32; 3],
    env_kind: u32,
    voxel: [f32; 3],
    _pad0: f32,
    dims: [u32; 3],
    _pad1: u32,
    image: [u32; 2],
    env_size: [u32; 2],
    zenith: [f32; 3],
    sharpness: f32,
    horizon: [f32; 3],
    _pad2: f32,
    ground: [f32; 3],
    _pad3: f32,
    sun_direction: [f32; 3],
    _pad4: f32,
    sun: [f32; 3],
    _pad5: f32,
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

/// The compiled view pass, reusable across frames.
#[derive(Debug)]
pub struct ViewPass {
    pipeline: wgpu::ComputePipeline,
}

impl ViewPass {
    /// Compiles the shader and builds the pipeline.
    pub fn new(ctx: &GpuContext) -> Result<ViewPass, GpuError> {
        let pipeline = ctx.scoped("view pass pipeline creation", || {
            let module = ctx
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some("view_pass.wgsl"),
                    source: wgpu::ShaderSource::Wgsl(SHADER.into()),
                });
            ctx.device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("view pass"),
                    layout: None,
                    module: &module,
                    entry_point: Some("main"),
                    compilation_options: Default::default(),
                    cache: None,
                })
        })?;
        Ok(ViewPass { pipeline })
    }

    /// The image of the volume-pass grids `g` (RGB per pixel, row 0 at the top), slice
    /// thickness `du` (world units). Refuses grids whose radiance does not match the
    /// density's voxels, a `du` that is not positive and finite, a sky with a negative
    /// sun sharpness, and buffers beyond the device's limits.
    pub fn run(
        &self,
        ctx: &GpuContext,
        g: &VolumeGrids,
        medium: &Medium,
        env: &Environment,
        camera: &Camera,
        du: f64,
    ) -> Result<Vec<[f32; 3]>, GpuError> {
        let dims = g.density.dims();
        let voxels = dims.iter().product::<usize>();
        if g.radiance.len() != voxels {
            return Err(GpuError::Input(format!(
                "the radiance grid has {} voxels, the density grid {voxels}",
                g.radiance.len()
            )));
        }
        if !(du > 0.0 && du.is_finite()) {
            return Err(GpuError::Input(format!(
                "slice thickness {du} must be positive and finite"
            )));
        }
        let (width, height) = (camera.width, camera.height);
        let groups = [width, height].map(|n| n.div_ceil(TILE as usize));
        let max_groups = ctx.device.limits().max_compute_workgroups_per_dimension as usize;
        if groups.iter().any(|&n| n > max_groups) {
            return Err(GpuError::Input(format!(
                "an image of {width}×{height} pixels is larger than the device dispatches ({} pixels a side at most)",
                max_groups * TILE as usize
            )));
        }

        // D and J̃ interleaved; one zero voxel stands in for an empty grid (the shader
        // sees the zero dims and samples nothing).
        let mut cells: Vec<[f32; 4]> = g
            .radiance
            .iter()
            .zip(g.density.data())
            .map(|(j, d)| [j[0], j[1], j[2], *d])
            .collect();
        if cells.is_empty() {
            cells.push([0.0; 4]);
        }
        let (env_kind, env_size, texels, sky) = match env {
            Environment::Sky(s) => {
                if !(s.sharpness >= 0.0 && s.sharpness.is_finite()) {
                    return Err(GpuError::Input(format!(
                        "sky sun sharpness {} must be finite and ≥ 0",
                        s.sharpness
                    )));
                }
                (0, [0, 0], vec![[0.0f32; 3]], Some(s))
            }
            Environment::Map(m) => (1, [m.width as u32, m.height as u32], m.texels.clone(), None),
        };
        let sky = sky.cloned().unwrap_or_default();
        let cell_bytes = std::mem::size_of_val(cells.as_slice()) as u64;
        let env_bytes = std::mem::size_of_val(texels.as_slice()) as u64;
        let out_bytes = (width * height * 16) as u64;
        ctx.check_storage_size("the volume (density and radiance)", cell_bytes)?;
        ctx.check_storage_size("the environment map", env_bytes)?;
        ctx.check_storage_size("the image", out_bytes)?;

        let bbox = g.density.bbox();
        let eye = [0, 1, 2].map(|a| camera.eye[a] - bbox.min[a]);
        let params = Params {
            eye: f32x3(eye),
            tan_half: camera.tan_half() as f32,
            forward: f32x3(camera.forward()),
            aspect: (width as f64 / height as f64) as f32,
            right: f32x3(camera.right()),
            sigma_t: medium.sigma_t as f32,
            up: f32x3(camera.up()),
            du: du as f32,
            size: f32x3(bbox.size()),
            env_kind,
            voxel: f32x3(g.density.voxel_size()),
            _pad0: 0.0,
            dims: dims.map(|n| n as u32),
            _pad1: 0,
            image: [width as u32, height as u32],
            env_size,
            zenith: f32x3(sky.zenith),
            sharpness: sky.sharpness as f32,
            horizon: f32x3(sky.horizon),
            _pad2: 0.0,
            ground: f32x3(sky.ground),
            _pad3: 0.0,
            sun_direction: f32x3(sky.sun_direction),
            _pad4: 0.0,
            sun: f32x3(sky.sun),
            _pad5: 0.0,
        };

        let output = ctx.scoped("the view pass", || {
            let dev = &ctx.device;
            let init = |label, contents: &[u8], usage| {
                dev.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
            };
            let uniform = init(
                "view pass parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM,
            );
            let grid = init(
                "view pass grid",
                bytemuck::cast_slice(&cells),
                wgpu::BufferUsages::STORAGE,
            );
            let env_map = init(
                "view pass environment",
                bytemuck::cast_slice(&texels),
                wgpu::BufferUsages::STORAGE,
            );
            let output = dev.create_buffer(&wgpu::BufferDescriptor {
                label: Some("view pass image"),
                size: out_bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let bind = dev.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("view pass"),
                layout: &self.pipeline.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: grid.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: env_map.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: output.as_entire_binding(),
                    },
                ],
            });
            let mut enc = dev.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("view pass"),
            });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("view pass"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.dispatch_workgroups(groups[0] as u32, groups[1] as u32, 1);
            }
            ctx.queue.submit([enc.finish()]);
            output
        })?;
        let bytes = ctx.read_buffer(&output)?;
        // Copied rather than cast: the bytes come without `f32` alignment.
        let pixels: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(pixels.iter().map(|p| [p[0], p[1], p[2]]).collect())
    }
}

/// [`crate::render::crm::view_pass`] on the GPU: compiles the pass and runs it once (keep
/// a [`ViewPass`] to render many frames).
pub fn view_pass(
    ctx: &GpuContext,
    g: &VolumeGrids,
    medium: &Medium,
    env: &Environment,
    camera: &Camera,
    du: f64,
) -> Result<Vec<[f32; 3]>, GpuError> {
    ViewPass::new(ctx)?.run(ctx, g, medium, env, camera, du)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_match_the_wgsl_layout() {
        // Offsets of the WGSL struct: vec3 at 16-byte boundaries, vec2<u32> at 8.
        assert_eq!(std::mem::size_of::<Params>(), 208);
        assert_eq!(std::mem::offset_of!(Params, image), 112);
        assert_eq!(std::mem::offset_of!(Params, zenith), 128);
        assert_eq!(std::mem::offset_of!(Params, sun), 192);
    }
}
