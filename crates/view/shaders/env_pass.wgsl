// Environment pass of the fast renderer: the GPU twin of `render::env_pass`, in f32, on the
// volume pass's grid (prepended with `sh_basis.wgsl`). Three entry points:
//
// `needed`, one invocation per node x of the environment's grid: whether some voxel
// center with D > 0 lies within one cell and one voxel of the node (per axis, strictly),
// so that the pass reads it, and the box of node indices holding those nodes (the
// domain).
//
// `sweep`, dispatched once per block of STRIDE node planes and per group of directions
// (those crossing the same axis's planes fastest, in the same sense), one invocation per
// node: at the needed nodes the light the smoke takes away
//
//     S_lm(x) = Σ_k w_k·L(ω_k)·(1 − T(x, ω_k))·Y_lm(ω_k)
//
// over the direction rule (uploaded: ω, w·L(ω), Y(ω)), T = exp(−σt·τ), the depths τ by
// `render::env_sweep`'s sweep: a segment of STRIDE planes by the midpoint rule plus the
// depth read bilinearly from the plane there, or a march through the grid's D with
// `lights_pass::optical_depth`'s midpoint rule (n = ⌈ℓ/h0⌉ equal steps to the box's
// face, trilinear D, stopping once σt·τ > SHADOW_CUTOFF; the samples in blocks without
// density passed over, `blocked_depth`) for the domain's first STRIDE planes and the
// rays that leave it through a side; 0 at the other nodes.
//
// `apply`, one invocation per voxel center u with D(u) > 0, seen along d (from the eye):
//
//     J̃(u, d) += max(0, Σ_j Ω·g^l·(L_j − S_j(u))·Y_j(d))
//
// S trilinear between the nodes (`ShGrid::at`). It writes the J words of its own voxel and
// reads only D words and S, so it runs in place without races.
// Positions are relative to the box's minimum corner (f32 precision far from the origin).

#import sh_basis
#import grid_march
#import block_skip
#import lit
#import lat_long

struct Params {
    // Eye relative to the box's minimum corner.
    eye: vec3<f32>,
    sigma_t: f32,
    voxel: vec3<f32>,
    // The march's step bound: the smallest voxel side.
    h0: f32,
    // Box size.
    size: vec3<f32>,
    // SH order.
    order: u32,
    dims: vec3<u32>,
    // Directions of the rule.
    directions: u32,
    // The first node, relative to the box.
    node_min: vec3<f32>,
    // `apply`: Ω·f of the forward peak (`env_pass::peak_share`), 0 for none.
    peak: f32,
    // Distance between nodes per axis (0 on an axis of one node).
    cell: vec3<f32>,
    // `apply`: cells of the forward peak's rule (`render::peak_rule`).
    peak_cells: u32,
    nodes: vec3<u32>,
    // `apply`: directions per cell of the peak's rule.
    peak_azimuths: u32,
}

@group(0) @binding(0) var<storage, read> p: Params;
// `shadow`: per direction 4 + 4 + order² words: ω x y z, 0, w·L r g b, 0, Y_j(ω).
// `apply`: per coefficient j (order² of them) L_j r g b, Ω·(g^l − f); then the forward
// peak's sky (`env_pass::peak_sky`), PEAK_W × PEAK_H texels r g b from the zenith row;
// then per cell of the peak's rule cos θ, sin θ, Ω·weight, 0.
@group(0) @binding(1) var<storage, read> table: array<f32>;
// Per voxel (x fastest): J̃ r g b, D.
@group(0) @binding(2) var<storage, read_write> grid: array<f32>;
// Per node (x fastest) 3·order² words: S_j r g b per coefficient.
@group(0) @binding(3) var<storage, read_write> shadow_sh: array<f32>;
// `shadow`: per block of OCCUPANCY_BLOCK³ voxels (x fastest) whether the march must
// sample it (`occupancy.wgsl`).
@group(0) @binding(4) var<storage, read> occupancy: array<u32>;

// `env_pass::PEAK_SKY`.
const PEAK_W: u32 = 64u;
const PEAK_H: u32 = 32u;

fn peak_texel(x: u32, y: u32) -> vec3<f32> {
    let i = 4u * p.order * p.order + 3u * (y * PEAK_W + x);
    return vec3<f32>(table[i], table[i + 1u], table[i + 2u]);
}

