//! The GPU path (wgpu compute): each stage is the twin of a CPU function, computes the
//! same quantity in `f32` and is tested against it. The shaders live in
//! `crates/view/shaders/`, each file named for its CPU twin (`single_scattering.wgsl` ↔
//! [`crate::lighting::single::single_scattering`], `view_pass.wgsl` ↔
//! [`crate::render::crm::view_pass`], `volume_pass.wgsl` ↔
//! [`crate::render::crm::volume_pass`], `lights_pass.wgsl` ↔
//! [`crate::render::lights_pass::lights_pass`], `diffusion.wgsl` ↔
//! [`crate::render::add_multiple_scattering`], `orders.wgsl` ↔
//! [`crate::grid_diffusion::explicit_media_radiance`] and
//! [`crate::grid_diffusion::add_to_grids`]; `sh_basis.wgsl` ↔ [`crate::sh::eval_into`]
//! is prepended to the shaders that need it, the shadow march `grid_march.wgsl` and the
//! phase functions `disk_phase.wgsl` to those that march or light). Single scattering leaves the sources at the
//! centers on the GPU in a [`SourceBuffer`], which the volume pass reads; the volume pass
//! leaves its grids in a [`GridBuffer`], to which the lights pass adds the suns and point
//! lights in place and which the view pass reads — no round trip through the host. [`renderer::GpuRenderer`] chains the stages into frames.
//!
//! Everything here builds on every platform; at run time a machine without a usable GPU
//! gets a [`GpuError`] from [`GpuContext::new`], never a panic. Headless Linux machines can
//! use Mesa's lavapipe, a Vulkan driver on the CPU.

pub mod diffusion;
pub mod env_pass;
pub mod lights_pass;
pub mod orders;
pub mod renderer;
pub mod single_scattering;
pub mod view_pass;
pub mod volume_pass;

use crate::lighting::single::{RgbSh, SingleScattering};
use crate::render::crm::VolumeGrids;
use haze_volume::{Bbox, Volume};
use std::fmt;
use std::future::Future;
use std::sync::{Arc, Mutex};

/// Why GPU work could not run.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter on any backend this build can use.
    #[error(
        "no GPU adapter found on {backends} (install Mesa's lavapipe: mesa-vulkan-drivers libvulkan1)"
    )]
    NoAdapter { backends: String },
    /// The adapter refused to open a device.
    #[error("the GPU adapter {adapter} refused a device: {reason}")]
    Device { adapter: String, reason: String },
    /// An input the GPU stage cannot take (the text says which and why).
    #[error("{0}")]
    Input(String),
    /// A buffer larger than the device allows.
    #[error("{what} needs {bytes} bytes of GPU buffer, more than the device's limit of {limit}")]
    TooLarge {
        what: &'static str,
        bytes: u64,
        limit: u64,
    },
    /// wgpu reported an error while the work ran (validation, out of memory, device lost).
    #[error("GPU error during {during}: {reason}")]
    Gpu {
        during: &'static str,
        reason: String,
    },
}

/// A headless GPU device: no window, no surface, compute and copies only.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    /// Errors wgpu reports outside any error scope (and device loss), kept for the next
    /// [`GpuContext::check`] instead of wgpu's default of panicking.
    uncaptured: Arc<Mutex<Option<String>>>,
    /// Timestamp queries for per-stage GPU times, where the adapter has them.
    timer: Option<StageTimer>,
}

/// Passes timed between two [`GpuContext::take_stage_times`].
const TIMED_PASSES: u32 = 16;

/// A query set of `2 × TIMED_PASSES` timestamps (start and end of each pass) and the
/// buffer they resolve into.
struct StageTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    /// Nanoseconds per timestamp tick.
    period: f64,
    /// The passes timed since the last take, in order; `None` while timing is off.
    labels: Mutex<Option<Vec<&'static str>>>,
}

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.info.name)
            .field("backend", &self.info.backend)
            .finish_non_exhaustive()
    }
}

/// Collapses an error's text (wgpu's are several lines long) into one line.
fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

impl GpuContext {
    /// The first adapter found, Vulkan preferred (then whatever else this build supports:
    /// Metal on Apple platforms, DX12 on Windows), with a device whose storage buffers may
    /// be as large as the adapter allows.
    pub fn new() -> Result<GpuContext, GpuError> {
        let available = wgpu::Instance::enabled_backend_features();
        for backends in [wgpu::Backends::VULKAN, available - wgpu::Backends::VULKAN] {
            match GpuContext::with_backends(backends & available) {
                Err(GpuError::NoAdapter { .. }) => continue,
                found => return found,
            }
        }
        Err(GpuError::NoAdapter {
            backends: backend_names(available),
        })
    }

