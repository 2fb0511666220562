// Paper B on the GPU: the twin of crates/scene's `paper_b::Prepared::radiance`, over
// render.wgsl (whose helpers it calls) — see `src/gpu/paper_b.rs`. Positions are relative to the eye. P.sigma_t/P.sigma_s carry the
// homogeneous part β0, σs0 (the scene's homogeneous media plus the Gaussian backgrounds).

// Two records per Gaussian: (centre, a = 1/r), (c = peak extinction, albedo, cull radius², -).
// With noise (header .z = 1), then two more per Gaussian: (eye + offset, frequency),
// (scale gain·r/|v − b|, record of its permutation, -, -); then the permutations, 512
// entries each, four per record.
//
// Two variants: tiled (the Gaussians listed per 8 × 8 tile beyond DIRECT_MAX of them) and
// UNTILED (every count direct, no workgroup barrier at all: on lavapipe a shader with
// barriers runs ~30 % slower even where it reaches none).

#import render

// Perlin's vector offsets 1 and 2 (haze_gaussians::noise::Perlin::VECTOR_OFFSETS), set by
// the pipeline from the CPU's constants.
override NOISE_OFFSET_1_X: f32;
override NOISE_OFFSET_1_Y: f32;
override NOISE_OFFSET_1_Z: f32;
override NOISE_OFFSET_2_X: f32;
override NOISE_OFFSET_2_Y: f32;
override NOISE_OFFSET_2_Z: f32;
@group(0) @binding(7) var<storage, read> blobs: array<vec4<f32>>;
// Per light l and Gaussian i at l·n + i: e^{Eᵢ} per channel and, when the pair is
// integrated along the ray (haze_gaussians::integrated), e^{Eᵢ} of the Gaussians alone
// without the light's exact list (−1: the closed form); then per light (C_sv, C_sv without
// the exact list, its length, -); then per light the list's indices in EXACT_RECORDS
// records (four a record); then per light l and Gaussian i at l·n + i the pair's list in
// EXACT_RECORDS records (−1 past its end); with an environment, per Gaussian (αᵢ·Ēᵢ·e^{Eᵢ}, -) and (Ē, β_bg·D) (gaussian_env);
// then (n, 1 if a background hides the suns, 1 if noise records follow, environment: 0
// none, 1 without, 2 with its light scattered onto surfaces) and (σs of the scene's
// homogeneous media, -).
@group(0) @binding(8) var<storage, read> bexp: array<vec4<f32>>;

const SQRT_PI_2: f32 = 0.88622692545;
const TWO_OVER_SQRT_PI: f32 = 1.12837916710;
// Lengths beyond this are the same as ∞ to the erf (and keep a·len finite).
const LONG: f32 = 1.0e30;

// erfc(x) for x ≥ 0 by Abramowitz & Stegun 7.1.26 (gaussians::erf::erf_as): absolute
// error ≤ 1.5e-7.
fn erfc_pos(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.3275911 * x);
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    return poly * exp(-x * x);
}

// erf(x1) − erf(x0) for x0 ≤ x1 (gaussians::erf::erf_diff), arguments clamped to
// [−10, 10] (erfc(10) is below f32's range).
fn erf_diff(a: f32, b: f32) -> f32 {
    let x0 = clamp(a, -10.0, 10.0);
    let x1 = clamp(b, -10.0, 10.0);
    let delta = x1 - x0;
    if (!(delta > 0.0)) {
        return 0.0;
    }
    let mid = 0.5 * (x0 + x1);
    if (delta * max(abs(mid), 1.0) < 1.0e-3) {
        return TWO_OVER_SQRT_PI * exp(-mid * mid) * delta * (1.0 + (2.0 * mid * mid - 1.0) * delta * delta / 12.0);
    }
    if (x0 >= 0.0) {
        return erfc_pos(x0) - erfc_pos(x1);
    }
    if (x1 <= 0.0) {
        return erfc_pos(-x1) - erfc_pos(-x0);
    }
    return (1.0 - erfc_pos(x1)) + (1.0 - erfc_pos(-x0));
}

// gaussians::line::gaussian: ∫₀^len c·exp(−a²|o + t·d − b|²) dt, unit d.
fn line_gauss(c: f32, a: f32, b: vec3<f32>, o: vec3<f32>, d: vec3<f32>, len_in: f32) -> f32 {
    let len = min(len_in, LONG);
    if (len <= 0.0 || c == 0.0) {
        return 0.0;
    }
    let bp = b - o;
    let m = dot(bp, d);
    let perp = bp - m * d;
    // Lines farther than √40 radii pick up at most e⁻⁴⁰ of the Gaussian's depth (the CPU
    // drops them below 10⁻¹⁰ absolute): skip the erf.
    let q = a * a * dot(perp, perp);
    if (q > 40.0) {
        return 0.0;
    }
    let side = exp(-q);
    return c * side * SQRT_PI_2 / a * erf_diff(-a * m, a * (len - m));
}

// Perlin's improved noise (gaussians::noise::Perlin::value) with the permutation at
// record `base` of `blobs`.
fn noise_perm(base: u32, k: u32) -> u32 {
    return u32(blobs[base + (k >> 2u)][k & 3u]);
}

