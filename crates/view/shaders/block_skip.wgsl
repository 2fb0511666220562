// Passing over the empty blocks of `occupancy.wgsl` in a march: the block a box-local
// point lies in, and how far along the march's direction it leaves that block. A march
// that jumps from a sample in an empty block to the last sample before the block's exit
// (rounded down) passes over only samples whose trilinear D is exactly 0.

// `occupancy.wgsl`'s BLOCK.
const OCCUPANCY_BLOCK: u32 = 4u;

// Block index of box-local point q (clamped to the grid's `blocks`), blocks of `side`.
fn block_of(q: vec3<f32>, side: vec3<f32>, blocks: vec3<u32>) -> vec3<u32> {
    return min(vec3<u32>(max(floor(q / side), vec3<f32>(0.0))), blocks - 1u);
}

// Distance along s from q to the far faces of block b (3.0e38 where s is 0 on every
// axis).
fn block_exit(q: vec3<f32>, s: vec3<f32>, b: vec3<u32>, side: vec3<f32>) -> f32 {
    var out = 3.0e38;
    for (var a = 0u; a < 3u; a++) {
        if s[a] > 0.0 {
            out = min(out, (f32(b[a] + 1u) * side[a] - q[a]) / s[a]);
        } else if s[a] < 0.0 {
            out = min(out, (f32(b[a]) * side[a] - q[a]) / s[a]);
        }
    }
    return out;
}
