// Explicit scattering orders of the fast renderer on the GPU: the twin of
// `grid_diffusion::explicit_media_radiance` (with `CoarseGrid::new`,
// `env_grid_sources`, `add_lights`, `sun_sources`, `gather`, `FvSystem`, `solve` and
// `add_to_grids`), in f32 (prepended with `grid_march.wgsl`, `disk_phase.wgsl` and
// `sh_basis.wgsl`).
// Positions are relative to the box's minimum corner. The light is carried through the
// medium's delta-Eddington transport medium (`Medium::delta_eddington`): σt, Ω and g of
// the parameters are the medium's own (the lights' transmittance, the first source and
// the light towards the eye), `transport_*` and the diffusion's coefficients the
// transport medium's (the gathers and the diffusion), and the first source is scaled by
// `first_scale` = 1/(1 − Ωf) to the transport's optical depth.
// Entry points, in order:
//
// `cells`, one invocation per coarse cell c (blocks of f³ voxels): the cell's mean density
// D_c (positive finite voxel densities over the block's voxels) and the record of the first
// source: D_c·J⁰, D_c·J¹ of the environment (per voxel v with D > 0 the bands 0–1 of
// J(v, d) = Σ_j Ω g^l (L_j − S_j(v)) Y_j(d), S trilinear between the environment grid's
// nodes, turned into moments J⁰ = J_00/√4π, J¹ = −√(3/4π)(J_11, J_1−1, J_10) and averaged
// weighted by D) plus the point lights' moments at the cell center (J⁰ = (Ω/4π) I T/(r² +
// soft), J¹ = −3g J⁰ s), then D_c·T toward each sun, T marched through the fine D from
// the cell center (`grid_march.wgsl`), every word but D_c scaled by `first_scale`.
//
// `occupied`, one workgroup: the box of the cells with smoke, widened by a cell on each
// side and clipped to the grid (`gather`'s `occupied`), as positions lo, hi in `work`'s
// first six words (an empty grid: both 0). The gather's rays stop at it.
//
// `gather`, one invocation per cell with D > 0 (one order, its rule in dispatches of 8
// directions): along each direction ω of the rule the light arriving at the cell center x from x − sω, marched to the
// coarse box's face in n = ⌈ℓ/h⌉ equal steps (h the smallest cell side), the record
// trilinear between cell centers, each step's share T(1 − e^{−Δτ})·(D·J)/D, stopping
// below T_MIN; L = J⁰-part + J¹-part·ω + Σ_suns (Ω E/4π)·(D·T)-part·p̄(s·(−ω)), clamped
// ≥ 0; L⁰ = Σ w L/4π, L¹ = 3 Σ w L ω/4π, bands 2–4 c_lm = Σ w L Y_lm(ω), P = Σ w T/4π
// (first order). It adds L⁰, L¹, c_lm (and P) to `media`, which `cells` cleared, and the
// next order's record
// D·(Ω L⁰, Ω g L¹) to `rec_out`.
//
// `system`, one invocation per cell: the finite-volume row of the diffusion after the
// last gathered order (`grid_diffusion` module docs), divided by the cell volume V:
// diag = (σa + σs P) D + Σ G, G = (1 − P̄)/(3σtr D̄ h_a²), b = σt D (1 − P) J⁰ − Σ drive,
// drive = σt/(3σtr h_a)·((1 − P)J¹)̄_a·n; a cell with σtr D h_min ≤ THIN (or no smoke)
// is an identity row with b = 0 (its L = 0, as the CPU leaves it out). G < 0 marks a face
// without a neighbouring unknown. Then x = 0 (or, with `warm`, the last solve's x), r =
// b − Ax, p = 0.
//
// `cg_update`, `cg_start`, then per iteration `cg_product`, `cg_alpha`, `cg_update`,
// `cg_beta`: Jacobi-preconditioned conjugate gradients (z = r/diag), the three colour
// channels each with its own step lengths (as the CPU's), spread over every cell: the
// cell dispatches (`cg_product`: p = z + βp and Ap; `cg_update`: x += αp, r −= αAp) write
// each workgroup's partial dot products, and one workgroup (`cg_start`, `cg_alpha`,
// `cg_beta`) adds them up into α, β and the residual ‖r‖/‖b‖. p has two slots per row,
// the current one read and the next written, so a cell's new direction and its product
// need no wait for the neighbours'. A channel is done at ‖r‖/‖b‖ ≤ tolerance, after
// `max_iterations` or at a breakdown (p·Ap not positive and finite); once all three are,
// the reductions empty the cell dispatches' indirect arguments, so the iterations the host
// recorded beyond convergence cost next to nothing.
//
// lavapipe ends every loop nested in an outermost loop once they have run 65535 iterations
// together (gallivm's loop limiter), silently: so the corners of a sample and the faces
// of a row are written out, the gather's directions come in dispatches of 8, the CG's
// loops are over one partial sum per 256 cells, and the host keeps the cell factor ≤ 8
// (≤ 512 voxels per cell in `cells`).
//
// `finish`, one invocation per cell: L⁰ += max(x, 0), L¹ += 3× the mean of the two
// opposite faces' flux densities G(x_i − x_j) + drive, then L⁰ ≥ 0 and |L¹| ≤ 3L⁰.
//
// `apply`, one invocation per voxel with D > 0: L⁰, L¹, c_lm trilinear between cell
// centers weighted by D_c, J̃ += max(0, Ω (L⁰ − g L¹·d + Σ_{l=2}^{4} g^l c_lm Y_lm(−d)))
// towards the eye (d from the eye).

#import grid_march
#import lit
#import disk_phase
#import sh_basis
#import finite
#import workgroup_sum

