//! Single scattering at the RBF centers on the GPU (`shaders/single_scattering.wgsl`), the
//! twin of [`crate::lighting::single::single_scattering`]: the same `J̃ss(c_ℓ)` and escape
//! probabilities, computed in `f32`.
//!
//! One workgroup of 64 invocations per RBF: they split the optical-depth sum over the RBFs
//! (ZH table lookup and rotation, [`crate::lighting::single::optical_depth_sh`]), reduce it
//! in workgroup memory, then evaluate `exp*` ([`crate::sh::ShExp::exp`], any
//! [`ExpMethod`]), the triple product with the light and the phase convolution with one
//! coefficient per invocation (a row of the triple-product tensor Γ each). The tables of
//! the order — the ZH table, Γ by rows, and for [`ExpMethod::OptimalLinear`] the fitted
//! `(‖f̂‖, ln a, ln b)` — are uploaded once per [`SingleScatteringPass`]; a frame uploads
//! its RBFs and the light. The result stays on the GPU as a [`SourceBuffer`], the volume
//! pass's input.
//!
//! Cost per frame: `points · L²` ZH lookups and `n²`-term rotations (`points` = 1 at the
//! centers, 6 over the footprint), `L/64` per invocation, plus per RBF and point one
//! `exp*` of `k + terms` triple products of `|Γ|/n²` multiply-adds per invocation.

use super::SourceBuffer;
use crate::Medium;
use crate::lighting::single::{RgbSh, ShKit, SingleScattering, SourcePoints};
use crate::lighting::zh_table::SAMPLES;
use crate::sh::{self, ExpMethod, MAX_ORDER};
use haze_gpu::wgsl::Variant;
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline, submit_pass};
use haze_volume::Rbf;
use std::f64::consts::PI;
use std::sync::OnceLock;

/// The shader: `crates/view/shaders/single_scattering.wgsl`, importing `sh_basis`.
pub const SHADER: Variant = Variant {
    label: "single scattering",
    entry: include_str!("../../shaders/single_scattering.wgsl"),
    defines: &[],
};

/// The shader's `Params` (a read-only storage buffer), 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    count: u32,
    order: u32,
    points: u32,
    method: u32,
    halvings: u32,
    table_len: u32,
    groups_x: u32,
    neg_sigma_t: f32,
}

/// Γ by rows for the shader: `n² + 1` row starts, then per entry `(j | k << 16, Γ bits)`.
fn gamma_words(kit: &ShKit) -> Vec<u32> {
    let n2 = kit.order * kit.order;
    let entries = kit.triple.entries();
    let mut starts = vec![0u32; n2 + 1];
    for &(i, _, _, _) in entries {
        starts[i as usize + 1] += 1;
    }
    for i in 0..n2 {
        starts[i + 1] += starts[i];
    }
    let mut words = starts;
    for &(_, j, k, g) in entries {
        words.push(u32::from(j) | u32::from(k) << 16);
        words.push((g as f32).to_bits());
    }
    words
}

/// Single scattering of one SH order on the GPU: the pipeline and the order's tables.
#[derive(Debug)]
pub struct SingleScatteringPass {
    pipeline: wgpu::ComputePipeline,
    order: usize,
    zh: wgpu::Buffer,
    gamma: wgpu::Buffer,
    /// `ShExp::linear_table`, uploaded when [`ExpMethod::OptimalLinear`] is first asked
    /// for (fitting it takes up to a second); `(buffer, rows)`.
    linear: OnceLock<(wgpu::Buffer, u32)>,
    /// One zero row, bound in place of the linear table by the other methods.
    no_table: wgpu::Buffer,
}

