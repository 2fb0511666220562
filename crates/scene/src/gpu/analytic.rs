//! Paper D's composite on the GPU (`shaders/analytic.wgsl`, [`super::shaders::ANALYTIC`]):
//! the twin of [`crate::analytic::render`] in `f32`. One pass per frame: `render.wgsl`'s
//! paper C pixel (`paper_c_main`, the scene's analytic media left out as the CPU's first
//! pass leaves them out), then in the same invocation the primary hit found again, each
//! analytic fog's exact optical depth to it by `haze_fogfn`'s WGSL closed forms
//! (`fog_depth_from`), and `C_fin = τ C_in + (1 − τ) C_fog` per channel with the fogs'
//! depths added and their colours weighted by depth, as [`crate::analytic::composite`].
//!
//! The CPU prepares in `f64` what depends on the eye and the time
//! ([`haze_fogfn::gpu::records`], relative to the eye) and `C_fog`
//! ([`crate::analytic::fog_colours`]: the ambient light is an average over the sphere,
//! computed once per frame, not per pixel).

use super::GpuRenderer;
use super::shaders;
use crate::paper_c::airlight::Limits;
use crate::render::Image;
use crate::scene::Scene;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline};

/// The compiled composite; the tables are paper C's renderer's.
#[derive(Debug)]
pub struct GpuAnalytic {
    pipeline: wgpu::ComputePipeline,
}

impl GpuAnalytic {
    pub fn new(ctx: &GpuContext) -> Result<GpuAnalytic, GpuError> {
        Ok(GpuAnalytic {
            pipeline: compute_pipeline(
                ctx,
                "analytic fog pipeline creation",
                &shaders::source(&shaders::ANALYTIC)?,
            )?,
        })
    }

    /// Renders `scene` as [`crate::analytic::render`] does with paper C's model and
    /// `lim`, with the tables of `tables` (built from the same scene). Every
    /// heterogeneous medium of the scene must be analytic.
    pub fn render(
        &self,
        ctx: &GpuContext,
        tables: &GpuRenderer,
        scene: &Scene,
        lim: &Limits,
    ) -> Result<Image, GpuError> {
        if let Some(m) = scene.hetero.iter().find(|m| !m.is_analytic()) {
            return Err(GpuError::Input(format!(
                "the fog composite renders analytic media only, not {}",
                m.name()
            )));
        }
        let eye = scene.camera.eye;
        let colours = crate::analytic::fog_colours(scene);
        let mut terms: Vec<[f32; 4]> = Vec::new();
        let mut media: Vec<[f32; 4]> = Vec::new();
        for (m, (sigma, colour)) in scene.analytic_media().zip(&colours) {
            let start = terms.len();
            if start >= 1 << 24 {
                return Err(GpuError::Input(format!(
                    "{start} fog records are too many for the GPU renderer"
                )));
            }
            terms.extend(haze_fogfn::gpu::records(&m.fog, eye, m.time));
            let [s0, s1, s2] = sigma.map(|s| s as f32);
            let [c0, c1, c2] = colour.map(|c| c as f32);
            media.push([s0, s1, s2, start as f32]);
            // Beyond f32's range `far` would read as ∞ in the shader.
            media.push([c0, c1, c2, m.far.min(1e30) as f32]);
        }
        // wgpu binds no empty buffers: without analytic media, one fog of zero σt and
        // `far` (the picture is left as it is).
        if media.is_empty() {
            terms.push([-1.0, 0.0, 0.0, 0.0]);
            media.extend([[0.0; 4], [0.0; 4]]);
        }
        ctx.check_storage_size("the fog terms", 16 * terms.len() as u64)?;
        ctx.check_storage_size("the fog media", 16 * media.len() as u64)?;
        let (terms, media) = ctx.scoped("analytic fog upload", || {
            (
                buffer_init(
                    ctx,
                    "fog terms",
                    bytemuck::cast_slice(&terms),
                    wgpu::BufferUsages::STORAGE,
                ),
                buffer_init(
                    ctx,
                    "fog media",
                    bytemuck::cast_slice(&media),
                    wgpu::BufferUsages::STORAGE,
                ),
            )
        })?;
        let mut clear = scene.clone();
        clear.hetero.clear();
        tables.render_pass(ctx, &clear, lim, &self.pipeline, None, &[&terms, &media])
    }
}
