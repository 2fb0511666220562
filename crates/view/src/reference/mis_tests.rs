//! Tests of the environment's importance sampling in the estimators: unbiased against
//! quadrature, and of lower variance than phase sampling alone where the map is sharp.

use rand::SeedableRng;

use super::*;
use crate::distant::direction;
use crate::medium::hg;
use crate::{LatLong, Sun};

fn cube() -> Bbox {
    Bbox::new([-1.0; 3], [1.0; 3])
}

/// Three overlapping Gaussians in [−1, 1]³ (as in `tests.rs`), peak density about 1.
fn blob() -> Volume {
    let rbfs = [
        Rbf::new([0.0, 0.0, 0.0], 0.45, 1.0),
        Rbf::new([0.35, 0.2, 0.3], 0.3, 0.6),
        Rbf::new([-0.4, -0.1, -0.2], 0.25, 0.8),
    ];
    rbf_volume(&rbfs, [16, 16, 16], cube()).unwrap()
}

/// A `w × h` map of a dim sky `[0.1, 0.12, 0.15]` with the texels `xs × ys` set to `patch`.
fn patch_map(
    (w, h): (usize, usize),
    xs: std::ops::Range<usize>,
    ys: std::ops::Range<usize>,
    patch: [f32; 3],
) -> Environment {
    let texels = (0..w * h)
        .map(|i| {
            if xs.contains(&(i % w)) && ys.contains(&(i / w)) {
                patch
            } else {
                [0.1, 0.12, 0.15]
            }
        })
        .collect();
    Environment::map(LatLong::new(w, h, texels).unwrap())
}

/// Mean and standard error of the mean, per channel, of `n` draws of `f`.
fn stats(n: usize, mut f: impl FnMut() -> Rgb) -> (Rgb, Rgb) {
    let (mut s, mut s2) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..n {
        let v = f();
        for c in 0..3 {
            s[c] += v[c];
            s2[c] += v[c] * v[c];
        }
    }
    let nf = n as f64;
    let mean = s.map(|v| v / nf);
    let se = [0, 1, 2].map(|c| ((s2[c] / nf - mean[c] * mean[c]).max(0.0) / (nf - 1.0)).sqrt());
    (mean, se)
}

/// `(1/4π)∫ p(ω·d)·T(x, ω)·L(ω) dω` by the midpoint rule on a `w × h` lat-long grid
/// (each cell of exact solid angle, `L` and `T` looked up at its center).
fn in_scattered_quadrature(
    scene: &Scene<'_>,
    x: [f64; 3],
    d: [f64; 3],
    (w, h): (usize, usize),
) -> Rgb {
    let mut out = [0.0; 3];
    for y in 0..h {
        let (t0, t1) = (PI * y as f64 / h as f64, PI * (y + 1) as f64 / h as f64);
        let omega = 2.0 * PI / w as f64 * (t0.cos() - t1.cos());
        for xx in 0..w {
            let wdir = direction(0.5 * (t0 + t1), 2.0 * PI * (xx as f64 + 0.5) / w as f64);
            let l = scene.env.distant.radiance(wdir);
            let f = hg(scene.medium.g, dot(wdir, d)) / FOUR_PI
                * scene.transmittance(x, wdir, f64::INFINITY)
                * omega;
            for c in 0..3 {
                out[c] += f * l[c];
            }
        }
    }
    out
}

use std::f64::consts::PI;

