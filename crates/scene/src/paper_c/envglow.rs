//! Environment lighting through the medium, with its glow (paper C §6.4): the environment
//! seen through fog, blurred by the medium's point-spread function, and surfaces lit by
//! the environment convolved with it — in spherical harmonics.
//!
//! **Model** (paper C §6.4 and its footnote 5). The environment is a sphere of small
//! isotropic sources at the environment distance `D` from the point that sees them: the
//! directions `dω′` around `ω′` hold the radiant intensity `L(ω′)·D²·dω′`, so that through
//! a clear medium they give the irradiance `L(ω′)·dω′`. Per channel (`β = σt`,
//! `σs = albedo·β`), single scattering, isotropic phase:
//!
//! - Along a view ray `x·ω`, `x ∈ [0, t]`, the environment's airlight is paper C's
//!   point-light airlight (eq. 5) summed over the sources:
//!   `L_a(ω, t) = ∫ L(ω′)·k_t(ω·ω′) dω′`, with the kernel
//!   `k_t(cos γ) = D²·σs/(4π)·∫₀^t e^{−β(d + x)}/d² dx`, `d² = D² + x² − 2xD·cos γ` — the
//!   PSF of eq. 20 at `Dsv = D`, `Dvp = t`. Rays that hit nothing end at the environment,
//!   `t = D`; there `k_D ~ D·σs·e^{−βD}/(8γ)` as `γ → 0`, integrable against `sin γ dγ`.
//! - Funk–Hecke: `k_t` depends on the angle only, so in the real orthonormal SH of order `n`
//!   `L_a(ω, t) = Σ_lm λ_l(t)·L_lm·Y_lm(ω)` with `λ_l(t) = 2π∫₀^π k_t(cos γ)·P_l(cos γ)·sin γ dγ`
//!   (`= √(4π/(2l+1))·PSF_l`, eq. 25). The exact `λ_l` replace the paper's factorization
//!   `PSF ≈ T·e^{−T}·NPSF` (eq. 22), which misses the scattered energy by up to 70 %
//!   (notes on paper C, §1.4).
//! - Light arriving at a surface point from `ω_i` (eq. 26–27; the sources again at `D` from
//!   the point, the incoming ray reaching them): `L_in(ω_i) = e^{−βD}·L(ω_i) + L_a(ω_i, D)`,
//!   so `L_in,lm = (e^{−βD} + λ_l(D))·L_lm`.
//! - Reflected towards the viewer, unshadowed (as environment maps in paper C §6.4):
//!   Lambert `ρd/π·∫L_in·max(0, n·ω) dω = ρd/π·Σ a_l·L_in,lm·Y_lm(n)` with
//!   `a_l = 2π∫₀¹ μ·P_l(μ) dμ` (π, 2π/3, π/4, 0, −π/24, …); normalized Phong
//!   `ks(m + 2)/(2π)·∫L_in·max(0, r·ω)^m dω = ks(m + 2)/(2π)·Σ p_l·L_in,lm·Y_lm(r)` with
//!   `p_l = 2π∫₀¹ μ^m·P_l(μ) dμ` — the lobe is not cut at the surface's horizon (the point
//!   lights' direct term is).
//!
//! `λ_l(t)` is tabulated at `t = D·j/(N − 1)` and read linearly in `t`; `k_t` comes from
//! paper C's airlight in its stable form ([`crate::paper_c::airlight::point`]) through the `K`
//! table, integrated over γ by Gauss–Legendre on panels graded towards `γ = 0`. Limits:
//! `D = ∞` with `β > 0` gives `e^{−βD} = 0` and `λ = 0` (the sources deliver
//! `L·e^{−βD}·dω`); `β = 0` gives `λ = 0` and `L_in = L`. The environment's own radiance
//! along escaping rays, `e^{−βD}·L(ω)`, stays exact ([`crate::render::background`]).

use super::airlight::{self, KFunction};
use super::quad::{composite, gauss_legendre};
use crate::scene::{Environment, Material, Rgb, Scene};
use crate::vec3::Vec3;
use haze_view::sh;
use std::f64::consts::PI;
use std::sync::{Arc, Mutex};

/// The SH order (bands `l < 16`, 256 coefficients per channel), chosen by measurement
/// (BENCHMARKS.md "Environment glow").
pub const DEFAULT_ORDER: usize = 16;

/// Highest order evaluated on the CPU (its stack buffers).
pub const MAX_ORDER: usize = 24;

/// Highest order the GPU shader evaluates (its `SH_MAX`).
pub const GPU_MAX_ORDER: usize = 16;

/// Nodes of the `λ_l(t)` table over `t ∈ [0, D]`.
pub const T_NODES: usize = 65;

