// Multiple scattering by diffusion on the GPU (paper A §5.4): the twin of
// `diffusion::Operators::system`, `diffusion::cgls` and `Operators::ms_source_sh`, in f32.
//
// One workgroup per colour channel in `setup`, `iterate` and `finish`. From the frame's
// geometric operators (`diffusion::operators` module docs) and the single-scattering
// sources it forms
//   A_hl = (1 − P_h) diffusion_hl/(3σtr) − (σa + σs P_h) v_hl
//   b_h  = Σ_l (1 − P_l) [−σt v_hl J⁰_l + (σt/(3σtr)) grad_hl · J¹_l]
// row-equilibrates (R) and column-scales (C) A as the CPU's CGLS does (`setup`), runs CGLS
// on M = R A C from the start in `work` (the previous frame's L⁰ or zero) in chunks of
// iterations (`iterate`, dispatched as often as `max_iterations` needs), and writes the
// multiple-scattering source (`finish`)
//   J_ms = (Ω 2√π L⁰, Ω g √(4π/3)·(L¹_y, L¹_z, L¹_x)),
//   L¹ = (σt D̃ (1 − P_h) J¹ − ∇L⁰)/(σtr D̃)
// (direction of propagation). `add`: one invocation per center adds J_ms to the sources,
// band 1 negated (propagation → viewing direction).
//
// J⁰ and J¹ come from the sources' bands 0 and 1 (viewing direction):
//   J⁰ = J_00/√4π,  J¹ = −√(3/4π)·(J_11, J_1−1, J_10);
// plus, when `params.direct` is 1, the direct light of the suns and point lights at the
// centers (`lighting::direct::add_light_moments`, computed on the host): per center and
// channel one vec4 (J⁰, J¹ x y z) in `direct`;
// P_h (escape probability) from the `w` of the center's first coefficient. Non-finite
// inputs count as 0, as on the CPU.
//
// `work`, f32: per channel c at 8nc: x, r, s, p, q, row scale, column scale, b (n each);
// then J_ms at 24n + (3h + c)·4 + k; then per channel at 36n + 8c the solver's state:
// iterations, relative residual ‖b − A x‖/‖b‖, converged (1 or 0), γ, ‖b‖, ‖M‖_F, ‖r‖,
// stopped (1 or 0).

struct Params {
    n: u32,
    // SH coefficients per center in `sources` (order²).
    n2: u32,
    max_iterations: u32,
    // 1: start from x in `work`, 0: from zero.
    warm: u32,
    tolerance: f32,
    sigma_t: f32,
    sigma_s: f32,
    sigma_a: f32,
    sigma_tr: f32,
    // Ω 2√π and Ω g √(4π/3).
    band0: f32,
    band1: f32,
    // Iterations per `iterate` dispatch.
    chunk: u32,
    // 1: add the lights' moments in `direct`, 0: there are none (`direct` is a dummy).
    direct: u32,
    _p0: u32,
    _p1: u32,
    _p2: u32,
};

// diffusion_hl, v_hl, grad_hl (module docs of `diffusion::operators`) of column `col`.
struct Entry {
    col: u32,
    diffusion: f32,
    v: f32,
    gx: f32,
    gy: f32,
    gz: f32,
    _p0: f32,
    _p1: f32,
};

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read_write> sources: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> work: array<f32>;
// Row starts (n + 1), column starts (n + 1), then per column its (row, entry) pairs.
@group(0) @binding(3) var<storage, read> index: array<u32>;
@group(0) @binding(4) var<storage, read> entries: array<Entry>;
// D̃(c_h), 0 at an inactive center, whose row holds one entry, the identity's (col h).
@group(0) @binding(5) var<storage, read> density: array<f32>;
// The lights' direct J⁰ and J¹ (direction of propagation) per center and channel, at
// (3h + c): (J⁰, J¹x, J¹y, J¹z).
@group(0) @binding(6) var<storage, read> direct: array<vec4<f32>>;

const WG: u32 = 256u;

#import finite
#import workgroup_sum
// A least-squares optimum is reached when ‖Mᵀ R r‖ ≤ LS_OPTIMAL ‖M‖_F ‖R r‖ (the CPU's
// 1e-12 is below f32 rounding; this is a few ulps).
const LS_OPTIMAL: f32 = 1e-6;


fn escape(h: u32) -> f32 {
    let p = sources[h * params.n2].w;
    return select(0.0, clamp(p, 0.0, 1.0), finite(p));
}

