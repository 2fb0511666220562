// The sky's share that reaches the ground through the smoke (`ground::sky_seen`), on the
// nodes of its grid: the GPU twin of `SkyGrid::compute`, in f32, one invocation per node.
//
//     V_c(x) = Σ_k w_{k,c} · T(x, ω_k, ∞)
//
// with the directions ω_k and weights w_k of `SkyDirections` (cosine-stratified over the
// upper hemisphere, weighed by the sky's radiance) and T the ground's shadow rays
// (`grid_shadow.wgsl`'s `shadow`, the view pass's). Positions are box-local.

struct Params {
    // Box size (its maximum corner, relative to its minimum).
    size: vec3<f32>,
    sigma_t: f32,
    voxel: vec3<f32>,
    // Nodes per side of the grid.
    nodes: u32,
    dims: vec3<u32>,
    // Directions in `directions`.
    count: u32,
    // Node (0, 0), box-local x, y.
    origin: vec2<f32>,
    // The nodes' spacing.
    cell: f32,
    // The ground's height, box-local.
    ground_z: f32,
    // Where the nodes start in `seen`.
    first: u32,
    // The shadow rays' step: the view pass's slice thickness.
    du: f32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<storage, read> p: Params;
// Per voxel (x fastest): D in w.
@group(0) @binding(1) var<storage, read> grid: array<vec4<f32>>;
// Per block of OCCUPANCY_BLOCK³ voxels whether a sample there may see density.
@group(0) @binding(2) var<storage, read> occupancy: array<u32>;
// Two per direction: (unit direction, 0), (its weight per channel, 0).
@group(0) @binding(3) var<storage, read> directions: array<vec4<f32>>;
// V per node (x fastest) in xyz, from `first` on (the view pass's `ground_lights`,
// after the ground's lights).
@group(0) @binding(4) var<storage, read_write> seen: array<vec4<f32>>;

#import grid_shadow

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = p.nodes;
    if id.x >= n * n {
        return;
    }
    let x = vec3<f32>(p.origin + vec2<f32>(f32(id.x % n), f32(id.x / n)) * p.cell, p.ground_z);
    var v = vec3<f32>(0.0);
    for (var k = 0u; k < p.count; k++) {
        let t = shadow(x, directions[2u * k].xyz, 3.0e38);
        if t > 0.0 {
            v += directions[2u * k + 1u].xyz * t;
        }
    }
    seen[p.first + id.x] = vec4<f32>(clamp(v, vec3<f32>(0.0), vec3<f32>(1.0)), 0.0);
}
