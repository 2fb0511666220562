// The scene renderer on the GPU: the twin of crates/scene's `render::render` with the
// `Analytic` model (paper C), one invocation per pixel (`paper_c_main`), in f32. See
// `src/gpu/mod.rs` for the buffers' layout and what differs from the CPU (offsets of shadow
// rays).
//
// A module, imported by the entry files of every scene renderer: `paper_c.wgsl` (paper C
// alone), `analytic.wgsl` (paper D's composite), `march.wgsl` (voxel media and analytic
// fogs), `paper_b.wgsl` (Gaussian media) and `raster.wgsl` (primary hits rasterized),
// which share its bindings, intersections, shadow rays, airlight tables, BRDF and
// environment. Defines:
// - GBUFFER: `paper_c_main` takes its primary hit from `gbuffer_hit` (raster.wgsl)
//   instead of tracing it;
// - PARAMS_IN_STORAGE: `P` is read from a storage buffer, not a uniform (Mesa's lavapipe
//   compiles a new shader variant per set of uniform values that steer branches).
//
// Coordinates are relative to the eye (the eye is the origin), so f32 keeps its
// precision wherever the scene is placed.

#import optics

const HALF_PI: f32 = 1.5707963267949;
// The G tables' largest optical distance (gtable::T_MAX).
const T_MAX: f32 = 50.0;

struct Params {
    forward: vec4<f32>,   // xyz; w: tan(fov/2)
    right: vec4<f32>,     // xyz; w: width/height
    up: vec4<f32>,        // xyz; w: γ_min
    sigma_t: vec4<f32>,   // xyz; w: r_min
    sigma_s: vec4<f32>,   // xyz; w: the environment's distance (when finite)
    albedo: vec4<f32>,    // xyz; w: shadow offset (relative)
    env_color: vec4<f32>, // xyz: a constant environment's radiance
    size: vec4<u32>,      // width, height, lights, surfaces
    flags: vec4<u32>,     // environment (0 black, 1 sky, 2 constant, 3 map), environment at ∞, K side, G nx
    tables: vec4<u32>,    // G ny, offset of the first G table, -, -
    env: vec4<u32>,       // map width, map height, SH order (0: no environment light), 1 if it glows
    env_at: vec4<u32>,    // offsets in `envdata`: L_in,lm, λ table, lobe factors, map texels
}

#ifdef PARAMS_IN_STORAGE
@group(0) @binding(0) var<storage, read> P: Params;
#else
@group(0) @binding(0) var<uniform> P: Params;
#endif
// Three vec4 per light: (kind 0 point / 1 sun, position or unit direction),
// (intensity or disk radiance, -), (sun irradiance, cos(angle/2) or 2 for no disk).
@group(0) @binding(1) var<storage, read> lights: array<vec4<f32>>;
// Four vec4 per surface: (kind 0 plane / 1 sphere / 2 mesh, point or center; a mesh: its
// first node and first triangle in `meshes`), (normal, radius), (diffuse, shininess),
// (specular, index of its G table or -1).
@group(0) @binding(2) var<storage, read> surfaces: array<vec4<f32>>;
// K (side² values), then the G tables (nx·ny values each; G0 first), x fastest.
@group(0) @binding(3) var<storage, read> tables: array<f32>;
@group(0) @binding(4) var<storage, read_write> image: array<vec4<f32>>;
// The meshes' hierarchies and triangles (mesh::Mesh), f32 bits: per node two records
// (box min, first) and (box max, count) — a leaf's triangles from `first`, an inner
// node's children at its own index + 1 and at `first` —, per triangle six records
// (p0, 1 if it has vertex normals), (p1, -), (p2, -), (n0, -), (n1, -), (n2, -).
@group(0) @binding(5) var<storage, read> meshes: array<vec4<u32>>;
// The environment's light (envglow::EnvGlow): L_lm (order² records, rgb), L_in,lm
// (order²), λ_l(t_j) (T_NODES·order, at j·order + l), the lobe factors in .x (order per
// row: Lambert's a_l, then p_l of each G table's Phong exponent), then a map's texels.
@group(0) @binding(6) var<storage, read> envdata: array<vec4<f32>>;