/// Checks `distant_light` at a point of `volume` lit by the map `env`, with and without
/// the sampler, against the quadrature on a 512 × 256 grid (a multiple of the map's
/// texels, so that no cell straddles a texel center): each mean within 5 standard
/// errors plus the quadrature's own error (its change from the 256 × 128 grid).
/// Returns the variances of channel 0, (MIS, phase only).
fn check_in_scattering(
    volume: &Volume,
    env: &Environment,
    g: f64,
    x: [f64; 3],
    d: [f64; 3],
    n: usize,
) -> (f64, f64) {
    let medium = Medium::new(2.0, 1.0, g).unwrap();
    let sampler = sampler_for(env, &RefOptions::default());
    assert!(sampler.is_some());
    let with = Scene::new(volume, &medium, env, sampler.as_ref(), None);
    let without = Scene {
        sampler: None,
        ..with
    };
    let fine = in_scattered_quadrature(&with, x, d, (512, 256));
    let coarse = in_scattered_quadrature(&with, x, d, (256, 128));
    let mut rng = Pcg64::seed_from_u64(3);
    let mut var = [0.0; 2];
    for (i, scene) in [with, without].iter().enumerate() {
        let (mean, se) = stats(n, || distant_light(scene, x, d, &mut rng));
        var[i] = se[0] * se[0] * n as f64;
        for c in 0..3 {
            let tol = 5.0 * se[c] + (fine[c] - coarse[c]).abs();
            eprintln!(
                "g {g} {}: {:.5} vs quadrature {:.5} (± {tol:.1e})",
                ["MIS", "phase only"][i],
                mean[c],
                fine[c]
            );
            assert!(
                (mean[c] - fine[c]).abs() < tol,
                "{} vs {}",
                mean[c],
                fine[c]
            );
        }
    }
    eprintln!("variance: MIS {:.3e}, phase only {:.3e}", var[0], var[1]);
    (var[0], var[1])
}

#[test]
fn mis_in_scattering_under_a_bright_patch_matches_quadrature_with_less_variance() {
    // A 2 × 2 patch 10⁴ times the sky on a 64 × 32 map: ≈ 0.03 sr carrying ≈ 97 % of
    // the light, which phase sampling hits about once in 400 directions.
    let env = patch_map((64, 32), 40..42, 10..12, [2000.0, 1800.0, 1500.0]);
    let volume = blob();
    let patch = direction(PI * 11.0 / 32.0, 2.0 * PI * 41.0 / 64.0);
    let x = [0.2, -0.1, 0.1];
    let n = 20_000;
    // Isotropic, and forward scattering with the patch away from the peak: map sampling
    // finds the patch, phase sampling rarely does.
    for (g, d) in [(0.0, [0.0, 0.0, 1.0]), (0.9, patch.map(|c| -c))] {
        let (mis, phase) = check_in_scattering(&volume, &env, g, x, d, n);
        assert!(mis < 0.01 * phase, "g {g}: {mis} vs {phase}");
    }
    // The patch in the forward peak (g = 0.9, within a texel of it): phase sampling is
    // the better strategy there, and MIS must stay close to it.
    let (mis, phase) = check_in_scattering(&volume, &env, 0.9, x, patch, n);
    assert!(mis < 2.0 * phase, "{mis} vs {phase}");
}

#[test]
fn mis_in_scattering_under_a_one_row_map_matches_quadrature() {
    // One row of 16 texels (radiance a function of azimuth only), three of them 500×.
    let texels = (0..16)
        .map(|x| {
            if (5..8).contains(&x) {
                [50.0, 40.0, 30.0]
            } else {
                [0.1, 0.1, 0.1]
            }
        })
        .collect();
    let env = Environment::map(LatLong::new(16, 1, texels).unwrap());
    for g in [0.0, 0.6] {
        let (mis, phase) =
            check_in_scattering(&blob(), &env, g, [-0.3, 0.2, 0.0], [0.6, 0.0, 0.8], 10_000);
        assert!(mis < phase, "g {g}: {mis} vs {phase}");
    }
}

#[test]
fn a_black_map_falls_back_to_phase_sampling_and_lights_nothing() {
    let black = Environment::map(LatLong::new(8, 4, vec![[0.0; 3]; 32]).unwrap());
    assert!(sampler_for(&black, &RefOptions::default()).is_none());
    let v = blob();
    let m = Medium::new(3.0, 0.9, 0.5).unwrap();
    let cam = Camera::framing(cube().min, cube().max, 40.0, 8, 6).unwrap();
    let mut lit = black.clone();
    lit.suns
        .push(crate::lights::Sun::from_radiance([0.3, -0.5, 0.8], [800.0; 3], 2.0).unwrap());
    for multiple in [false, true] {
        let o = RefOptions {
            spp: 8,
            multiple,
            ..RefOptions::default()
        };
        let im = render(&v, &m, &black, &cam, &o);
        assert!(im.pixels.iter().all(|p| *p == [0.0; 3]));
        // With a sun: the same image as without environment sampling, finite.
        let a = render(&v, &m, &lit, &cam, &o);
        let b = render(
            &v,
            &m,
            &lit,
            &cam,
            &RefOptions {
                env_sampling: false,
                ..o
            },
        );
        assert_eq!(a, b);
        assert!(a.pixels.iter().flatten().all(|c| c.is_finite()));
        assert!(a.pixels.iter().flatten().any(|c| *c > 0.0));
    }
}

