//! The scene renderers on the GPU. Here paper C's (`shaders/render.wgsl` through the
//! entry `paper_c.wgsl`, wgpu compute): the twin of
//! [`crate::render::render`] with the [`Analytic`] model — paper C's airlight of point
//! lights through the `K` table, suns, the medium's transmittance, planes, spheres and meshes lit
//! by Lambert + normalized Phong with the light scattered onto them through the `G0`/`Gn`
//! tables, the environment — one invocation per pixel, in `f32`.
//!
//! Uploads (once, [`GpuRenderer::new`]): the tables in one storage buffer, `K` then `G0`
//! then the `Gn` of the scene's Phong exponents, read by bilinear interpolation in the
//! shader exactly as [`crate::paper_c::table::Table2::at`] reads them on the CPU (a filtered
//! texture would not do: GPUs interpolate with 8-bit fractions, an error of up to 1/512
//! of a cell's difference). Per frame ([`GpuRenderer::render`]): the camera, medium and
//! environment (a uniform), the lights and surfaces (storage), the meshes' hierarchies and
//! triangles (storage, traversed as [`crate::mesh::Mesh::intersect`] does), all positions
//! relative to the eye so that `f32` keeps its precision wherever the scene lies.
//!
//! The other renderers reuse its tables and buffers: paper D's composite
//! ([`analytic`]), the march through voxel media and analytic fogs ([`march`]), paper B's
//! Gaussian media ([`paper_b`]) and primary hits from the rasterizer ([`raster`]); their
//! shaders are composed from `render.wgsl` and short entry files ([`shaders`]). On a CPU
//! adapter (lavapipe), whose loops stop silently after 65535 iterations, a scene past the
//! shaders' budget is refused ([`cpu_device`]).
//!
//! What differs from the CPU beyond `f32` rounding: shadow rays leave a surface
//! [`SHADOW_OFFSET`] (relative) off it instead of the CPU's `10⁻⁹` and ignore surfaces
//! within that distance of their ends (the CPU: `10⁻⁷`), since a smaller offset is
//! below `f32`'s resolution; and environments at `∞` are flagged, not carried as `∞`
//! (WGSL does not promise infinities), finite ones beyond `10³⁰` clamped there.

use crate::media::HeteroMedium;
use crate::mesh::Mesh;
use crate::paper_c::airlight::Limits;
use crate::paper_c::envglow;
use crate::paper_c::htable::HTable;
use crate::render::{Analytic, Image};
use crate::scene::{Environment, Light, Scene, Shape};
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline, submit_pass};

pub mod analytic;
pub mod cpu_device;
pub mod march;
pub mod paper_b;
pub mod raster;
pub mod shaders;

/// Relative offset of shadow rays off the surface (and the margin they keep from their
/// ends): `(1 + |p|)·SHADOW_OFFSET`, `p` relative to the eye.
pub const SHADOW_OFFSET: f32 = 1e-4;

/// Pixels per workgroup side (`@workgroup_size(8, 8, 1)`).
const SIDE: usize = 8;

/// The shader's `Params` uniform (twelve `vec4`, 192 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    forward: [f32; 4],
    right: [f32; 4],
    up: [f32; 4],
    sigma_t: [f32; 4],
    sigma_s: [f32; 4],
    albedo: [f32; 4],
    env_color: [f32; 4],
    size: [u32; 4],
    flags: [u32; 4],
    tables: [u32; 4],
    env: [u32; 4],
    env_at: [u32; 4],
}

/// The compiled renderer with its tables on the GPU, reusable across frames of scenes
/// whose Phong exponents it has tables for.
#[derive(Debug)]
pub struct GpuRenderer {
    pipeline: wgpu::ComputePipeline,
    tables: wgpu::Buffer,
    k_side: u32,
    g_size: (u32, u32),
    /// The exponents of the `Gn` tables, in upload order (table `i + 1`).
    exponents: Vec<f64>,
    /// The march of scenes with voxel media ([`crate::gpu::march`]), compiled for the first.
    march: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The environment's light on the voxel media, kept between frames.
    env: crate::march::env_smoke::Cache,
    /// The rasterized renderer's passes ([`crate::gpu::raster`]), compiled for its first frame.
    raster: std::sync::OnceLock<crate::gpu::raster::RasterPipelines>,
    /// The `K` table, for the environment's glow ([`EnvGlow`](envglow::EnvGlow)).
    h: HTable,
    /// The environment's glow, kept between frames ([`envglow::Cache`]).
    glow: envglow::Cache,
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

/// `(kind, v)`: a record's first word says what it is.
fn tagged(kind: f32, v: [f64; 3]) -> [f32; 4] {
    [kind, v[0] as f32, v[1] as f32, v[2] as f32]
}

fn vec4(v: [f64; 3], w: f64) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, w as f32]
}

