// View pass of compensated ray marching (paper A §5.5, eq. 16): the GPU twin of
// `render::crm::view_pass`, in f32, one invocation per pixel.
//
// Slices perpendicular to the camera axis, `du` apart, are crossed by the pixel's ray at
// u_i (t = (k + ½)·Δs with Δs = du / cos γ, γ the angle to the axis); each slice has
// transmittance Δτ_i = exp(−σt·D(u_i)·Δs). Front to back, with early exit once the
// transmittance falls below OPAQUE:
//
//     L = L_env(d)·Π Δτ_j + Σ_i J̃(u_i)·(1 − Δτ_i)·Π_{j<i} Δτ_j
//
// where multiple scattering left HG's forward peak f to the eye's ray (`keep = 1 − Ωf`,
// `grid_diffusion::add_to_grids`), J̃'s light goes through σt·keep instead:
// J̃(u_i)·(1 − Δτ_i^keep)/keep·Π_{j<i} Δτ_j^keep, and the march stops on that transmittance.
//
// D and J̃_D = D·J̃ (eq. 15) are trilinear between voxel centers, J̃ = J̃_D/D, with the
// stencil of `field::sample`
// (constant to the box's faces, zero outside), done by hand on a storage buffer so the
// weights are exact f32 rather than a sampler's fixed-point ones. Positions are relative
// to the box's minimum corner, which keeps f32 precise for boxes far from the origin.

struct Params {
    // Eye relative to the box's minimum corner.
    eye: vec3<f32>,
    // tan(fov / 2).
    tan_half: f32,
    forward: vec3<f32>,
    // width / height.
    aspect: f32,
    right: vec3<f32>,
    sigma_t: f32,
    up: vec3<f32>,
    du: f32,
    // Box size (its maximum corner, relative to its minimum).
    size: vec3<f32>,
    // 0: the built-in sky below, 1: the lat-long map in `env_map`.
    env_kind: u32,
    voxel: vec3<f32>,
    // Suns whose disks are in `suns`.
    suns: u32,
    dims: vec3<u32>,
    // Lights of the ground in `ground_lights`.
    ground_lights: u32,
    image: vec2<u32>,
    env_size: vec2<u32>,
    zenith: vec3<f32>,
    sharpness: f32,
    horizon: vec3<f32>,
    // The ground's height, box-local.
    ground_z: f32,
    ground: vec3<f32>,
    // 1: camera rays meet a ground (`ground::GroundLight`), 0: none.
    has_ground: u32,
    sun_direction: vec3<f32>,
    // 1 − Ωf: the scattered light's share of σt on the way to the eye
    // (`VolumeGrids::eye_peak`; 1 for single scattering).
    keep: f32,
    sun: vec3<f32>,
    // HG asymmetry.
    g: f32,
    // ρ/π · E_sky of the ground.
    ground_sky: vec3<f32>,
    // R, the radius about a point light inside which its light is this pass's
    // (`near_light`).
    near_radius: f32,
    // Point lights in `near_lights`.
    near_lights: u32,
    // The spacing of the nodes of the ground's sky share (in `ground_lights`).
    sky_cell: f32,
    // Nodes per side of the sky's share; 0: the open sky (V = 1).
    sky_nodes: u32,
    // Where the sky's share starts in `ground_lights`.
    sky_first: u32,
    // Node (0, 0) of the sky's share, box-local x, y.
    sky_origin: vec2<f32>,
    _pad8: u32,
    _pad9: u32,
}

// Transmittance below which the march stops (`crm::OPAQUE`).
const OPAQUE: f32 = 1e-4;
// ln `crm::MAX_SPAN` (10³): the largest ratio across a cell the geometric mean of J̃
// spans.
const LN_MAX_SPAN: f32 = 6.9077552789821;
#import ln_radiance
#import optics
#import lat_long
#import block_skip
#import shadow_cutoff
#import grid_shadow

@group(0) @binding(0) var<storage, read> p: Params;
// Per voxel (x fastest): ln J̃ in xyz (UNLIT where J̃ = 0; `view_grid.wgsl`), D in w.
@group(0) @binding(1) var<storage, read> grid: array<vec4<f32>>;
// Lat-long texels, RGB, row 0 at the zenith.
@group(0) @binding(2) var<storage, read> env_map: array<f32>;
@group(0) @binding(3) var<storage, read_write> pixels: array<vec4<f32>>;
// Two per sun with a disk (`Environment::radiance`): (unit direction towards it,
// cos(angle/2)), (disk radiance, 0).
@group(0) @binding(4) var<storage, read> suns: array<vec4<f32>>;
// Two per light of the ground: (unit direction towards a sun, 0) or (box-local position
// of a point light, 1); (ρ/π · irradiance or intensity, 0). From `sky_first` on, the
// sky's share that reaches the ground per node of its grid (`ground_sky.wgsl`), in xyz.
@group(0) @binding(5) var<storage, read> ground_lights: array<vec4<f32>>;
// Per block of OCCUPANCY_BLOCK³ voxels (x fastest) whether a sample there may see
// density (`occupancy.wgsl`): in an empty block `sample_grid` is exactly 0.
@group(0) @binding(6) var<storage, read> occupancy: array<u32>;
// Two per point light (`gpu::view_pass::near_lights`): (box-local position, 0), (Ω/4π·I, 0).
@group(0) @binding(7) var<storage, read> near_lights: array<vec4<f32>>;


