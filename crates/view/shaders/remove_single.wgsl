// The centers' single scattering taken out of their sources when the environment pass
// lights every voxel instead: the GPU twin of the subtraction at the end of
// `render::source_radiance` (`sources −= single`, word by word, f32). Bound as flat f32
// words of two `SourceBuffer`s of the same size, the sources after the diffusion added
// J̃ms and the copy taken of them before.

@group(0) @binding(0) var<storage, read_write> sources: array<f32>;
@group(0) @binding(1) var<storage, read> single: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let i = gid.x + 64u * ng.x * gid.y;
    if i >= arrayLength(&sources) {
        return;
    }
    // The escape probability (w of coefficient 0) stays: the volume pass ignores it.
    if i % 4u == 3u {
        return;
    }
    sources[i] -= single[i];
}