/// Panel ends of the γ quadrature, graded towards the `1/γ` peak of `k_D`.
const GAMMA_BREAKS: [f64; 12] = [
    0.0, 5e-4, 0.002, 0.008, 0.025, 0.06, 0.15, 0.35, 0.7, 1.2, 2.0, PI,
];

/// `(γ, weight)` of composite Gauss–Legendre with `per_panel` nodes on each graded panel
/// of `[0, π]` (weights for `dγ`).
pub fn gamma_rule(per_panel: usize) -> Vec<(f64, f64)> {
    let rule = gauss_legendre(per_panel);
    let mut out = Vec::with_capacity(rule.len() * (GAMMA_BREAKS.len() - 1));
    for w in GAMMA_BREAKS.windows(2) {
        let (c, h) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
        out.extend(rule.iter().map(|&(x, wt)| (c + h * x, h * wt)));
    }
    out
}

/// `P_0(μ) … P_{n−1}(μ)` by the three-term recurrence.
pub fn legendre(n: usize, mu: f64) -> Vec<f64> {
    let mut p = vec![0.0; n];
    if n > 0 {
        p[0] = 1.0;
    }
    if n > 1 {
        p[1] = mu;
    }
    for l in 2..n {
        let lf = l as f64;
        p[l] = ((2.0 * lf - 1.0) * mu * p[l - 1] - (lf - 1.0) * p[l - 2]) / lf;
    }
    p
}

/// `2π∫₀¹ μ^e·P_l(μ) dμ`, `l < order`: the Funk–Hecke factors of the clamped lobe
/// `max(0, cos γ)^e` (`e = 1`: Lambert's cosine).
pub fn lobe_factors(order: usize, e: f64) -> Vec<f64> {
    let rule = gauss_legendre(16);
    (0..order)
        .map(|l| {
            2.0 * PI
                * composite(
                    |mu| mu.powf(e) * legendre(order, mu)[l],
                    0.0,
                    1.0,
                    &rule,
                    16,
                )
        })
        .collect()
}

/// The scene's environment as crates/view's, for its exact SH projection.
pub fn view_environment(env: &Environment) -> Option<haze_view::Environment> {
    match env {
        Environment::Black => None,
        Environment::Sky => Some(haze_view::Environment::sky(haze_view::Sky::default())),
        Environment::Constant(c) => Some(haze_view::Environment::constant(*c)),
        Environment::Map(m) => Some(haze_view::Environment::map(m.as_ref().clone())),
    }
}

/// The environment's exact SH projection at `order`, `L_lm` per channel at
/// `l(l + 1) + m` (`sh::project_env`); `None` for a black environment.
pub fn projection(env: &Environment, order: usize) -> Option<Vec<[f64; 3]>> {
    let proj = sh::project_env(&view_environment(env)?, order);
    Some(
        (0..order * order)
            .map(|i| [proj[0][i], proj[1][i], proj[2][i]])
            .collect(),
    )
}

/// Two environments are the same light (a map compared by its texels, unless it is the
/// very same map).
fn same_environment(a: &Environment, b: &Environment) -> bool {
    match (a, b) {
        (Environment::Map(x), Environment::Map(y)) => Arc::ptr_eq(x, y) || x == y,
        _ => a == b,
    }
}

/// What an [`EnvGlow`] depends on besides the environment and the `K` table: the
/// environment distance, the medium's σt and σs, the order and the Phong exponents (not
/// the camera, the lights or the surfaces' shapes).
#[derive(Clone, Debug, PartialEq)]
struct GlowKey {
    distance: f64,
    sigma_t: Rgb,
    sigma_s: Rgb,
    order: usize,
    exponents: Vec<f64>,
}

#[derive(Debug, Default)]
struct Slots {
    /// The environment, the order and [`projection`] of them.
    projection: Option<(Environment, usize, Vec<[f64; 3]>)>,
    /// The last glow, of the environment in `projection`.
    glow: Option<(GlowKey, EnvGlow)>,
    projections: u64,
    glows: u64,
}

/// [`EnvGlow::new`] kept between frames, for one `K` table (its holder's): the
/// environment's SH projection (about half of [`EnvGlow::new`]'s time, BENCHMARKS.md
/// "Environment glow") is keyed by the environment and the order; the glow by those and
/// [`GlowKey`] — so camera moves and light or surface edits rebuild nothing, and a medium
/// edit only the `λ_l` tables, from the kept projection.
#[derive(Debug, Default)]
pub struct Cache(Mutex<Slots>);

