//! The scene renderer with rasterized surfaces (`shaders/raster.wgsl`, a wgpu render
//! pass then a compute pass): the pictures of [`crate::gpu::GpuRenderer::render`] with
//! each pixel's primary hit found by the rasterizer and a depth buffer instead of a ray
//! traced through every surface and the meshes' hierarchies.
//!
//! **Raster pass.** Every surface becomes triangles ([`vertices`]): a mesh its own, a
//! sphere its bounding cube, a plane one triangle covering the screen. Each fragment
//! intersects the pixel's ray with its primitive (a mesh triangle's plane; the sphere or
//! the plane exactly as the ray tracer does), discards a miss and writes the exact depth
//! (reversed, `RASTER_NEAR / z` for the depth `z` along the view axis, so `f32` keeps its
//! relative precision at every distance), and the depth test (`>`, surfaces drawn in
//! file order) keeps the nearest — a tie to the first, as the ray tracer. The G-buffer
//! (`Rgba32Uint`) holds per pixel the hit's distance `t`, its surface and triangle.
//!
//! **Shading pass.** `render.wgsl` itself, composed with its primary `intersect` replaced
//! by the read of the G-buffer (a mesh's barycentrics recomputed on the triangle found there): the
//! airlight to that depth, the surfaces' shading, the environment's glow, and the shadow
//! rays towards the lights, which stay ray-traced through the hierarchies.
//!
//! **What differs from the ray tracer.** Inside a surface's image nothing but the rounding
//! of the same `f32` operations run in another stage. At a silhouette or a shared mesh
//! edge the rasterizer's coverage rule (the pixel center inside the projected triangle,
//! ties by the top-left rule) and the ray's edge tests are the same test rounded
//! differently, so a pixel whose center lies within rounding of an edge may take the
//! neighbouring primitive; surfaces nearer than `RASTER_NEAR` (10⁻⁴ scene units) along the
//! view axis are clipped. Scenes with voxel media take the ray-traced march
//! ([`crate::gpu::march`]) unchanged.

use super::shaders;
use crate::mesh::Mesh;
use crate::scene::{Scene, Shape};
use haze_gpu::{GpuContext, GpuError, buffer_init};

/// The G-buffer's format: (bits of `t`, surface + 1 or 0, triangle, 0).
const GBUFFER: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;

/// One vertex of the raster pass: `p` relative to the eye with `w = 1`, or in normalized
/// device coordinates with `w = 0` (a plane's screen triangle); `id` (surface, triangle).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    pub p: [f32; 4],
    pub id: [u32; 2],
}

/// The triangles of the scene's surfaces, positions relative to `eye`, in surface order.
/// A sphere's cube is 10⁻³ wider than the sphere, so that rounding never leaves a pixel of
/// the sphere outside it.
pub fn vertices(scene: &Scene, eye: [f64; 3]) -> Result<Vec<Vertex>, GpuError> {
    let rel = |p: [f64; 3]| [0, 1, 2].map(|a| (p[a] - eye[a]) as f32);
    let mut out = Vec::new();
    for (i, s) in scene.surfaces.iter().enumerate() {
        let surface =
            u32::try_from(i).map_err(|_| GpuError::Input(format!("{i} surfaces are too many")))?;
        match &s.shape {
            Shape::Plane { .. } => {
                for [x, y] in [[-1.0, -1.0], [3.0, -1.0], [-1.0, 3.0]] {
                    out.push(Vertex {
                        p: [x, y, 0.0, 0.0],
                        id: [surface, 0],
                    });
                }
            }
            &Shape::Sphere { center, radius } => {
                let r = radius * (1.0 + 1e-3);
                let corner = |k: usize| {
                    let c = rel(center);
                    let sign = |b: usize| if k >> b & 1 == 1 { r } else { -r } as f32;
                    [c[0] + sign(0), c[1] + sign(1), c[2] + sign(2), 1.0]
                };
                // Two triangles per face of the cube, corners numbered by their bits.
                const FACES: [[usize; 4]; 6] = [
                    [0, 1, 3, 2],
                    [4, 5, 7, 6],
                    [0, 1, 5, 4],
                    [2, 3, 7, 6],
                    [0, 2, 6, 4],
                    [1, 3, 7, 5],
                ];
                for f in FACES {
                    for k in [f[0], f[1], f[2], f[0], f[2], f[3]] {
                        out.push(Vertex {
                            p: corner(k),
                            id: [surface, 0],
                        });
                    }
                }
            }
            Shape::Mesh(mesh) => mesh_vertices(mesh, surface, &rel, &mut out)?,
        }
    }
    Ok(out)
}