// The lights' (J⁰, J¹) of center l, channel c; zero without lights.
fn direct_at(l: u32, c: u32) -> vec4<f32> {
    if params.direct == 0u {
        return vec4<f32>(0.0);
    }
    return direct[3u * l + c];
}

fn j0(l: u32, c: u32) -> f32 {
    // sources[..] / √4π + the lights', as the CPU sums them into `Sources::j0`.
    return finite_or_zero(sources[l * params.n2][c] * 0.28209479 + direct_at(l, c).x);
}

fn j1(l: u32, c: u32) -> vec3<f32> {
    let lights = direct_at(l, c).yzw;
    if params.n2 < 4u {
        return vec3<f32>(finite_or_zero(lights.x), finite_or_zero(lights.y),
                         finite_or_zero(lights.z));
    }
    let base = l * params.n2;
    let k1 = -0.48860251; // −√(3/4π)
    return vec3<f32>(
        finite_or_zero(k1 * sources[base + 3u][c] + lights.x),
        finite_or_zero(k1 * sources[base + 1u][c] + lights.y),
        finite_or_zero(k1 * sources[base + 2u][c] + lights.z),
    );
}

// A_hl for the stored entry k of row h.
fn coef(k: u32, h: u32) -> f32 {
    if density[h] <= 0.0 {
        return 1.0;
    }
    let e = entries[k];
    let p = escape(h);
    let sink = params.sigma_a + params.sigma_s * p;
    return e.diffusion * (1.0 - p) / (3.0 * params.sigma_tr) - sink * e.v;
}

fn inverse_norm(sq: f32) -> f32 {
    let norm = sqrt(sq);
    return select(1.0, 1.0 / norm, norm > 0.0 && finite(1.0 / norm));
}

// Offsets of channel c's vectors in `work`.
struct Vectors {
    x: u32,
    r: u32,
    s: u32,
    p: u32,
    q: u32,
    row: u32,
    col: u32,
    b: u32,
};

fn vectors(c: u32) -> Vectors {
    let n = params.n;
    let base = 8u * n * c;
    return Vectors(base, base + n, base + 2u * n, base + 3u * n, base + 4u * n,
                   base + 5u * n, base + 6u * n, base + 7u * n);
}

// Row h of A applied to the vector at `at` scaled by the column scale: Σ_l A_hl C_l y_l.
fn row_times(h: u32, v: Vectors, at: u32) -> f32 {
    var sum = 0.0;
    for (var k = index[h]; k < index[h + 1u]; k++) {
        let l = entries[k].col;
        sum += coef(k, h) * work[v.col + l] * work[at + l];
    }
    return sum;
}

// Column l of (R A)ᵀ applied to the vector at `at`: Σ_h A_hl R_h y_h.
fn column_times(l: u32, v: Vectors, at: u32) -> f32 {
    let n = params.n;
    let cols = n + 1u;
    let pairs = 2u * n + 2u;
    var sum = 0.0;
    for (var i = index[cols + l]; i < index[cols + l + 1u]; i++) {
        let h = index[pairs + 2u * i];
        let k = index[pairs + 2u * i + 1u];
        sum += coef(k, h) * work[v.row + h] * work[at + h];
    }
    return sum;
}

// Channel c's solver state in `work` (module docs): iterations, relative residual,
// converged, γ = ‖Mᵀr‖², ‖b‖, ‖M‖_F, ‖r‖, stopped (converged or broken down).
fn state_at(c: u32) -> u32 {
    return 36u * params.n + 8u * c;
}

var<workgroup> state: array<f32, 8>;

// Whether CGLS may stop: the residual meets the tolerance, or a least-squares optimum.
fn done(residual: f32, gamma: f32, m_norm: f32, r_norm: f32) -> bool {
    return residual <= params.tolerance || sqrt(gamma) <= LS_OPTIMAL * m_norm * r_norm;
}

