//! The fast renderer (paper A §5.3–5.5) against independent computations: the
//! single-scattering source at an RBF center against a direct spherical quadrature of its
//! definition, whole images against the reference renderer, and the extremes.

use haze_view::lighting::single::{RgbSh, ShKit, SourcePoints, single_scattering};
use haze_view::medium::hg;
use haze_view::reference::{self, RefOptions, rbf_volume, smoke_pixels};
use haze_view::render::env_pass::EnvSource;
use haze_view::render::{CrmOptions, crm_render};
use haze_view::sh::{self, ExpMethod, quad::SphereGrid, quad::gauss_legendre};
use haze_view::{Camera, Environment, Image, LatLong, Medium, PointLight, Sky, Sun};
use haze_volume::{Bbox, Rbf};
use std::f64::consts::PI;

mod common;
use common::{cluster, front_camera, unit_box};

/// `∫₀^∞ Σ B_h(x + sω) ds` by 32-point Gauss–Legendre on each RBF's chord through its
/// support sphere (the cut-off at 3r is where the integrand jumps, so each piece is
/// smooth): independent of the closed form behind the ZH table.
fn optical_depth(rbfs: &[Rbf], x: [f64; 3], w: [f64; 3]) -> f64 {
    let gl = gauss_legendre(32);
    let mut sum = 0.0;
    for h in rbfs {
        let s = h.support_radius();
        let oc = [0, 1, 2].map(|a| x[a] - h.center[a]);
        let b = oc[0] * w[0] + oc[1] * w[1] + oc[2] * w[2];
        let c = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - s * s;
        let disc = b * b - c;
        if disc <= 0.0 {
            continue;
        }
        let (t0, t1) = ((-b - disc.sqrt()).max(0.0), -b + disc.sqrt());
        if t1 <= t0 {
            continue;
        }
        let (mid, half) = (0.5 * (t0 + t1), 0.5 * (t1 - t0));
        for &(u, wt) in &gl {
            let t = mid + half * u;
            sum += half * wt * h.eval([x[0] + t * w[0], x[1] + t * w[1], x[2] + t * w[2]]);
        }
    }
    sum
}

/// The single-scattering source at `x` seen along `d`, straight from its definition
/// `J(x, d) = (Ω/4π) ∫ L(ω) τ(x, ω) p(ω·d) dω` on a 64 × 128 product grid.
fn source_by_quadrature(
    rbfs: &[Rbf],
    medium: &Medium,
    light: impl Fn([f64; 3]) -> f64,
    x: [f64; 3],
    dirs: &[[f64; 3]],
) -> Vec<f64> {
    let grid = SphereGrid::new(64, 128);
    let lit: Vec<([f64; 3], f64)> = grid
        .points()
        .map(|(w, wt)| {
            let tau = (-medium.sigma_t * optical_depth(rbfs, x, w)).exp();
            (w, wt * light(w) * tau)
        })
        .collect();
    dirs.iter()
        .map(|d| {
            let s: f64 = lit
                .iter()
                .map(|(w, lt)| lt * hg(medium.g, w[0] * d[0] + w[1] * d[1] + w[2] * d[2]))
                .sum();
            medium.albedo / (4.0 * PI) * s
        })
        .collect()
}

fn fibonacci_sphere(n: usize) -> Vec<[f64; 3]> {
    let golden = PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - (2 * i + 1) as f64 / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            [r * phi.cos(), r * phi.sin(), z]
        })
        .collect()
}

/// Relative L2 error over `dirs` of the SH source of center `k` against quadrature, for a
/// band-1 light `L(ω) = 1 + 0.6 ω_z + 0.3 ω_x` (exact in SH, so what is measured is the
/// transmittance and phase machinery).
fn single_scattering_error(order: usize, medium: &Medium, k: usize) -> f64 {
    let rbfs = cluster(&unit_box());
    let light_fn = |w: [f64; 3]| 1.0 + 0.6 * w[2] + 0.3 * w[0];
    let mut l = vec![0.0; order * order];
    l[0] = (4.0 * PI).sqrt();
    if order > 1 {
        let b1 = (4.0 * PI / 3.0).sqrt();
        l[2] = 0.6 * b1; // z
        l[3] = 0.3 * b1; // x
    }
    let light: RgbSh = [l.clone(), l.clone(), l];
    let kit = ShKit::new(order);
    let j = single_scattering(
        &kit,
        &rbfs,
        medium,
        &light,
        ExpMethod::ScaleSquareAuto,
        SourcePoints::Center,
    )
    .source;
    let dirs = fibonacci_sphere(200);
    let truth = source_by_quadrature(&rbfs, medium, light_fn, rbfs[k].center, &dirs);
    let (mut num, mut den) = (0.0, 0.0);
    for (d, t) in dirs.iter().zip(&truth) {
        let v = sh::reconstruct(&j[k][0], *d);
        num += (v - t).powi(2);
        den += t * t;
    }
    (num / den).sqrt()
}

#[test]
fn single_scattering_at_centers_matches_quadrature() {
    // σt = 3: optical depths from the centers up to ≈ 0.6, ‖f̂‖ ≈ 0.5, where the exp*
    // table (BENCHMARKS.md) gives < 1e-3; what remains is the truncation of τ and of the
    // phase function to `order` bands, which must fall with the order.
    let medium = Medium::new(3.0, 0.9, 0.3).unwrap();
    for k in [0, 3, 4] {
        let e: Vec<f64> = [2, 4, 6]
            .iter()
            .map(|&n| single_scattering_error(n, &medium, k))
            .collect();
        println!("center {k}: rel L2 at orders 2, 4, 6: {e:?}");
        assert!(e[2] < 0.01, "center {k}, order 6: {e:?}");
        assert!(e[1] < 0.03, "center {k}, order 4: {e:?}");
        assert!(
            e[2] < e[0],
            "center {k}: no convergence with the order: {e:?}"
        );
    }
}

#[test]
fn single_scattering_in_thick_smoke_and_strong_phase() {
    // σt = 40: optical depths to ≈ 8 (‖f̂‖ ≈ 5), the regime where the optimal linear
    // exp* fails; scaling and squaring keeps the source within 10 % at order 6 (the
    // exp* table's 6 % at ‖f̂‖ = 4 plus truncation).
    let medium = Medium::new(40.0, 0.9, 0.6).unwrap();
    let e = single_scattering_error(6, &medium, 0);
    println!("thick smoke, order 6: rel L2 {e:.4}");
    assert!(e < 0.10, "{e}");
}

fn constant_env(c: f32) -> Environment {
    Environment::map(LatLong::new(8, 4, vec![[c; 3]; 32]).unwrap())
}