struct Params {
    eye: vec3<f32>,
    sigma_t: f32,
    voxel: vec3<f32>,
    // The fine march's step bound: the smallest voxel side.
    h0: f32,
    // The fine box's size.
    size: vec3<f32>,
    // A point light's softening in a cell: (half the smallest cell side)²/3.
    soft: f32,
    dims: vec3<u32>,
    // Voxels per cell side.
    factor: u32,
    cells: vec3<u32>,
    suns: u32,
    // Cell sides.
    cell: vec3<f32>,
    points: u32,
    g: f32,
    albedo: f32,
    // Ω/4π.
    k: f32,
    // Words per cell of `rec_in`: 13 + the suns of the first order, 13 after.
    stride: u32,
    // 1 for the first gathered order.
    first: u32,
    // The environment grid's SH order.
    order: u32,
    // Directions of this order's rule.
    directions: u32,
    max_iterations: u32,
    node_min: vec3<f32>,
    // 1: the diffusion's CG starts from the x in `work` (the last solve's, warm start).
    warm: u32,
    node_cell: vec3<f32>,
    tolerance: f32,
    nodes: vec3<u32>,
    sigma_s: f32,
    sigma_a: f32,
    sigma_tr: f32,
    // The suns in the first source (0 in `rec_in` of the later orders).
    rec_suns: u32,
    // 1 for the first dispatch of an order (its directions come in several).
    chunk_first: u32,
    // The delta-Eddington transport medium's σt', Ω', g' (σs, σa, σtr above are its own).
    transport_sigma_t: f32,
    transport_albedo: f32,
    transport_g: f32,
    // The first source's factor 1/(1 − Ωf).
    first_scale: f32,
    // L_j r g b and Ω g^l of the environment's coefficients j < 4.
    env: array<vec4<f32>, 4>,
    // Per sun of the first order, the factor that makes its phase function integrate to
    // 4π on the first order's rule (`grid_diffusion::phase_norm`), four to a vec4.
    sun_norm: array<vec4<f32>, 2>,
    // This dispatch's directions of the order's rule: ω x y z, weight (summing to 4π
    // over the order's dispatches).
    rule: array<vec4<f32>, 8>,
}

const NONE: u32 = 0xffffffffu;
// `grid_diffusion::T_MIN` and `grid_diffusion::THIN`.
const T_MIN: f32 = 1e-4;
const THIN: f32 = 1e-2;
const FOUR_PI: f32 = 12.5663706144;
// Records hold at most 13 + 8 words (eight suns).
const MAX_RECORD: u32 = 21u;
// Words per cell of `media` (L⁰ rgb, L¹ [channel][axis], P, D, 2 unused, c_lm of bands
// 2–4 of the red channel [HIGH] from word 16), of the green and blue channels' bands in
// `work` during the gathers and `apply` (after the box's BOX words: `more_at`), and of the
// system in `work` during the diffusion (diag, G ×6, b ×3, drive [face][channel], x, r,
// two slots of p, Ap per channel). The bands are split over two bindings so that neither
// holds more words a cell than the system.
const HIGH: u32 = 21u;
const MEDIA: u32 = 16u + HIGH;
const MORE: u32 = 2u * HIGH;
const BOX: u32 = 8u;
const ROW: u32 = 43u;
// The first of a row's two slots of the search direction p (3 words each).
const P_SLOTS: u32 = 34u;
// Words of the CG's state in `work` after the rows (3 channels × 8, the current p slot).
const STATE: u32 = 32u;
const WG: u32 = 256u;

@group(0) @binding(0) var<storage, read> p: Params;
// The lights pass's records (eight words per light, suns first) and the suns' tables; in
// the CG's reductions, the cell dispatches' indirect arguments (x, y, z workgroups).
@group(0) @binding(1) var<storage, read_write> lights: array<u32>;
// The volume pass's grid: per voxel J̃ r g b, D.
@group(0) @binding(2) var<storage, read_write> grid: array<f32>;
// The environment grid's S per node (3·order² words, channel fastest).
@group(0) @binding(3) var<storage, read> shadow_sh: array<f32>;
@group(0) @binding(4) var<storage, read> rec_in: array<f32>;
@group(0) @binding(5) var<storage, read_write> rec_out: array<f32>;
@group(0) @binding(6) var<storage, read_write> media: array<f32>;
// The rows and CG vectors (ROW words per cell, stored word by word: `at`), then the
// CG's state (STATE words: `state_at`, `parity_at`), then 8 words of partial sums per
// workgroup of a CG cell dispatch; in `occupied` and `gather`, the box of the cells with
// smoke (6 words).
@group(0) @binding(7) var<storage, read_write> work: array<f32>;

var<workgroup> cg_flag: u32;
var<workgroup> occ_lo: array<vec3<u32>, WG>;
var<workgroup> occ_hi: array<vec3<u32>, WG>;

fn total_cells() -> u32 {
    return p.cells.x * p.cells.y * p.cells.z;
}

fn cell_coords(i: u32) -> vec3<u32> {
    return vec3<u32>(i % p.cells.x, (i / p.cells.x) % p.cells.y, i / (p.cells.x * p.cells.y));
}

fn cell_index(c: vec3<u32>) -> u32 {
    return c.x + p.cells.x * (c.y + p.cells.y * c.z);
}

// Band coefficient j (of bands 2–4) of channel ch of cell i: the red channel's in `media`,
// the green and blue channels' in `work` after the box (bound there in `cells`, the
// gathers and `apply`).
fn band(i: u32, ch: u32, j: u32) -> f32 {
    if ch == 0u {
        return media[i * MEDIA + 16u + j];
    }
    return work[BOX + i * MORE + (ch - 1u) * HIGH + j];
}

fn add_band(i: u32, ch: u32, j: u32, v: f32) {
    if ch == 0u {
        media[i * MEDIA + 16u + j] += v;
    } else {
        work[BOX + i * MORE + (ch - 1u) * HIGH + j] += v;
    }
}

// The cell of a flat dispatch of 64-invocation groups (x, then rows of x groups).
fn invocation_cell(gid: vec3<u32>, ng: vec3<u32>) -> u32 {
    return gid.x + 64u * ng.x * gid.y;
}