// `Camera::pixel_ray`: through the center of pixel (x, y), row 0 at the top.
fn pixel_ray(x: u32, y: u32) -> vec3<f32> {
    let px = f32(x) + 0.5;
    let py = f32(y) + 0.5;
    let sx = (2.0 * px / f32(p.image.x) - 1.0) * p.tan_half * p.aspect;
    let sy = (1.0 - 2.0 * py / f32(p.image.y)) * p.tan_half;
    return normalize(p.forward + sx * p.right + sy * p.up);
}

// `crm::sample_radiance` and `field::sample` at box-local point q, zero outside the box:
// (J̃, D), J̃ per channel the geometric mean of the stencil's corners by their trilinear
// weights, exp(Σ w_k ln max(J̃_k, J̃_max/MAX_SPAN)) (decision 0049: the light falls as
// e^{−τ} and τ is what is smooth across a cell); the empty corners are the smoke's shell,
// lit at their own centers. 0 where D(q) ≤ 0 or every corner is unlit.
fn sample_grid(q: vec3<f32>) -> vec4<f32> {
    if !in_grid(q) {
        return vec4<f32>(0.0);
    }
    let s = stencil(q);
    var corners: array<vec4<f32>, 8>;
    var weights: array<f32, 8>;
    var dq = 0.0;
    for (var c = 0u; c < 8u; c++) {
        let k = corner(s, c);
        corners[c] = grid[k.index];
        weights[c] = k.w;
        dq += weights[c] * corners[c].w;
    }
    if !(dq > 0.0) {
        return vec4<f32>(0.0);
    }
    // J̃: the corners' geometric mean by their trilinear weights, each corner floored
    // at the cell's brightest over MAX_SPAN (`crm::sample_radiance`, decision 0049), in
    // logarithms (`view_grid.wgsl` took them once a voxel).
    var top = vec3<f32>(UNLIT);
    for (var c = 0u; c < 8u; c++) {
        top = max(top, corners[c].xyz);
    }
    let floor_ln = max(top - LN_MAX_SPAN, vec3<f32>(LN_MIN_NORMAL));
    var ln_j = vec3<f32>(0.0);
    for (var c = 0u; c < 8u; c++) {
        ln_j += weights[c] * max(corners[c].xyz, floor_ln);
    }
    let j = select(vec3<f32>(0.0), exp(ln_j), top > vec3<f32>(UNLIT));
    return vec4<f32>(j, dq);
}

// `Sky::radiance`.
fn sky(d: vec3<f32>) -> vec3<f32> {
    let n = length(d);
    if !(n > 0.0) {
        return p.zenith;
    }
    let u = d / n;
    // Below the horizon the ground, which the glow does not reach (`distant::Sky`).
    if u.z < 0.0 {
        return p.ground;
    }
    let out = mix(p.horizon, p.zenith, u.z);
    let c = max(dot(u, p.sun_direction), 0.0);
    var glow = 0.0;
    if c > 0.0 {
        glow = pow(c, p.sharpness);
    } else if p.sharpness == 0.0 {
        glow = 1.0;
    }
    return out + p.sun * glow;
}

fn texel(x: u32, y: u32) -> vec3<f32> {
    let i = 3u * (y * p.env_size.x + x);
    return vec3<f32>(env_map[i], env_map[i + 1u], env_map[i + 2u]);
}

// `LatLong::radiance` of the environment map.
fn lat_long(d: vec3<f32>) -> vec3<f32> {
    let s = lat_long_stencil(d, p.env_size);
    return lat_long_blend(s, texel(s.xa, s.ya), texel(s.xb, s.ya), texel(s.xa, s.yb), texel(s.xb, s.yb));
}

// `Environment::radiance`: the distant radiance plus the disks of the suns (`Sun::covers`)
// in the unit direction d.
fn environment(d: vec3<f32>) -> vec3<f32> {
    var out: vec3<f32>;
    if p.env_kind == 1u {
        out = lat_long(d);
    } else {
        out = sky(d);
    }
    for (var i = 0u; i < p.suns; i++) {
        let s = suns[2u * i];
        if dot(d, s.xyz) >= s.w {
            out += suns[2u * i + 1u].xyz;
        }
    }
    return out;
}

