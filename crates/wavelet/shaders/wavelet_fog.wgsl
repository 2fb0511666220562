// Wavelet fog on the GPU (paper E §4.3–4.4, §5): the twin of `haze_wavelet::render::shade`
// over a fog in `Mode::Deconstructed`, in f32, one invocation per pixel (`main`) or per
// given ray (`depths`, the twin of `Fog::optical_depth` / `Fog::optical_depth_ray`).
//
// A pixel's ray leaves the eye; P is where it meets the ground z = 0, or, for a sky ray,
// where it leaves the fog. The optical depth from the eye to P is integrated exactly:
// the ray is cut into µ bands (d_max,l = |OP|·µ^l, eq. 12), band l integrates the single
// scaling basis A_l of level l, finest band first, cell by cell of the level's grid (a
// 2-D DDA); in a cell every B-spline piece is a polynomial of the normalized ray
// parameter σ, the vertical profile h(z) = e^{−k(z − bottom)} is an exponential in σ, so
// the cell's integral is Δ·h(z_lo)·Σ_n R_n M_n(k|Δz|) with M_n(x) = ∫₀¹ σⁿ e^{−xσ} dσ
// (`integrate::moments`). The march stops once the accumulated integral, less the lowest
// value the rest of the ray can add (the floors of later bands), reaches the depth where
// the transmittance is `min_transmittance`, as the CPU does. Then
// L = τ·L_surface + (1 − τ)·L_fog.
//
// Coordinates: x, y relative to the fogmap's origin, z relative to the fog's bottom, so a
// fog far from the world origin keeps f32 precision; grid coordinates of level l are
// (x/cell + d/2)/scale_l.
//
// With a smoke layer (radiance L_s, transmittance T_s and depth d per pixel, `smoke`), the
// fog is integrated in two spans split at d, with the µ bands of the whole ray, and
// L = F[0, d] + T_f[0, d]·(L_s + T_s·F[d, P]) (`render::shade_over`).
//
// Output per pixel: (r, g, b, τ) (τ of fog and smoke together); per ray: (optical depth,
// 0, 0, 0).