// J_j = Ω g^l (L_j − S_j(u)) for j < 4 (zero beyond order²) at box-local u, S trilinear
// between the nodes (`ShGrid::at`'s stencil), the corners' four coefficients read together.
fn env_coeffs(u: vec3<f32>) -> array<vec3<f32>, 4> {
    let many = p.nodes >= vec3<u32>(2u) & p.node_cell > vec3<f32>(0.0);
    let t = clamp((u - p.node_min) / select(vec3<f32>(1.0), p.node_cell, many), vec3<f32>(0.0),
        vec3<f32>(max(p.nodes, vec3<u32>(1u)) - 1u));
    let i0 = select(vec3<u32>(0u), min(vec3<u32>(floor(t)), max(p.nodes, vec3<u32>(2u)) - 2u), many);
    let f = select(vec3<f32>(0.0), t - vec3<f32>(i0), many);
    let k3 = 3u * p.order * p.order;
    let n2 = min(p.order * p.order, 4u);
    var s = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var corner = 0u; corner < 8u; corner++) {
        let d = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
        let wv = select(1.0 - f, select(vec3<f32>(0.0), f, many), d == vec3<u32>(1u));
        let w = wv.x * wv.y * wv.z;
        if w == 0.0 {
            continue;
        }
        let c = i0 + d;
        let at = (c.x + p.nodes.x * (c.y + p.nodes.y * c.z)) * k3;
        s[0] += w * vec3<f32>(shadow_sh[at], shadow_sh[at + 1u], shadow_sh[at + 2u]);
        if n2 == 4u {
            s[1] += w * vec3<f32>(shadow_sh[at + 3u], shadow_sh[at + 4u], shadow_sh[at + 5u]);
            s[2] += w * vec3<f32>(shadow_sh[at + 6u], shadow_sh[at + 7u], shadow_sh[at + 8u]);
            s[3] += w * vec3<f32>(shadow_sh[at + 9u], shadow_sh[at + 10u], shadow_sh[at + 11u]);
        }
    }
    var out = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    out[0] = p.env[0].w * (p.env[0].xyz - s[0]);
    if n2 == 4u {
        out[1] = p.env[1].w * (p.env[1].xyz - s[1]);
        out[2] = p.env[2].w * (p.env[2].xyz - s[2]);
        out[3] = p.env[3].w * (p.env[3].xyz - s[3]);
    }
    return out;
}

@compute @workgroup_size(64)
fn cells(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let i = invocation_cell(gid, ng);
    if i >= total_cells() {
        return;
    }
    let c = cell_coords(i);
    let lo = c * p.factor;
    let hi = min(lo + p.factor, p.dims);
    var sum = 0.0;
    var w = 0.0;
    var j0 = vec3<f32>(0.0);
    // J¹ per channel, axes in the vector.
    var j1 = array<vec3<f32>, 3>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var z = lo.z; z < hi.z; z++) {
        for (var y = lo.y; y < hi.y; y++) {
            for (var x = lo.x; x < hi.x; x++) {
                let d = density(vec3<u32>(x, y, z));
                if !(d > 0.0 && finite(d)) {
                    continue;
                }
                sum += d;
                w += d;
                let u = (vec3<f32>(f32(x), f32(y), f32(z)) + 0.5) * p.voxel;
                let coef = env_coeffs(u);
                j0 += d * coef[0] / sqrt(FOUR_PI);
                // J¹ = −√(3/4π)(J_11, J_1−1, J_10) per channel (zero below order 2).
                let k1 = -d * sqrt(3.0 / FOUR_PI);
                j1[0] += k1 * vec3<f32>(coef[3].x, coef[1].x, coef[2].x);
                j1[1] += k1 * vec3<f32>(coef[3].y, coef[1].y, coef[2].y);
                j1[2] += k1 * vec3<f32>(coef[3].z, coef[1].z, coef[2].z);
            }
        }
    }
    let count = f32((hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z));
    let dc = select(0.0, sum / count, count > 0.0);
    let base = i * p.stride;
    for (var k = 0u; k < p.stride; k++) {
        rec_out[base + k] = 0.0;
    }
    for (var k = 0u; k < MEDIA; k++) {
        media[i * MEDIA + k] = 0.0;
    }
    for (var k = 0u; k < MORE; k++) {
        work[BOX + i * MORE + k] = 0.0;
    }
    media[i * MEDIA + 13u] = dc;
    if !(dc > 0.0) {
        return;
    }
    if w > 0.0 {
        j0 /= w;
        for (var ch = 0u; ch < 3u; ch++) {
            j1[ch] /= w;
        }
    }
    let u = (vec3<f32>(c) + 0.5) * p.cell;
    if p.albedo != 0.0 {
        let hc = min(p.cell.x, min(p.cell.y, p.cell.z));
        for (var l = 0u; l < p.points; l++) {
            let at = 8u * (p.suns + l);
            let v = light_vec(at) - u;
            let r2 = dot(v, v);
            let intensity = light_vec(at + 4u);
            if r2 < (NEAR_CELLS * hc) * (NEAR_CELLS * hc) {
                let mean = near_light_mean(u, light_vec(at));
                if mean.y > 0.0 {
                    let a = p.k * intensity * mean.x;
                    j0 += a;
                    if r2 > 0.0 {
                        let s = v / sqrt(r2);
                        for (var ch = 0u; ch < 3u; ch++) {
                            j1[ch] -= 3.0 * p.g * a[ch] * s;
                        }
                    }
                    continue;
                }
            }
            if !(r2 > 0.0) {
                j0 += p.k * intensity / p.soft;
                continue;
            }
            let s = v / sqrt(r2);
            let a = p.k * intensity * transmittance(u, s, sqrt(r2)) / (r2 + p.soft);
            j0 += a;
            for (var ch = 0u; ch < 3u; ch++) {
                j1[ch] -= 3.0 * p.g * a[ch] * s;
            }
        }
    }
    rec_out[base] = dc;
    let ds = dc * p.first_scale;
    for (var ch = 0u; ch < 3u; ch++) {
        rec_out[base + 1u + ch] = ds * finite_or_zero(j0[ch]);
        for (var a = 0u; a < 3u; a++) {
            rec_out[base + 4u + 3u * ch + a] = ds * finite_or_zero(j1[ch][a]);
        }
    }
    for (var l = 0u; l < p.rec_suns; l++) {
        let t = transmittance(u, light_vec(8u * l), 3.0e38);
        rec_out[base + 13u + l] = ds * clamp(finite_or_zero(t), 0.0, 1.0);
    }
}

// `source::near_light_mean`: a point light's T/r² over the cell centred at u, the
// density-weighted mean over NEAR_SUB³ sub-cell centres, Σ D·T/(r² + a²/3) / Σ D (a half
// the smallest sub-cell side); (mean, Σ D), Σ D = 0 where the sub-cells hold no density.
const NEAR_CELLS: f32 = 2.5;
const NEAR_SUB: u32 = 4u;

