//! GPU plumbing shared by haze's renderers (the smoke renderer in `haze-view`, the scene
//! renderers in `haze-scene`, the wavelet fog, the analytic fogs): a headless wgpu device
//! whose errors come back as values ([`GpuContext`], [`GpuError`]), the calls every
//! compute pass makes (buffers, bind groups, pipelines, dispatches), and WGSL shaders
//! composed from modules with `#import` and `#ifdef`, validated on the CPU by naga
//! ([`wgsl`]).
//!
//! Everything here builds on every platform; at run time a machine without a usable GPU
//! gets a [`GpuError`] from [`GpuContext::new`], never a panic. Headless Linux machines can
//! use Mesa's lavapipe, a Vulkan driver on the CPU.

mod context;
mod pipeline;
pub mod wgsl;

pub use context::{GpuContext, GpuError};
pub use pipeline::{
    ComputeLayout, bind_buffers, buffer_init, compute_layout, compute_pipeline,
    compute_pipeline_at, compute_pipeline_with, line_groups, submit_pass, timed_pass, voxel_groups,
};
