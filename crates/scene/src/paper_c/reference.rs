//! The reference: the same single-scattering model as the analytic renderer (paper C:
//! point lights, homogeneous isotropic medium, surfaces lit by once-scattered light),
//! integrated by quadrature, independent of every table and of paper C's special
//! function.
//!
//! - Airlight along a ray (eq. 5): `σs·I/(4π)∫ e^{−β(d + x)}/d² dx`, written in the angle
//!   `θ` at which the light sees the point (`x = Dsv cos γ + h tan θ`, `d = h/cos θ`,
//!   `dx/d² = dθ/h`): `σs·I/(4πh)∫_{θ₀}^{θ₁} e^{−β(Dsv cos γ + h(1 + sin θ)/cos θ)} dθ`,
//!   a smooth bounded integrand, by adaptive Gauss–Kronrod.
//! - Light scattered onto a surface (eq. 15): the sphere of directions about the light,
//!   `γ′` by composite Gauss–Legendre and the azimuth by the midpoint rule, the incoming
//!   airlight along each direction by the quadrature above, times the material's lobes
//!   evaluated on the direction vectors themselves.

use super::quad::{adaptive, adaptive_pieces, composite, gauss_legendre};
use crate::scene::Material;
use crate::vec3::{Vec3, axpy, cos_sin, cross, dot, norm, normalize, perpendicular, scale, sub};
use std::f64::consts::{FRAC_PI_2, PI};

/// Quadrature settings of the reference.
#[derive(Clone, Debug, PartialEq)]
pub struct RefOptions {
    /// Relative tolerance of the airlight quadrature along a ray.
    pub tolerance: f64,
    /// Panels of 8 Gauss–Legendre nodes over `γ′ ∈ [0, π]` (surface scattering).
    pub gamma_panels: usize,
    /// Midpoint nodes over the azimuth (surface scattering).
    pub phi_nodes: usize,
}

impl Default for RefOptions {
    fn default() -> Self {
        RefOptions {
            tolerance: 1e-9,
            gamma_panels: 8,
            phi_nodes: 64,
        }
    }
}

/// `(1 + sin θ)/cos θ = tan(θ/2 + π/4)`, written as `cos θ/(1 − sin θ)` for `θ < 0`
/// (no `0/0` at `−π/2`).
fn half_tan(theta: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    if theta < 0.0 {
        c / (1.0 - s)
    } else {
        (1.0 + s) / c
    }
}

/// Airlight of a unit-intensity point light at `light` along `eye + t·dir`, `t ∈ [0,
/// t_end]` (`t_end` may be `∞`), by quadrature (module docs). `+∞` only for a light on
/// the ray in front of the eye.
pub fn point_airlight(
    eye: Vec3,
    dir: Vec3,
    t_end: f64,
    light: Vec3,
    beta: f64,
    sigma_s: f64,
    tol: f64,
) -> f64 {
    if sigma_s <= 0.0 || t_end <= 0.0 {
        return 0.0;
    }
    let v = sub(light, eye);
    let d_sv = norm(v);
    if d_sv == 0.0 {
        return f64::INFINITY;
    }
    let (c, s) = cos_sin(scale(v, 1.0 / d_sv), dir);
    let h = d_sv * s;
    let k = sigma_s / (4.0 * PI);
    if h > 1e-9 * d_sv {
        let theta0 = (-d_sv * c).atan2(h);
        let theta1 = if t_end.is_finite() {
            (t_end - d_sv * c).atan2(h)
        } else {
            FRAC_PI_2
        };
        let f = |t: f64| {
            let q = half_tan(t);
            if q.is_finite() {
                (-beta * (d_sv * c + h * q)).exp()
            } else {
                0.0
            }
        };
        let pts: Vec<f64> = (0..=8)
            .map(|i| theta0 + (theta1 - theta0) * i as f64 / 8.0)
            .collect();
        return k / h * adaptive_pieces(f, &pts, tol);
    }
    if c > 0.0 {
        return f64::INFINITY;
    }
    // The light behind the eye on the ray's line: d = Dsv + x.
    let f = |x: f64| (-beta * (d_sv + 2.0 * x)).exp() / ((d_sv + x) * (d_sv + x));
    if t_end.is_finite() {
        k * adaptive(f, 0.0, t_end, tol)
    } else {
        let g = |q: f64| {
            if q >= 1.0 {
                return 0.0;
            }
            let x = d_sv * q / (1.0 - q);
            f(x) * d_sv / ((1.0 - q) * (1.0 - q))
        };
        k * adaptive(g, 0.0, 1.0, tol)
    }
}