/// The volume-pass grids of `volume` lit by `env`'s suns and point lights alone (no
/// environment source): zero radiance, then the lights pass.
fn lit_by_lights(
    volume: &haze_volume::Volume,
    env: &Environment,
    medium: &Medium,
    eye: [f64; 3],
) -> haze_view::render::crm::VolumeGrids {
    let mut grids = haze_view::render::crm::VolumeGrids {
        density: volume.clone(),
        radiance: vec![[0.0; 3]; volume.data().len()],
        eye_peak: 0.0,
    };
    haze_view::render::lights_pass::lights_pass(&mut grids, env, medium, eye);
    grids
}

/// `rel_rms` over the pixels whose ray meets the smoke (`mask`).
fn masked_rel_rms(a: &Image, reference: &Image, mask: &[bool]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((p, q), m) in a.pixels.iter().zip(&reference.pixels).zip(mask) {
        if *m {
            for c in 0..3 {
                num += f64::from(p[c] - q[c]).powi(2);
                den += f64::from(q[c]).powi(2);
            }
        }
    }
    (num / den.max(1e-300)).sqrt()
}

/// Pixels where the smoke blocks at least 2 % of the background (from an albedo-0
/// reference render under a constant environment: exactly the transmittance).
fn smoke_mask(volume: &haze_volume::Volume, sigma_t: f64, cam: &Camera) -> Vec<bool> {
    let medium = Medium::new(sigma_t, 0.0, 0.0).unwrap();
    let opts = RefOptions {
        spp: 1,
        multiple: false,
        ..RefOptions::default()
    };
    let t = reference::render(volume, &medium, &constant_env(1.0), cam, &opts);
    t.pixels.iter().map(|p| p[0] < 0.98).collect()
}

fn crm(rbfs: &[Rbf], medium: &Medium, env: &Environment, cam: &Camera, opts: CrmOptions) -> Image {
    crm_render(rbfs, None, [32; 3], &unit_box(), medium, env, cam, &opts).0
}

/// Paper A Fig. 6 reports 4.3 % (single scattering) and 13.8 % (single + multiple) against
/// ray tracing on its smoke. On this scene (peak optical depth ≈ 3) the measured errors
/// are 4.5 % and ≈ 5 % (bias ≈ 3 % under ≈ 4 % reference noise at 512 paths); the bounds
/// are the paper's figures with room for the reference noise. Before the diffusion's
/// vacuum correction, multiple scattering was off by more than 100 % on plume-a.
#[test]
fn crm_matches_the_reference_on_an_rbf_scene() {
    let rbfs = cluster(&unit_box());
    let volume = rbf_volume(&rbfs, [32; 3], unit_box()).unwrap();
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    let env = Environment::sky(Sky::default());
    let cam = front_camera(48, 36);
    let mask = smoke_mask(&volume, medium.sigma_t, &cam);
    assert!(mask.iter().filter(|m| **m).count() > 100);
    let reference = |multiple: bool, spp: u32| {
        let opts = RefOptions {
            spp,
            multiple,
            ..RefOptions::default()
        };
        reference::render(&volume, &medium, &env, &cam, &opts)
    };
    let single = crm(
        &rbfs,
        &medium,
        &env,
        &cam,
        CrmOptions {
            multiple: false,
            ..CrmOptions::default()
        },
    );
    let e_single = masked_rel_rms(&single, &reference(false, 256), &mask);
    let multi = crm(&rbfs, &medium, &env, &cam, CrmOptions::default());
    let e_multi = masked_rel_rms(&multi, &reference(true, 512), &mask);
    println!("rel RMS on smoke pixels: single {e_single:.4}, single + multiple {e_multi:.4}");
    assert!(e_single < 0.06, "single scattering: {e_single}");
    assert!(e_multi < 0.10, "single + multiple scattering: {e_multi}");
    // The paper's choice of source points is within its own figure too.
    let center = CrmOptions {
        multiple: false,
        source_points: SourcePoints::Center,
        env_source: EnvSource::Centers,
        ..CrmOptions::default()
    };
    let e_center = masked_rel_rms(
        &crm(&rbfs, &medium, &env, &cam, center),
        &reference(false, 256),
        &mask,
    );
    assert!(
        e_center < 0.09 && e_single < e_center,
        "{e_center} vs {e_single}"
    );
}

fn finite_nonnegative(img: &Image) -> bool {
    img.pixels
        .iter()
        .all(|p| p.iter().all(|c| c.is_finite() && *c >= 0.0))
}

#[test]
fn no_extinction_shows_the_background_exactly() {
    let env = Environment::sky(Sky::default());
    let cam = front_camera(24, 18);
    let medium = Medium::new(0.0, 0.8, 0.3).unwrap();
    for rbfs in [cluster(&unit_box()), Vec::new()] {
        let img = crm(&rbfs, &medium, &env, &cam, CrmOptions::default());
        for (i, p) in img.pixels.iter().enumerate() {
            let b = env.radiance(cam.pixel_ray(i % 24, i / 24));
            assert_eq!(*p, b.map(|c| c as f32), "pixel {i}");
        }
    }
    // No RBFs at all, with extinction: nothing to scatter or block.
    let thick = Medium::new(50.0, 0.8, 0.3).unwrap();
    let img = crm(&[], &thick, &env, &cam, CrmOptions::default());
    let b = env.radiance(cam.pixel_ray(12, 9));
    assert_eq!(img.get(12, 9), b.map(|c| c as f32));
}

#[test]
fn albedo_zero_is_the_exact_transmittance() {
    // Without scattering the image is T·L_env; the reference integrates the optical depth
    // of the same trilinear field exactly, the view pass with half-voxel slices (midpoint
    // rule, error O(Δu²)): measured 2e-4.
    let rbfs = cluster(&unit_box());
    let volume = rbf_volume(&rbfs, [32; 3], unit_box()).unwrap();
    let env = Environment::sky(Sky::default());
    let cam = front_camera(32, 24);
    for sigma_t in [4.0, 12.0] {
        let medium = Medium::new(sigma_t, 0.0, 0.0).unwrap();
        let opts = RefOptions {
            spp: 1,
            multiple: false,
            ..RefOptions::default()
        };
        let r = reference::render(&volume, &medium, &env, &cam, &opts);
        let c = crm(&rbfs, &medium, &env, &cam, CrmOptions::default());
        let e = c.rel_rms(&r);
        assert!(e < 2e-3, "σt {sigma_t}: {e}");
    }
}

