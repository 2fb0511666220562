//! A point light in the smoke: what the grids cannot follow.
//!
//! Voxel centres holding a point light's `I/r²`, interpolated between them by the view
//! pass, cannot follow its peak within a few voxels of its position `s`: a view ray
//! passing at `h ≪` a voxel from the light should gather `∫ dt/(h² + t²) = π/h` there
//! and would gather what the neighbouring centres hold; the multiple scattering's cells
//! ([`super::grid_diffusion`]) likewise take the light at their centres. Where smoke
//! surrounds the light, much of its first scattering happens in that neighbourhood.
//!
//! **The split.** The grids hold what they can follow: the lights pass gives a voxel
//! centre `I·min(1/r², 1/R²)` ([`NEAR_RADIUS_VOXELS`]: `R` four smallest voxel sides),
//! flat inside the sphere of radius `R` about the light. The view pass adds the rest,
//! `I·(1/r² − 1/R²)` inside that sphere, at each step of its ray ([`NearLights`]): with
//! `h` the ray's distance from the light, `u` the distance along the ray from its foot
//! and `φ = atan(u/h)` the angle seen from the light, `du/r² = dφ/h` and `r = h/cos φ`,
//! so the step's part of the chord `|u| < √(R² − h²)` gives
//! `(1/h)∫ p(−sin φ)(1 − h²/(R² cos² φ)) dφ` (`−sin φ` the scattering angle's cosine:
//! forward before the light, backward past it), by Gauss–Legendre ([`NODES`]); times
//! the step's density and the light's transmittance at the step's middle (a march of
//! at most `R`). With an isotropic phase it is `atan(u/h)/h − u/R²` between the step's
//! ends. A ray passing at `h ≪ R` gathers `π/h`, infinite for a ray through the light:
//! `h` is floored at a sixteenth of the pixel's side at the light's depth. Like the rest
//! of the view pass (and the reference), a pixel is its central ray, so the pixel
//! nearest the light's image holds the spike as that ray meets it. The multiple
//! scattering's cells beside the light take their own mean of `T/r²`
//! ([`super::grid_diffusion::near_light_mean`]).
//!
//! **The measure.** [`near_share`]: the light's first scatterings within
//! [`NEAR_VOXELS`] smallest voxel sides of it, as a share of all its first scatterings.
//! Along a direction `ω` from the light, a first scattering happens before distance `r`
//! with probability `1 − e^{−τ(r)}`, `τ` the optical depth `σt∫₀^r D(s + tω)dt` (the
//! shadow march of [`super::lights_pass::optical_depth`]); a point light sends the same
//! power every way, so the share is `Σ_ω (1 − e^{−τ_ω(ρ)}) / Σ_ω (1 − e^{−τ_ω(∞)})` over
//! [`DIRECTIONS`] Fibonacci directions (`ρ` that radius, `τ(∞)` to the box's face). 0 for
//! a light whose rays meet no smoke.
//!
//! **Measured** (BENCHMARKS "A point light in the smoke": the bundled sample's first
//! frame and held-out plume-d, σt 4, albedo 0.8, g 0.3, against `--reference`). Before
//! the split, a light in the stem (share 0.37) left single scattering 36 % RMS off (0.89×
//! the mean) and the final image 34 % (0.82×, the multiple scattering's cells smoothing
//! the same peak); after it and the cells' mean of `T/r²`
//! ([`super::grid_diffusion::near_light_mean`]), single scattering is within the
//! reference's noise but for 7 % in the stem, and the final image 8–22 % with the noise
//! taken out where the share is 3–41 %, its mean within 6 %. [`describe`] warns above
//! [`NEAR_SHARE_WARNING`].

use super::grid_diffusion::fibonacci_directions;
use super::lights_pass::optical_depth;
use super::occupancy::Occupancy;
use crate::Camera;
use crate::lights::{PointLight, dot};
use crate::medium::{FOUR_PI, Medium, hg};
use haze_volume::Volume;
use rayon::prelude::*;

/// The radius `R` of the sphere about a point light, in smallest voxel sides, inside
/// which the grids hold its `1/r²` at `1/R²` and the view pass adds the rest (module
/// docs). Beyond it the grids carry the light between voxel centres, its `ln(1/r²)` to
/// within `h²/(4r²)` (1.6 % at four voxels) and its phase function as well as a voxel
/// seen from the light resolves it: against the integral along each ray
/// (`tests/crm.rs`, g 0.3) two, three, four and six voxels give 4.0, 2.3, 1.8 and 1.4 %
/// RMS; at g 0.6, 11, 6.7, 4.6 and 2.8 %. Its cost grows with the rays that cross the
/// sphere and their steps in it (BENCHMARKS "A point light in the smoke": a lamp inside
/// a 96³-class frame adds a third to the view pass at 800 × 600).
pub const NEAR_RADIUS_VOXELS: f64 = 4.0;

