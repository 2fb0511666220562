// The bilinear stencil of `LatLong::radiance` (a module, `#import lat_long`; it imports
// `optics` for PI): column u → φ = 2πu from +X towards +Y, row v → θ = πv from +Z,
// bilinear between texel centers, wrapping in φ and clamped at the poles. The importer
// fetches the four texels and blends them with `lat_long_blend`.
#import optics

struct LatLongStencil {
    xa: u32,
    xb: u32,
    ya: u32,
    yb: u32,
    tx: f32,
    ty: f32,
}

fn lat_long_column(x: f32, w: f32, width: u32) -> u32 {
    return min(u32(x - w * floor(x / w)), width - 1u);
}

// The stencil of direction d on a size.x × size.y map.
fn lat_long_stencil(d: vec3<f32>, size: vec2<u32>) -> LatLongStencil {
    // θ by atan2 rather than acos: well conditioned at the poles too.
    let theta = atan2(length(d.xy), d.z);
    var phi = atan2(d.y, d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let w = f32(size.x);
    let h = f32(size.y);
    let fx = phi / (2.0 * PI) * w - 0.5;
    let fy = clamp(theta / PI * h - 0.5, 0.0, h - 1.0);
    let x0 = floor(fx);
    let y0 = floor(fy);
    let ya = u32(y0);
    return LatLongStencil(
        lat_long_column(x0, w, size.x),
        lat_long_column(x0 + 1.0, w, size.x),
        ya,
        min(ya + 1u, size.y - 1u),
        fx - x0,
        fy - y0,
    );
}

// The bilinear blend of the stencil's texels (a at (xa, ya), b (xb, ya), c (xa, yb),
// d (xb, yb)).
fn lat_long_blend(s: LatLongStencil, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    return mix(mix(a, b, s.tx), mix(c, d, s.tx), s.ty);
}
