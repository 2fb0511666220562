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
//! The march passes over the slices that fall in blocks of 4³ voxels with no density
//! within a voxel of them ([`super::occupancy`], built before each dispatch): the
//! trilinear `D` is exactly 0 there and such a slice adds nothing, so the image is the
//! same to the bit, and rays through the air around the smoke cost less.
//!
//! Each ray's samples read `J̃` between voxel centers as the corners' geometric mean
//! (decision 0049), whose logarithms a small pass takes once a voxel before the march
//! (`shaders/view_grid.wgsl`, the pass "view pass grid", a copy of the grid with
//! `ln J̃` in place of `J̃`) instead of eight times a sample.
//!
//! Inputs on the GPU: `D` and `J̃` interleaved in one storage buffer (`vec4` per voxel,
//! trilinear by hand with the CPU's stencil and exact `f32` weights: the filtering units
//! of GPUs interpolate with 8-bit weights, and 32-bit float textures are not filterable
//! everywhere); the environment as the CPU has it — the built-in sky evaluated
//! analytically, a lat-long map uploaded texel for texel and looked up bilinearly with
//! `LatLong::radiance`'s convention — plus the disks of the suns (`Environment::radiance`:
//! direction, `cos(angle/2)` and radiance per sun), so the background differs from the
//! CPU's by `f32` rounding only (and, at a disk's rim, by which side of it `f32` puts a
//! pixel's ray). Coordinates are relative to the box's minimum corner. The grid buffer is
//! a [`GridBuffer`]: uploaded from CPU [`VolumeGrids`] by [`ViewPass::run`], or left on
//! the GPU by the volume pass and read by [`ViewPass::run_on`].

use super::GridBuffer;
use super::occupancy::OccupancyPass;
use crate::Camera;
use crate::distant::Distant;
use crate::env::{Backdrop, Environment};
use crate::ground::GroundLight;
use crate::ground::sky_seen::{NODES, SkyGrid};
use crate::lights::PointLight;
use crate::medium::{FOUR_PI, Medium};
use crate::render::crm::VolumeGrids;
use crate::render::near_light::NEAR_RADIUS_VOXELS;
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline, line_groups, submit_pass};
use haze_volume::Bbox;

/// The shader, `crates/view/shaders/view_pass.wgsl`.
pub const SHADER: Variant = Variant {
    label: "view pass",
    entry: include_str!("../../shaders/view_pass.wgsl"),
    defines: &[],
};

/// The view pass's copy of the grid with each voxel's `ln J̃` taken once,
/// `crates/view/shaders/view_grid.wgsl`.
pub const GRID_SHADER: Variant = Variant {
    label: "view pass grid",
    entry: include_str!("../../shaders/view_grid.wgsl"),
    defines: &[],
};

/// The sky's share that reaches the ground on its grid's nodes,
/// `crates/view/shaders/ground_sky.wgsl` (the twin of [`SkyGrid::compute`]).
pub const SKY_SHADER: Variant = Variant {
    label: "ground sky",
    entry: include_str!("../../shaders/ground_sky.wgsl"),
    defines: &[],
};

/// `ground_sky.wgsl`'s parameters, 80 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SkyParams {
    size: [f32; 3],
    sigma_t: f32,
    voxel: [f32; 3],
    nodes: u32,
    dims: [u32; 3],
    count: u32,
    origin: [f32; 2],
    cell: f32,
    ground_z: f32,
    first: u32,
    du: f32,
    _pad: [u32; 2],
}

/// Nodes per workgroup of [`SKY_SHADER`] (`@workgroup_size(64)`).
const NODES_PER_GROUP: usize = 64;

/// Voxels per workgroup of [`GRID_SHADER`] (`@workgroup_size(64)`).
const VOXELS_PER_GROUP: usize = 64;

/// `view_grid.wgsl`'s parameters.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GridParams {
    count: u32,
    _pad: [u32; 3],
}

/// Pixels per workgroup side (`@workgroup_size(8, 8)` in the shader).
const TILE: u32 = 8;

