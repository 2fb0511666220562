//! Tests of the reference renderer against closed forms, quadrature and conservation laws.

use super::*;
use crate::Sky;
use crate::field::ray_box;
use crate::medium::{FOUR_PI, hg};
use std::f64::consts::PI;

fn cube() -> Bbox {
    Bbox::new([-1.0; 3], [1.0; 3])
}

/// A constant-density box: the trilinear field is `density` everywhere inside.
fn constant_box(dims: [usize; 3], bbox: Bbox, density: f32) -> Volume {
    Volume::new(dims, bbox, vec![density; dims[0] * dims[1] * dims[2]]).unwrap()
}

/// Three overlapping Gaussians in the unit cube [−1, 1]³, peak density about 1.
fn blob() -> Volume {
    let rbfs = [
        Rbf::new([0.0, 0.0, 0.0], 0.45, 1.0),
        Rbf::new([0.35, 0.2, 0.3], 0.3, 0.6),
        Rbf::new([-0.4, -0.1, -0.2], 0.25, 0.8),
    ];
    rbf_volume(&rbfs, [16, 16, 16], cube()).unwrap()
}

fn medium(sigma_t: f64, albedo: f64, g: f64) -> Medium {
    Medium::new(sigma_t, albedo, g).unwrap()
}

fn opts(spp: u32, multiple: bool) -> RefOptions {
    RefOptions {
        spp,
        light_samples: 2,
        seed: 7,
        multiple,
        max_bounces: 256,
        env_sampling: true,
        ground: None,
    }
}

fn sky() -> Environment {
    Environment::sky(Sky::default())
}

fn as_f32(c: Rgb) -> [f32; 3] {
    c.map(|v| v as f32)
}

fn close(a: f32, b: f64, rel: f64) -> bool {
    (f64::from(a) - b).abs() <= rel * b.abs().max(1e-30)
}

#[test]
fn rbf_volume_samples_the_rbfs_at_voxel_centers() {
    let v = blob();
    let rbfs = [
        Rbf::new([0.0, 0.0, 0.0], 0.45, 1.0),
        Rbf::new([0.35, 0.2, 0.3], 0.3, 0.6),
        Rbf::new([-0.4, -0.1, -0.2], 0.25, 0.8),
    ];
    for (x, y, z) in [(0, 0, 0), (7, 8, 8), (10, 9, 11), (4, 7, 6)] {
        let p = v.voxel_center(x, y, z);
        let want: f64 = rbfs.iter().map(|r| r.eval(p)).sum();
        assert!(close(v.get(x, y, z), want, 1e-6), "{x} {y} {z}");
    }
    assert!(rbf_volume(&rbfs, [2, 2, 2], Bbox::new([0.0; 3], [0.0; 3])).is_err());
}

#[test]
fn without_extinction_or_density_the_image_is_the_environment() {
    let env = sky();
    let cam = Camera::framing(cube().min, cube().max, 40.0, 16, 12).unwrap();
    let empty = Volume::new([0, 0, 0], cube(), vec![]).unwrap();
    let zeros = constant_box([4, 4, 4], cube(), 0.0);
    let scenes = [
        (blob(), medium(0.0, 0.9, 0.5)),
        (zeros, medium(10.0, 0.9, 0.5)),
        (empty, medium(10.0, 0.9, 0.5)),
    ];
    for (v, m) in &scenes {
        for multiple in [false, true] {
            let im = render(v, m, &env, &cam, &opts(4, multiple));
            for y in 0..cam.height {
                for x in 0..cam.width {
                    assert_eq!(im.get(x, y), as_f32(env.radiance(cam.pixel_ray(x, y))));
                }
            }
        }
    }
}

