//! A headless GPU device ([`GpuContext`]): no window, no surface, compute and copies
//! only; wgpu's errors captured per piece of work and returned as [`GpuError`], one line
//! each, never a panic; per-pass GPU times from timestamp queries where the adapter has
//! them.

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
    /// A shader could not be composed from its modules (a mistake in the shader files,
    /// which each renderer's validation test finds first).
    #[error("shader {label}: {reason}")]
    Shader { label: &'static str, reason: String },
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
const TIMED_PASSES: u32 = 64;

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
    /// be as large as the adapter allows. wgpu's `WGPU_BACKEND` (e.g. `vulkan`, `dx12`)
    /// narrows the search to the backends it names; one this build lacks finds no adapter.
    pub fn new() -> Result<GpuContext, GpuError> {
        if let Some(asked) = wgpu::Backends::from_env() {
            return GpuContext::with_backends(asked);
        }
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

    /// Whether the adapter is a CPU (a software rasterizer such as Mesa's lavapipe).
    pub fn is_cpu_adapter(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
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

    /// The largest storage buffer a pass may bind, in bytes.
    pub fn storage_limit(&self) -> u64 {
        let l = self.device.limits();
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    }

    /// Refuses a buffer of `bytes` that the device cannot bind as storage.
    pub fn check_storage_size(&self, what: &'static str, bytes: u64) -> Result<(), GpuError> {
        let limit = self.storage_limit();
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
    /// device can time them. While on, every pass submitted is timed (the first 64
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
        self.read_range(source, 0, source.size())
    }

    /// [`GpuContext::read_buffer`] of `size` bytes from byte `offset` (both multiples of
    /// 4, within the buffer).
    pub fn read_range(
        &self,
        source: &wgpu::Buffer,
        offset: u64,
        size: u64,
    ) -> Result<Vec<u8>, GpuError> {
        self.read_with(source, offset, size, <[u8]>::to_vec)
    }

    /// `read` of the `size` bytes from byte `offset` of `source` (both multiples of 4,
    /// within the buffer; `source` created with `COPY_SRC`) while they are mapped: what a
    /// reader turns into its own values reads them in place, with no copy of the bytes
    /// first (a 1920 × 1080 picture of `f32` RGBA is 33 MB). Waits for the queue.
    pub fn read_with<T>(
        &self,
        source: &wgpu::Buffer,
        offset: u64,
        size: u64,
        read: impl FnOnce(&[u8]) -> T,
    ) -> Result<T, GpuError> {
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
            enc.copy_buffer_to_buffer(source, offset, &staging, 0, size);
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
        let out = {
            let view = staging.get_mapped_range(..).map_err(|e| GpuError::Gpu {
                during: "readback",
                reason: one_line(&e.to_string()),
            })?;
            read(&view)
        };
        staging.unmap();
        self.check("readback")?;
        Ok(out)
    }
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
pub(crate) fn block_on<F: Future>(f: F) -> F::Output {
    pollster::block_on(f)
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
