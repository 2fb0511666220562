// Volume pass of compensated ray marching (paper A §5.5, eqs. 14–15): the GPU twin of
// `render::crm::volume_pass`, in f32, one invocation per voxel center u.
//
//     D̃(u) = Σ_ℓ w_ℓ B_ℓ(u),   B_ℓ(u) = exp(−|u − c_ℓ|²/r_ℓ²) for |u − c_ℓ| < 3r_ℓ, else 0
//     J̃(u, d) = Σ_ℓ w_ℓ B_ℓ(u) (y(d)·J̃(c_ℓ)) / D̃(u)        (clamped ≥ 0)
//     D(u) = max(D̃(u) + R(u), 0)
//
// with d = u − eye (normalized) and y the real SH basis of `sh::eval_into` (`sh_basis.wgsl`,
// prepended to this file). Where
// D̃ < MIN_DENSITY the residual is ignored, D = max(D̃, 0) and J̃ = 0. y(d) is evaluated
// once per voxel, so each RBF costs one dot product of n² coefficients per channel, the
// same sum as the CPU's y·Σ w B J̃(c) taken in the other order.
//
// RBFs are culled per workgroup: a 4×4×4 tile of voxels tests 64 RBFs at a time (one per
// invocation) against the box of its voxel centers, collects the hits in a 64-bit mask,
// and every voxel of the tile then visits only those, in ascending order (the CPU's
// order, and the same order on every run). The per-voxel cut-off test is Rbf::eval's.
//
// The residual R is a dense f32 grid, or the frame's slot of a perfect spatial hash of
// voxel bricks (`ResidualGroup::lookup`, `PerfectHash::get`, `pack::get`) looked up here:
// one u32 buffer holding the offset table Φ (x | y << 10 | z << 20), the keys (linear brick
// index in the hash domain + 1, 0 for an empty slot), the payloads (first data word << 3 |
// width code: 2, 4, 8, 16 bits, or 32 for f32 values) and the bricks' packed values.
//
// Positions are relative to the box's minimum corner, like the view pass. The output is
// the view pass's grid: J̃ in xyz, D in w, x fastest.

#import sh_basis

struct Params {
    // Eye relative to the box's minimum corner.
    eye: vec3<f32>,
    // Number of RBFs.
    count: u32,
    voxel: vec3<f32>,
    // SH order (bands), 1..=6.
    order: u32,
    dims: vec3<u32>,
    // 0: no residual, 1: dense f32 (bits in `residual`), 2: the hash in `residual`.
    residual_kind: u32,
    // Hash domain in bricks (three frames wide on every axis) and table side m̄.
    hash_domain: vec3<u32>,
    hash_m: u32,
    // Brick-space origin of the frame's tile (`tile_origin`) and offset table side r̄.
    tile: vec3<u32>,
    hash_r: u32,
    // Where the keys, payloads and packed values start in `residual` (Φ starts at 0).
    keys_at: u32,
    payloads_at: u32,
    data_at: u32,
    // Brick side in voxels.
    brick: u32,
    // Dequantization step of the frame.
    step: f32,
}

// `crm::MIN_DENSITY`.
const MIN_DENSITY: f32 = 1e-10;
// Support radius in units of r, squared (`rbf::CUTOFF`²).
const CUTOFF2: f32 = 9.0;
// Voxels per tile side, and RBFs tested per round (one per invocation).
const SIDE: u32 = 4u;
const CHUNK: u32 = 64u;

@group(0) @binding(0) var<storage, read> p: Params;
// Per RBF two vec4: (center relative to the box, 1/r), (w, culling radius², 0, 0); the
// culling radius² is (3r)² with a margin, or −1 for an RBF without support.
@group(0) @binding(1) var<storage, read> rbfs: array<vec4<f32>>;
// Per RBF n² coefficients, each (r, g, b, 0): J̃(c_ℓ) as a function of the viewing
// direction.
@group(0) @binding(2) var<storage, read> source: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> residual: array<u32>;
@group(0) @binding(4) var<storage, read_write> grid: array<vec4<f32>>;

// RBFs of the current round whose support meets the tile (bit i: RBF base + i).
var<workgroup> hit_bits: array<atomic<u32>, 2>;
var<workgroup> hit_mask: vec2<u32>;