#[test]
fn without_albedo_a_box_only_attenuates() {
    // Constant density 0.7 in [−1, 1]³, σt = 1.3: L = c·exp(−σt·0.7·length) per pixel.
    let c = [0.8, 0.5, 1.2];
    let env = Environment::constant(c);
    let v = constant_box([3, 3, 3], cube(), 0.7);
    let m = medium(1.3, 0.0, 0.3);
    let cam = Camera::framing(cube().min, cube().max, 40.0, 16, 12).unwrap();
    let want = |x: usize, y: usize| {
        let d = cam.pixel_ray(x, y);
        let len = ray_box(cam.eye, d, v.bbox()).map_or(0.0, |(a, b)| b - a);
        (-1.3 * 0.7 * len).exp()
    };
    // Both estimators take the camera ray's transmittance exactly; the scattered term
    // vanishes (the path tracer's forced collisions carry weight 0).
    for multiple in [false, true] {
        let im = render(&v, &m, &env, &cam, &opts(4, multiple));
        let mut through = 0;
        for y in 0..cam.height {
            for x in 0..cam.width {
                let t = want(x, y);
                through += usize::from(t < 0.99);
                for (p, ck) in im.get(x, y).into_iter().zip(c) {
                    assert!(close(p, ck * t, 1e-6), "{x} {y}");
                }
            }
        }
        assert!(through > 50, "the box covers much of the image");
    }
}

/// The ground under an absorbing box (albedo 0), seen through it and beside it, lit by
/// a uniform sky (`E = πc`) and a sun at 40° straight through the box: each pixel is
/// `T_view · ρ/π · (πc·V + E_sun sin 40° · T_sun)` with the transmittances in closed form
/// (the density is constant, the paths straight) and the sky's share `V` by a fine
/// midpoint rule over the hemisphere of them (128 × 256 cells in `sin²θ` and `φ`), for
/// both estimators. The reference estimates `V` by 2048 jittered directions: within 2 %
/// of the sky's term.
#[test]
fn the_ground_under_an_absorbing_box_has_its_exact_shadow() {
    let c = 0.6;
    let mut env = Environment::constant([c; 3]);
    let e = 40f64.to_radians();
    env.suns.push(crate::Sun {
        direction: [e.cos(), 0.0, e.sin()],
        irradiance: [5.0; 3],
        angle: 0.0,
    });
    let v = constant_box([3, 3, 3], cube(), 0.7);
    let m = medium(1.3, 0.0, 0.3);
    let ground = crate::ground::Ground {
        height: -1.0,
        albedo: [0.4, 0.3, 0.2],
    };
    let cam = Camera::new(
        [0.0, -4.0, 2.0],
        [0.0, 0.0, -1.0],
        [0.0, 0.0, 1.0],
        60.0,
        24,
        18,
    )
    .unwrap();
    let path = |o: [f64; 3], d: [f64; 3]| ray_box(o, d, v.bbox()).map_or(0.0, |(a, b)| b - a);
    let sun = [e.cos(), 0.0, e.sin()];
    let (mut shaded, mut seen, mut covered) = (0, 0, 0);
    // V = (1/π)∫ T ω_z dω: in u = sin²θ and φ the measure is du dφ / 2.
    let sky_share = |p: [f64; 3]| {
        let (nu, nphi) = (128, 256);
        let mut sum = 0.0;
        for i in 0..nu {
            let u = (i as f64 + 0.5) / nu as f64;
            let (st, ct) = (u.sqrt(), (1.0 - u).sqrt());
            for j in 0..nphi {
                let phi = 2.0 * PI * (j as f64 + 0.5) / nphi as f64;
                let w = [st * phi.cos(), st * phi.sin(), ct];
                sum += (-1.3 * 0.7 * path(p, w)).exp();
            }
        }
        sum / (nu * nphi) as f64
    };
    for multiple in [false, true] {
        // Absorbing smoke: the samples only draw the ground's sky directions.
        let o = RefOptions {
            ground: Some(ground),
            spp: 2048,
            ..opts(2, multiple)
        };
        let im = render(&v, &m, &env, &cam, &o);
        for y in 0..cam.height {
            for x in 0..cam.width {
                let d = cam.pixel_ray(x, y);
                let t_view = (-1.3 * 0.7 * path(cam.eye, d)).exp();
                let (want, sky): ([f64; 3], [f64; 3]) = if d[2] < 0.0 {
                    let t = (cam.eye[2] + 1.0) / -d[2];
                    let p = [cam.eye[0] + t * d[0], cam.eye[1] + t * d[1], -1.0];
                    let t_sun = (-1.3 * 0.7 * path(p, sun)).exp();
                    let v = sky_share(p);
                    shaded += usize::from(t_sun < 0.5);
                    covered += usize::from(v < 0.8);
                    seen += 1;
                    (
                        ground
                            .albedo
                            .map(|a| a / PI * (PI * c * v + 5.0 * e.sin() * t_sun) * t_view),
                        ground.albedo.map(|a| a * c * t_view),
                    )
                } else {
                    ([c * t_view; 3], [0.0; 3])
                };
                for (k, (p, w)) in im.get(x, y).into_iter().zip(want).enumerate() {
                    let tol = 1e-5 * w.abs().max(1.0) + 0.02 * sky[k];
                    assert!((f64::from(p) - w).abs() <= tol, "{x} {y} {k}: {p} vs {w}");
                }
            }
        }
    }
    assert!(shaded > 20 && seen > shaded + 20, "{shaded} of {seen}");
    assert!(
        covered > 20,
        "{covered} of {seen} under the box's sky shadow"
    );
}

