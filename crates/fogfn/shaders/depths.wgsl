// Optical depths of a batch of rays from the eye (haze_fogfn::gpu::DepthKernel), the
// test and benchmark harness of fogfn.wgsl.
#import fogfn

@group(0) @binding(0) var<storage, read> fog_terms: array<vec4<f32>>;

fn fog_record(i: u32) -> vec4<f32> {
    return fog_terms[i];
}
// Unit direction and length per ray.
@group(0) @binding(1) var<storage, read> rays: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> depths: array<f32>;

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= arrayLength(&depths)) {
        return;
    }
    let r = rays[id.x];
    depths[id.x] = fog_depth(r.xyz, r.w);
}
