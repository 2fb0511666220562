// Paper C's scene renderer (crates/scene's `gpu::GpuRenderer`): one invocation per pixel
// of render.wgsl's `paper_c_main`.
#import render

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    paper_c_main(id);
}
