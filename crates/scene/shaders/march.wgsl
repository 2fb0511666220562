// The single-scattering march on the GPU: the twin of crates/scene's `march::radiance`
// for scenes whose heterogeneous media are voxel grids (smoke assets) and analytic fogs
// (paper D), one invocation per pixel, in f32. Over render.wgsl (its bindings, surfaces,
// shadow rays, BRDF and environment are shared), env_smoke.wgsl (the environment's light
// on the media) and haze_fogfn's fogfn.wgsl (which reads its records from `media`
// through `fog_record`); see `src/gpu/march.rs`.
//
// Positions are relative to the eye, as in render.wgsl.

#import render
#import env_smoke
#import fogfn

// The grids' values, one after the other (x fastest).
@group(0) @binding(7) var<storage, read> grid: array<f32>;
// media[0]: (grid count, step, most steps, smallest transmittance); per grid five records:
// (box min, g), (voxel size, first value in `grid`), (dims, -), (σt scale per channel, -),
// (albedo per channel, -); the environment's record (env_smoke.wgsl); the analytic fogs'
// head (fog count, -, -, -) and per fog three records: (σt per channel, index in `media`
// of its first closed-form record), (albedo per channel, g), (far, -, -, -); then the
// fogs' closed-form records (haze_fogfn::gpu::records), each fog's ended by its
// terminator.
@group(0) @binding(8) var<storage, read> media: array<vec4<f32>>;

// fogfn.wgsl's records: the fogs' closed forms are in `media`, after the grids'.
fn fog_record(i: u32) -> vec4<f32> {
    return media[i];
}

// Analytic fogs a march takes at most (gpu::march::MarchInput::of refuses more).
const FOG_MAX_MEDIA: u32 = 8u;

fn grid_base(i: u32) -> u32 {
    return 1u + 5u * i;
}

// voxel_grid::VoxelGrid::at_index: trilinear at continuous voxel coordinates u, clamped
// to [0, dims − 1].
fn grid_at(i: u32, u: vec3<f32>) -> f32 {
    let b = grid_base(i);
    let first = u32(media[b + 1u].w);
    let dims = media[b + 2u].xyz;
    let n = vec3<u32>(dims);
    let x = clamp(u, vec3<f32>(0.0), dims - 1.0);
    let i0 = min(vec3<u32>(floor(x)), max(n, vec3<u32>(2u)) - 2u);
    let f = x - vec3<f32>(i0);
    let i1 = min(i0 + 1u, n - 1u);
    let r0 = first + n.x * (i0.y + n.y * i0.z);
    let r1 = first + n.x * (i1.y + n.y * i0.z);
    let r2 = first + n.x * (i0.y + n.y * i1.z);
    let r3 = first + n.x * (i1.y + n.y * i1.z);
    let a = mix(grid[r0 + i0.x], grid[r0 + i1.x], f.x);
    let b1 = mix(grid[r1 + i0.x], grid[r1 + i1.x], f.x);
    let c = mix(grid[r2 + i0.x], grid[r2 + i1.x], f.x);
    let d = mix(grid[r3 + i0.x], grid[r3 + i1.x], f.x);
    return mix(mix(a, b1, f.y), mix(c, d, f.y), f.z);
}