fn near_light_mean(u: vec3<f32>, light: vec3<f32>) -> vec2<f32> {
    let n = f32(NEAR_SUB);
    let hs = min(p.cell.x, min(p.cell.y, p.cell.z)) / n;
    let soft = 0.25 * hs * hs / 3.0;
    var sum = 0.0;
    var weight = 0.0;
    for (var k = 0u; k < NEAR_SUB * NEAR_SUB * NEAR_SUB; k++) {
        let idx = vec3<u32>(k % NEAR_SUB, (k / NEAR_SUB) % NEAR_SUB, k / (NEAR_SUB * NEAR_SUB));
        let x = u + ((vec3<f32>(idx) + 0.5) / n - 0.5) * p.cell;
        let d = sample_density(x);
        if !(d > 0.0) {
            continue;
        }
        let w = light - x;
        let r2 = dot(w, w);
        var t = 1.0;
        if r2 > 0.0 {
            let r = sqrt(r2);
            t = transmittance(x, w / r, r);
        }
        sum += d * t / (r2 + soft);
        weight += d;
    }
    if weight > 0.0 {
        return vec2<f32>(sum / weight, weight);
    }
    return vec2<f32>(0.0);
}

// Distance from x along s to the coarse box's face (∞ for s = 0, as
// `CoarseGrid::exit_distance`).
fn coarse_exit(x: vec3<f32>, s: vec3<f32>) -> f32 {
    let size = p.cell * vec3<f32>(p.cells);
    var len = 3.0e38;
    for (var a = 0u; a < 3u; a++) {
        if s[a] > 0.0 {
            len = min(len, (size[a] - x[a]) / s[a]);
        } else if s[a] < 0.0 {
            len = min(len, -x[a] / s[a]);
        }
    }
    return len;
}

// One of the eight cells around a sample: its record's first word and trilinear weight
// (0 for a cell without smoke, as `gather`'s `trilinear` skips it).
struct Corner {
    at: u32,
    w: f32,
}

fn corner(c0: vec3<u32>, f: vec3<f32>, o: vec3<u32>) -> Corner {
    let cc = min(c0 + o, p.cells - 1u);
    let wv = select(1.0 - f, f, o == vec3<u32>(1u));
    let at = cell_index(cc) * p.stride;
    return Corner(at, select(0.0, wv.x * wv.y * wv.z, rec_in[at] > 0.0));
}

// The record's J⁰ and J¹ (per channel, axes in the vector) at a corner, times w.
struct Moments {
    j0: vec3<f32>,
    r: vec3<f32>,
    g: vec3<f32>,
    b: vec3<f32>,
}

fn moments_at(k: Corner, w: f32) -> Moments {
    let a = k.at;
    return Moments(
        w * vec3<f32>(rec_in[a + 1u], rec_in[a + 2u], rec_in[a + 3u]),
        w * vec3<f32>(rec_in[a + 4u], rec_in[a + 5u], rec_in[a + 6u]),
        w * vec3<f32>(rec_in[a + 7u], rec_in[a + 8u], rec_in[a + 9u]),
        w * vec3<f32>(rec_in[a + 10u], rec_in[a + 11u], rec_in[a + 12u]),
    );
}

fn add_moments(a: Moments, b: Moments) -> Moments {
    return Moments(a.j0 + b.j0, a.r + b.r, a.g + b.g, a.b + b.b);
}

@compute @workgroup_size(256)
fn occupied(@builtin(local_invocation_index) lid: u32) {
    var lo = vec3<u32>(NONE);
    var hi = vec3<u32>(0u);
    let n = total_cells();
    for (var i = lid; i < n; i += WG) {
        if media[i * MEDIA + 13u] > 0.0 {
            let c = cell_coords(i);
            lo = min(lo, c);
            hi = max(hi, c);
        }
    }
    occ_lo[lid] = lo;
    occ_hi[lid] = hi;
    workgroupBarrier();
    for (var s = WG / 2u; s > 0u; s = s / 2u) {
        if lid < s {
            occ_lo[lid] = min(occ_lo[lid], occ_lo[lid + s]);
            occ_hi[lid] = max(occ_hi[lid], occ_hi[lid + s]);
        }
        workgroupBarrier();
    }
    if lid == 0u {
        let l = occ_lo[0];
        let h = occ_hi[0];
        var a = vec3<f32>(0.0);
        var b = vec3<f32>(0.0);
        if l.x != NONE {
            a = vec3<f32>(max(l, vec3<u32>(1u)) - 1u) * p.cell;
            b = vec3<f32>(min(h + 2u, p.cells)) * p.cell;
        }
        work[0] = a.x;
        work[1] = a.y;
        work[2] = a.z;
        work[3] = b.x;
        work[4] = b.y;
        work[5] = b.z;
    }
}