#[test]
fn a_non_absorbing_medium_under_a_uniform_environment_is_invisible() {
    // White furnace: with Ω = 1 under constant c, L = c for every ray. Every path carries
    // weight 1 and ends in the environment unless it needs more than max_bounces
    // scatterings (optical depths here ≤ 6: such paths are vanishingly rare), so the
    // pixels equal c up to f32 rounding; a lost or double-counted path would show as c/spp.
    let c = [0.7, 0.4, 1.5];
    let env = Environment::constant(c);
    let v = blob();
    let bbox = cube();
    let inside = Camera::new(
        [0.1, -0.2, 0.05],
        [0.3, 1.0, 0.2],
        [0.0, 0.0, 1.0],
        60.0,
        8,
        6,
    )
    .unwrap();
    let outside = Camera::framing(bbox.min, bbox.max, 40.0, 16, 12).unwrap();
    for g in [0.0, 0.9] {
        for (vol, cam) in [
            (&v, &outside),
            (&constant_box([2, 2, 2], cube(), 1.0), &inside),
        ] {
            let im = render(vol, &medium(3.0, 1.0, g), &env, cam, &opts(16, true));
            for p in &im.pixels {
                for k in 0..3 {
                    assert!(close(p[k], c[k], 1e-6), "g {g}: {p:?}");
                }
            }
        }
    }
}

/// Single scattering of a camera ray going straight down through a homogeneous slab
/// `0 ≤ z ≤ 1` (unit density, extinction `s`) under a constant environment of 1, by
/// midpoint quadrature in depth and `μ = cos θ` of the light direction:
/// `L = e^{−s} + Ω·s ∫₀¹ e^{−s·u} ½∫₋₁¹ p(−μ)·e^{−s·ℓ(1−u, μ)} dμ du`, with the path
/// length to the slab's surface `ℓ(z, μ) = (1 − z)/μ` upwards and `z/|μ|` downwards
/// (the camera looks along −z, so the scattering angle has cosine `−μ`).
fn slab_quadrature(s: f64, albedo: f64, g: f64) -> f64 {
    let (nu, nm) = (1000, 2000);
    let mut outer = 0.0;
    for i in 0..nu {
        let u = (i as f64 + 0.5) / nu as f64;
        let z = 1.0 - u;
        let mut inner = 0.0;
        for j in 0..nm {
            let mu = -1.0 + (j as f64 + 0.5) * 2.0 / nm as f64;
            let len = if mu > 0.0 { (1.0 - z) / mu } else { z / -mu };
            inner += 0.5 * hg(g, -mu) * (-s * len).exp() * 2.0 / nm as f64;
        }
        outer += (-s * u).exp() * inner / nu as f64;
    }
    (-s).exp() + albedo * s * outer
}

