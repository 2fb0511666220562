//! A wavelet fog on the GPU (`shaders/wavelet_fog.wgsl`), the twin of
//! [`crate::render::render`] and [`Fog::optical_depth`]: the same image and optical depths,
//! computed in `f32`.
//!
//! [`FogRenderer::upload`] copies a fog's deconstructed levels — level `l`'s scaling
//! coefficients `A_l` (paper E §4.4), its cell footprint and lower bound — into storage
//! buffers, with the basis's polynomial pieces. Per frame, one invocation per pixel casts
//! the pixel's ray, integrates the levels exactly cell by cell in their µ bands (eq. 11,
//! 12) with the early exit on transmittance, and blends ground or sky with the fog's
//! colour, as [`crate::render::shade`] does. With a [`SmokeLayer`] (per pixel a smoke's
//! radiance, transmittance and depth, [`FogRenderer::draw_over`]) the fog is integrated
//! in two spans split at the smoke's depth and composited with it, as
//! [`crate::render::shade_over`] does.
//!
//! Positions on the GPU are relative to the fogmap's south-west corner (and heights to the
//! layer's bottom), computed in `f64` on the host, so a fog far from the world's origin
//! loses no `f32` precision.

use crate::lod::{Fog, MAX_LEVELS, Mode};
use crate::render::{Scene, SmokeSample};
use haze_camera::LookAt;
use haze_gpu::buffer_init;
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError};

/// The shader, `crates/wavelet/shaders/wavelet_fog.wgsl` (no imports).
pub const SHADER: Variant = Variant {
    label: "wavelet fog",
    entry: include_str!("../../shaders/wavelet_fog.wgsl"),
    defines: &[],
};

/// Pixels per workgroup side (`@workgroup_size(8, 8)` of `main`).
const TILE: u32 = 8;
/// Rays per workgroup (`@workgroup_size(64)` of `depths`).
const RAYS_PER_GROUP: u32 = 64;
/// Most workgroups along one dispatch dimension (WebGPU's default limit).
const MAX_GROUPS: u32 = 65_535;
/// "Never" on the GPU, where infinities are best avoided: larger than any depth.
const NEVER: f32 = 3.0e38;

/// The shader's `Params` in WGSL's layout (a `vec3` is 16-byte aligned and the scalar
/// after it fills its fourth slot), 224 bytes; bound as a read-only storage buffer, not a
/// uniform one (the shader says why).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    eye: [f32; 3],
    tan_half: f32,
    forward: [f32; 3],
    aspect: f32,
    right: [f32; 3],
    cell: f32,
    up: [f32; 3],
    density: f32,
    bounds: [f32; 4],
    zenith: [f32; 3],
    checker: f32,
    horizon: [f32; 3],
    ground_z: f32,
    ground0: [f32; 3],
    top: f32,
    ground1: [f32; 3],
    falloff: f32,
    fog: [f32; 3],
    mu: f32,
    origin: [f32; 2],
    stop_depth: f32,
    shift: f32,
    image: [u32; 2],
    levels: u32,
    degree: u32,
    first: [i32; 2],
    support: [i32; 2],
    layer: u32,
    _pad: [u32; 3],
}

/// The shader's `Level`: 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Level {
    cells: [i32; 4],
    k0: [i32; 2],
    n: [i32; 2],
    scale: f32,
    floor: f32,
    coef_at: u32,
    _pad: u32,
}

/// The shader's `Query`: 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Query {
    o: [f32; 3],
    len: f32,
    d: [f32; 3],
    _pad: f32,
}

/// A ray whose optical depth [`FogRenderer::optical_depths`] computes (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RayQuery {
    /// The segment between two points, as [`Fog::optical_depth`].
    Segment {
        /// Start.
        from: [f64; 3],
        /// End.
        to: [f64; 3],
    },
    /// From a point along a direction to where the ray leaves the fog, as
    /// [`Fog::optical_depth_ray`].
    ToExit {
        /// Start.
        from: [f64; 3],
        /// Direction (need not be unit).
        dir: [f64; 3],
    },
}

/// The compiled passes, reusable across fogs and frames.
#[derive(Debug)]
pub struct FogRenderer {
    image: wgpu::ComputePipeline,
    depths: wgpu::ComputePipeline,
    /// Bound as the smoke layer when there is none (never read).
    no_smoke: wgpu::Buffer,
}

