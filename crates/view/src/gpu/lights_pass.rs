//! The lights pass on the GPU (`shaders/lights_pass.wgsl`), the twin of
//! [`crate::render::lights_pass::lights_pass`]: the suns and point lights of the
//! environment added to the volume pass's grids per voxel, in `f32`, in place on a
//! [`GridBuffer`].
//!
//! One invocation per voxel center `u` with `D(u) > 0` adds, for each light,
//! `Ω·E(u)·T(u)·p(s·d)/4π` to `J̃` (`d` from the eye to the voxel, `s` towards the light):
//! the sun's irradiance and disk-averaged phase ([`DiskPhase`]'s table, uploaded; exact HG
//! for a zero-angle sun), or a point light's `I/(|P − u|² + a²/3)` and HG; the
//! transmittance `T = exp(−σt·τ)` marched through the grid's `D` (its `w` words) with the
//! CPU's midpoint rule — `n = ⌈ℓ/h₀⌉` steps to the box's face or to the light, trilinear
//! `D`, stopping once `σt·τ >` [`SHADOW_CUTOFF`]. The pass writes only the `J̃` words of
//! its own voxel and reads only `D` words, so it runs in place without races.
//!
//! Two dispatches: `shadow` marches `T` toward every light from every voxel with `D > 0`
//! into a [`LightShadow`] (it depends on `D`, σt and the lights' directions and positions
//! only, so a renderer keeps it across camera moves and `g`, albedo or power changes),
//! `main` adds the lights from it.
//!
//! Uploads: the lights, positions relative to the box's minimum corner (as every pass:
//! `f32` keeps its precision for boxes far from the origin), eight words each, then the
//! suns' phase tables (512 `f32` per sun with a disk, [`DiskPhase::shared`]: built once
//! per `(g, angle)` and kept for the next frames). A point light that sits exactly on a
//! voxel center (in the CPU's `f64` arithmetic) is flagged with that voxel's index, so the
//! GPU adds the CPU's isotropic, unshadowed `I/(a²/3)` there even where `f32` rounding puts
//! the two points an ulp apart.
//!
//! Cost: per voxel and light one shadow march of up to `ℓ/h₀` trilinear samples (eight
//! density reads each); neighbouring invocations march parallel (a sun) or converging (a
//! point light) rays, so the reads stay coherent.

use super::GridBuffer;
use crate::env::Environment;
use crate::lights::DiskPhase;
use crate::medium::{FOUR_PI, Medium};
use crate::render::crm::VolumeGrids;
pub use crate::render::lights_pass::SHADOW_CUTOFF;
use haze_gpu::wgsl::Variant;
use haze_gpu::{
    GpuContext, GpuError, buffer_init, compute_pipeline, compute_pipeline_at, submit_pass,
    voxel_groups,
};
use haze_volume::Bbox;

/// The shader: `crates/view/shaders/lights_pass.wgsl`, importing the shadow march shared
/// with the environment pass (`grid_march`) and the phase functions shared with the
/// gathered orders (`disk_phase`).
pub const SHADER: Variant = Variant {
    label: "lights pass",
    entry: include_str!("../../shaders/lights_pass.wgsl"),
    defines: &[],
};

/// Voxels per workgroup side (`@workgroup_size(4, 4, 4)` in the shader).
const SIDE: usize = 4;

/// Words per light record in the lights buffer.
const RECORD: usize = 8;

/// How far from 1 the length of a sun's direction may be: `Sun::direction` is a unit
/// vector, and the shader takes it for one (the CPU's phase and march read it as given).
pub const UNIT_TOLERANCE: f64 = 1e-6;

/// "No voxel" in a point light's record.
const NONE: u32 = u32::MAX;

/// The shader's `Params` (a read-only storage buffer): WGSL's layout (a `vec3` is 16-byte aligned and the
/// scalar after it fills its fourth slot), 80 bytes.
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
    suns: u32,
    points: u32,
    g: f32,
    k: f32,
    _pad: u32,
}

/// The compiled lights pass, reusable across frames (the suns' phase tables are
/// [`DiskPhase::shared`]).
#[derive(Debug)]
pub struct LightsPass {
    pipeline: wgpu::ComputePipeline,
    shadow: wgpu::ComputePipeline,
}

/// The lights' shadow volume on the GPU: `T = exp(−σt·τ)` toward each light at every
/// voxel center with `D > 0` ([`LightsPass::shadow`]), for any number of
/// [`LightsPass::apply`]: it depends on the grid's `D`, σt and the lights' directions and
/// positions, not on the eye, `g`, the albedo or the lights' power.
#[derive(Debug)]
pub struct LightShadow {
    buffer: wgpu::Buffer,
    dims: [usize; 3],
    bbox: Bbox,
    sigma_t: f64,
    /// [`geometry`] of the lights it was marched toward.
    geometry: Vec<[f64; 3]>,
}

