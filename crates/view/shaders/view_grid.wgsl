// The view pass's copy of the volume pass's grid: per voxel (ln J̃ r g b, D), the
// logarithm of each channel's J̃ taken once here instead of at every sample of every
// ray (the geometric mean of `view_pass.wgsl`'s `sample_grid`, decision 0049; the CPU's
// `crm::RadianceField` keeps its logarithms the same way). A channel with J̃ ≤ 0 (unlit)
// is `UNLIT`; a lit one below f32's smallest normal is taken at that normal, as the
// view pass's floor takes it. One invocation per voxel.

#import ln_radiance

struct Params {
    // Voxels in the grid.
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<storage, read> p: Params;
// Per voxel (x fastest): J̃ r g b, D.
@group(0) @binding(1) var<storage, read> grid: array<vec4<f32>>;
// Per voxel: ln J̃ r g b (UNLIT where J̃ ≤ 0), D.
@group(0) @binding(2) var<storage, read_write> ln_grid: array<vec4<f32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let i = gid.x + 64u * ng.x * gid.y;
    if i >= p.count {
        return;
    }
    let v = grid[i];
    let ln_j = select(vec3<f32>(UNLIT), log(max(v.xyz, vec3<f32>(MIN_NORMAL))), v.xyz > vec3<f32>(0.0));
    ln_grid[i] = vec4<f32>(ln_j, v.w);
}