#[test]
fn single_scattering_in_a_slab_matches_quadrature() {
    // A 100×100×1 box is a slab for a central ray: sideways paths are ≥ 50 long, their
    // transmittance e^{−25} is negligible. One pixel, spp = 40 000 scattering points.
    // One sample is (1 − T)·Ω·mean(T_light·c) ∈ [0, (1 − T)Ω·c]: its standard deviation is
    // at most half that range, so 4 standard errors are ≤ 2·(1 − T)Ω·c/√spp = 1 %.
    let bbox = Bbox::new([-50.0, -50.0, 0.0], [50.0, 50.0, 1.0]);
    let v = constant_box([2, 2, 2], bbox, 1.0);
    let c = [1.0, 0.5, 2.0];
    let env = Environment::constant(c);
    let cam = Camera::new([0.0, 0.0, 3.0], [0.0; 3], [0.0, 1.0, 0.0], 10.0, 1, 1).unwrap();
    let spp = 40_000;
    for (s, albedo, g) in [(0.5, 0.8, 0.0), (0.5, 0.8, 0.6), (2.0, 1.0, -0.4)] {
        let m = medium(s, albedo, g);
        let im = render(&v, &m, &env, &cam, &opts(spp, false));
        let want = slab_quadrature(s, albedo, g);
        let scattered = want - (-s).exp();
        let tol = 2.0 * (1.0 - (-s).exp()) * albedo / f64::from(spp).sqrt();
        // The channels scale the same samples: each must be c_k times the same value.
        let got = im.pixels[0].map(f64::from);
        let err = got[0] / c[0] - want;
        eprintln!(
            "slab s {s} Ω {albedo} g {g}: L {:.5} vs {want:.5} (scattered {scattered:.5}), \
             error {err:+.2e}, tolerance {tol:.1e}",
            got[0] / c[0]
        );
        for (gk, ck) in got.into_iter().zip(c) {
            assert!((gk / ck - want).abs() < tol, "{gk} vs {want}·{ck}");
        }
    }
}

#[test]
fn path_tracing_with_one_bounce_is_single_scattering() {
    // Two independent estimators of the same quantity (the path tracer samples light
    // directions by escaping, single scattering by exact transmittance): their difference
    // is pure noise. Its expected size is calibrated from each estimator's own seed-to-seed
    // spread: E|a − b|² = σa² + σb² and E|a₁ − a₂|² = 2σa².
    let v = blob();
    let m = medium(3.0, 0.9, 0.5);
    let env = sky();
    let cam = Camera::framing(cube().min, cube().max, 40.0, 12, 9).unwrap();
    let single = |seed| {
        let o = RefOptions {
            seed,
            ..opts(16, false)
        };
        render(&v, &m, &env, &cam, &o)
    };
    let path = |seed| {
        let o = RefOptions {
            seed,
            max_bounces: 1,
            ..opts(96, true)
        };
        render(&v, &m, &env, &cam, &o)
    };
    let (s1, s2, p1, p2) = (single(1), single(2), path(1), path(2));
    let noise = (0.5 * s1.rel_rms(&s2).powi(2) + 0.5 * p1.rel_rms(&p2).powi(2)).sqrt();
    let err = p1.rel_rms(&s1);
    eprintln!("path (1 bounce) vs single: rel_rms {err:.4}, noise {noise:.4}");
    assert!(err < 1.5 * noise && err < 0.05, "{err} vs noise {noise}");
    // Multiple scattering adds light.
    let full = render(&v, &m, &env, &cam, &opts(96, true));
    let sum = |im: &Image| im.pixels.iter().map(|p| f64::from(p[0])).sum::<f64>();
    assert!(sum(&full) > sum(&p1) * 1.02);
}

#[test]
fn huge_extinction_is_opaque_finite_and_terminates() {
    let c = [1.0, 1.0, 1.0];
    let env = Environment::constant(c);
    let v = constant_box([4, 4, 4], cube(), 1.0);
    let cam = Camera::framing(cube().min, cube().max, 40.0, 8, 6).unwrap();
    let hits =
        |x, y| ray_box(cam.eye, cam.pixel_ray(x, y), v.bbox()).is_some_and(|(a, b)| b - a > 1e-3);
    for multiple in [false, true] {
        let o = RefOptions {
            max_bounces: 64,
            ..opts(8, multiple)
        };
        // Albedo 0: nothing passes.
        let im = render(&v, &medium(1e6, 0.0, 0.0), &env, &cam, &o);
        for y in 0..cam.height {
            for x in 0..cam.width {
                let want = if hits(x, y) { 0.0 } else { 1.0 };
                assert_eq!(im.get(x, y), [want; 3], "{x} {y}");
            }
        }
        // Albedo 1, strongly peaked phase functions: light scattered at the surface only,
        // finite and within the environment's bound.
        for g in [0.95, -0.95] {
            let im = render(&v, &medium(1e6, 1.0, g), &env, &cam, &o);
            for p in &im.pixels {
                assert!(
                    p.iter()
                        .all(|c| c.is_finite() && (0.0..=1.0 + 1e-6).contains(c))
                );
            }
        }
    }
}