// `LatLong::radiance` of the forward peak's sky.
fn peak_sky(d: vec3<f32>) -> vec3<f32> {
    let s = lat_long_stencil(d, vec2<u32>(PEAK_W, PEAK_H));
    return lat_long_blend(s, peak_texel(s.xa, s.ya), peak_texel(s.xb, s.ya), peak_texel(s.xa, s.yb), peak_texel(s.xb, s.yb));
}

// The forward peak's light at u seen along the unit d (`render::peak_rule`): over the
// rule's cells and azimuths around d, turned by voxel lin's spin, the light behind u
// through the smoke; the δ (one cell at θ 0, one azimuth) is d itself.
fn peak_light(u: vec3<f32>, d: vec3<f32>, lin: u32, n2: u32) -> vec3<f32> {
    // `peak_rule::tangents`.
    let a = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), abs(d.x) < 0.9);
    let c = cross(d, a);
    let n = length(c);
    let t1 = select(vec3<f32>(0.0), c / n, n > 0.0);
    let t2 = cross(d, t1);
    // `peak_rule::spin`.
    let spin = f32(lin * 0x9E3779B9u) * (1.0 / 4294967296.0);
    let k = p.peak_azimuths;
    let base = 4u * n2 + 3u * PEAK_W * PEAK_H;
    var light = vec3<f32>(0.0);
    for (var r = 0u; r < p.peak_cells; r++) {
        let cell = vec3<f32>(table[base + 4u * r], table[base + 4u * r + 1u], table[base + 4u * r + 2u]);
        for (var j = 0u; j < k; j++) {
            let phi = 6.283185307179586 * (f32(j) + 0.5 * f32(r) + spin) / f32(k);
            let w = cell.x * d + cell.y * (cos(phi) * t1 + sin(phi) * t2);
            light += (cell.z / f32(k)) * peak_sky(w) * transmittance(u, w, 3.0e38);
        }
    }
    return light;
}

// `grid_march::optical_depth` from u along s to the box's face, skipping the samples
// that fall in empty blocks: the same samples, summed in the same order, less exact
// zeros (`occupancy.wgsl`), so the same value. From a sample in an empty block it jumps
// to the last sample before the block's exit (rounded down, so no sample beyond the
// exit is ever passed over; at least one step).
fn blocked_depth(u: vec3<f32>, s: vec3<f32>) -> f32 {
    let len = exit_distance(u, s);
    if !(len > 0.0) {
        return 0.0;
    }
    let n = u32(max(ceil(len / p.h0), 1.0));
    let h = len / f32(n);
    let side = f32(OCCUPANCY_BLOCK) * p.voxel;
    let blocks = (p.dims + OCCUPANCY_BLOCK - 1u) / OCCUPANCY_BLOCK;
    var depth = 0.0;
    var k = 0u;
    loop {
        if k >= n {
            break;
        }
        let t = (f32(k) + 0.5) * h;
        let q = u + t * s;
        let b = block_of(q, side, blocks);
        if occupancy[b.x + blocks.x * (b.y + blocks.y * b.z)] == 0u {
            let out = block_exit(q, s, b, side);
            let next = floor((t + max(out, 0.0)) / h - 0.5);
            k = max(u32(max(next, 0.0)), k + 1u);
            continue;
        }
        depth += p.sigma_t * sample_density(q) * h;
        if depth > SHADOW_CUTOFF {
            break;
        }
        k++;
    }
    return depth;
}

// Voxel index range (inclusive) along axis a whose centers lie strictly within one cell
// and one voxel of the node coordinate x; lo > hi when none. An axis of one node covers
// every voxel. A voxel with D > 0 there puts a lit voxel (`lit`: it or its neighbour
// towards x) within one cell of the node: `env_pass::needed_nodes`.
fn voxel_range(a: u32, x: f32) -> vec2<i32> {
    let last = i32(p.dims[a]) - 1;
    if p.nodes[a] < 2u || !(p.cell[a] > 0.0) {
        return vec2<i32>(0, last);
    }
    // Center k at (k + ½)·voxel: |(k + ½)·voxel − x| < cell + voxel.
    let reach = p.cell[a] + p.voxel[a];
    let lo = i32(floor((x - reach) / p.voxel[a] - 0.5)) + 1;
    let hi = i32(ceil((x + reach) / p.voxel[a] - 0.5)) - 1;
    return vec2<i32>(max(lo, 0), min(hi, last));
}

