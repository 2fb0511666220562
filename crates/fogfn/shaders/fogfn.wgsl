// Analytic fog functions (paper D) in f32: the twin of haze_fogfn's closed forms
// (crates/fogfn/src, one function per family), for rays leaving the eye or any point given
// relative to it (fog_depth_at), and the density K itself (fog_density_at).
//
// A module (`#import fogfn`). The importer defines `fn fog_record(i: u32) -> vec4<f32>`,
// the i-th of the records written by haze_fogfn::gpu::records (wherever its bindings
// keep them): everything that depends on the eye and the time (phases, cell
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

// s^p for 0 ≤ p ≤ 15 by squaring (the spec allows powers ≤ 9, antiderivatives ≤ 10).
// Written without a loop, as fog_piece's nodes and fog_polynomial's axes: lavapipe
// (llvmpipe) ends an invocation's loops after 65535 iterations in all, and a march or a
// long cell walk evaluates the polynomial many times (one loop over the monomials each).
fn fog_powi(s: f32, p: u32) -> f32 {
    let s2 = s * s;
    let s4 = s2 * s2;
    return select(1.0, s, (p & 1u) != 0u) * select(1.0, s2, (p & 2u) != 0u)
        * select(1.0, s4, (p & 4u) != 0u) * select(1.0, s4 * s4, (p & 8u) != 0u);
}

// One monomial [coef, p0, p1, p2] at cell coordinates s.
fn fog_mono(r: vec4<f32>, s: vec3<f32>) -> f32 {
    return r.x * fog_powi(s.x, u32(r.y)) * fog_powi(s.y, u32(r.z)) * fog_powi(s.z, u32(r.w));
}

// P at cell coordinates s; monomials from record `m`.
fn fog_poly(m: u32, count: u32, s: vec3<f32>) -> f32 {
    var v = 0.0;
    for (var i = 0u; i < count; i++) {
        v += fog_mono(fog_record(m + i), s);
    }
    return v;
}