/// The radius, in smallest voxel sides, within which the grids smooth a point light's
/// `1/r²` away (a voxel's interpolation on each side of the light, and half a voxel of
/// the lights pass's ball).
pub const NEAR_VOXELS: f64 = 1.5;

/// Directions from the light the share is summed over.
pub const DIRECTIONS: usize = 256;

/// The share of a point light's first scattering near it above which the renderers warn
/// ([`describe`]).
pub const NEAR_SHARE_WARNING: f64 = 0.01;

/// The share of the first scatterings of a point light at `light` that happen within
/// [`NEAR_VOXELS`] smallest voxel sides of it, through `density` at extinction
/// `sigma_t` (module docs). 0 for an empty grid, a zero or non-finite `σt` or a light
/// whose rays meet no smoke.
pub fn near_share(density: &Volume, sigma_t: f64, light: [f64; 3]) -> f64 {
    if !(sigma_t.is_finite() && sigma_t > 0.0) || light.iter().any(|c| !c.is_finite()) {
        return 0.0;
    }
    if Occupancy::new(density).is_none() {
        return 0.0;
    }
    let vs = density.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let radius = NEAR_VOXELS * h0;
    // The march's step: half a voxel, so the near part takes three samples at least.
    let step = 0.5 * h0;
    let each: Vec<(f64, f64)> = fibonacci_directions(DIRECTIONS)
        .par_iter()
        .map(|&w| {
            let scattered =
                |len: f64| -(-optical_depth(density, sigma_t, light, w, len, step)).exp_m1();
            (scattered(radius), scattered(f64::INFINITY))
        })
        .collect();
    // Summed in order, so the same light in the same smoke gives the same share.
    let (near, all) = each.iter().fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    // Below a millionth of the light scattered at all (per direction, on average) the
    // smoke is not lit by it: nothing to smooth.
    if all <= 1e-6 * DIRECTIONS as f64 {
        0.0
    } else {
        (near / all).clamp(0.0, 1.0)
    }
}

/// The point lights' light inside their spheres of radius `R`, which the view pass adds
/// along its rays (module docs, "The split").
#[derive(Debug)]
pub struct NearLights<'a> {
    lights: Vec<PointLight>,
    density: &'a Volume,
    /// `R`.
    radius: f64,
    /// The shadow march's step, the smallest voxel side.
    h0: f64,
    sigma_t: f64,
    /// `Ω/4π`.
    k: f64,
    g: f64,
    /// The camera's forward axis.
    forward: [f64; 3],
    /// A pixel's side per unit of depth along `forward`, `2·tan(fov/2)/height`.
    pixel: f64,
    /// [`NODES`] Gauss–Legendre nodes and weights on `[−1, 1]`.
    nodes: Vec<(f64, f64)>,
}

/// Where a ray crosses a light's sphere: the light, the foot's distance along the ray,
/// the ray's distance from the light (floored), and the chord's half-length.
#[derive(Clone, Copy, Debug)]
pub struct Crossing {
    light: usize,
    foot: f64,
    h: f64,
    half_chord: f64,
}

