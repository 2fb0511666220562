//! The environment's light on heterogeneous media (smoke assets; paper A §6 lights the
//! smoke by an environment in SH): single scattering of the environment, precomputed as
//! the transmitted environment's spherical harmonics on a coarse grid over the media.
//!
//! **Model.** A point `x` of the smoke receives from the direction `ω` (pointing towards
//! the source) the environment's radiance attenuated on the way out,
//! `L_env(ω)·T(x, ω)`, `T(x, ω) = exp(−τ_het(x, ω, ∞))·e^{−σt·D}·V(x, ω)`: `τ_het` the
//! heterogeneous media's optical depth along the whole ray (exact, as every shadow ray of
//! [`crate::march`]), `e^{−σt·D}` the homogeneous fog between the smoke and an environment
//! of sources `D = environment_distance` away (paper C §6.4's model, [`crate::paper_c::envglow`]:
//! `D = ∞` hides the environment behind any fog; no fog: 1), `V` zero where a surface
//! blocks the ray. Light the fog scatters towards the smoke from the environment (the glow
//! `λ_l(D)` of [`crate::paper_c::envglow`]) would be scattered twice before reaching the eye and is
//! left out, as single scattering demands; so is the fog's own airlight of the
//! environment, which the march of today does not include either.
//!
//! Scattered towards the eye along the camera ray direction `dir` by a medium of
//! scattering `σs(x)` and Henyey–Greenstein phase `g` (the phase of the angle between the
//! light's travel direction `−ω` and the outgoing `−dir`, so of `cos = ω·dir`, as the
//! march's lights):
//! `J(x) = σs(x)·∫ L_env(ω)·T(x, ω)·p_g(ω·dir) dω`.
//! HG's Legendre expansion `p_g(μ) = Σ_l (2l+1)/(4π)·g^l·P_l(μ)` and the addition theorem
//! `P_l(ω·dir) = 4π/(2l+1)·Σ_m Y_lm(ω)·Y_lm(dir)` give
//! `J(x) = σs(x)·Σ_l g^l·Σ_m E_lm(x)·Y_lm(dir)`, `E_lm(x) = ∫ L_env(ω)·T(x, ω)·Y_lm(ω) dω`
//! (real orthonormal SH, `haze_view::sh`): `Y` is evaluated at `+dir` because `E` is over
//! directions towards the sources.
//!
//! **Precomputation** ([`EnvGrid::build`], rayon). `E_lm` at the nodes of a grid of
//! [`EnvOptions::nodes`] per axis spanning the union of the media's boxes, each by the
//! product rule of Gauss–Legendre in `cos θ` (`n` nodes) and `2n` equal steps in `φ` —
//! `2n²` shadow rays through the media per node; between nodes `E` is trilinear. Errors:
//! the truncation at [`EnvOptions::order`] bands (small where `g^l` is), the grid's
//! interpolation of `T` (the smoke's self-shadowing varies over a voxel or so) and the
//! quadrature of the shadow's edges; measured against [`Direct`] — the same integral by
//! the product rule of many more directions at every march sample, no SH, no grid —
//! by `cargo run --release -p haze-scene --example env_smoke_error` (BENCHMARKS.md "Smoke
//! lit by the environment"), which chose the defaults.

use crate::media::Aabb;
use crate::scene::{Environment, Material, Rgb, Scene};
use crate::vec3::{Vec3, dot, norm};
use haze_view::sh::{self, ShGrid, quad::SphereGrid};
use rayon::prelude::*;

/// Settings of the environment's grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvOptions {
    /// Grid nodes per axis (≥ 2).
    pub nodes: usize,
    /// SH order: bands `l < order` (1 ..= [`MAX_ORDER`]).
    pub order: usize,
    /// Gauss–Legendre nodes in `cos θ` of the direction rule (`2n²` directions).
    pub theta: usize,
}

/// Highest SH order the renderers evaluate (the GPU's `ENV_SH_MAX`).
pub const MAX_ORDER: usize = 8;

impl Default for EnvOptions {
    fn default() -> Self {
        EnvOptions {
            nodes: 24,
            order: 6,
            theta: 8,
        }
    }
}