// b, the scalings R and C, the start x, r = R(b − A x), s = p = Mᵀ r and the state.
@compute @workgroup_size(256)
fn setup(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let n = params.n;
    let c = wg.x;
    let v = vectors(c);
    let inv_3_sigma_tr = 1.0 / (3.0 * params.sigma_tr);
    let j1_factor = params.sigma_t * inv_3_sigma_tr;

    // b and the row scale R = 1/‖A_h‖.
    var part = vec2<f32>(0.0);
    for (var h = lid; h < n; h += WG) {
        var b = 0.0;
        var sq = 1.0;
        if density[h] > 0.0 {
            sq = 0.0;
            for (var k = index[h]; k < index[h + 1u]; k++) {
                let e = entries[k];
                let a = coef(k, h);
                sq += a * a;
                let kept = 1.0 - escape(e.col);
                b += kept * (-params.sigma_t * e.v * j0(e.col, c)
                    + j1_factor * dot(vec3<f32>(e.gx, e.gy, e.gz), j1(e.col, c)));
            }
        }
        work[v.b + h] = b;
        work[v.row + h] = inverse_norm(sq);
        part.x += b * b;
    }
    storageBarrier();
    // The column scale C = 1/‖(RA)_·l‖, and ‖RAC‖_F² = the non-zero columns.
    for (var l = lid; l < n; l += WG) {
        var sq = 0.0;
        let cols = n + 1u;
        let pairs = 2u * n + 2u;
        for (var i = index[cols + l]; i < index[cols + l + 1u]; i++) {
            let h = index[pairs + 2u * i];
            let a = coef(index[pairs + 2u * i + 1u], h) * work[v.row + h];
            sq += a * a;
        }
        work[v.col + l] = inverse_norm(sq);
        part.y += select(0.0, 1.0, sq > 0.0);
    }
    storageBarrier();
    let totals = workgroup_sum(lid, part);
    let b_norm = sqrt(totals.x);
    let m_norm = sqrt(totals.y);
    let solving = b_norm > 0.0 && finite(b_norm);

    // x from the start (zero when b = 0: the minimum-norm solution).
    for (var h = lid; h < n; h += WG) {
        let x = select(0.0, finite_or_zero(work[v.x + h]), params.warm == 1u && solving);
        work[v.x + h] = x;
        // row_times multiplies by C: p = C⁻¹ x makes it form A x.
        work[v.p + h] = x / work[v.col + h];
    }
    storageBarrier();
    for (var h = lid; h < n; h += WG) {
        work[v.r + h] = (work[v.b + h] - row_times(h, v, v.p)) * work[v.row + h];
    }
    storageBarrier();
    part = vec2<f32>(0.0);
    for (var l = lid; l < n; l += WG) {
        let s = work[v.col + l] * column_times(l, v, v.r);
        work[v.s + l] = s;
        work[v.p + l] = s;
        part.x += s * s;
    }
    for (var h = lid; h < n; h += WG) {
        let r = work[v.r + h];
        part.y += r * r;
    }
    storageBarrier();
    let sums = workgroup_sum(lid, part);
    // ‖b − A x‖ = ‖R⁻¹ r‖.
    part = vec2<f32>(0.0);
    for (var h = lid; h < n; h += WG) {
        let u = work[v.r + h] / work[v.row + h];
        part.x += u * u;
    }
    let residual = select(0.0, sqrt(workgroup_sum(lid, part).x) / b_norm, solving);
    let converged = !solving || done(residual, sums.x, m_norm, sqrt(sums.y));
    if lid == 0u {
        let st = state_at(c);
        work[st] = 0.0;
        work[st + 1u] = residual;
        work[st + 2u] = select(0.0, 1.0, converged);
        work[st + 3u] = sums.x;
        work[st + 4u] = b_norm;
        work[st + 5u] = m_norm;
        work[st + 6u] = sqrt(sums.y);
        work[st + 7u] = select(0.0, 1.0, converged);
    }
}

