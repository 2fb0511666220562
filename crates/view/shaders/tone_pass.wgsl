// The picture's 8-bit sRGB encoding on the GPU: the twin of `Image::to_srgb8` (the
// exposure, the tone curve and the sRGB transfer function, rounded to 8 bits), one
// invocation per pixel of a view pass's image.
//
// The host gives the 255 stored values where the code steps up at this exposure and
// curve (`haze_core::srgb8_thresholds`, exact in f32 comparisons), so a channel's code is
// the number of them at or below its value: a bisection over the sorted table, no
// transcendental function, the host's codes to the bit. NaN and negative values compare
// below every entry (code 0), +inf at or above every one (255). Each pixel is packed as
// one word, R in the low byte, then G, B, and 255 in the high byte (opaque RGBA8).

struct Params {
    pixels: u32,
    // Workgroups along x of the dispatch (the rest go along y).
    groups_x: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> image: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> steps: array<f32, 255>;
@group(0) @binding(3) var<storage, read_write> encoded: array<u32>;

// The number of table entries at or below `x`: the first index whose entry is above it.
fn code(x: f32) -> u32 {
    var lo = 0u;
    var hi = 255u;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (steps[mid] <= x) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    return lo;
}

@compute @workgroup_size(256)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.y * params.groups_x * 256u + id.x;
    if (i >= params.pixels) {
        return;
    }
    let p = image[i];
    encoded[i] = code(p.x) | (code(p.y) << 8u) | (code(p.z) << 16u) | (255u << 24u);
}