    /// Like [`GpuContext::new`], on the given backends only (none gives
    /// [`GpuError::NoAdapter`]).
    pub fn with_backends(backends: wgpu::Backends) -> Result<GpuContext, GpuError> {
        let no_adapter = || GpuError::NoAdapter {
            backends: backend_names(backends),
        };
        // `Instance::new` panics when the build has no backend for this platform.
        if (backends & wgpu::Instance::enabled_backend_features()).is_empty() {
            return Err(no_adapter());
        }
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends,
            // wgpu's release defaults in every build: debug builds would otherwise turn on
            // the driver's debug messages, which land on stderr through the log (the
            // Vulkan loader's complaints before a "no adapter" error, for one).
            // WGPU_VALIDATION=1 and WGPU_DEBUG=1 turn them back on.
            flags: wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL.with_env(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|_| no_adapter())?;
        let info = adapter.get_info();
        let supported = adapter.limits();
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: supported.max_storage_buffer_binding_size,
            max_buffer_size: supported.max_buffer_size,
            // Single scattering binds six storage buffers (WebGPU's default allows 8;
            // every Vulkan, Metal and DX12 device has them).
            max_storage_buffers_per_shader_stage: 8,
            ..wgpu::Limits::downlevel_defaults()
        };
        // Timestamp queries time the stages where the adapter has them; nothing needs them.
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        let (device, queue) = block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("haze"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: format!("{} ({})", info.name, info.backend),
            reason: one_line(&e.to_string()),
        })?;
        let uncaptured = Arc::new(Mutex::new(None::<String>));
        let keep = |slot: &Arc<Mutex<Option<String>>>, text: String| {
            if let Ok(mut s) = slot.lock() {
                s.get_or_insert(one_line(&text));
            }
        };
        let slot = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| keep(&slot, e.to_string())));
        let slot = uncaptured.clone();
        device.set_device_lost_callback(move |reason, text| {
            // Dropping the device reports a loss too; only a real one is an error.
            if reason != wgpu::DeviceLostReason::Destroyed {
                keep(&slot, format!("device lost: {text}"));
            }
        });
        let timer = features
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| StageTimer {
                queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("stage times"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2 * TIMED_PASSES,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("stage times"),
                    size: u64::from(2 * TIMED_PASSES) * wgpu::QUERY_SIZE as u64,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                period: f64::from(queue.get_timestamp_period()),
                labels: Mutex::new(None),
            });
        Ok(GpuContext {
            device,
            queue,
            info,
            uncaptured,
            timer,
        })
    }

    /// The adapter's name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)` for lavapipe.
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// The backend in use.
    pub fn backend(&self) -> wgpu::Backend {
        self.info.backend
    }

    /// Everything wgpu says about the adapter.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// Runs `work` with wgpu's validation, out-of-memory and internal errors captured, and
    /// turns the first of them (or one reported outside any scope since the last check)
    /// into [`GpuError::Gpu`].
    pub fn scoped<T>(&self, during: &'static str, work: impl FnOnce() -> T) -> Result<T, GpuError> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = work();
        let errors = [
            block_on(validation.pop()),
            block_on(memory.pop()),
            block_on(internal.pop()),
        ];
        if let Some(e) = errors.into_iter().flatten().next() {
            return Err(GpuError::Gpu {
                during,
                reason: one_line(&e.to_string()),
            });
        }
        self.check(during)?;
        Ok(out)
    }

    /// The first error wgpu reported outside an error scope since the last check, if any.
    pub fn check(&self, during: &'static str) -> Result<(), GpuError> {
        let taken = self.uncaptured.lock().ok().and_then(|mut s| s.take());
        match taken {
            Some(reason) => Err(GpuError::Gpu { during, reason }),
            None => Ok(()),
        }
    }

    /// Refuses a buffer of `bytes` that the device cannot bind as storage.
    pub fn check_storage_size(&self, what: &'static str, bytes: u64) -> Result<(), GpuError> {
        let l = self.device.limits();
        let limit = l.max_storage_buffer_binding_size.min(l.max_buffer_size);
        if bytes > limit {
            return Err(GpuError::TooLarge { what, bytes, limit });
        }
        Ok(())
    }

    /// Whether the device can time its passes (timestamp queries).
    pub fn has_timestamps(&self) -> bool {
        self.timer.is_some()
    }

    /// Turns GPU timing of the passes on or off (off by default); returns whether the
    /// device can time them. While on, every pass submitted is timed (the first 16
    /// between two [`GpuContext::take_stage_times`]).
    pub fn time_stages(&self, on: bool) -> bool {
        let Some(t) = &self.timer else {
            return false;
        };
        if let Ok(mut labels) = t.labels.lock() {
            *labels = on.then(Vec::new);
        }
        true
    }

    /// Where a compute pass called `label` writes its start and end times: `None` unless
    /// timing is on and room is left.
    pub fn timestamp_writes(
        &self,
        label: &'static str,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let t = self.timer.as_ref()?;
        let mut labels = t.labels.lock().ok()?;
        let list = labels.as_mut()?;
        let i = u32::try_from(list.len())
            .ok()
            .filter(|&i| i < TIMED_PASSES)?;
        list.push(label);
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &t.queries,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    /// The GPU time of each pass timed since the last call, `(label, seconds)` in
    /// submission order (waits for the GPU); empty when timing is off or unsupported.
    pub fn take_stage_times(&self) -> Result<Vec<(&'static str, f64)>, GpuError> {
        let Some(t) = &self.timer else {
            return Ok(Vec::new());
        };
        let labels = match t.labels.lock() {
            Ok(mut l) => l.as_mut().map(std::mem::take).unwrap_or_default(),
            Err(_) => Vec::new(),
        };
        if labels.is_empty() {
            return Ok(Vec::new());
        }
        let n = labels.len() as u32;
        self.scoped("stage timing", || {
            let mut enc = self
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("stage times"),
                });
            enc.resolve_query_set(&t.queries, 0..2 * n, &t.resolve, 0);
            self.queue.submit([enc.finish()]);
        })?;
        let bytes = self.read_buffer(&t.resolve)?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(labels
            .into_iter()
            .enumerate()
            .map(|(i, l)| {
                let d = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                (l, d as f64 * t.period * 1e-9)
            })
            .collect())
    }

    /// Waits until the GPU has finished everything submitted so far (to time a stage).
    pub fn finish(&self, during: &'static str) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Gpu {
                during,
                reason: one_line(&e.to_string()),
            })?;
        self.check(during)
    }

    /// Copies a storage buffer (created with `COPY_SRC`) back to the host: through a
    /// mappable staging buffer, waiting for the queue.
    pub fn read_buffer(&self, source: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let size = source.size();
        let staging = self.scoped("readback", || {
            let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("haze readback"),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut enc = self
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("haze readback"),
                });
            enc.copy_buffer_to_buffer(source, 0, &staging, 0, size);
            self.queue.submit([enc.finish()]);
            staging
        })?;
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            // The receiver waits below; a send can only fail if it is gone.
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Gpu {
                during: "readback",
                reason: one_line(&e.to_string()),
            })?;
        rx.recv()
            .map_err(|_| "the map callback never ran".to_string())
            .and_then(|r| r.map_err(|e| one_line(&e.to_string())))
            .map_err(|reason| GpuError::Gpu {
                during: "readback",
                reason,
            })?;
        let bytes = {
            let view = staging.get_mapped_range(..).map_err(|e| GpuError::Gpu {
                during: "readback",
                reason: one_line(&e.to_string()),
            })?;
            view.to_vec()
        };
        staging.unmap();
        self.check("readback")?;
        Ok(bytes)
    }
}