/// `[x, y, z, w]` as the bits of `f32` coordinates and a `u32`.
fn bits(v: [f64; 3], w: u32) -> [u32; 4] {
    [
        (v[0] as f32).to_bits(),
        (v[1] as f32).to_bits(),
        (v[2] as f32).to_bits(),
        w,
    ]
}

/// Three records per light (layout in `render.wgsl`: kind and position or direction,
/// The surfaces' records (`f32`) and the meshes' hierarchies and triangles (`u32`).
type SurfaceRecords = (Vec<[f32; 4]>, Vec<[u32; 4]>);

/// intensity or disk radiance, a sun's irradiance and disk), positions relative to `eye`.
fn light_records(scene: &Scene, eye: [f64; 3]) -> Vec<[f32; 4]> {
    let rel = |p: [f64; 3]| [0, 1, 2].map(|a| p[a] - eye[a]);
    let mut lights: Vec<[f32; 4]> = Vec::with_capacity(3 * scene.lights.len().max(1));
    for light in &scene.lights {
        match *light {
            Light::Point {
                position,
                intensity,
            } => {
                lights.push(tagged(0.0, rel(position)));
                lights.push(vec4(intensity, 0.0));
                lights.push([0.0; 4]);
            }
            Light::Sun {
                direction,
                radiance,
                angle,
            } => {
                let disk = if angle > 0.0 {
                    (0.5 * angle).cos()
                } else {
                    2.0
                };
                lights.push(tagged(1.0, direction));
                lights.push(vec4(radiance, 0.0));
                lights.push(vec4(Light::sun_irradiance(radiance, angle), disk));
            }
        }
    }
    // wgpu binds no empty buffers.
    if lights.is_empty() {
        lights.push([0.0; 4]);
    }
    lights
}

/// Appends `mesh`'s records to `out` (the shader's `meshes` layout), positions relative
/// to `eye`; returns the record indices of its first node and first triangle. The boxes
/// grow by `4·10⁻⁶` of the mesh's size plus its distance from the eye: `f32` rounds the
/// corners and the shader's hit distances by ~`10⁻⁷` of those, and a box must still
/// hold every triangle the shader would hit.
fn mesh_records(mesh: &Mesh, eye: [f64; 3], out: &mut Vec<[u32; 4]>) -> (usize, usize) {
    let rel = |p: [f64; 3]| [0, 1, 2].map(|a| p[a] - eye[a]);
    let root = mesh.nodes[0].bounds;
    let (lo, hi) = (rel(root.min), rel(root.max));
    let far = (0..3)
        .map(|a| lo[a].abs().max(hi[a].abs()))
        .fold(0.0, f64::max);
    let pad = 4e-6 * (far + crate::vec3::norm(crate::vec3::sub(hi, lo)));
    let nodes = out.len();
    for n in &mesh.nodes {
        out.push(bits(rel(n.bounds.min).map(|x| x - pad), n.first));
        out.push(bits(rel(n.bounds.max).map(|x| x + pad), n.count));
    }
    let tris = out.len();
    for t in &mesh.triangles {
        out.push(bits(rel(t.p[0]), u32::from(t.n.is_some())));
        out.push(bits(rel(t.p[1]), 0));
        out.push(bits(rel(t.p[2]), 0));
        for k in 0..3 {
            out.push(bits(t.n.map_or([0.0; 3], |n| n[k]), 0));
        }
    }
    (nodes, tris)
}