fn node_needed(x: vec3<f32>) -> bool {
    let rx = voxel_range(0u, x.x);
    let ry = voxel_range(1u, x.y);
    let rz = voxel_range(2u, x.z);
    for (var z = rz.x; z <= rz.y; z++) {
        for (var y = ry.x; y <= ry.y; y++) {
            for (var k = rx.x; k <= rx.y; k++) {
                if density(vec3<u32>(u32(k), u32(y), u32(z))) > 0.0 {
                    return true;
                }
            }
        }
    }
    return false;
}

// `needed`'s and `sweep`'s words before the nodes' flags: the domain, per axis the
// first (words 0..2) and the last (words 3..5) index of a needed node (first > last
// without one).
const DOMAIN_WORDS: u32 = 6u;

// `env_sweep::STRIDE`: a node's depth is read from the node plane STRIDE planes nearer
// the face its ray leaves by.
const STRIDE: u32 = 4u;

// Node planes a direction's ring keeps: the block being swept and the one it reads.
const RING: u32 = 8u;

// `env_sweep::DEPTH_CAP`: the largest depth kept (a NaN one too).
const DEPTH_CAP: f32 = 1.0e30;

// Node units of slack on the domain's edge for a read's rounding (`plane_sweep`'s
// `stencil`).
const EDGE: f32 = 1.0e-4;

// `sweep`'s record for one dispatch: one block of STRIDE node planes of one group of
// directions, those the host found sweeping along the same axis in the same sense.
struct Block {
    // The sweep's axis k (the axis whose node planes the group's rays cross fastest).
    axis: u32,
    // 1 when the rays leave by k's far face (ω_k > 0): the planes from the last.
    descending: u32,
    // The group's directions: the rule's entries first .. first + count.
    first: u32,
    count: u32,
    // The block's first plane in sweep order (a multiple of STRIDE).
    start: u32,
    // Nodes in a plane across this axis: nodes[k + 1]·nodes[k + 2].
    plane: u32,
    // Words per ring plane: the largest plane over the axes.
    ring_plane: u32,
    _pad: u32,
}

// `needed`: DOMAIN_WORDS words, then per node 1 where the pass reads it.
@group(0) @binding(5) var<storage, read_write> state: array<atomic<u32>>;
// `sweep`: per direction of the rule RING planes of ring_plane depths σt·τ.
@group(0) @binding(6) var<storage, read_write> ring: array<f32>;
@group(0) @binding(7) var<storage, read> block: Block;

var<workgroup> wg_lo: array<atomic<u32>, 3>;
var<workgroup> wg_hi: array<atomic<u32>, 3>;

fn node_of(node: u32) -> vec3<u32> {
    return vec3<u32>(node % p.nodes.x, (node / p.nodes.x) % p.nodes.y, node / (p.nodes.x * p.nodes.y));
}

// One invocation per node: whether the pass reads it (`node_needed`), and the domain of
// the nodes it reads (reduced in the workgroup first).
@compute @workgroup_size(64)
fn needed(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) ng: vec3<u32>) {
    if li < 3u {
        atomicStore(&wg_lo[li], 0xffffffffu);
        atomicStore(&wg_hi[li], 0u);
    }
    workgroupBarrier();
    let node = gid.x + 64u * ng.x * gid.y;
    if node < p.nodes.x * p.nodes.y * p.nodes.z {
        let idx = node_of(node);
        let need = node_needed(p.node_min + vec3<f32>(idx) * p.cell);
        atomicStore(&state[DOMAIN_WORDS + node], select(0u, 1u, need));
        if need {
            for (var a = 0u; a < 3u; a++) {
                atomicMin(&wg_lo[a], idx[a]);
                atomicMax(&wg_hi[a], idx[a]);
            }
        }
    }
    workgroupBarrier();
    if li < 3u {
        let lo = atomicLoad(&wg_lo[li]);
        let hi = atomicLoad(&wg_hi[li]);
        if lo <= hi {
            atomicMin(&state[li], lo);
            atomicMax(&state[3u + li], hi);
        }
    }
}

struct Stencil {
    ok: bool,
    i0: u32,
    f: f32,
}