impl Cache {
    /// [`EnvGlow::new`] of `scene` with `k`, computed again only in the part whose inputs
    /// changed (type docs). Panics as [`EnvGlow::new`] for an order outside 1 to
    /// [`MAX_ORDER`].
    pub fn glow(
        &self,
        scene: &Scene,
        k: &(impl KFunction + Sync),
        order: usize,
        exponents: &[f64],
    ) -> Option<EnvGlow> {
        if matches!(scene.environment, Environment::Black) {
            return None;
        }
        let key = GlowKey {
            distance: scene.environment_distance,
            sigma_t: scene.medium.sigma_t,
            sigma_s: scene.medium.sigma_s(),
            order,
            exponents: exponents.to_vec(),
        };
        let mut slots = self.0.lock().unwrap_or_else(|e| e.into_inner());
        let same_projection = matches!(&slots.projection,
            Some((env, o, _)) if *o == order && same_environment(env, &scene.environment));
        if same_projection
            && let Some((k0, glow)) = &slots.glow
            && *k0 == key
        {
            return Some(glow.clone());
        }
        let radiance = match &slots.projection {
            Some((_, _, r)) if same_projection => r.clone(),
            _ => {
                let r = projection(&scene.environment, order)?;
                slots.projections += 1;
                slots.projection = Some((scene.environment.clone(), order, r.clone()));
                r
            }
        };
        let glow = EnvGlow::with_radiance(scene, k, order, exponents, radiance);
        slots.glows += 1;
        slots.glow = Some((key, glow.clone()));
        Some(glow)
    }

    /// How many projections and glows were computed so far (for tests and figures).
    pub fn builds(&self) -> (u64, u64) {
        let slots = self.0.lock().unwrap_or_else(|e| e.into_inner());
        (slots.projections, slots.glows)
    }
}

/// `k_t(cos γ)` for a unit-direction ray and sources at distance `d` (module docs), by
/// paper C's stable form with `k`.
pub fn kernel(k: &impl KFunction, d: f64, t: f64, gamma: f64, beta: f64, sigma_s: f64) -> f64 {
    let light = [d * gamma.sin(), 0.0, d * gamma.cos()];
    d * d * airlight::point(k, [0.0; 3], [0.0, 0.0, 1.0], t, light, 1.0, beta, sigma_s)
}

/// The environment in SH with the medium's glow, ready to evaluate per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvGlow {
    pub order: usize,
    /// The environment distance `D` (may be `∞`).
    pub distance: f64,
    /// `L_lm` per channel, index `l(l + 1) + m`.
    pub radiance: Vec<[f64; 3]>,
    /// `L_in,lm = (e^{−βD} + λ_l(D))·L_lm`.
    pub incident: Vec<[f64; 3]>,
    /// `λ_l(t_j)`, `t_j = D·j/(T_NODES − 1)`, at `j·order + l`.
    pub lambda: Vec<[f64; 3]>,
    /// Whether any `λ` is non-zero (a finite `D` and a scattering medium).
    pub glows: bool,
    /// Lambert's `a_l`.
    pub diffuse_lobe: Vec<f64>,
    /// `(m, p_l(m))` for each Phong exponent asked for.
    pub specular_lobes: Vec<(f64, Vec<f64>)>,
}

impl EnvGlow {
    /// The glow of the scene's environment and medium at SH order `order` (1 to
    /// [`MAX_ORDER`]; panics otherwise), with Phong factors for `exponents`; `None` for a
    /// black environment.
    pub fn new(
        scene: &Scene,
        k: &(impl KFunction + Sync),
        order: usize,
        exponents: &[f64],
    ) -> Option<EnvGlow> {
        assert!(
            (1..=MAX_ORDER).contains(&order),
            "SH order {order} outside 1..={MAX_ORDER}"
        );
        let radiance = projection(&scene.environment, order)?;
        Some(EnvGlow::with_radiance(scene, k, order, exponents, radiance))
    }

