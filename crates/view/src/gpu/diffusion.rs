//! Multiple scattering on the GPU (`shaders/diffusion.wgsl`), the twin of
//! [`crate::render::add_multiple_scattering`]: the diffusion system of
//! [`Operators::system`], solved by the CGLS of [`crate::diffusion::cgls`], turned into the
//! source of [`Operators::ms_source_sh`] and added to the sources at the centers, in `f32`
//! and without leaving the GPU.
//!
//! The frame's [`Operators`] (geometry only, computed on the CPU once per frame) are
//! uploaded once; the medium and the sources enter as scalars and as the
//! [`SourceBuffer`] that single scattering left, so a new light or medium costs one
//! compute pass. The direct light of suns and point lights at the centers — moments `J⁰`,
//! `J¹` that [`crate::lighting::direct::add_light_moments`] computes on the host in closed
//! form — is uploaded as a [`DirectBuffer`] and added to the moments formed from the
//! sources ([`DiffusionPass::run_with`]), as the CPU adds it to its `Sources`. One workgroup per colour channel forms the system and its scalings
//! (`setup`), runs CGLS in chunks of at least 16 iterations per dispatch (`iterate`: every
//! dispatch carries on from the state the previous one left in the work buffer, and those
//! after convergence return at once; at most 64 of them), then forms `J̃ms` (`finish`); a
//! last dispatch adds it to the sources (`add`). All in one compute pass: no host round
//! trip, no dispatch per iteration, and no dispatch long enough for a watchdog to abandon
//! (lavapipe gave up on a single-dispatch solve after ≈ 0.6 s, at 1000 RBFs). The price of
//! one workgroup per channel is that three of the GPU's compute units do this stage. The
//! solution stays on the GPU as the next frame's start when the RBF count is unchanged
//! (the CPU solver interpolates across counts; here a new count starts from zero).
//!
//! Accuracy: `f32` CGLS reaches about `κ(RAC)·ε_f32` in relative error of `L⁰` (a few
//! `1e-4` at the condition numbers of `BENCHMARKS.md`, "Multiple scattering"), its
//! recurrence residual keeps falling below that; the tests bound the difference from the
//! CPU's `f64` solve by the condition number they compute.

use super::SourceBuffer;
use crate::Medium;
use crate::diffusion::{Coefficients, Operators, SolveOptions, Sources};
use haze_gpu::wgsl::Variant;
use haze_gpu::{ComputeLayout, GpuContext, GpuError, bind_buffers, buffer_init, compute_layout};
use std::f64::consts::PI;

/// The shader, `crates/view/shaders/diffusion.wgsl`.
pub const SHADER: Variant = Variant {
    label: "diffusion",
    entry: include_str!("../../shaders/diffusion.wgsl"),
    defines: &[],
};

/// Invocations per workgroup of `add`.
const ADD_GROUP: u32 = 64;
/// Most `iterate` dispatches per solve: chunks grow beyond [`MIN_CHUNK`] iterations to keep
/// within it.
const MAX_CHUNKS: u32 = 64;
/// Fewest CGLS iterations per `iterate` dispatch.
const MIN_CHUNK: u32 = 16;

/// The shader's `Params` (a read-only storage buffer), 64 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    n: u32,
    n2: u32,
    max_iterations: u32,
    warm: u32,
    tolerance: f32,
    sigma_t: f32,
    sigma_s: f32,
    sigma_a: f32,
    sigma_tr: f32,
    band0: f32,
    band1: f32,
    chunk: u32,
    direct: u32,
    _pad: [u32; 3],
}

/// The shader's `Entry`, 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Entry {
    col: u32,
    diffusion: f32,
    v: f32,
    grad: [f32; 3],
    _pad: [f32; 2],
}

/// A frame's operators on the GPU.
#[derive(Debug)]
pub struct OperatorBuffers {
    n: usize,
    index: wgpu::Buffer,
    entries: wgpu::Buffer,
    density: wgpu::Buffer,
}