// envglow::T_NODES.
const T_NODES: u32 = 65u;
// envglow::GPU_MAX_ORDER.
const SH_MAX: u32 = 16u;

// table::Table2::at: bilinear on nodes i/(n−1), clamped to the unit square.
fn table_at(base: u32, nx: u32, ny: u32, x: f32, y: f32) -> f32 {
    let fx = clamp(x, 0.0, 1.0) * f32(nx - 1u);
    let fy = clamp(y, 0.0, 1.0) * f32(ny - 1u);
    let i = min(u32(floor(fx)), nx - 2u);
    let j = min(u32(floor(fy)), ny - 2u);
    let tx = fx - f32(i);
    let ty = fy - f32(j);
    let k = base + j * nx + i;
    let v00 = tables[k];
    let v10 = tables[k + 1u];
    let v01 = tables[k + nx];
    let v11 = tables[k + nx + 1u];
    let a = v00 + tx * (v10 - v00);
    let b = v01 + tx * (v11 - v01);
    return a + ty * (b - a);
}

// htable::HTable::k on x = √(ρ/(1 + ρ)), y = 1 − δ/(π/2).
fn k_table(rho: f32, delta: f32) -> f32 {
    let n = P.flags.z;
    return table_at(0u, n, n, sqrt(rho / (1.0 + rho)), 1.0 - delta / HALF_PI);
}

// gtable::GTable::g for the table at `index` (0: G0).
fn g_table(index: u32, t: f32, theta: f32) -> f32 {
    if (t > T_MAX) {
        return 0.0;
    }
    let nx = P.flags.w;
    let ny = P.tables.x;
    let xmax = T_MAX / (1.0 + T_MAX);
    let q = table_at(P.tables.y + index * nx * ny, nx, ny, t / (1.0 + t) / xmax, theta / PI);
    return exp(-t) * q / (1.0 + t);
}

// e^x − 1 without cancellation for small |x| (WGSL has no expm1): the Taylor series to
// x⁶ below 0.1 (truncation < x⁷/5040 < 2e-11 relative), exp(x) − 1 above (rounding
// < 1e-6 relative there).
fn expm1(x: f32) -> f32 {
    if (abs(x) < 0.1) {
        return x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0 + x / 720.0)))));
    }
    return exp(x) - 1.0;
}

// airlight::attenuated_length for a finite t.
fn attenuated_length(beta: f32, t: f32) -> f32 {
    if (beta <= 0.0) {
        return t;
    }
    return -expm1(-beta * t) / beta;
}

// A unit vector perpendicular to the unit vector a (vec3::perpendicular).
fn perpendicular(a: vec3<f32>) -> vec3<f32> {
    var helper = vec3<f32>(0.0, 1.0, 0.0);
    if (abs(a.x) < 0.9) {
        helper = vec3<f32>(1.0, 0.0, 0.0);
    }
    return normalize(cross(a, helper));
}

// airlight::atan2_over: atan2(h, y)/h for h > 0 or y > 0, its series 1/y·(1 − q²/3 + q⁴/5)
// for q = h/y below 1e-3 (truncation < q⁶/7).
fn atan2_over(h: f32, y: f32) -> f32 {
    if (y > 0.0 && h < 1e-3 * y) {
        let q2 = (h / y) * (h / y);
        return (1.0 - q2 / 3.0 + q2 * q2 / 5.0) / y;
    }
    return atan2(h, y) / h;
}