// `lights_pass::optical_depth`: σt·τ from box-local x along the unit s over at most
// max_len, the midpoint rule in n = ⌈ℓ/h0⌉ equal steps over ℓ, the distance to the box's
// face or max_len, h0 the smallest voxel side; stops once past SHADOW_CUTOFF.
fn light_depth(x: vec3<f32>, s: vec3<f32>, max_len: f32) -> f32 {
    let hit = ray_box(x, s);
    let h0 = min(p.voxel.x, min(p.voxel.y, p.voxel.z));
    if hit.z == 0.0 || !(p.sigma_t > 0.0) {
        return 0.0;
    }
    let len = min(hit.y, max_len);
    if !(len > 0.0) {
        return 0.0;
    }
    let n = max(ceil(len / h0), 1.0);
    let h = len / n;
    let k0 = u32(max(floor(hit.x / h - 1.0), 0.0));
    let k1 = u32(min(max(ceil(hit.y / h + 1.0), 0.0), n));
    var depth = 0.0;
    for (var k = k0; k < k1; k++) {
        depth += p.sigma_t * sample_density(x + (f32(k) + 0.5) * h * s) * h;
        if depth > SHADOW_CUTOFF {
            break;
        }
    }
    return depth;
}

// Gauss–Legendre nodes and weights on [−1, 1], 6 points (`near_light::NODES`).
const GL_X = array<f32, 6>(-0.9324695142, -0.6612093865, -0.2386191861, 0.2386191861, 0.6612093865, 0.9324695142);
const GL_W = array<f32, 6>(0.1713244924, 0.3607615730, 0.4679139346, 0.4679139346, 0.3607615730, 0.1713244924);

// `NearLights::chord_integral`: ∫ p(cos θ)(1/r² − 1/R²) du over u ∈ [lo, hi] for a ray
// passing at h from the light, in the angle φ = atan(u/h) seen from it.
fn chord_integral(h: f32, lo: f32, hi: f32) -> f32 {
    let a = atan(lo / h);
    let b = atan(hi / h);
    let mid = 0.5 * (a + b);
    let half = 0.5 * (b - a);
    let r2 = p.near_radius * p.near_radius;
    var sum = 0.0;
    for (var i = 0u; i < 6u; i++) {
        let phi = mid + half * GL_X[i];
        let c = cos(phi);
        let flat = max(1.0 - h * h / (r2 * c * c), 0.0);
        sum += GL_W[i] * hg_lobe(p.g, -sin(phi)) * flat;
    }
    return max(sum * half / h, 0.0);
}

// `NearLights::at_step`: the point lights' light inside their spheres of radius R at the
// step [t − ds/2, t + ds/2] of the ray along unit d, per unit of the step's optical depth.
fn near_at_step(d: vec3<f32>, t: f32, ds: f32) -> vec3<f32> {
    var out = vec3<f32>(0.0);
    let radius = p.near_radius;
    for (var i = 0u; i < p.near_lights; i++) {
        let at = near_lights[2u * i].xyz;
        let v = at - p.eye;
        let foot = dot(v, d);
        var h = length(v - foot * d);
        if !(h < radius && foot + radius > 0.0) {
            continue;
        }
        // A ray through the light: h floored at a sixteenth of the pixel's side there.
        let side = 2.0 * p.tan_half / f32(p.image.y) * max(dot(v, p.forward), 0.0);
        h = max(max(h, side / 16.0), 1e-9 * radius);
        if !(h < radius) {
            continue;
        }
        let half_chord = sqrt(max(radius * radius - h * h, 0.0));
        let lo = max(t - 0.5 * ds - foot, -half_chord);
        let hi = min(t + 0.5 * ds - foot, half_chord);
        if hi <= lo || !(ds > 0.0) {
            continue;
        }
        let x = p.eye + t * d;
        let w = at - x;
        let r = length(w);
        var tr = 1.0;
        if r > 0.0 {
            tr = exp(-light_depth(x, w / r, r));
        }
        out += near_lights[2u * i + 1u].xyz * (tr * chord_integral(h, lo, hi) / ds);
    }
    return out;
}

// `SkyGrid::at`: the sky's share at the box-local ground point x, bilinear between the
// nodes, 1 outside the grid (and without one).
fn sky_share(x: vec3<f32>) -> vec3<f32> {
    let n = p.sky_nodes;
    if n < 2u {
        return vec3<f32>(1.0);
    }
    let f = (x.xy - p.sky_origin) / p.sky_cell;
    let top = f32(n - 1u);
    if !(all(f >= vec2<f32>(0.0)) && all(f <= vec2<f32>(top))) {
        return vec3<f32>(1.0);
    }
    let i0 = min(vec2<u32>(floor(f)), vec2<u32>(n - 2u));
    let t = f - vec2<f32>(i0);
    let k = p.sky_first + i0.x + n * i0.y;
    let a = ground_lights[k].xyz;
    let b = ground_lights[k + 1u].xyz;
    let c = ground_lights[k + n].xyz;
    let d = ground_lights[k + n + 1u].xyz;
    return (1.0 - t.y) * ((1.0 - t.x) * a + t.x * b) + t.y * ((1.0 - t.x) * c + t.x * d);
}

