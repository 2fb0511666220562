//! The reference for the environment's light through the medium: the single-scattering
//! model of [`crate::paper_c::envglow`] (sources on a sphere at the environment distance `D`)
//! integrated directly on the sphere of directions, independent of spherical harmonics,
//! of the `λ_l` table and of paper C's special function.
//!
//! - Airlight along a view ray `x·ω`, `x ∈ [0, t]`:
//!   `L_a(ω, t) = ∫₀^π k_t(γ)·[∫₀^{2π} L(ω′(γ, φ)) dφ]·sin γ dγ`, `ω′(γ, φ)` the direction at
//!   angle `γ` from `ω` and azimuth `φ` about it. The kernel `k_t = D²·(airlight of a unit
//!   point light at distance D, angle γ)` is the quadrature of eq. 5
//!   ([`crate::paper_c::reference::point_airlight`]); `γ` by composite Gauss–Legendre (16 nodes on
//!   panels graded towards the `1/γ` peak), `φ` by the midpoint rule.
//! - Light on a surface point: `L_in(ω) = e^{−βD}·L(ω) + L_a(ω, D)`, the second term
//!   precomputed by the quadrature above on a lat-long grid and read bilinearly (it is
//!   smooth: a blur of the environment), and `∫ L_in(ω)·f(ω)·cos θ dω` with the material's
//!   own lobes ([`Material::brdf`], cut at the horizon): the diffuse lobe over the
//!   hemisphere about `n` (Gauss–Legendre in `cos θ` × midpoint azimuths), the specular
//!   lobe about `r` on panels scaled by its width `1/√(m + 2)`.

use super::envglow::gamma_rule;
use super::quad::gauss_legendre;
use super::reference::point_airlight;
use crate::scene::{Environment, Material, Rgb, Scene};
use crate::vec3::{Vec3, axpy, cross, dot, perpendicular, scale};
use haze_view::LatLong;
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

/// Midpoint nodes over the azimuth.
const PHI_NODES: usize = 64;

/// Relative tolerance of the kernel's quadrature along the ray.
const KERNEL_TOL: f64 = 1e-8;

/// Texels of the incoming glow's lat-long grid (`2N × N`).
const GLOW_ROWS: usize = 32;

/// The direction at angle `gamma` from the unit `axis`, azimuth `phi` about it.
fn around(axis: Vec3, gamma: f64, phi: f64) -> Vec3 {
    let u = perpendicular(axis);
    let v = cross(axis, u);
    let (s, c) = gamma.sin_cos();
    let (sp, cp) = phi.sin_cos();
    axpy(axpy(scale(axis, c), s * cp, u), s * sp, v)
}

/// The reference's environment term for one scene.
#[derive(Clone, Debug)]
pub struct EnvReference {
    env: Environment,
    distance: f64,
    /// Channels grouped by equal `(β, σs)` with `σs > 0`.
    groups: Vec<(f64, f64, Vec<usize>)>,
    transmit: [f64; 3],
    rule: Vec<(f64, f64)>,
    /// `k_D(γ_j)` per group.
    far_kernel: Vec<Vec<f64>>,
    /// `L_a(ω, D)` on a lat-long grid, when the medium glows.
    glow: Option<LatLong>,
}

impl EnvReference {
    /// `None` for a black environment.
    pub fn new(scene: &Scene) -> Option<EnvReference> {
        if scene.environment == Environment::Black {
            return None;
        }
        let d = scene.environment_distance;
        let ss = scene.medium.sigma_s();
        let mut groups: Vec<(f64, f64, Vec<usize>)> = Vec::new();
        if d.is_finite() {
            for (c, (&st, &s)) in scene.medium.sigma_t.iter().zip(&ss).enumerate() {
                let key = (st, s);
                if key.1 <= 0.0 {
                    continue;
                }
                match groups.iter_mut().find(|g| (g.0, g.1) == key) {
                    Some(g) => g.2.push(c),
                    None => groups.push((key.0, key.1, vec![c])),
                }
            }
        }
        let transmit = [0, 1, 2].map(|c| {
            let beta = scene.medium.sigma_t[c];
            if beta <= 0.0 { 1.0 } else { (-beta * d).exp() }
        });
        let rule = gamma_rule(16);
        let far_kernel = groups
            .iter()
            .map(|&(beta, s, _)| {
                rule.par_iter()
                    .map(|&(g, _)| kernel(d, d, g, beta, s))
                    .collect()
            })
            .collect();
        let mut r = EnvReference {
            env: scene.environment.clone(),
            distance: d,
            groups,
            transmit,
            rule,
            far_kernel,
            glow: None,
        };
        if !r.groups.is_empty() {
            let (w, h) = (2 * GLOW_ROWS, GLOW_ROWS);
            let grid = LatLong {
                width: w,
                height: h,
                texels: vec![[0.0; 3]; w * h],
            };
            let texels = (0..w * h)
                .into_par_iter()
                .map(|i| {
                    let (dir, _) = grid.texel_direction(i % w, i / w);
                    r.view(dir, d).map(|v| v as f32)
                })
                .collect();
            r.glow = Some(LatLong { texels, ..grid });
        }
        Some(r)
    }