/// A smoke layer on the GPU, composited by depth with the fog by
/// [`FogRenderer::draw_over`]: per pixel the smoke's radiance, transmittance and depth
/// ([`SmokeSample`], as [`crate::render::shade_over`] takes it).
#[derive(Debug)]
pub struct SmokeLayer {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
}

impl SmokeLayer {
    /// A layer of `width × height` pixels holding `samples` (row 0 on top).
    pub fn new(
        ctx: &GpuContext,
        samples: &[SmokeSample],
        width: usize,
        height: usize,
    ) -> Result<SmokeLayer, GpuError> {
        if samples.len() != width * height || samples.is_empty() {
            return Err(GpuError::Input(format!(
                "a smoke layer of {} samples for {width} × {height} pixels",
                samples.len()
            )));
        }
        let bytes = (samples.len() * 32) as u64;
        ctx.check_storage_size("the smoke layer", bytes)?;
        let buffer = ctx.scoped("smoke layer", || {
            buffer_init(
                ctx,
                "smoke layer",
                bytemuck::cast_slice(&Self::pack(samples)),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            )
        })?;
        Ok(SmokeLayer {
            buffer,
            width: width as u32,
            height: height as u32,
        })
    }

    /// Replaces the samples (same size) without a new buffer.
    pub fn write(&self, ctx: &GpuContext, samples: &[SmokeSample]) -> Result<(), GpuError> {
        if samples.len() != (self.width * self.height) as usize {
            return Err(GpuError::Input(format!(
                "{} smoke samples for a layer of {} × {} pixels",
                samples.len(),
                self.width,
                self.height
            )));
        }
        ctx.queue
            .write_buffer(&self.buffer, 0, bytemuck::cast_slice(&Self::pack(samples)));
        Ok(())
    }

    /// The shader's two `vec4` per pixel: `(L_s, T_s)`, `(d, 0, 0, 0)`.
    fn pack(samples: &[SmokeSample]) -> Vec<[f32; 4]> {
        samples
            .iter()
            .flat_map(|s| {
                let [r, g, b] = s.radiance;
                [[r, g, b, s.transmittance], [s.depth, 0.0, 0.0, 0.0]]
            })
            .collect()
    }
}

/// A fog's levels on the GPU, ready to render (made by [`FogRenderer::upload`]).
#[derive(Debug)]
pub struct GpuFog {
    levels: wgpu::Buffer,
    pieces: wgpu::Buffer,
    coef: wgpu::Buffer,
    /// Everything of `Params` that belongs to the fog; camera, scene and size per frame.
    base: Params,
    /// World `(x, y)` of the fogmap's corner and the layer's bottom: the GPU's origin.
    anchor: [f64; 3],
}

/// An image on the GPU: `(r, g, b, τ)` per pixel, row 0 on top.
#[derive(Debug)]
pub struct FogImage {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
}

