//! Airlight: light of point and sun lights scattered once towards the eye by a
//! homogeneous isotropic medium (paper C, §3 and appendix A), per colour channel.
//!
//! **Point light.** Along a ray from the eye `v` (unit direction `r̂`) to `t_end`, with
//! the light `s` at distance `Dsv` and angle `γ` from the ray, extinction `β` and
//! scattering `σs = α·β` (paper C's eq. 5 with the albedo):
//!
//! `La = σs·I/(4π) ∫₀^{t_end} e^{−β(d(x) + x)}/d(x)² dx`,  `d(x)² = Dsv² + x² − 2x·Dsv·cos γ`.
//!
//! Paper C's substitutions (`z = βx − Tsv cos γ = h·tan η`, `η = 2ξ − π/2`) turn it
//! into `A0·[F(A1, v1) − F(A1, γ/2)]` (eq. 7–12). We use the equivalent stable form of
//! [`crate::paper_c::hfunc`]: with `h = Dsv·sin γ` (the light's distance from the ray's line) and,
//! for each end `k` of the segment (0: the eye, 1: the far end `p`), `y_k` the signed
//! distance along the ray from the foot of that perpendicular to the end (`y₀ = −Dsv cos γ`,
//! `y₁ = t_end − Dsv cos γ`), `r_k` the end's distance to the light (`r₀ = Dsv`,
//! `r₁ = Dsp`) and `T_k = β(r_k + x_k)` the optical length light → end → eye:
//!
//! `La = σs·I/(4π)·Σ_k ±e^{−T_k}·[atan2(h, y_k)/h]·K(ρ_k, δ_k)/(1 + ρ_k)`  (+ for k = 0),
//!
//! `δ_k = ½·atan2(h, y_k)` (the paper's `π/2 − γ/2` and `π/2 − v1`) and
//! `ρ_k = β·√(2 r_k (r_k + y_k))` (the paper's `A1/cos w`, without a division). Every
//! factor is bounded except `atan2(h, y)/h ~ π/h` when the light is in front of an end
//! (`y < 0`, `h → 0`): the true `1/γ` peak of the glow around a light seen through fog.
//! Rays are never evaluated closer than `γ_min` to a light in front of them (the radius of
//! a pixel's disc of rays, halved: the mean of `1/γ` over the disc is `2/ρ_pix`), nor
//! lights closer than `r_min` to the eye ([`effective_light`]); the reference renderer
//! takes the same effective light. `β = 0` gives 0; `β → 0` the unattenuated limit
//! `σs·I/(4πh)·[atan2(h, y₀) − atan2(h, y₁)]`; large `β` underflows to 0.
//!
//! **Sun.** A distant light of irradiance `E` lights every point of the medium unattenuated
//! (the homogeneous medium is the local fog around the scene, lit from outside it), so
//! `La = σs·E/(4π)·∫₀^{t_end} e^{−βx} dx = σs·E/(4π)·(1 − e^{−β t_end})/β`.

use super::htable::HTable;
use crate::vec3::{Vec3, axpy, cos_sin, dot, norm, normalize, perpendicular, scale, sub};
use std::f64::consts::PI;

/// Where `K(ρ, δ)` comes from: the table, or the exact quadrature (for checks).
pub trait KFunction {
    fn k(&self, rho: f64, delta: f64) -> f64;
}

impl KFunction for HTable {
    fn k(&self, rho: f64, delta: f64) -> f64 {
        HTable::k(self, rho, delta)
    }
}

/// `K` by adaptive quadrature ([`crate::paper_c::hfunc::k_exact`]): slow, exact to 1e-11.
#[derive(Clone, Copy, Debug, Default)]
pub struct ExactK;

impl KFunction for ExactK {
    fn k(&self, rho: f64, delta: f64) -> f64 {
        super::hfunc::k_exact(rho, delta.clamp(0.0, std::f64::consts::FRAC_PI_2))
    }
}

/// Limits that keep the airlight finite where the model diverges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Smallest angle between a ray and a light in front of it (radians).
    pub gamma_min: f64,
    /// Smallest distance between a light and the point it lights or the eye (world units).
    pub r_min: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            gamma_min: 1e-4,
            r_min: 1e-3,
        }
    }
}