// Q(s) = Σ c s^{p+1}/(p + 1) of a one-axis polynomial.
fn fog_antiderivative(m: u32, count: u32, s: f32) -> f32 {
    var v = 0.0;
    for (var i = 0u; i < count; i++) {
        let r = fog_record(m + i);
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

// 5-point Gauss–Legendre on [t0, t1] of P(s0 + t·ds − shift): the five nodes in one pass
// over the monomials.
fn fog_piece(m: u32, count: u32, s0: vec3<f32>, ds: vec3<f32>, shift: vec3<f32>, t0: f32, t1: f32) -> f32 {
    let mid = 0.5 * (t0 + t1);
    let half = 0.5 * (t1 - t0);
    let x1 = 0.5384693101056831 * half;
    let x2 = 0.9061798459386640 * half;
    let p0 = s0 + mid * ds - shift;
    let p1 = s0 + (mid - x1) * ds - shift;
    let p2 = s0 + (mid + x1) * ds - shift;
    let p3 = s0 + (mid - x2) * ds - shift;
    let p4 = s0 + (mid + x2) * ds - shift;
    var v = 0.0;
    for (var i = 0u; i < count; i++) {
        let r = fog_record(m + i);
        v += 0.5688888888888889 * fog_mono(r, p0)
            + 0.4786286704993665 * (fog_mono(r, p1) + fog_mono(r, p2))
            + 0.2369268850561891 * (fog_mono(r, p3) + fog_mono(r, p4));
    }
    return v * half;
}

// ∫₀^len along o + t·w (o relative to the eye) of the polynomial whose record starts at
// `i` (haze_fogfn::polynomial).
fn fog_polynomial(i: u32, o: vec3<f32>, w: vec3<f32>, len: f32) -> f32 {
    let head = fog_record(i);
    let c = head.z;
    let periodic = head.w > 0.5;
    let n = u32(fog_record(i + 1u).x);
    let count = u32(fog_record(i + 1u).y);
    let m = i + 2u + n;
    // The axes as vector lanes (unused lanes: s0 = ds = 0).
    let used = vec3<bool>(true, n > 1u, n > 2u);
    let a0 = fog_record(i + 2u);
    let a1 = select(vec4<f32>(0.0), fog_record(i + 3u), used.y);
    let a2 = select(vec4<f32>(0.0), fog_record(i + 4u), used.z);
    let s0 = vec3<f32>(a0.w, a1.w, a2.w) + vec3<f32>(dot(a0.xyz, o), dot(a1.xyz, o), dot(a2.xyz, o));
    let ds = vec3<f32>(dot(a0.xyz, w), dot(a1.xyz, w), dot(a2.xyz, w));
    let flat = ds == vec3<f32>(0.0);
    if (!periodic) {
        // Along an axis the ray does not move on: inside the slab or nothing.
        if (any(used & flat & (abs(s0) > vec3<f32>(c)))) {
            return 0.0;
        }
        let inv = 1.0 / select(ds, vec3<f32>(1.0), flat);
        let a = (-c - s0) * inv;
        let b = (c - s0) * inv;
        let skip = flat | !used;
        let lo = select(min(a, b), vec3<f32>(-3.0e38), skip);
        let hi = select(max(a, b), vec3<f32>(3.0e38), skip);
        let t0 = max(0.0, max(lo.x, max(lo.y, lo.z)));
        let t1 = min(len, min(hi.x, min(hi.y, hi.z)));
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
    // computed from k each time rather than accumulated; the axes as vector lanes.
    let moving = used & !flat;
    let up = ds > vec3<f32>(0.0);
    let inv = 1.0 / select(ds, vec3<f32>(1.0), flat);
    let first = floor((s0 + c) / p);
    var crossed = vec3<f32>(0.0);
    var t = 0.0;
    var total = 0.0;
    for (var step = 0u; step < FOG_MAX_CELLS && t < len; step++) {
        let border = select((first - crossed) * p - c, (first + crossed + 1.0) * p - c, up);
        let tj = select(vec3<f32>(3.0e38), max((border - s0) * inv, vec3<f32>(t)), moving);
        let best = min(len, min(tj.x, min(tj.y, tj.z)));
        // The first axis whose border comes first (before len).
        let hit = (tj == vec3<f32>(best)) & (tj < vec3<f32>(len));
        var pick = vec3<bool>(false);
        if (hit.x) {
            pick.x = true;
        } else if (hit.y) {
            pick.y = true;
        } else if (hit.z) {
            pick.z = true;
        }
        if (best > t) {
            let mid = 0.5 * (t + best);
            let shift = p * floor((s0 + mid * ds + c) / p);
            total += fog_piece(m, count, s0, ds, shift, t, best);
        }
        t = best;
        crossed += select(vec3<f32>(0.0), vec3<f32>(1.0), pick);
    }
    return total;
}

// The optical depth ∫₀^len K(eye + s·w) ds of every term (haze_fogfn::Fog::optical_depth).
fn fog_depth(w: vec3<f32>, len: f32) -> f32 {
    return fog_depth_from(0u, w, len);
}

// fog_depth of the fog whose records start at fog_record(start) (several fogs in one array,
// each ended by its terminator).
fn fog_depth_from(start: u32, w: vec3<f32>, len: f32) -> f32 {
    return fog_depth_at(start, vec3<f32>(0.0), w, len);
}

// ∫₀^len K(eye + o + s·w) ds of the fog whose records start at fog_record(start): the ray
// leaves the point o (relative to the eye). Each record's eye-relative quantity moves by o:
// a wave's phase by q·o, a cell coordinate by a_j·o, an offset to a blob by o (its part
// across a line by o's), a height layer's ln-density by −b·(n·o).
fn fog_depth_at(start: u32, o: vec3<f32>, w: vec3<f32>, len: f32) -> f32 {
    if (len <= 0.0) {
        return 0.0;
    }
    var total = 0.0;
    var i = start;
    var bad = false;
    loop {
        let h = fog_record(i);
        let kind = i32(h.x);
        if (kind < 0) {
            break;
        }
        // A blob of d = 0 is the constant 1/c (haze_fogfn::blob).
        let flat_blob = kind >= 3 && kind <= 5 && h.w == 0.0;
        switch kind {
            case 0: {
                total += h.y * len;
                i += 1u;
            }
            case 1: {
                let q = fog_record(i + 1u).xyz;
                let half = 0.5 * dot(q, w) * len;
                let phase = fog_wrap(h.z + dot(q, o));
                total += h.y * len * cos(fog_wrap(phase + fog_wrap(half))) * fog_sinc(half);
                i += 2u;
            }
            case 2: {
                total += h.y * fog_polynomial(i, o, w, len);
                i += 2u + u32(fog_record(i + 1u).x) + u32(fog_record(i + 1u).y);
            }
            case 3: {
                if (flat_blob) {
                    total += h.y * len / h.z;
                    i += 2u;
                    break;
                }
                let e = fog_record(i + 1u).xyz + o;
                let cr = cross(w, e);
                let disc = h.z / h.w + dot(cr, cr);
                total += h.y * fog_inv_quad(1.0, dot(e, w), disc, 0.0, len) / h.w;
                i += 2u;
            }
            case 4: {
                if (flat_blob) {
                    total += h.y * len / h.z;
                    i += 3u;
                    break;
                }
                let l = fog_record(i + 2u).xyz;
                let e = fog_record(i + 1u).xyz + o - dot(o, l) * l;
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
                if (flat_blob) {
                    total += h.y * len / h.z;
                    i += 2u;
                    break;
                }
                let e = fog_record(i + 1u).xyz + o;
                let r = fog_record(i + 1u).w;
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
                let n = fog_record(i + 1u).xyz;
                total += len * exp(h.y - h.z * dot(n, o) + fog_ln_e(h.z * dot(n, w) * len));
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

// K(eye + x) of the fog whose records start at fog_record(start) (haze_fogfn::Fog::density).
fn fog_density_at(start: u32, x: vec3<f32>) -> f32 {
    var total = 0.0;
    var i = start;
    var bad = false;
    loop {
        let h = fog_record(i);
        let kind = i32(h.x);
        if (kind < 0) {
            break;
        }
        switch kind {
            case 0: {
                total += h.y;
                i += 1u;
            }
            case 1: {
                let q = fog_record(i + 1u).xyz;
                total += h.y * cos(fog_wrap(h.z + dot(q, x)));
                i += 2u;
            }
            case 2: {
                let c = h.z;
                let p = 2.0 * c;
                let n = u32(fog_record(i + 1u).x);
                let count = u32(fog_record(i + 1u).y);
                var s = vec3<f32>(0.0);
                var inside = true;
                for (var j = 0u; j < n; j++) {
                    let a = fog_record(i + 2u + j);
                    s[j] = a.w + dot(a.xyz, x);
                    if (h.w > 0.5) {
                        s[j] -= p * floor((s[j] + c) / p);
                    } else if (abs(s[j]) > c) {
                        inside = false;
                    }
                }
                if (inside) {
                    total += h.y * fog_poly(i + 2u + n, count, s);
                }
                i += 2u + n + count;
            }
            case 3: {
                let e = fog_record(i + 1u).xyz + x;
                total += h.y / (h.z + h.w * dot(e, e));
                i += 2u;
            }
            case 4: {
                let l = fog_record(i + 2u).xyz;
                let e = fog_record(i + 1u).xyz + x - dot(x, l) * l;
                total += h.y / (h.z + h.w * dot(e, e));
                i += 3u;
            }
            case 5: {
                let e = fog_record(i + 1u).xyz + x;
                let r = fog_record(i + 1u).w;
                total += h.y / (h.z + h.w * max(dot(e, e) - r * r, 0.0));
                i += 2u;
            }
            case 6: {
                let n = fog_record(i + 1u).xyz;
                total += exp(h.y - h.z * dot(n, x));
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