#[test]
fn huge_extinction_is_opaque_and_finite() {
    let rbfs = cluster(&unit_box());
    let env = Environment::sky(Sky::default());
    let cam = front_camera(24, 18);
    let medium = Medium::new(1e6, 0.9, 0.3).unwrap();
    for order in [1, 4] {
        let opts = CrmOptions {
            order,
            ..CrmOptions::default()
        };
        let img = crm(&rbfs, &medium, &env, &cam, opts);
        assert!(finite_nonnegative(&img));
        // The center pixel looks into the core: the background is blocked and the smoke's
        // own light (single scattering of its lit surface, plus the diffusion's) is
        // bounded by the brightest sky radiance.
        let brightest = SphereGrid::new(32, 64)
            .points()
            .fold([0.0f64; 3], |m, (d, _)| {
                let l = env.radiance(d);
                [0, 1, 2].map(|c| m[c].max(l[c]))
            });
        let p = img.get(12, 9);
        assert!(
            p.iter().zip(brightest).all(|(p, b)| f64::from(*p) < b),
            "{p:?} vs {brightest:?}"
        );
    }
}

#[test]
fn strong_phase_functions_keep_their_direction() {
    // Looking towards the sun through thin smoke, forward scattering (g = 0.95) is
    // brighter than back scattering (g = −0.95); looking away from it, the opposite.
    let rbfs = cluster(&unit_box());
    let sky = Sky::default();
    let s = sky.sun_direction;
    let env = Environment::sky(sky);
    let target = [0.5, 0.5, 0.52];
    let mean = |img: &Image| img.pixels.iter().map(|p| f64::from(p[0])).sum::<f64>();
    for (toward, sign) in [(true, 1.0), (false, -1.0)] {
        let eye = [0, 1, 2].map(|a| target[a] - sign * 1.6 * s[a]);
        let cam = Camera::new(eye, target, [0.0, 0.0, 1.0], 30.0, 16, 12).unwrap();
        let render = |g: f64| {
            let m = Medium::new(2.0, 0.9, g).unwrap();
            crm(
                &rbfs,
                &m,
                &env,
                &cam,
                CrmOptions {
                    order: 6,
                    ..CrmOptions::default()
                },
            )
        };
        let (fwd, back) = (render(0.95), render(-0.95));
        assert!(finite_nonnegative(&fwd) && finite_nonnegative(&back));
        assert_eq!(mean(&fwd) > mean(&back), toward, "toward the sun: {toward}");
    }
}

#[test]
fn camera_inside_the_smoke_and_every_order_agree_with_the_reference() {
    let rbfs = cluster(&unit_box());
    let volume = rbf_volume(&rbfs, [32; 3], unit_box()).unwrap();
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(2.0, 0.8, 0.3).unwrap();
    let inside = Camera::new(
        [0.5, 0.45, 0.45],
        [0.6, 0.9, 0.6],
        [0.0, 0.0, 1.0],
        60.0,
        24,
        18,
    )
    .unwrap();
    let opts = RefOptions {
        spp: 256,
        multiple: false,
        ..RefOptions::default()
    };
    let r = reference::render(&volume, &medium, &env, &inside, &opts);
    for (order, tol) in [(1, 0.05), (2, 0.03), (6, 0.03)] {
        let c = crm(
            &rbfs,
            &medium,
            &env,
            &inside,
            CrmOptions {
                order,
                multiple: false,
                ..CrmOptions::default()
            },
        );
        assert!(finite_nonnegative(&c));
        let e = c.rel_rms(&r);
        println!("camera inside, order {order}: rel RMS {e:.4}");
        assert!(e < tol, "order {order}: {e}");
    }
}

#[test]
fn albedo_one_with_multiple_scattering_is_finite() {
    // The uncorrected diffusion system is singular at Ω = 1; with the escape term it is
    // not, and the image stays finite and brighter than single scattering alone.
    let rbfs = cluster(&unit_box());
    let env = Environment::sky(Sky::default());
    let cam = front_camera(24, 18);
    let medium = Medium::new(8.0, 1.0, 0.0).unwrap();
    let ms = crm(&rbfs, &medium, &env, &cam, CrmOptions::default());
    let ss = crm(
        &rbfs,
        &medium,
        &env,
        &cam,
        CrmOptions {
            multiple: false,
            ..CrmOptions::default()
        },
    );
    assert!(finite_nonnegative(&ms));
    let sum = |i: &Image| i.pixels.iter().map(|p| f64::from(p[1])).sum::<f64>();
    assert!(sum(&ms) > sum(&ss));
}

// Suns and point lights (the lights pass and the diffusion's direct light) against the
// reference renderer, which samples the same lights explicitly, and the extremes: a sun
// below the horizon, a sun straight behind the smoke with a strongly forward phase
// function, a light inside the smoke, σt → 0 and σt large, a zero-width sun.

/// A dim uniform sky and the given lights.
fn lit(suns: Vec<Sun>, points: Vec<PointLight>) -> Environment {
    let mut env = Environment::constant([0.05; 3]);
    env.suns = suns;
    env.points = points;
    env
}

fn crm_lit(medium: &Medium, env: &Environment, cam: &Camera, multiple: bool) -> Image {
    let opts = CrmOptions {
        multiple,
        ..CrmOptions::default()
    };
    crm(&cluster(&unit_box()), medium, env, cam, opts)
}

/// The reference's single scattering at `spp` (seed 1), the pixels it changes, and its
/// noise (the relative RMS of a second seed's picture against it over √2).
fn single_reference(
    volume: &haze_volume::Volume,
    medium: &Medium,
    env: &Environment,
    cam: &Camera,
    spp: u32,
) -> (Image, Vec<bool>, f64) {
    let opts = |seed| RefOptions {
        spp,
        multiple: false,
        seed,
        ..RefOptions::default()
    };
    let r = reference::render(volume, medium, env, cam, &opts(1));
    let r2 = reference::render(volume, medium, env, cam, &opts(2));
    let mask = smoke_pixels(&r, env, cam);
    let noise = masked_rel_rms(&r2, &r, &mask) / 2f64.sqrt();
    (r, mask, noise)
}