/// The light position the models use for the ray `eye + t·dir` (unit `dir`): at least
/// `r_min` from the eye (pushed out along the eye–light line, or sideways if the light is
/// exactly at the eye), and if it is in front of the ray closer than `γ_min` to it, turned
/// about the eye onto the cone `γ = γ_min` (on the side where it lies; the airlight
/// depends only on `γ`, so any side will do for a light on the ray).
pub fn effective_light(eye: Vec3, dir: Vec3, light: Vec3, lim: &Limits) -> Vec3 {
    let mut v = sub(light, eye);
    let d = norm(v);
    if d < lim.r_min {
        let u = normalize(v).unwrap_or_else(|| perpendicular(dir));
        v = scale(u, lim.r_min);
    }
    let d = norm(v);
    let (c, s) = cos_sin(scale(v, 1.0 / d), dir);
    if c > 0.0 && s < lim.gamma_min.sin() {
        // The part of v across the ray, projected twice: with the light on the ray the
        // first projection leaves rounding noise, which need not be across the ray.
        let across = |a: Vec3| normalize(axpy(a, -dot(a, dir), dir));
        let side = across(v)
            .and_then(across)
            .unwrap_or_else(|| perpendicular(dir));
        let (sg, cg) = lim.gamma_min.sin_cos();
        v = scale(axpy(scale(dir, cg), sg, side), d);
    }
    axpy(eye, 1.0, v)
}

/// A light moved to at least `r_min` from a lit point `p` (along `p`→light, or along the
/// unit normal `n` if the light is at `p`).
pub fn light_off_point(p: Vec3, n: Vec3, light: Vec3, r_min: f64) -> Vec3 {
    let v = sub(light, p);
    if norm(v) >= r_min {
        return light;
    }
    let u = normalize(v).unwrap_or(n);
    axpy(p, r_min, u)
}

/// `atan2(h, y)/h` for `h ≥ 0`, with its limit `1/y` as `h → 0` for `y > 0` (`+∞` for
/// `h = 0`, `y ≤ 0`).
pub fn atan2_over(h: f64, y: f64) -> f64 {
    if y > 0.0 && h < 1e-6 * y {
        let q = h / y;
        return (1.0 - q * q / 3.0) / y;
    }
    if h <= 0.0 {
        return f64::INFINITY;
    }
    h.atan2(y) / h
}

/// `r + y` for `r = √(h² + y²)`, without cancellation when `y ≈ −r`.
fn r_plus_y(h: f64, y: f64, r: f64) -> f64 {
    if y >= 0.0 { r + y } else { h * h / (r - y) }
}

/// The airlight of one point light along one segment, for one channel, in paper C's
/// stable form (module docs). `light` is the effective position ([`effective_light`]);
/// `t_end` may be `∞` (the ray escapes).
#[allow(clippy::too_many_arguments)]
pub fn point(
    k: &impl KFunction,
    eye: Vec3,
    dir: Vec3,
    t_end: f64,
    light: Vec3,
    intensity: f64,
    beta: f64,
    sigma_s: f64,
) -> f64 {
    if sigma_s <= 0.0 || intensity <= 0.0 || t_end <= 0.0 {
        return 0.0;
    }
    let v = sub(light, eye);
    let d_sv = norm(v);
    let (cos_g, sin_g) = cos_sin(scale(v, 1.0 / d_sv), dir);
    let h = d_sv * sin_g;
    let term = |y: f64, r: f64, t_opt: f64| -> f64 {
        let attenuation = (-t_opt).exp();
        if attenuation == 0.0 {
            return 0.0;
        }
        let rho = beta * (2.0 * r * r_plus_y(h, y, r)).sqrt();
        let delta = 0.5 * h.atan2(y);
        attenuation * atan2_over(h, y) * k.k(rho, delta) / (1.0 + rho)
    };
    let near = term(-d_sv * cos_g, d_sv, beta * d_sv);
    let far = if t_end.is_finite() {
        let p = axpy(eye, t_end, dir);
        let d_sp = norm(sub(light, p));
        term(t_end - d_sv * cos_g, d_sp, beta * (d_sp + t_end))
    } else {
        0.0
    };
    let la = sigma_s * intensity / (4.0 * PI) * (near - far);
    // The difference of two nearly equal terms (light far behind a close surface) may
    // round to a tiny negative number.
    la.max(0.0)
}

/// `∫₀^t e^{−βx} dx = (1 − e^{−βt})/β` (`t` at `β = 0`, `1/β` at `t = ∞`).
pub fn attenuated_length(beta: f64, t: f64) -> f64 {
    if beta <= 0.0 {
        return t;
    }
    if t.is_infinite() {
        return 1.0 / beta;
    }
    -(-beta * t).exp_m1() / beta
}

/// The airlight of a sun of irradiance `irradiance` along a segment of length `t_end`, for
/// one channel (module docs).
pub fn sun(t_end: f64, irradiance: f64, beta: f64, sigma_s: f64) -> f64 {
    if sigma_s <= 0.0 || irradiance <= 0.0 {
        return 0.0;
    }
    sigma_s * irradiance / (4.0 * PI) * attenuated_length(beta, t_end)
}