/// The shader's `Params` (a read-only storage buffer): WGSL's layout (a `vec3` is 16-byte aligned and the
/// scalar after it fills its fourth slot), 256 bytes.
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
    suns: u32,
    dims: [u32; 3],
    ground_lights: u32,
    image: [u32; 2],
    env_size: [u32; 2],
    zenith: [f32; 3],
    sharpness: f32,
    horizon: [f32; 3],
    ground_z: f32,
    ground: [f32; 3],
    has_ground: u32,
    sun_direction: [f32; 3],
    keep: f32,
    sun: [f32; 3],
    g: f32,
    ground_sky: [f32; 3],
    near_radius: f32,
    near_lights: u32,
    sky_cell: f32,
    sky_nodes: u32,
    sky_first: u32,
    sky_origin: [f32; 2],
    _pad8: [u32; 2],
}

impl Params {
    /// The view of `grid` by `camera` through `medium` under `env` over `ground`, slices
    /// `du` apart; no ground lights, point lights or sky share yet (their counts come with
    /// their buffers).
    fn new(
        camera: &Camera,
        medium: &Medium,
        env: &EnvBuffer,
        grid: &GridBuffer,
        du: f64,
        ground: Option<&GroundLight>,
    ) -> Params {
        let bbox = grid.bbox();
        let sky = &env.sky;
        let (width, height) = (camera.width, camera.height);
        Params {
            eye: f32x3([0, 1, 2].map(|a| camera.eye[a] - bbox.min[a])),
            tan_half: camera.tan_half() as f32,
            forward: f32x3(camera.forward()),
            aspect: (width as f64 / height as f64) as f32,
            right: f32x3(camera.right()),
            sigma_t: medium.sigma_t as f32,
            up: f32x3(camera.up()),
            du: du as f32,
            size: f32x3(bbox.size()),
            env_kind: env.kind,
            voxel: f32x3(grid.voxel_size()),
            suns: env.suns,
            dims: grid.dims().map(|n| n as u32),
            ground_lights: 0,
            image: [width as u32, height as u32],
            env_size: env.size,
            zenith: f32x3(sky.zenith),
            sharpness: sky.sharpness as f32,
            horizon: f32x3(sky.horizon),
            ground_z: ground.map_or(0.0, |g| (g.height - bbox.min[2]) as f32),
            ground: f32x3(sky.ground),
            has_ground: u32::from(ground.is_some()),
            sun_direction: f32x3(sky.sun_direction),
            keep: (1.0 - grid.eye_peak()) as f32,
            sun: f32x3(sky.sun),
            g: medium.g as f32,
            ground_sky: f32x3(ground.map_or([0.0; 3], |g| g.sky)),
            near_radius: 0.0,
            near_lights: 0,
            sky_cell: 0.0,
            sky_nodes: 0,
            sky_first: 0,
            sky_origin: [0.0; 2],
            _pad8: [0; 2],
        }
    }
}

