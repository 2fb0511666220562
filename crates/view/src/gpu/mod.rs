//! The GPU path (wgpu compute): each stage is the twin of a CPU function, computes the
//! same quantity in `f32` and is tested against it. The shaders live in
//! `crates/view/shaders/`, each file named for its CPU twin (`single_scattering.wgsl` ↔
//! [`crate::lighting::single::single_scattering`], `view_pass.wgsl` ↔
//! [`crate::render::crm::view_pass`], `volume_pass.wgsl` ↔
//! [`crate::render::crm::volume_pass`], `lights_pass.wgsl` ↔
//! [`crate::render::lights_pass::lights_pass`], `diffusion.wgsl` ↔
//! [`crate::render::add_multiple_scattering`], `orders.wgsl` ↔
//! [`crate::render::grid_diffusion::explicit_media_radiance`] and
//! [`crate::render::grid_diffusion::add_to_grids`]; the modules `sh_basis.wgsl` ↔
//! [`crate::sh::eval_into`], the shadow march `grid_march.wgsl` and the phase functions
//! `disk_phase.wgsl` are imported by the shaders that need them ([`shaders`]). Single scattering leaves the sources at the
//! centers on the GPU in a [`SourceBuffer`], which the volume pass reads; the volume pass
//! leaves its grids in a [`GridBuffer`], to which the lights pass adds the suns and point
//! lights in place and which the view pass reads — no round trip through the host. [`renderer::GpuRenderer`] chains the stages into frames.
//!
//! The device, buffers and pipelines come from `haze-gpu`; a machine without a usable GPU
//! gets a [`GpuError`] from [`GpuContext::new`], never a panic.

pub mod diffusion;
pub mod env_pass;
pub mod env_sweep;
pub mod host_grids;
pub mod lights_pass;
pub mod occupancy;
pub mod orders;
pub mod renderer;
pub mod shaders;
pub mod single_scattering;
pub mod tone_pass;
pub mod view_pass;
pub mod volume_pass;

use crate::lighting::single::{RgbSh, SingleScattering};
use crate::render::crm::VolumeGrids;
use haze_gpu::{GpuContext, GpuError, buffer_init};
use haze_volume::{Bbox, Volume};

/// The grids of a volume pass on the GPU: one `vec4<f32>` per voxel (x fastest), `J̃`
/// (RGB) in `xyz` and `D` in `w`, over a `dims` grid on `bbox` — what
/// [`volume_pass::VolumePass`] writes, [`lights_pass::LightsPass`] adds to and
/// [`view_pass::ViewPass`] reads. An empty grid
/// still has one (zero) voxel of buffer: wgpu binds no empty buffers. `eye_peak` is
/// [`VolumeGrids::eye_peak`]: [`orders::OrdersPass::apply`] sets it with the light it adds.
#[derive(Debug)]
pub struct GridBuffer {
    buffer: wgpu::Buffer,
    dims: [usize; 3],
    bbox: Bbox,
    eye_peak: std::cell::Cell<f64>,
}

impl GridBuffer {
    /// The most voxels a grid may have on `ctx`'s device (16 bytes each).
    pub fn max_voxels(ctx: &GpuContext) -> usize {
        usize::try_from(ctx.storage_limit() / 16).unwrap_or(usize::MAX)
    }

    /// Bytes of buffer for a `dims` grid.
    fn bytes(dims: [usize; 3]) -> u64 {
        (dims.iter().product::<usize>().max(1) * 16) as u64
    }