impl GpuRenderer {
    /// Compiles the shader and uploads the tables of `analytic`.
    pub fn new(ctx: &GpuContext, analytic: &Analytic) -> Result<GpuRenderer, GpuError> {
        let k = &analytic.h.table;
        if k.nx != k.ny {
            return Err(GpuError::Input(format!(
                "the K table must be square, not {}×{}",
                k.nx, k.ny
            )));
        }
        let g0 = &analytic.g0.table;
        let mut data = k.data.clone();
        data.extend_from_slice(&g0.data);
        for g in &analytic.gn {
            if (g.table.nx, g.table.ny) != (g0.nx, g0.ny) {
                return Err(GpuError::Input(format!(
                    "the G{} table is {}×{}, not {}×{} as G0",
                    g.exponent, g.table.nx, g.table.ny, g0.nx, g0.ny
                )));
            }
            data.extend_from_slice(&g.table.data);
        }
        let bytes = std::mem::size_of_val(data.as_slice()) as u64;
        ctx.check_storage_size("the K and G tables", bytes)?;
        let pipeline = compute_pipeline(
            ctx,
            "scene render pipeline creation",
            &shaders::source(&shaders::PAPER_C)?,
        )?;
        let tables = ctx.scoped("scene tables upload", || {
            buffer_init(
                ctx,
                "scene tables",
                bytemuck::cast_slice(&data),
                wgpu::BufferUsages::STORAGE,
            )
        })?;
        let side =
            |n: usize| u32::try_from(n).map_err(|_| GpuError::Input(format!("table side {n}")));
        Ok(GpuRenderer {
            pipeline,
            tables,
            k_side: side(k.nx)?,
            g_size: (side(g0.nx)?, side(g0.ny)?),
            exponents: analytic.gn.iter().map(|g| g.exponent).collect(),
            march: std::sync::OnceLock::new(),
            env: Default::default(),
            raster: std::sync::OnceLock::new(),
            h: analytic.h.clone(),
            glow: envglow::Cache::default(),
        })
    }

    /// How many SH projections of the environment and glows ([`EnvGlow`](envglow::EnvGlow)) this renderer
    /// computed: they are kept across camera moves and light edits, the glow rebuilt
    /// (from the kept projection) when the medium changes ([`envglow::Cache`]).
    pub fn env_builds(&self) -> (u64, u64) {
        self.glow.builds()
    }

    /// The index (in the tables buffer, 0 for `G0`) of the `Gn` table of `exponent`.
    fn gn_index(&self, exponent: f64) -> Option<usize> {
        self.exponents
            .iter()
            .position(|&e| e == exponent)
            .map(|i| i + 1)
    }

    /// The `envdata` records of the scene's environment (the shader's layout: the
    /// [`EnvGlow`](envglow::EnvGlow) of the frame's medium, then a map's texels), `Params::env` and
    /// `Params::env_at`.
    #[allow(clippy::type_complexity)]
    fn env_records(&self, scene: &Scene) -> Result<(Vec<[f32; 4]>, [u32; 4], [u32; 4]), GpuError> {
        let mut data: Vec<[f32; 4]> = Vec::new();
        let mut env = [0u32; 4];
        let mut at = [0u32; 4];
        let offset = |n: usize| {
            u32::try_from(n).map_err(|_| GpuError::Input("the environment is too large".into()))
        };
        if let Some(g) = self
            .glow
            .glow(scene, &self.h, envglow::DEFAULT_ORDER, &self.exponents)
        {
            let rgb = |v: &[f64; 3]| vec4(*v, 0.0);
            data.extend(g.radiance.iter().map(rgb));
            at[0] = offset(data.len())?;
            data.extend(g.incident.iter().map(rgb));
            at[1] = offset(data.len())?;
            data.extend(g.lambda.iter().map(rgb));
            at[2] = offset(data.len())?;
            for row in std::iter::once(&g.diffuse_lobe).chain(g.specular_lobes.iter().map(|s| &s.1))
            {
                data.extend(row.iter().map(|&v| [v as f32, 0.0, 0.0, 0.0]));
            }
            if g.order > envglow::GPU_MAX_ORDER {
                return Err(GpuError::Input(format!(
                    "SH order {} above the shader's {}",
                    g.order,
                    envglow::GPU_MAX_ORDER
                )));
            }
            env[2] = offset(g.order)?;
            env[3] = u32::from(g.glows);
        }
        if let Environment::Map(m) = &scene.environment {
            at[3] = offset(data.len())?;
            env[0] = offset(m.width)?;
            env[1] = offset(m.height)?;
            data.extend(m.texels.iter().map(|t| [t[0], t[1], t[2], 0.0]));
        }
        if data.is_empty() {
            data.push([0.0; 4]);
        }
        Ok((data, env, at))
    }

