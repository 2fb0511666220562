// Lights pass of the fast renderer: the GPU twin of `render::lights_pass::lights_pass`, in
// f32, one invocation per voxel center u, in place on the volume pass's grid.
//
// Where D(u) > 0, seen along d = (u − eye)/|u − eye|, each light adds
//
//     J(u, d) += (Ω/4π)·E(u)·T(u)·p(s·d)
//
// with s the unit vector towards the light. A sun: E its irradiance, p the disk-averaged
// HG (`DiskPhase`: a table over θc ∈ [0, π], linear in θc; exact HG for a zero-angle sun).
// A point light of intensity I at P: E = I/max(|P − u|², soft), p = HG (soft = R², R four
// voxels: the view pass adds the rest of 1/r² inside that sphere, `near_light`), and a
// light at the voxel center itself adds I/soft, isotropic and unshadowed. The transmittance
// T = exp(−σt·τ) is marched through D (the grid's w, the shadow volume): the midpoint rule
// over n = ⌈ℓ/h0⌉ equal steps h = ℓ/n, ℓ the distance to the box's face along s (or to a
// point light inside the box), D trilinear with `field::sample`'s stencil; the march stops
// once σt·τ > SHADOW_CUTOFF.
//
// Two entry points: `shadow` writes T per voxel with D > 0 and light (the shadow volume:
// it depends on D, σt and the lights' directions and positions, not on the eye, g, the
// albedo or the lights' power, so the renderer keeps it across camera moves), `main` adds
// the lights from it.
//
// In place: invocation u writes the xyz (J) words of its own voxel only and reads the
// w (D) words of any voxel, which nobody writes, so the invocations do not race. The grid
// is bound as flat f32 words (4 per voxel) so that every access touches one word.
// Positions are relative to the box's minimum corner (f32 precision far from the origin).

#import grid_march
#import lit
#import disk_phase

struct Params {
    // Eye relative to the box's minimum corner.
    eye: vec3<f32>,
    sigma_t: f32,
    voxel: vec3<f32>,
    // The march's step bound: the smallest voxel side.
    h0: f32,
    // Box size (its maximum corner, relative to its minimum).
    size: vec3<f32>,
    // R², the floor under a point light's r² (`near_light::NEAR_RADIUS_VOXELS`).
    soft: f32,
    dims: vec3<u32>,
    suns: u32,
    points: u32,
    // HG asymmetry.
    g: f32,
    // Ω/4π.
    k: f32,
    _pad: u32,
}

const NONE: u32 = 0xffffffffu;

@group(0) @binding(0) var<storage, read> p: Params;
// Eight words per light, suns first: a sun (direction towards it, x y z; its table's first
// word; irradiance r g b; its table's length, 0 for exact HG), a point light (position
// relative to the box, x y z; the linear index of the voxel whose center it is, NONE if
// none; intensity r g b; 0); then the suns' DiskPhase tables. f32 values as their bits.
@group(0) @binding(1) var<storage, read> lights: array<u32>;
// Per voxel (x fastest): J̃ r g b, D.
@group(0) @binding(2) var<storage, read_write> grid: array<f32>;
// T per voxel (x fastest) and light (suns then point lights, fastest): `shadow` writes it
// at the lit voxels, `main` reads it.
@group(0) @binding(3) var<storage, read_write> shadow_t: array<f32>;

// The voxel index of invocation i when it is a lit voxel (D > 0 or the smoke's shell,
// `lit`), else NONE.
fn smoke_voxel(i: vec3<u32>) -> u32 {
    if any(i >= p.dims) || !lit(i) {
        return NONE;
    }
    return i.x + p.dims.x * (i.y + p.dims.y * i.z);
}

@compute @workgroup_size(4, 4, 4)
fn shadow(@builtin(global_invocation_id) i: vec3<u32>) {
    let lin = smoke_voxel(i);
    if lin == NONE {
        return;
    }
    let u = (vec3<f32>(i) + 0.5) * p.voxel;
    let n = p.suns + p.points;
    for (var l = 0u; l < p.suns; l++) {
        shadow_t[lin * n + l] = transmittance(u, light_vec(8u * l), 3.0e38);
    }
    for (var l = 0u; l < p.points; l++) {
        let at = 8u * (p.suns + l);
        let v = light_vec(at) - u;
        let r2 = dot(v, v);
        var t = 1.0;
        // A light at the voxel center is unshadowed (`main`).
        if lights[at + 3u] != lin && r2 > 0.0 {
            let r = sqrt(r2);
            t = transmittance(u, v / r, r);
        }
        shadow_t[lin * n + p.suns + l] = t;
    }
}

@compute @workgroup_size(4, 4, 4)
fn main(@builtin(global_invocation_id) i: vec3<u32>) {
    let lin = smoke_voxel(i);
    if lin == NONE {
        return;
    }
    let u = (vec3<f32>(i) + 0.5) * p.voxel;
    let view = u - p.eye;
    let view_len = length(view);
    if !(view_len > 0.0) {
        return;
    }
    let d = view / view_len;
    let n = p.suns + p.points;
    var add = vec3<f32>(0.0);
    for (var l = 0u; l < p.suns; l++) {
        let at = 8u * l;
        let s = light_vec(at);
        let t = shadow_t[lin * n + l];
        if t <= 0.0 {
            continue;
        }
        let phase = disk_phase(lights[at + 3u], lights[at + 7u], s, d);
        add += light_vec(at + 4u) * (t * phase);
    }
    for (var l = 0u; l < p.points; l++) {
        let at = 8u * (p.suns + l);
        let v = light_vec(at) - u;
        let r2 = dot(v, v);
        let intensity = light_vec(at + 4u);
        if lights[at + 3u] == lin || !(r2 > 0.0) {
            // The light at the voxel center: isotropic, unshadowed.
            add += intensity / p.soft;
            continue;
        }
        let s = v / sqrt(r2);
        let t = shadow_t[lin * n + p.suns + l];
        add += intensity * (t * hg_lobe(p.g, dot(s, d)) / max(r2, p.soft));
    }
    for (var c = 0u; c < 3u; c++) {
        grid[4u * lin + c] += p.k * add[c];
    }
}
