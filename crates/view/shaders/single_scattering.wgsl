// Single scattering at the RBF centers (paper A §5.3, eqs. 10–11): the GPU twin of
// `lighting::single::single_scattering`, in f32. One workgroup of 64 invocations per RBF ℓ.
//
// For each evaluation point p of RBF ℓ (its center, or the six footprint points
// c ± r√(3/2)·e_i of `SourcePoints::Footprint`):
//
//     f(p) = −σt · Σ_h w_h r_h · rot(T(|c_h − p| / r_h), c_h − p)      (`optical_depth_sh`)
//
// the invocations splitting the RBFs h between them (ZH table lookup, linear in the
// paper's angle β, rotated onto the axis c_h − p by y(axis) with band factors √(4π/(2l+1))),
// then a reduction in workgroup memory. τ̃(p) = exp*(f(p)) (`ShExp::exp`): the DC factor
// exp(f_0/(2^k√4π)) exactly, the rest by the Taylor series in triple products (scaling and
// squaring, k halvings) or by the optimal linear table a(‖f̂‖)·1 + b(‖f̂‖)·f̂; then k
// squarings. Invocation i < n² owns coefficient i throughout: a triple product
// (a ∗ b)_i = Σ_{j≤k} Γ_ijk (a_j b_k + a_k b_j) (a_j b_j when j = k) is one row of Γ per
// invocation. τ̃ is the mean over the points; the source is
//
//     J_lm = (Ω/4π) √(4π/(2l+1)) p_l · (L_in ∗ τ̃)_lm        (`conv` holds the factors)
//
// written as (r, g, b, ·) per coefficient; the w of coefficient 0 holds the escape
// probability τ̃_00/√4π ∈ [0, 1] (the diffusion's vacuum correction), the others 0.
// The layout is the volume pass's `source` buffer.

#import sh_basis

struct Params {
    // Number of RBFs.
    count: u32,
    // SH order (bands), 1..=6.
    order: u32,
    // Evaluation points per RBF: 1 (center) or 6 (footprint).
    points: u32,
    // 0: scaling and squaring, k = ⌈log2 ‖f̂‖⌉; 1: scaling and squaring, k = `halvings`;
    // 2: optimal linear (k halvings only beyond the table's last norm).
    method: u32,
    halvings: u32,
    // Rows of `exp_table`.
    table_len: u32,
    // Workgroups per row of the dispatch (ℓ = x + y·groups_x).
    groups_x: u32,
    // −σt.
    neg_sigma_t: f32,
}

#import optics
// √(4π).
const SQRT_4PI: f32 = 3.5449077018110318;
// ZH table samples of β (`zh_table::SAMPLES`).
const SAMPLES: u32 = 256u;
// Most Taylor terms (`exp::TAYLOR_TERMS`).
const TAYLOR_TERMS: u32 = 24u;
// Invocations per workgroup, and the coefficient stride of `partial`.
const THREADS: u32 = 64u;
const MAXC: u32 = 36u;

@group(0) @binding(0) var<storage, read> p: Params;
// Per RBF two vec4: (center, r), (w, 0, 0, 0); centers relative to any common origin.
@group(0) @binding(1) var<storage, read> rbfs: array<vec4<f32>>;
// `ZhTable::rows`: SAMPLES rows of `order` zonal coefficients.
@group(0) @binding(2) var<storage, read> zh: array<f32>;
// Γ by rows: n² + 1 row starts, then per entry (j | k << 16, bits of Γ_ijk).
@group(0) @binding(3) var<storage, read> gamma: array<u32>;
// n² vec4 of L_in (r, g, b, 0), then `order` vec4 of (conv_l, 0, 0, 0).
@group(0) @binding(4) var<storage, read> light: array<vec4<f32>>;
// `ShExp::linear_table`: (‖f̂‖, ln a, ln b, 0), ascending norms.
@group(0) @binding(5) var<storage, read> exp_table: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> source: array<vec4<f32>>;

