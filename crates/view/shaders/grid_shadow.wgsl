// The density grid and the ground's shadow rays through it (`field::sample`,
// `ground::ShadowMarch`), for the shaders that declare what it reads: `p` with `size`
// (the box's maximum corner, box-local), `voxel`, `dims` and `sigma_t`; `grid`, a `vec4`
// per voxel with D in w; and `occupancy` (`occupancy.wgsl`'s blocks). The view pass and
// the ground's sky (`ground_sky.wgsl`) import it.
#import block_skip
#import shadow_cutoff

// `field::ray_box` on [0, size]: (t0, t1, 1) where the ray o + t·d is inside, t0 ≥ 0, or
// z = 0 when it misses.
fn ray_box(o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    var t0 = 0.0;
    var t1 = 3.0e38;
    for (var a = 0u; a < 3u; a++) {
        if d[a] == 0.0 {
            if o[a] < 0.0 || o[a] > p.size[a] {
                return vec3<f32>(0.0);
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let ta = -o[a] * inv;
        let tb = (p.size[a] - o[a]) * inv;
        t0 = max(t0, min(ta, tb));
        t1 = min(t1, max(ta, tb));
    }
    if t0 <= t1 && t1 < 3.0e38 {
        return vec3<f32>(t0, t1, 1.0);
    }
    return vec3<f32>(0.0);
}

// The trilinear stencil of `field::sample` at box-local point q inside the box: the
// cell's lower and upper voxels per axis and q's fractions between them (constant to
// the box's faces).
struct Stencil {
    i0: vec3<u32>,
    i1: vec3<u32>,
    t: vec3<f32>,
}

fn stencil(q: vec3<f32>) -> Stencil {
    let n = p.dims;
    let f = clamp(q / p.voxel - 0.5, vec3<f32>(0.0), vec3<f32>(n) - 1.0);
    let i0 = min(vec3<u32>(floor(f)), max(n, vec3<u32>(2u)) - 2u);
    return Stencil(i0, min(i0 + 1u, n - 1u), f - vec3<f32>(i0));
}

// Corner c (bit a: the upper voxel along axis a) of stencil s: its voxel's index in
// `grid` and its trilinear weight in w.
struct Corner {
    index: u32,
    w: f32,
}

fn corner(s: Stencil, c: u32) -> Corner {
    let hi = vec3<u32>(c & 1u, (c >> 1u) & 1u, c >> 2u) == vec3<u32>(1u);
    let k = select(s.i0, s.i1, hi);
    let w = select(1.0 - s.t, s.t, hi);
    return Corner(k.x + p.dims.x * (k.y + p.dims.y * k.z), w.x * w.y * w.z);
}

// Whether box-local q lies in a box with voxels (outside, every field is 0).
fn in_grid(q: vec3<f32>) -> bool {
    return !any(p.dims == vec3<u32>(0u)) && all(q >= vec3<f32>(0.0)) && all(q <= p.size);
}

// `field::sample`: the trilinear density D at box-local point q, 0 outside the box.
fn sample_density(q: vec3<f32>) -> f32 {
    if !in_grid(q) {
        return 0.0;
    }
    let s = stencil(q);
    var dq = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let k = corner(s, c);
        dq += k.w * grid[k.index].w;
    }
    return dq;
}

// `ground::ShadowMarch::transmittance`: exp(−σt ∫ D) from box-local x along the unit w
// over the distance len, by the midpoint rule in steps of at most the view pass's slice
// thickness p.du, the steps in empty blocks passed over as the view rays do (the same
// samples count); 0 once σt·τ passes SHADOW_CUTOFF.
fn shadow(x: vec3<f32>, w: vec3<f32>, len: f32) -> f32 {
    let hit = ray_box(x, w);
    if hit.z == 0.0 {
        return 1.0;
    }
    let t0 = hit.x;
    let t1 = min(hit.y, len);
    let h = p.du;
    if !(p.sigma_t > 0.0 && h > 0.0 && t1 > t0) {
        return 1.0;
    }
    let steps = u32(min(ceil((t1 - t0) / h), 1.0e6));
    let dt = (t1 - t0) / f32(steps);
    let side = f32(OCCUPANCY_BLOCK) * p.voxel;
    let blocks = (p.dims + OCCUPANCY_BLOCK - 1u) / OCCUPANCY_BLOCK;
    var depth = 0.0;
    var k = 0u;
    loop {
        if k >= steps {
            break;
        }
        let t = t0 + (f32(k) + 0.5) * dt;
        let q = x + t * w;
        let b = block_of(q, side, blocks);
        if occupancy[b.x + blocks.x * (b.y + blocks.y * b.z)] == 0u {
            // To the last step before the block's exit (rounded down, at least one on).
            let next = floor((t + max(block_exit(q, w, b, side), 0.0) - t0) / dt - 0.5);
            k = max(u32(max(next, 0.0)), k + 1u);
            continue;
        }
        depth += sample_density(q);
        if p.sigma_t * depth * dt > SHADOW_CUTOFF {
            return 0.0;
        }
        k++;
    }
    if depth > 0.0 {
        return exp(-p.sigma_t * depth * dt);
    }
    return 1.0;
}