/// Places the sky's share that reaches `ground` (`ground::sky_seen`'s grid under the
/// smoke in `bbox`) in `params`, its nodes after the ground's `lights` (room made for
/// them there), and gives its directions ([`sky_directions`]); the open sky where there
/// is no ground or the smoke cannot hide it.
fn place_sky_share(
    params: &mut Params,
    lights: &mut Vec<[f32; 4]>,
    ground: Option<&GroundLight>,
    bbox: &Bbox,
) -> Result<Vec<[f32; 4]>, GpuError> {
    let placed = ground.and_then(|g| Some((g, SkyGrid::placed(bbox, g.height)?)));
    if let Some((_, (origin, cell))) = placed {
        params.sky_cell = cell as f32;
        params.sky_nodes = NODES as u32;
        params.sky_first = lights.len() as u32;
        params.sky_origin = [0, 1].map(|a| (origin[a] - bbox.min[a]) as f32);
        lights.resize(lights.len() + NODES * NODES, [0.0; 4]);
    }
    sky_directions(placed.map(|(g, _)| g))
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

/// The compiled view pass, reusable across frames.
#[derive(Debug)]
pub struct ViewPass {
    pipeline: wgpu::ComputePipeline,
    /// [`GRID_SHADER`]'s.
    ln_pipeline: wgpu::ComputePipeline,
    /// [`SKY_SHADER`]'s.
    sky_pipeline: wgpu::ComputePipeline,
    occupancy: OccupancyPass,
}

impl ViewPass {
    /// Compiles the shader and builds the pipeline.
    pub fn new(ctx: &GpuContext) -> Result<ViewPass, GpuError> {
        let pipeline = compute_pipeline(
            ctx,
            "view pass pipeline creation",
            &super::shaders::source(&SHADER)?,
        )?;
        let ln_pipeline = compute_pipeline(
            ctx,
            "view pass grid pipeline creation",
            &super::shaders::source(&GRID_SHADER)?,
        )?;
        let sky_pipeline = compute_pipeline(
            ctx,
            "ground sky pipeline creation",
            &super::shaders::source(&SKY_SHADER)?,
        )?;
        Ok(ViewPass {
            pipeline,
            ln_pipeline,
            sky_pipeline,
            occupancy: OccupancyPass::new(ctx)?,
        })
    }

    /// The image of the volume-pass grids `g` (RGB per pixel, row 0 at the top), slice
    /// thickness `du` (world units): uploads the grids, then [`ViewPass::run_on`]. Refuses
    /// grids whose radiance does not match the density's voxels, a `du` that is not
    /// positive and finite, a sky with a negative sun sharpness, and buffers beyond the
    /// device's limits.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &self,
        ctx: &GpuContext,
        g: &VolumeGrids,
        medium: &Medium,
        env: &Environment,
        camera: &Camera,
        du: f64,
        ground: Option<&GroundLight>,
    ) -> Result<Vec<[f32; 3]>, GpuError> {
        let grid = GridBuffer::upload(ctx, g)?;
        self.run_on(ctx, &grid, medium, env, camera, du, ground)
    }

    /// The image of grids already on the GPU (those a
    /// [`VolumePass`](super::volume_pass::VolumePass) wrote), as [`ViewPass::run`]:
    /// [`ViewPass::dispatch`], then [`ImageBuffer::read`].
    #[allow(clippy::too_many_arguments)]
    pub fn run_on(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        medium: &Medium,
        env: &Environment,
        camera: &Camera,
        du: f64,
        ground: Option<&GroundLight>,
    ) -> Result<Vec<[f32; 3]>, GpuError> {
        self.dispatch(ctx, grid, medium, env, camera, du, ground)?
            .read(ctx)
    }

    /// Submits the view pass of grids on the GPU and leaves the image there (a frame
    /// that is displayed or timed need not come back to the host).
    #[allow(clippy::too_many_arguments)]
    pub fn dispatch(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        medium: &Medium,
        env: &Environment,
        camera: &Camera,
        du: f64,
        ground: Option<&GroundLight>,
    ) -> Result<ImageBuffer, GpuError> {
        let env = EnvBuffer::upload(ctx, env)?;
        self.dispatch_in(ctx, grid, medium, &env, camera, du, ground)
    }

    /// [`ViewPass::dispatch`] with the environment already on the GPU (uploaded once for
    /// many frames). Camera rays that meet `ground` see it instead of the environment
    /// ([`crate::ground`]).
    #[allow(clippy::too_many_arguments)]
    pub fn dispatch_in(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        medium: &Medium,
        env: &EnvBuffer,
        camera: &Camera,
        du: f64,
        ground: Option<&GroundLight>,
    ) -> Result<ImageBuffer, GpuError> {
        let dims = grid.dims();
        if !(du > 0.0 && du.is_finite()) {
            return Err(GpuError::Input(format!(
                "slice thickness {du} must be positive and finite"
            )));
        }
        let (width, height) = (camera.width, camera.height);
        let groups = image_groups(ctx, width, height)?;
        let out_bytes = (width * height * 16) as u64;
        ctx.check_storage_size("the image", out_bytes)?;

        let bbox = grid.bbox();
        let mut lights = ground_lights(ground, bbox.min)?;
        let (near, near_radius) = near_lights(ctx, &env.points, medium, grid)?;
        let mut params = Params::new(camera, medium, env, grid, du, ground);
        params.ground_lights = ((lights.len() - 1) / 2) as u32;
        params.near_radius = near_radius;
        params.near_lights = ((near.len() - 1) / 2) as u32;
        let sky_directions = place_sky_share(&mut params, &mut lights, ground, bbox)?;
        ctx.check_storage_size(
            "the ground's lights",
            std::mem::size_of_val(lights.as_slice()) as u64,
        )?;
        let sky_groups = line_groups(ctx, NODES * NODES, NODES_PER_GROUP, "nodes")?;

        let block_groups = OccupancyPass::groups(ctx, dims)?;
        let voxels = dims.iter().product::<usize>();
        let voxel_groups = line_groups(ctx, voxels, VOXELS_PER_GROUP, "voxels")?;
        let output = ctx.scoped("the view pass", || {
            // The blocks the march passes over (`occupancy` module docs).
            let occupancy = self
                .occupancy
                .submit(ctx, grid, block_groups, "view pass occupancy");
            // The grid with each voxel's `ln J̃` taken once (`view_grid.wgsl`).
            let ln_grid = self.ln_grid(ctx, grid, voxels, voxel_groups);
            let params_buffer = buffer_init(
                ctx,
                "view pass parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::STORAGE,
            );
            let output = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("view pass image"),
                size: out_bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let lights_buffer = buffer_init(
                ctx,
                "view pass ground lights",
                bytemuck::cast_slice(&lights),
                wgpu::BufferUsages::STORAGE,
            );
            // The sky's share that reaches the ground, on its grid (`ground_sky.wgsl`),
            // into the nodes after the lights.
            self.sky_seen(
                ctx,
                grid,
                medium,
                (&occupancy, &lights_buffer),
                &params,
                &sky_directions,
                sky_groups,
            );
            let near_buffer = buffer_init(
                ctx,
                "view pass point lights",
                bytemuck::cast_slice(&near),
                wgpu::BufferUsages::STORAGE,
            );
            let buffers = [
                &params_buffer,
                &ln_grid,
                &env.buffer,
                &output,
                &env.sun_buffer,
                &lights_buffer,
                &occupancy,
                &near_buffer,
            ];
            let groups = [groups[0] as u32, groups[1] as u32, 1];
            submit_pass(ctx, &self.pipeline, "view pass", &buffers, groups);
            output
        })?;
        Ok(ImageBuffer {
            buffer: output,
            width,
            height,
        })
    }

    /// Submits the sky's share that reaches the ground on the nodes `params` places
    /// (`ground_sky.wgsl`, over `groups`) by `directions` ([`sky_directions`]), through
    /// `grid`'s density and its occupancy, into `seen` from `params.sky_first` on;
    /// nothing where `params` places no node (the view pass then takes the open sky).
    /// Call inside [`GpuContext::scoped`].
    #[allow(clippy::too_many_arguments)]
    fn sky_seen(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        medium: &Medium,
        (occupancy, seen): (&wgpu::Buffer, &wgpu::Buffer),
        params: &Params,
        directions: &[[f32; 4]],
        groups: [u32; 3],
    ) {
        if params.sky_nodes == 0 {
            return;
        }
        let sky = SkyParams {
            size: params.size,
            sigma_t: medium.sigma_t as f32,
            voxel: params.voxel,
            nodes: params.sky_nodes,
            dims: params.dims,
            count: (directions.len() / 2) as u32,
            origin: params.sky_origin,
            cell: params.sky_cell,
            ground_z: params.ground_z,
            first: params.sky_first,
            du: params.du,
            _pad: [0; 2],
        };
        let sky = buffer_init(
            ctx,
            "ground sky parameters",
            bytemuck::bytes_of(&sky),
            wgpu::BufferUsages::STORAGE,
        );
        let directions = buffer_init(
            ctx,
            "ground sky directions",
            bytemuck::cast_slice(directions),
            wgpu::BufferUsages::STORAGE,
        );
        submit_pass(
            ctx,
            &self.sky_pipeline,
            "ground sky",
            &[&sky, grid.buffer(), occupancy, &directions, seen],
            groups,
        );
    }

    /// Submits the copy of `grid` (`voxels` voxels, dispatched as `groups`) with each
    /// voxel's `ln J̃` in place of `J̃` (`view_grid.wgsl`); call inside
    /// [`GpuContext::scoped`].
    fn ln_grid(
        &self,
        ctx: &GpuContext,
        grid: &GridBuffer,
        voxels: usize,
        groups: [u32; 3],
    ) -> wgpu::Buffer {
        let params = GridParams {
            count: voxels as u32,
            _pad: [0; 3],
        };
        let params = buffer_init(
            ctx,
            "view pass grid parameters",
            bytemuck::bytes_of(&params),
            wgpu::BufferUsages::STORAGE,
        );
        let ln_grid = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view pass grid"),
            size: grid.buffer().size(),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        submit_pass(
            ctx,
            &self.ln_pipeline,
            "view pass grid",
            &[&params, grid.buffer(), &ln_grid],
            groups,
        );
        ln_grid
    }
}