/// The unit slab `0 ≤ z ≤ 1` (unit density, extinction `s`) seen straight down from
/// above under a distant radiance whose mean over azimuth is `l(μ)` at `μ = cos θ`
/// (`l[j]` on `l.len()` cells of `μ` from −1 to 1) and `l_down` straight down:
/// `L = e^{−s}·l_down + Ω·s ∫₀¹ e^{−s·u} ½∫₋₁¹ p(−μ)·l(μ)·e^{−s·ℓ(1−u, μ)} dμ du` (the
/// single-scattering quadrature of `tests.rs` with the light depending on `μ`), by the
/// midpoint rule with `nu` cells in depth.
fn slab(s: f64, albedo: f64, g: f64, l_down: f64, l: &[f64], nu: usize) -> f64 {
    let nm = l.len();
    let mut outer = 0.0;
    for i in 0..nu {
        let u = (i as f64 + 0.5) / nu as f64;
        let z = 1.0 - u;
        let mut inner = 0.0;
        for (j, lj) in l.iter().enumerate() {
            let mu = -1.0 + (j as f64 + 0.5) * 2.0 / nm as f64;
            let len = if mu > 0.0 { (1.0 - z) / mu } else { z / -mu };
            inner += 0.5 * hg(g, -mu) * lj * (-s * len).exp() * 2.0 / nm as f64;
        }
        outer += (-s * u).exp() * inner / nu as f64;
    }
    (-s).exp() * l_down + albedo * s * outer
}

#[test]
fn both_estimators_with_mis_match_quadrature_in_a_slab_under_a_ring() {
    // An 8 × 16 map: a ring of rows 2–3 (θ 22–34°) 400× brighter than the rest, modulated
    // in azimuth. The 100 × 100 × 1 box is a slab for the central ray (as in `tests.rs`).
    // Each estimator (single scattering; paths cut at one bounce) within 5 standard
    // errors of its samples plus the quadrature's error (its change at half resolution).
    let (w, h) = (8, 16);
    let texels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let a = 1.0 + 0.5 * (x % 3) as f32;
            if (2..4).contains(&y) {
                [200.0 * a, 150.0 * a, 100.0]
            } else {
                [0.5, 0.5, 0.5 * a]
            }
        })
        .collect();
    let env = Environment::map(LatLong::new(w, h, texels).unwrap());
    // l(μ) on `nm` cells, each the azimuthal mean of 64 lookups (8 per texel, so that no
    // piece of the piecewise-linear lookup is straddled: exact).
    let l_of = |nm: usize| -> Vec<f64> {
        (0..nm)
            .map(|j| {
                let theta = (-1.0 + (j as f64 + 0.5) * 2.0 / nm as f64).acos();
                (0..64)
                    .map(|k| {
                        let phi = 2.0 * PI * (k as f64 + 0.5) / 64.0;
                        env.distant.radiance(direction(theta, phi))[0]
                    })
                    .sum::<f64>()
                    / 64.0
            })
            .collect()
    };
    let l_down = env.distant.radiance([0.0, 0.0, -1.0])[0];
    let (fine_l, coarse_l) = (l_of(2000), l_of(1000));
    let bbox = Bbox::new([-50.0, -50.0, 0.0], [50.0, 50.0, 1.0]);
    let v = Volume::new([2, 2, 2], bbox, vec![1.0; 8]).unwrap();
    let (o, d) = ([0.0, 0.0, 3.0], [0.0, 0.0, -1.0]);
    let sampler = sampler_for(&env, &RefOptions::default());
    for (s, albedo, g) in [(0.5, 0.8, 0.0), (1.0, 0.9, 0.9), (2.0, 1.0, -0.4)] {
        let m = Medium::new(s, albedo, g).unwrap();
        let fine = slab(s, albedo, g, l_down, &fine_l, 1000);
        let coarse = slab(s, albedo, g, l_down, &coarse_l, 500);
        let scene = Scene::new(&v, &m, &env, sampler.as_ref(), None);
        for multiple in [false, true] {
            let opts = RefOptions {
                spp: 1,
                light_samples: 1,
                multiple,
                max_bounces: 1,
                ..RefOptions::default()
            };
            let mut rng = Pcg64::seed_from_u64(5);
            let (mean, se) = stats(20_000, || {
                if multiple {
                    path::radiance(&scene, o, d, &opts, &mut rng)
                } else {
                    single::radiance(&scene, o, d, &opts, &mut rng)
                }
            });
            let tol = 5.0 * se[0] + (fine - coarse).abs();
            eprintln!(
                "slab σ {s} Ω {albedo} g {g}, multiple {multiple}: {:.5} vs {fine:.5} (± {tol:.1e})",
                mean[0]
            );
            assert!((mean[0] - fine).abs() < tol, "{} vs {fine}", mean[0]);
        }
    }
}