#[test]
fn a_camera_inside_sees_the_attenuated_environment() {
    let c = [0.3, 0.6, 0.9];
    let env = Environment::constant(c);
    let v = constant_box([5, 5, 5], cube(), 0.5);
    let cam = Camera::new(
        [0.1, -0.2, 0.05],
        [0.3, 1.0, 0.2],
        [0.0, 0.0, 1.0],
        70.0,
        8,
        6,
    )
    .unwrap();
    let im = render(&v, &medium(2.0, 0.0, 0.0), &env, &cam, &opts(4, false));
    for y in 0..cam.height {
        for x in 0..cam.width {
            let (t0, t1) = ray_box(cam.eye, cam.pixel_ray(x, y), v.bbox()).unwrap();
            assert_eq!(t0, 0.0);
            let t = (-2.0 * 0.5 * t1).exp();
            for (p, ck) in im.get(x, y).into_iter().zip(c) {
                assert!(close(p, ck * t, 1e-6), "{x} {y}");
            }
        }
    }
}

#[test]
fn images_depend_on_the_seed_but_not_on_the_thread_count() {
    let v = blob();
    let m = medium(4.0, 0.95, 0.7);
    let env = sky();
    let cam = Camera::framing(cube().min, cube().max, 40.0, 8, 6).unwrap();
    for multiple in [false, true] {
        let o = opts(4, multiple);
        let in_pool = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| render(&v, &m, &env, &cam, &o))
        };
        let one = in_pool(1);
        assert_eq!(one, in_pool(2));
        let other = render(&v, &m, &env, &cam, &RefOptions { seed: 8, ..o });
        assert_ne!(one, other);
    }
}

#[test]
fn phase_sampled_directions_have_the_requested_cosine() {
    for d in [
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.6, -0.8, 0.0],
        [0.48, 0.6, 0.64],
    ] {
        for (u1, u2) in [(0.1, 0.2), (0.5, 0.9), (0.93, 0.4)] {
            let w = hg_direction(d, 0.6, u1, u2);
            let cos = w[0] * d[0] + w[1] * d[1] + w[2] * d[2];
            let norm = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            assert!((norm - 1.0).abs() < 1e-12);
            assert!((cos - sample_hg_cos(0.6, u1)).abs() < 1e-12, "{d:?}");
        }
    }
}

/// Single scattering of a directional sun (irradiance `e`, towards `(sin θs, 0, cos θs)`)
/// in the unit slab seen from above along −Z, black sky: the closed form
/// `Ω·e·p(−cos θs)/4π · σ∫₀¹ e^{−σu(1 + 1/cos θs)} du`.
fn sun_slab(s: f64, albedo: f64, g: f64, theta_s: f64, e: f64) -> f64 {
    let k = 1.0 + 1.0 / theta_s.cos();
    albedo * e * hg(g, -theta_s.cos()) / FOUR_PI * (1.0 - (-s * k).exp()) / k
}