/// The workgroups of an image of `width × height` pixels, [`TILE`]² pixels each; refuses
/// more than the device dispatches.
fn image_groups(ctx: &GpuContext, width: usize, height: usize) -> Result<[usize; 2], GpuError> {
    let groups = [width, height].map(|n| n.div_ceil(TILE as usize));
    let max_groups = ctx.device.limits().max_compute_workgroups_per_dimension as usize;
    if groups.iter().any(|&n| n > max_groups) {
        return Err(GpuError::Input(format!(
            "an image of {width}×{height} pixels is larger than the device dispatches ({} pixels a side at most)",
            max_groups * TILE as usize
        )));
    }
    Ok(groups)
}

/// The ground's lights as `view_pass.wgsl` reads them: per light `(direction towards a
/// sun, 0)` or `(box-local position of a point light, 1)`, then `(ρ/π·E or ρ/π·I, 0)`;
/// after them one zero `vec4` (a buffer is never empty). Refuses non-finite values.
fn ground_lights(
    ground: Option<&GroundLight>,
    origin: [f64; 3],
) -> Result<Vec<[f32; 4]>, GpuError> {
    let mut out = Vec::new();
    if let Some(g) = ground {
        let finite = [g.height].iter().chain(&g.sky).all(|c| c.is_finite())
            && g.suns
                .iter()
                .chain(&g.points)
                .all(|(a, e)| a.iter().chain(e).all(|c| c.is_finite()));
        if !finite {
            return Err(GpuError::Input(format!(
                "the ground at height {} has a non-finite light",
                g.height
            )));
        }
        for (w, e) in &g.suns {
            let w = f32x3(*w);
            out.push([w[0], w[1], w[2], 0.0]);
            let e = f32x3(*e);
            out.push([e[0], e[1], e[2], 0.0]);
        }
        for (q, i) in &g.points {
            let q = f32x3([0, 1, 2].map(|a| q[a] - origin[a]));
            out.push([q[0], q[1], q[2], 1.0]);
            let i = f32x3(*i);
            out.push([i[0], i[1], i[2], 0.0]);
        }
    }
    out.push([0.0; 4]);
    Ok(out)
}