struct Params {
    eye: vec3<f32>,
    tan_half: f32,
    forward: vec3<f32>,
    aspect: f32,
    right: vec3<f32>,
    cell: f32,
    up: vec3<f32>,
    density: f32,
    // Fog footprint: x min, x max, y min, y max (relative to the origin).
    bounds: vec4<f32>,
    zenith: vec3<f32>,
    checker: f32,
    horizon: vec3<f32>,
    // Height of the ground z = 0, relative to the fog's bottom.
    ground_z: f32,
    ground0: vec3<f32>,
    // Top of the slab, relative to its bottom.
    top: f32,
    ground1: vec3<f32>,
    falloff: f32,
    fog: vec3<f32>,
    mu: f32,
    // World (x, y) of the fogmap's origin (for the ground's checker).
    origin: vec2<f32>,
    // Integral (coefficient × length) at which the transmittance is `min_transmittance`:
    // −ln(min_transmittance)/density, 3e38 for never.
    stop_depth: f32,
    // d/2: finest-grid shift of the B-spline knots.
    shift: f32,
    // Image size in pixels (`main`), or rays and 1 (`depths`).
    image: vec2<u32>,
    // Decomposition steps L: levels 0 … L.
    levels: u32,
    degree: u32,
    // Scaling basis: cell of coefficient 0's first piece, pieces per function.
    first: vec2<i32>,
    support: vec2<i32>,
    // 1: composite the smoke layer `smoke` by depth (`main`), 0: no smoke.
    layer: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct Level {
    // Cells covered: x [c.x, c.y), y [c.z, c.w); empty when c.x >= c.y.
    cells: vec4<i32>,
    // First stored coefficient (x, y) and counts (nx, ny).
    k0: vec2<i32>,
    n: vec2<i32>,
    // Finest cells per cell of this level, the lower bound of A_l, where its coefficients
    // start in `coef`.
    scale: f32,
    floor: f32,
    coef_at: u32,
    _pad: u32,
}

// The parameters are a storage buffer, not a uniform one: Mesa's lavapipe inlines the
// values of uniforms that steer branches and loops into the shader and compiles a new
// variant for every new set of values (seconds of LLVM work each); the eye's x is among
// them, so a fog drifting east–west (or a camera moving so) recompiled the shader on
// every frame. Storage buffers are never inlined.
@group(0) @binding(0) var<storage, read> p: Params;
@group(0) @binding(1) var<storage, read> levels: array<Level>;
// The basis pieces: piece j along axis a has coefficients pieces[3·(6a + j) + 0..3].
@group(0) @binding(2) var<storage, read> pieces: array<f32>;
@group(0) @binding(3) var<storage, read> coef: array<f32>;
// Per pixel (row 0 on top, x fastest) or per ray.
@group(0) @binding(4) var<storage, read_write> result: array<vec4<f32>>;

// A ray of `depths`: from `o` along unit `d` for `len`, or to where it leaves the fog when
// `len` < 0.
struct Query {
    o: vec3<f32>,
    len: f32,
    d: vec3<f32>,
    _pad: f32,
}

@group(0) @binding(5) var<storage, read> queries: array<Query>;

// The smoke layer of `main`, two entries per pixel (x fastest, row 0 on top): the smoke's
// radiance and transmittance (L_s, T_s), then its representative depth d (in x).
@group(0) @binding(6) var<storage, read> smoke: array<vec4<f32>>;

// A polynomial of degree ≤ 4 in σ (or the moments M_0 … M_4): coefficients 0–3 in `lo`,
// 4 in `hi`. Vectors rather than arrays: a local array indexed at run time lives in
// memory on most GPUs (and on lavapipe), vectors stay in registers.
struct Poly4 {
    lo: vec4<f32>,
    hi: f32,
}

// `integrate::moments`: M_n(x) = ∫₀¹ σⁿ e^{−xσ} dσ for n = 0 … nmax (nmax ≤ 4, x ≥ 0).
// Entries above nmax multiply zero coefficients: they need only be finite.
fn moments(x: f32, nmax: u32) -> Poly4 {
    if x == 0.0 {
        return Poly4(vec4<f32>(1.0, 0.5, 1.0 / 3.0, 0.25), 0.2);
    }
    let e = exp(-x);
    let a = f32(nmax + 1u);
    if x > a {
        // Upward recurrence M_n = (n·M_{n−1} − e^{−x})/x from M_0 = (1 − e^{−x})/x
        // (x > 1: no cancellation); stable for n < x.
        let m0 = (1.0 - e) / x;
        let m1 = (m0 - e) / x;
        let m2 = (2.0 * m1 - e) / x;
        let m3 = (3.0 * m2 - e) / x;
        let m4 = (4.0 * m3 - e) / x;
        return Poly4(vec4<f32>(m0, m1, m2, m3), m4);
    }
    // M_nmax = e^{−x}·Σ_k x^k/((nmax+1)…(nmax+1+k)), all terms positive; x ≤ 5, so the
    // series reaches f32 precision in at most ~25 terms.
    var term = 1.0 / a;
    var sum = term;
    var k = 1.0;
    for (var i = 0; i < 64 && term > 1e-9 * sum; i++) {
        term *= x / (a + k);
        sum += term;
        k += 1.0;
    }
    // Downward: M_{n−1} = (x·M_n + e^{−x})/n, positive terms only.
    var m = e * sum;
    var out = Poly4(vec4<f32>(0.0), 0.0);
    if nmax >= 4u {
        out.hi = m;
        m = (x * m + e) / 4.0;
    }
    if nmax >= 3u {
        out.lo.w = m;
        m = (x * m + e) / 3.0;
    }
    if nmax >= 2u {
        out.lo.z = m;
        m = (x * m + e) / 2.0;
    }
    if nmax >= 1u {
        out.lo.y = m;
        m = x * m + e;
    }
    out.lo.x = m;
    return out;
}

// `along::<D>`: piece `j` of axis `axis` at a + σ(b − a), as a polynomial in σ.
fn along(axis: u32, j: i32, a: f32, b: f32) -> vec3<f32> {
    let at = 3u * (6u * axis + u32(j));
    let q = vec3<f32>(pieces[at], pieces[at + 1u], pieces[at + 2u]);
    let delta = b - a;
    switch p.degree {
        case 0u: {
            return vec3<f32>(q.x, 0.0, 0.0);
        }
        case 1u: {
            return vec3<f32>(q.x + q.y * a, q.y * delta, 0.0);
        }
        default: {
            return vec3<f32>((q.z * a + q.y) * a + q.x, (2.0 * q.z * a + q.y) * delta, q.z * delta * delta);
        }
    }
}

// `cell_polynomial`: the integrand polynomial of level `lv` in cell (ix, iy), whose local
// coordinates run from (s.x, q.x) to (s.y, q.y): Σ_kx X_kx(σ)·Σ_ky c·Y_ky(σ).
fn cell_polynomial(lv: Level, ix: i32, iy: i32, s: vec2<f32>, q: vec2<f32>) -> Poly4 {
    var r = Poly4(vec4<f32>(0.0), 0.0);
    // Stride 1: the coefficients whose support covers the cell.
    let kx0 = max(ix - p.first.x - p.support.x + 1, lv.k0.x);
    let kx1 = min(ix - p.first.x, lv.k0.x + lv.n.x - 1);
    let ky0 = max(iy - p.first.y - p.support.y + 1, lv.k0.y);
    let ky1 = min(iy - p.first.y, lv.k0.y + lv.n.y - 1);
    if kx0 > kx1 || ky0 > ky1 {
        return r;
    }
    // At most 3 functions overlap a cell along y (quadratic support).
    let ny = ky1 - ky0 + 1;
    let y0 = along(1u, iy - p.first.y - ky0, q.x, q.y);
    var y1 = vec3<f32>(0.0);
    var y2 = vec3<f32>(0.0);
    if ny > 1 {
        y1 = along(1u, iy - p.first.y - ky0 - 1, q.x, q.y);
    }
    if ny > 2 {
        y2 = along(1u, iy - p.first.y - ky0 - 2, q.x, q.y);
    }
    let row0 = lv.coef_at + u32((ky0 - lv.k0.y) * lv.n.x);
    let width = u32(lv.n.x);
    for (var kx = kx0; kx <= kx1; kx++) {
        let x = along(0u, ix - p.first.x - kx, s.x, s.y);
        let at = row0 + u32(kx - lv.k0.x);
        // Z(σ) = Σ_ky c·Y_ky(σ).
        var z = coef[at] * y0;
        if ny > 1 {
            z += coef[at + width] * y1;
        }
        if ny > 2 {
            z += coef[at + 2u * width] * y2;
        }
        // R += X·Z (degree ≤ 4; the unused coefficients of X and Z are zero).
        r.lo += vec4<f32>(
            x.x * z.x,
            x.x * z.y + x.y * z.x,
            x.x * z.z + x.y * z.y + x.z * z.x,
            x.y * z.z + x.z * z.y,
        );
        r.hi += x.z * z.z;
    }
    return r;
}

fn start_cell(x: f32, dx: f32) -> i32 {
    if dx < 0.0 {
        return i32(ceil(x)) - 1;
    }
    return i32(floor(x));
}

fn next_crossing(c: i32, x0: f32, dx: f32) -> f32 {
    if dx > 0.0 {
        return (f32(c) + 1.0 - x0) / dx;
    } else if dx < 0.0 {
        return (f32(c) - x0) / dx;
    }
    return 3.0e38;
}

// Clips [t.x, t.y] to lo ≤ x0 + t·dx ≤ hi (an empty interval when outside).
fn clip_axis(x0: f32, dx: f32, lo: f32, hi: f32, t: vec2<f32>) -> vec2<f32> {
    if dx == 0.0 {
        if x0 < lo || x0 > hi {
            return vec2<f32>(t.x, t.x - 1.0);
        }
        return t;
    }
    let a = (lo - x0) / dx;
    let b = (hi - x0) / dx;
    return vec2<f32>(max(t.x, min(a, b)), min(t.y, max(a, b)));
}

struct March {
    acc: f32,
    stopped: bool,
}

// `integrate::integrate` of level l over t ∈ [ta, tb] of the ray o + t·d, added to acc;
// stops once acc + floor·(rest) ≥ goal.
fn integrate(l: u32, o: vec3<f32>, d: vec3<f32>, ta_in: f32, tb_in: f32, goal: f32, acc_in: f32) -> March {
    var out = March(acc_in, false);
    let lv = levels[l];
    if lv.cells.x >= lv.cells.y {
        return out;
    }
    let k = 1.0 / (p.cell * lv.scale);
    let u0 = (o.x / p.cell + p.shift) / lv.scale;
    let v0 = (o.y / p.cell + p.shift) / lv.scale;
    let du = d.x * k;
    let dv = d.y * k;
    var t2 = clip_axis(u0, du, f32(lv.cells.x), f32(lv.cells.y), vec2<f32>(ta_in, tb_in));
    t2 = clip_axis(v0, dv, f32(lv.cells.z), f32(lv.cells.w), t2);
    let ta = t2.x;
    let tb = t2.y;
    if !(tb > ta) {
        return out;
    }
    var ix = start_cell(u0 + ta * du, du);
    var iy = start_cell(v0 + ta * dv, dv);
    let sx = select(1, -1, du < 0.0);
    let sy = select(1, -1, dv < 0.0);
    var tx = next_crossing(ix, u0, du);
    var ty = next_crossing(iy, v0, dv);
    var t = ta;
    var budget = (lv.cells.y - lv.cells.x) + (lv.cells.w - lv.cells.z) + 8;
    let nmax = 2u * p.degree;
    var m = moments(0.0, nmax);
    loop {
        let t_exit = min(min(tx, ty), tb);
        let len = t_exit - t;
        if len > 0.0 {
            var sa = u0 + t * du - f32(ix);
            var sb = u0 + t_exit * du - f32(ix);
            var ra = v0 + t * dv - f32(iy);
            var rb = v0 + t_exit * dv - f32(iy);
            var h = 1.0;
            if p.falloff > 0.0 {
                let za = o.z + t * d.z;
                let zb = o.z + t_exit * d.z;
                if zb < za {
                    let s0 = sa;
                    sa = sb;
                    sb = s0;
                    let r0 = ra;
                    ra = rb;
                    rb = r0;
                }
                // A hair below the slab's bottom by rounding: h is at most 1 there.
                h = exp(-p.falloff * max(min(za, zb), 0.0));
                m = moments(p.falloff * abs(za - zb), nmax);
            }
            let r = cell_polynomial(lv, ix, iy, vec2<f32>(sa, sb), vec2<f32>(ra, rb));
            out.acc += len * h * (dot(r.lo, m.lo) + r.hi * m.hi);
            if out.acc + lv.floor * (tb - t_exit) >= goal {
                out.stopped = true;
                return out;
            }
        }
        budget -= 1;
        if t_exit >= tb || budget < 0 {
            break;
        }
        if tx <= ty {
            ix += sx;
            tx = next_crossing(ix, u0, du);
        } else {
            iy += sy;
            ty = next_crossing(iy, v0, dv);
        }
        t = max(t, t_exit);
    }
    return out;
}

// `Fog::fog_interval`: [ta, tb] ⊂ [0, len] inside the slab and the footprint; empty when
// tb ≤ ta.
fn fog_interval(o: vec3<f32>, d: vec3<f32>, len: f32) -> vec2<f32> {
    var t = vec2<f32>(0.0, len);
    t = clip_axis(o.z, d.z, 0.0, p.top, t);
    t = clip_axis(o.x, d.x, p.bounds.x, p.bounds.y, t);
    t = clip_axis(o.y, d.y, p.bounds.z, p.bounds.w, t);
    return t;
}

// `Fog::depth`: density·∫ f h along o + t·d, t ∈ [0, len], d unit.
fn depth(o: vec3<f32>, d: vec3<f32>, len: f32) -> f32 {
    return depth_span(o, d, len, 0.0, len);
}

// `Fog::depth_span`: density·∫ f h along o + t·d over t ∈ [t0, t1] ⊂ [0, len], with the µ
// bands of the whole ray (len = |OP|), so that spans split at any s add up to `depth`.
fn depth_span(o: vec3<f32>, d: vec3<f32>, len: f32, t0: f32, t1: f32) -> f32 {
    var iv = fog_interval(o, d, len);
    iv = vec2<f32>(max(iv.x, t0), min(iv.y, t1));
    if !(iv.y > iv.x) || p.density == 0.0 {
        return 0.0;
    }
    let big_l = p.levels;
    // d_max,l = len·µ^l, d_max,0 = len; the band of level l is [d_max,l+1, d_max,l]
    // (from 0 for the finest level), clipped to the fog.
    // At most 16 steps (`lod::MAX_LEVELS`): levels 0 … 16 and the bound after them.
    var dmax: array<f32, 18>;
    dmax[0] = len;
    for (var l = 1u; l <= big_l + 1u; l++) {
        dmax[l] = dmax[l - 1u] * p.mu;
    }
    var lo: array<f32, 17>;
    var hi: array<f32, 17>;
    var floors: array<f32, 17>;
    var later = 0.0;
    for (var l = 0u; l <= big_l; l++) {
        let a = select(dmax[l + 1u], 0.0, l == big_l);
        lo[l] = max(a, iv.x);
        hi[l] = min(dmax[l], iv.y);
        floors[l] = later;
        later += levels[l].floor * max(hi[l] - lo[l], 0.0);
    }
    var acc = 0.0;
    for (var i = 0u; i <= big_l; i++) {
        let l = big_l - i;
        if hi[l] <= lo[l] {
            continue;
        }
        let r = integrate(l, o, d, lo[l], hi[l], p.stop_depth - floors[l], acc);
        acc = r.acc;
        if r.stopped {
            break;
        }
    }
    return p.density * acc;
}

// `Fog::optical_depth_ray`: to where the ray leaves the fog.
fn depth_to_exit(o: vec3<f32>, d: vec3<f32>) -> f32 {
    let iv = fog_interval(o, d, 3.0e38);
    if iv.y > iv.x {
        return depth(o, d, iv.y);
    }
    return 0.0;
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= p.image.x || gid.y >= p.image.y {
        return;
    }
    // `Frame::ray`: through the pixel's centre, row 0 on top.
    let w = f32(p.image.x);
    let hgt = f32(p.image.y);
    let sx = ((f32(gid.x) + 0.5) / w * 2.0 - 1.0) * p.tan_half * p.aspect;
    let sy = (1.0 - (f32(gid.y) + 0.5) / hgt * 2.0) * p.tan_half;
    let dir = normalize(p.forward + sx * p.right + sy * p.up);
    let eye = p.eye;
    var surface: vec3<f32>;
    // |OP|: to the ground, or to where a sky ray leaves the fog (0 if it never enters).
    var len = 0.0;
    // The ground is at relative height ground_z; the eye is above it when eye.z > ground_z.
    if eye.z > p.ground_z && dir.z < 0.0 {
        let t = (p.ground_z - eye.z) / dir.z;
        let q = vec2<f32>(eye.x + t * dir.x, eye.y + t * dir.y) + p.origin;
        // (⌊x/c⌋ + ⌊y/c⌋) mod 2, the Euclidean remainder.
        let a = floor(q.x / p.checker) + floor(q.y / p.checker);
        let parity = a - 2.0 * floor(a / 2.0);
        surface = select(p.ground0, p.ground1, parity >= 1.0);
        len = t;
    } else {
        let e = sqrt(clamp(dir.z, 0.0, 1.0));
        surface = p.horizon + (p.zenith - p.horizon) * e;
        let iv = fog_interval(eye, dir, 3.0e38);
        len = select(0.0, iv.y, iv.y > iv.x);
    }
    let i = gid.x + p.image.x * gid.y;
    if p.layer == 0u {
        // e^{−88} ≈ 6e-39 is below f32's normal range: a larger depth (even one that
        // overflowed to infinity) gives the same τ ≈ 0.
        let tau = exp(-min(depth(eye, dir, len), 88.0));
        let c = tau * surface + (1.0 - tau) * p.fog;
        result[i] = vec4<f32>(c, tau);
        return;
    }
    // `render::shade_over`: the fog split at the smoke's depth s,
    // L = F[0, s] + T_f[0, s]·(L_s + T_s·F[s, P]).
    let ls = smoke[2u * i];
    let s = clamp(smoke[2u * i + 1u].x, 0.0, len);
    let front = exp(-min(depth_span(eye, dir, len, 0.0, s), 88.0));
    let back = exp(-min(depth_span(eye, dir, len, s, len), 88.0));
    let behind = (1.0 - back) * p.fog + back * surface;
    let c = (1.0 - front) * p.fog + front * (ls.xyz + ls.w * behind);
    result[i] = vec4<f32>(c, front * ls.w * back);
}

@compute @workgroup_size(64, 1, 1)
fn depths(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= p.image.x {
        return;
    }
    let q = queries[i];
    var od: f32;
    if q.len < 0.0 {
        od = depth_to_exit(q.o, q.d);
    } else {
        od = depth(q.o, q.d, q.len);
    }
    result[i] = vec4<f32>(od, 0.0, 0.0, 0.0);
}
