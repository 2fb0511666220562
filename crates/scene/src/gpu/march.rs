//! The single-scattering march on the GPU (`shaders/march.wgsl`): the `f32` twin of
//! [`crate::march::radiance`] for scenes whose heterogeneous media are voxel grids
//! ([`crate::media::voxel_grid::VoxelGrid`], smoke assets) and analytic fogs
//! ([`crate::media::analytic::AnalyticMedium`], paper D), alone or together.
//! [`crate::gpu::GpuRenderer::render`] takes this path for such scenes (paper D's
//! composite of analytic fogs alone is [`crate::gpu::analytic`]'s); the camera, lights,
//! surfaces and meshes travel in the
//! buffers of paper C's renderer, and the shader ([`super::shaders::MARCH`]) imports
//! `render.wgsl`'s surfaces, shadow rays, BRDF and environment, and `haze_fogfn`'s WGSL
//! closed forms (`fog_depth_at` from any point, `fog_density_at`), their
//! records after the grids' in the same buffer (the device has no ninth storage binding).
//!
//! Per pixel, as on the CPU: midpoint steps of [`crate::march::MarchOptions::step`] over
//! the part of the camera ray holding extinction, each step's transmittance from the
//! media's optical depths — the grids' by the same exact walk through the voxel planes
//! with Simpson's rule per piece ([`crate::media::voxel_grid::VoxelGrid::density_integral`]) —, shadow rays towards
//! every light through the grids (smoke → surfaces and smoke → itself), Henyey–Greenstein
//! phase, and the environment's light from the precomputed SH grid
//! ([`crate::march::env_smoke`], `shaders/env_smoke.wgsl`). What differs from the CPU beyond `f32`: a surface point's shadow rays test the
//! surfaces' visibility from [`crate::gpu::SHADOW_OFFSET`] (relative) off it, as paper
//! C's renderer does, the media's optical depth still from the point itself (from the
//! offset point the shadow of dense smoke would move by as much, a visible error at its
//! edges).
//!
//! **Lavapipe.** Mesa's CPU driver ends an invocation's loops after 65535 iterations in
//! all (steps, lights, voxel planes crossed, fog records and monomials — and, as it runs
//! eight pixels in lock step under masks, every loop on an untaken branch still costs an
//! iteration); a step of the example analytic fog costs ~10³. So the march goes [`chunks`]
//! of steps per dispatch, several dispatches per picture, each invocation's state (its
//! radiance so far, `t`, transmittance, steps) kept after the image between them; each
//! dispatch has its own budget. Real GPUs have no such limit (the extra dispatches cost
//! them a primary ray per pixel each).

use super::shaders;
use crate::march::MarchOptions;
use crate::march::env_smoke::EnvLight;
use crate::media::HeteroMedium;
use crate::scene::Scene;
use crate::vec3::Vec3;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline};

/// The march's `(steps per dispatch, dispatches)` for `scene` marched with `opt`: a
/// dispatch's loop iterations kept below lavapipe's 65535 by a model of a step's cost —
/// `100 + 100·L + 10·(L + 3)·R` iterations for `L` lights and `R` fog records, fitted
/// with a margin of two on the bundled analytic fog — and enough dispatches for the
/// longest march: the analytic fogs' `far`, the voxel boxes' farthest corner, or (with a
/// homogeneous medium) the environment's distance, over the step, capped by
/// [`MarchOptions::max_steps`] and [`MAX_DISPATCHES`].
pub fn chunks(scene: &Scene, opt: &MarchOptions) -> (u32, u32) {
    let lights = scene.lights.len() as f64;
    let records: usize = scene
        .analytic_media()
        .map(|a| haze_fogfn::gpu::records(&a.fog, scene.camera.eye, a.time).len())
        .sum();
    let per_step = 100.0 + 100.0 * lights + 10.0 * (lights + 3.0) * records as f64;
    let chunk = (50_000.0 / per_step).floor().clamp(1.0, 4096.0);
    let eye = scene.camera.eye;
    let mut reach: f64 = 0.0;
    for m in &scene.hetero {
        if let HeteroMedium::Analytic(a) = m {
            reach = reach.max(a.far);
        } else if let Some(b) = m.bounds() {
            let corner =
                [0, 1, 2].map(|k| (b.min[k] - eye[k]).abs().max((b.max[k] - eye[k]).abs()));
            reach = reach.max(crate::vec3::norm(corner));
        }
    }
    if scene.medium.sigma_t.iter().any(|&s| s > 0.0) {
        reach = reach.max(scene.environment_distance);
    }
    let steps = (reach / opt.step).ceil() + 1.0;
    let steps = if steps.is_finite() {
        steps.min(opt.max_steps as f64)
    } else {
        opt.max_steps as f64
    };
    (
        chunk as u32,
        (steps / chunk).ceil().clamp(1.0, MAX_DISPATCHES) as u32,
    )
}

