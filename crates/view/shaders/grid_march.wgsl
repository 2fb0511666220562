// The shadow march shared by the lights pass and the environment pass of the fast
// renderer (a module imported by each; both declare `p` with `dims`, `size`, `voxel`, `h0` and
// `sigma_t`, and the grid of the volume pass as `grid`): D trilinear in the grid, and
// σt·τ by the midpoint rule of `render::lights_pass::optical_depth`.

// −expm1(−x) = 1 − e^{−x} without cancellation for small x ≥ 0.
fn one_minus_exp(x: f32) -> f32 {
    if x < 1e-3 {
        return x * (1.0 - x * (0.5 - x / 6.0));
    }
    return 1.0 - exp(-x);
}

#import shadow_cutoff

fn density(i: vec3<u32>) -> f32 {
    return grid[4u * (i.x + p.dims.x * (i.y + p.dims.y * i.z)) + 3u];
}

// `field::sample`: D trilinear at box-local q, constant to the faces, zero outside.
fn sample_density(q: vec3<f32>) -> f32 {
    let n = p.dims;
    if !(all(q >= vec3<f32>(0.0)) && all(q <= p.size)) {
        return 0.0;
    }
    let f = clamp(q / p.voxel - 0.5, vec3<f32>(0.0), vec3<f32>(n) - 1.0);
    let i0 = min(vec3<u32>(floor(f)), max(n, vec3<u32>(2u)) - 2u);
    let t = f - vec3<f32>(i0);
    let i1 = min(i0 + 1u, n - 1u);
    let c00 = mix(density(i0), density(vec3<u32>(i1.x, i0.y, i0.z)), t.x);
    let c10 = mix(density(vec3<u32>(i0.x, i1.y, i0.z)), density(vec3<u32>(i1.x, i1.y, i0.z)), t.x);
    let c01 = mix(density(vec3<u32>(i0.x, i0.y, i1.z)), density(vec3<u32>(i1.x, i0.y, i1.z)), t.x);
    let c11 = mix(density(vec3<u32>(i0.x, i1.y, i1.z)), density(i1), t.x);
    return mix(mix(c00, c10, t.y), mix(c01, c11, t.y), t.z);
}

// Distance from u (inside the box) along the unit s to the box's face (`field::ray_box`'s
// t1); 0 when there is none.
fn exit_distance(u: vec3<f32>, s: vec3<f32>) -> f32 {
    var t1 = 3.0e38;
    for (var a = 0u; a < 3u; a++) {
        if s[a] == 0.0 {
            if u[a] < 0.0 || u[a] > p.size[a] {
                return 0.0;
            }
            continue;
        }
        let inv = 1.0 / s[a];
        t1 = min(t1, max(-u[a] * inv, (p.size[a] - u[a]) * inv));
    }
    return select(0.0, t1, t1 < 3.0e38);
}

// `lights_pass::optical_depth`: σt·τ from u along s to the box's face or max_len.
fn optical_depth(u: vec3<f32>, s: vec3<f32>, max_len: f32) -> f32 {
    let len = min(exit_distance(u, s), max_len);
    if !(len > 0.0) {
        return 0.0;
    }
    // An integer count: a float one stalls past 2²⁴.
    let n = u32(max(ceil(len / p.h0), 1.0));
    let h = len / f32(n);
    var depth = 0.0;
    for (var k = 0u; k < n; k++) {
        let t = (f32(k) + 0.5) * h;
        depth += p.sigma_t * sample_density(u + t * s) * h;
        if depth > SHADOW_CUTOFF {
            break;
        }
    }
    return depth;
}

// `lights_pass::transmittance`: exp(−σt·τ) from u along s to the face or max_len.
fn transmittance(u: vec3<f32>, s: vec3<f32>, max_len: f32) -> f32 {
    if p.sigma_t == 0.0 {
        return 1.0;
    }
    return exp(-optical_depth(u, s, max_len));
}
