//! The environment grid's sweep on the GPU (`shaders/env_pass.wgsl`'s `needed` and
//! `sweep`): the plan of its dispatches and their submission, for
//! [`super::env_pass::EnvPass::grid`].
//!
//! The nodes' optical depths towards each direction of the rule come from the CPU's
//! default sweep ([`crate::render::env_sweep`]): each node's depth is a segment of
//! [`STRIDE`] node planes plus the depth read bilinearly from the plane there. On the
//! GPU the rule's directions are grouped by the axis whose node planes they cross
//! fastest and their sense along it (`sweep_groups`), and each group is dispatched
//! once per block of `STRIDE` planes in sweep order: every read then comes from a plane
//! an earlier dispatch wrote (WebGPU orders the dispatches of a pass), and a ring of
//! [`RING`] planes per direction is all the depths that must be kept (22.6 MB for 72
//! directions over a 128 × 128 × 170 grid's nodes at 1.5 voxels, where the depths of
//! every node would take 243 MB). A `needed` dispatch before them marks the nodes the
//! pass reads and reduces their domain (per axis the first and last such node), which
//! the sweep covers: the CPU's [`crate::render::env_pass::env_grid`] sweeps the same
//! domain.
//!
//! A group's dispatch covers the whole grid's planes (the host does not read the domain
//! back); the invocations outside the domain return at once. Where the domain is one
//! node across a group's axis, every node of it marches (the CPU sweeps such a
//! direction along another axis; both stay within the sweep's error of the march).

use crate::render::env_sweep;
use crate::render::plane_sweep::{self, Lattice};
use crate::sh::ShGrid;
use haze_gpu::{GpuContext, GpuError, buffer_init, line_groups, timed_pass};

/// `env_pass.wgsl`'s STRIDE: node planes between a node and the plane its depth is read
/// from (the CPU's sweep's).
pub const STRIDE: usize = env_sweep::STRIDE;

/// `env_pass.wgsl`'s RING: node planes of depths kept per direction.
pub const RING: usize = 2 * STRIDE;

/// `env_pass.wgsl`'s DOMAIN_WORDS: the nodes' domain before their flags.
const DOMAIN_WORDS: usize = 6;

/// `env_pass.wgsl`'s `Block`: one `sweep` dispatch's block of node planes and group of
/// directions, 32 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SweepBlock {
    axis: u32,
    descending: u32,
    first: u32,
    count: u32,
    start: u32,
    plane: u32,
    ring_plane: u32,
    _pad: u32,
}

/// Directions of the rule that sweep the same node planes in the same order: along
/// `axis` (the one whose planes they cross fastest, [`plane_sweep::axis`] over the whole
/// grid), from its far face when `descending` (`ω_axis > 0`).
#[derive(Clone, Debug, PartialEq)]
struct SweepGroup {
    axis: usize,
    descending: bool,
    /// Indices into the rule, in its order.
    directions: Vec<usize>,
}

/// The rule's directions `w` grouped for the sweep over `frame`'s nodes (non-empty
/// groups, axis by axis, ascending before descending).
fn sweep_groups(frame: &ShGrid, w: impl Iterator<Item = [f64; 3]>) -> Vec<SweepGroup> {
    let lattice = Lattice {
        min: frame.min,
        cell: frame.cell,
        dims: frame.nodes,
    };
    let whole = frame.nodes.map(|n| (0, n.saturating_sub(1)));
    let mut groups: Vec<SweepGroup> = (0..6)
        .map(|g| SweepGroup {
            axis: g / 2,
            descending: g % 2 == 1,
            directions: Vec::new(),
        })
        .collect();
    for (i, w) in w.enumerate() {
        let k = plane_sweep::axis(&lattice, whole, w);
        groups[2 * k + usize::from(w[k] > 0.0)].directions.push(i);
    }
    groups.retain(|g| !g.directions.is_empty());
    groups
}

/// A bind group of `pipeline`'s group 0 with the `(binding, resource)` pairs given (the
/// bindings its entry point uses).
fn bind_at(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    entries: &[(u32, wgpu::BindingResource<'_>)],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = entries
        .iter()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: resource.clone(),
        })
        .collect();
    ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("environment grid"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &entries,
    })
}

/// The bytes of the sweep's rings over a grid of `nodes` for `directions` directions:
/// [`RING`] planes of the largest plane across an axis, `f32`, per direction.
pub fn ring_bytes(nodes: [usize; 3], directions: usize) -> u64 {
    (directions * RING * largest_plane(nodes)).max(1) as u64 * 4
}