impl LightShadow {
    /// Whether it is the shadow volume of `env`'s lights (their directions and positions)
    /// in a grid of `grid`'s box and dims with σt `sigma_t` (the grid's `D` is the
    /// caller's to vouch for).
    pub fn fits(&self, grid: &GridBuffer, env: &Environment, sigma_t: f64) -> bool {
        self.dims == grid.dims()
            && self.bbox == *grid.bbox()
            && self.sigma_t == sigma_t
            && self.geometry == geometry(env)
    }
}

/// What the shadow volume sees of the lights: the suns' directions, then the point
/// lights' positions (with the sun count to tell them apart).
fn geometry(env: &Environment) -> Vec<[f64; 3]> {
    std::iter::once([env.suns.len() as f64, 0.0, 0.0])
        .chain(env.suns.iter().map(|s| s.direction))
        .chain(env.points.iter().map(|l| l.position))
        .collect()
}

/// Refuses lights with non-finite values, a sun direction that is not a unit vector or a
/// sun angle outside `[0, π]`.
fn check_lights(env: &Environment) -> Result<(), GpuError> {
    let finite = |v: &[f64]| v.iter().all(|c| c.is_finite());
    for (i, s) in env.suns.iter().enumerate() {
        if !(finite(&s.direction) && finite(&s.irradiance)) {
            return Err(GpuError::Input(format!(
                "sun {i} has a non-finite direction {:?} or irradiance {:?}",
                s.direction, s.irradiance
            )));
        }
        let norm = s.direction.iter().map(|c| c * c).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > UNIT_TOLERANCE {
            return Err(GpuError::Input(format!(
                "sun {i}'s direction {:?} is not a unit vector (length {norm})",
                s.direction
            )));
        }
        if !(0.0..=std::f64::consts::PI).contains(&s.angle) {
            return Err(GpuError::Input(format!(
                "sun {i}'s angle {} rad is outside [0, π]",
                s.angle
            )));
        }
    }
    for (i, l) in env.points.iter().enumerate() {
        if !(finite(&l.position) && finite(&l.intensity)) {
            return Err(GpuError::Input(format!(
                "point light {i} has a non-finite position {:?} or intensity {:?}",
                l.position, l.intensity
            )));
        }
    }
    Ok(())
}

/// Uploads the parameters and the lights' records (`records`) and submits one pass of
/// `pipeline` over `groups`, bound as both entry points read them: parameters, lights,
/// the grid, the shadow volume. Call inside [`GpuContext::scoped`].
fn submit(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    label: &'static str,
    (params, words): (&Params, &[u32]),
    grid: &GridBuffer,
    shadow: &LightShadow,
    groups: [u32; 3],
) {
    let params_buffer = buffer_init(
        ctx,
        "lights parameters",
        bytemuck::bytes_of(params),
        wgpu::BufferUsages::STORAGE,
    );
    let lights = buffer_init(
        ctx,
        "lights",
        bytemuck::cast_slice(words),
        wgpu::BufferUsages::STORAGE,
    );
    submit_pass(
        ctx,
        pipeline,
        label,
        &[&params_buffer, &lights, grid.buffer(), &shadow.buffer],
        groups,
    );
}

/// The linear index of the voxel whose center is `p` in the CPU's arithmetic
/// (`bbox.min + (i + ½)·voxel`, `f64`), if one is.
fn voxel_at(p: [f64; 3], grid: &GridBuffer) -> Option<u32> {
    let dims = grid.dims();
    let vs = grid.voxel_size();
    let min = grid.bbox().min;
    let mut idx = [0usize; 3];
    for a in 0..3 {
        if dims[a] == 0 || vs[a] <= 0.0 {
            return None;
        }
        let f = ((p[a] - min[a]) / vs[a] - 0.5).round();
        if !(f >= 0.0 && f < dims[a] as f64) {
            return None;
        }
        idx[a] = f as usize;
        if min[a] + (idx[a] as f64 + 0.5) * vs[a] != p[a] {
            return None;
        }
    }
    u32::try_from(idx[0] + dims[0] * (idx[1] + dims[1] * idx[2])).ok()
}

impl LightsPass {
    /// Compiles the shader and builds the pipeline.
    pub fn new(ctx: &GpuContext) -> Result<LightsPass, GpuError> {
        let source = super::shaders::source(&SHADER)?;
        let pipeline = compute_pipeline(ctx, "lights pass pipeline creation", &source)?;
        let shadow =
            compute_pipeline_at(ctx, "lights shadow pipeline creation", &source, "shadow")?;
        Ok(LightsPass { pipeline, shadow })
    }

