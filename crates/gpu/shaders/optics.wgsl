// Constants and the phase function every renderer shares (a module, `#import optics`).

const PI: f32 = 3.14159265358979;

// The Henyey–Greenstein lobe without its 1/(4π): (1 − g²) / (1 + g² − 2gc)^{3/2}, with
// 1 + g² − 2gc written as (1 − g)² + 2g(1 − c) (no cancellation in 1 + g² − 2g for a
// forward peak) and held above the smallest normal f32 (g = ±1 at c = ±1).
fn hg_lobe(g: f32, c: f32) -> f32 {
    let denom = max((1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - clamp(c, -1.0, 1.0)), 1e-37);
    return (1.0 - g * g) / (denom * sqrt(denom));
}

// The Henyey–Greenstein phase function p(c) = hg_lobe(g, c) / (4π), which integrates to
// one over the sphere (`haze_core::phase::henyey_greenstein`).
fn hg_phase(g: f32, c: f32) -> f32 {
    return hg_lobe(g, c) / (4.0 * PI);
}