/// The sky's directions of `ground` as `ground_sky.wgsl` reads them: per direction
/// `(unit direction, 0)`, `(weight per channel, 0)`; one zero `vec4` without a ground (a
/// buffer is never empty). Refuses non-finite weights.
fn sky_directions(ground: Option<&GroundLight>) -> Result<Vec<[f32; 4]>, GpuError> {
    let mut out = Vec::new();
    if let Some(g) = ground {
        let d = &g.sky_directions;
        for (w, k) in d.directions.iter().zip(&d.weights) {
            if !w.iter().chain(k).all(|c| c.is_finite()) {
                return Err(GpuError::Input(
                    "the ground's sky has a non-finite radiance".into(),
                ));
            }
            let w = f32x3(*w);
            out.push([w[0], w[1], w[2], 0.0]);
            let k = f32x3(*k);
            out.push([k[0], k[1], k[2], 0.0]);
        }
    }
    if out.is_empty() {
        out.push([0.0; 4]);
    }
    Ok(out)
}

/// The point lights whose light near them the view pass adds (`render::near_light`), as
/// `view_pass.wgsl` reads them: per light `(box-local position, 0)`, `(Ω/4π·I, 0)`; after
/// them one zero `vec4` (a buffer is never empty). None for an albedo of 0 or a grid
/// without a voxel size, as on the CPU. With the radius `R` of their spheres. Refuses
/// non-finite values and more than the device holds.
fn near_lights(
    ctx: &GpuContext,
    points: &[PointLight],
    medium: &Medium,
    grid: &GridBuffer,
) -> Result<(Vec<[f32; 4]>, f32), GpuError> {
    let vs = grid.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let origin = grid.bbox().min;
    let mut out = Vec::new();
    if medium.albedo > 0.0 && h0 > 0.0 && h0.is_finite() {
        let k = medium.albedo / FOUR_PI;
        for (i, l) in points.iter().enumerate() {
            if !l.position.iter().chain(&l.intensity).all(|c| c.is_finite()) {
                return Err(GpuError::Input(format!(
                    "point light {} has a non-finite position or intensity",
                    i + 1
                )));
            }
            let q = f32x3([0, 1, 2].map(|a| l.position[a] - origin[a]));
            out.push([q[0], q[1], q[2], 0.0]);
            let e = f32x3(l.intensity.map(|c| k * c));
            out.push([e[0], e[1], e[2], 0.0]);
        }
    }
    out.push([0.0; 4]);
    ctx.check_storage_size(
        "the point lights",
        std::mem::size_of_val(out.as_slice()) as u64,
    )?;
    Ok((out, (NEAR_RADIUS_VOXELS * h0) as f32))
}