impl<'a> NearLights<'a> {
    /// The near parts of `lights` in `density`'s grid (the one the view pass marches),
    /// seen through `camera`'s pixels.
    pub fn new(
        lights: &[PointLight],
        density: &'a Volume,
        medium: &Medium,
        camera: &Camera,
    ) -> NearLights<'a> {
        let vs = density.voxel_size();
        let h0 = vs[0].min(vs[1]).min(vs[2]);
        let usable = medium.albedo > 0.0 && h0 > 0.0 && h0.is_finite();
        NearLights {
            lights: if usable { lights.to_vec() } else { Vec::new() },
            density,
            radius: NEAR_RADIUS_VOXELS * h0,
            h0,
            sigma_t: medium.sigma_t,
            k: medium.albedo / FOUR_PI,
            g: medium.g,
            forward: camera.forward(),
            pixel: 2.0 * camera.tan_half() / camera.height.max(1) as f64,
            nodes: crate::sh::quad::gauss_legendre(NODES),
        }
    }

    /// `R²`, the grids' floor under `r²` ([`super::lights_pass`]).
    pub fn radius2(h0: f64) -> f64 {
        (NEAR_RADIUS_VOXELS * h0).powi(2)
    }

    /// The spheres the ray from `eye` (the camera's) along unit `d` (a pixel's central
    /// ray) crosses (none allocates nothing).
    pub fn crossings(&self, eye: [f64; 3], d: [f64; 3]) -> Vec<Crossing> {
        let mut out = Vec::new();
        let r2 = self.radius * self.radius;
        for (light, l) in self.lights.iter().enumerate() {
            let v = [0, 1, 2].map(|a| l.position[a] - eye[a]);
            let foot = dot(v, d);
            let miss = [0, 1, 2].map(|a| v[a] - foot * d[a]);
            let mut h = dot(miss, miss).sqrt();
            if !(h < self.radius && foot + self.radius > 0.0) {
                continue;
            }
            // A ray through the light itself gathers an infinite `π/h`: floored at a
            // sixteenth of the pixel's side at the light (module docs).
            let side = self.pixel * dot(v, self.forward).max(0.0);
            h = h.max(side / 16.0).max(1e-9 * self.radius);
            if h < self.radius {
                out.push(Crossing {
                    light,
                    foot,
                    h,
                    half_chord: (r2 - h * h).max(0.0).sqrt(),
                });
            }
        }
        out
    }

    /// The near light at the step `[t − ds/2, t + ds/2]` of the ray from `eye` along
    /// unit `d`, per unit of the step's optical depth: `Σ Ω/4π·p·I·T·∫(1/r² − 1/R²)dt / ds` over
    /// the `crossings`, to be added to the grids' `J̃` there.
    pub fn at_step(
        &self,
        crossings: &[Crossing],
        eye: [f64; 3],
        d: [f64; 3],
        t: f64,
        ds: f64,
    ) -> [f64; 3] {
        let mut out = [0.0; 3];
        for c in crossings {
            let lo = (t - 0.5 * ds - c.foot).max(-c.half_chord);
            let hi = (t + 0.5 * ds - c.foot).min(c.half_chord);
            if hi <= lo || ds.is_nan() || ds <= 0.0 {
                continue;
            }
            let light = &self.lights[c.light];
            let x = [0, 1, 2].map(|a| eye[a] + t * d[a]);
            let v = [0, 1, 2].map(|a| light.position[a] - x[a]);
            let r = dot(v, v).sqrt();
            let tr = if r > 0.0 {
                let s = v.map(|c| c / r);
                (-optical_depth(self.density, self.sigma_t, x, s, r, self.h0)).exp()
            } else {
                1.0
            };
            let integral = self.chord_integral(c.h, lo, hi);
            let w = self.k * tr * integral / ds;
            for (o, i) in out.iter_mut().zip(light.intensity) {
                *o += w * i;
            }
        }
        out
    }

    /// `∫ p(cos θ)(1/r² − 1/R²) du` over `u ∈ [lo, hi]` of a ray passing at `h` from the
    /// light, `u` from the foot: in the angle `φ = atan(u/h)` seen from the light, `du/r²
    /// = dφ/h`, `r = h/cos φ` and the scattering angle's cosine `−sin φ`, so it is
    /// `(1/h)∫ p(−sin φ)(1 − h²/(R² cos² φ)) dφ`, by [`NODES`]-point Gauss–Legendre
    /// (the phase function changes from forward to backward as the ray passes the light).
    fn chord_integral(&self, h: f64, lo: f64, hi: f64) -> f64 {
        let (a, b) = ((lo / h).atan(), (hi / h).atan());
        let (mid, half) = (0.5 * (a + b), 0.5 * (b - a));
        let r2 = self.radius * self.radius;
        let sum: f64 = self
            .nodes
            .iter()
            .map(|&(x, w)| {
                let phi = mid + half * x;
                let (sin, cos) = phi.sin_cos();
                let flat = (1.0 - h * h / (r2 * cos * cos)).max(0.0);
                w * hg(self.g, -sin) * flat
            })
            .sum();
        (sum * half / h).max(0.0)
    }
}

/// Gauss–Legendre nodes a step of a chord takes in the angle seen from the light: over
/// the view pass's steps, within 10⁻⁸ of the closed form (isotropic) and of a 256-node
/// rule (HG up to g 0.9; test `chord_integrals_match_closed_form_and_a_finer_rule`).
pub const NODES: usize = 6;