impl OperatorBuffers {
    /// Uploads `ops`: rows (an inactive center's as the identity's single entry), their
    /// transpose as `(row, entry)` pairs per column, and `D̃` at the centers. Refuses
    /// buffers beyond the device's limits.
    pub fn upload(ctx: &GpuContext, ops: &Operators) -> Result<OperatorBuffers, GpuError> {
        let n = ops.n();
        let too_many = || GpuError::Input(format!("{n} RBFs are too many for the diffusion"));
        let mut rows = Vec::with_capacity(n + 1);
        let mut entries: Vec<Entry> = Vec::with_capacity(ops.nnz() + n);
        let mut density = Vec::with_capacity(n.max(1));
        rows.push(0u32);
        for h in 0..n {
            let d = ops.density(h);
            if d > 0.0 {
                entries.extend(ops.row(h).iter().map(|e| Entry {
                    col: e.l as u32,
                    diffusion: e.diffusion as f32,
                    v: e.v as f32,
                    grad: e.grad.map(|g| g as f32),
                    _pad: [0.0; 2],
                }));
            } else {
                entries.push(Entry {
                    col: h as u32,
                    ..Entry::default()
                });
            }
            density.push(d as f32);
            rows.push(u32::try_from(entries.len()).map_err(|_| too_many())?);
        }
        // Column starts, then the (row, entry) pairs of each column by increasing row.
        let mut cols = vec![0u32; n + 1];
        for e in &entries {
            cols[e.col as usize + 1] += 1;
        }
        for l in 0..n {
            cols[l + 1] += cols[l];
        }
        let mut fill = cols.clone();
        let mut pairs = vec![0u32; 2 * entries.len()];
        for h in 0..n {
            for k in rows[h]..rows[h + 1] {
                let l = entries[k as usize].col as usize;
                let i = fill[l] as usize;
                pairs[2 * i] = h as u32;
                pairs[2 * i + 1] = k;
                fill[l] += 1;
            }
        }
        let mut index = rows;
        index.extend(cols);
        index.extend(pairs);
        if entries.is_empty() {
            entries.push(Entry::default());
        }
        if density.is_empty() {
            density.push(0.0);
        }
        ctx.check_storage_size(
            "the diffusion operators",
            std::mem::size_of_val(entries.as_slice()) as u64,
        )?;
        ctx.check_storage_size("the diffusion index", 4 * index.len() as u64)?;
        ctx.scoped("diffusion operator upload", || {
            let storage = wgpu::BufferUsages::STORAGE;
            OperatorBuffers {
                n,
                index: buffer_init(
                    ctx,
                    "diffusion index",
                    bytemuck::cast_slice(&index),
                    storage,
                ),
                entries: buffer_init(
                    ctx,
                    "diffusion operators",
                    bytemuck::cast_slice(&entries),
                    storage,
                ),
                density: buffer_init(
                    ctx,
                    "density at the centers",
                    bytemuck::cast_slice(&density),
                    storage,
                ),
            }
        })
    }

    /// Number of centers.
    pub fn n(&self) -> usize {
        self.n
    }
}

/// The direct light of the suns and point lights at the centers on the GPU, as the
/// diffusion's source moments `J⁰`, `J¹` (direction of propagation) that
/// [`crate::lighting::direct::add_light_moments`] computes on the host (closed-form
/// transmittance through the RBFs, cheap beside the solve): per center and channel one
/// `vec4` `(J⁰, J¹)`, which `setup` and `finish` add to the moments they form from the
/// [`SourceBuffer`], as the CPU adds them to its `Sources`.
#[derive(Debug)]
pub struct DirectBuffer {
    buffer: wgpu::Buffer,
    count: usize,
}

impl DirectBuffer {
    /// Uploads the moments of `direct` (its escape probabilities are not used). Refuses
    /// moments of unequal lengths and buffers beyond the device's limits.
    pub fn upload(ctx: &GpuContext, direct: &Sources) -> Result<DirectBuffer, GpuError> {
        let n = direct.j0.len();
        if direct.j1.len() != n {
            return Err(GpuError::Input(format!(
                "direct light moments J⁰ for {n} centers, J¹ for {}",
                direct.j1.len()
            )));
        }
        let mut words: Vec<[f32; 4]> = Vec::with_capacity((3 * n).max(1));
        for (j0, j1) in direct.j0.iter().zip(&direct.j1) {
            for c in 0..3 {
                let v = j1[c];
                words.push([j0[c] as f32, v[0] as f32, v[1] as f32, v[2] as f32]);
            }
        }
        if words.is_empty() {
            words.push([0.0; 4]);
        }
        ctx.check_storage_size(
            "the direct light at the centers",
            std::mem::size_of_val(words.as_slice()) as u64,
        )?;
        let buffer = ctx.scoped("direct light upload", || {
            buffer_init(
                ctx,
                "direct light at the centers",
                bytemuck::cast_slice(&words),
                wgpu::BufferUsages::STORAGE,
            )
        })?;
        Ok(DirectBuffer { buffer, count: n })
    }