/// The environment on the GPU as the view pass reads it: the sky's parameters (evaluated
/// analytically), or a lat-long map's texels (the backdrop's where a map was split into
/// suns); and the disks of the suns that are not in the backdrop
/// ([`Environment::radiance`]).
#[derive(Debug)]
pub struct EnvBuffer {
    /// 0: sky, 1: lat-long map.
    kind: u32,
    size: [u32; 2],
    /// The sky (the default for a map, unused).
    sky: crate::distant::Sky,
    buffer: wgpu::Buffer,
    /// Suns with a disk (zero-angle suns have none).
    suns: u32,
    /// Per sun `(direction, cos(angle/2))`, `(radiance, 0)`; one zero `vec4` when none.
    sun_buffer: wgpu::Buffer,
    /// The point lights (their light near them is the view pass's, `render::near_light`).
    points: Vec<PointLight>,
}

impl EnvBuffer {
    /// Uploads `env`. Refuses a sky with a negative or non-finite sun sharpness, suns with
    /// a non-finite direction, irradiance or angle or a direction that is not a unit
    /// vector, and a map beyond the device's limits.
    pub fn upload(ctx: &GpuContext, env: &Environment) -> Result<EnvBuffer, GpuError> {
        let mut disks: Vec<[f32; 4]> = Vec::with_capacity(2 * env.suns.len());
        let own = env.backdrop.as_ref().map_or(0, |b| b.suns);
        for (i, sun) in env.suns.iter().enumerate() {
            let finite = sun
                .direction
                .iter()
                .chain(&sun.irradiance)
                .all(|c| c.is_finite())
                && sun.angle.is_finite();
            if !finite {
                return Err(GpuError::Input(format!(
                    "sun {i} has a non-finite direction {:?}, irradiance {:?} or angle {}",
                    sun.direction, sun.irradiance, sun.angle
                )));
            }
            let norm = sun.direction.iter().map(|c| c * c).sum::<f64>().sqrt();
            if (norm - 1.0).abs() > super::lights_pass::UNIT_TOLERANCE {
                return Err(GpuError::Input(format!(
                    "sun {i}'s direction {:?} is not a unit vector (length {norm})",
                    sun.direction
                )));
            }
            // Zero-angle suns have no disk; the suns split off a backdrop are in its texels.
            if sun.angle <= 0.0 || i < own {
                continue;
            }
            let d = f32x3(sun.direction);
            let l = f32x3(sun.radiance());
            disks.push([d[0], d[1], d[2], (0.5 * sun.angle).cos() as f32]);
            disks.push([l[0], l[1], l[2], 0.0]);
        }
        let suns = u32::try_from(disks.len() / 2)
            .map_err(|_| GpuError::Input(format!("{} suns are too many", env.suns.len())))?;
        if disks.is_empty() {
            disks.push([0.0; 4]);
        }
        ctx.check_storage_size("the suns", std::mem::size_of_val(disks.as_slice()) as u64)?;
        // What a ray leaving the scene sees: a backdrop (the map as given, where it was
        // split into suns) before the distant radiance (`Environment::radiance`).
        let (kind, size, texels, sky) = match (&env.backdrop, &env.distant) {
            (Some(Backdrop { map: m, .. }), _) | (None, Distant::Map(m)) => (
                1,
                [m.width as u32, m.height as u32],
                &m.texels[..],
                crate::distant::Sky::default(),
            ),
            (None, Distant::Sky(s)) => {
                if !(s.sharpness >= 0.0 && s.sharpness.is_finite()) {
                    return Err(GpuError::Input(format!(
                        "sky sun sharpness {} must be finite and ≥ 0",
                        s.sharpness
                    )));
                }
                (0, [0, 0], &[[0.0f32; 3]][..], s.clone())
            }
        };
        ctx.check_storage_size("the environment map", std::mem::size_of_val(texels) as u64)?;
        let (buffer, sun_buffer) = ctx.scoped("environment upload", || {
            (
                buffer_init(
                    ctx,
                    "view pass environment",
                    bytemuck::cast_slice(texels),
                    wgpu::BufferUsages::STORAGE,
                ),
                buffer_init(
                    ctx,
                    "view pass suns",
                    bytemuck::cast_slice(&disks),
                    wgpu::BufferUsages::STORAGE,
                ),
            )
        })?;
        Ok(EnvBuffer {
            kind,
            size,
            sky,
            buffer,
            suns,
            sun_buffer,
            points: env.points.clone(),
        })
    }
}