/// The product rule: `(unit direction, weight)` with weights summing to `4π` — `theta`
/// Gauss–Legendre latitudes × `2·theta` azimuths (`haze_view::sh::quad::SphereGrid`).
pub fn directions(theta: usize) -> Vec<(Vec3, f64)> {
    let t = theta.max(1);
    SphereGrid::new(t, 2 * t).points().collect()
}

/// `e^{−σt·D}` per channel: the homogeneous fog between the smoke and the environment.
fn fog_factor(scene: &Scene) -> Rgb {
    let d = scene.environment_distance;
    scene.medium.sigma_t.map(|s| {
        if s > 0.0 {
            (-s * d).exp() // D = ∞: 0.
        } else {
            1.0
        }
    })
}

/// `L_env(ω)·T(x, ω)` (module docs) for unit `w` towards the source, `fog` from
/// [`fog_factor`].
fn transmitted(scene: &Scene, fog: Rgb, x: Vec3, w: Vec3) -> Rgb {
    if scene
        .intersect(x, w, 1e-9 * (1.0 + norm(x)), f64::INFINITY)
        .is_some()
    {
        return [0.0; 3];
    }
    let l = scene.environment.radiance(w);
    let mut tau = [0.0; 3];
    for m in &scene.hetero {
        let t = m.optical_depth(x, w, f64::INFINITY);
        for c in 0..3 {
            tau[c] += t[c];
        }
    }
    [0, 1, 2].map(|c| l[c] * fog[c] * (-tau[c]).exp())
}

/// Each heterogeneous medium's `(σs(x), g)` at `x`.
fn scatterers(scene: &Scene, x: Vec3) -> Vec<(Rgb, f64)> {
    scene
        .hetero
        .iter()
        .map(|m| {
            let (st, a) = (m.sigma_t(x), m.albedo());
            ([0, 1, 2].map(|c| st[c] * a[c]), m.g())
        })
        .filter(|(s, _)| s.iter().any(|&v| v > 0.0))
        .collect()
}

/// Whether the environment can light the media at all (a visible, non-black environment
/// and media with bounds).
fn lit(scene: &Scene) -> bool {
    !matches!(scene.environment, Environment::Black)
        && fog_factor(scene).iter().any(|&f| f > 0.0)
        && !scene.hetero.is_empty()
}

/// Which nodes of the grid over `b` (`nodes` a side, cells of `cell`) a render reads:
/// `J(x)` is taken only where a medium scatters (`σs(x) > 0`), from the eight nodes of the
/// cell holding `x`, so a node is needed when one of the (up to eight) cells it corners
/// may hold a scattering medium ([`crate::media::Heterogeneous::occupies`]); the others
/// are never read with a weight and are left at 0 (an empty corner of the box, or the air
/// around a plume: most of a smoke asset's box).
fn needed_nodes(scene: &Scene, b: &Aabb, nodes: usize, cell: Vec3) -> Vec<bool> {
    let cells = nodes - 1;
    let scattering: Vec<&crate::media::HeteroMedium> = scene
        .hetero
        .iter()
        .filter(|m| m.albedo().iter().any(|&a| a > 0.0))
        .collect();
    let occupied: Vec<bool> = (0..cells * cells * cells)
        .into_par_iter()
        .map(|c| {
            let i = [c % cells, (c / cells) % cells, c / (cells * cells)];
            let lo: Vec3 = [0, 1, 2].map(|a| b.min[a] + i[a] as f64 * cell[a]);
            let hi: Vec3 = [0, 1, 2].map(|a| b.min[a] + (i[a] + 1) as f64 * cell[a]);
            let bx = Aabb { min: lo, max: hi };
            scattering.iter().any(|m| m.occupies(&bx))
        })
        .collect();
    let mut needed = vec![false; nodes * nodes * nodes];
    for (c, _) in occupied.iter().enumerate().filter(|(_, o)| **o) {
        let i = [c % cells, (c / cells) % cells, c / (cells * cells)];
        for corner in 0..8 {
            let n = [0, 1, 2].map(|a| i[a] + (corner >> a & 1));
            needed[n[0] + nodes * (n[1] + nodes * n[2])] = true;
        }
    }
    needed
}