    /// Renders the scene's camera image (as [`crate::render::render`] with
    /// [`Analytic`] and the limits `lim`), reading it back to the host.
    pub fn render(&self, ctx: &GpuContext, scene: &Scene, lim: &Limits) -> Result<Image, GpuError> {
        Ok(self.frame(ctx, scene, lim, false)?.0)
    }

    /// [`GpuRenderer::render`] with the surfaces rasterized ([`crate::gpu::raster`]): the same
    /// picture but where a pixel's center lies within rounding of a silhouette.
    pub fn render_rasterized(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        lim: &Limits,
    ) -> Result<Image, GpuError> {
        Ok(self.frame(ctx, scene, lim, true)?.0)
    }

    /// [`GpuRenderer::render_rasterized`] and the surface its raster pass found at each
    /// pixel (row by row; `None` for none, and for every pixel of a scene with voxel
    /// media, which is ray-traced).
    pub fn render_rasterized_with_surfaces(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        lim: &Limits,
    ) -> Result<(Image, Vec<Option<usize>>), GpuError> {
        let (image, gbuffer) = self.frame(ctx, scene, lim, true)?;
        let surfaces = match gbuffer {
            Some(g) => self.raster.get().map_or_else(
                || Err(GpuError::Input("no raster pass ran".into())),
                |r| r.read_surfaces(ctx, &g),
            )?,
            None => vec![None; image.pixels.len()],
        };
        Ok((image, surfaces))
    }

    /// One frame, its primary hits rasterized when `rasterize` and the scene has no
    /// heterogeneous media; the G-buffer when one was drawn.
    fn frame(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        lim: &Limits,
        rasterize: bool,
    ) -> Result<(Image, Option<wgpu::Texture>), GpuError> {
        if scene.hetero.is_empty() {
            return self.pass(ctx, scene, lim, &self.pipeline, None, &[], rasterize, None);
        }
        // Scenes with voxel media or analytic fogs: the march (crate::gpu::march) instead
        // of paper C; other heterogeneous media (paper B's Gaussians:
        // [`crate::gpu::paper_b`]) are refused here rather than rendered without them.
        if let Some(m) = scene
            .hetero
            .iter()
            .find(|m| !matches!(m, HeteroMedium::Asset(_) | HeteroMedium::Analytic(_)))
        {
            return Err(GpuError::Input(format!(
                "this renderer does not render heterogeneous media ({})",
                m.name()
            )));
        }
        let mut opt = crate::march::march_steps(scene, false);
        opt.env = self.env.light(scene);
        let Some(march) = crate::gpu::march::MarchInput::of(scene, scene.camera.eye, &opt)? else {
            return self.pass(ctx, scene, lim, &self.pipeline, None, &[], rasterize, None);
        };
        march.check(ctx)?;
        if self.march.get().is_none() {
            let _ = self.march.set(crate::gpu::march::pipeline(ctx)?);
        }
        let pipeline = self.march.get().expect("set above");
        let [grid, records] = march.buffers(ctx);
        let chunks = crate::gpu::march::chunks(scene, &opt);
        self.pass(
            ctx,
            scene,
            lim,
            pipeline,
            None,
            &[&grid, &records],
            false,
            Some(chunks),
        )
    }

    /// [`GpuRenderer::render`]'s frame with another entry point of the same bindings
    /// (`pipeline`), the homogeneous medium's `(σt, σs)` replaced by `medium` if given, and
    /// `extra` storage buffers bound after the seven of `render.wgsl` (bindings 7, 8, …).
    pub(crate) fn render_pass(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        lim: &Limits,
        pipeline: &wgpu::ComputePipeline,
        medium: Option<([f64; 3], [f64; 3])>,
        extra: &[&wgpu::Buffer],
    ) -> Result<Image, GpuError> {
        Ok(self
            .pass(ctx, scene, lim, pipeline, medium, extra, false, None)?
            .0)
    }