// One dispatch gathers the parameters' rule (a share of an order's directions, few enough
// that an invocation's loops stay within lavapipe's budget of 65535 iterations per
// outermost loop): it adds its part of L⁰, L¹ to `media` (and of P for the first order),
// and of the next source to `rec_out`, which its order's first dispatch clears.
@compute @workgroup_size(64)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let i = invocation_cell(gid, ng);
    if i >= total_cells() {
        return;
    }
    let dc = rec_in[i * p.stride];
    let m = i * MEDIA;
    let next = i * 13u;
    if p.chunk_first == 1u {
        for (var k = 0u; k < 13u; k++) {
            rec_out[next + k] = 0.0;
        }
    }
    rec_out[next] = max(dc, 0.0);
    if !(dc > 0.0) {
        // No smoke: no light, P = 1.
        if p.first == 1u && p.chunk_first == 1u {
            media[m + 12u] = 1.0;
        }
        return;
    }
    let x = (vec3<f32>(cell_coords(i)) + 0.5) * p.cell;
    let h = min(p.cell.x, min(p.cell.y, p.cell.z));
    let n = p.cells;
    let top = max(n, vec3<u32>(2u)) - 2u;
    let occ_a = vec3<f32>(work[0], work[1], work[2]);
    let occ_b = vec3<f32>(work[3], work[4], work[5]);
    var l0 = vec3<f32>(0.0);
    var l1 = array<vec3<f32>, 3>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var high: array<array<f32, 21>, 3>;
    var escape = 0.0;
    for (var k = 0u; k < p.directions; k++) {
        let w = p.rule[k].xyz;
        let wt = p.rule[k].w;
        let back = -w;
        let len = coarse_exit(x, back);
        let all_steps = u32(max(ceil(len / h), 1.0));
        let step = len / f32(all_steps);
        // The same steps, those beyond the box of the cells with smoke skipped.
        let to = select(select(vec3<f32>(3.0e38), (occ_a - x) / back, back < vec3<f32>(0.0)),
            (occ_b - x) / back, back > vec3<f32>(0.0));
        let reach = min(to.x, min(to.y, to.z));
        let steps = min(all_steps, u32(max(ceil(reach / step + 0.5), 0.0)));
        var acc = Moments(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        var acc_sun = array<f32, 8>(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        var t = 1.0;
        for (var s = 0u; s < steps; s++) {
            let q = x + ((f32(s) + 0.5) * step) * back;
            // `CoarseGrid::corners`: nothing outside the box.
            let u = q / p.cell;
            if !(all(u >= vec3<f32>(0.0)) && all(u <= vec3<f32>(n))) {
                continue;
            }
            let cf = clamp(u - 0.5, vec3<f32>(0.0), vec3<f32>(n) - 1.0);
            let c0 = min(vec3<u32>(floor(cf)), top);
            let f = cf - vec3<f32>(c0);
            let k0 = corner(c0, f, vec3<u32>(0u, 0u, 0u));
            let k1 = corner(c0, f, vec3<u32>(1u, 0u, 0u));
            let k2 = corner(c0, f, vec3<u32>(0u, 1u, 0u));
            let k3 = corner(c0, f, vec3<u32>(1u, 1u, 0u));
            let k4 = corner(c0, f, vec3<u32>(0u, 0u, 1u));
            let k5 = corner(c0, f, vec3<u32>(1u, 0u, 1u));
            let k6 = corner(c0, f, vec3<u32>(0u, 1u, 1u));
            let k7 = corner(c0, f, vec3<u32>(1u, 1u, 1u));
            let d = k0.w * rec_in[k0.at] + k1.w * rec_in[k1.at] + k2.w * rec_in[k2.at]
                + k3.w * rec_in[k3.at] + k4.w * rec_in[k4.at] + k5.w * rec_in[k5.at]
                + k6.w * rec_in[k6.at] + k7.w * rec_in[k7.at];
            if !(d > 0.0) {
                continue;
            }
            let dtau = p.transport_sigma_t * d * step;
            let share = t * one_minus_exp(dtau) / d;
            let a = add_moments(
                add_moments(add_moments(moments_at(k0, k0.w), moments_at(k1, k1.w)),
                    add_moments(moments_at(k2, k2.w), moments_at(k3, k3.w))),
                add_moments(add_moments(moments_at(k4, k4.w), moments_at(k5, k5.w)),
                    add_moments(moments_at(k6, k6.w), moments_at(k7, k7.w))),
            );
            acc = add_moments(acc, Moments(share * a.j0, share * a.r, share * a.g, share * a.b));
            for (var sun = 0u; sun < p.rec_suns; sun++) {
                let o = 13u + sun;
                acc_sun[sun] += share * (k0.w * rec_in[k0.at + o] + k1.w * rec_in[k1.at + o]
                    + k2.w * rec_in[k2.at + o] + k3.w * rec_in[k3.at + o]
                    + k4.w * rec_in[k4.at + o] + k5.w * rec_in[k5.at + o]
                    + k6.w * rec_in[k6.at + o] + k7.w * rec_in[k7.at + o]);
            }
            t *= exp(-dtau);
            if t < T_MIN {
                t = 0.0;
                break;
            }
        }
        escape += wt * t;
        var l = acc.j0 + vec3<f32>(dot(acc.r, w), dot(acc.g, w), dot(acc.b, w));
        for (var sun = 0u; sun < p.rec_suns; sun++) {
            let at = 8u * sun;
            let phase = disk_phase(lights[at + 3u], lights[at + 7u], light_vec(at), back);
            let norm = p.sun_norm[sun / 4u][sun % 4u];
            l += (p.k * norm * acc_sun[sun] * phase) * light_vec(at + 4u);
        }
        l = max(l, vec3<f32>(0.0));
        l0 += wt * l;
        l1[0] += (3.0 * wt * l.x) * w;
        l1[1] += (3.0 * wt * l.y) * w;
        l1[2] += (3.0 * wt * l.z) * w;
        sh_eval(5u, w);
        for (var j = 0u; j < HIGH; j++) {
            let y = wt * ysh[4u + j];
            high[0][j] += y * l.x;
            high[1][j] += y * l.y;
            high[2][j] += y * l.z;
        }
    }
    for (var ch = 0u; ch < 3u; ch++) {
        let a0 = l0[ch] / FOUR_PI;
        let a1 = l1[ch] / FOUR_PI;
        media[m + ch] += a0;
        rec_out[next + 1u + ch] += dc * p.transport_albedo * a0;
        for (var a = 0u; a < 3u; a++) {
            media[m + 3u + 3u * ch + a] += a1[a];
            rec_out[next + 4u + 3u * ch + a] += dc * p.transport_albedo * p.transport_g * a1[a];
        }
        for (var j = 0u; j < HIGH; j++) {
            add_band(i, ch, j, high[ch][j]);
        }
    }
    if p.first == 1u {
        media[m + 12u] += escape / FOUR_PI;
    }
}

// The escape probability of cell i for the system (1 where it is not finite).
fn escape_of(i: u32) -> f32 {
    let e = media[i * MEDIA + 12u];
    return select(1.0, clamp(e, 0.0, 1.0), finite(e));
}

fn unknown(i: u32) -> bool {
    let hmin = min(p.cell.x, min(p.cell.y, p.cell.z));
    return p.sigma_tr * media[i * MEDIA + 13u] * hmin > THIN;
}

// The source the light after the gathered orders starts from, J = rec/D (D > 0).
fn source_j0(i: u32, ch: u32) -> f32 {
    return finite_or_zero(rec_in[i * 13u + 1u + ch] / rec_in[i * 13u]);
}

fn source_j1(i: u32, ch: u32, a: u32) -> f32 {
    return finite_or_zero(rec_in[i * 13u + 4u + 3u * ch + a] / rec_in[i * 13u]);
}

// The neighbour of cell c through face f (−x, +x, −y, +y, −z, +z), NONE outside.
fn neighbour(c: vec3<u32>, f: u32) -> u32 {
    let a = f / 2u;
    var cj = c;
    if f % 2u == 1u {
        cj[a] += 1u;
        if cj[a] >= p.cells[a] {
            return NONE;
        }
    } else {
        if c[a] == 0u {
            return NONE;
        }
        cj[a] -= 1u;
    }
    return cell_index(cj);
}

@compute @workgroup_size(64)
fn system(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let i = invocation_cell(gid, ng);
    if i >= total_cells() {
        return;
    }
    if i == 0u {
        // α = β = 0 and slot 0 current for `cg_update`'s first sums (`cg_start` sets the rest).
        for (var c = 0u; c < 3u; c++) {
            work[state_at(c) + 5u] = 0.0;
            work[state_at(c) + 6u] = 0.0;
        }
        work[parity_at()] = 0.0;
    }
    // A warm start keeps an unknown's x (made finite: a neighbour reading it before or
    // after this write reads the same value through `finite_or_zero`).
    let keep = p.warm == 1u && unknown(i);
    let x0 = select(vec3<f32>(0.0), vec3<f32>(finite_or_zero(work[at(i, 28u)]),
        finite_or_zero(work[at(i, 29u)]), finite_or_zero(work[at(i, 30u)])), keep);
    for (var k = 0u; k < ROW; k++) {
        // A kept x is never zeroed, not even for a moment: the neighbours read it.
        if !(keep && k >= 28u && k < 31u) {
            work[at(i, k)] = 0.0;
        }
    }
    if keep {
        for (var ch = 0u; ch < 3u; ch++) {
            work[at(i, 28u + ch)] = x0[ch];
        }
    }
    if !unknown(i) {
        work[at(i, 0u)] = 1.0;
        for (var f = 0u; f < 6u; f++) {
            work[at(i, 1u + f)] = -1.0;
        }
        return;
    }
    let c = cell_coords(i);
    let di = media[i * MEDIA + 13u];
    let pi = escape_of(i);
    var diag = (p.sigma_a + p.sigma_s * pi) * di;
    var b = vec3<f32>(0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        b[ch] = p.transport_sigma_t * di * (1.0 - pi) * source_j0(i, ch);
    }
    // Σ G x_j over the faces with a neighbouring unknown (the warm start's A x0).
    var gx = vec3<f32>(0.0);
    for (var f = 0u; f < 6u; f++) {
        let j = neighbour(c, f);
        if j == NONE || !unknown(j) {
            work[at(i, 1u + f)] = -1.0;
            continue;
        }
        let a = f / 2u;
        let h = p.cell[a];
        let n = select(-1.0, 1.0, f % 2u == 1u);
        let pj = escape_of(j);
        let df = 0.5 * (di + media[j * MEDIA + 13u]);
        let kept = 1.0 - 0.5 * (pi + pj);
        let g = finite_or_zero(kept / (3.0 * p.sigma_tr * df * h * h));
        diag += g;
        work[at(i, 1u + f)] = g;
        if keep {
            for (var ch = 0u; ch < 3u; ch++) {
                gx[ch] += g * finite_or_zero(work[at(j, 28u + ch)]);
            }
        }
        for (var ch = 0u; ch < 3u; ch++) {
            let flux = 0.5 * ((1.0 - pi) * source_j1(i, ch, a) + (1.0 - pj) * source_j1(j, ch, a)) * n;
            let drive = finite_or_zero(p.transport_sigma_t / (3.0 * p.sigma_tr * h) * flux);
            work[at(i, 10u + 3u * f + ch)] = drive;
            b[ch] -= drive;
        }
    }
    work[at(i, 0u)] = diag;
    for (var ch = 0u; ch < 3u; ch++) {
        work[at(i, 7u + ch)] = b[ch];
        // r = b − A x0 (x0 = 0 cold), both p slots and Ap 0.
        work[at(i, 31u + ch)] = b[ch] - (diag * x0[ch] - gx[ch]);
    }
}

// Word k of cell i's row of the system: the rows are stored word by word (k·n + i), so
// that neighbouring invocations read neighbouring words.
fn at(i: u32, k: u32) -> u32 {
    return k * total_cells() + i;
}

// The CG's state of channel c in `work`, after the rows: iterations, ‖r‖/‖b‖, r·z, ‖b‖,
// done (converged, out of iterations or broken down), α, β.
fn state_at(c: u32) -> u32 {
    return ROW * total_cells() + 8u * c;
}

// Which of the two `p` slots of a row holds the current search direction (0 or 1).
fn parity_at() -> u32 {
    return ROW * total_cells() + 24u;
}

// The partial sums of workgroup w of a CG cell dispatch (8 words: p·Ap or r·r per channel,
// then r·z per channel from word 4).
fn partial_at(w: u32) -> u32 {
    return ROW * total_cells() + STATE + 8u * w;
}

// Workgroups of a CG cell dispatch that hold cells (those that write partial sums).
fn partial_groups() -> u32 {
    return (total_cells() + WG - 1u) / WG;
}

// The cell and the flat workgroup index of a CG cell dispatch (WG invocations a group).
fn cg_cell(gid: vec3<u32>, ng: vec3<u32>) -> u32 {
    return gid.x + WG * ng.x * gid.y;
}

fn cg_group(wg: vec3<u32>, ng: vec3<u32>) -> u32 {
    return wg.x + ng.x * wg.y;
}

// z_j + β p_j of cell j (z = r/diag): its next search direction, from the current slot
// `old`.
fn next_p(j: u32, old: u32, ch: u32, beta: f32) -> f32 {
    return work[at(j, 31u + ch)] / work[at(j, 0u)] + beta * work[at(j, P_SLOTS + 3u * old + ch)];
}

// G (z_j + β p_j) through face f of cell i's row (0 without a neighbouring unknown).
fn face_term(i: u32, cc: vec3<u32>, f: u32, old: u32, ch: u32, beta: f32) -> f32 {
    let g = work[at(i, 1u + f)];
    if !(g > 0.0) {
        return 0.0;
    }
    return g * next_p(neighbour(cc, f), old, ch, beta);
}

// The three channels' sums of `v` (one vec3 per invocation) over the workgroup, written to
// the workgroup's partial sums from word `at` (groups past the cells write nothing).
fn write_partial3(lid: u32, w: u32, at: u32, v: vec3<f32>) {
    let s01 = workgroup_sum(lid, v.xy);
    let s2 = workgroup_sum(lid, vec2<f32>(v.z, 0.0)).x;
    if lid == 0u && w < partial_groups() {
        let o = partial_at(w) + at;
        work[o] = s01.x;
        work[o + 1u] = s01.y;
        work[o + 2u] = s2;
    }
}

// The sum over every cell workgroup's partial sums from word `at`, per channel (one
// workgroup; every invocation gets it).
fn total3(lid: u32, at: u32) -> vec3<f32> {
    var a = vec3<f32>(0.0);
    for (var w = lid; w < partial_groups(); w += WG) {
        let o = partial_at(w) + at;
        a += vec3<f32>(work[o], work[o + 1u], work[o + 2u]);
    }
    let s01 = workgroup_sum(lid, a.xy);
    let s2 = workgroup_sum(lid, vec2<f32>(a.z, 0.0)).x;
    return vec3<f32>(s01, s2);
}

// 1 when every channel is done (read by every invocation of a reduction; uniform).
fn all_done(lid: u32) -> bool {
    if lid == 0u {
        var done = 1u;
        for (var c = 0u; c < 3u; c++) {
            if work[state_at(c) + 4u] != 1.0 {
                done = 0u;
            }
        }
        cg_flag = done;
    }
    return workgroupUniformLoad(&cg_flag) == 1u;
}

// After a reduction: once every channel is done, the cell dispatches' indirect arguments
// become empty (`lights` holds them in the CG's reductions).
fn close_if_done() {
    var done = true;
    for (var c = 0u; c < 3u; c++) {
        done = done && work[state_at(c) + 4u] == 1.0;
    }
    if done {
        lights[0] = 0u;
        lights[1] = 0u;
    }
}

// The search direction p = z + βp into the other slot and Ap, and p·Ap per workgroup.
@compute @workgroup_size(256)
fn cg_product(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) ng: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = cg_cell(gid, ng);
    let old = u32(work[parity_at()]);
    var pap = vec3<f32>(0.0);
    if i < total_cells() {
        let cc = cell_coords(i);
        for (var ch = 0u; ch < 3u; ch++) {
            let beta = work[state_at(ch) + 6u];
            let pi = next_p(i, old, ch, beta);
            let ap = work[at(i, 0u)] * pi - face_term(i, cc, 0u, old, ch, beta)
                - face_term(i, cc, 1u, old, ch, beta) - face_term(i, cc, 2u, old, ch, beta)
                - face_term(i, cc, 3u, old, ch, beta) - face_term(i, cc, 4u, old, ch, beta)
                - face_term(i, cc, 5u, old, ch, beta);
            work[at(i, P_SLOTS + 3u * (1u - old) + ch)] = pi;
            work[at(i, 40u + ch)] = ap;
            pap[ch] = pi * ap;
        }
    }
    write_partial3(lid, cg_group(wg, ng), 0u, pap);
}