    /// Centers.
    pub fn count(&self) -> usize {
        self.count
    }
}

/// How the last solve ended (read back from the GPU).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiffusionStats {
    /// Most CGLS iterations among the three channels.
    pub iterations: u32,
    /// Largest relative residual `‖b − A L⁰‖/‖b‖` among the channels, as the `f32`
    /// recurrence carries it.
    pub residual: f64,
    /// Every channel met the tolerance (or a least-squares optimum).
    pub converged: bool,
}

/// The diffusion on the GPU: the pipelines and the solution kept for the next frame.
#[derive(Debug)]
pub struct DiffusionPass {
    layout: wgpu::BindGroupLayout,
    /// The shader's entry points `setup`, `iterate`, `finish` and `add`.
    setup: wgpu::ComputePipeline,
    iterate: wgpu::ComputePipeline,
    finish: wgpu::ComputePipeline,
    add: wgpu::ComputePipeline,
    /// Bound in place of a [`DirectBuffer`] when there is none.
    no_direct: wgpu::Buffer,
    /// `(centers, work buffer)`: the vectors of the last solve (module docs of the shader).
    work: Option<(usize, wgpu::Buffer)>,
}

impl DiffusionPass {
    /// Compiles the shader's entry points, which share one bind group layout.
    pub fn new(ctx: &GpuContext) -> Result<DiffusionPass, GpuError> {
        let source = super::shaders::source(&SHADER)?;
        ctx.scoped("diffusion pipeline creation", || {
            let d = &ctx.device;
            let ComputeLayout {
                layout,
                pipeline_layout,
                module,
            } = compute_layout(
                d,
                "diffusion",
                &source,
                &[false, false, true, true, true, true],
            );
            let pipeline = |entry: &'static str| {
                d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            };
            DiffusionPass {
                setup: pipeline("setup"),
                iterate: pipeline("iterate"),
                finish: pipeline("finish"),
                add: pipeline("add"),
                no_direct: buffer_init(
                    ctx,
                    "no direct light",
                    &[0; 16],
                    wgpu::BufferUsages::STORAGE,
                ),
                layout,
                work: None,
            }
        })
    }

    /// Forgets the last solution: the next solve starts from zero.
    pub fn reset(&mut self) {
        self.work = None;
    }

    /// Adds `J̃ms` to `sources` (single scattering's, with the escape probabilities): the
    /// diffusion of the frame whose operators are `ops` in `medium`, solved with `opts`
    /// from the last solution when it had as many centers (submitted, not waited for).
    /// Nothing to add without centers or when the medium does not interact with light
    /// (`σt = 0`: no source). Refuses sources for another number of centers and buffers
    /// beyond the device's limits.
    pub fn run(
        &mut self,
        ctx: &GpuContext,
        ops: &OperatorBuffers,
        medium: &Medium,
        sources: &SourceBuffer,
        opts: &SolveOptions,
    ) -> Result<(), GpuError> {
        self.run_with(ctx, ops, medium, sources, None, opts)
    }

    /// [`DiffusionPass::run`] with the direct light of suns and point lights at the
    /// centers added to the single-scattering moments (the CPU's
    /// [`crate::render::add_multiple_scattering`]); refuses moments for another number of
    /// centers too.
    pub fn run_with(
        &mut self,
        ctx: &GpuContext,
        ops: &OperatorBuffers,
        medium: &Medium,
        sources: &SourceBuffer,
        direct: Option<&DirectBuffer>,
        opts: &SolveOptions,
    ) -> Result<(), GpuError> {
        let n = ops.n;
        if sources.count() != n {
            return Err(GpuError::Input(format!(
                "sources for {} centers, diffusion operators for {n}",
                sources.count()
            )));
        }
        if let Some(d) = direct
            && d.count != n
        {
            return Err(GpuError::Input(format!(
                "direct light for {} centers, diffusion operators for {n}",
                d.count
            )));
        }
        let Some(k) = Coefficients::of(medium) else {
            return Ok(());
        };
        if n == 0 {
            return Ok(());
        }
        let n32 = u32::try_from(n)
            .map_err(|_| GpuError::Input(format!("{n} RBFs are too many for the diffusion")))?;
        let words = 36 * n as u64 + 24;
        ctx.check_storage_size("the diffusion's vectors", 4 * words)?;
        let warm = matches!(&self.work, Some((m, _)) if *m == n);
        if !warm {
            let buffer = ctx.scoped("diffusion buffer creation", || {
                ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("diffusion vectors"),
                    size: 4 * words,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            })?;
            self.work = Some((n, buffer));
        }
        let Some((_, work)) = &self.work else {
            unreachable!("the work buffer was just made");
        };
        let order = sources.order();
        let params = Params {
            n: n32,
            n2: (order * order) as u32,
            max_iterations: opts.max_iterations,
            warm: u32::from(warm),
            tolerance: opts.tolerance as f32,
            sigma_t: k.sigma_t as f32,
            sigma_s: k.sigma_s as f32,
            sigma_a: k.sigma_a as f32,
            sigma_tr: k.sigma_tr as f32,
            band0: (medium.albedo * 2.0 * PI.sqrt()) as f32,
            band1: (medium.albedo * medium.g * (4.0 * PI / 3.0).sqrt()) as f32,
            chunk: MIN_CHUNK.max(opts.max_iterations.div_ceil(MAX_CHUNKS)),
            direct: u32::from(direct.is_some()),
            _pad: [0; 3],
        };
        ctx.scoped("diffusion", || {
            let params_buffer = buffer_init(
                ctx,
                "diffusion parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::STORAGE,
            );
            let buffers = [
                &params_buffer,
                sources.buffer(),
                work,
                &ops.index,
                &ops.entries,
                &ops.density,
                direct.map_or(&self.no_direct, |d| &d.buffer),
            ];
            let bind = bind_buffers(ctx, "diffusion", &self.layout, &buffers);
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("diffusion"),
                });
            {
                // One pass (one timed stage); each dispatch sees the previous one's writes.
                let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("diffusion"),
                    timestamp_writes: ctx.timestamp_writes("diffusion"),
                });
                pass.set_bind_group(0, &bind, &[]);
                pass.set_pipeline(&self.setup);
                pass.dispatch_workgroups(3, 1, 1);
                pass.set_pipeline(&self.iterate);
                for _ in 0..opts.max_iterations.div_ceil(params.chunk) {
                    pass.dispatch_workgroups(3, 1, 1);
                }
                pass.set_pipeline(&self.finish);
                pass.dispatch_workgroups(3, 1, 1);
                pass.set_pipeline(&self.add);
                pass.dispatch_workgroups(n32.div_ceil(ADD_GROUP), 1, 1);
            }
            ctx.queue.submit([enc.finish()]);
        })
    }

    /// The last solve's iterations, residual and convergence (waits for the GPU);
    /// `None` before the first solve.
    pub fn stats(&self, ctx: &GpuContext) -> Result<Option<DiffusionStats>, GpuError> {
        let Some((n, work)) = &self.work else {
            return Ok(None);
        };
        let words: Vec<f32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(work)?);
        let mut stats = DiffusionStats {
            converged: true,
            ..DiffusionStats::default()
        };
        for c in 0..3 {
            let at = 36 * n + 8 * c;
            stats.iterations = stats.iterations.max(words[at] as u32);
            stats.residual = stats.residual.max(f64::from(words[at + 1]));
            stats.converged &= words[at + 2] == 1.0;
        }
        Ok(Some(stats))
    }

    /// `L⁰` at the centers from the last solve, per channel (waits for the GPU); `None`
    /// before the first solve.
    pub fn solution(&self, ctx: &GpuContext) -> Result<Option<Vec<[f64; 3]>>, GpuError> {
        let Some((n, work)) = &self.work else {
            return Ok(None);
        };
        let words: Vec<f32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(work)?);
        Ok(Some(
            (0..*n)
                .map(|h| [0, 1, 2].map(|c| f64::from(words[8 * n * c + h])))
                .collect(),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_match_the_shader() {
        assert_eq!(std::mem::size_of::<Params>(), 64);
        assert_eq!(std::mem::size_of::<Entry>(), 32);
    }
}
