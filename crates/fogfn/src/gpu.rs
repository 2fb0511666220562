//! The `f32` WGSL twin of the closed forms (`shaders/fogfn.wgsl`): the module `fogfn`
//! ([`MODULES`]) defines `fog_depth(w, len)`, the optical depth along a ray leaving the
//! eye, for any shader that imports it and defines `fog_record(i)`, the `i`-th of the
//! [`records`] it keeps in a buffer (and `fog_depth_from(start, w, len)` for a fog whose
//! records start at `fog_record(start)`,
//! several fogs' records laid end to end; `fog_depth_at(start, o, w, len)` for a ray
//! leaving the point `o` relative to the eye and `fog_density_at(start, x)` for `K`
//! itself, what a march needs); [`DepthKernel`]
//! runs it over a batch of rays (the twin tests and the benchmarks).
//!
//! Precision: [`records`] does in `f64` everything that depends on where the eye is and
//! when — the phase of each wave at the eye reduced to `[0, 2π)`, the cell coordinates
//! of the eye (wrapped into the reference cell when periodic), the offsets from the eye to
//! the blobs, `ln w − b·s(eye)` of a height layer — so that a fog far from the origin or
//! late in an animation loses nothing in `f32`; the shader reduces its own phases to
//! `[−π, π]` before `sin`/`cos`. A periodic polynomial of several axes walks at most
//! `FOG_MAX_CELLS` (4096) cells per ray on the GPU.

use crate::vec3::{Vec3, dot, perp, sub};
use crate::{Family, Fog, blob::Shape};
use haze_gpu::wgsl::{Module, Variant};
use haze_gpu::{GpuContext, GpuError, buffer_init, compute_pipeline, submit_pass};

/// The WGSL module `fogfn` (`fog_depth` and its helpers), for the shaders of other crates
/// that march analytic fogs.
pub const MODULES: &[Module] = &[Module {
    name: "fogfn",
    source: include_str!("../shaders/fogfn.wgsl"),
}];

/// [`DepthKernel`]'s shader (`shaders/depths.wgsl`).
pub const DEPTHS: Variant = Variant {
    label: "fog depths",
    entry: include_str!("../shaders/depths.wgsl"),
    defines: &[],
};

fn v4(v: Vec3, w: f64) -> [f32; 4] {
    [v[0] as f32, v[1] as f32, v[2] as f32, w as f32]
}

/// The records of `fog` seen from `eye` at time `t` (layout in `shaders/fogfn.wgsl`),
/// ended by the terminator. Terms of zero weight are left out.
pub fn records(fog: &Fog, eye: Vec3, t: f64) -> Vec<[f32; 4]> {
    let mut out = Vec::new();
    for term in fog.terms.iter().filter(|term| term.weight != 0.0) {
        let o = fog.shifted(term, eye, t);
        let w = term.weight;
        match &term.family {
            Family::Constant => out.push([0.0, w as f32, 0.0, 0.0]),
            Family::Cosine(c) => {
                for wave in &c.waves {
                    out.push([1.0, (w * wave.amp) as f32, wave.phase_at(o, t) as f32, 0.0]);
                    out.push(v4(wave.q, 0.0));
                }
            }
            Family::Polynomial(p) => {
                let n = p.axes.len();
                out.push([
                    2.0,
                    w as f32,
                    p.half as f32,
                    if p.periodic { 1.0 } else { 0.0 },
                ]);
                out.push([n as f32, p.monomials.len() as f32, 0.0, 0.0]);
                let s = p.coords(o);
                for (j, a) in p.axes.iter().enumerate() {
                    let sj = if p.periodic { p.wrap(s[j]) } else { s[j] };
                    out.push(v4(*a, sj));
                }
                for &(coef, pw) in &p.monomials {
                    out.push([coef as f32, pw[0] as f32, pw[1] as f32, pw[2] as f32]);
                }
            }
            Family::Blob(b) => {
                let head = |kind: f32| [kind, w as f32, b.c as f32, b.d as f32];
                match b.shape {
                    Shape::Point { center } => {
                        out.push(head(3.0));
                        out.push(v4(sub(o, center), 0.0));
                    }
                    Shape::Line { point, direction } => {
                        out.push(head(4.0));
                        out.push(v4(perp(sub(o, point), direction), 0.0));
                        out.push(v4(direction, 0.0));
                    }
                    Shape::Sphere { center, radius } => {
                        out.push(head(5.0));
                        out.push(v4(sub(o, center), radius));
                    }
                }
            }
            Family::Height(h) => {
                let s0 = dot(h.normal, o) - h.base;
                out.push([6.0, (w.ln() - h.falloff * s0) as f32, h.falloff as f32, 0.0]);
                out.push(v4(h.normal, 0.0));
            }
        }
    }
    out.push([-1.0, 0.0, 0.0, 0.0]);
    out
}

/// `fog_depth` over a batch of rays on the GPU.
#[derive(Debug)]
pub struct DepthKernel {
    pipeline: wgpu::ComputePipeline,
}

impl DepthKernel {
    pub fn new(ctx: &GpuContext) -> Result<DepthKernel, GpuError> {
        let source = DEPTHS.source(&[MODULES])?;
        Ok(DepthKernel {
            pipeline: compute_pipeline(ctx, "fog depths pipeline creation", &source)?,
        })
    }

    /// The optical depth of `fog` from `eye` at time `t` along each `(unit direction,
    /// length)`, in `f32`.
    pub fn run(
        &self,
        ctx: &GpuContext,
        fog: &Fog,
        eye: Vec3,
        t: f64,
        rays: &[(Vec3, f64)],
    ) -> Result<Vec<f32>, GpuError> {
        if rays.is_empty() {
            return Ok(Vec::new());
        }
        let terms = records(fog, eye, t);
        let dirs: Vec<[f32; 4]> = rays.iter().map(|&(d, l)| v4(d, l)).collect();
        ctx.check_storage_size("the fog terms", 16 * terms.len() as u64)?;
        ctx.check_storage_size("the rays", 16 * dirs.len() as u64)?;
        let n = u32::try_from(rays.len())
            .map_err(|_| GpuError::Input(format!("{} rays are too many", rays.len())))?;
        let out = ctx.scoped("fog depths", || {
            let terms = buffer_init(
                ctx,
                "fog terms",
                bytemuck::cast_slice(&terms),
                wgpu::BufferUsages::STORAGE,
            );
            let dirs = buffer_init(
                ctx,
                "fog rays",
                bytemuck::cast_slice(&dirs),
                wgpu::BufferUsages::STORAGE,
            );
            let out = ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("fog depths"),
                size: 4 * u64::from(n),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            submit_pass(
                ctx,
                &self.pipeline,
                "fog depths",
                &[&terms, &dirs, &out],
                [n.div_ceil(64), 1, 1],
            );
            out
        })?;
        Ok(bytemuck::pod_collect_to_vec(&ctx.read_buffer(&out)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The depth kernel's shader composes and validates on the CPU (no device needed).
    #[test]
    fn the_shader_validates() {
        haze_gpu::wgsl::assert_variants_valid(&[DEPTHS], &[MODULES]);
    }
}
