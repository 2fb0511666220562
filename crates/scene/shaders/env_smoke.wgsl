// The environment's light on the voxel media: crates/scene's `env_smoke::EnvGrid`, the
// transmitted environment's SH coefficients E_lm on a grid of nodes, trilinear between
// them, scattered towards −dir as Σ_media σs(x)·Σ_l g^l·Σ_m E_lm(x)·Y_lm(dir). A module
// of march.wgsl, whose `grid` and `media` bindings and grid helpers it reads; see
// `src/gpu/march.rs`.

// The environment's grid lies in march.wgsl's `grid` after the voxel grids, from the
// index in the record after the media's: (first node relative to the eye, nodes per
// axis; < 2: no environment light), (node spacing, SH order); then E_lm per node (x
// fastest), coefficient, channel.
fn env_at(i: u32) -> f32 {
    return grid[u32(media[1u + 5u * u32(media[0].x)].x) + i];
}

// env_smoke::MAX_ORDER² coefficients.
const ENV_SH_MAX: u32 = 64u;

// haze_view::sh::eval_into: the real orthonormal SH without the Condon–Shortley phase.
fn env_sh(d: vec3<f32>, order: u32) -> array<f32, ENV_SH_MAX> {
    var out: array<f32, ENV_SH_MAX>;
    let u = normalize(d);
    let z = clamp(u.z, -1.0, 1.0);
    var cm = 1.0;
    var sm = 0.0;
    var qmm = 0.28209479177387814;
    for (var m = 0u; m < order; m++) {
        var ca = 1.0;
        var sa = 0.0;
        let mf = f32(m);
        if (m > 0u) {
            qmm *= sqrt((2.0 * mf + 1.0) / (2.0 * mf));
            let c2 = cm * u.x - sm * u.y;
            sm = cm * u.y + sm * u.x;
            cm = c2;
            ca = 1.4142135623730951 * cm;
            sa = 1.4142135623730951 * sm;
        }
        var q_prev = 0.0;
        var q = qmm;
        for (var l = m; l < order; l++) {
            if (l == m + 1u) {
                q_prev = q;
                q = sqrt(2.0 * mf + 3.0) * z * qmm;
            } else if (l > m + 1u) {
                let lf = f32(l);
                let a = sqrt((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf));
                let b = sqrt(((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0));
                let next = a * (z * q - b * q_prev);
                q_prev = q;
                q = next;
            }
            let base = l * (l + 1u);
            out[base + m] = q * ca;
            if (m > 0u) {
                out[base - m] = q * sa;
            }
        }
    }
    return out;
}

// Coefficient j's three channels at node `node` (k coefficients per node).
fn env_e(node: u32, k: u32, j: u32) -> vec3<f32> {
    let i = 8u + 3u * (node * k + j);
    return vec3<f32>(env_at(i), env_at(i + 1u), env_at(i + 2u));
}

// env_smoke::EnvGrid::in_scattered.
fn env_in_scattered(x: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let n = u32(env_at(3));
    if (n < 2u) {
        return vec3<f32>(0.0);
    }
    let order = u32(env_at(7));
    // h_l = Σ_media σs(x)·g^l per band.
    var h: array<vec3<f32>, 8>;
    var any_s = false;
    for (var m = 0u; m < u32(media[0].x); m++) {
        let b = grid_base(m);
        let s = media[b + 3u].xyz * grid_density(m, x) * media[b + 4u].xyz;
        if (any(s > vec3<f32>(0.0))) {
            any_s = true;
            var gl = 1.0;
            for (var l = 0u; l < order; l++) {
                h[l] += s * gl;
                gl *= media[b].w;
            }
        }
    }
    if (!any_s) {
        return vec3<f32>(0.0);
    }
    let y = env_sh(dir, order);
    let lo = vec3<f32>(env_at(0), env_at(1), env_at(2));
    let cell = vec3<f32>(env_at(4), env_at(5), env_at(6));
    let nf = f32(n - 1u);
    let u = select(vec3<f32>(0.0), clamp((x - lo) / select(cell, vec3<f32>(1.0), cell <= vec3<f32>(0.0)), vec3<f32>(0.0), vec3<f32>(nf)), cell > vec3<f32>(0.0));
    let i0 = min(vec3<u32>(floor(u)), vec3<u32>(n - 2u));
    let f = u - vec3<f32>(i0);
    let g = 1.0 - f;
    let n000 = i0.x + n * (i0.y + n * i0.z);
    let dy = n;
    let dz = n * n;
    let k = order * order;
    var out = vec3<f32>(0.0);
    for (var j = 0u; j < k; j++) {
        let l = u32(floor(sqrt(f32(j) + 0.5)));
        let e = g.z * (g.y * (g.x * env_e(n000, k, j) + f.x * env_e(n000 + 1u, k, j))
                     + f.y * (g.x * env_e(n000 + dy, k, j) + f.x * env_e(n000 + dy + 1u, k, j)))
              + f.z * (g.y * (g.x * env_e(n000 + dz, k, j) + f.x * env_e(n000 + dz + 1u, k, j))
                     + f.y * (g.x * env_e(n000 + dz + dy, k, j) + f.x * env_e(n000 + dz + dy + 1u, k, j)));
        out += h[l] * e * y[j];
    }
    return out;
}