/// Single scattering of a sun and of a point light against the reference (the same
/// trilinear density: the RBFs on the 32³ grid, no residual). The lights pass marches
/// the shadow at one voxel per step through the same field and takes the disk's phase
/// average from a table, so what is left is the view pass's slices and the reference's
/// noise (measured 2 seeds): measured 1.2–2.0 % on noise of 0.4–0.8 %, bound 4 %.
#[test]
fn lights_match_the_reference_in_single_scattering() {
    let volume = rbf_volume(&cluster(&unit_box()), [32; 3], unit_box()).unwrap();
    let cam = front_camera(40, 30);
    let medium = Medium::new(6.0, 0.9, 0.5).unwrap();
    let cases = [
        (
            "sun from the side",
            lit(
                vec![Sun::from_radiance([0.8, -0.3, 0.5], [4000.0; 3], 2.0).unwrap()],
                vec![],
            ),
        ),
        (
            "back light through the smoke",
            lit(
                vec![Sun::from_radiance([0.1, 1.0, 0.2], [400.0, 300.0, 200.0], 6.0).unwrap()],
                vec![],
            ),
        ),
        (
            "point light beside the smoke",
            lit(
                vec![],
                vec![PointLight::new([1.1, 0.2, 0.9], [2.0; 3]).unwrap()],
            ),
        ),
    ];
    for (name, env) in cases {
        let (r, mask, noise) = single_reference(&volume, &medium, &env, &cam, 128);
        assert!(mask.iter().filter(|m| **m).count() > 100, "{name}");
        let e = masked_rel_rms(&crm_lit(&medium, &env, &cam, false), &r, &mask);
        println!("{name}: rel RMS {e:.4}, reference noise {noise:.4}");
        assert!(e < 0.04, "{name}: {e} (noise {noise})");
    }
}

/// With multiple scattering the diffusion gets the lights' direct light at the centers:
/// the final image against the path tracer, at the paper's own level (Fig. 6: 14.1 %;
/// measured here 14.2 % with the path tracer's ≈ 4 % noise, single scattering alone 24 %):
/// the diffusion's error, not the lights', dominates it (BENCHMARKS.md "Lights").
#[test]
fn a_sun_lit_final_image_matches_the_path_tracer() {
    let volume = rbf_volume(&cluster(&unit_box()), [32; 3], unit_box()).unwrap();
    let cam = front_camera(40, 30);
    let medium = Medium::new(4.0, 0.9, 0.3).unwrap();
    let env = lit(
        vec![Sun::from_radiance([0.6, -0.4, 0.7], [2000.0; 3], 3.0).unwrap()],
        vec![],
    );
    let r = reference::render(
        &volume,
        &medium,
        &env,
        &cam,
        &RefOptions {
            spp: 256,
            ..RefOptions::default()
        },
    );
    let mask = smoke_pixels(&r, &env, &cam);
    let e = masked_rel_rms(&crm_lit(&medium, &env, &cam, true), &r, &mask);
    let single = masked_rel_rms(&crm_lit(&medium, &env, &cam, false), &r, &mask);
    println!("final vs path tracer: {e:.4} (single scattering alone: {single:.4})");
    assert!(e < 0.17 && e < 0.7 * single, "{e} vs single {single}");
}

#[test]
fn extreme_lights_stay_finite_and_physical() {
    let cam = front_camera(24, 18);
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    let base = crm_lit(&medium, &lit(vec![], vec![]), &cam, true);
    let sum = |im: &Image| im.pixels.iter().map(|p| f64::from(p[0])).sum::<f64>();
    // A sun below the horizon lights the smoke from below: finite, and it adds light.
    let below = lit(
        vec![Sun::from_radiance([0.2, 0.1, -1.0], [5000.0; 3], 1.0).unwrap()],
        vec![],
    );
    let img = crm_lit(&medium, &below, &cam, true);
    assert!(finite_nonnegative(&img) && sum(&img) > 1.01 * sum(&base));
    // A sun exactly behind the smoke (on the camera's axis) with g = 0.9: the forward
    // peak makes the smoke glow, bounded by the disk's radiance.
    let axis = [0.0, 1.8, -0.33];
    let behind = lit(
        vec![Sun::from_radiance(axis, [100.0; 3], 6.0).unwrap()],
        vec![],
    );
    let forward = Medium::new(4.0, 0.8, 0.9).unwrap();
    let img = crm_lit(&forward, &behind, &cam, true);
    assert!(finite_nonnegative(&img));
    assert!(
        img.pixels.iter().all(|p| p[0] < 100.0),
        "brighter than the sun"
    );
    let glow = img.get(12, 9)[0];
    let side = crm_lit(
        &forward,
        &lit(
            vec![Sun::from_radiance([1.0, 0.0, 0.2], [100.0; 3], 6.0).unwrap()],
            vec![],
        ),
        &cam,
        true,
    )
    .get(12, 9)[0];
    assert!(glow > 2.0 * side, "back light {glow} vs side light {side}");
    // A point light inside the smoke, at a voxel center: finite; the brightest pixel is
    // bounded by the light's intensity over (half a voxel)²/3 times the albedo.
    let inside = lit(
        vec![],
        vec![PointLight::new([15.5 / 32.0, 16.5 / 32.0, 12.5 / 32.0], [0.5; 3]).unwrap()],
    );
    let img = crm_lit(&medium, &inside, &cam, true);
    assert!(finite_nonnegative(&img) && sum(&img) > sum(&base));
    // σt → 0: the background exactly, the sun's disk included where a ray sees it.
    let none = Medium::new(0.0, 0.8, 0.3).unwrap();
    let sun_in_view = lit(
        vec![Sun::from_radiance([0.0, -1.0, 0.0], [50.0; 3], 8.0).unwrap()],
        vec![PointLight::new([0.5, 0.5, 0.5], [1.0; 3]).unwrap()],
    );
    let img = crm_lit(&none, &sun_in_view, &cam, true);
    for (i, p) in img.pixels.iter().enumerate() {
        let b = sun_in_view.radiance(cam.pixel_ray(i % 24, i / 24));
        assert_eq!(*p, b.map(|c| c as f32), "pixel {i}");
    }
    // σt large: opaque, finite, the smoke's own light bounded by what lights it.
    let thick = Medium::new(1e4, 0.9, 0.3).unwrap();
    let img = crm_lit(&thick, &below, &cam, true);
    assert!(finite_nonnegative(&img));
    // A zero-width sun (a directional light) equals a narrow disk of the same irradiance
    // within the disk's phase average (g = 0.3 over 0.05°: < 0.1 %).
    let narrow = Sun::from_radiance([0.8, -0.3, 0.5], [1.0; 3], 0.05).unwrap();
    let point_sun = Sun {
        angle: 0.0,
        ..narrow.clone()
    };
    let a = crm_lit(&medium, &lit(vec![narrow], vec![]), &cam, false);
    let b = crm_lit(&medium, &lit(vec![point_sun], vec![]), &cam, false);
    assert!(finite_nonnegative(&b));
    let e = a.rel_rms(&b);
    assert!(e < 1e-3, "{e}");
}