// media::Aabb::clip of grid i: (t0, t1) with t0 > t1 for a miss. Written without
// per-axis loops, as everything the march repeats: lavapipe (llvmpipe) stops an
// invocation's loops after 65535 iterations in all.
fn grid_clip(i: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> vec2<f32> {
    let b = grid_base(i);
    let lo = media[b].xyz;
    let hi = lo + media[b + 2u].xyz * media[b + 1u].xyz;
    let flat = d == vec3<f32>(0.0);
    // Along an axis where d is zero: inside the slab or a miss.
    if (any(flat & ((o < lo) | (o > hi)))) {
        return vec2<f32>(1.0, 0.0);
    }
    let inv = 1.0 / select(d, vec3<f32>(1.0), flat);
    let a = (lo - o) * inv;
    let c = (hi - o) * inv;
    let near = select(min(a, c), vec3<f32>(-3.0e38), flat);
    let far = select(max(a, c), vec3<f32>(3.0e38), flat);
    return vec2<f32>(
        max(t_min, max(near.x, max(near.y, near.z))),
        min(t_max, min(far.x, min(far.y, far.z)))
    );
}

// voxel_grid::VoxelGrid::density: 0 outside the box.
fn grid_density(i: u32, x: vec3<f32>) -> f32 {
    let b = grid_base(i);
    let lo = media[b].xyz;
    let voxel = media[b + 1u].xyz;
    let hi = lo + media[b + 2u].xyz * voxel;
    if (any(x < lo) || any(x > hi)) {
        return 0.0;
    }
    return grid_at(i, (x - lo) / voxel - 0.5);
}

// voxel_grid::VoxelGrid::density_integral: Simpson's rule between consecutive planes
// through voxel centers (exact for the trilinear field's cubic pieces).
fn grid_integral(i: u32, o: vec3<f32>, d: vec3<f32>, len: f32) -> f32 {
    if (!(len > 0.0)) {
        return 0.0;
    }
    let span = grid_clip(i, o, d, 0.0, len);
    let t0 = span.x;
    let t1 = span.y;
    if (!(t1 > t0)) {
        return 0.0;
    }
    let b = grid_base(i);
    let voxel = media[b + 1u].xyz;
    let dims = media[b + 2u].xyz;
    let u0 = (o + t0 * d - media[b].xyz) / voxel - 0.5;
    let du = d / voxel;
    let pos = du > vec3<f32>(0.0);
    let moving = du != vec3<f32>(0.0);
    let step = select(vec3<f32>(3.0e38), 1.0 / abs(select(du, vec3<f32>(1.0), !moving)), moving);
    let frac = select(u0 - (ceil(u0) - 1.0), floor(u0) + 1.0 - u0, pos);
    var next = select(vec3<f32>(3.0e38), t0 + frac * step, moving);
    var sum = 0.0;
    var t = t0;
    var f_t = grid_at(i, u0);
    // A guard: a ray crosses at most dims.x + dims.y + dims.z + 3 planes.
    let most = u32(dims.x + dims.y + dims.z) + 8u;
    for (var n = 0u; n < most && t < t1; n++) {
        let tn = min(min(next.x, next.y), min(next.z, t1));
        let h = tn - t;
        if (h > 0.0) {
            let f_end = grid_at(i, u0 + (tn - t0) * du);
            let f_mid = grid_at(i, u0 + (t + 0.5 * h - t0) * du);
            sum += h / 6.0 * (f_t + 4.0 * f_mid + f_end);
            f_t = f_end;
        }
        t = tn;
        next = select(next, next + step, next <= vec3<f32>(t));
    }
    return sum;
}

// The voxel media's optical depth along o + t·d, t ∈ [0, len] (march::hetero_depth).
fn grids_depth(o: vec3<f32>, d: vec3<f32>, len: f32) -> vec3<f32> {
    var tau = vec3<f32>(0.0);
    for (var i = 0u; i < u32(media[0].x); i++) {
        let r = grid_integral(i, o, d, len);
        if (r > 0.0) {
            tau += media[grid_base(i) + 3u].xyz * r;
        }
    }
    return tau;
}

// The analytic fogs' head record.
fn fog_head() -> u32 {
    return 2u + 5u * u32(media[0].x);
}

fn fog_count() -> u32 {
    return u32(media[fog_head()].x);
}

// The first of fog k's three records.
fn fog_base(k: u32) -> u32 {
    return fog_head() + 1u + 3u * k;
}

// The analytic fogs' optical depth along o + t·d, t ∈ [0, min(len, far)] per fog
// (analytic::AnalyticMedium::optical_depth), by their closed forms.
fn fogs_depth(o: vec3<f32>, d: vec3<f32>, len: f32) -> vec3<f32> {
    var tau = vec3<f32>(0.0);
    for (var k = 0u; k < fog_count(); k++) {
        let b = fog_base(k);
        let a = media[b];
        let k_len = fog_depth_at(u32(a.w), o, d, min(len, media[b + 2u].x));
        tau += a.xyz * k_len;
    }
    return tau;
}

// The heterogeneous media's optical depth (march::hetero_depth: what attenuates a sun).
fn hetero_depth(o: vec3<f32>, d: vec3<f32>, len: f32) -> vec3<f32> {
    if (len <= 0.0) {
        return vec3<f32>(0.0);
    }
    return grids_depth(o, d, len) + fogs_depth(o, d, len);
}

// Every medium's optical depth (march::optical_depth): the homogeneous one's σt·len plus
// the heterogeneous media's.
fn total_depth(o: vec3<f32>, d: vec3<f32>, len: f32) -> vec3<f32> {
    if (len <= 0.0) {
        return vec3<f32>(0.0);
    }
    return max(P.sigma_t.xyz, vec3<f32>(0.0)) * len + hetero_depth(o, d, len);
}

// The light arriving at x from light i (march::lights_at): xyz the unit direction
// towards it, and the radiance scale in `scale`; false when a surface blocks it.
struct Arrival {
    lit: bool,
    l: vec3<f32>,
    e: vec3<f32>,
}

// `x_vis`: where shadow rays start for the surfaces' visibility (a surface point's
// offset along its normal; `x` itself in the medium): the media's depth is from `x`.
fn arrival(i: u32, x: vec3<f32>, x_vis: vec3<f32>) -> Arrival {
    let a = lights[3u * i];
    let eps = P.albedo.w;
    if (a.x == 0.0) {
        let v = a.yzw - x;
        let d = max(length(v), P.sigma_t.w);
        let l = v / d;
        if (!visible(x_vis, a.yzw, eps)) {
            return Arrival(false, l, vec3<f32>(0.0));
        }
        let tau = total_depth(x, l, d);
        return Arrival(true, l, lights[3u * i + 1u].xyz * exp(-tau) / (d * d));
    }
    let l = a.yzw;
    if (intersect(x_vis, l, eps * (1.0 + length(x_vis)), 3.0e38).surface >= 0) {
        return Arrival(false, l, vec3<f32>(0.0));
    }
    // Suns pass the homogeneous medium unattenuated (paper C's convention).
    let tau = hetero_depth(x, l, 3.0e38);
    return Arrival(true, l, lights[3u * i + 2u].xyz * exp(-tau));
}

// Light scattered once towards −dir at x (march::in_scattered).
fn in_scattered(x: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let count = u32(media[0].x);
    var any_s = any(P.sigma_s.xyz > vec3<f32>(0.0));
    for (var m = 0u; m < count; m++) {
        let b = grid_base(m);
        if (grid_density(m, x) * max(max(media[b + 3u].x, media[b + 3u].y), media[b + 3u].z) > 0.0) {
            any_s = true;
        }
    }
    // Each fog's σs at x: σt·K(x)·albedo (its K read once).
    let fogs = fog_count();
    var fog_k = array<f32, FOG_MAX_MEDIA>();
    for (var k = 0u; k < min(fogs, FOG_MAX_MEDIA); k++) {
        let b = fog_base(k);
        fog_k[k] = fog_density_at(u32(media[b].w), x);
        if (any(media[b].xyz * fog_k[k] * media[b + 1u].xyz > vec3<f32>(0.0))) {
            any_s = true;
        }
    }
    if (!any_s) {
        return vec3<f32>(0.0);
    }
    var out = vec3<f32>(0.0);
    for (var i = 0u; i < P.size.z; i++) {
        let arr = arrival(i, x, x);
        if (!arr.lit) {
            continue;
        }
        let c = dot(dir, arr.l);
        var s = max(P.sigma_s.xyz, vec3<f32>(0.0)) / (4.0 * PI);
        for (var m = 0u; m < count; m++) {
            let b = grid_base(m);
            let rho = grid_density(m, x);
            if (rho > 0.0) {
                s += media[b + 3u].xyz * rho * media[b + 4u].xyz * hg_phase(media[b].w, c);
            }
        }
        for (var k = 0u; k < min(fogs, FOG_MAX_MEDIA); k++) {
            let b = fog_base(k);
            s += media[b].xyz * fog_k[k] * media[b + 1u].xyz * hg_phase(media[b + 1u].w, c);
        }
        out += s * arr.e;
    }
    return out;
}

// march::medium_span: where the camera ray holds extinction (t0 > t1 for nowhere).
fn medium_span(dir: vec3<f32>, t_end: f32) -> vec2<f32> {
    if (any(P.sigma_t.xyz > vec3<f32>(0.0))) {
        return vec2<f32>(0.0, t_end);
    }
    var span = vec2<f32>(1.0, 0.0);
    // An analytic fog holds extinction up to its far.
    for (var k = 0u; k < fog_count(); k++) {
        span = vec2<f32>(0.0, max(span.y, min(t_end, media[fog_base(k) + 2u].x)));
    }
    for (var m = 0u; m < u32(media[0].x); m++) {
        let s = grid_clip(m, vec3<f32>(0.0), dir, 0.0, t_end);
        if (s.x <= s.y) {
            if (span.x > span.y) {
                span = s;
            } else {
                span = vec2<f32>(min(span.x, s.x), max(span.y, s.y));
            }
        }
    }
    return span;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    // The K and G tables are render.wgsl's; bound here too, though the march reads none.
    _ = tables[0];
    let w = P.size.x;
    let h = P.size.y;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let dir = pixel_dir(vec2<f32>(id.xy) + 0.5);

    let env_far = P.flags.y == 0u;
    let t_max = primary_t_max();
    let hit = intersect(vec3<f32>(0.0), dir, 0.0, t_max);
    let t_end = hit.t;
    // A march longer than P.tables.z steps (0: no limit) goes on in the next dispatch of
    // the same pass: its state after the image, two vec4 per pixel — (radiance so far, t),
    // (transmittance, steps taken + 1; 0 before the first dispatch, −1 once done).
    // Lavapipe ends an invocation's loops after 65535 iterations in all; a dispatch per
    // chunk of steps gives each its own budget (gpu::march module docs).
    let idx = id.y * w + id.x;
    let chunk = P.tables.z;
    let at = w * h + 2u * idx;
    var out = vec3<f32>(0.0);
    var trans = vec3<f32>(1.0);
    var faded = false;
    let span = medium_span(dir, t_end);
    var t = span.x;
    var steps = 0u;
    if (chunk > 0u && image[at + 1u].w != 0.0) {
        if (image[at + 1u].w < 0.0) {
            return;
        }
        out = image[at].xyz;
        t = image[at].w;
        trans = image[at + 1u].xyz;
        steps = u32(image[at + 1u].w) - 1u;
    } else if (span.x <= span.y) {
        trans = exp(-total_depth(vec3<f32>(0.0), dir, span.x));
    }
    if (span.x <= span.y) {
        let step_len = media[0].y;
        let most = u32(media[0].z);
        var taken = 0u;
        while (t < span.y && steps < most) {
            if (chunk > 0u && taken == chunk) {
                image[at] = vec4<f32>(out, t);
                image[at + 1u] = vec4<f32>(trans, f32(steps + 1u));
                return;
            }
            let hs = min(step_len, span.y - t);
            let mid = (t + 0.5 * hs) * dir;
            let first = total_depth(t * dir, dir, 0.5 * hs);
            let second = total_depth(mid, dir, 0.5 * hs);
            let j = in_scattered(mid, dir) + env_in_scattered(mid, dir);
            out += trans * exp(-first) * j * hs;
            trans *= exp(-(first + second));
            t += hs;
            steps += 1u;
            taken += 1u;
            if (all(trans < vec3<f32>(media[0].w))) {
                faded = true;
                break;
            }
        }
    }
    if (chunk > 0u) {
        image[at + 1u] = vec4<f32>(0.0, 0.0, 0.0, -1.0);
    }
    if (!faded) {
        var behind = vec3<f32>(0.0);
        if (hit.surface >= 0) {
            let s = u32(hit.surface);
            let p = t_end * dir;
            let n = hit_normal(hit, p, dir);
            let diffuse = surfaces[4u * s + 2u].xyz;
            let m = surfaces[4u * s + 2u].w;
            let specular = surfaces[4u * s + 3u].xyz;
            let r = 2.0 * dot(-dir, n) * n + dir;
            let p_off = p + P.albedo.w * (1.0 + length(p)) * n;
            for (var i = 0u; i < P.size.z; i++) {
                let arr = arrival(i, p, p_off);
                if (arr.lit) {
                    behind += brdf(n, r, arr.l, diffuse, specular, m) * arr.e;
                }
            }
        } else if (env_far || any(P.sigma_t.xyz <= vec3<f32>(0.0))) {
            behind = background(dir);
        }
        out += trans * behind;
    }
    image[idx] = vec4<f32>(out, 1.0);
}