    /// [`EnvGlow::new`] of the environment whose projection at `order` is `radiance`
    /// (`L_lm` per channel, `order²` of them, as [`projection`] gives): the `λ_l` tables of
    /// the scene's medium and distance and the lobes of `exponents`. Panics for an order
    /// outside 1 to [`MAX_ORDER`] or another count of coefficients.
    pub fn with_radiance(
        scene: &Scene,
        k: &(impl KFunction + Sync),
        order: usize,
        exponents: &[f64],
        radiance: Vec<[f64; 3]>,
    ) -> EnvGlow {
        use rayon::prelude::*;
        assert!(
            (1..=MAX_ORDER).contains(&order) && radiance.len() == order * order,
            "SH order {order} outside 1..={MAX_ORDER} or {} coefficients",
            radiance.len()
        );
        let d = scene.environment_distance;
        let rule = gamma_rule(8);
        let mut lambda = vec![[0.0; 3]; T_NODES * order];
        let mut glows = false;
        let sigma_s = scene.medium.sigma_s();
        for c in 0..3 {
            let (beta, ss) = (scene.medium.sigma_t[c], sigma_s[c]);
            if !d.is_finite() || ss <= 0.0 {
                continue;
            }
            glows = true;
            // Channels of equal (β, σs) share the table.
            if let Some(c0) =
                (0..c).find(|&c0| (scene.medium.sigma_t[c0], sigma_s[c0]) == (beta, ss))
            {
                for v in lambda.iter_mut() {
                    v[c] = v[c0];
                }
                continue;
            }
            let rows: Vec<Vec<f64>> = (0..T_NODES)
                .into_par_iter()
                .map(|j| {
                    let t = d * j as f64 / (T_NODES - 1) as f64;
                    let mut row = vec![0.0; order];
                    if j == 0 {
                        return row;
                    }
                    for &(g, w) in &rule {
                        let kv = kernel(k, d, t, g, beta, ss) * g.sin() * w * 2.0 * PI;
                        for (r, p) in row.iter_mut().zip(legendre(order, g.cos())) {
                            *r += kv * p;
                        }
                    }
                    row
                })
                .collect();
            for (j, row) in rows.iter().enumerate() {
                for (l, v) in row.iter().enumerate() {
                    lambda[j * order + l][c] = *v;
                }
            }
        }
        let transmit: [f64; 3] = [0, 1, 2].map(|c| {
            let beta = scene.medium.sigma_t[c];
            if beta <= 0.0 { 1.0 } else { (-beta * d).exp() }
        });
        let last = (T_NODES - 1) * order;
        let incident = radiance
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let l = sh::basis::band_of(i);
                [0, 1, 2].map(|c| (transmit[c] + lambda[last + l][c]) * r[c])
            })
            .collect();
        EnvGlow {
            order,
            distance: d,
            radiance,
            incident,
            lambda,
            glows,
            diffuse_lobe: lobe_factors(order, 1.0),
            specular_lobes: exponents
                .iter()
                .map(|&e| (e, lobe_factors(order, e)))
                .collect(),
        }
    }

    /// `λ_l(t)` per channel, linear between the table's nodes (`t` clamped to `[0, D]`).
    pub fn lambda_at(&self, l: usize, t: f64) -> [f64; 3] {
        let s = (t / self.distance).clamp(0.0, 1.0) * (T_NODES - 1) as f64;
        let j = (s.floor() as usize).min(T_NODES - 2);
        let f = s - j as f64;
        let (a, b) = (
            self.lambda[j * self.order + l],
            self.lambda[(j + 1) * self.order + l],
        );
        [0, 1, 2].map(|c| (1.0 - f) * a[c] + f * b[c])
    }

    /// The environment's airlight along the view ray of unit direction `dir`, `x ∈ [0, t]`.
    pub fn view(&self, dir: Vec3, t: f64) -> Rgb {
        if !self.glows {
            return [0.0; 3];
        }
        let mut lam = [[0.0; 3]; MAX_ORDER];
        for (l, v) in lam.iter_mut().enumerate().take(self.order) {
            *v = self.lambda_at(l, t);
        }
        self.sum(&lam, &self.radiance, dir)
    }

    /// `Σ_lm f_l·c_lm·Y_lm(axis)` per channel (`order ≤ MAX_ORDER`).
    fn sum(&self, f: &[[f64; 3]; MAX_ORDER], coeffs: &[[f64; 3]], axis: Vec3) -> Rgb {
        let mut y = [0.0; MAX_ORDER * MAX_ORDER];
        sh::eval_into(self.order, axis, &mut y);
        let mut out = [0.0; 3];
        for (l, fl) in f.iter().enumerate().take(self.order) {
            for i in l * l..(l + 1) * (l + 1) {
                for c in 0..3 {
                    out[c] += fl[c] * coeffs[i][c] * y[i];
                }
            }
        }
        out
    }

    /// `Σ f_l·L_in,lm·Y_lm(axis)` per channel.
    fn filtered(&self, f: &[f64], axis: Vec3) -> Rgb {
        let mut fl = [[0.0; 3]; MAX_ORDER];
        for (o, v) in fl.iter_mut().zip(f) {
            *o = [*v; 3];
        }
        self.sum(&fl, &self.incident, axis)
    }

    /// Environment light (direct and scattered) reflected towards the viewer by a surface
    /// point of unit normal `n`, `r` the mirror direction of the view (module docs).
    pub fn surface(&self, n: Vec3, r: Vec3, m: &Material) -> Rgb {
        let d = self.filtered(&self.diffuse_lobe, n);
        let mut out = [0, 1, 2].map(|c| m.diffuse[c] / PI * d[c]);
        if m.is_specular()
            && let Some((_, p)) = self.specular_lobes.iter().find(|(e, _)| *e == m.shininess)
        {
            let s = self.filtered(p, r);
            for c in 0..3 {
                out[c] += m.specular[c] * (m.shininess + 2.0) / (2.0 * PI) * s[c];
            }
        }
        out
    }
}