// Up to `params.chunk` CGLS iterations from the state, until it stops or reaches
// `params.max_iterations`. Chunks bound the length of one dispatch (watchdogs, and a
// software rasterizer that abandons long ones); the host submits enough of them, and
// those after the stop return at once.
@compute @workgroup_size(256)
fn iterate(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let n = params.n;
    let c = wg.x;
    let v = vectors(c);
    let st = state_at(c);
    if lid < 8u {
        state[lid] = work[st + lid];
    }
    var iterations = u32(workgroupUniformLoad(&state[0]));
    var residual = workgroupUniformLoad(&state[1]);
    var converged = workgroupUniformLoad(&state[2]) == 1.0;
    var gamma = workgroupUniformLoad(&state[3]);
    let b_norm = workgroupUniformLoad(&state[4]);
    let m_norm = workgroupUniformLoad(&state[5]);
    var r_norm = workgroupUniformLoad(&state[6]);
    var stopped = workgroupUniformLoad(&state[7]) == 1.0;
    let end = min(params.max_iterations, iterations + params.chunk);
    loop {
        if stopped || iterations >= end {
            break;
        }
        // q = M p, α = γ/‖q‖².
        var part = vec2<f32>(0.0);
        for (var h = lid; h < n; h += WG) {
            let q = work[v.row + h] * row_times(h, v, v.p);
            work[v.q + h] = q;
            part.x += q * q;
        }
        storageBarrier();
        let alpha = gamma / workgroup_sum(lid, part).x;
        if !finite(alpha) {
            stopped = true;
            break;
        }
        // x += α C p, r −= α q.
        part = vec2<f32>(0.0);
        for (var h = lid; h < n; h += WG) {
            work[v.x + h] += alpha * work[v.col + h] * work[v.p + h];
            let r = work[v.r + h] - alpha * work[v.q + h];
            work[v.r + h] = r;
            let u = r / work[v.row + h];
            part += vec2<f32>(u * u, r * r);
        }
        storageBarrier();
        let sums = workgroup_sum(lid, part);
        // s = Mᵀ r, γ' = ‖s‖².
        part = vec2<f32>(0.0);
        for (var l = lid; l < n; l += WG) {
            let s = work[v.col + l] * column_times(l, v, v.r);
            work[v.s + l] = s;
            part.x += s * s;
        }
        storageBarrier();
        let gamma_next = workgroup_sum(lid, part).x;
        iterations += 1u;
        if !(finite(gamma_next) && finite(sums.x)) {
            stopped = true;
            break;
        }
        let beta = gamma_next / gamma;
        for (var l = lid; l < n; l += WG) {
            work[v.p + l] = work[v.s + l] + beta * work[v.p + l];
        }
        storageBarrier();
        gamma = gamma_next;
        r_norm = sqrt(sums.y);
        residual = sqrt(sums.x) / b_norm;
        converged = done(residual, gamma, m_norm, r_norm);
        stopped = converged;
    }
    if lid == 0u {
        work[st] = f32(iterations);
        work[st + 1u] = residual;
        work[st + 2u] = select(0.0, 1.0, converged);
        work[st + 3u] = gamma;
        work[st + 6u] = r_norm;
        work[st + 7u] = select(0.0, 1.0, stopped);
    }
}

// J_ms at the centers from L⁰ = x (a breakdown's non-finite values count as 0).
@compute @workgroup_size(256)
fn finish(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    let n = params.n;
    let c = wg.x;
    let v = vectors(c);
    for (var h = lid; h < n; h += WG) {
        work[v.x + h] = finite_or_zero(work[v.x + h]);
    }
    storageBarrier();
    let ms = 24u * n;
    for (var h = lid; h < n; h += WG) {
        var out = vec4<f32>(0.0);
        let d = density[h];
        if d > 0.0 && params.sigma_t > 0.0 {
            var grad = vec3<f32>(0.0);
            for (var k = index[h]; k < index[h + 1u]; k++) {
                let e = entries[k];
                grad += vec3<f32>(e.gx, e.gy, e.gz) * work[v.x + e.col];
            }
            let kept = 1.0 - escape(h);
            let l1 = (j1(h, c) * (params.sigma_t * d * kept) - grad) / (params.sigma_tr * d);
            out = vec4<f32>(params.band0 * work[v.x + h], params.band1 * l1.y,
                            params.band1 * l1.z, params.band1 * l1.x);
        }
        for (var k = 0u; k < 4u; k++) {
            work[ms + (3u * h + c) * 4u + k] = out[k];
        }
    }
}

@compute @workgroup_size(64)
fn add(@builtin(global_invocation_id) id: vec3<u32>) {
    let h = id.x;
    if h >= params.n {
        return;
    }
    let ms = 24u * params.n;
    for (var k = 0u; k < min(4u, params.n2); k++) {
        let sign = select(-1.0, 1.0, k == 0u);
        let extra = vec3<f32>(
            work[ms + (3u * h) * 4u + k],
            work[ms + (3u * h + 1u) * 4u + k],
            work[ms + (3u * h + 2u) * 4u + k],
        );
        let i = h * params.n2 + k;
        sources[i] = vec4<f32>(sources[i].xyz + sign * extra, sources[i].w);
    }
}