// `PerfectHash::get`: the payload stored for brick c of the hash domain; 0xffffffff if none
// (no payload has all bits set: its width code is at most 4).
fn hash_get(c: vec3<u32>) -> u32 {
    let d = p.hash_domain;
    if any(c >= d) {
        return 0xffffffffu;
    }
    let m = p.hash_m;
    let r = p.hash_r;
    let cr = c % r;
    let o = residual[cr.x + r * (cr.y + r * cr.z)];
    let phi = vec3<u32>(o & 1023u, (o >> 10u) & 1023u, (o >> 20u) & 1023u);
    let h = (c % m + phi) % m;
    let s = h.x + m * (h.y + m * h.z);
    if residual[p.keys_at + s] != c.x + d.x * (c.y + d.y * c.z) + 1u {
        return 0xffffffffu;
    }
    return residual[p.payloads_at + s];
}

// R at voxel i (linear index `lin`): `ResidualGroup::lookup` of the frame's tile — the
// brick's payload, then value k of the brick at its width (`pack::get`) — dequantized
// as the CPU does (f32(q)·step, or the f32 itself at 32 bits).
fn residual_at(i: vec3<u32>, lin: u32) -> f32 {
    switch p.residual_kind {
        case 1u: {
            return bitcast<f32>(residual[lin]);
        }
        case 2u: {
            let b = p.brick;
            let payload = hash_get(p.tile + i / b);
            if payload == 0xffffffffu {
                return 0.0;
            }
            let code = payload & 7u;
            let w = 2u << code;
            let l = i % b;
            let k = l.x + b * (l.y + b * l.z);
            let bit = k * w;
            let v = residual[p.data_at + (payload >> 3u) + bit / 32u] >> (bit % 32u);
            if w == 32u {
                return bitcast<f32>(v);
            }
            // Sign-extend the w-bit value (>> on i32 is arithmetic).
            let q = bitcast<i32>(v << (32u - w)) >> (32u - w);
            return f32(q) * p.step;
        }
        default: {
            return 0.0;
        }
    }
}

@compute @workgroup_size(4, 4, 4)
fn main(
    @builtin(workgroup_id) wg: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = wg * SIDE + local;
    // Invocations past the grid's edge still take part in the culling (barriers).
    let inside = all(i < p.dims);
    let u = (vec3<f32>(i) + 0.5) * p.voxel;
    // The tile's voxel centers, same arithmetic as u.
    let first = wg * SIDE;
    let last = min(first + (SIDE - 1u), max(p.dims, vec3<u32>(1u)) - 1u);
    let lo = (vec3<f32>(first) + 0.5) * p.voxel;
    let hi = (vec3<f32>(last) + 0.5) * p.voxel;
    let n2 = p.order * p.order;
    if inside {
        sh_eval(p.order, u - p.eye);
    }
    var dt = 0.0;
    var acc = vec3<f32>(0.0);
    for (var base = 0u; base < p.count; base += CHUNK) {
        if lid == 0u {
            atomicStore(&hit_bits[0], 0u);
            atomicStore(&hit_bits[1], 0u);
        }
        workgroupBarrier();
        let l = base + lid;
        if l < p.count {
            let c = rbfs[2u * l];
            let cull2 = rbfs[2u * l + 1u].y;
            let gap = max(max(lo - c.xyz, c.xyz - hi), vec3<f32>(0.0));
            if dot(gap, gap) <= cull2 {
                atomicOr(&hit_bits[lid / 32u], 1u << (lid % 32u));
            }
        }
        workgroupBarrier();
        if lid == 0u {
            hit_mask = vec2<u32>(atomicLoad(&hit_bits[0]), atomicLoad(&hit_bits[1]));
        }
        // Uniform: every invocation of the workgroup reaches the barriers of each round
        // (a `continue` for the voxels outside would break that).
        let mask = workgroupUniformLoad(&hit_mask);
        if inside {
            for (var word = 0u; word < 2u; word++) {
                var bits = mask[word];
                while bits != 0u {
                    let k = base + 32u * word + firstTrailingBit(bits);
                    bits &= bits - 1u;
                    let c = rbfs[2u * k];
                    let q = (u - c.xyz) * c.w;
                    let q2 = dot(q, q);
                    if q2 >= CUTOFF2 {
                        continue;
                    }
                    let b = rbfs[2u * k + 1u].x * exp(-q2);
                    dt += b;
                    var s = vec3<f32>(0.0);
                    let at = k * n2;
                    for (var j = 0u; j < n2; j++) {
                        s += ysh[j] * source[at + j].xyz;
                    }
                    acc += b * s;
                }
            }
        }
    }
    if !inside {
        return;
    }
    let lin = i.x + p.dims.x * (i.y + p.dims.y * i.z);
    if dt < MIN_DENSITY {
        grid[lin] = vec4<f32>(0.0, 0.0, 0.0, max(dt, 0.0));
        return;
    }
    let d = max(dt + residual_at(i, lin), 0.0);
    grid[lin] = vec4<f32>(max(acc / dt, vec3<f32>(0.0)), d);
}