/// `E_lm` on a grid of nodes (module docs): [`ShGrid`], the same number of nodes on every
/// axis.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvGrid(ShGrid);

impl std::ops::Deref for EnvGrid {
    type Target = ShGrid;
    fn deref(&self) -> &ShGrid {
        &self.0
    }
}

impl EnvGrid {
    /// The grid of `scene`'s environment over its heterogeneous media; `None` when the
    /// environment lights nothing (black, hidden by the fog, no such media — the march
    /// then renders exactly as without this term) or a medium has no bounds. Only the
    /// nodes a render reads are computed ([`needed_nodes`]); the rest are 0.
    pub fn build(scene: &Scene, opt: &EnvOptions) -> Option<EnvGrid> {
        Self::build_nodes(scene, opt, true)
    }

    /// [`EnvGrid::build`], computing every node when `skip` is false.
    fn build_nodes(scene: &Scene, opt: &EnvOptions, skip: bool) -> Option<EnvGrid> {
        if !lit(scene) {
            return None;
        }
        let mut b: Option<Aabb> = None;
        for m in &scene.hetero {
            let mb = m.bounds()?;
            b = Some(b.map_or(mb, |a| Aabb {
                min: [0, 1, 2].map(|k| a.min[k].min(mb.min[k])),
                max: [0, 1, 2].map(|k| a.max[k].max(mb.max[k])),
            }));
        }
        let b = b?;
        let nodes = opt.nodes.max(2);
        let order = opt.order.clamp(1, MAX_ORDER);
        let k = sh::count(order);
        let cell = [0, 1, 2].map(|a| (b.max[a] - b.min[a]) / (nodes - 1) as f64);
        let rule: Vec<(Vec3, f64, Vec<f64>)> = directions(opt.theta)
            .into_iter()
            .map(|(w, wt)| (w, wt, sh::eval(order, w)))
            .collect();
        let fog = fog_factor(scene);
        let needed = if skip {
            needed_nodes(scene, &b, nodes, cell)
        } else {
            vec![true; nodes * nodes * nodes]
        };
        let coeffs: Vec<f32> = (0..nodes * nodes * nodes)
            .into_par_iter()
            .flat_map_iter(|i| {
                let (ix, iy, iz) = (i % nodes, (i / nodes) % nodes, i / (nodes * nodes));
                let x = [
                    b.min[0] + ix as f64 * cell[0],
                    b.min[1] + iy as f64 * cell[1],
                    b.min[2] + iz as f64 * cell[2],
                ];
                let mut e = vec![0.0f64; 3 * k];
                let read = needed[i];
                for (w, wt, y) in rule.iter().filter(|_| read) {
                    let l = transmitted(scene, fog, x, *w);
                    if l.iter().all(|&v| v == 0.0) {
                        continue;
                    }
                    for (j, yj) in y.iter().enumerate() {
                        for c in 0..3 {
                            e[3 * j + c] += wt * yj * l[c];
                        }
                    }
                }
                e.into_iter().map(|v| v as f32)
            })
            .collect();
        Some(EnvGrid(ShGrid {
            min: b.min,
            cell,
            nodes: [nodes; 3],
            order,
            coeffs,
        }))
    }

    /// `J(x)` (module docs): the environment's light scattered once towards `−dir` at `x`
    /// by every heterogeneous medium.
    pub fn in_scattered(&self, scene: &Scene, x: Vec3, dir: Vec3) -> Rgb {
        let media = scatterers(scene, x);
        if media.is_empty() {
            return [0.0; 3];
        }
        let mut e = [0.0; 3 * MAX_ORDER * MAX_ORDER];
        let mut y = [0.0; MAX_ORDER * MAX_ORDER];
        self.at(x, &mut e);
        sh::eval_into(self.order, dir, &mut y);
        let mut out = [0.0; 3];
        for (ss, g) in media {
            let mut gl = 1.0;
            for l in 0..self.order {
                for j in l * l..(l + 1) * (l + 1) {
                    for c in 0..3 {
                        out[c] += ss[c] * gl * e[3 * j + c] * y[j];
                    }
                }
                gl *= g;
            }
        }
        out
    }
}