    /// The phase tables of the suns of `env` for `g` (empty for a zero-angle sun).
    fn tables(env: &Environment, g: f64) -> Vec<Vec<f32>> {
        env.suns
            .iter()
            .map(|sun| {
                let phase = DiskPhase::shared(g, sun.angle);
                phase.table().iter().map(|v| *v as f32).collect()
            })
            .collect()
    }

    /// Adds the suns and point lights of `env` to the grids on the GPU (those a
    /// [`VolumePass`](super::volume_pass::VolumePass) wrote, or an upload), the camera at
    /// `eye`, as [`crate::render::lights_pass::lights_pass`] does on the CPU (submitted,
    /// not waited for): [`LightsPass::shadow`] then [`LightsPass::apply`]. Without lights,
    /// or with albedo 0, nothing is dispatched. Refuses lights with non-finite values, a
    /// sun direction that is not a unit vector (within [`UNIT_TOLERANCE`]), a sun angle
    /// outside `[0, π]`, and grids or buffers beyond the device's limits.
    pub fn run_on(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        env: &Environment,
        medium: &Medium,
        eye: [f64; 3],
    ) -> Result<(), GpuError> {
        if !env.has_lights() || medium.albedo == 0.0 || grid.dims().contains(&0) {
            return Ok(());
        }
        check_lights(env)?;
        if !eye.iter().all(|c| c.is_finite()) {
            return Err(GpuError::Input(format!("the eye {eye:?} is not finite")));
        }
        let shadow = self.shadow(ctx, grid, env, medium.sigma_t)?;
        self.apply(ctx, grid, &shadow, env, medium, eye)
    }