// Per-invocation partial optical depths, THREADS × MAXC.
var<workgroup> partial: array<f32, 2304>;
// Operands of the triple product.
var<workgroup> va: array<f32, 36>;
var<workgroup> vb: array<f32, 36>;
// Squared norms of the Taylor term and sum (convergence test).
var<workgroup> sq: array<f32, 72>;
var<workgroup> wg_halvings: u32;
var<workgroup> wg_done: u32;
var<workgroup> wg_scale: f32;
var<workgroup> wg_dc: f32;
var<workgroup> wg_nu: f32;

fn band_of(i: u32) -> u32 {
    var l = 0u;
    while (l + 1u) * (l + 1u) <= i {
        l++;
    }
    return l;
}

// (va ∗ vb)_i.
fn triple_row(i: u32) -> f32 {
    let n2 = p.order * p.order;
    let base = n2 + 1u;
    var s = 0.0;
    for (var e = gamma[i]; e < gamma[i + 1u]; e++) {
        let jk = gamma[base + 2u * e];
        let g = bitcast<f32>(gamma[base + 2u * e + 1u]);
        let j = jk & 0xffffu;
        let k = jk >> 16u;
        if j == k {
            s += g * va[j] * vb[j];
        } else {
            s += g * (va[j] * vb[k] + va[k] * vb[j]);
        }
    }
    return s;
}

// (L_in ∗ va)_i per channel.
fn light_row(i: u32) -> vec3<f32> {
    let n2 = p.order * p.order;
    let base = n2 + 1u;
    var s = vec3<f32>(0.0);
    for (var e = gamma[i]; e < gamma[i + 1u]; e++) {
        let jk = gamma[base + 2u * e];
        let g = bitcast<f32>(gamma[base + 2u * e + 1u]);
        let j = jk & 0xffffu;
        let k = jk >> 16u;
        if j == k {
            s += g * light[j].xyz * va[j];
        } else {
            s += g * (light[j].xyz * va[k] + light[k].xyz * va[j]);
        }
    }
    return s;
}

// `zh_table::beta_of`.
fn beta_of(d: f32) -> f32 {
    if d > 1.0 {
        return asin(1.0 / d);
    }
    return acos(max(d, 0.0)) + 0.5 * PI;
}

// `ShExp::coefficients`: (a, b) at ‖f̂‖ = nu, linear in ln a, ln b.
fn linear_coefficients(nu_in: f32) -> vec2<f32> {
    let last = p.table_len - 1u;
    let nu = clamp(nu_in, 0.0, exp_table[last].x);
    // partition_point(x ≤ nu), clamped to 1..=last.
    var i = 1u;
    while i < last && exp_table[i].x <= nu {
        i++;
    }
    let a = exp_table[i - 1u];
    let b = exp_table[i];
    let t = (nu - a.x) / (b.x - a.x);
    return exp(mix(a.yz, b.yz, t));
}