// `plane_sweep::Sweep::stencil`: where x (box-relative) falls on axis a among the
// domain's nodes lo..=hi: the lower node and the fraction to the next; not ok outside
// the domain (or off its one node, on an axis of one).
fn stencil(a: u32, x: f32, lo: u32, hi: u32) -> Stencil {
    let cell = p.cell[a];
    if hi == lo || !(cell > 0.0) {
        let on = p.node_min[a] + f32(lo) * cell;
        let scale = max(max(max(p.cell.x, p.cell.y), p.cell.z), max(max(p.voxel.x, p.voxel.y), p.voxel.z));
        return Stencil(abs(x - on) <= 1.0e-5 * scale, lo, 0.0);
    }
    let f = (x - p.node_min[a]) / cell;
    if !(f >= f32(lo) - EDGE && f <= f32(hi) + EDGE) {
        return Stencil(false, 0u, 0.0);
    }
    let c = clamp(f, f32(lo), f32(hi));
    let i0 = min(u32(floor(c)), hi - 1u);
    return Stencil(true, i0, c - f32(i0));
}

// `env_sweep`'s segment: σt·∫₀^{s1} D(x + sω) ds by the midpoint rule, m = ⌈s1/step⌉
// samples, step the smallest node cell but never finer than h0.
fn segment_depth(x: vec3<f32>, w: vec3<f32>, s1: f32) -> f32 {
    var cell = 3.0e38;
    for (var a = 0u; a < 3u; a++) {
        if p.cell[a] > 0.0 {
            cell = min(cell, p.cell[a]);
        }
    }
    let step = select(p.h0, max(cell, p.h0), cell < 3.0e38);
    let m = max(ceil(s1 / step), 1.0);
    let h = s1 / m;
    var sum = 0.0;
    for (var j = 0u; j < u32(m); j++) {
        sum += sample_density(x + (f32(j) + 0.5) * h * w);
    }
    return p.sigma_t * sum * h;
}

// One invocation per node of the block's STRIDE planes (within the domain): for each of
// the group's directions ω its depth σt·τ(x, ω) — the segment to the plane STRIDE planes
// on plus the depth there read bilinearly from that plane's nodes (swept by an earlier
// dispatch), or a march to the face for the domain's first STRIDE planes and the rays
// whose read point leaves the domain (`env_sweep::sweep_depths`) — kept in the
// direction's ring, and at a needed node the light lost added to its S.
@compute @workgroup_size(64)
fn sweep(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) ng: vec3<u32>) {
    let id = gid.x + 64u * ng.x * gid.y;
    if id >= STRIDE * block.plane {
        return;
    }
    let k = block.axis;
    let a = (k + 1u) % 3u;
    let b = (k + 2u) % 3u;
    let inplane = id % block.plane;
    let ia = inplane % p.nodes[a];
    let ib = inplane / p.nodes[a];
    let at_order = block.start + id / block.plane;
    if at_order >= p.nodes[k] {
        return;
    }
    let descending = block.descending == 1u;
    let plane = select(at_order, p.nodes[k] - 1u - at_order, descending);
    let lo = vec3<u32>(atomicLoad(&state[0]), atomicLoad(&state[1]), atomicLoad(&state[2]));
    let hi = vec3<u32>(atomicLoad(&state[3]), atomicLoad(&state[4]), atomicLoad(&state[5]));
    if plane < lo[k] || plane > hi[k] || ia < lo[a] || ia > hi[a] || ib < lo[b] || ib > hi[b] {
        return;
    }
    var idx = vec3<u32>(0u);
    idx[k] = plane;
    idx[a] = ia;
    idx[b] = ib;
    let node = idx.x + p.nodes.x * (idx.y + p.nodes.y * idx.z);
    let x = p.node_min + vec3<f32>(idx) * p.cell;
    let need = atomicLoad(&state[DOMAIN_WORDS + node]) == 1u;
    let step = select(plane - lo[k], hi[k] - plane, descending);
    let sweeps = step >= STRIDE && p.cell[k] > 0.0;
    let up = select(plane - STRIDE, plane + STRIDE, descending) % RING;
    let n2 = p.order * p.order;
    let k3 = 3u * n2;
    let stride = 8u + n2;
    var s: array<f32, 108>;
    for (var j = 0u; j < k3; j++) {
        s[j] = 0.0;
    }
    for (var d = block.first; d < block.first + block.count; d++) {
        let at = d * stride;
        let w = vec3<f32>(table[at], table[at + 1u], table[at + 2u]);
        var tau = 0.0;
        var read = false;
        if sweeps && w[k] != 0.0 {
            let s1 = f32(STRIDE) * p.cell[k] / abs(w[k]);
            let q = x + s1 * w;
            let sa = stencil(a, q[a], lo[a], hi[a]);
            let sb = stencil(b, q[b], lo[b], hi[b]);
            if sa.ok && sb.ok {
                read = true;
                let base = (d * RING + up) * block.ring_plane;
                let a1 = min(sa.i0 + 1u, hi[a]);
                let b1 = min(sb.i0 + 1u, hi[b]);
                let na = p.nodes[a];
                let reads = (1.0 - sa.f) * (1.0 - sb.f) * ring[base + sa.i0 + na * sb.i0]
                    + sa.f * (1.0 - sb.f) * ring[base + a1 + na * sb.i0]
                    + (1.0 - sa.f) * sb.f * ring[base + sa.i0 + na * b1]
                    + sa.f * sb.f * ring[base + a1 + na * b1];
                tau = segment_depth(x, w, s1) + reads;
            }
        }
        if !read {
            tau = blocked_depth(x, w);
        }
        if !(tau < DEPTH_CAP) {
            tau = DEPTH_CAP;
        }
        ring[(d * RING + plane % RING) * block.ring_plane + inplane] = tau;
        if need {
            let lost = one_minus_exp(tau);
            if lost == 0.0 {
                continue;
            }
            let l = lost * vec3<f32>(table[at + 4u], table[at + 5u], table[at + 6u]);
            for (var j = 0u; j < n2; j++) {
                let y = table[at + 8u + j];
                s[3u * j] += l.x * y;
                s[3u * j + 1u] += l.y * y;
                s[3u * j + 2u] += l.z * y;
            }
        }
    }
    if need {
        for (var j = 0u; j < k3; j++) {
            shadow_sh[node * k3 + j] += s[j];
        }
    }
}