// airlight::effective_light, the eye at the origin.
fn effective_light(dir: vec3<f32>, light: vec3<f32>) -> vec3<f32> {
    var v = light;
    let r_min = P.sigma_t.w;
    let d0 = length(v);
    if (d0 < r_min) {
        var u = perpendicular(dir);
        if (d0 > 0.0) {
            u = v / d0;
        }
        v = u * r_min;
    }
    let d = length(v);
    let u = v / d;
    let gamma_min = P.up.w;
    if (dot(u, dir) > 0.0 && length(cross(u, dir)) < sin(gamma_min)) {
        // The part of v across the ray, projected twice (as on the CPU): with the light
        // on the ray the first projection leaves rounding noise, not across the ray.
        var side = perpendicular(dir);
        let w = v - dot(v, dir) * dir;
        if (length(w) > 0.0) {
            let w1 = normalize(w);
            let w2 = w1 - dot(w1, dir) * dir;
            if (length(w2) > 0.0) {
                side = normalize(w2);
            }
        }
        v = (dir * cos(gamma_min) + side * sin(gamma_min)) * d;
    }
    return v;
}

// One end's term of the stable airlight (airlight::point): light at distance r from the
// end, y the end's signed distance along the ray from the foot of the light's
// perpendicular, h the light's distance from the ray's line, t_opt light → end → eye.
fn airlight_term(h: f32, y: f32, r: f32, t_opt: f32, beta: f32) -> f32 {
    let attenuation = exp(-t_opt);
    if (attenuation == 0.0) {
        return 0.0;
    }
    var r_plus_y = r + y;
    if (y < 0.0) {
        r_plus_y = h * h / (r - y);
    }
    let rho = beta * sqrt(2.0 * r * r_plus_y);
    let delta = 0.5 * atan2(h, y);
    return attenuation * atan2_over(h, y) * k_table(rho, delta) / (1.0 + rho);
}

// airlight::point per unit intensity, the eye at the origin; `far` false for a ray to ∞.
fn airlight(dir: vec3<f32>, t_end: f32, far: bool, light: vec3<f32>, beta: f32, ss: f32) -> f32 {
    if (ss <= 0.0 || t_end <= 0.0) {
        return 0.0;
    }
    let d_sv = length(light);
    let u = light / d_sv;
    let cos_g = dot(u, dir);
    let h = d_sv * length(cross(u, dir));
    let near = airlight_term(h, -d_sv * cos_g, d_sv, beta * d_sv, beta);
    var end = 0.0;
    if (far) {
        let d_sp = length(light - t_end * dir);
        end = airlight_term(h, t_end - d_sv * cos_g, d_sp, beta * (d_sp + t_end), beta);
    }
    return max(ss / (4.0 * PI) * (near - end), 0.0);
}

struct Hit {
    t: f32,
    surface: i32,
    // On a mesh: the triangle (from the mesh's first) and the barycentric u, v.
    tri: u32,
    u: f32,
    v: f32,
}

// Where a ray meets one surface: t (-1 for none), and on a mesh the triangle and u, v.
struct Found {
    t: f32,
    tri: u32,
    u: f32,
    v: f32,
}

fn f3(x: vec4<u32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(x.xyz);
}

// mesh::Aabb::hit: whether o + t·d meets the box for some t in [t_min, t_max]; along
// an axis where d is zero, whether o lies in the slab.
fn box_hit(lo: vec3<f32>, hi: vec3<f32>, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, t_min: f32, t_max: f32) -> bool {
    var a = t_min;
    var b = t_max;
    for (var k = 0; k < 3; k++) {
        if (d[k] == 0.0) {
            if (o[k] < lo[k] || o[k] > hi[k]) {
                return false;
            }
        } else {
            let t0 = (lo[k] - o[k]) * inv[k];
            let t1 = (hi[k] - o[k]) * inv[k];
            a = max(a, min(t0, t1));
            b = min(b, max(t0, t1) * (1.0 + 4.8e-7));
        }
    }
    return a <= b;
}