    /// `∫₀^{2π} L(ω′(γ_j, φ)) dφ` for every node `γ_j`.
    fn rings(&self, dir: Vec3) -> Vec<Rgb> {
        let dphi = 2.0 * PI / PHI_NODES as f64;
        self.rule
            .iter()
            .map(|&(g, _)| {
                let mut s = [0.0; 3];
                for k in 0..PHI_NODES {
                    let l = self.env.radiance(around(dir, g, (k as f64 + 0.5) * dphi));
                    for c in 0..3 {
                        s[c] += dphi * l[c];
                    }
                }
                s
            })
            .collect()
    }

    /// The environment's airlight along the view ray `x·dir`, `x ∈ [0, t]`.
    pub fn view(&self, dir: Vec3, t: f64) -> Rgb {
        let mut out = [0.0; 3];
        if self.groups.is_empty() || t <= 0.0 {
            return out;
        }
        let rings = self.rings(dir);
        let d = self.distance;
        for (gi, (beta, ss, chans)) in self.groups.iter().enumerate() {
            let at_end = t >= d;
            for (j, &(g, w)) in self.rule.iter().enumerate() {
                let k = if at_end {
                    self.far_kernel[gi][j]
                } else {
                    kernel(d, t, g, *beta, *ss)
                };
                let f = k * g.sin() * w;
                for &c in chans {
                    out[c] += f * rings[j][c];
                }
            }
        }
        out
    }

    /// Light arriving at a surface from `w`: `e^{−βD}·L(w) + L_a(w, D)`.
    fn incoming(&self, w: Vec3) -> Rgb {
        let l = self.env.radiance(w);
        let g = self.glow.as_ref().map_or([0.0; 3], |m| m.radiance(w));
        [0, 1, 2].map(|c| self.transmit[c] * l[c] + g[c])
    }

    /// Environment light reflected towards the viewer by a surface point of unit normal
    /// `n`, `r` the mirror direction of the view (module docs).
    pub fn surface(&self, n: Vec3, r: Vec3, m: &Material) -> Rgb {
        let mut out = [0.0; 3];
        let dphi = 2.0 * PI / PHI_NODES as f64;
        let diffuse = Material {
            specular: [0.0; 3],
            ..m.clone()
        };
        // Diffuse: the hemisphere about n, μ = cos θ by 32 Gauss–Legendre nodes on (0, 1).
        for &(x, wx) in &gauss_legendre(32) {
            let mu: f64 = 0.5 * (x + 1.0);
            let g = mu.clamp(-1.0, 1.0).acos();
            for k in 0..PHI_NODES {
                let w = around(n, g, (k as f64 + 0.5) * dphi);
                let li = self.incoming(w);
                for c in 0..3 {
                    out[c] += 0.5 * wx * dphi * li[c] * diffuse.brdf(n, r, w, c);
                }
            }
        }
        if m.is_specular() {
            let spec = Material {
                diffuse: [0.0; 3],
                ..m.clone()
            };
            let width = 1.0 / (m.shininess + 2.0).sqrt();
            let mut breaks: Vec<f64> = [0.0, 0.25, 0.5, 1.0, 2.0, 4.0]
                .iter()
                .map(|f| f * width)
                .filter(|&b| b < FRAC_PI_2)
                .collect();
            breaks.push(FRAC_PI_2);
            let rule = gauss_legendre(12);
            for p in breaks.windows(2) {
                let (mid, half) = (0.5 * (p[0] + p[1]), 0.5 * (p[1] - p[0]));
                for &(x, wx) in &rule {
                    let g = mid + half * x;
                    for k in 0..PHI_NODES {
                        let w = around(r, g, (k as f64 + 0.5) * dphi);
                        if dot(n, w) <= 0.0 {
                            continue;
                        }
                        let li = self.incoming(w);
                        for c in 0..3 {
                            out[c] += half * wx * g.sin() * dphi * li[c] * spec.brdf(n, r, w, c);
                        }
                    }
                }
            }
        }
        out
    }
}

/// `k_t(γ) = D²·(airlight of a unit point light at distance D)` by quadrature.
fn kernel(d: f64, t: f64, gamma: f64, beta: f64, sigma_s: f64) -> f64 {
    let light = [d * gamma.sin(), 0.0, d * gamma.cos()];
    d * d
        * point_airlight(
            [0.0; 3],
            [0.0, 0.0, 1.0],
            t,
            light,
            beta,
            sigma_s,
            KERNEL_TOL,
        )
}
