// Paper D's composite on the GPU (haze_scene::gpu::analytic), over render.wgsl and
// haze_fogfn's fogfn.wgsl. Per pixel: paper C's picture (`paper_c_main`), then the analytic fogs' exact optical depth from the eye to the primary
// hit and C_fin = τ C_in + (1 − τ) C_fog per channel (haze_scene::analytic::composite).

#import render
#import fogfn

// Every fog's records (haze_fogfn::gpu::records), laid end to end.
@group(0) @binding(7) var<storage, read> fog_terms: array<vec4<f32>>;

// fogfn.wgsl's records.
fn fog_record(i: u32) -> vec4<f32> {
    return fog_terms[i];
}
// Two vec4 per fog: (σt, index of its first record), (C_fog, far).
@group(0) @binding(8) var<storage, read> fog_media: array<vec4<f32>>;

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let w = P.size.x;
    let h = P.size.y;
    if (id.x >= w || id.y >= h) {
        return;
    }
    paper_c_main(id);
    // The primary ray and hit as paper_c_main finds them.
    let dir = pixel_dir(vec2<f32>(id.xy) + 0.5);
    let env_far = P.flags.y == 0u;
    let t_max = primary_t_max();
    let hit = intersect(vec3<f32>(0.0), dir, 0.0, t_max);
    // A ray to an environment at ∞ ends at each fog's far (min below).
    var t_end = 3.0e38;
    if (hit.surface >= 0 || env_far) {
        t_end = hit.t;
    }
    var depth = vec3<f32>(0.0);
    var weighted = vec3<f32>(0.0);
    let n = arrayLength(&fog_media) / 2u;
    for (var m = 0u; m < n; m++) {
        let a = fog_media[2u * m];
        let b = fog_media[2u * m + 1u];
        let k = fog_depth_from(u32(a.w), dir, min(t_end, b.w));
        depth += a.xyz * k;
        weighted += a.xyz * k * b.xyz;
    }
    let idx = id.y * w + id.x;
    let c_in = image[idx].xyz;
    var out = c_in;
    for (var c = 0u; c < 3u; c++) {
        if (depth[c] > 0.0) {
            let tau = exp(-depth[c]);
            out[c] = tau * c_in[c] + (1.0 - tau) * weighted[c] / depth[c];
        }
    }
    image[idx] = vec4<f32>(out, 1.0);
}