/// The environment term by direct quadrature at every sample — no SH, no grid: the
/// reference [`EnvGrid`] is measured against.
#[derive(Clone, Debug, PartialEq)]
pub struct Direct {
    rule: Vec<(Vec3, f64)>,
}

impl Direct {
    /// The product rule of `theta` Gauss–Legendre nodes (`2·theta²` directions).
    pub fn new(theta: usize) -> Direct {
        Direct {
            rule: directions(theta),
        }
    }

    /// `J(x)` by the rule: `σs(x)·Σ_ω w·L_env(ω)·T(x, ω)·p_g(ω·dir)`.
    pub fn in_scattered(&self, scene: &Scene, x: Vec3, dir: Vec3) -> Rgb {
        let media = scatterers(scene, x);
        if media.is_empty() || !lit(scene) {
            return [0.0; 3];
        }
        let fog = fog_factor(scene);
        let mut out = [0.0; 3];
        for (w, wt) in &self.rule {
            let l = transmitted(scene, fog, x, *w);
            if l.iter().all(|&v| v == 0.0) {
                continue;
            }
            let cos = dot(*w, dir);
            for (ss, g) in &media {
                let p = crate::media::henyey_greenstein(*g, cos);
                for c in 0..3 {
                    out[c] += wt * ss[c] * p * l[c];
                }
            }
        }
        out
    }

    /// The environment's light reflected towards the viewer by the surface point `p` of
    /// unit normal `n` (`r` the view's mirror direction) by the rule:
    /// `Σ_ω w·L_env(ω)·e^{−σt·D}·e^{−τ_het(p, ω, ∞)}·f(n, r, ω)·cos θ` — each direction
    /// attenuated exactly by the heterogeneous media, unshadowed by surfaces (paper C §6.4's
    /// convention for environment maps, as [`crate::paper_c::envglow`]). The reference of
    /// [`crate::paper_b::gaussian_env`]'s surfaces; the Lambert lobe's kink at the horizon makes
    /// the product rule converge as `~1/n²`.
    pub fn surface(&self, scene: &Scene, p: Vec3, n: Vec3, r: Vec3, m: &Material) -> Rgb {
        if matches!(scene.environment, Environment::Black) {
            return [0.0; 3];
        }
        let fog = fog_factor(scene);
        let mut out = [0.0; 3];
        for (w, wt) in &self.rule {
            if dot(*w, n) <= 0.0 {
                continue;
            }
            let l = scene.environment.radiance(*w);
            let mut tau = [0.0; 3];
            for med in &scene.hetero {
                let t = med.optical_depth(p, *w, f64::INFINITY);
                for c in 0..3 {
                    tau[c] += t[c];
                }
            }
            for c in 0..3 {
                out[c] += wt * l[c] * fog[c] * (-tau[c]).exp() * m.brdf(n, r, *w, c);
            }
        }
        out
    }
}

/// How the march lights its media by the environment.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum EnvLight {
    /// Not at all (a black or hidden environment, or no heterogeneous media).
    #[default]
    None,
    /// By the precomputed grid.
    Grid(std::sync::Arc<EnvGrid>),
    /// By direct quadrature at every sample (the reference).
    Direct(std::sync::Arc<Direct>),
}

impl EnvLight {
    /// `J(x)` of the chosen method.
    pub fn in_scattered(&self, scene: &Scene, x: Vec3, dir: Vec3) -> Rgb {
        match self {
            EnvLight::None => [0.0; 3],
            EnvLight::Grid(g) => g.in_scattered(scene, x, dir),
            EnvLight::Direct(d) => d.in_scattered(scene, x, dir),
        }
    }
}

/// [`EnvLight::Grid`] of the default settings for `scene`, or [`EnvLight::None`] when the
/// environment lights none of its media.
pub fn light(scene: &Scene) -> EnvLight {
    EnvGrid::build(scene, &EnvOptions::default())
        .map_or(EnvLight::None, |g| EnvLight::Grid(std::sync::Arc::new(g)))
}

/// What the grid depends on: the environment, its distance, the fog, the heterogeneous
/// media and the surfaces (not the camera, not the lights).
type Key = (
    Environment,
    f64,
    crate::scene::Medium,
    Vec<crate::media::HeteroMedium>,
    Vec<crate::scene::Surface>,
);

