// Analytic fog functions (paper D) in f32: the twin of haze_fogfn's closed forms
// (crates/fogfn/src, one function per family), for rays leaving the eye.
//
// The includer declares `fog_terms: array<vec4<f32>>`, the records written by
// haze_fogfn::gpu::records: everything that depends on the eye and the time (phases, cell
// coordinates, offsets to the blobs, the height layer at the eye) is computed there in
// f64, relative to the eye, so that only the direction and the length of each ray reach
// f32. Records (kind in .x), ended by kind -1:
//   0 constant  [0, w, 0, 0]
//   1 wave      [1, w·amp, phase at the eye in [0, 2π), 0] [q, 0]
//   2 polynomial [2, w, C, periodic] [axes, monomials, 0, 0] axes × [a_j, s_j(eye)]
//               monomials × [coef, p0, p1, p2]
//   3 point     [3, w, c, d] [eye − p, 0]
//   4 line      [4, w, c, d] [(eye − p)⊥, 0] [ℓ, 0]
//   5 sphere    [5, w, c, d] [eye − b, R]
//   6 height    [6, ln w − b·s(eye), b, 0] [n, 0]

const FOG_TAU: f32 = 6.283185307179586;
// Cells a periodic polynomial's walk crosses at most per ray (beyond: the rest is left out).
const FOG_MAX_CELLS: u32 = 4096u;

// x reduced to [−π, π] (GPU sin/cos are only promised accurate there).
fn fog_wrap(x: f32) -> f32 {
    return x - FOG_TAU * floor(x / FOG_TAU + 0.5);
}

fn fog_sinc(x: f32) -> f32 {
    if (x == 0.0) {
        return 1.0;
    }
    return sin(fog_wrap(x)) / x;
}

fn fog_log1p(z: f32) -> f32 {
    if (abs(z) < 1e-3) {
        return z * (1.0 - z * (0.5 - z / 3.0));
    }
    return log(1.0 + z);
}

// ∫_{t0}^{t1} dt / (a t² + 2b t + c), disc = a c − b² (haze_fogfn::quadratic).
fn fog_inv_quad(a: f32, b: f32, disc: f32, t0: f32, t1: f32) -> f32 {
    if (t1 <= t0) {
        return 0.0;
    }
    let v0 = a * t0 + b;
    let v1 = a * t1 + b;
    let dv = a * (t1 - t0);
    if (disc > 0.0) {
        let s = sqrt(disc);
        return atan2(dv * s, disc + v0 * v1) / s;
    }
    if (disc < 0.0) {
        let k = sqrt(-disc);
        return fog_log1p(2.0 * k * dv / ((v1 + k) * (v0 - k))) / (2.0 * k);
    }
    return dv / (v0 * v1);
}

// ln((1 − e^{−x})/x) (haze_fogfn::height::ln_e).
fn fog_ln_e(x: f32) -> f32 {
    if (abs(x) < 1e-2) {
        return fog_log1p(-x * (0.5 - x * (1.0 / 6.0 - x / 24.0)));
    }
    if (x > 0.0) {
        return log((1.0 - exp(-x)) / x);
    }
    return -x + log(1.0 - exp(x)) - log(-x);
}

fn fog_powi(s: f32, p: u32) -> f32 {
    var r = 1.0;
    for (var i = 0u; i < p; i++) {
        r *= s;
    }
    return r;
}

// P at cell coordinates s; monomials from record `m`.
fn fog_poly(m: u32, count: u32, s: vec3<f32>) -> f32 {
    var v = 0.0;
    for (var i = 0u; i < count; i++) {
        let r = fog_terms[m + i];
        v += r.x * fog_powi(s.x, u32(r.y)) * fog_powi(s.y, u32(r.z)) * fog_powi(s.z, u32(r.w));
    }
    return v;
}