@compute @workgroup_size(4, 4, 4)
fn apply(@builtin(global_invocation_id) i: vec3<u32>) {
    if any(i >= p.dims) {
        return;
    }
    let lin = i.x + p.dims.x * (i.y + p.dims.y * i.z);
    if !lit(i) {
        return;
    }
    let u = (vec3<f32>(i) + 0.5) * p.voxel;
    let view = u - p.eye;
    if !(length(view) > 0.0) {
        return;
    }
    sh_eval(p.order, view);
    // `ShGrid::stencil`.
    var i0 = vec3<u32>(0u);
    var f = vec3<f32>(0.0);
    for (var a = 0u; a < 3u; a++) {
        if p.nodes[a] < 2u || !(p.cell[a] > 0.0) {
            continue;
        }
        let t = clamp((u[a] - p.node_min[a]) / p.cell[a], 0.0, f32(p.nodes[a] - 1u));
        i0[a] = min(u32(floor(t)), p.nodes[a] - 2u);
        f[a] = t - f32(i0[a]);
    }
    let n2 = p.order * p.order;
    let k3 = 3u * n2;
    var acc = vec3<f32>(0.0);
    for (var corner = 0u; corner < 8u; corner++) {
        let d = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, corner >> 2u);
        var w = 1.0;
        for (var a = 0u; a < 3u; a++) {
            if d[a] == 1u {
                w *= select(f[a], 0.0, p.nodes[a] < 2u);
            } else {
                w *= 1.0 - f[a];
            }
        }
        if w == 0.0 {
            continue;
        }
        let c = i0 + d;
        let node = c.x + p.nodes.x * (c.y + p.nodes.y * c.z);
        for (var j = 0u; j < n2; j++) {
            let a = table[4u * j + 3u] * ysh[j] * w;
            acc -= a * vec3<f32>(shadow_sh[node * k3 + 3u * j], shadow_sh[node * k3 + 3u * j + 1u], shadow_sh[node * k3 + 3u * j + 2u]);
        }
    }
    for (var j = 0u; j < n2; j++) {
        acc += table[4u * j + 3u] * ysh[j] * vec3<f32>(table[4u * j], table[4u * j + 1u], table[4u * j + 2u]);
    }
    var add = max(acc, vec3<f32>(0.0));
    if p.peak > 0.0 {
        add += peak_light(u, normalize(view), lin, n2);
    }
    for (var c = 0u; c < 3u; c++) {
        grid[4u * lin + c] += add[c];
    }
}