/// The grids of a volume pass on the GPU: one `vec4<f32>` per voxel (x fastest), `J̃`
/// (RGB) in `xyz` and `D` in `w`, over a `dims` grid on `bbox` — what
/// [`volume_pass::VolumePass`] writes, [`lights_pass::LightsPass`] adds to and
/// [`view_pass::ViewPass`] reads. An empty grid
/// still has one (zero) voxel of buffer: wgpu binds no empty buffers.
#[derive(Debug)]
pub struct GridBuffer {
    buffer: wgpu::Buffer,
    dims: [usize; 3],
    bbox: Bbox,
}

impl GridBuffer {
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
        Ok(GridBuffer { buffer, dims, bbox })
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
        })
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

/// Compiles the WGSL `source` and builds its compute pipeline (entry point `main`, the
/// bind group layout taken from the shader), as the stage called `label`.
pub fn compute_pipeline(
    ctx: &GpuContext,
    label: &'static str,
    source: &str,
) -> Result<wgpu::ComputePipeline, GpuError> {
    compute_pipeline_at(ctx, label, source, "main")
}

/// [`compute_pipeline`] of the entry point `entry` (shaders with several).
pub fn compute_pipeline_at(
    ctx: &GpuContext,
    label: &'static str,
    source: &str,
    entry: &'static str,
) -> Result<wgpu::ComputePipeline, GpuError> {
    ctx.scoped(label, || {
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        ctx.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    })
}