// mesh::Triangle::intersect (Möller–Trumbore) of triangle record `r`: (t, u, v), t = -1
// for none.
fn triangle_hit(r: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> vec3<f32> {
    let p0 = f3(meshes[r]);
    let e1 = f3(meshes[r + 1u]) - p0;
    let e2 = f3(meshes[r + 2u]) - p0;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if (det == 0.0) {
        return vec3<f32>(-1.0);
    }
    let inv = 1.0 / det;
    let s = o - p0;
    let u = dot(s, pv) * inv;
    if (u < 0.0 || u > 1.0) {
        return vec3<f32>(-1.0);
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) {
        return vec3<f32>(-1.0);
    }
    let t = dot(e2, q) * inv;
    if (t > t_min && t < t_max) {
        return vec3<f32>(t, u, v);
    }
    return vec3<f32>(-1.0);
}

// mesh::Mesh::intersect: the nearest triangle through the hierarchy from node record
// `nodes`, triangles from record `tris`.
fn mesh_hit(nodes: u32, tris: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Found {
    let inv = select(vec3<f32>(0.0), 1.0 / d, d != vec3<f32>(0.0));
    var best = Found(-1.0, 0u, 0.0, 0.0);
    var hi = t_max;
    var stack: array<u32, 64>;
    var top = 1u;
    stack[0] = 0u;
    while (top > 0u) {
        top -= 1u;
        let index = stack[top];
        let a = meshes[nodes + 2u * index];
        let b = meshes[nodes + 2u * index + 1u];
        if (!box_hit(f3(a), f3(b), o, d, inv, t_min, hi)) {
            continue;
        }
        if (b.w > 0u) {
            for (var i = a.w; i < a.w + b.w; i++) {
                let h = triangle_hit(tris + 6u * i, o, d, t_min, hi);
                if (h.x >= 0.0) {
                    best = Found(h.x, i, h.y, h.z);
                    hi = h.x;
                }
            }
        } else {
            stack[top] = a.w;
            stack[top + 1u] = index + 1u;
            top += 2u;
        }
    }
    return best;
}

// scene::Shape::intersect of surface i: the nearest t in (t_min, t_max) (-1 for none).
fn intersect_one(i: u32, o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Found {
    let none = Found(-1.0, 0u, 0.0, 0.0);
    let a = surfaces[4u * i];
    let b = surfaces[4u * i + 1u];
    if (a.x == 0.0) {
        let den = dot(d, b.xyz);
        if (den == 0.0) {
            return none;
        }
        let t = dot(a.yzw - o, b.xyz) / den;
        if (t > t_min && t < t_max) {
            return Found(t, 0u, 0.0, 0.0);
        }
        return none;
    }
    if (a.x == 2.0) {
        return mesh_hit(u32(a.y), u32(a.z), o, d, t_min, t_max);
    }
    let oc = a.yzw - o;
    let bb = dot(d, oc);
    let perp = oc - bb * d;
    let disc = b.w * b.w - dot(perp, perp);
    if (disc < 0.0) {
        return none;
    }
    let s = sqrt(disc);
    if (bb - s > t_min && bb - s < t_max) {
        return Found(bb - s, 0u, 0.0, 0.0);
    }
    if (bb + s > t_min && bb + s < t_max) {
        return Found(bb + s, 0u, 0.0, 0.0);
    }
    return none;
}

// scene::Scene::intersect.
fn intersect(o: vec3<f32>, d: vec3<f32>, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(t_max, -1, 0u, 0.0, 0.0);
    for (var i = 0u; i < P.size.w; i++) {
        let f = intersect_one(i, o, d, t_min, best.t);
        if (f.t >= 0.0) {
            best = Hit(f.t, i32(i), f.tri, f.u, f.v);
        }
    }
    return best;
}

// The normal of surface `hit.surface` at its point p on a ray of direction d: a plane's
// own, a sphere's radial one, a mesh's interpolated one; turned towards the ray.
fn hit_normal(hit: Hit, p: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let s = u32(hit.surface);
    let a = surfaces[4u * s];
    var n = surfaces[4u * s + 1u].xyz;
    if (a.x == 1.0) {
        n = normalize(p - a.yzw);
    } else if (a.x == 2.0) {
        n = mesh_normal(u32(a.z), hit.tri, hit.u, hit.v, d);
    }
    if (dot(n, d) > 0.0) {
        n = -n;
    }
    return n;
}

// The normal where a ray of direction d meets triangle `tri` of the mesh whose triangles
// start at record `tris`, at barycentric (u, v): the vertex normals interpolated (or the
// face normal), on the side of the face the ray arrives at (scene::Shape::intersect).
fn mesh_normal(tris: u32, tri: u32, u: f32, v: f32, d: vec3<f32>) -> vec3<f32> {
    let r = tris + 6u * tri;
    let p0 = f3(meshes[r]);
    let c = cross(f3(meshes[r + 1u]) - p0, f3(meshes[r + 2u]) - p0);
    var face = vec3<f32>(0.0, 0.0, 1.0);
    if (dot(c, c) > 0.0) {
        face = normalize(c);
    }
    var n = face;
    if (meshes[r].w != 0u) {
        let m = (1.0 - u - v) * f3(meshes[r + 3u]) + u * f3(meshes[r + 4u]) + v * f3(meshes[r + 5u]);
        if (dot(m, m) > 0.0) {
            n = normalize(m);
        }
    }
    if (dot(face, d) * dot(n, d) < 0.0) {
        n = -n;
    }
    return n;
}

// Whether the segment p → q is free of surfaces (scene::Scene::visible), its ends
// excluded by `eps` relative.
fn visible(p: vec3<f32>, q: vec3<f32>, eps_rel: f32) -> bool {
    let v = q - p;
    let len = length(v);
    if (len <= 0.0) {
        return true;
    }
    let dir = v / len;
    let eps = eps_rel * (1.0 + len);
    for (var i = 0u; i < P.size.w; i++) {
        if (intersect_one(i, p, dir, eps, len - eps).t >= 0.0) {
            return false;
        }
    }
    return true;
}

// The angle between two unit vectors by atan2 (render::angle).
fn angle(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return atan2(length(cross(a, b)), dot(a, b));
}

// Lambert + normalized Phong times cos θᵢ (render::surface's brdf), per channel.
fn brdf(n: vec3<f32>, r: vec3<f32>, l: vec3<f32>, diffuse: vec3<f32>, specular: vec3<f32>, m: f32) -> vec3<f32> {
    let c = dot(n, l);
    if (c <= 0.0) {
        return vec3<f32>(0.0);
    }
    var f = diffuse / PI * c;
    // max(0, r·l)^m, with 0⁰ = 1 as the CPU's powf.
    let rl = dot(r, l);
    var lobe = 1.0;
    if (m > 0.0) {
        lobe = 0.0;
        if (rl > 0.0) {
            lobe = pow(rl, m);
        }
    }
    return f + specular * (m + 2.0) / (2.0 * PI) * lobe;
}

// haze_view::LatLong::radiance: bilinear between texel centres, wrapping in azimuth,
// clamped at the poles.
fn env_map(d: vec3<f32>) -> vec3<f32> {
    let w = P.env.x;
    let h = P.env.y;
    let len = length(d);
    let theta = acos(clamp(d.z / len, -1.0, 1.0));
    var phi = atan2(d.y, d.x);
    if (phi < 0.0) {
        phi += 2.0 * PI;
    }
    let fx = phi / (2.0 * PI) * f32(w) - 0.5;
    let fy = clamp(theta / PI * f32(h) - 0.5, 0.0, f32(h - 1u));
    let x0 = floor(fx);
    let y0 = floor(fy);
    let tx = fx - x0;
    let ty = fy - y0;
    let xa = u32(x0 - floor(x0 / f32(w)) * f32(w)) % w;
    let xb = (xa + 1u) % w;
    let ya = min(u32(y0), h - 1u);
    let yb = min(ya + 1u, h - 1u);
    let base = P.env_at.w;
    return envdata[base + ya * w + xa].xyz * ((1.0 - tx) * (1.0 - ty))
        + envdata[base + ya * w + xb].xyz * (tx * (1.0 - ty))
        + envdata[base + yb * w + xa].xyz * ((1.0 - tx) * ty)
        + envdata[base + yb * w + xb].xyz * (tx * ty);
}

// Σ_lm f_l·c_lm·Y_lm(d), the coefficients c from `envdata[base]` (sh::basis::eval_into:
// the real orthonormal SH without the Condon–Shortley phase, by the normalized
// recurrences in z = cos θ and (x + iy)^m for the azimuth).
fn sh_sum(d: vec3<f32>, base: u32, f_in: array<vec3<f32>, SH_MAX>) -> vec3<f32> {
    var f = f_in;
    let order = P.env.z;
    let u = normalize(d);
    let z = clamp(u.z, -1.0, 1.0);
    var cm = 1.0;
    var sm = 0.0;
    var qmm = 0.28209479177387814;
    var out = vec3<f32>(0.0);
    for (var m = 0u; m < order; m++) {
        var ca = 1.0;
        var sa = 0.0;
        if (m > 0u) {
            let mf = f32(m);
            qmm *= sqrt((2.0 * mf + 1.0) / (2.0 * mf));
            let c2 = cm * u.x - sm * u.y;
            sm = cm * u.y + sm * u.x;
            cm = c2;
            ca = 1.4142135623730951 * cm;
            sa = 1.4142135623730951 * sm;
        }
        let mf = f32(m);
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
            let i = l * (l + 1u);
            var c = envdata[base + i + m].xyz * ca;
            if (m > 0u) {
                c += envdata[base + i - m].xyz * sa;
            }
            out += f[l] * q * c;
        }
    }
    return out;
}

// EnvGlow::view: the environment's airlight along x·dir, x ∈ [0, t].
fn env_view(dir: vec3<f32>, t: f32) -> vec3<f32> {
    var f: array<vec3<f32>, SH_MAX>;
    let order = P.env.z;
    let s = clamp(t / P.sigma_s.w, 0.0, 1.0) * f32(T_NODES - 1u);
    let j = min(u32(floor(s)), T_NODES - 2u);
    let a = s - f32(j);
    for (var l = 0u; l < order; l++) {
        f[l] = (1.0 - a) * envdata[P.env_at.y + j * order + l].xyz
            + a * envdata[P.env_at.y + (j + 1u) * order + l].xyz;
    }
    return sh_sum(dir, 0u, f);
}

// EnvGlow::filtered: Σ f_l·L_in,lm·Y_lm(axis), f from lobe row `row`.
fn env_lobe(axis: vec3<f32>, row: u32) -> vec3<f32> {
    var f: array<vec3<f32>, SH_MAX>;
    let order = P.env.z;
    for (var l = 0u; l < order; l++) {
        f[l] = vec3<f32>(envdata[P.env_at.z + row * order + l].x);
    }
    return sh_sum(axis, P.env_at.x, f);
}

// Scene::environment radiance (scene::Environment::radiance).
fn environment(d: vec3<f32>) -> vec3<f32> {
    let kind = P.flags.x;
    if (kind == 0u) {
        return vec3<f32>(0.0);
    }
    if (kind == 2u) {
        return P.env_color.xyz;
    }
    if (kind == 3u) {
        return env_map(d);
    }
    // Below the horizon the ground, which the glow does not reach (`Environment::radiance`).
    if (d.z < 0.0) {
        return vec3<f32>(0.25, 0.22, 0.2);
    }
    let out = vec3<f32>(0.8, 0.85, 0.9) * (1.0 - d.z) + vec3<f32>(0.25, 0.45, 0.9) * d.z;
    let n = sqrt(0.25 + 0.09 + 0.64);
    let c = max(dot(d, vec3<f32>(0.5, 0.3, 0.8) / n), 0.0);
    let c2 = c * c;
    let c4 = c2 * c2;
    return out + vec3<f32>(4.0, 3.6, 3.0) * (c4 * c4);
}

// The environment and the suns' disks (render::background).
fn background(d: vec3<f32>) -> vec3<f32> {
    var l = environment(d);
    for (var i = 0u; i < P.size.z; i++) {
        let a = lights[3u * i];
        let c = lights[3u * i + 2u];
        if (a.x == 1.0 && c.w <= 1.0 && dot(d, a.yzw) >= c.w) {
            l += lights[3u * i + 1u].xyz;
        }
    }
    return l;
}

// Light leaving the surface hit at p (normal n towards the viewer) towards the eye
// (render::surface with the Analytic model).
fn shade_surface(dir: vec3<f32>, p: vec3<f32>, n: vec3<f32>, s: u32) -> vec3<f32> {
    let diffuse = surfaces[4u * s + 2u].xyz;
    let m = surfaces[4u * s + 2u].w;
    let specular = surfaces[4u * s + 3u].xyz;
    let gn = surfaces[4u * s + 3u].w;
    let r = 2.0 * dot(-dir, n) * n + dir;
    let eps = P.albedo.w;
    let p_off = p + eps * (1.0 + length(p)) * n;
    let beta = P.sigma_t.xyz;
    let ss = P.sigma_s.xyz;
    var out = vec3<f32>(0.0);
    // The environment's light, direct and scattered (EnvGlow::surface).
    if (P.env.z > 0u) {
        out += diffuse / PI * env_lobe(n, 0u);
        if (gn >= 0.0 && any(specular > vec3<f32>(0.0))) {
            out += specular * (m + 2.0) / (2.0 * PI) * env_lobe(r, u32(gn));
        }
    }
    for (var i = 0u; i < P.size.z; i++) {
        let a = lights[3u * i];
        let e = lights[3u * i + 1u].xyz;
        if (a.x == 0.0) {
            // light_off_point
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
            if (dot(n, l) > 0.0 && visible(p_off, light, eps)) {
                f = brdf(n, r, l, diffuse, specular, m);
            }
            let theta_s = angle(n, l);
            let theta_r = angle(r, l);
            // G0 and Gn at T = β·d; channels of equal β share them.
            var g0 = 0.0;
            var gm = 0.0;
            var g_beta = -1.0;
            for (var c = 0u; c < 3u; c++) {
                if (e[c] <= 0.0) {
                    continue;
                }
                var v_c = 0.0;
                if (f[c] != 0.0) {
                    var att = 1.0;
                    if (beta[c] > 0.0) {
                        att = exp(-beta[c] * d);
                    }
                    v_c = att / (d * d) * f[c];
                }
                if (ss[c] > 0.0 && (diffuse[c] > 0.0 || specular[c] > 0.0)) {
                    if (beta[c] != g_beta) {
                        let t = beta[c] * d;
                        g0 = g_table(0u, t, theta_s);
                        gm = 0.0;
                        if (gn >= 0.0) {
                            gm = g_table(u32(gn), t, theta_r);
                        }
                        g_beta = beta[c];
                    }
                    var g = diffuse[c] / PI * g0;
                    if (gn >= 0.0 && specular[c] > 0.0) {
                        g += specular[c] * (m + 2.0) / (2.0 * PI) * gm;
                    }
                    v_c += ss[c] / (2.0 * PI * d) * g;
                }
                out[c] += e[c] * v_c;
            }
        } else {
            let irradiance = lights[3u * i + 2u].xyz;
            let sd = a.yzw;
            if (dot(n, sd) > 0.0 && intersect(p_off, sd, 0.0, 3.0e38).surface < 0) {
                out += irradiance * brdf(n, r, sd, diffuse, specular, m);
            }
            let lobes = diffuse + specular * (m + 2.0) / (m + 1.0);
            for (var c = 0u; c < 3u; c++) {
                if (ss[c] > 0.0) {
                    out[c] += P.albedo[c] * irradiance[c] / (4.0 * PI) * lobes[c];
                }
            }
        }
    }
    return out;
}

// Camera::ray through the point `c` of the image (in pixels, y down; a pixel's center
// is its index + 0.5): a unit direction from the eye.
fn pixel_dir(c: vec2<f32>) -> vec3<f32> {
    let tan_half = P.forward.w;
    let sx = (2.0 * c.x / f32(P.size.x) - 1.0) * tan_half * P.right.w;
    let sy = (1.0 - 2.0 * c.y / f32(P.size.y)) * tan_half;
    return normalize(P.forward.xyz + sx * P.right.xyz + sy * P.up.xyz);
}

// How far primary rays look for surfaces: the environment's distance when it is finite,
// else "∞".
fn primary_t_max() -> f32 {
    if (P.flags.y == 0u) {
        return P.sigma_s.w;
    }
    return 3.0e38;
}

// Paper C's pixel `id`: the airlight of every light along the primary ray, the
// environment's, and the surface hit (or the background) attenuated to the eye.
fn paper_c_main(id: vec3<u32>) {
    let w = P.size.x;
    let h = P.size.y;
    if (id.x >= w || id.y >= h) {
        return;
    }
    let dir = pixel_dir(vec2<f32>(id.xy) + 0.5);

    let env_far = P.flags.y == 0u;
    let t_max = primary_t_max();
#ifdef GBUFFER
    let hit = gbuffer_hit(id, dir, t_max);
#else
    let hit = intersect(vec3<f32>(0.0), dir, 0.0, t_max);
#endif
    let finite_end = hit.surface >= 0 || env_far;
    let t_end = hit.t;
    let beta = P.sigma_t.xyz;
    let ss = P.sigma_s.xyz;
    var out = vec3<f32>(0.0);
    for (var i = 0u; i < P.size.z; i++) {
        let a = lights[3u * i];
        let e = lights[3u * i + 1u].xyz;
        if (a.x == 0.0) {
            let s = effective_light(dir, a.yzw);
            var la = 0.0;
            for (var c = 0u; c < 3u; c++) {
                if (ss[c] <= 0.0 || e[c] <= 0.0) {
                    continue;
                }
                // Channels of equal (β, σs) share one evaluation.
                if (c == 0u || beta[c] != beta[c - 1u] || ss[c] != ss[c - 1u] || e[c - 1u] <= 0.0) {
                    la = airlight(dir, t_end, finite_end, s, beta[c], ss[c]);
                }
                out[c] += e[c] * la;
            }
        } else {
            let irradiance = lights[3u * i + 2u].xyz;
            for (var c = 0u; c < 3u; c++) {
                if (ss[c] <= 0.0 || irradiance[c] <= 0.0) {
                    continue;
                }
                var len = 0.0;
                if (finite_end) {
                    len = attenuated_length(beta[c], t_end);
                } else {
                    len = 1.0 / beta[c];
                }
                out[c] += ss[c] * irradiance[c] / (4.0 * PI) * len;
            }
        }
    }
    // The environment's airlight (EnvGlow::view).
    if (P.env.w != 0u) {
        out += env_view(dir, t_end);
    }
    var behind = vec3<f32>(0.0);
    if (hit.surface >= 0) {
        let s = u32(hit.surface);
        let p = t_end * dir;
        let n = hit_normal(hit, p, dir);
        behind = shade_surface(dir, p, n, s);
    } else if (finite_end || any(beta <= vec3<f32>(0.0))) {
        behind = background(dir);
    }
    for (var c = 0u; c < 3u; c++) {
        if (behind[c] != 0.0) {
            if (!finite_end) {
                // Only a clear channel (β = 0) sees an environment at ∞.
                if (beta[c] <= 0.0) {
                    out[c] += behind[c];
                }
            } else if (beta[c] <= 0.0) {
                out[c] += behind[c];
            } else {
                out[c] += exp(-beta[c] * t_end) * behind[c];
            }
        }
    }
    image[id.y * w + id.x] = vec4<f32>(out, 1.0);
}