impl FogImage {
    /// An image of `width × height` pixels that a frame will fill.
    pub fn new(ctx: &GpuContext, width: usize, height: usize) -> Result<FogImage, GpuError> {
        let groups = |n: usize| n.div_ceil(TILE as usize);
        if width == 0 || height == 0 || groups(width).max(groups(height)) > MAX_GROUPS as usize {
            return Err(GpuError::Input(format!(
                "an image of {width} × {height} pixels: each side must be between 1 and {}",
                MAX_GROUPS * TILE
            )));
        }
        let bytes = (width * height * 16) as u64;
        ctx.check_storage_size("the image", bytes)?;
        let buffer = ctx.scoped("image creation", || {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("wavelet fog image"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        })?;
        Ok(FogImage {
            buffer,
            width: width as u32,
            height: height as u32,
        })
    }

    /// Reads the pixels back: `(r, g, b, τ)`, linear RGB, row 0 on top.
    pub fn read(&self, ctx: &GpuContext) -> Result<Vec<[f32; 4]>, GpuError> {
        let bytes = ctx.read_buffer(&self.buffer)?;
        // Copied rather than cast: the bytes come without `f32` alignment.
        Ok(bytemuck::pod_collect_to_vec(&bytes))
    }

    /// Width and height in pixels.
    pub fn size(&self) -> [usize; 2] {
        [self.width as usize, self.height as usize]
    }
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    v.map(|c| c as f32)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// A value the shader holds in `i32`, or why not.
fn to_i32(v: i64, what: &str) -> Result<i32, GpuError> {
    i32::try_from(v).map_err(|_| {
        GpuError::Input(format!(
            "{what} {v} is beyond the GPU's 32-bit cell indices"
        ))
    })
}

impl FogRenderer {
    /// Compiles both passes.
    pub fn new(ctx: &GpuContext) -> Result<FogRenderer, GpuError> {
        let source = SHADER.source(&[])?;
        let pipeline = |entry: &'static str| {
            ctx.scoped("wavelet fog shader", || {
                let module = ctx
                    .device
                    .create_shader_module(wgpu::ShaderModuleDescriptor {
                        label: Some("wavelet fog"),
                        source: wgpu::ShaderSource::Wgsl(source.as_str().into()),
                    });
                ctx.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout: None,
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            })
        };
        let no_smoke = ctx.scoped("empty smoke layer", || {
            buffer_init(
                ctx,
                "no smoke layer",
                &[0u8; 32],
                wgpu::BufferUsages::STORAGE,
            )
        })?;
        Ok(FogRenderer {
            image: pipeline("main")?,
            depths: pipeline("depths")?,
            no_smoke,
        })
    }

    /// Uploads a fog's levels. Refuses a fog in [`Mode::Direct`] (the GPU integrates the
    /// deconstructed scaling bases, whose early exit it needs), values beyond `f32` and
    /// cell indices beyond `i32`.
    pub fn upload(&self, ctx: &GpuContext, fog: &Fog) -> Result<GpuFog, GpuError> {
        if fog.settings().mode != Mode::Deconstructed {
            return Err(GpuError::Input(
                "the GPU integrates deconstructed levels only (the direct wavelet integration is CPU only)"
                    .to_string(),
            ));
        }
        let Levels {
            records: levels,
            coef,
            table,
            first,
            support,
        } = Levels::of(fog)?;
        let p = fog.placement();
        let settings = fog.settings();
        if p.density > f64::from(f32::MAX) {
            return Err(GpuError::Input(format!(
                "density {:e} is beyond the GPU's 32-bit floats",
                p.density
            )));
        }
        let stop_depth = if settings.min_transmittance > 0.0 && p.density > 0.0 {
            (-settings.min_transmittance.ln() / p.density).min(f64::from(NEVER)) as f32
        } else {
            NEVER
        };
        let [bx0, bx1, by0, by1] = fog.bounds();
        let bounds = if bx0 < bx1 && by0 < by1 {
            [
                bx0 - p.origin[0],
                bx1 - p.origin[0],
                by0 - p.origin[1],
                by1 - p.origin[1],
            ]
        } else {
            [0.0; 4]
        };
        let base = Params {
            eye: [0.0; 3],
            tan_half: 0.0,
            forward: [0.0; 3],
            aspect: 0.0,
            right: [0.0; 3],
            cell: p.cell as f32,
            up: [0.0; 3],
            density: p.density as f32,
            bounds: bounds.map(|b| b as f32),
            zenith: [0.0; 3],
            checker: 0.0,
            horizon: [0.0; 3],
            ground_z: -p.bottom as f32,
            ground0: [0.0; 3],
            top: (p.top - p.bottom) as f32,
            ground1: [0.0; 3],
            falloff: p.falloff as f32,
            fog: [0.0; 3],
            mu: settings.mu as f32,
            origin: p.origin.map(|c| c as f32),
            stop_depth,
            shift: fog.basis().degree() as f32 / 2.0,
            image: [0; 2],
            levels: fog.levels() as u32,
            degree: fog.basis().degree() as u32,
            first: [
                to_i32(first[0], "first cell")?,
                to_i32(first[1], "first cell")?,
            ],
            support: [support[0] as i32, support[1] as i32],
            layer: 0,
            _pad: [0; 3],
        };
        let storage = wgpu::BufferUsages::STORAGE;
        ctx.check_storage_size("the fog's coefficients", (coef.len() * 4) as u64)?;
        let (levels, pieces, coef) = ctx.scoped("fog upload", || {
            (
                buffer_init(ctx, "fog levels", bytemuck::cast_slice(&levels), storage),
                buffer_init(
                    ctx,
                    "fog basis pieces",
                    bytemuck::cast_slice(&table),
                    storage,
                ),
                buffer_init(
                    ctx,
                    "fog coefficients",
                    bytemuck::cast_slice(&coef),
                    storage,
                ),
            )
        })?;
        Ok(GpuFog {
            levels,
            pieces,
            coef,
            base,
            anchor: [p.origin[0], p.origin[1], p.bottom],
        })
    }

    /// Renders `fog` as [`crate::render::render`] does into `image`: submits the frame
    /// without waiting for it ([`GpuContext::finish`] waits, [`FogImage::read`] reads).
    pub fn draw(
        &self,
        ctx: &GpuContext,
        fog: &GpuFog,
        look: &LookAt,
        scene: &Scene,
        image: &FogImage,
    ) -> Result<(), GpuError> {
        self.draw_layer(ctx, fog, look, scene, None, image)
    }

    /// [`FogRenderer::draw`] with a smoke layer of the image's size composited by depth,
    /// as [`crate::render::render_over`] does.
    pub fn draw_over(
        &self,
        ctx: &GpuContext,
        fog: &GpuFog,
        look: &LookAt,
        scene: &Scene,
        smoke: &SmokeLayer,
        image: &FogImage,
    ) -> Result<(), GpuError> {
        if [smoke.width, smoke.height] != [image.width, image.height] {
            return Err(GpuError::Input(format!(
                "a smoke layer of {} × {} pixels over an image of {} × {}",
                smoke.width, smoke.height, image.width, image.height
            )));
        }
        self.draw_layer(ctx, fog, look, scene, Some(smoke), image)
    }

    fn draw_layer(
        &self,
        ctx: &GpuContext,
        fog: &GpuFog,
        look: &LookAt,
        scene: &Scene,
        smoke: Option<&SmokeLayer>,
        image: &FogImage,
    ) -> Result<(), GpuError> {
        // The CPU's camera for the image (which validates the view), in f64.
        let camera = look
            .camera(image.width as usize, image.height as usize)
            .map_err(GpuError::Input)?;
        let (forward, right, up) = (camera.forward(), camera.right(), camera.up());
        let mut params = fog.base;
        params.eye = f32x3(fog.relative(camera.eye));
        params.tan_half = camera.tan_half() as f32;
        params.forward = f32x3(forward);
        params.aspect = (f64::from(image.width) / f64::from(image.height)) as f32;
        params.right = f32x3(right);
        params.up = f32x3(up);
        params.zenith = f32x3(scene.zenith);
        params.horizon = f32x3(scene.horizon);
        params.ground0 = f32x3(scene.ground[0]);
        params.ground1 = f32x3(scene.ground[1]);
        params.checker = scene.checker as f32;
        params.fog = f32x3(scene.fog);
        params.image = [image.width, image.height];
        params.layer = u32::from(smoke.is_some());
        let layer = smoke.map_or(&self.no_smoke, |s| &s.buffer);
        let groups = [image.width.div_ceil(TILE), image.height.div_ceil(TILE), 1];
        self.submit(
            ctx,
            &self.image,
            fog,
            &params,
            &image.buffer,
            (6, layer),
            groups,
        )
    }

    /// Renders `fog` with a smoke layer to `width × height` pixels `(r, g, b, τ)` and
    /// reads them back (the twin of [`crate::render::render_over`]).
    #[allow(clippy::too_many_arguments)]
    pub fn render_over(
        &self,
        ctx: &GpuContext,
        fog: &GpuFog,
        look: &LookAt,
        scene: &Scene,
        smoke: &[SmokeSample],
        width: usize,
        height: usize,
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        let image = FogImage::new(ctx, width, height)?;
        let layer = SmokeLayer::new(ctx, smoke, width, height)?;
        self.draw_over(ctx, fog, look, scene, &layer, &image)?;
        image.read(ctx)
    }

    /// Renders `fog` to `width × height` pixels `(r, g, b, τ)` and reads them back.
    pub fn render(
        &self,
        ctx: &GpuContext,
        fog: &GpuFog,
        look: &LookAt,
        scene: &Scene,
        width: usize,
        height: usize,
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        let image = FogImage::new(ctx, width, height)?;
        self.draw(ctx, fog, look, scene, &image)?;
        image.read(ctx)
    }

    /// The optical depth of each ray, as [`Fog::optical_depth`] and
    /// [`Fog::optical_depth_ray`] compute it on the CPU.
    pub fn optical_depths(
        &self,
        ctx: &GpuContext,
        fog: &GpuFog,
        rays: &[RayQuery],
    ) -> Result<Vec<f64>, GpuError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let groups = (rays.len() as u64).div_ceil(u64::from(RAYS_PER_GROUP));
        if groups > u64::from(MAX_GROUPS) {
            return Err(GpuError::Input(format!(
                "{} rays in one call: at most {}",
                rays.len(),
                MAX_GROUPS * RAYS_PER_GROUP
            )));
        }
        // A zero-length segment or direction has depth 0 (as on the CPU): length 0.
        let empty = |o: [f64; 3]| Query {
            o: f32x3(fog.relative(o)),
            len: 0.0,
            d: [1.0, 0.0, 0.0],
            _pad: 0.0,
        };
        let queries: Vec<Query> = rays
            .iter()
            .map(|r| match *r {
                RayQuery::Segment { from, to } => {
                    let v = sub(to, from);
                    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    if !(len.is_finite() && len > 0.0) {
                        return empty(from);
                    }
                    Query {
                        o: f32x3(fog.relative(from)),
                        len: len as f32,
                        d: f32x3(v.map(|c| c / len)),
                        _pad: 0.0,
                    }
                }
                RayQuery::ToExit { from, dir } => {
                    let n = (dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]).sqrt();
                    if !(n.is_finite() && n > 0.0) {
                        return empty(from);
                    }
                    Query {
                        o: f32x3(fog.relative(from)),
                        len: -1.0,
                        d: f32x3(dir.map(|c| c / n)),
                        _pad: 0.0,
                    }
                }
            })
            .collect();
        let out_bytes = (rays.len() * 16) as u64;
        ctx.check_storage_size("the rays' depths", out_bytes)?;
        let (input, output) = ctx.scoped("ray upload", || {
            (
                buffer_init(
                    ctx,
                    "fog rays",
                    bytemuck::cast_slice(&queries),
                    wgpu::BufferUsages::STORAGE,
                ),
                ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("fog ray depths"),
                    size: out_bytes,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
            )
        })?;
        let mut params = fog.base;
        params.image = [rays.len() as u32, 1];
        self.submit(
            ctx,
            &self.depths,
            fog,
            &params,
            &output,
            (5, &input),
            [groups as u32, 1, 1],
        )?;
        let bytes = ctx.read_buffer(&output)?;
        let out: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(out.iter().map(|v| f64::from(v[0])).collect())
    }

    /// Binds the fog, `params`, `output` and `extra` (binding, buffer: the smoke layer of
    /// `main`, the rays of `depths`) and submits one pass of `pipeline`.
    #[allow(clippy::too_many_arguments)]
    fn submit(
        &self,
        ctx: &GpuContext,
        pipeline: &wgpu::ComputePipeline,
        fog: &GpuFog,
        params: &Params,
        output: &wgpu::Buffer,
        extra: (u32, &wgpu::Buffer),
        groups: [u32; 3],
    ) -> Result<(), GpuError> {
        ctx.scoped("wavelet fog pass", || {
            let uniform = buffer_init(
                ctx,
                "wavelet fog params",
                bytemuck::bytes_of(params),
                wgpu::BufferUsages::STORAGE,
            );
            let buffers = [&uniform, &fog.levels, &fog.pieces, &fog.coef, output];
            let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
                .into_iter()
                .zip(0..)
                .chain([(extra.1, extra.0)])
                .map(|(b, binding)| wgpu::BindGroupEntry {
                    binding,
                    resource: b.as_entire_binding(),
                })
                .collect();
            let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavelet fog"),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            });
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("wavelet fog"),
                });
            {
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("wavelet fog"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
            }
            ctx.queue.submit([enc.finish()]);
        })
    }
}

