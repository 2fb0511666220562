//! Buffers, bind groups and compute pipelines on a [`GpuContext`]: the few calls every
//! pass of every renderer makes, each inside [`GpuContext::scoped`] so that wgpu's errors
//! come back as [`GpuError`]s.

use crate::context::{GpuContext, GpuError};

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
    compute_pipeline_with(ctx, label, source, entry, &[])
}

/// [`compute_pipeline_at`] with the shader's pipeline-overridable constants (`override`
/// declarations) set by name: `constants` holds `(name, value)` pairs, the value in `f64`
/// as WebGPU passes every scalar type (exact for `u32`, `i32` and `f32` values).
pub fn compute_pipeline_with(
    ctx: &GpuContext,
    label: &'static str,
    source: &str,
    entry: &'static str,
    constants: &[(&str, f64)],
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
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
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
pub fn bind_buffers(
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

/// The workgroups of `per_group` invocations covering `n` items numbered along one line,
/// spread over two dimensions (`[x, y, 1]`, `x·y·per_group ≥ n`, `x` at most the device's
/// workgroups per dimension); `[0, 0, 0]` for no item; or why the device cannot dispatch
/// them (`what` names the items in the message).
pub fn line_groups(
    ctx: &GpuContext,
    n: usize,
    per_group: usize,
    what: &str,
) -> Result<[u32; 3], GpuError> {
    if n == 0 {
        return Ok([0, 0, 0]);
    }
    let groups = n.div_ceil(per_group.max(1));
    let max_groups = ctx.device.limits().max_compute_workgroups_per_dimension as usize;
    let gx = groups.clamp(1, max_groups);
    let gy = groups.div_ceil(gx);
    if gy > max_groups {
        return Err(GpuError::Input(format!(
            "{n} {what} are more than the device dispatches"
        )));
    }
    Ok([gx as u32, gy as u32, 1])
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

/// One compute pass timed as `label`, recorded by `record`, submitted. Call inside
/// [`GpuContext::scoped`].
pub fn timed_pass(
    ctx: &GpuContext,
    label: &'static str,
    record: impl FnOnce(&mut wgpu::ComputePass<'_>),
) {
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: ctx.timestamp_writes(label),
        });
        record(&mut pass);
    }
    ctx.queue.submit([enc.finish()]);
}

/// What a compute pass with one explicit bind group compiles before its pipelines.
#[derive(Debug)]
pub struct ComputeLayout {
    pub layout: wgpu::BindGroupLayout,
    pub pipeline_layout: wgpu::PipelineLayout,
    pub module: wgpu::ShaderModule,
}

/// The bind group layout of a compute pass — binding 0 the parameters, a read-only
/// storage buffer (not a uniform one: lavapipe compiles a new variant of a shader for
/// every uniform value that steers a branch or a loop), binding `i ≥ 1` a storage buffer,
/// read-only where `read_only[i − 1]` — the pipeline layout over it and the module of
/// `source`, all labelled `label`.
pub fn compute_layout(
    d: &wgpu::Device,
    label: &'static str,
    source: &str,
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
    let entries: Vec<wgpu::BindGroupLayoutEntry> = std::iter::once(buffer(
        0,
        wgpu::BufferBindingType::Storage { read_only: true },
    ))
    .chain(
        read_only
            .iter()
            .enumerate()
            .map(|(i, &read_only)| buffer(i + 1, wgpu::BufferBindingType::Storage { read_only })),
    )
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