/// The view pass as a layer: its radiance plus its transmittance times the background is
/// the view pass's image; the depth is the opacity-weighted mean of the slice positions,
/// which for a homogeneous slab seen head-on is `t0 + 1/σ − L·T/(1 − T)` (the mean of
/// an exponential truncated to the slab's length `L`, `T = e^{−σL}`), up to the slices'
/// discretization; a surface in front hides the smoke.
#[test]
fn the_view_layer_is_the_view_pass_split_into_smoke_and_background() {
    use haze_view::render::crm::{VolumeGrids, default_slice, view_layer, view_pass};
    use haze_volume::Volume;
    let n = 8;
    let bbox = Bbox::new([-1.0, -1.0, 2.0], [1.0, 1.0, 4.0]);
    let density = Volume::new([n; 3], bbox, vec![1.0; n * n * n]).unwrap();
    let grids = VolumeGrids {
        density,
        radiance: vec![[0.7, 0.4, 0.2]; n * n * n],
        eye_peak: 0.0,
    };
    let medium = Medium::new(0.9, 0.8, 0.0).unwrap();
    let env = Environment::sky(Sky::default());
    // Looking straight down at the slab from z = 6: the centre pixel crosses z 4 → 2.
    let camera = Camera::new(
        [0.0, 0.0, 6.0],
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        60.0,
        9,
        9,
    )
    .unwrap();
    let du = default_slice([n; 3], &bbox) / 4.0;
    let image = view_pass(&grids, &medium, &env, &camera, du, None);
    let layer = view_layer(&grids, &medium, &[], &camera, du, &|_| f64::INFINITY);
    for (i, (px, s)) in image.iter().zip(&layer).enumerate() {
        let bg = env.radiance(camera.pixel_ray(i % 9, i / 9));
        for c in 0..3 {
            let want = f64::from(s.radiance[c]) + f64::from(s.transmittance) * bg[c];
            assert!((f64::from(px[c]) - want).abs() < 1e-6, "pixel {i}");
        }
    }
    let centre = layer[4 * 9 + 4];
    let (sigma, len): (f64, f64) = (0.9, 2.0);
    let t = (-sigma * len).exp();
    let want = 2.0 + 1.0 / sigma - len * t / (1.0 - t);
    assert!(
        (f64::from(centre.depth) - want).abs() < 0.02,
        "depth {} vs {want}",
        centre.depth
    );
    assert!((f64::from(centre.transmittance) - t).abs() < 1e-3);
    // A corner pixel misses the box: nothing, at depth 0.
    assert_eq!(
        (layer[0].transmittance, layer[0].radiance, layer[0].depth),
        (1.0, [0.0; 3], 0.0)
    );
    // A surface 1 unit in front of the slab hides it.
    let hidden = view_layer(&grids, &medium, &[], &camera, du, &|_| 1.0);
    assert!(hidden.iter().all(|s| s.transmittance == 1.0));
}

/// A block of dense smoke with flat faces, its face towards the camera lit edge-on by a
/// sun that skims along it: the light reaching the face falls from the sunny end to the
/// far one, and within the half voxel where the trilinear density falls to zero it
/// climbs back towards the unshadowed sun (`render::shell`). The lights pass and the
/// view pass on the block's own grid against the reference's single scattering on the
/// same trilinear density. Lighting only the voxels with smoke, the face came out
/// 10.3 % off (mean 0.88: the band took its neighbours' shadowed light); with the
/// smoke's shell lit, 4.8 % (mean 1.03) on reference noise of 1.5 %; bound 7 %, which
/// the old rule fails.
#[test]
fn a_sun_skimming_a_face_lights_its_outer_band() {
    use haze_view::render::crm::{default_slice, view_pass};
    let n = 24;
    let dims = [n; 3];
    let bbox = unit_box();
    let mut data = vec![0.0f32; n * n * n];
    for z in 4..20 {
        for y in 4..20 {
            for x in 4..12 {
                data[x + n * (y + n * z)] = 1.0;
            }
        }
    }
    let volume = haze_volume::Volume::new(dims, bbox, data).unwrap();
    // σt 6 over the face's 16 voxels (2/3 of the box): τ 4 along the sun.
    let medium = Medium::new(6.0, 0.9, 0.0).unwrap();
    let mut env = Environment::constant([0.0; 3]);
    env.suns = vec![Sun::from_radiance([0.0, 1.0, 0.05], [20.0; 3], 0.0).unwrap()];
    let cam = Camera::new(
        [1.6, 0.5, 0.5],
        [0.3, 0.5, 0.5],
        [0.0, 0.0, 1.0],
        40.0,
        40,
        30,
    )
    .unwrap();
    let grids = lit_by_lights(&volume, &env, &medium, cam.eye);
    let fast = view_pass(
        &grids,
        &medium,
        &env,
        &cam,
        default_slice(dims, &bbox),
        None,
    );
    let (r, mask, noise) = single_reference(&volume, &medium, &env, &cam, 256);
    assert!(mask.iter().filter(|m| **m).count() > 300);
    let fast = Image {
        width: cam.width,
        height: cam.height,
        pixels: fast,
    };
    let e = masked_rel_rms(&fast, &r, &mask);
    let mean = |img: &Image| -> f64 {
        img.pixels
            .iter()
            .zip(&mask)
            .filter(|(_, m)| **m)
            .map(|(p, _)| f64::from(p[0]))
            .sum()
    };
    println!(
        "edge-on sun: rel RMS {e:.4} (mean {:.3}), reference noise {noise:.4}",
        mean(&fast) / mean(&r)
    );
    assert!(e < 0.07, "{e} (noise {noise})");
}