/// Dispatches one march takes at most (a homogeneous fog reaching an environment at `∞`
/// would ask for [`MarchOptions::max_steps`]; its march fades long before on a real
/// GPU, and on lavapipe ends after this many chunks).
const MAX_DISPATCHES: f64 = 256.0;

/// Analytic fogs one march takes at most (`FOG_MAX_MEDIA` in `shaders/march.wgsl`).
pub const MAX_FOGS: usize = 8;

/// Compiles the march's pipeline.
pub fn pipeline(ctx: &GpuContext) -> Result<wgpu::ComputePipeline, GpuError> {
    compute_pipeline(
        ctx,
        "scene march pipeline creation",
        &shaders::source(&shaders::MARCH)?,
    )
}

/// What the march adds to paper C's buffers: the grids' values and their records (the
/// shader's `grid` and `media` bindings), the environment's grid of SH coefficients
/// ([`crate::march::env_smoke::EnvGrid`]) after the voxel grids, the analytic fogs' records
/// after the grids' (layout in `shaders/march.wgsl`).
#[derive(Clone, Debug)]
pub struct MarchInput {
    grid: Vec<f32>,
    records: Vec<[f32; 4]>,
}

impl MarchInput {
    /// The scene's voxel media and analytic fogs, positions relative to `eye`, marched
    /// with `opt`; `None` when the scene has no heterogeneous medium (paper C's renderer
    /// serves it), an error when one is neither (or for more than
    /// [`MAX_FOGS`] fogs).
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
            0.0,
            opt.step as f32,
            opt.max_steps.min(1 << 24) as f32,
            opt.min_transmittance as f32,
        ]];
        let f = |v: Vec3, w: f64| [v[0] as f32, v[1] as f32, v[2] as f32, w as f32];
        let mut fogs = Vec::new();
        for m in &scene.hetero {
            let g = match m {
                HeteroMedium::Analytic(a) => {
                    fogs.push(&**a);
                    continue;
                }
                HeteroMedium::Asset(a) => a.grid(),
                _ => {
                    return Err(GpuError::Input(format!(
                        "the GPU renderer marches voxel media and analytic fogs only, not {}",
                        m.name()
                    )));
                }
            };
            // Indices travel as f32: exact below 2²⁴.
            if grid.len() + g.data.len() >= 1 << 24 {
                return Err(GpuError::Input(format!(
                    "{}: the scene's voxel grids are too large for the GPU renderer",
                    m.name()
                )));
            }
            let min = [0, 1, 2].map(|a| g.min[a] - eye[a]);
            records.push(f(min, m.g()));
            records.push(f(g.voxel, grid.len() as f64));
            records.push(f(g.dims.map(|d| d as f64), 0.0));
            records.push(f(g.scale, 0.0));
            records.push(f(m.albedo(), 0.0));
            records[0][0] += 1.0;
            grid.extend_from_slice(&g.data);
        }
        if fogs.len() > MAX_FOGS {
            return Err(GpuError::Input(format!(
                "{} analytic fogs are more than the GPU march takes ({MAX_FOGS})",
                fogs.len()
            )));
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
        // The fogs: their head, three records each, then their closed forms' records.
        records.push([fogs.len() as f32, 0.0, 0.0, 0.0]);
        let mut first = records.len() + 3 * fogs.len();
        let mut closed = Vec::new();
        for a in &fogs {
            let r = haze_fogfn::gpu::records(&a.fog, eye, a.time);
            if first + r.len() >= 1 << 24 {
                return Err(GpuError::Input(format!(
                    "{}: too many fog records for the GPU renderer",
                    a.fog.terms.len()
                )));
            }
            records.push(f(a.sigma_t, first as f64));
            records.push(f(a.albedo, a.g));
            // Beyond f32's range `far` would read as ∞ in the shader.
            records.push([a.far.min(1e30) as f32, 0.0, 0.0, 0.0]);
            first += r.len();
            closed.extend(r);
        }
        records.extend(closed);
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

    /// Whether the device holds the grids and the records in one storage buffer each.
    pub fn check(&self, ctx: &GpuContext) -> Result<(), GpuError> {
        ctx.check_storage_size("the voxel grids", 4 * self.grid.len() as u64)?;
        ctx.check_storage_size("the media's records", 16 * self.records.len() as u64)
    }
}