impl SingleScatteringPass {
    /// Compiles the shader and uploads the tables of `kit`'s order.
    pub fn new(ctx: &GpuContext, kit: &ShKit) -> Result<SingleScatteringPass, GpuError> {
        let order = kit.order;
        if !(1..=MAX_ORDER).contains(&order) {
            return Err(GpuError::Input(format!(
                "SH order {order} is outside 1..={MAX_ORDER}"
            )));
        }
        let zh: Vec<f32> = kit.table.rows().iter().map(|&v| v as f32).collect();
        debug_assert_eq!(zh.len(), SAMPLES * order);
        let gamma = gamma_words(kit);
        let pipeline = compute_pipeline(
            ctx,
            "single scattering pipeline creation",
            &super::shaders::source(&SHADER)?,
        )?;
        let storage = wgpu::BufferUsages::STORAGE;
        ctx.scoped("single scattering tables", || SingleScatteringPass {
            pipeline,
            order,
            zh: buffer_init(ctx, "ZH table", bytemuck::cast_slice(&zh), storage),
            gamma: buffer_init(ctx, "triple product", bytemuck::cast_slice(&gamma), storage),
            linear: OnceLock::new(),
            no_table: buffer_init(
                ctx,
                "no exp table",
                bytemuck::cast_slice(&[[0.0f32; 4]]),
                storage,
            ),
        })
    }

    /// The SH order of the tables.
    pub fn order(&self) -> usize {
        self.order
    }

    fn linear_table(&self, ctx: &GpuContext, kit: &ShKit) -> &(wgpu::Buffer, u32) {
        self.linear.get_or_init(|| {
            let (norms, ln_a, ln_b) = kit.exp.linear_table();
            let rows: Vec<[f32; 4]> = (0..norms.len())
                .map(|i| [norms[i] as f32, ln_a[i] as f32, ln_b[i] as f32, 0.0])
                .collect();
            let buffer = buffer_init(
                ctx,
                "optimal linear exp table",
                bytemuck::cast_slice(&rows),
                wgpu::BufferUsages::STORAGE,
            );
            (buffer, rows.len() as u32)
        })
    }

    /// `J̃ss` and the escape probability at every center of `rbfs`, lit by `light` (RGB SH
    /// of the order), into a [`SourceBuffer`] (submitted, not waited for). `kit` must be
    /// the one the pass was built with. Refuses a kit or light of another order and
    /// dispatches or buffers beyond the device's limits.
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &self,
        ctx: &GpuContext,
        kit: &ShKit,
        rbfs: &[Rbf],
        medium: &Medium,
        light: &RgbSh,
        method: ExpMethod,
        points: SourcePoints,
    ) -> Result<SourceBuffer, GpuError> {
        let n = self.order;
        let n2 = n * n;
        if kit.order != n {
            return Err(GpuError::Input(format!(
                "SH kit of order {} for a pass of order {n}",
                kit.order
            )));
        }
        if light.iter().any(|c| c.len() != n2) {
            return Err(GpuError::Input(format!(
                "the light has {:?} SH coefficients per channel, order {n} needs {n2}",
                light.each_ref().map(Vec::len)
            )));
        }
        let count = u32::try_from(rbfs.len())
            .map_err(|_| GpuError::Input(format!("{} RBFs are too many", rbfs.len())))?;
        let max_groups = ctx.device.limits().max_compute_workgroups_per_dimension;
        let groups_x = count.clamp(1, max_groups);
        let groups_y = count.div_ceil(groups_x);
        if groups_y > max_groups {
            return Err(GpuError::Input(format!(
                "{count} RBFs are more than one dispatch can take"
            )));
        }
        let (method_code, halvings) = match method {
            ExpMethod::ScaleSquareAuto => (0, 0),
            ExpMethod::ScaleSquare { halvings } => (1, halvings),
            ExpMethod::OptimalLinear => (2, 0),
        };
        let (table, table_len) = match method {
            ExpMethod::OptimalLinear => {
                let (b, len) = self.linear_table(ctx, kit);
                (b, *len)
            }
            _ => (&self.no_table, 1),
        };
        let params = Params {
            count,
            order: n as u32,
            points: match points {
                SourcePoints::Center => 1,
                SourcePoints::Footprint => 6,
            },
            method: method_code,
            halvings,
            table_len,
            groups_x,
            neg_sigma_t: (-medium.sigma_t) as f32,
        };
        let rbf_data = rbf_records(rbfs);
        let light_data = light_records(light, medium, n);
        ctx.check_storage_size(
            "the RBFs",
            std::mem::size_of_val(rbf_data.as_slice()) as u64,
        )?;
        let out = SourceBuffer::create(ctx, rbfs.len(), n)?;
        ctx.scoped("single scattering", || {
            let storage = wgpu::BufferUsages::STORAGE;
            let params_buffer = buffer_init(
                ctx,
                "single scattering parameters",
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::STORAGE,
            );
            let rbf_buf = buffer_init(
                ctx,
                "single scattering RBFs",
                bytemuck::cast_slice(&rbf_data),
                storage,
            );
            let light_buf = buffer_init(
                ctx,
                "single scattering light",
                bytemuck::cast_slice(&light_data),
                storage,
            );
            let buffers = [
                &params_buffer,
                &rbf_buf,
                &self.zh,
                &self.gamma,
                &light_buf,
                table,
                out.buffer(),
            ];
            let groups = [groups_x, if count > 0 { groups_y } else { 0 }, 1];
            submit_pass(ctx, &self.pipeline, "single scattering", &buffers, groups);
        })?;
        Ok(out)
    }
}