fn mesh_vertices(
    mesh: &Mesh,
    surface: u32,
    rel: &impl Fn([f64; 3]) -> [f32; 3],
    out: &mut Vec<Vertex>,
) -> Result<(), GpuError> {
    for (t, tri) in mesh.triangles.iter().enumerate() {
        let t = u32::try_from(t)
            .map_err(|_| GpuError::Input(format!("a mesh of {t} triangles is too large")))?;
        for p in tri.p {
            let [x, y, z] = rel(p);
            out.push(Vertex {
                p: [x, y, z, 1.0],
                id: [surface, t],
            });
        }
    }
    Ok(())
}

/// The two pipelines: the raster pass writing the G-buffer, the shading pass reading it.
#[derive(Debug)]
pub struct RasterPipelines {
    raster: wgpu::RenderPipeline,
    shade: wgpu::ComputePipeline,
}

impl RasterPipelines {
    /// Compiles both from [`shaders::RASTER`]: `render.wgsl` with its primary hit read
    /// from the G-buffer and its parameters from a storage buffer (Mesa's lavapipe inlines
    /// the values of uniforms that steer branches into a new shader variant, compiled for
    /// seconds per new set of values, and did so for the camera of the raster pass — every
    /// orbiting picture; it never inlines storage buffers), then `raster.wgsl`.
    pub fn new(ctx: &GpuContext) -> Result<RasterPipelines, GpuError> {
        let source = shaders::source(&shaders::RASTER)?;
        ctx.scoped("rasterized scene pipelines creation", || {
            let module = ctx
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some("rasterized scene shader"),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
            let attributes = wgpu::vertex_attr_array![0 => Float32x4, 1 => Uint32x2];
            let raster = ctx
                .device
                .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some("scene raster pass"),
                    layout: None,
                    vertex: wgpu::VertexState {
                        module: &module,
                        entry_point: Some("vs_main"),
                        compilation_options: Default::default(),
                        buffers: &[Some(wgpu::VertexBufferLayout {
                            array_stride: std::mem::size_of::<Vertex>() as u64,
                            step_mode: wgpu::VertexStepMode::Vertex,
                            attributes: &attributes,
                        })],
                    },
                    primitive: wgpu::PrimitiveState::default(),
                    depth_stencil: Some(wgpu::DepthStencilState {
                        format: wgpu::TextureFormat::Depth32Float,
                        depth_write_enabled: Some(true),
                        depth_compare: Some(wgpu::CompareFunction::Greater),
                        stencil: wgpu::StencilState::default(),
                        bias: wgpu::DepthBiasState::default(),
                    }),
                    multisample: wgpu::MultisampleState::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &module,
                        entry_point: Some("fs_main"),
                        compilation_options: Default::default(),
                        targets: &[Some(wgpu::ColorTargetState {
                            format: GBUFFER,
                            blend: None,
                            write_mask: wgpu::ColorWrites::ALL,
                        })],
                    }),
                    multiview_mask: None,
                    cache: None,
                });
            let shade = ctx
                .device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("scene shading pass"),
                    layout: None,
                    module: &module,
                    entry_point: Some("main"),
                    compilation_options: Default::default(),
                    cache: None,
                });
            RasterPipelines { raster, shade }
        })
    }

    /// Draws `vertices` into a new `width × height` G-buffer. `params`, `surfaces` and
    /// `meshes` are the shading pass's bindings 0, 2 and 5. Call inside
    /// [`GpuContext::scoped`].
    pub fn gbuffer(
        &self,
        ctx: &GpuContext,
        [params, surfaces, meshes]: [&wgpu::Buffer; 3],
        vertices: &[Vertex],
        (width, height): (u32, u32),
    ) -> wgpu::Texture {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, usage| {
            ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let gbuffer = texture(
            "scene G-buffer",
            GBUFFER,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture(
            "scene depth",
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        let layout = self.raster.get_bind_group_layout(0);
        let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene raster pass"),
            layout: &layout,
            entries: &[(0, params), (2, surfaces), (5, meshes)].map(|(binding, b)| {
                wgpu::BindGroupEntry {
                    binding,
                    resource: b.as_entire_binding(),
                }
            }),
        });
        // wgpu binds no empty buffers: a scene without surfaces draws nothing.
        let vbuf = buffer_init(
            ctx,
            "scene raster vertices",
            bytemuck::cast_slice(if vertices.is_empty() {
                &[Vertex {
                    p: [0.0; 4],
                    id: [0; 2],
                }]
            } else {
                vertices
            }),
            wgpu::BufferUsages::VERTEX,
        );
        let gview = gbuffer.create_view(&Default::default());
        let dview = depth.create_view(&Default::default());
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("scene raster pass"),
            });
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene raster pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &gview,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &dview,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.raster);
            pass.set_bind_group(0, &bind, &[]);
            pass.set_vertex_buffer(0, vbuf.slice(..));
            pass.draw(0..vertices.len() as u32, 0..1);
        }
        ctx.queue.submit([enc.finish()]);
        gbuffer
    }

    /// The shading pass over `groups` of 8 × 8 pixels: `render.wgsl`'s buffers (bindings
    /// 0–6) and the G-buffer (binding 7). Call inside [`GpuContext::scoped`].
    pub fn shade(
        &self,
        ctx: &GpuContext,
        buffers: &[&wgpu::Buffer],
        gbuffer: &wgpu::Texture,
        groups: [u32; 3],
    ) {
        let view = gbuffer.create_view(&Default::default());
        let mut entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .zip(0..)
            .map(|(b, binding)| wgpu::BindGroupEntry {
                binding,
                resource: b.as_entire_binding(),
            })
            .collect();
        entries.push(wgpu::BindGroupEntry {
            binding: 7,
            resource: wgpu::BindingResource::TextureView(&view),
        });
        let bind = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("scene shading pass"),
            layout: &self.shade.get_bind_group_layout(0),
            entries: &entries,
        });
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("scene shading pass"),
            });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("scene shading pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.shade);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
        }
        ctx.queue.submit([enc.finish()]);
    }

    /// The surface seen at each pixel (row by row, `None` where none is) in `gbuffer`.
    pub fn read_surfaces(
        &self,
        ctx: &GpuContext,
        gbuffer: &wgpu::Texture,
    ) -> Result<Vec<Option<usize>>, GpuError> {
        let (w, h) = (gbuffer.width(), gbuffer.height());
        let row = (16 * w).div_ceil(256) * 256;
        let buffer = ctx.scoped("scene G-buffer read back", || {
            let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("scene G-buffer read back"),
                size: u64::from(row) * u64::from(h),
                usage: wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            enc.copy_texture_to_buffer(
                gbuffer.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row),
                        rows_per_image: Some(h),
                    },
                },
                gbuffer.size(),
            );
            ctx.queue.submit([enc.finish()]);
            buffer
        })?;
        let bytes = ctx.read_buffer(&buffer)?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        let per_row = row as usize / 4;
        Ok((0..h as usize)
            .flat_map(|y| (0..w as usize).map(move |x| (x, y)))
            .map(|(x, y)| match words[y * per_row + 4 * x + 1] {
                0 => None,
                s => Some(s as usize - 1),
            })
            .collect())
    }
}