    /// [`GpuRenderer::render_pass`], its primary hits rasterized ([`crate::gpu::raster`]) when
    /// `rasterize` (then `pipeline` and `extra` are not used: the raster pass shades with
    /// `render.wgsl`); the G-buffer when one was drawn. `chunks`: the march's
    /// `(steps per dispatch, dispatches)` ([`crate::gpu::march::chunks`]), its state kept
    /// after the image between dispatches.
    #[allow(clippy::too_many_arguments)]
    fn pass(
        &self,
        ctx: &GpuContext,
        scene: &Scene,
        lim: &Limits,
        pipeline: &wgpu::ComputePipeline,
        medium: Option<([f64; 3], [f64; 3])>,
        extra: &[&wgpu::Buffer],
        rasterize: bool,
        chunks: Option<(u32, u32)>,
    ) -> Result<(Image, Option<wgpu::Texture>), GpuError> {
        let (sigma_t, sigma_s) = medium.unwrap_or((scene.medium.sigma_t, scene.medium.sigma_s()));
        let cam = &scene.camera;
        let (w, h) = (cam.width, cam.height);
        let pixels = w
            .checked_mul(h)
            .filter(|&n| u32::try_from(n).is_ok())
            .ok_or_else(|| GpuError::Input(format!("image of {w}×{h} pixels is too large")))?;
        let (chunk, dispatches) = chunks.unwrap_or((0, 1));
        // The march's state after the image: two vec4 per pixel.
        let out_bytes = 16 * pixels as u64 * if chunk > 0 { 3 } else { 1 };
        ctx.check_storage_size("the image", out_bytes)?;
        cpu_device::check_shading(ctx.is_cpu_adapter(), scene)?;
        let eye = cam.eye;
        let lights = light_records(scene, eye);
        let (surfaces, meshes) = self.surface_records(scene, eye)?;
        ctx.check_storage_size("the meshes", 16 * meshes.len() as u64)?;
        let (params, envdata) = self.params(scene, lim, (sigma_t, sigma_s), chunk)?;
        ctx.check_storage_size("the environment", 16 * envdata.len() as u64)?;
        let groups = [w.div_ceil(SIDE) as u32, h.div_ceil(SIDE) as u32, 1];
        let raster = if rasterize {
            if self.raster.get().is_none() {
                let _ = self
                    .raster
                    .set(crate::gpu::raster::RasterPipelines::new(ctx)?);
            }
            let vertices = crate::gpu::raster::vertices(scene, eye)?;
            self.raster.get().map(|r| (r, vertices))
        } else {
            None
        };
        let (output, gbuffer) = ctx.scoped("scene render", || {
            let uniform = buffer_init(
                ctx,
                "scene params",
                bytemuck::bytes_of(&params),
                // Storage for the rasterized renderer (crate::gpu::raster::shader).
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
            );
            let lights = buffer_init(
                ctx,
                "scene lights",
                bytemuck::cast_slice(&lights),
                wgpu::BufferUsages::STORAGE,
            );
            let surfaces = buffer_init(
                ctx,
                "scene surfaces",
                bytemuck::cast_slice(&surfaces),
                wgpu::BufferUsages::STORAGE,
            );
            let meshes = buffer_init(
                ctx,
                "scene meshes",
                bytemuck::cast_slice(&meshes),
                wgpu::BufferUsages::STORAGE,
            );
            let envdata = buffer_init(
                ctx,
                "scene environment",
                bytemuck::cast_slice(&envdata),
                wgpu::BufferUsages::STORAGE,
            );
            let output = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("scene image"),
                size: out_bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let mut buffers = vec![
                &uniform,
                &lights,
                &surfaces,
                &self.tables,
                &output,
                &meshes,
                &envdata,
            ];
            buffers.extend_from_slice(extra);
            let gbuffer = match &raster {
                Some((r, vertices)) => {
                    let size = (params.size[0], params.size[1]);
                    let g = r.gbuffer(ctx, [&uniform, &surfaces, &meshes], vertices, size);
                    r.shade(ctx, &buffers, &g, groups);
                    Some(g)
                }
                None => {
                    for _ in 0..dispatches.max(1) {
                        submit_pass(ctx, pipeline, "scene render", &buffers, groups);
                    }
                    None
                }
            };
            (output, gbuffer)
        })?;
        let bytes = ctx.read_buffer(&output)?;
        let mut rgba: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
        rgba.truncate(w * h);
        let image = Image {
            width: w,
            height: h,
            pixels: rgba.into_iter().map(|p| [p[0], p[1], p[2]]).collect(),
        };
        Ok((image, gbuffer))
    }