// Q(s) = Σ c s^{p+1}/(p + 1) of a one-axis polynomial.
fn fog_antiderivative(m: u32, count: u32, s: f32) -> f32 {
    var v = 0.0;
    for (var i = 0u; i < count; i++) {
        let r = fog_terms[m + i];
        let p = u32(r.y);
        v += r.x * fog_powi(s, p + 1u) / f32(p + 1u);
    }
    return v;
}

fn fog_phi(m: u32, count: u32, c: f32, s: f32) -> f32 {
    let p = 2.0 * c;
    let cell = floor((s + c) / p);
    let qc = fog_antiderivative(m, count, -c);
    return cell * (fog_antiderivative(m, count, c) - qc) + fog_antiderivative(m, count, s - p * cell) - qc;
}

// 5-point Gauss–Legendre on [t0, t1] of P(s0 + t·ds − shift).
fn fog_piece(m: u32, count: u32, s0: vec3<f32>, ds: vec3<f32>, shift: vec3<f32>, t0: f32, t1: f32) -> f32 {
    var x = array<f32, 5>(0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640, 0.9061798459386640);
    var wt = array<f32, 5>(0.5688888888888889, 0.4786286704993665, 0.4786286704993665, 0.2369268850561891, 0.2369268850561891);
    let mid = 0.5 * (t0 + t1);
    let half = 0.5 * (t1 - t0);
    var v = 0.0;
    for (var i = 0u; i < 5u; i++) {
        let t = mid + half * x[i];
        v += wt[i] * fog_poly(m, count, s0 + t * ds - shift);
    }
    return v * half;
}

// ∫₀^len of the polynomial whose record starts at `i` (haze_fogfn::polynomial).
fn fog_polynomial(i: u32, w: vec3<f32>, len: f32) -> f32 {
    let head = fog_terms[i];
    let c = head.z;
    let periodic = head.w > 0.5;
    let n = u32(fog_terms[i + 1u].x);
    let count = u32(fog_terms[i + 1u].y);
    let m = i + 2u + n;
    var s0 = vec3<f32>(0.0);
    var ds = vec3<f32>(0.0);
    for (var j = 0u; j < n; j++) {
        let a = fog_terms[i + 2u + j];
        s0[j] = a.w;
        ds[j] = dot(a.xyz, w);
    }
    if (!periodic) {
        var t0 = 0.0;
        var t1 = len;
        for (var j = 0u; j < n; j++) {
            if (ds[j] == 0.0) {
                if (abs(s0[j]) > c) {
                    return 0.0;
                }
                continue;
            }
            let a = (-c - s0[j]) / ds[j];
            let b = (c - s0[j]) / ds[j];
            t0 = max(t0, min(a, b));
            t1 = min(t1, max(a, b));
        }
        if (t1 <= t0) {
            return 0.0;
        }
        return fog_piece(m, count, s0, ds, vec3<f32>(0.0), t0, t1);
    }
    let p = 2.0 * c;
    if (n == 1u && abs(ds.x * len) >= p) {
        return (fog_phi(m, count, c, s0.x + ds.x * len) - fog_phi(m, count, c, s0.x)) / ds.x;
    }
    // The walk: border k of axis j ahead of the eye lies at
    // t = ((cell_j + k + 1)·2C − C − s0_j)/ds_j (ds_j > 0; mirrored for ds_j < 0),
    // computed from k each time rather than accumulated.
    var first = vec3<f32>(0.0);
    var crossed = vec3<f32>(0.0);
    for (var j = 0u; j < n; j++) {
        first[j] = floor((s0[j] + c) / p);
    }
    var t = 0.0;
    var total = 0.0;
    for (var step = 0u; step < FOG_MAX_CELLS && t < len; step++) {
        var best = len;
        var jb = 3u;
        for (var j = 0u; j < n; j++) {
            if (ds[j] == 0.0) {
                continue;
            }
            var border = 0.0;
            if (ds[j] > 0.0) {
                border = (first[j] + crossed[j] + 1.0) * p - c;
            } else {
                border = (first[j] - crossed[j]) * p - c;
            }
            let tj = max((border - s0[j]) / ds[j], t);
            if (tj < best) {
                best = tj;
                jb = j;
            }
        }
        if (best > t) {
            let mid = 0.5 * (t + best);
            var shift = vec3<f32>(0.0);
            for (var j = 0u; j < n; j++) {
                shift[j] = p * floor((s0[j] + mid * ds[j] + c) / p);
            }
            total += fog_piece(m, count, s0, ds, shift, t, best);
        }
        t = best;
        if (jb < 3u) {
            crossed[jb] += 1.0;
        }
    }
    return total;
}