fn noise_fade(t: vec3<f32>) -> vec3<f32> {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

fn noise_lerp(t: f32, a: f32, b: f32) -> f32 {
    return a + t * (b - a);
}

// The hashed cube-edge gradient dotted with (x, y, z).
fn noise_grad(hash: u32, x: f32, y: f32, z: f32) -> f32 {
    let h = hash & 15u;
    var u = y;
    if (h < 8u) {
        u = x;
    }
    var v = z;
    if (h < 4u) {
        v = y;
    } else if (h == 12u || h == 14u) {
        v = x;
    }
    if ((h & 1u) != 0u) {
        u = -u;
    }
    if ((h & 2u) != 0u) {
        v = -v;
    }
    return u + v;
}

fn perlin_value(base: u32, x: vec3<f32>) -> f32 {
    let fl = floor(x);
    // rem_euclid(256), exact while |fl| < 2²⁴.
    let cell = vec3<u32>(clamp(fl - 256.0 * floor(fl / 256.0), vec3<f32>(0.0), vec3<f32>(255.0)));
    let f = x - fl;
    let w = noise_fade(f);
    let a = noise_perm(base, cell.x) + cell.y;
    let aa = noise_perm(base, a) + cell.z;
    let ab = noise_perm(base, a + 1u) + cell.z;
    let b = noise_perm(base, cell.x + 1u) + cell.y;
    let ba = noise_perm(base, b) + cell.z;
    let bb = noise_perm(base, b + 1u) + cell.z;
    let g000 = noise_grad(noise_perm(base, aa), f.x, f.y, f.z);
    let g100 = noise_grad(noise_perm(base, ba), f.x - 1.0, f.y, f.z);
    let g010 = noise_grad(noise_perm(base, ab), f.x, f.y - 1.0, f.z);
    let g110 = noise_grad(noise_perm(base, bb), f.x - 1.0, f.y - 1.0, f.z);
    let g001 = noise_grad(noise_perm(base, aa + 1u), f.x, f.y, f.z - 1.0);
    let g101 = noise_grad(noise_perm(base, ba + 1u), f.x - 1.0, f.y, f.z - 1.0);
    let g011 = noise_grad(noise_perm(base, ab + 1u), f.x, f.y - 1.0, f.z - 1.0);
    let g111 = noise_grad(noise_perm(base, bb + 1u), f.x - 1.0, f.y - 1.0, f.z - 1.0);
    let y0 = noise_lerp(w.y, noise_lerp(w.x, g000, g100), noise_lerp(w.x, g010, g110));
    let y1 = noise_lerp(w.y, noise_lerp(w.x, g001, g101), noise_lerp(w.x, g011, g111));
    return noise_lerp(w.z, y0, y1);
}

// Noise::perturb: the view direction of Gaussian i's Tᵢ(v,p), its projection at t_r.
fn noisy_direction(i: u32, n_g: u32, dir: vec3<f32>, t_r: f32) -> vec3<f32> {
    let r0 = blobs[2u * n_g + 2u * i];
    let r1 = blobs[2u * n_g + 2u * i + 1u];
    if (r1.x == 0.0) {
        return dir;
    }
    let q = (t_r * dir + r0.xyz) * r0.w;
    let base = u32(r1.y);
    let n = vec3<f32>(
        perlin_value(base, q),
        perlin_value(base, q + vec3<f32>(NOISE_OFFSET_1_X, NOISE_OFFSET_1_Y, NOISE_OFFSET_1_Z)),
        perlin_value(base, q + vec3<f32>(NOISE_OFFSET_2_X, NOISE_OFFSET_2_Y, NOISE_OFFSET_2_Z)),
    );
    let d = dir + r1.x * n.x * P.right.xyz + r1.x * n.y * P.up.xyz + r1.x * n.z * P.forward.xyz;
    let len = length(d);
    if (len > 0.0 && len < 3.0e38) {
        return d / len;
    }
    return dir;
}

fn gaussian_count() -> u32 {
    return u32(bexp[arrayLength(&bexp) - 2u].x);
}

// Dawson's integral F(x) = e^{−x²}∫₀^x e^{t²} dt (gaussians::average::dawson): Taylor below
// 0.2, Rybicki's sum with h = 0.4 (Numerical Recipes §6.10, ~2e-7), 1/(2x) far away.
fn dawson(x: f32) -> f32 {
    let ax = abs(x);
    if (ax < 0.2) {
        let x2 = x * x;
        return x * (1.0 - 2.0 / 3.0 * x2 * (1.0 - 0.4 * x2 * (1.0 - 2.0 / 7.0 * x2)));
    }
    if (ax > 1.0e3) {
        return 0.5 / x;
    }
    let h = 0.4;
    let n0 = 2.0 * round(0.5 * ax / h);
    let xp = ax - n0 * h;
    var e1 = exp(2.0 * xp * h);
    let e2 = e1 * e1;
    var d1 = n0 + 1.0;
    var d2 = d1 - 2.0;
    var sum = 0.0;
    for (var k = 0u; k < 6u; k++) {
        let q = f32(2u * k + 1u) * h;
        sum += exp(-q * q) * (e1 / d1 + 1.0 / (d2 * e1));
        d1 += 2.0;
        d2 -= 2.0;
        e1 *= e2;
    }
    return 0.5641895835 * sign(x) * exp(-xp * xp) * sum;
}

// T̄ᵢ(p) = c·𝒯(a|p − b|)/a, 𝒯(ρ) = √π·F(ρ)/(2ρ) (gaussians::average); beyond ρ = 6
// Dawson's asymptotic series F ~ 1/(2ρ) + 1/(4ρ³) + 3/(8ρ⁵) + 15/(16ρ⁷) (the next term
// is 4·10⁻⁶ of F there), no exponentials.
fn gauss_mean_depth(c: f32, a: f32, b: vec3<f32>, p: vec3<f32>) -> f32 {
    let rho = a * length(p - b);
    var t = SQRT_PI_2;
    if (rho > 6.0) {
        let u = 1.0 / (rho * rho);
        t = SQRT_PI_2 * 0.5 * u * (1.0 + u * (0.5 + u * (0.75 + u * 1.875)));
    } else if (rho > 1.0e-4) {
        t = SQRT_PI_2 * dawson(rho) / rho;
    }
    return c * t / a;
}

// The environment's mode (0: none) and the record index of its per-Gaussian factors.
fn env_mode() -> u32 {
    return u32(bexp[arrayLength(&bexp) - 2u].w);
}

fn env_base(n_g: u32) -> u32 {
    let n_l = P.size.z;
    return n_l * n_g + (1u + EXACT_RECORDS) * n_l + EXACT_RECORDS * n_l * n_g;
}

// haze_gaussians::integrated: Gauss–Legendre on [−1, 1] (6 nodes), the chord in radii,
// the host ratio's sub-panels a side.
const GL_X = array<f32, 6>(-0.93246951, -0.66120939, -0.23861919, 0.23861919, 0.66120939, 0.93246951);
const GL_W = array<f32, 6>(0.17132449, 0.36076157, 0.46791393, 0.46791393, 0.36076157, 0.17132449);
const SUPPORT: f32 = 3.0;
const HOST_NODES: u32 = 2u;
// haze_gaussians::integrated::MAX_EXACT ids a list, four a record.
const MAX_EXACT: u32 = 16u;
const EXACT_RECORDS: u32 = 4u;

// The k-th Gaussian of light l's list for the homogeneous term (Lit::exact).
fn exact_id(l: u32, n_g: u32, k: u32) -> u32 {
    let rec = bexp[P.size.z * n_g + P.size.z + EXACT_RECORDS * l + k / 4u];
    return u32(rec[k % 4u]);
}

// The k-th entry of the list of the pair (light l, Gaussian i) (Lit::pair_exact); −1
// past its end.
fn pair_entry(l: u32, i: u32, n_g: u32, k: u32) -> f32 {
    let n_l = P.size.z;
    let base = n_l * n_g + (1u + EXACT_RECORDS) * n_l + EXACT_RECORDS * (l * n_g + i);
    return bexp[base + k / 4u][k % 4u];
}

// Σ over the list of the pair (light l, Gaussian i) of Tₖ(v, x) + Tₖ(x, s), x = t·dir
// (paper_b::Prepared::integrated_pair's `others`).
fn pair_depth_to(l: u32, i: u32, n_g: u32, dir: vec3<f32>, t: f32, s: vec3<f32>) -> f32 {
    let x = t * dir;
    let ls = s - x;
    let d = length(ls);
    var depth = 0.0;
    for (var k = 0u; k < MAX_EXACT; k++) {
        let e = pair_entry(l, i, n_g, k);
        if (e < 0.0) {
            break;
        }
        let j = u32(e);
        let h0 = blobs[2u * j];
        let hc = blobs[2u * j + 1u].x;
        depth += line_gauss(hc, h0.w, h0.xyz, vec3<f32>(0.0), dir, t);
        if (d > 0.0) {
            depth += line_gauss(hc, h0.w, h0.xyz, x, ls / d, d);
        }
    }
    return depth;
}

// haze_gaussians::integrated::integrated for Gaussian i and light l, per channel, with the
// exact list's depth towards the light and the eye per node; the caller multiplies by the light's power and
// the pair's exponent.
fn pair_integral(i: u32, l: u32, n_g: u32, dir: vec3<f32>, t_end: f32, beta: vec3<f32>) -> vec3<f32> {
    let b0 = blobs[2u * i];
    let b1 = blobs[2u * i + 1u];
    let b = b0.xyz;
    let a = b0.w;
    let c = b1.x;
    var out = vec3<f32>(0.0);
    if (b1.y <= 0.0 || c <= 0.0 || t_end <= 0.0) {
        return out;
    }
    let m = dot(b, dir);
    let h2 = max(dot(b, b) - m * m, 0.0);
    let reach = SUPPORT / a;
    if (h2 >= reach * reach) {
        return out;
    }
    let half = sqrt(reach * reach - h2);
    let lo = max(m - half, 0.0);
    let hi = min(m + half, t_end);
    if (hi <= lo) {
        return out;
    }
    let la = lights[3u * l];
    let point = la.x == 0.0;
    let s = la.yzw;
    let r_min = P.sigma_t.w;
    var ts = 0.0;
    var hs = 1.0;
    if (point) {
        ts = dot(s, dir);
        hs = max(sqrt(max(dot(s, s) - ts * ts, 0.0)), r_min);
    }
    var cuts = array<f32, 4>(lo, hi, hi, hi);
    var n = 1u;
    if (point && ts > lo && ts < hi) {
        cuts[n] = ts;
        n++;
    }
    if (m > lo && m < hi) {
        cuts[n] = m;
        n++;
    }
    cuts[n] = hi;
    if (n == 3u && cuts[1] > cuts[2]) {
        let q = cuts[1];
        cuts[1] = cuts[2];
        cuts[2] = q;
    }
    for (var k = 0u; k < n; k++) {
        let p0 = cuts[k];
        let p1 = cuts[k + 1u];
        if (p1 <= p0) {
            continue;
        }
        var th0 = 0.0;
        var th1 = 0.0;
        if (point) {
            th0 = atan((p0 - ts) / hs);
            th1 = atan((p1 - ts) / hs);
        }
        for (var q = 0u; q < 6u; q++) {
            var t = 0.0;
            var weight = 0.0;
            if (point) {
                // t = t_s + h_s·tan θ, dt = d²/h_s dθ.
                let th = 0.5 * (th0 + th1) + 0.5 * (th1 - th0) * GL_X[q];
                t = ts + hs * tan(th);
                let cs = cos(th);
                let d2 = max(hs * hs / (cs * cs), r_min * r_min);
                weight = 0.5 * (th1 - th0) * GL_W[q] * d2 / hs;
            } else {
                t = 0.5 * (p0 + p1) + 0.5 * (p1 - p0) * GL_X[q];
                weight = 0.5 * (p1 - p0) * GL_W[q];
            }
            let x = t * dir;
            let dx = x - b;
            let density = c * exp(-a * a * dot(dx, dx));
            let own_v = line_gauss(c, a, b, vec3<f32>(0.0), dir, t);
            var inv_d2 = 1.0;
            var own_s = 0.0;
            var path = t;
            var others = 0.0;
            if (point) {
                let ls = s - x;
                let d = length(ls);
                if (d > 0.0) {
                    own_s = line_gauss(c, a, b, x, ls / d, d);
                }
                let dd = max(d, r_min);
                inv_d2 = 1.0 / (dd * dd);
                path = t + d;
                others = pair_depth_to(l, i, n_g, dir, t, s);
            } else {
                own_s = line_gauss(c, a, b, x, s, LONG);
            }
            let f = weight * b1.y * density * inv_d2 / (4.0 * PI) * exp(-others - own_v - own_s);
            for (var ch = 0u; ch < 3u; ch++) {
                var e = 0.0;
                if (beta[ch] > 0.0) {
                    e = beta[ch] * path;
                }
                out[ch] += f * exp(-e);
            }
        }
    }
    return out;
}

// haze_gaussians::integrated::host_ratio of light l's exact list, point light at s (an
// empty list: 1).
fn host_ratio(l: u32, n_g: u32, dir: vec3<f32>, t_end: f32, s: vec3<f32>, beta0: f32) -> f32 {
    let n_l = P.size.z;
    let count = u32(bexp[n_l * n_g + l].z);
    if (count == 0u || t_end <= 0.0) {
        return 1.0;
    }
    let ts = dot(s, dir);
    let hs = max(sqrt(max(dot(s, s) - ts * ts, 0.0)), P.sigma_t.w);
    let lo = atan(-ts / hs);
    let hi = atan((t_end - ts) / hs);
    let pieces = array<f32, 3>(lo, clamp(0.0, lo, hi), hi);
    var num = 0.0;
    var den = 0.0;
    for (var side = 0u; side < 2u; side++) {
        let w0 = pieces[side];
        let w1 = pieces[side + 1u];
        for (var k = 0u; k < HOST_NODES; k++) {
            let a0 = w0 + (w1 - w0) * f32(k) / f32(HOST_NODES);
            let a1 = w0 + (w1 - w0) * f32(k + 1u) / f32(HOST_NODES);
            if (a1 <= a0) {
                continue;
            }
            for (var q = 0u; q < 6u; q++) {
                let th = 0.5 * (a0 + a1) + 0.5 * (a1 - a0) * GL_X[q];
                let t = ts + hs * tan(th);
                let p = t * dir;
                let ls = s - p;
                let d = length(ls);
                var g = GL_W[q] * (a1 - a0);
                if (beta0 > 0.0) {
                    g *= exp(-beta0 * (t + d));
                }
                if (!(g > 0.0)) {
                    continue;
                }
                var depth = 0.0;
                for (var j = 0u; j < count; j++) {
                    let h = exact_id(l, n_g, j);
                    let h0 = blobs[2u * h];
                    let hc = blobs[2u * h + 1u].x;
                    depth += line_gauss(hc, h0.w, h0.xyz, vec3<f32>(0.0), dir, t);
                    if (d > 0.0) {
                        depth += line_gauss(hc, h0.w, h0.xyz, p, ls / d, d);
                    }
                }
                num += g * exp(-depth);
                den += g;
            }
        }
    }
    if (den > 0.0) {
        return num / den;
    }
    return 1.0;
}

// The surfaces' exact shadow on the sky relative to e^{−T̄} at pixel `px` (the CPU's
// table, paper_b::sky_grid: its records start at the header's second record's w, −1
// without a table), where the pixel's ray ends on the table's surface; 1 elsewhere.
fn sky_ratio(px: vec2<u32>, surface: i32) -> vec3<f32> {
    let at = bexp[arrayLength(&bexp) - 1u].w;
    if (at < 0.0) {
        return vec3<f32>(1.0);
    }
    let rec = bexp[u32(at) + px.y * P.size.x + px.x];
    if (i32(rec.w) != surface) {
        return vec3<f32>(1.0);
    }
    return rec.xyz;
}

// GaussianEnv::surface: the SH environment on the surface dimmed by e^{−T̄(p)} times `sky`
// (sky_ratio), `mean` the Gaussians' (T̄, S̄) at p (tile_mean_depth).
fn env_surface_b(mean: vec2<f32>, sky: vec3<f32>, n: vec3<f32>, r: vec3<f32>, diffuse: vec3<f32>, specular: vec3<f32>, m: f32, gn: f32) -> vec3<f32> {
    let n_g = gaussian_count();
    let rec = bexp[env_base(n_g) + n_g];
    let t = rec.w + mean.x;
    let s = mean.y;
    let att = exp(-t) * sky;
    var out = vec3<f32>(0.0);
    if (P.env.z > 0u) {
        out += diffuse / PI * env_lobe(n, 0u);
        if (gn >= 0.0 && any(specular > vec3<f32>(0.0))) {
            out += specular * (m + 2.0) / (2.0 * PI) * env_lobe(r, u32(gn));
        }
    }
    out *= att;
    if (env_mode() == 2u && s > 0.0) {
        out += s * att * rec.xyz * (diffuse + specular * (m + 2.0) / (m + 1.0));
    }
    return out;
}

// ---- Per-tile lists of Gaussians (§5's splatting as screen tiles) ----
// A workgroup is an 8×8 tile of pixels. Its invocations test the Gaussians in chunks of
// CHUNK against a bound of the whole tile (the frustum of its view rays, or the hull of
// its surface points and a light) and compact the survivors, in index order, into
// `tile_list`; every pixel then loops over the list only. A Gaussian left out cannot
// reach any of the tile's per-pixel computations (the view ray's cull sphere test, or
// line_gauss's √40-radii cut-off), so these sums are the unculled ones, in the same
// order. (T̄(p), which has no cut-off, is another matter: tile_mean_depth.)
const TILE_SIZE: u32 = 8u;
const CHUNK: u32 = 256u;
// CHUNK / 64 invocations.
const PER_INVOCATION: u32 = 4u;
// Up to this many Gaussians every pixel loops over all of them (the same sums in the same
// order as through the lists, without the lists' barriers): gpu::paper_b::DIRECT_MAX, set
// by the pipeline (the UNTILED variant's: all of them).
override DIRECT_MAX: u32;

// The barrier of the tile lists; none in the UNTILED variant.
#ifdef UNTILED
fn tile_barrier() {}
#else
fn tile_barrier() {
    workgroupBarrier();
}
#endif
// line_gauss's cut-off, √40 radii.
const SQRT_40: f32 = 6.32455532;

var<workgroup> tile_list: array<u32, 256>;
var<workgroup> tile_counts: array<u32, 64>;
var<workgroup> tile_total: u32;
var<workgroup> tile_points: array<vec4<f32>, 64>;

// The margin added to every cull radius: f32's rounding of the shader's own per-pixel
// tests and of the bounds (~10⁻⁷ relative) a hundred times over.
fn cull_margin(r: f32, b: vec3<f32>) -> f32 {
    return 1.0e-3 * r + 1.0e-5 * length(b) + 1.0e-30;
}

// The tile's four side planes through the eye (inward unit normals) from the rays through
// its corners at the pixel edges; every view ray of the tile lies in the convex cone
// {x : nₖ·x ≥ 0}.
fn tile_planes(tile: vec2<u32>) -> array<vec3<f32>, 4> {
    let x0 = f32(tile.x * TILE_SIZE);
    let y0 = f32(tile.y * TILE_SIZE);
    let x1 = f32(min((tile.x + 1u) * TILE_SIZE, P.size.x));
    let y1 = f32(min((tile.y + 1u) * TILE_SIZE, P.size.y));
    let c00 = pixel_dir(vec2<f32>(x0, y0));
    let c10 = pixel_dir(vec2<f32>(x1, y0));
    let c01 = pixel_dir(vec2<f32>(x0, y1));
    let c11 = pixel_dir(vec2<f32>(x1, y1));
    let mid = pixel_dir(vec2<f32>(0.5 * (x0 + x1), 0.5 * (y0 + y1)));
    var planes = array<vec3<f32>, 4>(cross(c00, c01), cross(c10, c00), cross(c11, c10), cross(c01, c11));
    for (var k = 0u; k < 4u; k++) {
        var n = normalize(planes[k]);
        if (dot(n, mid) < 0.0) {
            n = -n;
        }
        planes[k] = n;
    }
    return planes;
}

// Whether Gaussian i's cull sphere meets the tile's cone of view rays.
fn meets_tile(i: u32, planes: array<vec3<f32>, 4>) -> bool {
    let b0 = blobs[2u * i];
    let r = sqrt(blobs[2u * i + 1u].z);
    let reach = -(r + cull_margin(r, b0.xyz));
    for (var k = 0u; k < 4u; k++) {
        if (dot(planes[k], b0.xyz) < reach) {
            return false;
        }
    }
    return true;
}

// Whether Gaussian i's √40-radii sphere comes within `rad` of the segment o + t·u,
// t ∈ [0, len] (rad < 0: never).
fn near_segment(i: u32, o: vec3<f32>, u: vec3<f32>, len: f32, rad: f32) -> bool {
    if (rad < 0.0) {
        return false;
    }
    let b0 = blobs[2u * i];
    let r = SQRT_40 / b0.w;
    let bo = b0.xyz - o;
    let t = clamp(dot(bo, u), 0.0, len);
    let foot = bo - t * u;
    let reach = r + rad + cull_margin(r, b0.xyz) + 1.0e-5 * length(o);
    return dot(foot, foot) <= reach * reach;
}

// The tests of list_chunk.
const LIST_VIEW: u32 = 0u;
const LIST_SEGMENT: u32 = 1u;
const LIST_NEAR: u32 = 2u;

// Fills tile_list with the Gaussians start.. start + CHUNK that pass the tile's test
// (LIST_VIEW: meets_tile with `planes`; LIST_SEGMENT: near_segment with o, u, len, rad;
// LIST_NEAR: not far_from_tile of the sphere (o, rad)), in index order; returns how
// many. Called by every invocation of the workgroup alike.
fn list_chunk(start: u32, n: u32, lid: u32, mode: u32, planes: array<vec3<f32>, 4>, o: vec3<f32>, u: vec3<f32>, len: f32, rad: f32) -> u32 {
    // Every invocation is done with the previous list before it is overwritten.
    tile_barrier();
    var mine: array<u32, 4>;
    var count = 0u;
    for (var k = 0u; k < PER_INVOCATION; k++) {
        let i = start + PER_INVOCATION * lid + k;
        if (i < n) {
            var keep = false;
            if (mode == LIST_VIEW) {
                keep = meets_tile(i, planes);
            } else if (mode == LIST_SEGMENT) {
                keep = near_segment(i, o, u, len, rad);
            } else {
                keep = rad >= 0.0 && !far_from_tile(i, o, rad);
            }
            if (keep) {
                mine[count] = i;
                count++;
            }
        }
    }
    tile_counts[lid] = count;
    tile_barrier();
    // One invocation turns the counts into offsets (an exclusive scan).
    if (lid == 0u) {
        var total = 0u;
        for (var j = 0u; j < TILE_SIZE * TILE_SIZE; j++) {
            let c = tile_counts[j];
            tile_counts[j] = total;
            total += c;
        }
        tile_total = total;
    }
    tile_barrier();
    let at = tile_counts[lid];
    for (var k = 0u; k < count; k++) {
        tile_list[at + k] = mine[k];
    }
    tile_barrier();
    return tile_total;
}

// ---- T̄(p) by tiles: far Gaussians through a Taylor expansion about the tile ----
// T̄ has no cut-off (𝒯 ~ √π/(4ρ²)). A Gaussian far from the sphere (cb, rb) around the
// tile's surface points — every point at ρ = a|p − b| ≥ 6, where gauss_mean_depth takes
// Dawson's asymptotic series, and |cb − b| ≥ FAR_RATIO·rb — adds its series' Taylor
// expansion to second order about cb, summed over the tile's far Gaussians once (value,
// gradient, Hessian; T̄ and S̄ = Σ αᵢT̄ᵢ): for the leading 1/|x|² the remainder is below
// Σ_{k≥3}(k+1)ε^k ≈ 4ε³, ε = rb/|cb − b| ≤ 1/FAR_RATIO (Gegenbauer's |C_k¹| ≤ k + 1), so
// within 1.1·10⁻³ of the far Gaussians' share. The near ones are listed and summed
// exactly per pixel.
const FAR_RATIO: f32 = 16.0;

// Per invocation, its share of the far sums: (T̄, ∇T̄), (H_xx, H_yy, H_zz, H_xy),
// (H_xz, H_yz, -, -), then the same for S̄.
var<workgroup> tile_far: array<vec4<f32>, 384>;

// Whether Gaussian i is far from every point of the sphere (cb, rb) (above).
fn far_from_tile(i: u32, cb: vec3<f32>, rb: f32) -> bool {
    let b0 = blobs[2u * i];
    let d = length(b0.xyz - cb) * (1.0 - 1.0e-4);
    return d >= FAR_RATIO * rb && b0.w * (d - rb) >= 6.0;
}

// Gaussian i's asymptotic T̄ᵢ (gauss_mean_depth beyond ρ = 6) at cb, its gradient and
// Hessian: with s = |x|², x = cb − b, u = 1/(a²s), φ(s) = (c/a)(√π/4)·P(u),
// P = u + u²/2 + 3u³/4 + 15u⁴/8: φ′ = −(c/a)(√π/4)·u·P′(u)/s, φ″ = (c/a)(√π/4)·Q′(u)/s²,
// Q = u²P′; ∇ = 2φ′x, H = 2φ′I + 4φ″xxᵀ. Written as the three records of tile_far.
fn far_terms(i: u32, cb: vec3<f32>) -> array<vec4<f32>, 3> {
    let b0 = blobs[2u * i];
    let c = blobs[2u * i + 1u].x;
    let a = b0.w;
    let x = cb - b0.xyz;
    let s = dot(x, x);
    let u = 1.0 / (a * a * s);
    let k = SQRT_PI_2 * 0.5 * c / a;
    let p = u * (1.0 + u * (0.5 + u * (0.75 + u * 1.875)));
    let dp = 1.0 + u * (1.0 + u * (2.25 + u * 7.5));
    let dq = u * (2.0 + u * (3.0 + u * (9.0 + u * 37.5)));
    let d1 = -k * u * dp / s;
    let d2 = k * dq / (s * s);
    let g = 2.0 * d1 * x;
    let hd = 2.0 * d1 + 4.0 * d2 * x * x;
    let ho = 4.0 * d2 * vec3<f32>(x.x * x.y, x.x * x.z, x.y * x.z);
    return array<vec4<f32>, 3>(vec4<f32>(k * p, g), vec4<f32>(hd, ho.x), vec4<f32>(ho.y, ho.z, 0.0, 0.0));
}

// The expansion of records r0..r2 at cb + d.
fn far_at(r0: vec4<f32>, r1: vec4<f32>, r2: vec4<f32>, d: vec3<f32>) -> f32 {
    let quad = dot(r1.xyz, d * d) + 2.0 * (r1.w * d.x * d.y + r2.x * d.x * d.z + r2.y * d.y * d.z);
    return r0.x + dot(r0.yzw, d) + 0.5 * quad;
}

// (T̄(p), S̄(p)) of the Gaussians (the background's β_bg·D apart) for every invocation
// where `shading`; (cb, rb): the sphere around the tile's surface points (rb < 0: none).
fn tile_mean_depth(p: vec3<f32>, shading: bool, lid: u32, cb: vec3<f32>, rb: f32) -> vec2<f32> {
    let n = gaussian_count();
    if (n <= DIRECT_MAX) {
        var exact = vec2<f32>(0.0);
        if (shading) {
            for (var i = 0u; i < n; i++) {
                let b0 = blobs[2u * i];
                let b1 = blobs[2u * i + 1u];
                let ti = gauss_mean_depth(b1.x, b0.w, b0.xyz, p);
                exact += vec2<f32>(ti, b1.y * ti);
            }
        }
        return exact;
    }
    var acc = array<vec4<f32>, 6>(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    if (rb >= 0.0) {
        for (var i = lid; i < n; i += TILE_SIZE * TILE_SIZE) {
            if (far_from_tile(i, cb, rb)) {
                let f = far_terms(i, cb);
                let albedo = blobs[2u * i + 1u].y;
                for (var k = 0u; k < 3u; k++) {
                    acc[k] += f[k];
                    acc[k + 3u] += albedo * f[k];
                }
            }
        }
    }
    tile_barrier();
    for (var k = 0u; k < 6u; k++) {
        tile_far[6u * lid + k] = acc[k];
    }
    tile_barrier();
    // One invocation sums the shares into the first six records.
    if (lid == 0u) {
        for (var j = 1u; j < TILE_SIZE * TILE_SIZE; j++) {
            for (var k = 0u; k < 6u; k++) {
                tile_far[k] += tile_far[6u * j + k];
            }
        }
    }
    tile_barrier();
    var out = vec2<f32>(0.0);
    if (shading) {
        let d = p - cb;
        out = vec2<f32>(far_at(tile_far[0], tile_far[1], tile_far[2], d), far_at(tile_far[3], tile_far[4], tile_far[5], d));
    }
    let none = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    for (var start = 0u; start < n; start += CHUNK) {
        let m = list_chunk(start, n, lid, LIST_NEAR, none, cb, vec3<f32>(0.0), 0.0, rb);
        if (shading) {
            for (var k = 0u; k < m; k++) {
                let i = tile_list[k];
                let b0 = blobs[2u * i];
                let b1 = blobs[2u * i + 1u];
                let ti = gauss_mean_depth(b1.x, b0.w, b0.xyz, p);
                out += vec2<f32>(ti, b1.y * ti);
            }
        }
    }
    return out;
}

// The Gaussians' optical depth along o + t·u, t ∈ [0, len], and its scattering part, for
// every invocation where `shading`, over the Gaussians near the segment (cu, culen) of
// the tile's bound (radius crad) — which holds every shading invocation's segment.
fn gauss_depth_tiled(o: vec3<f32>, u: vec3<f32>, len: f32, shading: bool, lid: u32, co: vec3<f32>, cu: vec3<f32>, clen: f32, crad: f32) -> vec2<f32> {
    var out = vec2<f32>(0.0);
    let n = gaussian_count();
    let none = array<vec3<f32>, 4>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    let direct = n <= DIRECT_MAX;
    for (var start = 0u; start < n; start += CHUNK) {
        var m = n - start;
        if (!direct) {
            m = list_chunk(start, n, lid, LIST_SEGMENT, none, co, cu, clen, crad);
        }
        if (shading) {
            for (var k = 0u; k < m; k++) {
                let i = select(tile_list[k], start + k, direct);
                let b0 = blobs[2u * i];
                let b1 = blobs[2u * i + 1u];
                let t = line_gauss(b1.x, b0.w, b0.xyz, o, u, len);
                out += vec2<f32>(t, b1.y * t);
            }
        }
    }
    return out;
}

// paper_b::Prepared::surface: the surface lit through T(s,p), for every invocation
// where `shading` (the others pass along for the tile's lists). (cb, rb): a sphere
// holding the tile's surface points (rb < 0: none).
fn shade_surface_b(dir: vec3<f32>, p: vec3<f32>, n: vec3<f32>, s: u32, shading: bool, sky: vec3<f32>, lid: u32, cb: vec3<f32>, rb: f32) -> vec3<f32> {
    // A scene without surfaces has one empty record: read materials where shading only.
    var mat = array<vec4<f32>, 2>(vec4<f32>(0.0), vec4<f32>(0.0, 0.0, 0.0, -1.0));
    if (shading) {
        mat = array<vec4<f32>, 2>(surfaces[4u * s + 2u], surfaces[4u * s + 3u]);
    }
    let diffuse = mat[0].xyz;
    let m = mat[0].w;
    let specular = mat[1].xyz;
    let gn = mat[1].w;
    let r = 2.0 * dot(-dir, n) * n + dir;
    let eps = P.albedo.w;
    let p_off = p + eps * (1.0 + length(p)) * n;
    let header = arrayLength(&bexp) - 2u;
    let background_hides_suns = bexp[header].y > 0.5;
    let ss_scene = bexp[header + 1u].xyz;
    var out = vec3<f32>(0.0);
    if (env_mode() > 0u) {
        let mean = tile_mean_depth(p, shading, lid, cb, rb);
        if (shading) {
            out = env_surface_b(mean, sky, n, r, diffuse, specular, m, gn);
        }
    }
    for (var i = 0u; i < P.size.z; i++) {
        let a = lights[3u * i];
        let e = lights[3u * i + 1u].xyz;
        if (a.x == 0.0) {
            var light = a.yzw;
            let v0 = light - p;
            let d0 = length(v0);
            if (d0 < P.sigma_t.w) {
                var u = n;
                if (d0 > 0.0) {
                    u = v0 / d0;
                }
                light = p + P.sigma_t.w * u;
            }
            let v = light - p;
            let d = length(v);
            let l = v / d;
            var f = vec3<f32>(0.0);
            if (shading && dot(n, l) > 0.0 && visible(p_off, light, eps)) {
                f = brdf(n, r, l, diffuse, specular, m);
            }
            // The tile's bound: the capsule around cb → light of radius rb (+ r_min, how
            // far a light is moved off a point too close).
            let cv = a.yzw - cb;
            let clen = length(cv);
            var cu = vec3<f32>(0.0, 0.0, 1.0);
            if (clen > 0.0) {
                cu = cv / clen;
            }
            var crad = rb;
            if (rb >= 0.0) {
                crad = rb + P.sigma_t.w;
            }
            let depth = gauss_depth_tiled(p, l, d, shading, lid, cb, cu, clen, crad);
            if (!shading) {
                continue;
            }
            let theta_s = angle(n, l);
            let theta_r = angle(r, l);
            for (var c = 0u; c < 3u; c++) {
                if (e[c] <= 0.0) {
                    continue;
                }
                let beta = P.sigma_t[c] + depth.x / d;
                var v_c = exp(-beta * d) / (d * d) * f[c];
                let ss = P.sigma_s[c] + depth.y / d;
                if (ss > 0.0) {
                    let t = beta * d;
                    var g = diffuse[c] / PI * g_table(0u, t, theta_s);
                    if (gn >= 0.0 && specular[c] > 0.0) {
                        g += specular[c] * (m + 2.0) / (2.0 * PI) * g_table(u32(gn), t, theta_r);
                    }
                    v_c += ss / (2.0 * PI * d) * g;
                }
                out[c] += e[c] * v_c;
            }
        } else {
            let irradiance = lights[3u * i + 2u].xyz;
            let sd = a.yzw;
            let lit = shading && dot(n, sd) > 0.0 && !background_hides_suns && intersect(p_off, sd, 0.0, 3.0e38).surface < 0;
            let t = gauss_depth_tiled(p, sd, LONG, lit, lid, cb, sd, LONG, rb).x;
            if (lit) {
                out += irradiance * exp(-t) * brdf(n, r, sd, diffuse, specular, m);
            }
            let lobes = diffuse + specular * (m + 2.0) / (m + 1.0);
            for (var c = 0u; c < 3u; c++) {
                if (shading && ss_scene[c] > 0.0) {
                    out[c] += P.albedo[c] * irradiance[c] / (4.0 * PI) * lobes[c];
                }
            }
        }
    }
    return out;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) tile: vec3<u32>) {
    let w = P.size.x;
    let h = P.size.y;
    // Invocations beyond the image's edge take part in the tile's lists, write nothing.
    let inside = id.x < w && id.y < h;
    let dir = pixel_dir(vec2<f32>(min(id.xy, vec2<u32>(w - 1u, h - 1u))) + 0.5);

    let env_far = P.flags.y == 0u;
    let t_max = primary_t_max();
    let hit = intersect(vec3<f32>(0.0), dir, 0.0, t_max);
    let finite_end = hit.surface >= 0 || env_far;
    var t_end = LONG;
    if (finite_end) {
        t_end = hit.t;
    }
    let beta = P.sigma_t.xyz;
    let ss = P.sigma_s.xyz;
    let n_g = gaussian_count();
    let n_l = P.size.z;
    let header = arrayLength(&bexp) - 2u;
    let background_hides_suns = bexp[header].y > 0.5;
    let ss_scene = bexp[header + 1u].xyz;
    let noisy = bexp[header].z > 0.5;
    let has_env = env_mode() > 0u;
    let env_at = env_base(n_g);
    var out = vec3<f32>(0.0);
    // The Gaussians whose cull sphere the ray crosses: Tᵢ(v,p) and their factored airlight.
    var tau = 0.0;
    let planes = tile_planes(tile.xy);
    let direct = n_g <= DIRECT_MAX;
    for (var start = 0u; start < n_g; start += CHUNK) {
        var listed = n_g - start;
        if (!direct) {
            listed = list_chunk(start, n_g, lid, LIST_VIEW, planes, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0);
        }
        for (var k = 0u; k < listed; k++) {
            let i = select(tile_list[k], start + k, direct);
            let b0 = blobs[2u * i];
            let b1 = blobs[2u * i + 1u];
            let b = b0.xyz;
            let m = dot(b, dir);
            let foot = b - clamp(m, 0.0, t_end) * dir;
            if (dot(foot, foot) > b1.z) {
                continue;
            }
            let a = b0.w;
            let t_r = clamp(m, 0.0, t_end);
            var along = dir;
            if (noisy) {
                along = noisy_direction(i, n_g, dir, t_r);
            }
            let vp = line_gauss(b1.x, a, b, vec3<f32>(0.0), along, t_end);
            tau += vp;
            if (vp <= 0.0 || b1.y <= 0.0) {
                continue;
            }
            let vr = line_gauss(b1.x, a, b, vec3<f32>(0.0), dir, t_r);
            let br = t_r * dir;
            for (var l = 0u; l < n_l; l++) {
                let la = lights[3u * l];
                let pair = bexp[l * n_g + i].w;
                if (pair >= 0.0) {
                    // Integrated along the ray, noise scaling the integral as it scales
                    // Tᵢ(v,p).
                    var f = pair;
                    if (noisy) {
                        let straight = line_gauss(b1.x, a, b, vec3<f32>(0.0), dir, t_end);
                        f = select(0.0, f * vp / straight, straight > 0.0);
                    }
                    var power = lights[3u * l + 2u].xyz;
                    if (la.x == 0.0) {
                        power = lights[3u * l + 1u].xyz;
                    }
                    out += power * f * pair_integral(i, l, n_g, dir, t_end, beta);
                    continue;
                }
                var f0 = 1.0 / (4.0 * PI);
                var sr = 0.0;
                var e = lights[3u * l + 2u].xyz;
                if (la.x == 0.0) {
                    e = lights[3u * l + 1u].xyz;
                    let ls = br - la.yzw;
                    let d = length(ls);
                    if (d > 0.0) {
                        sr = line_gauss(b1.x, a, b, la.yzw, ls / d, d);
                    }
                    let dc = max(d, P.sigma_t.w);
                    f0 = 1.0 / (4.0 * PI * dc * dc);
                } else {
                    sr = line_gauss(b1.x, a, b, br, la.yzw, LONG);
                }
                let base = b1.y * f0 * exp(-sr - vr) * vp;
                out += e * base * bexp[l * n_g + i].xyz;
            }
            if (has_env) {
                let own = vr + gauss_mean_depth(b1.x, a, b, br);
                out += bexp[env_at + i].xyz * (exp(-own) * vp);
            }
        }
    }
    // The homogeneous term of each light.
    for (var l = 0u; l < n_l; l++) {
        let la = lights[3u * l];
        var c_sv = bexp[n_l * n_g + l].x;
        if (la.x == 0.0) {
            if (bexp[n_l * n_g + l].z > 0.0) {
                let b0 = (beta.x + beta.y + beta.z) / 3.0;
                c_sv = bexp[n_l * n_g + l].y * host_ratio(l, n_g, dir, t_end, la.yzw, b0);
            }
            let e = lights[3u * l + 1u].xyz;
            let s = effective_light(dir, la.yzw);
            for (var c = 0u; c < 3u; c++) {
                if (e[c] > 0.0 && ss[c] > 0.0) {
                    out[c] += e[c] * c_sv * airlight(dir, t_end, finite_end, s, beta[c], ss[c]);
                }
            }
        } else if (!background_hides_suns) {
            let irradiance = lights[3u * l + 2u].xyz;
            for (var c = 0u; c < 3u; c++) {
                if (ss_scene[c] <= 0.0 || irradiance[c] <= 0.0) {
                    continue;
                }
                var len = 0.0;
                if (finite_end) {
                    len = attenuated_length(beta[c], t_end);
                } else {
                    len = 1.0 / beta[c];
                }
                out[c] += c_sv * ss_scene[c] * irradiance[c] / (4.0 * PI) * len;
            }
        }
    }
    // The tile's surface points, bounded by a sphere for the lists (none without them).
    let on_surface = inside && hit.surface >= 0;
    let p = t_end * dir;
    var surf_id = 0u;
    var n = vec3<f32>(0.0, 0.0, 1.0);
    if (on_surface) {
        surf_id = u32(hit.surface);
        n = hit_normal(hit, p, dir);
    }
    var cb = vec3<f32>(0.0);
    var rb = -1.0;
    if (n_g > DIRECT_MAX) {
        tile_points[lid] = select(vec4<f32>(0.0), vec4<f32>(p, 1.0), on_surface);
        tile_barrier();
        // One invocation bounds them (into the first record; w < 0: no surface point).
        if (lid == 0u) {
            var lo = vec3<f32>(3.0e38);
            var hi = vec3<f32>(-3.0e38);
            for (var k = 0u; k < TILE_SIZE * TILE_SIZE; k++) {
                let q = tile_points[k];
                if (q.w > 0.0) {
                    lo = min(lo, q.xyz);
                    hi = max(hi, q.xyz);
                }
            }
            var sphere = vec4<f32>(0.0, 0.0, 0.0, -1.0);
            if (all(lo <= hi)) {
                let c = 0.5 * (lo + hi);
                sphere = vec4<f32>(c, 0.5 * length(hi - lo) * (1.0 + 1.0e-5) + 1.0e-5 * length(c));
            }
            tile_points[0] = sphere;
        }
        tile_barrier();
        cb = tile_points[0].xyz;
        rb = tile_points[0].w;
    }
    var sky = vec3<f32>(1.0);
    if (on_surface) {
        sky = sky_ratio(id.xy, hit.surface);
    }
    var behind = shade_surface_b(dir, p, n, surf_id, on_surface, sky, lid, cb, rb);
    if (!on_surface && (finite_end || any(beta <= vec3<f32>(0.0)))) {
        behind = background(dir);
    }
    for (var c = 0u; c < 3u; c++) {
        if (behind[c] != 0.0) {
            if (!finite_end) {
                if (beta[c] <= 0.0) {
                    out[c] += exp(-tau) * behind[c];
                }
            } else if (beta[c] <= 0.0) {
                out[c] += exp(-tau) * behind[c];
            } else {
                out[c] += exp(-beta[c] * t_end - tau) * behind[c];
            }
        }
    }
    if (inside) {
        image[id.y * w + id.x] = vec4<f32>(out, 1.0);
    }
}