    /// An uninitialized grid buffer that a shader will write.
    fn create(ctx: &GpuContext, dims: [usize; 3], bbox: Bbox) -> Result<GridBuffer, GpuError> {
        let bytes = GridBuffer::bytes(dims);
        ctx.check_storage_size("the volume (density and radiance)", bytes)?;
        let buffer = ctx.scoped("grid buffer creation", || {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("volume grids"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        })?;
        Ok(GridBuffer {
            buffer,
            dims,
            bbox,
            eye_peak: std::cell::Cell::new(0.0),
        })
    }

    /// Uploads CPU grids. Refuses grids whose radiance does not match the density's voxels
    /// and buffers beyond the device's limits.
    pub fn upload(ctx: &GpuContext, g: &VolumeGrids) -> Result<GridBuffer, GpuError> {
        let dims = g.density.dims();
        let voxels = dims.iter().product::<usize>();
        if g.radiance.len() != voxels {
            return Err(GpuError::Input(format!(
                "the radiance grid has {} voxels, the density grid {voxels}",
                g.radiance.len()
            )));
        }
        let mut cells: Vec<[f32; 4]> = g
            .radiance
            .iter()
            .zip(g.density.data())
            .map(|(j, d)| [j[0], j[1], j[2], *d])
            .collect();
        if cells.is_empty() {
            cells.push([0.0; 4]);
        }
        ctx.check_storage_size("the volume (density and radiance)", GridBuffer::bytes(dims))?;
        let buffer = ctx.scoped("grid upload", || {
            buffer_init(
                ctx,
                "volume grids",
                bytemuck::cast_slice(&cells),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            )
        })?;
        Ok(GridBuffer {
            buffer,
            dims,
            bbox: *g.density.bbox(),
            eye_peak: std::cell::Cell::new(g.eye_peak),
        })
    }

    /// Reads the grids back to the host.
    pub fn read(&self, ctx: &GpuContext) -> Result<VolumeGrids, GpuError> {
        let bytes = ctx.read_buffer(&self.buffer)?;
        // Copied rather than cast: the bytes come without `f32` alignment.
        let mut cells: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
        cells.truncate(self.dims.iter().product());
        let density = cells.iter().map(|c| c[3]).collect();
        let radiance = cells.iter().map(|c| [c[0], c[1], c[2]]).collect();
        Ok(VolumeGrids {
            density: Volume::new(self.dims, self.bbox, density)
                .map_err(|e| GpuError::Input(format!("grid of {:?} voxels: {e}", self.dims)))?,
            radiance,
            eye_peak: self.eye_peak.get(),
        })
    }

    /// [`VolumeGrids::eye_peak`] of the light in the grid.
    pub fn eye_peak(&self) -> f64 {
        self.eye_peak.get()
    }

    /// Voxels per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The box the grid covers.
    pub fn bbox(&self) -> &Bbox {
        &self.bbox
    }

    /// Voxel edge lengths (0 on an axis without voxels), as `Volume::voxel_size`.
    pub fn voxel_size(&self) -> [f64; 3] {
        let s = self.bbox.size();
        [0, 1, 2].map(|a| {
            if self.dims[a] == 0 {
                0.0
            } else {
                s[a] / self.dims[a] as f64
            }
        })
    }

    /// The storage buffer.
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}

/// The source radiance at the RBF centers on the GPU: per RBF `order²` `vec4<f32>`, the
/// RGB SH coefficients of `J̃(c_ℓ)` (a function of the viewing direction) in `xyz`; the `w`
/// of coefficient 0 is the center's escape probability where single scattering on the GPU
/// wrote it (0 in an upload). What [`single_scattering::SingleScatteringPass`] writes and
/// [`volume_pass::VolumePass`] reads. An empty set still has one (zero) coefficient.
#[derive(Debug)]
pub struct SourceBuffer {
    buffer: wgpu::Buffer,
    count: usize,
    order: usize,
}

impl SourceBuffer {
    fn bytes(count: usize, order: usize) -> u64 {
        ((count * order * order).max(1) * 16) as u64
    }

    /// An uninitialized source buffer that a shader will write.
    fn create(ctx: &GpuContext, count: usize, order: usize) -> Result<SourceBuffer, GpuError> {
        let bytes = SourceBuffer::bytes(count, order);
        ctx.check_storage_size("the source radiance at the centers", bytes)?;
        let buffer = ctx.scoped("source buffer creation", || {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("sources at the centers"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        })?;
        Ok(SourceBuffer {
            buffer,
            count,
            order,
        })
    }

    /// Uploads CPU sources (RGB SH of `order` per center; fewer coefficients are
    /// zero-padded). Refuses an order outside 1..=6, a source with more than `order²`
    /// coefficients per channel and buffers beyond the device's limits.
    pub fn upload(
        ctx: &GpuContext,
        source: &[RgbSh],
        order: usize,
    ) -> Result<SourceBuffer, GpuError> {
        if !(1..=crate::sh::MAX_ORDER).contains(&order) {
            return Err(GpuError::Input(format!(
                "SH order {order} is outside 1..={}",
                crate::sh::MAX_ORDER
            )));
        }
        let n2 = order * order;
        if let Some(l) = source.iter().position(|j| j.iter().any(|c| c.len() > n2)) {
            return Err(GpuError::Input(format!(
                "the source of RBF {l} has more than {n2} SH coefficients (order {order})"
            )));
        }
        let mut coeffs: Vec<[f32; 4]> = vec![[0.0; 4]; (n2 * source.len()).max(1)];
        for (l, j) in source.iter().enumerate() {
            for (ch, jc) in j.iter().enumerate() {
                for (k, v) in jc.iter().enumerate() {
                    coeffs[l * n2 + k][ch] = *v as f32;
                }
            }
        }
        ctx.check_storage_size(
            "the source radiance at the centers",
            SourceBuffer::bytes(source.len(), order),
        )?;
        let buffer = ctx.scoped("source upload", || {
            buffer_init(
                ctx,
                "sources at the centers",
                bytemuck::cast_slice(&coeffs),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            )
        })?;
        Ok(SourceBuffer {
            buffer,
            count: source.len(),
            order,
        })
    }

    /// Reads the sources back: `J̃(c_ℓ)` in `f64` and the escape probabilities.
    pub fn read(&self, ctx: &GpuContext) -> Result<SingleScattering, GpuError> {
        let bytes = ctx.read_buffer(&self.buffer)?;
        let coeffs: Vec<[f32; 4]> = bytemuck::pod_collect_to_vec(&bytes);
        let n2 = self.order * self.order;
        let mut out = SingleScattering::default();
        for l in 0..self.count {
            let c = &coeffs[l * n2..(l + 1) * n2];
            out.source
                .push([0, 1, 2].map(|ch| c.iter().map(|v| f64::from(v[ch])).collect()));
            out.escape.push(f64::from(c[0][3]));
        }
        Ok(out)
    }

    /// Centers.
    pub fn count(&self) -> usize {
        self.count
    }

    /// SH order of the coefficients.
    pub fn order(&self) -> usize {
        self.order
    }

    /// The storage buffer.
    pub fn buffer(&self) -> &wgpu::Buffer {
        &self.buffer
    }
}