// α = r·z / p·Ap per channel (a breakdown, p·Ap not positive and finite, ends the channel);
// the new direction becomes the current slot.
@compute @workgroup_size(256)
fn cg_alpha(@builtin(local_invocation_index) lid: u32) {
    if all_done(lid) {
        return;
    }
    let pap = total3(lid, 0u);
    if lid == 0u {
        for (var c = 0u; c < 3u; c++) {
            let st = state_at(c);
            if work[st + 4u] == 1.0 {
                continue;
            }
            if pap[c] > 0.0 && finite(pap[c]) {
                work[st + 5u] = work[st + 2u] / pap[c];
            } else {
                work[st + 4u] = 1.0;
                work[st + 5u] = 0.0;
                work[st + 6u] = 0.0;
            }
        }
        work[parity_at()] = 1.0 - work[parity_at()];
        close_if_done();
    }
}

// x += αp, r −= αAp, and r·r, r·z per workgroup (α = 0 before the first iteration: the
// sums of b).
@compute @workgroup_size(256)
fn cg_update(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(num_workgroups) ng: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = cg_cell(gid, ng);
    let cur = u32(work[parity_at()]);
    var rr = vec3<f32>(0.0);
    var rz = vec3<f32>(0.0);
    if i < total_cells() {
        for (var ch = 0u; ch < 3u; ch++) {
            let alpha = work[state_at(ch) + 5u];
            work[at(i, 28u + ch)] += alpha * work[at(i, P_SLOTS + 3u * cur + ch)];
            let ri = work[at(i, 31u + ch)] - alpha * work[at(i, 40u + ch)];
            work[at(i, 31u + ch)] = ri;
            rr[ch] = ri * ri;
            rz[ch] = ri * ri / work[at(i, 0u)];
        }
    }
    let w = cg_group(wg, ng);
    write_partial3(lid, w, 0u, rr);
    write_partial3(lid, w, 4u, rz);
}