/// Radiance a unit-intensity point light at `light` scatters once in the medium onto
/// the surface point `p` (unit normal `n` towards the viewer, `r` the mirror direction of
/// the view) and the surface reflects towards the viewer, for the material's channel `ch`:
/// `∫ L_in(ω)·[ρd/π·max(0, n·ω) + ks·(m + 2)/(2π)·max(0, r·ω)^m] dω` (module docs).
#[allow(clippy::too_many_arguments)]
pub fn surface_scattered(
    p: Vec3,
    n: Vec3,
    r: Vec3,
    light: Vec3,
    beta: f64,
    sigma_s: f64,
    material: &Material,
    ch: usize,
    opts: &RefOptions,
) -> f64 {
    if sigma_s <= 0.0 {
        return 0.0;
    }
    let Some(l) = normalize(sub(light, p)) else {
        return 0.0;
    };
    let e1 = perpendicular(l);
    let e2 = cross(l, e1);
    let kd = material.diffuse[ch] / PI;
    let m = material.shininess;
    let ks = material.specular[ch] * (m + 2.0) / (2.0 * PI);
    let rule = gauss_legendre(8);
    let dphi = 2.0 * PI / opts.phi_nodes as f64;
    let f = |g: f64| {
        let (sg, cg) = g.sin_cos();
        let dir0 = axpy(scale(l, cg), sg, e1);
        let la = point_airlight(p, dir0, f64::INFINITY, light, beta, sigma_s, opts.tolerance);
        let mut lobe = 0.0;
        for k in 0..opts.phi_nodes {
            let (sp, cp) = ((k as f64 + 0.5) * dphi).sin_cos();
            let w = axpy(axpy(scale(l, cg), sg * cp, e1), sg * sp, e2);
            lobe += kd * dot(n, w).max(0.0);
            if ks > 0.0 {
                lobe += ks * dot(r, w).max(0.0).powf(m);
            }
        }
        la * lobe * dphi * sg
    };
    composite(f, 0.0, PI, &rule, opts.gamma_panels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paper_c::quad::adaptive_pieces;

    /// The θ form against plain quadrature in `x` of eq. 5.
    #[test]
    fn airlight_forms_agree() {
        let (beta, ss) = (0.7, 0.5);
        let eye = [0.0; 3];
        for (light, dir, t_end) in [
            ([1.0, 2.0, 0.5], [0.0, 1.0, 0.0], 4.0),
            ([1.0, -2.0, 0.5], [0.0, 1.0, 0.0], 3.0),
            ([0.05, 2.0, 0.0], [0.0, 1.0, 0.0], 1.5),
            ([0.3, 1.0, 0.0], [0.0, 1.0, 0.0], 30.0),
        ] {
            let th = point_airlight(eye, dir, t_end, light, beta, ss, 1e-11);
            let foot = dot(light, dir);
            let f = |x: f64| {
                let d = norm(sub(light, scale(dir, x)));
                (-beta * (d + x)).exp() / (d * d)
            };
            let mut pts = vec![0.0];
            for p in [foot - 0.5, foot, foot + 0.5] {
                if p > 0.0 && p < t_end {
                    pts.push(p);
                }
            }
            pts.push(t_end);
            let x = ss / (4.0 * PI) * adaptive_pieces(f, &pts, 1e-12);
            assert!((th / x - 1.0).abs() < 1e-9, "{light:?}: {th} vs {x}");
        }
        // On the line behind the eye: ∫₀^∞ e^{−β(D + 2x)}/(D + x)² dx, finite.
        let v = point_airlight(
            eye,
            [0.0, 1.0, 0.0],
            f64::INFINITY,
            [0.0, -1.0, 0.0],
            beta,
            ss,
            1e-11,
        );
        assert!(v.is_finite() && v > 0.0);
    }
}
