//! Wavelet fog on the GPU (paper E §5): wgpu compute, the twin of the CPU renderer
//! ([`crate::render::shade`] over a [`Fog`](crate::Fog) in [`Mode::Deconstructed`](crate::Mode)),
//! computing the same image in `f32`.
//!
//! * [`GpuContext`]: a headless device, found and opened as `haze-view`'s GPU path does
//!   (Vulkan first, then whatever else the build has), with wgpu's errors turned into
//!   [`GpuError`] values instead of panics.
//! * [`fog`]: the levels of a fog uploaded to storage buffers ([`fog::GpuFog`]) and the
//!   two passes of `shaders/wavelet_fog.wgsl` — one image of the scene through the fog,
//!   or the optical depths of given rays.
//!
//! Everything here builds on every platform; at run time a machine without a usable GPU
//! gets a [`GpuError`] from [`GpuContext::new`], never a panic. Headless Linux machines can
//! use Mesa's lavapipe, a Vulkan driver on the CPU.

pub mod fog;

use std::fmt;
use std::sync::{Arc, Mutex};

/// Why GPU work could not run.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter on any backend this build can use.
    #[error(
        "no GPU adapter found on {backends} (install Mesa's lavapipe: mesa-vulkan-drivers libvulkan1)"
    )]
    NoAdapter {
        /// The backends tried.
        backends: String,
    },
    /// The adapter refused to open a device.
    #[error("the GPU adapter {adapter} refused a device: {reason}")]
    Device {
        /// Adapter name and backend.
        adapter: String,
        /// wgpu's reason, on one line.
        reason: String,
    },
    /// An input the GPU cannot take (the text says which and why).
    #[error("{0}")]
    Input(String),
    /// A buffer larger than the device allows.
    #[error("{what} needs {bytes} bytes of GPU buffer, more than the device's limit of {limit}")]
    TooLarge {
        /// The buffer.
        what: &'static str,
        /// Its size.
        bytes: u64,
        /// The device's limit.
        limit: u64,
    },
    /// wgpu reported an error while the work ran (validation, out of memory, device lost).
    #[error("GPU error during {during}: {reason}")]
    Gpu {
        /// The step.
        during: &'static str,
        /// wgpu's reason, on one line.
        reason: String,
    },
}

/// A headless GPU device: no window, no surface, compute and copies only.
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    /// Errors wgpu reports outside any error scope (and device loss), kept for the next
    /// [`GpuContext::check`] instead of wgpu's default of panicking.
    uncaptured: Arc<Mutex<Option<String>>>,
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
            // wgpu's release defaults in every build (debug builds would otherwise send the
            // driver's debug messages to stderr); WGPU_VALIDATION=1 and WGPU_DEBUG=1 turn
            // them back on.
            flags: wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL.with_env(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
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
            // The ray pass binds five storage buffers (WebGPU's default allows 8; every
            // Vulkan, Metal and DX12 device has them).
            max_storage_buffers_per_shader_stage: 8,
            ..wgpu::Limits::downlevel_defaults()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("haze wavelet fog"),
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
        Ok(GpuContext {
            device,
            queue,
            info,
            uncaptured,
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

    /// Runs `work` with wgpu's validation, out-of-memory and internal errors captured, and
    /// turns the first of them (or one reported outside any scope since the last check)
    /// into [`GpuError::Gpu`].
    pub fn scoped<T>(&self, during: &'static str, work: impl FnOnce() -> T) -> Result<T, GpuError> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = work();
        let errors = [
            pollster::block_on(validation.pop()),
            pollster::block_on(memory.pop()),
            pollster::block_on(internal.pop()),
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

    /// Waits until the GPU has finished everything submitted so far (to time a frame).
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
        self.finish("readback")?;
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

    /// A buffer holding `contents`. Call inside [`GpuContext::scoped`].
    fn buffer_init(
        &self,
        label: &'static str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    }
}

/// `Vulkan, Metal` … for messages.
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
    }
}