/// Nodes in the largest plane across an axis of a grid of `nodes`: a ring plane's words.
fn largest_plane(nodes: [usize; 3]) -> usize {
    (0..3)
        .map(|k| nodes[(k + 1) % 3] * nodes[(k + 2) % 3])
        .max()
        .unwrap_or(1)
}

/// The buffers a sweep binds besides its own: the parameters (`env_pass.wgsl`'s
/// `Params`), the volume pass's grid, the nodes' `S` (zeroed, written) and the grid's
/// occupancy.
#[derive(Debug)]
pub struct SweepBuffers<'a> {
    pub params: &'a wgpu::Buffer,
    pub grid: &'a wgpu::Buffer,
    pub shadow: &'a wgpu::Buffer,
    pub occupancy: &'a wgpu::Buffer,
}

/// One environment grid's sweep: the direction rule in group order as the shader takes
/// it, and every dispatch's record.
#[derive(Debug)]
pub struct SweepPlan {
    /// Per direction `ω x y z, 0, w·L r g b, 0, Y_j(ω)` (`8 + order²` words), the
    /// groups one after the other.
    table: Vec<f32>,
    directions: u32,
    /// Per `sweep` dispatch its record and its workgroups.
    records: Vec<(SweepBlock, [u32; 3])>,
    /// The `needed` dispatch's workgroups.
    node_groups: [u32; 3],
    ring_bytes: u64,
    state_bytes: u64,
    /// Bytes between the records in their buffer (the device's storage offset
    /// alignment).
    align: usize,
}

/// A count as the shader's `u32`.
fn count(n: usize, what: &str) -> Result<u32, GpuError> {
    u32::try_from(n).map_err(|_| GpuError::Input(format!("{n} {what} are too many")))
}

impl SweepPlan {
    /// The sweep of `frame`'s nodes for `rule` (`env_pass::lit_directions`: direction,
    /// power, SH), `per_group` invocations a workgroup (the shader's 64). Refuses sizes
    /// beyond the device's limits.
    pub fn new(
        ctx: &GpuContext,
        frame: &ShGrid,
        rule: &[([f64; 3], [f64; 3], Vec<f64>)],
        per_group: usize,
    ) -> Result<SweepPlan, GpuError> {
        let groups = sweep_groups(frame, rule.iter().map(|(w, _, _)| *w));
        let mut table: Vec<f32> = Vec::new();
        for group in &groups {
            for (w, l, y) in group.directions.iter().map(|&i| &rule[i]) {
                table.extend(w.map(|c| c as f32));
                table.push(0.0);
                table.extend(l.map(|c| c as f32));
                table.push(0.0);
                table.extend(y.iter().map(|v| *v as f32));
            }
        }
        if table.is_empty() {
            table.push(0.0);
        }
        ctx.check_storage_size("the direction rule", (table.len() * 4) as u64)?;
        let n = frame.nodes;
        let plane = |k: usize| n[(k + 1) % 3] * n[(k + 2) % 3];
        let ring_plane = largest_plane(n);
        let ring_bytes = ring_bytes(n, rule.len());
        ctx.check_storage_size("the environment grid's sweep", ring_bytes)?;
        let total = frame.len();
        let state_bytes = (DOMAIN_WORDS + total) as u64 * 4;
        ctx.check_storage_size("the environment grid's nodes", state_bytes)?;
        let mut records = Vec::new();
        let mut first = 0;
        for group in &groups {
            let k = group.axis;
            let dispatch =
                line_groups(ctx, STRIDE * plane(k), per_group, "environment grid nodes")?;
            for start in (0..n[k]).step_by(STRIDE) {
                let record = SweepBlock {
                    axis: k as u32,
                    descending: u32::from(group.descending),
                    first: count(first, "directions")?,
                    count: count(group.directions.len(), "directions")?,
                    start: count(start, "node planes")?,
                    plane: count(plane(k), "nodes")?,
                    ring_plane: count(ring_plane, "nodes")?,
                    _pad: 0,
                };
                records.push((record, dispatch));
            }
            first += group.directions.len();
        }
        let align = ctx.device.limits().min_storage_buffer_offset_alignment as usize;
        Ok(SweepPlan {
            table,
            directions: count(rule.len(), "directions")?,
            records,
            node_groups: line_groups(ctx, total, per_group, "environment grid nodes")?,
            ring_bytes,
            state_bytes,
            align: align.max(std::mem::size_of::<SweepBlock>()),
        })
    }

    /// The rule's directions (the shader's `Params::directions`).
    pub fn directions(&self) -> u32 {
        self.directions
    }