/// What `-v` says of point light number `index` (from 1) at `light` whose
/// [`near_share`] is `share`, and whether it is a warning (above
/// [`NEAR_SHARE_WARNING`]).
pub fn describe(index: usize, light: [f64; 3], share: f64) -> (String, bool) {
    let at = format!(
        "point light {index} at ({}, {}, {})",
        haze_core::number::shown(light[0]),
        haze_core::number::shown(light[1]),
        haze_core::number::shown(light[2])
    );
    let percent = 100.0 * share;
    if share > NEAR_SHARE_WARNING {
        (
            format!(
                "{at} sits in the smoke: {percent:.0} % of its first scattering happens within {NEAR_VOXELS} voxels of it, where the fast renderer's multiple scattering follows its light only cell by cell, so the smoke around it is approximate (lights with 3-41 % there: 8-22 % off the path tracer); `haze render --reference` renders it exactly"
            ),
            true,
        )
    } else {
        (
            format!(
                "{at}: {percent:.1} % of its first scattering within {NEAR_VOXELS} voxels of it"
            ),
            false,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Camera;
    use haze_volume::Bbox;

    /// A cube of `n³` unit voxels of density `d`.
    fn cube(n: usize, d: f32) -> Volume {
        let side = n as f64;
        Volume::new([n; 3], Bbox::new([0.0; 3], [side; 3]), vec![d; n * n * n]).unwrap()
    }

    /// In uniform smoke deep enough that every direction's march reaches the cut-off, the
    /// share is the closed form `1 − e^{−μR}` (`μ = σt·D`, `R` = 1.5 voxels: three
    /// midpoint steps of a constant density, exact).
    #[test]
    fn uniform_smoke_gives_the_closed_form() {
        let v = cube(40, 1.0);
        for mu in [0.5f64, 1.0, 3.0] {
            let share = near_share(&v, mu, [20.0; 3]);
            let exact = -(-mu * NEAR_VOXELS).exp_m1();
            // Each direction's far sum is 1 − e^{−τ}, τ past the cut-off (20) or, at
            // μ = 0.5, the 20–35 voxels to the faces (τ ≥ 10): within 5·10⁻⁵ of 1.
            assert!(
                (share - exact).abs() < 5e-5 * exact,
                "μ {mu}: {share} vs {exact}"
            );
        }
    }

    /// A light outside the smoke, or no smoke, or no extinction: nothing near it.
    #[test]
    fn lights_away_from_smoke_and_degenerate_input_give_zero() {
        let mut data = vec![0.0f32; 32 * 32 * 32];
        // A slab of smoke at x ∈ [20, 24).
        for z in 0..32 {
            for y in 0..32 {
                for x in 20..24 {
                    data[(z * 32 + y) * 32 + x] = 2.0;
                }
            }
        }
        let slab = Volume::new([32; 3], Bbox::new([0.0; 3], [32.0; 3]), data).unwrap();
        assert_eq!(near_share(&slab, 1.0, [5.0, 16.0, 16.0]), 0.0);
        // Beside the slab's face (its trilinear density reaches half a voxel out) and
        // inside it.
        let beside = near_share(&slab, 1.0, [18.5, 16.0, 16.0]);
        let inside = near_share(&slab, 1.0, [22.0, 16.0, 16.0]);
        assert!(
            0.0 < beside && beside < inside && inside < 1.0,
            "{beside} {inside}"
        );
        assert_eq!(near_share(&cube(8, 0.0), 1.0, [4.0; 3]), 0.0);
        for sigma_t in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(near_share(&cube(8, 1.0), sigma_t, [4.0; 3]), 0.0);
        }
        assert_eq!(near_share(&cube(8, 1.0), 1.0, [f64::NAN, 4.0, 4.0]), 0.0);
        // A light far outside the box, on a line through it.
        assert_eq!(near_share(&cube(8, 1.0), 1.0, [1e300, 4.0, 4.0]), 0.0);
    }

    /// A camera and near lights in a cube of `n³` unit voxels of density 1.
    fn near<'a>(v: &'a Volume, g: f64, sigma_t: f64, light: [f64; 3]) -> NearLights<'a> {
        let cam = Camera::new([-30.0, 4.0, 4.0], light, [0.0, 0.0, 1.0], 40.0, 64, 48).unwrap();
        let medium = Medium::new(sigma_t, 0.9, g).unwrap();
        NearLights::new(
            &[PointLight::new(light, [2.0; 3]).unwrap()],
            v,
            &medium,
            &cam,
        )
    }

    /// The chord's integral by the view pass's steps (half a voxel, an eighth of `R`,
    /// the steps' edges off the foot by a third of a step) against its closed form for an
    /// isotropic phase function, `atan(u/h)/h − u/R²` between the chord's ends, and
    /// against a 256-node rule on the same steps for HG, for rays from a tenth of `R` to
    /// `R` from the light. Measured at most 1.1·10⁻⁸ relative (g 0.9); bound 10⁻⁶.
    #[test]
    fn chord_integrals_match_closed_form_and_a_finer_rule() {
        let v = cube(16, 1.0);
        for g in [0.0, 0.3, 0.6, 0.9] {
            let n = near(&v, g, 1.0, [8.0; 3]);
            let fine = NearLights {
                nodes: crate::sh::quad::gauss_legendre(256),
                ..near(&v, g, 1.0, [8.0; 3])
            };
            let r = n.radius;
            let ds = r / 8.0;
            let mut worst = 0.0f64;
            for h in [0.1 * r, 0.3 * r, 0.7 * r, 0.99 * r] {
                let w = (r * r - h * h).sqrt();
                let (mut got, mut finer) = (0.0, 0.0);
                let mut lo = -w;
                let mut next = -w + (ds / 3.0 + (w / ds).fract() * ds) % ds;
                while lo < w {
                    let hi = next.min(w);
                    got += n.chord_integral(h, lo, hi);
                    finer += fine.chord_integral(h, lo, hi);
                    lo = hi;
                    next = hi + ds;
                }
                let want = if g == 0.0 {
                    let f = |u: f64| (u / h).atan() / h - u / (r * r);
                    f(w) - f(-w)
                } else {
                    finer
                };
                let e = (got / want - 1.0).abs();
                worst = worst.max(e);
                assert!(e < 1e-6, "g {g}, h {:.2} R: {got} vs {want}", h / r);
            }
            println!("g {g}: worst {worst:.1e}");
        }
    }

    /// The extremes: a ray through the light itself (its distance floored at a sixteenth
    /// of a pixel), a step whose middle is the light, a zero-length step, smoke so dense
    /// the light's transmittance underflows, a light outside the box, and a ray that
    /// misses the sphere: finite, non-negative, zero where nothing is near.
    #[test]
    fn the_near_light_stays_finite_at_its_extremes() {
        let v = cube(16, 1.0);
        let light = [8.0; 3];
        let eye = [-30.0, 4.0, 4.0];
        let d = {
            let w = [0, 1, 2].map(|a| light[a] - eye[a]);
            let l = dot(w, w).sqrt();
            w.map(|c| c / l)
        };
        let foot = dot([0, 1, 2].map(|a| light[a] - eye[a]), d);
        for sigma_t in [1.0, 1e6] {
            let n = near(&v, 0.3, sigma_t, light);
            let c = n.crossings(eye, d);
            assert_eq!(c.len(), 1);
            assert!(c[0].h > 0.0 && c[0].h.is_finite());
            for (t, ds) in [
                (foot, 0.5),
                (foot + 0.25, 0.5),
                (foot, 0.0),
                (foot - 3.0, 0.5),
            ] {
                let j = n.at_step(&c, eye, d, t, ds);
                assert!(j.iter().all(|x| x.is_finite() && *x >= 0.0), "{j:?}");
                if ds == 0.0 || t < foot - n.radius - ds {
                    assert_eq!(j, [0.0; 3]);
                }
            }
            if sigma_t == 1.0 {
                assert!(n.at_step(&c, eye, d, foot + 0.25, 0.5)[0] > 0.0);
            }
        }
        // A light outside the box and a ray that passes it by.
        let n = near(&v, 0.3, 1.0, [40.0, 8.0, 8.0]);
        assert!(n.crossings(eye, [0.0, 1.0, 0.0]).is_empty());
    }

    #[test]
    fn the_warning_names_the_light_and_its_share() {
        let (w, warn) = describe(2, [1.5, 1.5, 1.2], 0.37);
        assert!(warn);
        assert!(
            w.starts_with("point light 2 at (1.5, 1.5, 1.2) sits in the smoke: 37 %"),
            "{w}"
        );
        let (said, warn) = describe(1, [0.0, 1e300, -3.0], 0.004);
        assert!(!warn);
        assert_eq!(
            said,
            "point light 1 at (0, 1e300, -3): 0.4 % of its first scattering within 1.5 voxels of it"
        );
    }
}
