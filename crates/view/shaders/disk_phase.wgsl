// The phase functions shared by the lights pass and the gathered orders (a module imported by each;
// both declare `p` with the HG asymmetry `g`, and bind the lights' records, where the suns'
// `DiskPhase` tables are, as `lights: array<u32>`).

#import optics
#import light_records

// atan(a) for a in [0, 1], to a few ulp (Cephes' atanf): the built-in atan2 may be off by
// thousands of ulp (Vulkan allows 4096; lavapipe's is ≈ 1e-5 relative), which the steep
// table of a forward-scattering phase would turn into 1e-4 of the light.
fn atan_01(a: f32) -> f32 {
    var x = a;
    var y = 0.0;
    if a > 0.41421356 {
        // tan(π/8) < a ≤ 1: atan(a) = π/4 + atan((a − 1)/(a + 1)).
        x = (a - 1.0) / (a + 1.0);
        y = 0.25 * PI;
    }
    let z = x * x;
    return y + (((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
        - 3.33329491539e-1) * z * x + x;
}

// The angle between the unit s and d, as atan2(|s × d|, s·d) — well conditioned near 0
// and π, where acos is not — with `atan_01`.
fn angle_between(s: vec3<f32>, d: vec3<f32>) -> f32 {
    let y = length(cross(s, d));
    let x = dot(s, d);
    let big = max(y, abs(x));
    if !(big > 0.0) {
        return 0.0;
    }
    var r = atan_01(min(y, abs(x)) / big);
    if y > abs(x) {
        r = 0.5 * PI - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    return r;
}

// `DiskPhase::eval` of the table of `len` words at `at`, for the unit s and d.
fn disk_phase(at: u32, len: u32, s: vec3<f32>, d: vec3<f32>) -> f32 {
    let c = dot(s, d);
    if len == 0u {
        return hg_lobe(p.g, c);
    }
    let theta = angle_between(s, d);
    let f = clamp(theta / PI, 0.0, 1.0) * f32(len - 1u);
    let i = min(u32(floor(f)), len - 2u);
    let t = f - f32(i);
    return mix(word(at + i), word(at + i + 1u), t);
}