    /// Records `needed`, then every block of `sweep` (the pipelines, in that order) in
    /// one pass, timed as "environment grid", and submits it.
    pub fn submit(
        &self,
        ctx: &GpuContext,
        [needed, sweep]: [&wgpu::ComputePipeline; 2],
        b: SweepBuffers<'_>,
    ) {
        let rule = buffer_init(
            ctx,
            "environment direction rule",
            bytemuck::cast_slice(&self.table),
            wgpu::BufferUsages::STORAGE,
        );
        let state = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("environment grid nodes"),
            size: self.state_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // The domain starts empty: first u32::MAX, last 0 (the flags are all written).
        let empty: [u32; DOMAIN_WORDS] = [u32::MAX, u32::MAX, u32::MAX, 0, 0, 0];
        ctx.queue
            .write_buffer(&state, 0, bytemuck::cast_slice(&empty));
        let ring = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("environment grid sweep"),
            size: self.ring_bytes,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let size = std::mem::size_of::<SweepBlock>();
        let mut bytes = vec![0u8; self.records.len().max(1) * self.align];
        for (i, (record, _)) in self.records.iter().enumerate() {
            bytes[i * self.align..i * self.align + size]
                .copy_from_slice(bytemuck::bytes_of(record));
        }
        let blocks = buffer_init(
            ctx,
            "environment grid sweep blocks",
            &bytes,
            wgpu::BufferUsages::STORAGE,
        );
        let whole = wgpu::Buffer::as_entire_binding;
        let needed_bind = bind_at(
            ctx,
            needed,
            &[(0, whole(b.params)), (2, whole(b.grid)), (5, whole(&state))],
        );
        let sweep_binds: Vec<wgpu::BindGroup> = (0..self.records.len())
            .map(|i| {
                let block = wgpu::BufferBinding {
                    buffer: &blocks,
                    offset: (i * self.align) as u64,
                    size: wgpu::BufferSize::new(size as u64),
                };
                bind_at(
                    ctx,
                    sweep,
                    &[
                        (0, whole(b.params)),
                        (1, whole(&rule)),
                        (2, whole(b.grid)),
                        (3, whole(b.shadow)),
                        (4, whole(b.occupancy)),
                        (5, whole(&state)),
                        (6, whole(&ring)),
                        (7, wgpu::BindingResource::Buffer(block)),
                    ],
                )
            })
            .collect();
        timed_pass(ctx, "environment grid", |pass| {
            pass.set_pipeline(needed);
            pass.set_bind_group(0, &needed_bind, &[]);
            let g = self.node_groups;
            pass.dispatch_workgroups(g[0], g[1], g[2]);
            pass.set_pipeline(sweep);
            for (bind, (_, g)) in sweep_binds.iter().zip(&self.records) {
                pass.set_bind_group(0, bind, &[]);
                pass.dispatch_workgroups(g[0], g[1], g[2]);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::env_pass;

    /// Every direction of the rule lands in one group, of the axis whose node planes it
    /// crosses fastest and of its sense along it; a grid one node thick along an axis
    /// never sweeps along it.
    #[test]
    fn directions_are_grouped_by_the_planes_they_cross_fastest() {
        let bbox = haze_volume::Bbox::new([0.0; 3], [1.0, 2.0, 1.0]);
        for (dims, flat) in [([16, 24, 20], None), ([16, 24, 1], Some(2))] {
            let frame = env_pass::grid_frame(dims, &bbox, 1.5, 2);
            let rule = env_pass::directions(3);
            let w: Vec<[f64; 3]> = rule.points().map(|(w, _)| w).collect();
            let groups = sweep_groups(&frame, w.iter().copied());
            let mut seen = vec![0; w.len()];
            for g in &groups {
                assert!(!g.directions.is_empty());
                assert_ne!(Some(g.axis), flat, "{dims:?}");
                for &i in &g.directions {
                    seen[i] += 1;
                    let rate = |a: usize| {
                        if frame.nodes[a] > 1 {
                            w[i][a].abs() / frame.cell[a]
                        } else {
                            0.0
                        }
                    };
                    assert!((0..3).all(|a| rate(g.axis) >= rate(a)), "{:?}", w[i]);
                    assert_eq!(g.descending, w[i][g.axis] > 0.0);
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{seen:?}");
        }
    }

    #[test]
    fn the_block_record_matches_the_wgsl_layout() {
        assert_eq!(std::mem::size_of::<SweepBlock>(), 32);
        assert_eq!(std::mem::offset_of!(SweepBlock, start), 16);
        assert_eq!(std::mem::offset_of!(SweepBlock, ring_plane), 24);
    }
}