// The first state from r = b − A x0: ‖b‖ (summed over the rows here), ‖r‖/‖b‖, r·z, a
// channel with b = 0, already within the tolerance or with no iterations allowed done at
// once.
@compute @workgroup_size(256)
fn cg_start(@builtin(local_invocation_index) lid: u32) {
    let rr = total3(lid, 0u);
    let rz = total3(lid, 4u);
    var part = vec3<f32>(0.0);
    for (var i = lid; i < total_cells(); i += WG) {
        let b = vec3<f32>(work[at(i, 7u)], work[at(i, 8u)], work[at(i, 9u)]);
        part += b * b;
    }
    let b01 = workgroup_sum(lid, part.xy);
    let bb = vec3<f32>(b01, workgroup_sum(lid, vec2<f32>(part.z, 0.0)).x);
    if lid == 0u {
        for (var c = 0u; c < 3u; c++) {
            let st = state_at(c);
            let bn = sqrt(bb[c]);
            let residual = select(0.0, sqrt(rr[c]) / bn, bn > 0.0);
            work[st] = 0.0;
            work[st + 1u] = residual;
            work[st + 2u] = rz[c];
            work[st + 3u] = bn;
            let done = p.max_iterations == 0u || !(residual > p.tolerance);
            work[st + 4u] = select(0.0, 1.0, done);
            work[st + 5u] = 0.0;
            work[st + 6u] = 0.0;
        }
        close_if_done();
    }
}