    /// The shadow volume alone (the `shadow` dispatch, submitted): `T` toward each of
    /// `env`'s lights at every voxel center with `D > 0` of `grid`, for σt `sigma_t`.
    /// Refuses what [`LightsPass::run_on`] refuses.
    pub fn shadow(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        env: &Environment,
        sigma_t: f64,
    ) -> Result<LightShadow, GpuError> {
        check_lights(env)?;
        let dims = grid.dims();
        let groups = voxel_groups(ctx, dims, SIDE)?;
        let lights = env.suns.len() + env.points.len();
        let voxels = dims[0] * dims[1] * dims[2];
        let bytes = (4 * (voxels * lights).max(1)) as u64;
        ctx.check_storage_size("the lights' shadow volume", bytes)?;
        let (words, params) = self.records(ctx, grid, env, sigma_t, 0.0, 0.0, [0.0; 3])?;
        let shadow = LightShadow {
            buffer: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("lights' shadow volume"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            }),
            dims,
            bbox: *grid.bbox(),
            sigma_t,
            geometry: geometry(env),
        };
        if dims.contains(&0) || lights == 0 {
            return Ok(shadow);
        }
        ctx.scoped("the lights' shadow volume", || {
            submit(
                ctx,
                &self.shadow,
                "lights shadow volume",
                (&params, &words),
                grid,
                &shadow,
                groups,
            )
        })?;
        Ok(shadow)
    }

    /// The lights alone (the `main` dispatch, submitted): adds `env`'s lights to `grid`'s
    /// `J̃`, the camera at `eye`, their transmittance read from `shadow` (nothing with
    /// albedo 0 or without lights). Refuses what [`LightsPass::run_on`] refuses, and a
    /// `shadow` that is not of this grid's box and dims, σt and lights' directions and
    /// positions ([`LightShadow::fits`]).
    pub fn apply(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        shadow: &LightShadow,
        env: &Environment,
        medium: &Medium,
        eye: [f64; 3],
    ) -> Result<(), GpuError> {
        if !env.has_lights() || medium.albedo == 0.0 || grid.dims().contains(&0) {
            return Ok(());
        }
        check_lights(env)?;
        if !eye.iter().all(|c| c.is_finite()) {
            return Err(GpuError::Input(format!("the eye {eye:?} is not finite")));
        }
        if !shadow.fits(grid, env, medium.sigma_t) {
            return Err(GpuError::Input(
                "the lights' shadow volume is of another grid, σt or lights".into(),
            ));
        }
        let groups = voxel_groups(ctx, grid.dims(), SIDE)?;
        let (words, params) =
            self.records(ctx, grid, env, medium.sigma_t, medium.g, medium.albedo, eye)?;
        ctx.scoped("the lights pass", || {
            submit(
                ctx,
                &self.pipeline,
                "lights pass",
                (&params, &words),
                grid,
                shadow,
                groups,
            )
        })
    }

    /// The lights' records and the suns' phase tables for HG `g` (the shader's `lights`),
    /// which the gathered orders read too ([`super::orders`]). Refuses what
    /// [`LightsPass::run_on`] refuses of the lights.
    pub(crate) fn light_words(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        env: &Environment,
        g: f64,
    ) -> Result<Vec<u32>, GpuError> {
        check_lights(env)?;
        Ok(self.records(ctx, grid, env, 0.0, g, 0.0, [0.0; 3])?.0)
    }

    /// The lights' records and tables (the shader's `lights`) and the parameters, for
    /// HG `g`, albedo `albedo` and the eye at `eye`.
    #[allow(clippy::too_many_arguments)]
    fn records(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        env: &Environment,
        sigma_t: f64,
        g: f64,
        albedo: f64,
        eye: [f64; 3],
    ) -> Result<(Vec<u32>, Params), GpuError> {
        let count = |n: usize, what: &str| {
            u32::try_from(n).map_err(|_| GpuError::Input(format!("{n} {what} are too many")))
        };
        let suns = count(env.suns.len(), "suns")?;
        let points = count(env.points.len(), "point lights")?;

        let dims = grid.dims();
        let bbox = grid.bbox();
        let vs = grid.voxel_size();
        let h0 = vs[0].min(vs[1]).min(vs[2]);
        let rel = |p: [f64; 3]| [0, 1, 2].map(|a| ((p[a] - bbox.min[a]) as f32).to_bits());
        let bits = |v: [f64; 3]| v.map(|c| (c as f32).to_bits());

        // The records, then the tables.
        let tables = LightsPass::tables(env, g);
        let mut words: Vec<u32> =
            Vec::with_capacity(RECORD * (env.suns.len() + env.points.len()) + 512 * tables.len());
        let mut at = RECORD * (env.suns.len() + env.points.len());
        for (sun, table) in env.suns.iter().zip(&tables) {
            words.extend(bits(sun.direction));
            words.push(count(at, "phase table words")?);
            words.extend(bits(sun.irradiance));
            words.push(count(table.len(), "phase table entries")?);
            at += table.len();
        }
        for light in &env.points {
            words.extend(rel(light.position));
            words.push(voxel_at(light.position, grid).unwrap_or(NONE));
            words.extend(bits(light.intensity));
            words.push(0);
        }
        for table in &tables {
            words.extend(table.iter().map(|v| v.to_bits()));
        }
        if words.is_empty() {
            words.push(0);
        }
        ctx.check_storage_size("the lights", std::mem::size_of_val(words.as_slice()) as u64)?;

        let params = Params {
            eye: rel(eye).map(f32::from_bits),
            sigma_t: sigma_t as f32,
            voxel: vs.map(|v| v as f32),
            h0: h0 as f32,
            size: bbox.size().map(|v| v as f32),
            soft: crate::render::near_light::NearLights::radius2(h0) as f32,
            dims: dims.map(|n| n as u32),
            suns,
            points,
            g: g as f32,
            k: (albedo / FOUR_PI) as f32,
            _pad: 0,
        };
        Ok((words, params))
    }

    /// [`LightsPass::run_on`] CPU grids: uploads them, adds the lights and reads them back.
    pub fn run(
        &self,
        ctx: &GpuContext,
        grids: &VolumeGrids,
        env: &Environment,
        medium: &Medium,
        eye: [f64; 3],
    ) -> Result<VolumeGrids, GpuError> {
        let grid = GridBuffer::upload(ctx, grids)?;
        self.run_on(ctx, &grid, env, medium, eye)?;
        grid.read(ctx)
    }
}

/// [`crate::render::lights_pass::lights_pass`] on the GPU: compiles the pass, runs it
/// once on `grids` (uploaded and read back; keep a [`LightsPass`] and chain
/// [`LightsPass::run_on`] after the volume pass to render frames).
pub fn lights_pass(
    ctx: &GpuContext,
    grids: &mut VolumeGrids,
    env: &Environment,
    medium: &Medium,
    eye: [f64; 3],
) -> Result<(), GpuError> {
    *grids = LightsPass::new(ctx)?.run(ctx, grids, env, medium, eye)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_match_the_wgsl_layout() {
        assert_eq!(std::mem::size_of::<Params>(), 80);
        assert_eq!(std::mem::offset_of!(Params, dims), 48);
        assert_eq!(std::mem::offset_of!(Params, suns), 60);
        assert_eq!(std::mem::offset_of!(Params, k), 72);
    }
}