impl GpuFog {
    /// Moves the fog by `by` in world `(x, y)`, as [`Fog::translate`]: nothing is uploaded
    /// again (the levels are stored relative to the fog's corner, which moves).
    pub fn translate(&mut self, by: [f64; 2]) {
        self.anchor[0] += by[0];
        self.anchor[1] += by[1];
        self.base.origin = [self.anchor[0] as f32, self.anchor[1] as f32];
    }

    /// A world point in the GPU's coordinates (relative to the fogmap's corner and the
    /// layer's bottom).
    fn relative(&self, p: [f64; 3]) -> [f64; 3] {
        sub(p, self.anchor)
    }
}

/// A fog's levels as the shader reads them: a record per level, every level's
/// coefficients end to end (one zero for none: wgpu binds no empty buffers), and the
/// scaling basis they all share (its polynomial pieces in `f32`, first cell and support
/// per axis).
struct Levels {
    records: Vec<Level>,
    coef: Vec<f32>,
    table: Vec<f32>,
    first: [i64; 2],
    support: [usize; 2],
}

impl Levels {
    /// `fog`'s levels, or why the GPU cannot take them: a level of several scaling bases
    /// or off its own grid, levels of different bases, values beyond `f32` and indices
    /// beyond `i32`.
    fn of(fog: &Fog) -> Result<Levels, GpuError> {
        let layers = fog.layers();
        debug_assert!(layers.len() == fog.levels() + 1 && layers.len() <= MAX_LEVELS + 1);
        let mut levels = Vec::with_capacity(layers.len());
        let mut coef: Vec<f32> = Vec::new();
        let mut pieces = None;
        for layer in layers {
            let [term] = layer.terms() else {
                return Err(GpuError::Input(format!(
                    "a deconstructed level has one scaling basis, this one {}",
                    layer.terms().len()
                )));
            };
            let t = term.view();
            if t.stride != 1 {
                return Err(GpuError::Input(format!(
                    "a level's scaling functions are on its own grid (stride 1), not stride {}",
                    t.stride
                )));
            }
            // One basis for every level: the pieces, first cells and supports agree.
            let shape = (*t.pieces, t.first, t.support);
            match &pieces {
                None => pieces = Some(shape),
                Some(p) if *p == shape => {}
                Some(_) => {
                    return Err(GpuError::Input(
                        "every level must share one scaling basis".to_string(),
                    ));
                }
            }
            if let Some(c) = t.coef.iter().find(|c| c.abs() > f64::from(f32::MAX) / 16.0) {
                return Err(GpuError::Input(format!(
                    "coefficient {c:e} is beyond the GPU's 32-bit floats"
                )));
            }
            let coef_at = u32::try_from(coef.len()).map_err(|_| {
                GpuError::Input("more coefficients than 32-bit indices reach".to_string())
            })?;
            levels.push(Level {
                cells: [
                    to_i32(layer.cells[0], "cell")?,
                    to_i32(layer.cells[1], "cell")?,
                    to_i32(layer.cells[2], "cell")?,
                    to_i32(layer.cells[3], "cell")?,
                ],
                k0: [to_i32(t.k0[0], "index")?, to_i32(t.k0[1], "index")?],
                n: [
                    to_i32(t.n[0] as i64, "width")?,
                    to_i32(t.n[1] as i64, "height")?,
                ],
                scale: layer.scale as f32,
                floor: layer.floor as f32,
                coef_at,
                _pad: 0,
            });
            coef.extend(t.coef.iter().map(|&c| c as f32));
        }
        let (table, first, support) =
            pieces.ok_or_else(|| GpuError::Input("the fog has no levels".to_string()))?;
        let table: Vec<f32> = table
            .iter()
            .flat_map(|axis| axis.iter().flatten().map(|&c| c as f32))
            .collect();
        if coef.is_empty() {
            // wgpu binds no empty buffers.
            coef.push(0.0);
        }
        Ok(Levels {
            records: levels,
            coef,
            table,
            first,
            support,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_match_the_shader() {
        // WGSL: Params is 14 16-byte rows, Level 3, Query 2.
        assert_eq!(std::mem::size_of::<Params>(), 224);
        assert_eq!(std::mem::size_of::<Level>(), 48);
        assert_eq!(std::mem::size_of::<Query>(), 32);
        assert!(
            SHADER
                .entry
                .contains("@binding(5) var<storage, read> queries: array<Query>")
        );
        assert!(
            SHADER
                .entry
                .contains("@binding(6) var<storage, read> smoke: array<vec4<f32>>")
        );
    }

    /// The shader validates on the CPU (no device needed).
    #[test]
    fn the_shader_validates() {
        haze_gpu::wgsl::assert_variants_valid(&[SHADER], &[]);
    }
}