// The optical depth ∫₀^len K(eye + s·w) ds of every term (haze_fogfn::Fog::optical_depth).
fn fog_depth(w: vec3<f32>, len: f32) -> f32 {
    return fog_depth_from(0u, w, len);
}

// fog_depth of the fog whose records start at fog_terms[start] (several fogs in one array,
// each ended by its terminator).
fn fog_depth_from(start: u32, w: vec3<f32>, len: f32) -> f32 {
    if (len <= 0.0) {
        return 0.0;
    }
    var total = 0.0;
    var i = start;
    var bad = false;
    loop {
        let h = fog_terms[i];
        let kind = i32(h.x);
        if (kind < 0) {
            break;
        }
        switch kind {
            case 0: {
                total += h.y * len;
                i += 1u;
            }
            case 1: {
                let q = fog_terms[i + 1u].xyz;
                let half = 0.5 * dot(q, w) * len;
                total += h.y * len * cos(fog_wrap(h.z + fog_wrap(half))) * fog_sinc(half);
                i += 2u;
            }
            case 2: {
                total += h.y * fog_polynomial(i, w, len);
                i += 2u + u32(fog_terms[i + 1u].x) + u32(fog_terms[i + 1u].y);
            }
            case 3: {
                let e = fog_terms[i + 1u].xyz;
                let cr = cross(w, e);
                let disc = h.z / h.w + dot(cr, cr);
                total += h.y * fog_inv_quad(1.0, dot(e, w), disc, 0.0, len) / h.w;
                i += 2u;
            }
            case 4: {
                let e = fog_terms[i + 1u].xyz;
                let l = fog_terms[i + 2u].xyz;
                let wp = w - dot(w, l) * l;
                let a = dot(wp, wp);
                if (a == 0.0) {
                    total += h.y * len / (h.z + h.w * dot(e, e));
                } else {
                    let cr = cross(wp, e);
                    let disc = a * h.z / h.w + dot(cr, cr);
                    total += h.y * fog_inv_quad(a, dot(wp, e), disc, 0.0, len) / h.w;
                }
                i += 3u;
            }
            case 5: {
                let e = fog_terms[i + 1u].xyz;
                let r = fog_terms[i + 1u].w;
                let b = dot(e, w);
                let cr = cross(w, e);
                let h2 = dot(cr, cr);
                let disc = (h.z - h.w * r * r) / h.w + h2;
                let chord2 = r * r - h2;
                var v = 0.0;
                if (chord2 <= 0.0) {
                    v = fog_inv_quad(1.0, b, disc, 0.0, len) / h.w;
                } else {
                    let t_in = clamp(-b - sqrt(chord2), 0.0, len);
                    let t_out = clamp(-b + sqrt(chord2), 0.0, len);
                    v = (fog_inv_quad(1.0, b, disc, 0.0, t_in) + fog_inv_quad(1.0, b, disc, t_out, len)) / h.w
                        + (t_out - t_in) / h.z;
                }
                total += h.y * v;
                i += 2u;
            }
            case 6: {
                let n = fog_terms[i + 1u].xyz;
                total += len * exp(h.y + fog_ln_e(h.z * dot(n, w) * len));
                i += 2u;
            }
            default: {
                bad = true;
            }
        }
        if (bad) {
            break;
        }
    }
    return total;
}