#[test]
fn a_sun_over_a_slab_matches_the_closed_form_in_both_estimators() {
    // The slab of `single_scattering_in_a_slab_matches_quadrature`; the sun is sampled
    // explicitly, so a sample is (1 − T)·Ω·E·p/4π·T_sun ∈ [0, (1 − T)·Ω·E·p/4π]: 4
    // standard errors ≤ 2·range/√spp. The path tracer cut at one bounce estimates the
    // same integral (collisions drawn ∝ σT, the sun's light at each).
    let bbox = Bbox::new([-50.0, -50.0, 0.0], [50.0, 50.0, 1.0]);
    let v = constant_box([2, 2, 2], bbox, 1.0);
    let cam = Camera::new([0.0, 0.0, 3.0], [0.0; 3], [0.0, 1.0, 0.0], 10.0, 1, 1).unwrap();
    let spp = 20_000;
    for (s, albedo, g, theta_s) in [
        (0.5, 0.8, 0.0, 0.3f64),
        (1.5, 1.0, 0.6, 1.0),
        (0.2, 0.5, -0.4, 0.0),
    ] {
        let mut env = Environment::constant([0.0; 3]);
        env.suns.push(crate::lights::Sun {
            direction: [theta_s.sin(), 0.0, theta_s.cos()],
            irradiance: [3.0, 2.0, 1.0],
            angle: 0.0,
        });
        let m = medium(s, albedo, g);
        let want = sun_slab(s, albedo, g, theta_s, 1.0);
        let c = albedo * hg(g, -theta_s.cos()) / FOUR_PI;
        let mass = 1.0 - (-s).exp();
        let tol = 2.0 * mass * c / f64::from(spp).sqrt();
        // A path collides with probability 1 − T (else it sees the black sky): its sample
        // is in {0} ∪ [0, c], E[X²] ≤ (1 − T)c², 4 standard errors.
        let tol_path = 4.0 * c * mass.sqrt() / f64::from(spp).sqrt();
        let single = render(&v, &m, &env, &cam, &opts(spp, false)).pixels[0];
        let path = render(
            &v,
            &m,
            &env,
            &cam,
            &RefOptions {
                max_bounces: 1,
                ..opts(spp, true)
            },
        )
        .pixels[0];
        for (name, px, tol) in [("single", single, tol), ("path", path, tol_path)] {
            for (k, e) in [3.0, 2.0, 1.0].into_iter().enumerate() {
                let got = f64::from(px[k]) / e;
                assert!(
                    (got - want).abs() < tol.max(1e-6 * want),
                    "{name} σ {s} Ω {albedo} g {g} θs {theta_s}: {got} vs {want} (tolerance {tol:.1e})"
                );
            }
        }
    }
}

#[test]
fn a_sun_disk_and_a_point_light_reach_the_estimators() {
    // A 6° disk straight above and a zero-angle sun of the same irradiance light the slab
    // alike within the disk's phase average (g = 0: exactly alike); a point light far
    // above (distance 1000, intensity 1e6) is a sun of irradiance ≈ 1.
    let bbox = Bbox::new([-50.0, -50.0, 0.0], [50.0, 50.0, 1.0]);
    let v = constant_box([2, 2, 2], bbox, 1.0);
    let cam = Camera::new([0.0, 0.0, 3.0], [0.0; 3], [0.0, 1.0, 0.0], 10.0, 1, 1).unwrap();
    let m = medium(1.0, 0.9, 0.0);
    let spp = 20_000;
    let want = sun_slab(1.0, 0.9, 0.0, 0.0, 1.0);
    let tol = 2.0 * 0.9 / FOUR_PI / f64::from(spp).sqrt() + 0.01 * want;
    let mut disk = Environment::constant([0.0; 3]);
    disk.suns.push(crate::lights::Sun {
        direction: [0.0, 0.0, 1.0],
        irradiance: [1.0; 3],
        angle: 6f64.to_radians(),
    });
    let mut point = Environment::constant([0.0; 3]);
    point
        .points
        .push(crate::lights::PointLight::new([0.0, 0.0, 1001.0], [1e6; 3]).unwrap());
    for (name, env) in [("disk", disk), ("point", point)] {
        let got = f64::from(render(&v, &m, &env, &cam, &opts(spp, false)).pixels[0][0]);
        assert!((got - want).abs() < tol, "{name}: {got} vs {want}");
    }
}