/// The lights pass at a lower detail: a sun's shadows along planes of rays parallel to it
/// (`ray_planes`) against the march per voxel, on a smooth blob under a tilted sun, at
/// σt 8, 4 and 2 (peak optical depth ~5, 2.5, 1.3 across), each at the lowest detail the
/// floor allows there (`CrmOptions::detail_floor`: 0.85, 0.42 and 0.25; rays one voxel
/// apart at 0.85, `SUN_SPACING` voxels at the other two). Each voxel reads its plane's
/// rays around it (Catmull–Rom), and `1 − e^{−τ}` is concave, so it comes out a hair
/// darker: relative RMS over the lit voxels 0.15, 0.21 and 0.11 % (bound 1 %), the mean
/// within 0.02 % (bound 1 %). Point lights march either way: the same light to the bit.
#[test]
fn swept_sun_shadows_follow_the_march() {
    use haze_view::render::crm::VolumeGrids;
    use haze_view::render::lights_pass::{lights_pass, lights_pass_at};
    use haze_view::render::supersample::tau_per_voxel;
    let n = 32;
    let volume = rippled_blob(n, (1.5, 8.0), |c| 17.0 * c[0]);
    let grids = || VolumeGrids {
        density: volume.clone(),
        radiance: vec![[0.0; 3]; n * n * n],
        eye_peak: 0.0,
    };
    let eye = [2.0, -1.0, 0.8];
    for sigma_t in [8.0, 4.0, 2.0] {
        let medium = Medium::new(sigma_t, 0.9, 0.3).unwrap();
        let detail = CrmOptions::default()
            .detail_floor(tau_per_voxel(&volume, sigma_t))
            .max(0.25);
        let mut env = Environment::constant([0.0; 3]);
        env.suns = vec![Sun::from_radiance([0.3, 0.5, 0.81], [20.0; 3], 0.0).unwrap()];
        let (mut marched, mut swept) = (grids(), grids());
        lights_pass(&mut marched, &env, &medium, eye);
        lights_pass_at(&mut swept, &env, &medium, eye, detail);
        let (mut d2, mut r2, mut sm, mut ss) = (0.0, 0.0, 0.0, 0.0);
        for (m, s) in marched.radiance.iter().zip(&swept.radiance) {
            let (m, s) = (f64::from(m[0]), f64::from(s[0]));
            assert!(s.is_finite() && s >= 0.0);
            d2 += (s - m) * (s - m);
            r2 += m * m;
            sm += m;
            ss += s;
        }
        let e = (d2 / r2).sqrt();
        println!(
            "swept sun, σt {sigma_t}, detail {detail:.2}: rel RMS {e:.4}, mean ratio {:.4}",
            ss / sm
        );
        assert!(sm > 0.0);
        assert!(e < 0.01, "σt {sigma_t}: {e}");
        assert!((ss / sm - 1.0).abs() < 0.01, "σt {sigma_t}: {}", ss / sm);
    }
    let medium = Medium::new(8.0, 0.9, 0.3).unwrap();
    // A point light: marched at every detail.
    let mut env = Environment::constant([0.0; 3]);
    env.points = vec![PointLight {
        position: [0.9, 0.2, 0.7],
        intensity: [5.0; 3],
    }];
    let (mut a, mut b) = (grids(), grids());
    lights_pass(&mut a, &env, &medium, eye);
    lights_pass_at(&mut b, &env, &medium, eye, 0.5);
    assert_eq!(a.radiance, b.radiance);
}

/// The sun's rays at the grids' extremes (an axis of one voxel, a column, a single
/// voxel, smoke in one corner voxel): at detail 0.3 (rays 1.5 voxels apart) every lit
/// voxel's light is finite and non-negative and within 5 % of the march per voxel in the
/// mean. The slab one voxel thick fills its box to the faces along the rays, so its
/// voxels within two ray spacings of them march (`RayPlanes::near_smoky_side`; read from
/// the rays it was 1.1 % dark), the rest within 10⁻⁴; the column, the single voxel and
/// the corner are fewer than three voxels across the rays and march (exact).
#[test]
fn the_suns_rays_hold_at_the_grids_extremes() {
    use haze_view::render::crm::VolumeGrids;
    use haze_view::render::lights_pass::{lights_pass, lights_pass_at};
    let medium = Medium::new(6.0, 0.9, 0.3).unwrap();
    let mut env = Environment::constant([0.0; 3]);
    env.suns = vec![Sun::from_radiance([0.3, 0.5, 0.81], [20.0; 3], 0.0).unwrap()];
    let eye = [2.0, -1.0, 0.8];
    let corner = |dims: [usize; 3]| {
        let mut d = vec![0.0f32; dims.iter().product()];
        d[0] = 1.0;
        d
    };
    for (dims, data) in [
        ([9, 7, 1], vec![0.5f32; 63]),
        ([1, 1, 12], (0..12).map(|k| 0.1 * k as f32).collect()),
        ([1, 1, 1], vec![1.0]),
        ([6, 6, 6], corner([6, 6, 6])),
    ] {
        let volume = haze_volume::Volume::new(dims, unit_box(), data).unwrap();
        let cells = dims.iter().product();
        let grids = || VolumeGrids {
            density: volume.clone(),
            radiance: vec![[0.0; 3]; cells],
            eye_peak: 0.0,
        };
        let (mut marched, mut swept) = (grids(), grids());
        lights_pass(&mut marched, &env, &medium, eye);
        lights_pass_at(&mut swept, &env, &medium, eye, 0.3);
        let (mut sm, mut ss) = (0.0, 0.0);
        for (m, s) in marched.radiance.iter().zip(&swept.radiance) {
            assert!(s[0].is_finite() && s[0] >= 0.0, "{dims:?}: {s:?}");
            sm += f64::from(m[0]);
            ss += f64::from(s[0]);
        }
        assert!(sm > 0.0, "{dims:?}");
        println!("{dims:?}: mean ratio {:.4}", ss / sm);
        assert!(
            (ss / sm - 1.0).abs() < 0.05,
            "{dims:?}: mean ratio {}",
            ss / sm
        );
    }
}

/// A smooth blob on an `n³` grid of the unit box: `(1 − k·r²)⁺·(1 + 0.3·sin ripple(c))`
/// with `r² = x² + s·y² + z²` about the box's center (`(s, k)` = `shape`), `c` the voxel
/// center relative to it.
fn rippled_blob(
    n: usize,
    (s, k): (f64, f64),
    ripple: impl Fn([f64; 3]) -> f64,
) -> haze_volume::Volume {
    let data: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let c = [i % n, i / n % n, i / (n * n)].map(|a| (a as f64 + 0.5) / n as f64 - 0.5);
            let r2 = c[0] * c[0] + s * c[1] * c[1] + c[2] * c[2];
            ((1.0 - k * r2).max(0.0) * (1.0 + 0.3 * ripple(c).sin())) as f32
        })
        .collect();
    haze_volume::Volume::new([n; 3], unit_box(), data).unwrap()
}