// An iteration's end per channel: ‖r‖/‖b‖, β = r·z / the last r·z, done once the residual
// is at the tolerance or the iterations at their most.
@compute @workgroup_size(256)
fn cg_beta(@builtin(local_invocation_index) lid: u32) {
    if all_done(lid) {
        return;
    }
    let rr = total3(lid, 0u);
    let rz = total3(lid, 4u);
    if lid == 0u {
        for (var c = 0u; c < 3u; c++) {
            let st = state_at(c);
            if work[st + 4u] == 1.0 {
                work[st + 5u] = 0.0;
                work[st + 6u] = 0.0;
                continue;
            }
            let iterations = work[st] + 1.0;
            let bn = work[st + 3u];
            let residual = select(0.0, sqrt(rr[c]) / bn, bn > 0.0);
            let last = work[st + 2u];
            work[st] = iterations;
            work[st + 1u] = residual;
            work[st + 2u] = rz[c];
            work[st + 5u] = 0.0;
            work[st + 6u] = select(0.0, rz[c] / last, last > 0.0);
            let done = u32(iterations) >= p.max_iterations || !(residual > p.tolerance);
            work[st + 4u] = select(0.0, 1.0, done);
        }
        close_if_done();
    }
}

@compute @workgroup_size(64)
fn finish(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let i = invocation_cell(gid, ng);
    if i >= total_cells() {
        return;
    }
    let m = i * MEDIA;
    var l0 = vec3<f32>(media[m], media[m + 1u], media[m + 2u]);
    var l1 = array<vec3<f32>, 3>(
        vec3<f32>(media[m + 3u], media[m + 4u], media[m + 5u]),
        vec3<f32>(media[m + 6u], media[m + 7u], media[m + 8u]),
        vec3<f32>(media[m + 9u], media[m + 10u], media[m + 11u]),
    );
    if unknown(i) {
        let cc = cell_coords(i);
        for (var ch = 0u; ch < 3u; ch++) {
            let x = finite_or_zero(work[at(i, 28u + ch)]);
            l0[ch] += max(x, 0.0);
            for (var f = 0u; f < 6u; f++) {
                let g = work[at(i, 1u + f)];
                if g < 0.0 {
                    continue;
                }
                let a = f / 2u;
                let xj = finite_or_zero(work[at(neighbour(cc, f), 28u + ch)]);
                let q = g * (x - xj) + work[at(i, 10u + 3u * f + ch)];
                let s = select(-1.0, 1.0, f % 2u == 1u);
                l1[ch][a] += 1.5 * s * q * p.cell[a];
            }
        }
    }
    for (var ch = 0u; ch < 3u; ch++) {
        l0[ch] = max(l0[ch], 0.0);
        let norm = length(l1[ch]);
        if !(norm <= 3.0 * l0[ch]) {
            let s = select(0.0, 3.0 * l0[ch] / norm, norm > 0.0 && finite(norm));
            l1[ch] *= s;
        }
        media[m + ch] = l0[ch];
        for (var a = 0u; a < 3u; a++) {
            media[m + 3u + 3u * ch + a] = l1[ch][a];
        }
    }
}

@compute @workgroup_size(4, 4, 4)
fn apply(@builtin(global_invocation_id) v: vec3<u32>) {
    if any(v >= p.dims) {
        return;
    }
    let lin = v.x + p.dims.x * (v.y + p.dims.y * v.z);
    if !lit(v) {
        return;
    }
    let n = p.cells;
    let cf = clamp((vec3<f32>(v) + 0.5) / f32(p.factor) - 0.5, vec3<f32>(0.0), vec3<f32>(n) - 1.0);
    let c0 = min(vec3<u32>(floor(cf)), max(n, vec3<u32>(2u)) - 2u);
    let f = cf - vec3<f32>(c0);
    var ws = 0.0;
    var l0 = vec3<f32>(0.0);
    var l1 = array<vec3<f32>, 3>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var high: array<array<f32, 21>, 3>;
    for (var corner = 0u; corner < 8u; corner++) {
        let o = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
        let cc = min(c0 + o, n - 1u);
        let wv = select(1.0 - f, f, o == vec3<u32>(1u));
        let m = cell_index(cc) * MEDIA;
        let wd = wv.x * wv.y * wv.z * media[m + 13u];
        if !(wd > 0.0) {
            continue;
        }
        ws += wd;
        for (var ch = 0u; ch < 3u; ch++) {
            l0[ch] += wd * media[m + ch];
            l1[ch] += wd * vec3<f32>(media[m + 3u + 3u * ch], media[m + 4u + 3u * ch], media[m + 5u + 3u * ch]);
            for (var j = 0u; j < HIGH; j++) {
                high[ch][j] += wd * band(cell_index(cc), ch, j);
            }
        }
    }
    if !(ws > 0.0) {
        return;
    }
    let view = (vec3<f32>(v) + 0.5) * p.voxel - p.eye;
    let len = length(view);
    if !(len > 0.0) {
        return;
    }
    let d = view / len;
    // Bands 2–4 towards the eye, ω = −d, each scaled by g^l − f (Funk–Hecke on HG less
    // its peak f = g⁵, `grid_diffusion::eye_peak_share`).
    sh_eval(5u, -d);
    let g = p.g;
    let g2 = g * g;
    let peak = select(0.0, g2 * g2 * g, g > 0.0);
    for (var ch = 0u; ch < 3u; ch++) {
        var bands = 0.0;
        for (var j = 0u; j < HIGH; j++) {
            bands += (select(select(g2 * g2, g2 * g, j < 12u), g2, j < 5u) - peak) * high[ch][j] * ysh[4u + j];
        }
        let j = p.albedo * ((1.0 - peak) * l0[ch] - (g - peak) * dot(l1[ch], d) + bands) / ws;
        grid[4u * lin + ch] += max(j, 0.0);
    }
}