// `GroundLight::radiance` at the box-local ground point x, the smoke's shadow marched,
// the sky's share from its grid.
fn ground_radiance(x: vec3<f32>) -> vec3<f32> {
    var out = p.ground_sky * sky_share(x);
    for (var i = 0u; i < p.ground_lights; i++) {
        let a = ground_lights[2u * i];
        let e = ground_lights[2u * i + 1u].xyz;
        if a.w == 0.0 {
            if a.z > 0.0 {
                out += e * (a.z * shadow(x, a.xyz, 3.0e38));
            }
        } else {
            let v = a.xyz - x;
            let r2 = dot(v, v);
            if r2 > 0.0 && v.z > 0.0 {
                let r = sqrt(r2);
                let w = v / r;
                out += e * (w.z / r2 * shadow(x, w, r));
            }
        }
    }
    return out;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= p.image.x || id.y >= p.image.y {
        return;
    }
    let d = pixel_ray(id.x, id.y);
    var background = environment(d);
    // `GroundLight::hit`: the ground replaces the environment where the ray meets it.
    if p.has_ground == 1u && d.z < 0.0 && p.eye.z > p.ground_z {
        let t = (p.eye.z - p.ground_z) / -d.z;
        background = ground_radiance(vec3<f32>(p.eye.xy + t * d.xy, p.ground_z));
    }
    let cos_g = max(dot(d, p.forward), 1e-6);
    let hit = ray_box(p.eye, d);
    var out = vec3<f32>(0.0);
    var tau = 1.0;
    // The scattered light's transmittance, through σt·keep (`VolumeGrids::eye_peak`).
    var tau_j = 1.0;
    var optical = 0.0;
    var opaque = false;
    // A grid without voxels has no density to sample (`sample_grid` is 0 everywhere).
    if hit.z > 0.0 && all(p.dims > vec3<u32>(0u)) {
        let ds = p.du / cos_g;
        // Slice planes at axis distances k·du from the eye; the ray meets plane k at
        // t = k·du / cos γ. An integer counter: a float one stalls past 2²⁴.
        let k0 = max(floor(hit.x * cos_g / p.du), 0.0);
        let k1 = ceil(hit.y * cos_g / p.du);
        let count = u32(max(k1 - k0, 0.0));
        let side = f32(OCCUPANCY_BLOCK) * p.voxel;
        let blocks = (p.dims + OCCUPANCY_BLOCK - 1u) / OCCUPANCY_BLOCK;
        var i = 0u;
        loop {
            if i > count {
                break;
            }
            let t = (k0 + f32(i) + 0.5) * ds;
            if t < hit.x || t > hit.y {
                i++;
                continue;
            }
            let q = p.eye + t * d;
            // A sample in an empty block adds nothing (`sample_grid` is 0 there): jump to
            // the last slice before the block's exit (rounded down, at least one on), so
            // the samples that count are the same, in the same order.
            let b = block_of(q, side, blocks);
            if occupancy[b.x + blocks.x * (b.y + blocks.y * b.z)] == 0u {
                let out = block_exit(q, d, b, side);
                let next = floor((t + max(out, 0.0)) / ds - 0.5 - k0);
                i = max(u32(max(next, 0.0)), i + 1u);
                continue;
            }
            let s = sample_grid(q);
            if s.w <= 0.0 {
                i++;
                continue;
            }
            var j = s.xyz;
            if p.near_lights > 0u {
                j += near_at_step(d, t, ds);
            }
            let a = p.sigma_t * s.w * ds;
            // The background's transmittance through σt, e^{−Σ a}, is taken once after
            // the march (`crm::march` without a depth).
            optical += a;
            // `crm::scattered_step`: (1 − e^{−x})/keep with x = keep·a, by its series
            // a(1 − x/2) below x = 10⁻³ (f32's 1 − e^{−x} cancels there).
            let x = p.keep * a;
            let dt_j = exp(-x);
            let share = select((1.0 - dt_j) / p.keep, a * (1.0 - 0.5 * x), x < 1e-3);
            out += tau_j * j * share;
            tau_j *= dt_j;
            if tau_j < OPAQUE {
                opaque = true;
                break;
            }
            i++;
        }
        tau = select(exp(-optical), 0.0, opaque);
    }
    pixels[id.y * p.image.x + id.x] = vec4<f32>(out + tau * background, 1.0);
}
