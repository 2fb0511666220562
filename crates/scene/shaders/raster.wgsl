// The rasterized scene renderer (see `src/gpu/raster.rs`): render.wgsl's `paper_c_main`,
// composed with GBUFFER and PARAMS_IN_STORAGE defined, takes each pixel's primary hit from
// the G-buffer this file's raster pass writes instead of ray-tracing it; the airlight to
// that depth, the shading and the shadow rays are render.wgsl's own.
//
// The raster pass draws every surface as triangles into a reversed depth buffer: meshes'
// own triangles, each sphere as its bounding cube and each plane as one triangle covering
// the screen. Every fragment intersects the pixel's ray with its primitive — the
// triangle's plane (no edge test: the rasterizer's coverage already decided that the ray
// meets the triangle), or the sphere or plane exactly as render.wgsl's `intersect_one`
// does —, discards a miss and writes the exact depth, so the depth test keeps the nearest
// surface along the same ray the ray tracer follows. Positions are relative to the eye.

#import render

// The shading pass: one invocation per pixel.
@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    paper_c_main(id);
}

// The G-buffer: per pixel (bits of the hit's t, surface + 1 or 0 for none, triangle, 0).
@group(0) @binding(7) var gbuffer: texture_2d<u32>;

// Nearest depth along the view axis the raster pass keeps (scene units; the depth buffer
// holds RASTER_NEAR / z, 1 there, → 0 far away).
const RASTER_NEAR: f32 = 1e-4;

// Where o + t·d meets the plane of triangle record `r`: (t, u, v) as in `triangle_hit`
// (Möller–Trumbore, the same operations) without its range tests; t = -1 when the ray is
// parallel to the plane.
fn triangle_plane(r: u32, o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
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
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    return vec3<f32>(dot(e2, q) * inv, u, v);
}

// The primary hit of pixel `id` from the G-buffer; a mesh's barycentrics recomputed on
// the triangle found there.
fn gbuffer_hit(id: vec3<u32>, dir: vec3<f32>, t_max: f32) -> Hit {
    let g = textureLoad(gbuffer, vec2<i32>(id.xy), 0);
    if (g.y == 0u) {
        return Hit(t_max, -1, 0u, 0.0, 0.0);
    }
    let s = g.y - 1u;
    let a = surfaces[4u * s];
    var uv = vec2<f32>(0.0);
    if (a.x == 2.0) {
        uv = triangle_plane(u32(a.z) + 6u * g.z, vec3<f32>(0.0), dir).yz;
    }
    return Hit(bitcast<f32>(g.x), i32(s), g.z, uv.x, uv.y);
}

struct RasterVertex {
    @builtin(position) clip: vec4<f32>,
    // (surface, triangle)
    @location(0) @interpolate(flat) id: vec2<u32>,
}

// p.w = 1: a position relative to the eye, projected by the camera (clip z = RASTER_NEAR,
// w = depth along the view axis: depth RASTER_NEAR / z, nearer than RASTER_NEAR clipped);
// p.w = 0: p.xy already in normalized device coordinates (a plane's screen triangle).
@vertex
fn vs_main(@location(0) p: vec4<f32>, @location(1) id: vec2<u32>) -> RasterVertex {
    if (p.w == 0.0) {
        return RasterVertex(vec4<f32>(p.xy, 0.5, 1.0), id);
    }
    let tan_half = P.forward.w;
    let z = dot(p.xyz, P.forward.xyz);
    let x = dot(p.xyz, P.right.xyz) / (tan_half * P.right.w);
    let y = dot(p.xyz, P.up.xyz) / tan_half;
    return RasterVertex(vec4<f32>(x, y, RASTER_NEAR, z), id);
}

struct GOut {
    @location(0) g: vec4<u32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_main(v: RasterVertex) -> GOut {
    let dir = pixel_dir(v.clip.xy);
    let s = v.id.x;
    let t_max = primary_t_max();
    var t = -1.0;
    if (surfaces[4u * s].x == 2.0) {
        t = triangle_plane(u32(surfaces[4u * s].z) + 6u * v.id.y, vec3<f32>(0.0), dir).x;
    } else {
        t = intersect_one(s, vec3<f32>(0.0), dir, 0.0, t_max).t;
    }
    let z = t * dot(dir, P.forward.xyz);
    if (!(t > 0.0 && t < t_max && z >= RASTER_NEAR)) {
        discard;
    }
    return GOut(vec4<u32>(bitcast<u32>(t), s + 1u, v.id.y, 0u), RASTER_NEAR / z);
}
