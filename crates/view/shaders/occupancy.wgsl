// Which blocks of BLOCK³ voxels of the volume pass's grid a march may skip: block b is
// occupied (1) when some voxel within one voxel of it — indices [BLOCK·b − 1, BLOCK·b +
// BLOCK] per axis, clamped to the grid — has D > 0, else empty (0). The trilinear D of
// `grid_march::sample_density` at any point of an empty block's closed region reads only
// voxels of that range, so it is exactly 0 there: a march that skips the samples in empty
// blocks sums the same values in the same order (`env_pass.wgsl`'s `blocked_depth`).
// One invocation per block.

const BLOCK: u32 = 4u;

struct Params {
    dims: vec3<u32>,
    _pad0: u32,
    // Blocks per axis: ⌈dims / BLOCK⌉.
    blocks: vec3<u32>,
    _pad1: u32,
}

@group(0) @binding(0) var<storage, read> p: Params;
// Per voxel (x fastest): J̃ r g b, D.
@group(0) @binding(1) var<storage, read> grid: array<f32>;
// Per block (x fastest).
@group(0) @binding(2) var<storage, read_write> occupancy: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let b = gid.x + 64u * ng.x * gid.y;
    let total = p.blocks.x * p.blocks.y * p.blocks.z;
    if b >= total {
        return;
    }
    let idx = vec3<u32>(b % p.blocks.x, (b / p.blocks.x) % p.blocks.y, b / (p.blocks.x * p.blocks.y));
    let lo = max(vec3<i32>(idx * BLOCK) - 1, vec3<i32>(0));
    let hi = min(vec3<i32>(idx * BLOCK + BLOCK), vec3<i32>(p.dims) - 1);
    var any = 0u;
    for (var z = lo.z; z <= hi.z && any == 0u; z++) {
        for (var y = lo.y; y <= hi.y && any == 0u; y++) {
            for (var x = lo.x; x <= hi.x; x++) {
                let i = u32(x) + p.dims.x * (u32(y) + p.dims.y * u32(z));
                if grid[4u * i + 3u] > 0.0 {
                    any = 1u;
                    break;
                }
            }
        }
    }
    occupancy[b] = any;
}