/// The lights pass's shadows kept across camera moves (`LightShadows`, what the viewer
/// keeps for a frame on the CPU): added from a second and a third eye — one of them on a
/// voxel center, which that voxel does not light — they give the pass run afresh from
/// that eye to the bit, marched and swept, under a sun and two point lights (one on a
/// voxel center, lit there without a shadow); and the eye matters (g ≠ 0), so the check
/// can fail: the two eyes' grids differ.
#[test]
fn kept_light_shadows_give_the_fresh_pass_from_every_eye() {
    use haze_view::render::crm::VolumeGrids;
    use haze_view::render::lights_pass::{LightShadows, lights_pass_at};
    let n = 20;
    let bbox = unit_box();
    let volume = rippled_blob(n, (1.3, 7.0), |c| 13.0 * c[2]);
    let grids = || VolumeGrids {
        density: volume.clone(),
        radiance: vec![[0.01; 3]; n * n * n],
        eye_peak: 0.0,
    };
    let center = |k: [usize; 3]| {
        let vs = volume.voxel_size();
        [0, 1, 2].map(|a| bbox.min[a] + (k[a] as f64 + 0.5) * vs[a])
    };
    let medium = Medium::new(6.0, 0.9, 0.4).unwrap();
    let mut env = Environment::constant([0.0; 3]);
    env.suns = vec![Sun::from_radiance([0.3, 0.5, 0.81], [20.0; 3], 0.0).unwrap()];
    env.points = vec![
        PointLight {
            position: [0.9, 0.2, 0.7],
            intensity: [5.0; 3],
        },
        PointLight {
            position: center([9, 10, 11]),
            intensity: [0.5, 1.0, 2.0],
        },
    ];
    let eyes = [[2.0, -1.0, 0.8], [-1.5, 0.4, 1.9], center([10, 10, 10])];
    for detail in [1.0, 0.5] {
        let shadows = LightShadows::new(&volume, &env, &medium, detail).unwrap();
        let mut seen = Vec::new();
        for eye in eyes {
            let (mut fresh, mut kept) = (grids(), grids());
            lights_pass_at(&mut fresh, &env, &medium, eye, detail);
            shadows.add_to(&mut kept, &env, &medium, eye);
            assert_eq!(
                kept.radiance, fresh.radiance,
                "detail {detail}, eye {eye:?}"
            );
            seen.push(kept.radiance);
        }
        assert_ne!(seen[0], seen[1], "detail {detail}");
        let i = 10 + n * (10 + n * 10);
        assert_eq!(seen[2][i], [0.01; 3], "the voxel at the eye");
        assert!(seen[0][i][0] > 0.01);
    }
    // Nothing to add: no lights, or an albedo of 0.
    let dark = Environment::constant([0.0; 3]);
    assert!(LightShadows::new(&volume, &dark, &medium, 1.0).is_none());
    let black = Medium::new(6.0, 0.0, 0.4).unwrap();
    assert!(LightShadows::new(&volume, &env, &black, 1.0).is_none());
}

/// The lights pass at its extremes, marched (detail 1) and swept (detail 0.5), under suns
/// along an axis, along a diagonal and grazing a face: an empty box lights nothing; a
/// full box at σt 0 is lit without shadow (every voxel the same multiple of HG toward
/// the eye, to f32 rounding) and at 1e-12 within 1e-9 of it; at σt 4 every
/// value is finite and non-negative and the far side darker than the near; at σt 1e12
/// the box is opaque: no voxel center sees the sun (its half voxel alone is 5e11
/// optical depths).
#[test]
fn the_lights_pass_at_its_extremes() {
    use haze_view::render::crm::VolumeGrids;
    use haze_view::render::lights_pass::lights_pass_at;
    let n = 16;
    let grids = |d: f32| VolumeGrids {
        density: haze_volume::Volume::new([n; 3], unit_box(), vec![d; n * n * n]).unwrap(),
        radiance: vec![[0.0; 3]; n * n * n],
        eye_peak: 0.0,
    };
    let eye = [2.0, -1.0, 0.8];
    let lit = |d: f32, sigma_t: f64, dir: [f64; 3], detail: f64| {
        let medium = Medium::new(sigma_t, 0.9, 0.3).unwrap();
        let mut env = Environment::constant([0.0; 3]);
        env.suns = vec![Sun::from_radiance(dir, [20.0; 3], 0.0).unwrap()];
        let mut g = grids(d);
        lights_pass_at(&mut g, &env, &medium, eye, detail);
        g.radiance
            .iter()
            .map(|r| f64::from(r[0]))
            .collect::<Vec<f64>>()
    };
    let s = 0.5f64.sqrt();
    let a = 0.05f64;
    let dirs = [
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
        [1.0 / 3f64.sqrt(); 3],
        [(1.0 - a * a).sqrt() * s, (1.0 - a * a).sqrt() * s, a],
    ];
    for dir in dirs {
        for detail in [1.0, 0.5] {
            let what = format!("sun {dir:?}, detail {detail}");
            assert!(
                lit(0.0, 4.0, dir, detail).iter().all(|&v| v == 0.0),
                "{what}"
            );
            let clear = lit(1.0, 0.0, dir, detail);
            let faint = lit(1.0, 1e-12, dir, detail);
            // Unshadowed, each voxel's light is `Ω·E·p(μ)/4π`, μ between the sun's
            // light (−s) and the way to the eye: the same multiple of HG everywhere.
            let ratio: Vec<f64> = (0..n * n * n)
                .map(|i| {
                    let x = [i % n, i / n % n, i / (n * n)].map(|a| (a as f64 + 0.5) / n as f64);
                    let to_eye = [0, 1, 2].map(|k| eye[k] - x[k]);
                    let len = to_eye.iter().map(|c| c * c).sum::<f64>().sqrt();
                    let mu = -(0..3).map(|k| dir[k] * to_eye[k]).sum::<f64>() / len;
                    clear[i] / hg(0.3, mu)
                })
                .collect();
            let r0 = ratio[0];
            assert!(r0 > 0.0 && r0.is_finite(), "{what}: {r0}");
            for (i, r) in ratio.iter().enumerate() {
                assert!(
                    (r - r0).abs() <= 1e-5 * r0,
                    "{what}: voxel {i}: {r} vs {r0}"
                );
                let f = faint[i];
                assert!(
                    (f - clear[i]).abs() <= 1e-9 * clear[i],
                    "{what}: {f} vs {}",
                    clear[i]
                );
            }
            let thick = lit(1.0, 4.0, dir, detail);
            assert!(thick.iter().all(|v| v.is_finite() && *v >= 0.0), "{what}");
            // The voxel nearest the sun against the one farthest from it.
            let corner = |toward: bool| {
                let pick = |c: f64| usize::from((c > 0.0) == toward) * (n - 1);
                pick(dir[0]) + n * pick(dir[1]) + n * n * pick(dir[2])
            };
            assert!(thick[corner(true)] > thick[corner(false)], "{what}");
            let opaque = lit(1.0, 1e12, dir, detail);
            assert!(opaque.iter().all(|&v| v == 0.0), "{what}: {opaque:?}");
        }
    }
}

