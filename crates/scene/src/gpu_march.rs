//! The single-scattering march on the GPU (`shaders/march.wgsl`): the `f32` twin of
//! [`crate::march::radiance`] for scenes whose heterogeneous media are voxel grids
//! ([`crate::voxel_grid::VoxelGrid`], smoke assets). [`crate::gpu::GpuRenderer::render`]
//! takes this path for such scenes; the camera, lights, surfaces and meshes travel in the
//! buffers of paper C's renderer, and the shader reuses `render.wgsl`'s surfaces, shadow
//! rays, BRDF and environment (the march is appended to it, its entry point renamed).
//!
//! Per pixel, as on the CPU: midpoint steps of [`crate::march::MarchOptions::step`] over
//! the part of the camera ray holding extinction, each step's transmittance from the
//! media's optical depths — the grids' by the same exact walk through the voxel planes
//! with Simpson's rule per piece ([`VoxelGrid::density_integral`]) —, shadow rays towards
//! every light through the grids (smoke → surfaces and smoke → itself), Henyey–Greenstein
//! phase, and the environment's light from the precomputed SH grid
//! ([`crate::env_smoke`], `shaders/env_smoke.wgsl`). What differs from the CPU beyond `f32`: a surface point's shadow rays test the
//! surfaces' visibility from [`crate::gpu::SHADOW_OFFSET`] (relative) off it, as paper
//! C's renderer does, the media's optical depth still from the point itself (from the
//! offset point the shadow of dense smoke would move by as much, a visible error at its
//! edges).
//!
//! **Lavapipe.** Mesa's CPU driver ends an invocation's loops after 65535 iterations in
//! all (steps, lights, voxel planes crossed); the shader's per-axis work is written as
//! vector operations to stay far below that, but a march that long — a homogeneous fog
//! reaching an environment at `∞` at small steps — is cut short there. Real GPUs have no
//! such limit.

use crate::env_smoke::EnvLight;
use crate::march::MarchOptions;
use crate::scene::Scene;
use crate::vec3::Vec3;
use haze_view::gpu::{GpuContext, GpuError, buffer_init, compute_pipeline};

/// The march's own part of the shader.
const MARCH: &str = include_str!("../shaders/march.wgsl");

/// The environment's light on the media ([`crate::env_smoke`]), appended after the march.
const ENV_SMOKE: &str = include_str!("../shaders/env_smoke.wgsl");

/// `render.wgsl`'s entry point, renamed to a plain function in the march's module.
const ENTRY: &str =
    "@compute @workgroup_size(8, 8, 1)\nfn main(@builtin(global_invocation_id) id: vec3<u32>)";

/// The march's whole shader: `render.wgsl` with its entry point renamed, then
/// `march.wgsl`, `env_smoke.wgsl`.
pub fn shader() -> Result<String, GpuError> {
    let base = crate::gpu::SHADER;
    if !base.contains(ENTRY) {
        return Err(GpuError::Input(
            "render.wgsl's entry point changed: the march cannot rename it".into(),
        ));
    }
    Ok(format!(
        "{}\n{MARCH}\n{ENV_SMOKE}",
        base.replace(ENTRY, "fn analytic_main(id: vec3<u32>)")
    ))
}

/// Compiles the march's pipeline.
pub fn pipeline(ctx: &GpuContext) -> Result<wgpu::ComputePipeline, GpuError> {
    compute_pipeline(ctx, "scene march pipeline creation", &shader()?)
}

/// What the march adds to paper C's buffers: the grids' values and their records (the
/// shader's `grid` and `media` bindings), the environment's grid of SH coefficients
/// ([`crate::env_smoke::EnvGrid`]) after the voxel grids.
#[derive(Clone, Debug)]
pub struct MarchInput {
    grid: Vec<f32>,
    records: Vec<[f32; 4]>,
}

impl MarchInput {
    /// The scene's voxel media, positions relative to `eye`, marched with `opt`; `None`
    /// when the scene has no heterogeneous medium (paper C's renderer serves it), an
    /// error when one is not a voxel grid.
    pub fn of(
        scene: &Scene,
        eye: Vec3,
        opt: &MarchOptions,
    ) -> Result<Option<MarchInput>, GpuError> {
        if scene.hetero.is_empty() {
            return Ok(None);
        }
        let mut grid = Vec::new();
        let mut records = vec![[
            scene.hetero.len() as f32,
            opt.step as f32,
            opt.max_steps.min(1 << 24) as f32,
            opt.min_transmittance as f32,
        ]];
        for m in &scene.hetero {
            let g = m.voxels().ok_or_else(|| {
                GpuError::Input(format!(
                    "the GPU renderer marches voxel media only, not {}",
                    m.name()
                ))
            })?;
            // Indices travel as f32: exact below 2²⁴.
            if grid.len() + g.data.len() >= 1 << 24 {
                return Err(GpuError::Input(format!(
                    "{}: the scene's voxel grids are too large for the GPU renderer",
                    m.name()
                )));
            }
            let f = |v: Vec3, w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
            let min = [0, 1, 2].map(|a| g.min[a] - eye[a]);
            records.push(f(min, m.g()));
            records.push(f(g.voxel, grid.len() as f64));
            records.push(f(g.dims.map(|d| d as f64), 0.0));
            records.push(f(g.scale, 0.0));
            records.push(f(m.albedo(), 0.0));
            grid.extend_from_slice(&g.data);
        }
        // The environment's grid follows the voxel grids in `grid`, its start in the
        // record after the media's.
        let env = match &opt.env {
            EnvLight::None => vec![0.0; 8],
            EnvLight::Grid(g) => {
                let min = [0, 1, 2].map(|a| (g.min[a] - eye[a]) as f32);
                let cell = g.cell.map(|c| c as f32);
                let mut v = vec![min[0], min[1], min[2], g.nodes[0] as f32];
                v.extend([cell[0], cell[1], cell[2], g.order as f32]);
                v.extend_from_slice(&g.coeffs);
                v
            }
            EnvLight::Direct(_) => {
                return Err(GpuError::Input(
                    "the GPU march lights smoke by the environment's grid only".into(),
                ));
            }
        };
        if grid.len() + env.len() >= 1 << 24 {
            return Err(GpuError::Input(
                "the environment's grid over the media is too large for the GPU renderer".into(),
            ));
        }
        records.push([grid.len() as f32, 0.0, 0.0, 0.0]);
        grid.extend_from_slice(&env);
        Ok(Some(MarchInput { grid, records }))
    }

    /// Uploads the grids and records. Call inside [`GpuContext::scoped`], after
    /// [`MarchInput::check`].
    pub fn buffers(&self, ctx: &GpuContext) -> [wgpu::Buffer; 2] {
        let grid = buffer_init(
            ctx,
            "scene voxel grids",
            bytemuck::cast_slice(&self.grid),
            wgpu::BufferUsages::STORAGE,
        );
        let records = buffer_init(
            ctx,
            "scene voxel media",
            bytemuck::cast_slice(&self.records),
            wgpu::BufferUsages::STORAGE,
        );
        [grid, records]
    }

    /// Whether the device holds the grids in one storage buffer.
    pub fn check(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        ctx.check_storage_size("the voxel grids", 4 * self.grid.len() as u64)
    }
}