/// A view pass's image on the GPU: one `vec4<f32>` per pixel (RGB, then padding), row 0
/// at the top.
#[derive(Debug)]
pub struct ImageBuffer {
    buffer: wgpu::Buffer,
    width: usize,
    height: usize,
}

impl ImageBuffer {
    /// Copies the pixels back to the host (waits for the GPU).
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<[f32; 3]>, GpuError> {
        let n = self.width * self.height;
        let size = (16 * n as u64).min(self.buffer.size());
        // Read in place from the mapped bytes (which need not be `f32`-aligned), one pass.
        ctx.read_with(&self.buffer, 0, size, |bytes| {
            let word = |b: &[u8], k: usize| {
                f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
            };
            bytes
                .chunks_exact(16)
                .map(|p| [word(p, 0), word(p, 1), word(p, 2)])
                .collect()
        })
    }

    /// `(width, height)` in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// An image of `pixels` (row 0 at the top, `width × height` of them) put on the
    /// device, as a view pass would have left it there.
    pub fn upload(
        ctx: &GpuContext,
        width: usize,
        height: usize,
        pixels: &[[f32; 3]],
    ) -> Result<ImageBuffer, GpuError> {
        if pixels.len() != width * height {
            return Err(GpuError::Input(format!(
                "{} pixels for an image of {width}×{height}",
                pixels.len()
            )));
        }
        let data: Vec<[f32; 4]> = pixels.iter().map(|p| [p[0], p[1], p[2], 0.0]).collect();
        ctx.check_storage_size("the image", std::mem::size_of_val(data.as_slice()) as u64)?;
        let buffer = ctx.scoped("image upload", || {
            buffer_init(
                ctx,
                "uploaded image",
                bytemuck::cast_slice(&data),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            )
        })?;
        Ok(ImageBuffer {
            buffer,
            width,
            height,
        })
    }

    /// The pixels on the device (`vec4<f32>` each), for the passes that read them.
    pub(crate) fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
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
    ground: Option<&GroundLight>,
) -> Result<Vec<[f32; 3]>, GpuError> {
    ViewPass::new(ctx)?.run(ctx, g, medium, env, camera, du, ground)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_match_the_wgsl_layout() {
        // Offsets of the WGSL struct: vec3 at 16-byte boundaries, vec2<u32> at 8.
        assert_eq!(std::mem::size_of::<Params>(), 256);
        assert_eq!(std::mem::offset_of!(Params, ground_sky), 208);
        assert_eq!(std::mem::offset_of!(Params, near_radius), 220);
        assert_eq!(std::mem::offset_of!(Params, near_lights), 224);
        assert_eq!(std::mem::offset_of!(Params, sky_cell), 228);
        assert_eq!(std::mem::offset_of!(Params, sky_first), 236);
        assert_eq!(std::mem::offset_of!(Params, sky_origin), 240);
        assert_eq!(std::mem::offset_of!(Params, image), 112);
        assert_eq!(std::mem::offset_of!(Params, zenith), 128);
        assert_eq!(std::mem::offset_of!(Params, sun), 192);
        // `ground_sky.wgsl`'s: vec2<f32> at 8, the struct 16-byte aligned.
        assert_eq!(std::mem::size_of::<SkyParams>(), 80);
        assert_eq!(std::mem::offset_of!(SkyParams, count), 44);
        assert_eq!(std::mem::offset_of!(SkyParams, origin), 48);
        assert_eq!(std::mem::offset_of!(SkyParams, ground_z), 60);
        assert_eq!(std::mem::offset_of!(SkyParams, first), 64);
    }
}