    /// Four records per surface (layout in `render.wgsl`: shape, its parameters, the
    /// diffuse colour and shininess, the specular colour and its `Gn` table), positions
    /// relative to `eye`, and the meshes' hierarchies and triangles (each one zero record
    /// when empty).
    fn surface_records(&self, scene: &Scene, eye: [f64; 3]) -> Result<SurfaceRecords, GpuError> {
        let rel = |p: [f64; 3]| [0, 1, 2].map(|a| p[a] - eye[a]);
        let mut surfaces: Vec<[f32; 4]> = Vec::with_capacity(4 * scene.surfaces.len().max(1));
        let mut meshes: Vec<[u32; 4]> = Vec::new();
        for (i, s) in scene.surfaces.iter().enumerate() {
            let m = &s.material;
            let gn = if m.is_specular() {
                self.gn_index(m.shininess).ok_or_else(|| {
                    GpuError::Input(format!(
                        "surfaces[{i}]: no G table for the Phong exponent {}",
                        m.shininess
                    ))
                })? as f64
            } else {
                -1.0
            };
            match &s.shape {
                Shape::Mesh(mesh) => {
                    let (nodes, tris) = mesh_records(mesh, eye, &mut meshes);
                    // Record indices travel as f32 in the surface record: exact below 2²⁴.
                    if tris.max(nodes) >= 1 << 24 {
                        return Err(GpuError::Input(format!(
                            "surfaces[{i}]: the scene's meshes are too large for the GPU renderer"
                        )));
                    }
                    surfaces.push([2.0, nodes as f32, tris as f32, 0.0]);
                    surfaces.push([0.0; 4]);
                }
                &Shape::Plane { point, normal } => {
                    surfaces.push(tagged(0.0, rel(point)));
                    surfaces.push(vec4(normal, 0.0));
                }
                &Shape::Sphere { center, radius } => {
                    surfaces.push(tagged(1.0, rel(center)));
                    surfaces.push(vec4([0.0; 3], radius));
                }
            }
            surfaces.push(vec4(m.diffuse, m.shininess));
            surfaces.push(vec4(m.specular, gn));
        }
        // wgpu binds no empty buffers.
        if surfaces.is_empty() {
            surfaces.push([0.0; 4]);
        }
        if meshes.is_empty() {
            meshes.push([0; 4]);
        }
        Ok((surfaces, meshes))
    }

    /// The shader's parameters (camera, medium `(σt, σs)`, environment, sizes, tables,
    /// `chunk` steps per dispatch) and the environment's records.
    fn params(
        &self,
        scene: &Scene,
        lim: &Limits,
        (sigma_t, sigma_s): ([f64; 3], [f64; 3]),
        chunk: u32,
    ) -> Result<(Params, Vec<[f32; 4]>), GpuError> {
        let cam = &scene.camera;
        let (w, h) = (cam.width, cam.height);
        let (env_kind, env_color) = match &scene.environment {
            Environment::Black => (0, [0.0; 3]),
            Environment::Sky => (1, [0.0; 3]),
            Environment::Constant(c) => (2, *c),
            Environment::Map(_) => (3, [0.0; 3]),
        };
        let (envdata, env, env_at) = self.env_records(scene)?;
        let gamma_min = lim.gamma_min.max(0.5 * cam.pixel_radius());
        let far = scene.environment_distance;
        let count = |n: usize, what: &str| {
            u32::try_from(n).map_err(|_| GpuError::Input(format!("{n} {what} are too many")))
        };
        let params = Params {
            forward: vec4(cam.forward(), cam.tan_half()),
            right: vec4(cam.right(), w as f64 / h as f64),
            up: vec4(cam.up(), gamma_min),
            sigma_t: vec4(sigma_t, lim.r_min),
            sigma_s: vec4(
                sigma_s,
                // Beyond f32's range a finite distance would read as ∞ in the shader.
                if far.is_finite() { far.min(1e30) } else { 0.0 },
            ),
            albedo: {
                let [a, b, c] = f32x3(scene.medium.albedo);
                [a, b, c, SHADOW_OFFSET]
            },
            env_color: vec4(env_color, 0.0),
            size: [
                count(w, "columns")?,
                count(h, "rows")?,
                count(scene.lights.len(), "lights")?,
                count(scene.surfaces.len(), "surfaces")?,
            ],
            flags: [
                env_kind,
                u32::from(!far.is_finite()),
                self.k_side,
                self.g_size.0,
            ],
            tables: [self.g_size.1, self.k_side * self.k_side, chunk, 0],
            env,
            env_at,
        };
        Ok((params, envdata))
    }
}