/// [`crate::lighting::single::single_scattering`] on the GPU, read back: builds the pass
/// for `kit`'s order, runs it once and copies the sources and escape probabilities to the
/// host (keep a [`SingleScatteringPass`] to light frames).
pub fn single_scattering(
    ctx: &GpuContext,
    kit: &ShKit,
    rbfs: &[Rbf],
    medium: &Medium,
    light: &RgbSh,
    method: ExpMethod,
    points: SourcePoints,
) -> Result<SingleScattering, GpuError> {
    SingleScatteringPass::new(ctx, kit)?
        .run(ctx, kit, rbfs, medium, light, method, points)?
        .read(ctx)
}

/// Two records per RBF: (center relative to the first one's, radius), (weight, -, -, -).
/// Distances are all the shader needs, and smoke far from the origin keeps its `f32`
/// precision. One zero record for no RBF (wgpu binds no empty buffers).
fn rbf_records(rbfs: &[Rbf]) -> Vec<[f32; 4]> {
    let origin = rbfs.first().map_or([0.0; 3], |b| b.center);
    let mut rbf_data: Vec<[f32; 4]> = Vec::with_capacity(2 * rbfs.len().max(1));
    for b in rbfs {
        let c = [0, 1, 2].map(|a| (b.center[a] - origin[a]) as f32);
        rbf_data.push([c[0], c[1], c[2], b.radius as f32]);
        rbf_data.push([b.weight as f32, 0.0, 0.0, 0.0]);
    }
    if rbf_data.is_empty() {
        rbf_data.push([0.0; 4]);
    }
    rbf_data
}

/// The light's records for order `n`: `L_in` per coefficient, then per band `l` the
/// convolution factor `(Ω/4π)·√(4π/(2l+1))·p_l` of the medium's albedo and phase.
fn light_records(light: &RgbSh, medium: &Medium, n: usize) -> Vec<[f32; 4]> {
    let n2 = n * n;
    let phase = sh::hg_zh(medium.g, n);
    let mut light_data: Vec<[f32; 4]> = (0..n2)
        .map(|k| {
            [
                light[0][k] as f32,
                light[1][k] as f32,
                light[2][k] as f32,
                0.0,
            ]
        })
        .collect();
    light_data.extend((0..n).map(|l| {
        let band = (4.0 * PI / (2 * l + 1) as f64).sqrt();
        [
            (medium.albedo / (4.0 * PI) * band * phase[l]) as f32,
            0.0,
            0.0,
            0.0,
        ]
    }));
    light_data
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn params_are_32_bytes() {
        assert_eq!(std::mem::size_of::<Params>(), 32);
    }

    #[test]
    fn gamma_rows_hold_every_entry_once_in_order() {
        let kit = ShKit::new(3);
        let w = gamma_words(&kit);
        let n2 = 9;
        let entries = kit.triple.entries();
        assert_eq!(w[n2] as usize, entries.len());
        assert_eq!(w.len(), n2 + 1 + 2 * entries.len());
        for i in 0..n2 {
            for e in w[i]..w[i + 1] {
                let e = e as usize;
                let (ei, j, k, g) = entries[e];
                assert_eq!(ei as usize, i);
                assert_eq!(w[n2 + 1 + 2 * e], u32::from(j) | u32::from(k) << 16);
                assert_eq!(f32::from_bits(w[n2 + 2 + 2 * e]), g as f32);
            }
        }
    }
}