#[test]
fn path_tracing_with_and_without_mis_agree_under_a_patch() {
    // All orders, one ray through the blob, a 4 × 4 patch 100× the sky: the two
    // estimators' means within 5 combined standard errors; MIS with less variance.
    let env = patch_map((32, 16), 4..8, 3..7, [10.0, 12.0, 15.0]);
    let v = blob();
    let m = Medium::new(4.0, 0.95, 0.5).unwrap();
    let sampler = sampler_for(&env, &RefOptions::default());
    let with = Scene::new(&v, &m, &env, sampler.as_ref(), None);
    let without = Scene {
        sampler: None,
        ..with
    };
    let opts = RefOptions {
        spp: 1,
        ..RefOptions::default()
    };
    let (o, d) = ([0.0, -3.0, 0.2], [0.0, 1.0, 0.0]);
    let mut rng = Pcg64::seed_from_u64(9);
    let (a, sa) = stats(20_000, || path::radiance(&with, o, d, &opts, &mut rng));
    let (b, sb) = stats(20_000, || path::radiance(&without, o, d, &opts, &mut rng));
    for c in 0..3 {
        let tol = 5.0 * (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
        eprintln!(
            "paths, channel {c}: MIS {:.5} ± {:.1e}, phase only {:.5} ± {:.1e}",
            a[c], sa[c], b[c], sb[c]
        );
        assert!((a[c] - b[c]).abs() < tol, "{} vs {}", a[c], b[c]);
    }
    assert!(sa[0] < sb[0], "{} vs {}", sa[0], sb[0]);
}

/// The map is importance-sampled only while it brings more light than the suns: its
/// power `∫ Y dω` against the closed form of a two-valued map (upper half luminance 1,
/// lower half 0.5: `2π + π`), and the sampler kept with suns of 0.9× that luminance and
/// dropped at 1.1× (phase sampling alone then collects the map).
#[test]
fn the_map_is_sampled_only_while_it_outshines_the_suns() {
    let (w, h) = (8, 4);
    let texels = (0..w * h)
        .map(|i| if i / w < h / 2 { [1.0; 3] } else { [0.5; 3] })
        .collect();
    let map = LatLong::new(w, h, texels).unwrap();
    let sampler = EnvSampler::new(&map).unwrap();
    let power = 3.0 * std::f64::consts::PI;
    assert!(
        (sampler.power() - power).abs() < 1e-9 * power,
        "{} vs {power}",
        sampler.power()
    );
    let opts = RefOptions::default();
    let with_sun = |y: f64| {
        let mut env = Environment::map(map.clone());
        // A grey zero-angle sun: irradiance = the given radiance, luminance y.
        env.suns
            .push(Sun::from_radiance([0.3, 0.2, 0.9], [y; 3], 0.0).unwrap());
        env
    };
    assert!(sampler_for(&Environment::map(map.clone()), &opts).is_some());
    assert!(sampler_for(&with_sun(0.9 * power), &opts).is_some());
    assert!(sampler_for(&with_sun(1.1 * power), &opts).is_none());
}
