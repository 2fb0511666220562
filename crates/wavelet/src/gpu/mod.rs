//! Wavelet fog on the GPU (paper E §5): wgpu compute, the twin of the CPU renderer
//! ([`crate::render::shade`] over a [`Fog`](crate::Fog) in [`Mode::Deconstructed`](crate::Mode)),
//! computing the same image in `f32`.
//!
//! The device is `haze-gpu`'s [`haze_gpu::GpuContext`] (Vulkan first, then whatever
//! else the build has), with wgpu's errors turned into values instead of panics — the one
//! device setup of every GPU renderer in haze.
//!
//! * [`fog`]: the levels of a fog uploaded to storage buffers ([`fog::GpuFog`]) and the
//!   two passes of `shaders/wavelet_fog.wgsl` — one image of the scene through the fog
//!   (with a smoke layer composited by depth, or without), or the optical depths of given
//!   rays.
//!
//! Everything here builds on every platform; at run time a machine without a usable GPU
//! gets a [`haze_gpu::GpuError`] from [`haze_gpu::GpuContext::new`], never a panic.

pub mod fog;