/// [`light`] kept between renders of scenes that differ in their camera or lights only
/// (the viewer's frames).
#[derive(Debug, Default)]
pub struct Cache(std::sync::Mutex<Option<(Key, EnvLight)>>);

impl Cache {
    /// [`light`] of `scene`, computed again only when what it depends on changed.
    pub fn light(&self, scene: &Scene) -> EnvLight {
        let key: Key = (
            scene.environment.clone(),
            scene.environment_distance,
            scene.medium.clone(),
            scene.hetero.clone(),
            scene.surfaces.clone(),
        );
        let mut slot = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((k, l)) = slot.as_ref()
            && *k == key
        {
            return l.clone();
        }
        let l = light(scene);
        *slot = Some((key, l.clone()));
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_pcg::Pcg64;
    use std::f64::consts::PI;

    /// The bundled plume under a sky, half its size, with a fog around it.
    fn plume_scene() -> Scene {
        let text = r#"{"camera": {"eye": [0.3, -4.0, 1.5], "target": [0, 0, 0.8], "fov": 30,
                        "width": 12, "height": 9},
            "environment": "sky",
            "lights": [],
            "media": [{"type": "asset", "path": "plume.haze", "frame": 24, "sigma_t": 8,
                        "albedo": 0.9, "g": 0.5, "offset": [-0.75, -0.75, 0.1], "scale": 0.5}],
            "surfaces": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1],
                          "material": {"diffuse": [0.6, 0.58, 0.55]}}]}"#;
        let base = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/scenes");
        crate::file::parse_in(text, &base).unwrap()
    }

    /// The nodes left out are never read: wherever the plume scatters, the grid gives what
    /// the grid of every node gives, to the bit; and it leaves out most of them.
    #[test]
    fn the_nodes_left_out_are_never_read() {
        let scene = plume_scene();
        let opt = EnvOptions {
            nodes: 12,
            ..EnvOptions::default()
        };
        let some = EnvGrid::build(&scene, &opt).unwrap();
        let all = EnvGrid::build_nodes(&scene, &opt, false).unwrap();
        let zero = some.coeffs.chunks(3 * sh::count(opt.order));
        let skipped = zero
            .zip(all.coeffs.chunks(3 * sh::count(opt.order)))
            .filter(|(a, b)| a.iter().all(|&v| v == 0.0) && b.iter().any(|&v| v != 0.0))
            .count();
        assert!(skipped > 12 * 12 * 12 / 10, "{skipped} nodes left out");
        let b = scene.hetero[0].bounds().unwrap();
        let (mut rng, mut lit) = (Pcg64::seed_from_u64(7), 0);
        for _ in 0..20_000 {
            let mut r = || rng.random::<f64>();
            let x: Vec3 = [0, 1, 2].map(|a| b.min[a] + r() * (b.max[a] - b.min[a]));
            let Some(dir) = crate::vec3::normalize([r() - 0.5, r() - 0.5, r() - 0.5]) else {
                continue;
            };
            if scatterers(&scene, x).is_empty() {
                continue;
            }
            lit += 1;
            assert_eq!(
                some.in_scattered(&scene, x, dir),
                all.in_scattered(&scene, x, dir),
                "{x:?}"
            );
        }
        assert!(lit > 1000, "{lit} points in the smoke");
    }

    #[test]
    fn the_rule_integrates_low_order_polynomials() {
        // ∫ 1 = 4π, ∫ z² = 4π/3, ∫ x²y² = 4π/15 (exact for the product rule of degree
        // 2n−1 in z and 2n−1 in φ).
        let r = directions(6);
        let s = |f: &dyn Fn(Vec3) -> f64| r.iter().map(|(w, wt)| wt * f(*w)).sum::<f64>();
        assert!((s(&|_| 1.0) - 4.0 * PI).abs() < 1e-12);
        assert!((s(&|w| w[2] * w[2]) - 4.0 * PI / 3.0).abs() < 1e-12);
        assert!((s(&|w| w[0] * w[0] * w[1] * w[1]) - 4.0 * PI / 15.0).abs() < 1e-12);
    }
}