/// A point light inside uniform smoke (σt 2 over a unit box of 24³ voxels, albedo 0.9,
/// g 0.3), single scattering of it alone, against the integral along each pixel's ray
/// by Gauss–Legendre in the angle seen from the light (`σt·Ω/4π·p·I·e^{−σt r}/r²·
/// e^{−σt(t − t₀)}`, 4 × 64 nodes split at the ray's foot; independent of the grids). The
/// grids hold the light's `1/r²` flat inside four voxels and the view pass adds the rest
/// along each ray (`near_light`); the pixels around the light's image are where a grid
/// alone smooths its peak away. Measured: relative RMS 1.8 %, the light's pixel +1.1 %
/// (bounds 3 % each); the grid alone (the same lights pass, the near term left out) has
/// an eighth of the light's pixel. The grid's phase function between voxel centres is what
/// is left, growing with g: at g 0, 0.6 and 0.8 the RMS is 1.5, 4.6 and 16 %.
#[test]
fn a_point_light_in_the_smoke_matches_its_integral() {
    use haze_view::render::crm::{default_slice, view_pass};
    let n = 24;
    let dims = [n; 3];
    let bbox = unit_box();
    let volume = haze_volume::Volume::new(dims, bbox, vec![1.0; n * n * n]).unwrap();
    let medium = Medium::new(2.0, 0.9, 0.3).unwrap();
    let light = [0.52, 0.47, 0.55];
    let intensity = 3.0;
    let mut env = Environment::constant([0.0; 3]);
    env.points = vec![PointLight::new(light, [intensity; 3]).unwrap()];
    let cam = Camera::new(
        [1.9, 0.2, 0.9],
        [0.52, 0.47, 0.55],
        [0.0, 0.0, 1.0],
        30.0,
        48,
        36,
    )
    .unwrap();
    let grids = lit_by_lights(&volume, &env, &medium, cam.eye);
    let du = default_slice(dims, &bbox);
    let fast = view_pass(&grids, &medium, &env, &cam, du, None);
    let grid_alone = view_pass(
        &grids,
        &medium,
        &Environment::constant([0.0; 3]),
        &cam,
        du,
        None,
    );
    // The integral along a ray, in φ = atan((t − t_f)/h) on each side of the foot t_f.
    let (nodes, sigma) = (gauss_legendre(64), medium.sigma_t);
    let k = medium.albedo / (4.0 * PI);
    let exact = |d: [f64; 3]| -> f64 {
        let Some((t0, t1)) = haze_view::field::ray_box(cam.eye, d, &bbox) else {
            return 0.0;
        };
        let v = [0, 1, 2].map(|a| light[a] - cam.eye[a]);
        let tf = v[0] * d[0] + v[1] * d[1] + v[2] * d[2];
        let m = [0, 1, 2].map(|a| v[a] - tf * d[a]);
        let h = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        let (a, b) = (((t0 - tf) / h).atan(), ((t1 - tf) / h).atan());
        let mut sum = 0.0;
        // Four panels: the foot (φ = 0) is a panel edge when it lies on the ray.
        let cuts = [
            a,
            a + 0.5 * (0f64.clamp(a, b) - a),
            0f64.clamp(a, b),
            0f64.clamp(a, b) + 0.5 * (b - 0f64.clamp(a, b)),
            b,
        ];
        for w in cuts.windows(2) {
            let (mid, half) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
            for &(x, wt) in &nodes {
                let phi = mid + half * x;
                let r = h / phi.cos();
                let t = tf + h * phi.tan();
                sum += wt
                    * half
                    * hg(medium.g, -phi.sin())
                    * (-sigma * r).exp()
                    * (-sigma * (t - t0)).exp()
                    / h;
            }
        }
        sigma * k * intensity * sum
    };
    let (mut d2, mut r2) = (0.0, 0.0);
    let (px, py) = cam.project(light).unwrap();
    let (lx, ly) = (px as usize, py as usize);
    let mut at_light = (0.0, 0.0, 0.0);
    for y in 0..cam.height {
        for x in 0..cam.width {
            let want = exact(cam.pixel_ray(x, y));
            let got = f64::from(fast[y * cam.width + x][0]);
            d2 += (got - want).powi(2);
            r2 += want * want;
            if (x, y) == (lx, ly) {
                at_light = (got, want, f64::from(grid_alone[y * cam.width + x][0]));
            }
        }
    }
    let e = (d2 / r2).sqrt();
    let (got, want, alone) = at_light;
    println!(
        "point light in smoke: rel RMS {e:.4}; the light's pixel {got:.3} vs {want:.3} ({:+.4}), the grid alone {alone:.3}",
        got / want - 1.0
    );
    assert!(e < 0.03, "{e}");
    assert!((got / want - 1.0).abs() < 0.03, "{got} vs {want}");
    assert!(alone < 0.5 * want, "{alone} vs {want}");
}

/// The view pass taking pixels from their neighbours (`pixel_reuse`, the viewer's while
/// playing) on a rippled blob about five pixels a voxel, lit by a low sun and a point
/// light inside it (the near light's peak on the picture): at tolerance 0 it is
/// `view_pass` to the bit; at the viewer's 0.002 over a quarter of the pixels are reused
/// (measured: 30 %; the ripples and the light's peak fail the rest) and the picture is
/// within that share of the marched one in relative RMS (measured: 0.045 %) — the bound
/// each reused pixel is held to where the picture's second differences measure it, which
/// voxels wider than the coarse grid's two pixels leave no room to hide from.
#[test]
fn reused_pixels_stay_within_their_tolerance() {
    use haze_view::render::crm::{default_slice, view_pass, view_pass_reused};
    let n = 20;
    let volume = rippled_blob(n, (1.2, 3.0), |c| 11.0 * c[0] + 7.0 * c[2]);
    let mut env = Environment::constant([0.05; 3]);
    env.suns = vec![Sun::from_radiance([0.3, 1.0, 0.25], [20.0; 3], 0.0).unwrap()];
    env.points = vec![PointLight::new([0.52, 0.47, 0.55], [0.5; 3]).unwrap()];
    let medium = Medium::new(6.0, 0.9, 0.3).unwrap();
    let cam = Camera::new(
        [2.2, 0.4, 0.8],
        [0.5, 0.5, 0.5],
        [0.0, 0.0, 1.0],
        30.0,
        96,
        72,
    )
    .unwrap();
    let grids = lit_by_lights(&volume, &env, &medium, cam.eye);
    let du = default_slice([n; 3], &unit_box());
    let marched = view_pass(&grids, &medium, &env, &cam, du, None);
    let (same, count) = view_pass_reused(&grids, &medium, &env, &cam, du, None, 0.0);
    assert_eq!((same, count.reused), (marched.clone(), 0));
    let (got, count) = view_pass_reused(&grids, &medium, &env, &cam, du, None, 0.002);
    assert!(count.reused > 96 * 72 / 4, "{count:?}");
    let image = |pixels: Vec<[f32; 3]>| Image {
        width: 96,
        height: 72,
        pixels,
    };
    let rms = image(got).rel_rms(&image(marched));
    assert!(rms > 0.0 && rms <= 0.002, "relative RMS {rms}");
}