#[test]
fn the_noise_estimate_of_two_half_runs_predicts_the_error() {
    // Against a 16× longer render, the error of a short one is its noise (plus the long
    // one's, a quarter as large). The estimate is itself a sample variance over the
    // pixels, dominated by the few noisiest ones: one seed's estimate is seen from half
    // to twice the error (a spread of ≈ 30 %). Over 4 seeds (≈ 15 %), the RMS estimate
    // must be within a factor 1.5 of the RMS error.
    let v = blob();
    let m = medium(3.0, 0.9, 0.5);
    let mut env = sky();
    env.suns
        .push(crate::lights::Sun::from_radiance([0.3, -0.5, 0.8], [800.0; 3], 2.0).unwrap());
    let cam = Camera::framing(cube().min, cube().max, 40.0, 16, 12).unwrap();
    for multiple in [false, true] {
        let long = render(
            &v,
            &m,
            &env,
            &cam,
            &RefOptions {
                seed: 99,
                ..opts(256, multiple)
            },
        );
        let mask = smoke_pixels(&long, &env, &cam);
        let pick = |im: &Image| Image {
            width: mask.iter().filter(|m| **m).count(),
            height: 1,
            pixels: im
                .pixels
                .iter()
                .zip(&mask)
                .filter(|(_, m)| **m)
                .map(|(p, _)| *p)
                .collect(),
        };
        let (mut err2, mut noise2) = (0.0, 0.0);
        for seed in 1..=4 {
            let o = RefOptions {
                seed,
                ..opts(16, multiple)
            };
            let (short, noise) = render_with_noise(&v, &m, &env, &cam, &o);
            let noise = noise.expect("smoke in view");
            let err = pick(&short).rel_rms(&pick(&long));
            eprintln!("multiple {multiple}, seed {seed}: error {err:.4}, estimate {noise:.4}");
            err2 += err * err / 4.0;
            noise2 += noise * noise / 4.0;
        }
        let (err, noise) = (err2.sqrt(), noise2.sqrt());
        assert!(err < 1.5 * noise && noise < 1.5 * err, "{err} vs {noise}");
    }
    // Albedo 0, single scattering: exact (only the attenuation), no noise.
    let (_, zero) = render_with_noise(&v, &medium(3.0, 0.0, 0.0), &env, &cam, &opts(8, false));
    assert_eq!(zero, Some(0.0));
}

#[test]
fn pixel_estimates_match_the_image_and_their_variance_the_spread_of_seeds() {
    let v = blob();
    let camera = Camera::new([0.0, -4.0, 0.5], [0.0; 3], [0.0, 0.0, 1.0], 40.0, 12, 9).unwrap();
    let m = medium(4.0, 0.8, 0.3);
    let env = sky();
    // A pixel through the smoke and a corner pixel that misses the box.
    let pixels = [(6, 4), (0, 0)];
    for multiple in [false, true] {
        let o = opts(32, multiple);
        let image = render(&v, &m, &env, &camera, &o);
        let est = render_pixels(&v, &m, &env, &camera, &pixels, &o);
        // The same draws as the image's pixel: the same mean (summation order aside).
        for (&(x, y), (mean, _)) in pixels.iter().zip(&est) {
            let p = image.pixels[y * camera.width + x];
            for c in 0..3 {
                assert!(
                    close(p[c], mean[c], 1e-5),
                    "{multiple} ({x}, {y}) {p:?} {mean:?}"
                );
            }
        }
        // No randomness outside the smoke (rounding of Σl² − n·mean² aside); some inside.
        assert!(
            (0..3).all(|c| est[1].1[c] <= 1e-12 * est[1].0[c].powi(2)),
            "{:?}",
            est[1]
        );
        assert!(est[0].1.iter().all(|v| *v > 0.0));
        // The variance of the mean predicts the spread of means over seeds: over 40
        // seeds the sample variance of the means is within a factor 2 of the mean
        // predicted variance (a χ² of 39 degrees of freedom lies in [0.55, 1.5]× its
        // mean with probability > 0.99).
        let seeds: Vec<(Rgb, Rgb)> = (0..40)
            .map(|s| {
                render_pixels(
                    &v,
                    &m,
                    &env,
                    &camera,
                    &pixels[..1],
                    &RefOptions { seed: 100 + s, ..o },
                )[0]
            })
            .collect();
        let mean: f64 = seeds.iter().map(|e| e.0[0]).sum::<f64>() / 40.0;
        let spread: f64 = seeds.iter().map(|e| (e.0[0] - mean).powi(2)).sum::<f64>() / 39.0;
        let predicted: f64 = seeds.iter().map(|e| e.1[0]).sum::<f64>() / 40.0;
        assert!(
            spread / predicted > 0.5 && spread / predicted < 2.0,
            "{multiple}: {spread} vs {predicted}"
        );
    }
}
