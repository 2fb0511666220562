// The real SH basis (`sh::eval_into`) in WGSL, orders 1–6: a module imported by the shaders that
// evaluate SH at a direction (`volume_pass.wgsl`, `single_scattering.wgsl`).

// 1/√(4π) and √2.
const Y00: f32 = 0.28209479177387814;
const SQRT2: f32 = 1.4142135623730951;

var<private> ysh: array<f32, 36>;

fn put(l: u32, m: u32, q: f32, ca: f32, sa: f32) {
    let base = l * (l + 1u);
    ysh[base + m] = q * ca;
    if m > 0u {
        ysh[base - m] = q * sa;
    }
}

// `sh::eval_into`: the real SH basis of `order` at `dir` (need not be normalized; zero or
// non-finite evaluates at +Z) into `ysh`, by the fully normalized recurrences on
// Q̄_l^m = K_lm·P_l^m / sin^m θ, no Condon–Shortley phase; the azimuthal factors are the
// real and imaginary parts of (x + iy)^m.
fn sh_eval(order: u32, dir: vec3<f32>) {
    let n = length(dir);
    var v = vec3<f32>(0.0, 0.0, 1.0);
    if n > 0.0 && n <= 3.4e38 {
        v = dir / n;
    }
    let z = clamp(v.z, -1.0, 1.0);
    var cm = 1.0;
    var sm = 0.0;
    var qmm = Y00;
    for (var m = 0u; m < order; m++) {
        let mf = f32(m);
        var ca = 1.0;
        var sa = 0.0;
        if m > 0u {
            qmm *= sqrt((2.0 * mf + 1.0) / (2.0 * mf));
            let c = cm * v.x - sm * v.y;
            sm = cm * v.y + sm * v.x;
            cm = c;
            ca = SQRT2 * cm;
            sa = SQRT2 * sm;
        }
        put(m, m, qmm, ca, sa);
        if m + 1u >= order {
            continue;
        }
        var q_prev = qmm;
        var q = sqrt(2.0 * mf + 3.0) * z * qmm;
        put(m + 1u, m, q, ca, sa);
        for (var l = m + 2u; l < order; l++) {
            let lf = f32(l);
            let a = sqrt((4.0 * lf * lf - 1.0) / (lf * lf - mf * mf));
            let b = sqrt(((lf - 1.0) * (lf - 1.0) - mf * mf) / (4.0 * (lf - 1.0) * (lf - 1.0) - 1.0));
            let next = a * (z * q - b * q_prev);
            q_prev = q;
            q = next;
            put(l, m, q, ca, sa);
        }
    }
}

