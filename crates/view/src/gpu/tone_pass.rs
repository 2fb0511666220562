//! The picture's 8-bit sRGB encoding on the GPU (`shaders/tone_pass.wgsl`): a view pass's
//! image, still on the device, exposed, tone-mapped and encoded as [`haze_core::Image::
//! to_srgb8`] does on the host — to the same codes — and read back at 4 bytes a pixel
//! instead of the image's 16. For pictures that are only shown (the viewer): the host
//! neither reads the linear image nor encodes it.

use super::view_pass::ImageBuffer;
use haze_core::ToneMap;
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline, line_groups, submit_pass};

/// The shader, `crates/view/shaders/tone_pass.wgsl`.
pub const SHADER: Variant = Variant {
    label: "tone pass",
    entry: include_str!("../../shaders/tone_pass.wgsl"),
    defines: &[],
};

/// Invocations per workgroup (`@workgroup_size(256)` in the shader).
const GROUP: usize = 256;

/// The shader's `Params` (a read-only storage buffer), 16 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    pixels: u32,
    groups_x: u32,
    _pad: [u32; 2],
}

/// The compiled tone pass (module docs).
#[derive(Debug)]
pub struct TonePass {
    pipeline: wgpu::ComputePipeline,
}

impl TonePass {
    /// Compiles the shader and builds the pipeline.
    pub fn new(ctx: &GpuContext) -> Result<TonePass, GpuError> {
        let pipeline = compute_pipeline(
            ctx,
            "tone pass pipeline creation",
            &super::shaders::source(&SHADER)?,
        )?;
        Ok(TonePass { pipeline })
    }

    /// `image` at `exposure` (finite, > 0) under `tone` as 8-bit sRGB, three bytes a
    /// pixel, row 0 at the top: [`haze_core::Image::to_srgb8`] of the image's pixels.
    pub fn encode(
        &self,
        ctx: &GpuContext,
        image: &ImageBuffer,
        exposure: f64,
        tone: ToneMap,
    ) -> Result<Vec<u8>, GpuError> {
        if !(exposure.is_finite() && exposure > 0.0) {
            return Err(GpuError::Input(format!(
                "exposure {exposure} must be a finite number > 0"
            )));
        }
        let (width, height) = image.size();
        let n = width * height;
        if n == 0 {
            return Ok(Vec::new());
        }
        let groups = line_groups(ctx, n, GROUP, "pixels")?;
        let pixels = u32::try_from(n).map_err(|_| {
            GpuError::Input(format!("{n} pixels are more than the tone pass takes"))
        })?;
        let params = Params {
            pixels,
            groups_x: groups[0],
            _pad: [0; 2],
        };
        let steps = haze_core::srgb8_thresholds(exposure, tone);
        let bytes = 4 * n as u64;
        ctx.check_storage_size("the encoded picture", bytes)?;
        let encoded = ctx.scoped("the tone pass", || {
            let params = buffer_init(
                ctx,
                "tone pass parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::STORAGE,
            );
            let steps = buffer_init(
                ctx,
                "tone pass steps",
                bytemuck::cast_slice(&steps),
                wgpu::BufferUsages::STORAGE,
            );
            let encoded = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tone pass picture"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let buffers = [&params, image.buffer(), &steps, &encoded];
            submit_pass(ctx, &self.pipeline, "tone pass", &buffers, groups);
            encoded
        })?;
        ctx.read_with(&encoded, 0, bytes, |words| {
            let mut rgb = Vec::with_capacity(3 * n);
            for w in words.chunks_exact(4) {
                rgb.extend_from_slice(&w[..3]);
            }
            rgb
        })
    }
}