// exp*(f): invocation t < n² passes f_t and gets exp*(f)_t (`ShExp::exp`). Called in
// uniform control flow by the whole workgroup.
fn sh_exp(t: u32, f: f32) -> f32 {
    let n2 = p.order * p.order;
    if t < n2 {
        sq[t] = select(f * f, 0.0, t == 0u);
    }
    workgroupBarrier();
    if t == 0u {
        var nu2 = 0.0;
        for (var i = 1u; i < n2; i++) {
            nu2 += sq[i];
        }
        let nu = sqrt(nu2);
        var k = 0u;
        if p.method == 0u && nu > 1.0 && nu <= 3.4e38 {
            k = u32(ceil(log2(nu)));
        } else if p.method == 1u {
            k = p.halvings;
        } else if p.method == 2u {
            let top = exp_table[p.table_len - 1u].x;
            if nu > top && nu <= 3.4e38 {
                k = u32(ceil(log2(nu / top)));
            }
        }
        let scale = exp2(-f32(k));
        wg_halvings = k;
        wg_scale = scale;
        wg_nu = nu;
        wg_dc = exp(scale * f / SQRT_4PI);
    }
    let k = workgroupUniformLoad(&wg_halvings);
    let scale = wg_scale;
    let g = select(scale * f, 0.0, t == 0u);
    var r = 0.0;
    if p.method == 2u {
        let ab = linear_coefficients(scale * wg_nu);
        r = select(ab.y * g, ab.x * SQRT_4PI, t == 0u);
    } else {
        // Σ_j g^{∗j}/j! until a term is below 1e-7 of the sum (f32 rounding).
        var sum = select(0.0, SQRT_4PI, t == 0u);
        var term = sum;
        if t < n2 {
            vb[t] = g;
        }
        for (var j = 1u; j <= TAYLOR_TERMS; j++) {
            if t < n2 {
                va[t] = term;
            }
            workgroupBarrier();
            var next = 0.0;
            if t < n2 {
                next = triple_row(t);
            }
            term = next / f32(j);
            sum += term;
            if t < n2 {
                sq[t] = term * term;
                sq[MAXC + t] = sum * sum;
            }
            workgroupBarrier();
            if t == 0u {
                var tn = 0.0;
                var sn = 0.0;
                for (var i = 0u; i < n2; i++) {
                    tn += sq[i];
                    sn += sq[MAXC + i];
                }
                wg_done = select(0u, 1u, sqrt(tn) <= 1e-7 * sqrt(sn));
            }
            if workgroupUniformLoad(&wg_done) == 1u {
                break;
            }
        }
        r = sum;
    }
    r *= wg_dc;
    for (var s = 0u; s < k; s++) {
        if t < n2 {
            va[t] = r;
            vb[t] = r;
        }
        workgroupBarrier();
        if t < n2 {
            r = triple_row(t);
        }
        workgroupBarrier();
    }
    return r;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let l = wg.x + wg.y * p.groups_x;
    if l >= p.count {
        return;
    }
    let n = p.order;
    let n2 = n * n;
    let c = rbfs[2u * l].xyz;
    let r = max(rbfs[2u * l].w, 0.0);
    var tau = 0.0;
    for (var q = 0u; q < p.points; q++) {
        var pt = c;
        if p.points == 6u {
            let a = r * sqrt(1.5);
            pt[q / 2u] += select(-a, a, q % 2u == 0u);
        }
        // Σ_h w_h r_h T_h over this invocation's share of the RBFs.
        var f: array<f32, 36>;
        for (var h = t; h < p.count; h += THREADS) {
            let ch = rbfs[2u * h];
            let w = rbfs[2u * h + 1u].x;
            let rh = ch.w;
            if !(rh > 0.0 && rh <= 3.4e38) || w == 0.0 {
                continue;
            }
            let a = ch.xyz - pt;
            let dist = length(a);
            let fb = beta_of(dist / rh) / PI * f32(SAMPLES - 1u);
            let kb = min(u32(max(floor(fb), 0.0)), SAMPLES - 2u);
            let tb = clamp(fb - f32(kb), 0.0, 1.0);
            let s = w * rh;
            if dist <= 1e-12 * rh {
                f[0] += s * mix(zh[kb * n], zh[(kb + 1u) * n], tb);
                continue;
            }
            sh_eval(n, a);
            for (var b = 0u; b < n; b++) {
                let z = mix(zh[kb * n + b], zh[(kb + 1u) * n + b], tb);
                let kz = s * sqrt(4.0 * PI / f32(2u * b + 1u)) * z;
                for (var i = b * b; i < (b + 1u) * (b + 1u); i++) {
                    f[i] += kz * ysh[i];
                }
            }
        }
        for (var i = 0u; i < n2; i++) {
            partial[t * MAXC + i] = f[i];
        }
        workgroupBarrier();
        var depth = 0.0;
        if t < n2 {
            for (var k = 0u; k < THREADS; k++) {
                depth += partial[k * MAXC + t];
            }
        }
        workgroupBarrier();
        tau += sh_exp(t, p.neg_sigma_t * depth) / f32(p.points);
    }
    if t < n2 {
        va[t] = tau;
    }
    workgroupBarrier();
    if t < n2 {
        let j = light_row(t) * light[n2 + band_of(t)].x;
        var escape = 0.0;
        if t == 0u {
            let e = tau / SQRT_4PI;
            // Finite (exponent bits not all set): NaN and ±∞ escape nothing.
            if (bitcast<u32>(e) & 0x7f800000u) != 0x7f800000u {
                escape = clamp(e, 0.0, 1.0);
            }
        }
        source[l * n2 + t] = vec4<f32>(j, escape);
    }
}