/// A buffer holding `contents`. Call inside [`GpuContext::scoped`].
pub fn buffer_init(
    ctx: &GpuContext,
    label: &'static str,
    contents: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    ctx.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
}

/// A bind group of `layout` binding `buffers[i]`, whole, to binding `i`.
fn bind_buffers(
    ctx: &GpuContext,
    label: &'static str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
        .iter()
        .zip(0..)
        .map(|(b, binding)| wgpu::BindGroupEntry {
            binding,
            resource: b.as_entire_binding(),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// The workgroups of `side`³ invocations covering a grid of `dims` voxels, or why the
/// device cannot dispatch them (a side beyond its workgroups per dimension).
pub fn voxel_groups(ctx: &GpuContext, dims: [usize; 3], side: usize) -> Result<[u32; 3], GpuError> {
    let groups = dims.map(|n| n.div_ceil(side));
    let max_groups = ctx.device.limits().max_compute_workgroups_per_dimension as usize;
    if groups.iter().any(|&n| n > max_groups) {
        return Err(GpuError::Input(format!(
            "a grid of {dims:?} voxels is larger than the device dispatches ({} voxels a side at most)",
            max_groups * side
        )));
    }
    Ok(groups.map(|n| n as u32))
}

/// Binds `buffers` (binding `i` to `buffers[i]`) as group 0 of `pipeline` and submits one
/// compute pass of `groups` workgroups (none when a count is 0), timed as `label` while
/// [`GpuContext::time_stages`] is on. Call inside [`GpuContext::scoped`].
pub fn submit_pass(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    label: &'static str,
    buffers: &[&wgpu::Buffer],
    groups: [u32; 3],
) {
    let bind = bind_buffers(ctx, label, &pipeline.get_bind_group_layout(0), buffers);
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
    if groups.iter().all(|&n| n > 0) {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: ctx.timestamp_writes(label),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(groups[0], groups[1], groups[2]);
    }
    ctx.queue.submit([enc.finish()]);
}

/// `vulkan, metal` … for messages.
fn backend_names(backends: wgpu::Backends) -> String {
    let names: Vec<&str> = [
        (wgpu::Backends::VULKAN, "Vulkan"),
        (wgpu::Backends::METAL, "Metal"),
        (wgpu::Backends::DX12, "DX12"),
        (wgpu::Backends::GL, "OpenGL"),
        (wgpu::Backends::BROWSER_WEBGPU, "WebGPU"),
    ]
    .into_iter()
    .filter(|(b, _)| backends.contains(*b))
    .map(|(_, n)| n)
    .collect();
    if names.is_empty() {
        "no backend".to_string()
    } else {
        names.join(", ")
    }
}

/// Waits for a wgpu future (they complete during `Device::poll` or immediately on native
/// backends).
fn block_on<F: Future>(f: F) -> F::Output {
    pollster::block_on(f)
}

/// What a compute pass with one explicit bind group compiles before its pipelines.
struct ComputeLayout {
    layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    module: wgpu::ShaderModule,
}

/// The bind group layout of a compute pass — binding 0 a uniform buffer, binding `i ≥ 1`
/// a storage buffer, read-only where `read_only[i − 1]` — the pipeline layout over it and
/// the module of `source`, all labelled `label`.
fn compute_layout(
    d: &wgpu::Device,
    label: &'static str,
    source: &'static str,
    read_only: &[bool],
) -> ComputeLayout {
    let buffer = |binding: usize, ty| wgpu::BindGroupLayoutEntry {
        binding: binding as u32,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let entries: Vec<wgpu::BindGroupLayoutEntry> =
        std::iter::once(buffer(0, wgpu::BufferBindingType::Uniform))
            .chain(read_only.iter().enumerate().map(|(i, &read_only)| {
                buffer(i + 1, wgpu::BufferBindingType::Storage { read_only })
            }))
            .collect();
    let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    });
    let pipeline_layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    ComputeLayout {
        layout,
        pipeline_layout,
        module,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_backend_is_a_clear_error_not_a_panic() {
        let e = GpuContext::with_backends(wgpu::Backends::empty()).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with("no GPU adapter found on no backend")
                && text.contains("mesa-vulkan-drivers libvulkan1"),
            "{text}"
        );
        assert!(!text.contains('\n'));
    }

    #[test]
    fn errors_are_one_line() {
        assert_eq!(
            one_line("Validation Error\n\nCaused by:\n  x"),
            "Validation Error Caused by: x"
        );
        let e = GpuError::TooLarge {
            what: "the volume",
            bytes: 10,
            limit: 4,
        };
        assert_eq!(
            e.to_string(),
            "the volume needs 10 bytes of GPU buffer, more than the device's limit of 4"
        );
    }
}
