//! The GPU view pass against its CPU twin `crm::view_pass`, on volume-pass grids of small
//! RBF scenes: the same pixels up to `f32` arithmetic.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.

use haze_gpu::{GpuContext, GpuError};
use haze_view::diffusion::DiffusionSolver;
use haze_view::gpu::view_pass::{ViewPass, view_pass};
use haze_view::ground::{Ground, GroundLight};
use haze_view::lighting::single::ShKit;
use haze_view::render::crm::{self, OPAQUE, VolumeGrids};
use haze_view::render::{CrmOptions, CrmStats, source_radiance};
use haze_view::sh;
use haze_view::{Camera, Environment, LatLong, Medium, Sky, Sun};
use haze_volume::{Bbox, Rbf};
use std::time::Instant;

mod common;
use common::{cluster, context, front_camera, unit_box};

/// Source radiance at the centers (single + multiple scattering, order 4), then the CPU
/// volume pass: the grids both view passes read.
fn grids(
    rbfs: &[Rbf],
    dims: [usize; 3],
    bbox: &Bbox,
    medium: &Medium,
    env: &Environment,
    eye: [f64; 3],
) -> VolumeGrids {
    let opts = CrmOptions::default();
    let kit = ShKit::new(opts.order);
    let light = sh::project_env(env, opts.order);
    let source = source_radiance(
        &kit,
        rbfs,
        medium,
        &light,
        env,
        &opts,
        &mut DiffusionSolver::new(),
        &mut CrmStats::default(),
    );
    crm::volume_pass(rbfs, &source, opts.order, dims, bbox, None, eye)
}

/// A lat-long map with detail in every texel (hash-scrambled values in [0.2, 2.2]).
fn busy_map(w: usize, h: usize) -> Environment {
    let texels = (0..w * h)
        .map(|i| {
            [0u64, 1, 2].map(|c| {
                let mut z = (i as u64 * 3 + c).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                z ^= z >> 29;
                0.2 + 2.0 * (z % 1000) as f32 / 1000.0
            })
        })
        .collect();
    Environment::map(LatLong::new(w, h, texels).unwrap())
}

/// Largest radiance the scene can put in a pixel: the brightest background or voxel.
fn brightest(env: &Environment, g: &VolumeGrids, cam: &Camera) -> f64 {
    let mut m: f64 = 0.0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            m = m.max(
                env.radiance(cam.pixel_ray(x, y))
                    .into_iter()
                    .fold(0.0, f64::max),
            );
        }
    }
    for j in &g.radiance {
        m = m.max(j.iter().fold(0.0f32, |a, b| a.max(*b)).into());
    }
    m
}

/// Renders with both view passes and checks every pixel and channel:
/// `|gpu − cpu| ≤ 1e-4·|cpu| + OPAQUE·brightest`.
///
/// The relative part is `f32` arithmetic: the march accumulates at most a few hundred
/// slices, each adding a few ulp (2⁻²⁴ ≈ 6e-8) of rounding in the ray, the trilinear
/// weights, `exp` and the products — ≈ 1e-5 relative at worst (measured on lavapipe:
/// below 1e-6 of the brightest pixel in every scene), and the lat-long lookup's `atan2`
/// (see `no_extinction_shows_the_background`); 1e-4 leaves a margin of ten. The
/// absolute part covers the two decisions `f32` may take differently from `f64`: where
/// the transmittance crosses `OPAQUE` (the march stops one slice apart: a change below
/// `OPAQUE` times the brightest radiance, background or smoke) and whether a slice sample
/// lying on the box's face is inside (a single slice of the faint density at the face).
/// Returns the largest absolute and relative (to the largest pixel) errors.
fn compare(
    ctx: &GpuContext,
    g: &VolumeGrids,
    medium: &Medium,
    env: &Environment,
    cam: &Camera,
    du: f64,
) -> (f64, f64) {
    compare_over(ctx, g, medium, env, cam, du, None)
}

/// [`compare`] with a ground behind the smoke.
fn compare_over(
    ctx: &GpuContext,
    g: &VolumeGrids,
    medium: &Medium,
    env: &Environment,
    cam: &Camera,
    du: f64,
    ground: Option<&GroundLight>,
) -> (f64, f64) {
    let t = Instant::now();
    let cpu = crm::view_pass(g, medium, env, cam, du, ground);
    let cpu_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let gpu = view_pass(ctx, g, medium, env, cam, du, ground).unwrap_or_else(|e| panic!("{e}"));
    let gpu_s = t.elapsed().as_secs_f64();
    assert_eq!(gpu.len(), cpu.len());
    let slack = OPAQUE
        * brightest(env, g, cam).max(
            cpu.iter()
                .flatten()
                .fold(0.0f64, |m, v| m.max(f64::from(*v))),
        );
    let (mut max_abs, mut max_ref) = (0.0f64, 0.0f64);
    for (i, (p, q)) in gpu.iter().zip(&cpu).enumerate() {
        for c in 0..3 {
            let (p, q) = (f64::from(p[c]), f64::from(q[c]));
            assert!(p.is_finite(), "pixel {i}: {p}");
            let err = (p - q).abs();
            max_abs = max_abs.max(err);
            max_ref = max_ref.max(q.abs());
            assert!(
                err <= 1e-4 * q.abs() + slack,
                "pixel ({}, {}) channel {c}: GPU {p}, CPU {q}",
                i % cam.width,
                i / cam.width
            );
        }
    }
    let rel = max_abs / max_ref.max(1e-30);
    println!(
        "{}×{}: max abs error {max_abs:.3e}, relative to the brightest pixel {rel:.3e}; CPU {cpu_s:.3} s, GPU {gpu_s:.3} s (with pipeline creation)",
        cam.width, cam.height
    );
    (max_abs, rel)
}

#[test]
fn sky_seen_through_smoke_matches_the_cpu() {
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    // 36 rows: not a multiple of the 8×8 workgroups.
    let cam = front_camera(48, 36);
    let g = grids(&rbfs, [32; 3], &bbox, &medium, &env, cam.eye);
    let du = crm::default_slice([32; 3], &bbox);
    compare(&ctx, &g, &medium, &env, &cam, du);
}

/// Multiple scattering's light carried to the eye through `σt(1 − Ωf)`
/// (`VolumeGrids::eye_peak`): at g 0.8's `Ωf` = 0.8·0.8⁵, and near `keep` = 0 where the
/// step's share is taken by its series (`crm::scattered_step`); the scattered light
/// grows with the share given back, the background's transmittance does not change.
#[test]
fn scattered_light_through_the_peaks_extinction_matches_the_cpu() {
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(6.0, 0.8, 0.8).unwrap();
    let cam = front_camera(40, 30);
    let mut g = grids(&rbfs, [24; 3], &bbox, &medium, &env, cam.eye);
    let du = crm::default_slice([24; 3], &bbox);
    let sum = |g: &VolumeGrids| -> f64 {
        crm::view_pass(g, &medium, &env, &cam, du, None)
            .iter()
            .flatten()
            .map(|&v| f64::from(v))
            .sum()
    };
    let mut last = sum(&g);
    for peak in [0.8 * 0.8f64.powi(5), 1.0 - 1e-7] {
        g.eye_peak = peak;
        compare(&ctx, &g, &medium, &env, &cam, du);
        let now = sum(&g);
        assert!(now > last, "Ωf {peak}: {now} after {last}");
        last = now;
    }
}

/// A ground at the floor of a box far from the origin, lit by the sky, a low sun whose
/// shadow of the smoke falls across the picture and a point light above it: the marched
/// shadow is the CPU's, and the ground is darker in the shadow than beside it.
#[test]
fn the_ground_and_its_shadow_match_the_cpu() {
    let ctx = context();
    let bbox = Bbox::new([40.0, -20.0, 5.0], [41.0, -19.0, 6.0]);
    let rbfs = cluster(&bbox);
    let mut env = Environment::sky(Sky::default());
    let e = 25f64.to_radians();
    env.suns.push(Sun {
        direction: [-e.cos(), 0.0, e.sin()],
        irradiance: [8.0, 7.0, 6.0],
        angle: 0.01,
    });
    env.points
        .push(haze_view::PointLight::new([40.5, -19.5, 7.0], [2.0, 2.0, 2.0]).unwrap());
    let medium = Medium::new(8.0, 0.8, 0.3).unwrap();
    let cam = Camera::new(
        [40.5, -21.5, 6.6],
        [40.8, -19.5, 5.2],
        [0.0, 0.0, 1.0],
        50.0,
        45,
        35,
    )
    .unwrap();
    let g = grids(&rbfs, [20; 3], &bbox, &medium, &env, cam.eye);
    let du = crm::default_slice([20; 3], &bbox);
    let ground = Ground::at(bbox.min[2]).lit(&env);
    compare_over(&ctx, &g, &medium, &env, &cam, du, Some(&ground));
    // The same smoke in a grid four times as wide, mostly air: the shadow rays pass over
    // its empty blocks (`ground::ShadowMarch`) on both sides.
    let wide = Bbox::new([39.5, -20.5, 5.0], [41.5, -18.5, 6.2]);
    let dims = [40, 40, 24];
    let sparse = grids(&rbfs, dims, &wide, &medium, &env, cam.eye);
    let du = crm::default_slice(dims, &wide);
    compare_over(&ctx, &sparse, &medium, &env, &cam, du, Some(&ground));
    // The sun comes from −x: the smoke's shadow lies on the ground at +x of it.
    let shaded = ground.radiance([41.3, -19.5, 5.0], |x, w, l| {
        haze_view::render::ground_shadow::marched_transmittance(&g.density, medium.sigma_t, x, w, l)
    });
    let open = ground.radiance([39.3, -19.5, 5.0], |x, w, l| {
        haze_view::render::ground_shadow::marched_transmittance(&g.density, medium.sigma_t, x, w, l)
    });
    assert!(
        shaded[0] < 0.9 * open[0],
        "shadow {shaded:?}, beside it {open:?}"
    );
    // Under the smoke the sky's share is well below 1 (`ground::sky_seen`), so the
    // pictures above compared it too; far outside the grid it is 1.
    let seen = ground
        .clone()
        .seeing_sky_through(&bbox, |x, w, l| {
            haze_view::render::ground_shadow::marched_transmittance(
                &g.density,
                medium.sigma_t,
                x,
                w,
                l,
            )
        })
        .sky_seen;
    let under = seen.at([40.5, -19.5, 5.0]);
    assert!(under[0] < 0.9, "{under:?}");
    assert_eq!(seen.at([60.0, -19.5, 5.0]), [1.0; 3]);
}

/// A point light inside the smoke, in a box far from the origin: the view pass adds its
/// light within four voxels of it along each ray (`near_light`: the chord's integral in
/// the angle seen from the light, the light's transmittance marched), on the GPU as on
/// the CPU; the pixel nearest the light's image is the picture's brightest.
#[test]
fn a_point_light_inside_the_smoke_matches_the_cpu() {
    let ctx = context();
    let bbox = Bbox::new([40.0, -20.0, 5.0], [41.0, -19.0, 6.0]);
    let rbfs = cluster(&bbox);
    let light = [40.52, -19.47, 5.45];
    let mut env = Environment::constant([0.05; 3]);
    env.points
        .push(haze_view::PointLight::new(light, [3.0, 2.5, 2.0]).unwrap());
    let medium = Medium::new(6.0, 0.9, 0.3).unwrap();
    let cam = Camera::new(
        [42.2, -21.1, 6.1],
        [40.5, -19.5, 5.45],
        [0.0, 0.0, 1.0],
        35.0,
        41,
        33,
    )
    .unwrap();
    let dims = [20; 3];
    let mut g = grids(&rbfs, dims, &bbox, &medium, &env, cam.eye);
    haze_view::render::lights_pass::lights_pass(&mut g, &env, &medium, cam.eye);
    let du = crm::default_slice(dims, &bbox);
    compare(&ctx, &g, &medium, &env, &cam, du);
    let cpu = crm::view_pass(&g, &medium, &env, &cam, du, None);
    let (px, py) = cam.project(light).unwrap();
    let at = py as usize * cam.width + px as usize;
    let brightest = (0..cpu.len()).max_by(|&a, &b| cpu[a][0].total_cmp(&cpu[b][0]));
    assert_eq!(brightest, Some(at), "the light at pixel ({px:.1}, {py:.1})");
}

/// The radiance at its extremes, through the view pass's logarithms (`view_grid.wgsl`
/// takes `ln J̃` once a voxel; an unlit channel is its sentinel): voxels unlit in one
/// channel or all three, subnormal, 10⁻³⁰ and 10³⁰ beside ordinary ones, so cells whose
/// corners span more than `MAX_SPAN` meet the floor — the same pixels as the CPU's `f64`
/// logarithms.
#[test]
fn radiance_at_its_extremes_matches_the_cpu() {
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(4.0, 0.9, 0.3).unwrap();
    let cam = front_camera(31, 23);
    let dims = [20, 18, 16];
    let mut g = grids(&rbfs, dims, &bbox, &medium, &env, cam.eye);
    for (i, r) in g.radiance.iter_mut().enumerate() {
        match i % 11 {
            0 => *r = [0.0; 3],
            1 => r[1] = 0.0,
            2 => *r = [1e-40, 1e-39, 1e-41],
            3 => r[2] = 1e-30,
            4 => r[0] = 1e30,
            _ => {}
        }
    }
    let du = crm::default_slice(dims, &bbox);
    let (_, rel) = compare(&ctx, &g, &medium, &env, &cam, du);
    assert!(rel < 1e-4, "{rel}");
}

#[test]
fn lat_long_map_and_opaque_smoke_from_inside_match_the_cpu() {
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = busy_map(16, 8);
    // σt = 40: peak optical depths ≈ 30, so most rays stop early at OPAQUE.
    let medium = Medium::new(40.0, 0.9, 0.5).unwrap();
    let cam = Camera::new(
        [0.5, 0.45, 0.45],
        [0.6, 0.9, 0.6],
        [0.0, 0.0, 1.0],
        70.0,
        37,
        29,
    )
    .unwrap();
    let g = grids(&rbfs, [24, 28, 20], &bbox, &medium, &env, cam.eye);
    let du = crm::default_slice([24, 28, 20], &bbox);
    compare(&ctx, &g, &medium, &env, &cam, du);
}

#[test]
fn box_far_from_the_origin_with_uneven_voxels_matches_the_cpu() {
    // World coordinates in the hundreds (a Blender domain placed in a scene): the GPU
    // works relative to the box, so f32 keeps its precision.
    let ctx = context();
    let bbox = Bbox::new([120.0, -40.0, 15.0], [121.5, -39.0, 17.0]);
    let dims = [24, 16, 40];
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(6.0, 0.7, 0.0).unwrap();
    let cam = Camera::framing(bbox.min, bbox.max, 35.0, 40, 40).unwrap();
    let g = grids(&rbfs, dims, &bbox, &medium, &env, cam.eye);
    // Two slice thicknesses: the default half voxel and a coarse one.
    for du in [crm::default_slice(dims, &bbox), 0.05] {
        compare(&ctx, &g, &medium, &env, &cam, du);
    }
}

#[test]
fn no_extinction_shows_the_background() {
    // σt = 0: every pixel is the environment, so this isolates the GPU's ray directions
    // and environment lookups from the march. The sky is a few products and a power:
    // measured 7e-7 of the brightest pixel. The map goes through `atan2`, whose f32
    // result is a few ulp off (more on some GPUs: Vulkan allows 4096 ulp), and every
    // texel of this map differs from its neighbour by up to 2 in radiance, 5 texels per
    // radian: measured 1.2e-5, i.e. φ off by ≈ 2.5e-6 rad.
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let medium = Medium::new(0.0, 0.8, 0.3).unwrap();
    let cam = Camera::new(
        [0.5, -1.3, 0.85],
        [0.5, 0.5, 0.52],
        [0.0, 0.0, 1.0],
        90.0,
        40,
        24,
    )
    .unwrap();
    for (env, tol) in [
        (Environment::sky(Sky::default()), 1e-5),
        (busy_map(32, 16), 1e-4),
    ] {
        let g = grids(&rbfs, [16; 3], &bbox, &medium, &env, cam.eye);
        let (_, rel) = compare(&ctx, &g, &medium, &env, &cam, 0.02);
        assert!(rel < tol, "{rel}");
    }
}

#[test]
fn suns_disks_in_the_background_match_the_cpu() {
    // `Environment::radiance` adds the suns' disks to the sky: a 6° sun at the smoke's
    // edge, a 0.53° one on a pixel's ray, and a zero-angle one (a light without a disk)
    // in view. No pixel's ray lies within f32 rounding of a disk's rim (checked), where
    // the two sides could decide differently.
    let ctx = context();
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let cam = Camera::new(
        [0.5, -1.3, 0.85],
        [0.5, 0.5, 0.52],
        [0.0, 0.0, 1.0],
        40.0,
        64,
        48,
    )
    .unwrap();
    let (f, r, u) = (cam.forward(), cam.right(), cam.up());
    let toward = |a: f64, b: f64| {
        let v = [0, 1, 2].map(|k| f[k] + a * r[k] + b * u[k]);
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|c| c / n)
    };
    let mut env = Environment::sky(Sky::default());
    env.suns = vec![
        Sun {
            direction: toward(0.12, 0.05),
            irradiance: [3.0, 2.8, 2.5],
            angle: 6f64.to_radians(),
        },
        Sun {
            direction: cam.pixel_ray(40, 10),
            irradiance: [1.0, 1.0, 1.0],
            angle: 0.53f64.to_radians(),
        },
        Sun {
            direction: toward(-0.1, -0.05),
            irradiance: [5.0; 3],
            angle: 0.0,
        },
    ];
    let mut covered = [0usize; 3];
    for y in 0..cam.height {
        for x in 0..cam.width {
            let d = cam.pixel_ray(x, y);
            for (k, sun) in env.suns.iter().enumerate() {
                let c: f64 = (0..3).map(|a| d[a] * sun.direction[a]).sum();
                if sun.angle > 0.0 {
                    let rim = (0.5 * sun.angle).cos();
                    assert!((c - rim).abs() > 1e-6, "pixel ({x}, {y}) on sun {k}'s rim");
                }
                covered[k] += usize::from(sun.covers(d));
            }
        }
    }
    assert!(
        covered[0] > 20 && covered[1] == 1 && covered[2] == 0,
        "{covered:?}"
    );
    for (sigma_t, tol) in [(0.0, 1e-5), (4.0, 1e-4)] {
        let medium = Medium::new(sigma_t, 0.8, 0.3).unwrap();
        let g = grids(&rbfs, [24; 3], &bbox, &medium, &env, cam.eye);
        let du = crm::default_slice([24; 3], &bbox);
        let (_, rel) = compare(&ctx, &g, &medium, &env, &cam, du);
        assert!(rel < tol, "σt {sigma_t}: {rel}");
    }
    // The disks are drawn: without them the images differ.
    let medium = Medium::new(0.0, 0.8, 0.3).unwrap();
    let g = grids(&rbfs, [8; 3], &bbox, &medium, &env, cam.eye);
    let with = view_pass(&ctx, &g, &medium, &env, &cam, 0.05, None).unwrap();
    let bare = Environment::sky(Sky::default());
    let without = view_pass(&ctx, &g, &medium, &bare, &cam, 0.05, None).unwrap();
    let brighter = with
        .iter()
        .zip(&without)
        .filter(|(a, b)| a[0] > b[0] + 100.0)
        .count();
    assert_eq!(brighter, covered[0] + covered[1]);
}

#[test]
fn a_compiled_pass_renders_many_frames_and_refuses_bad_input() {
    let ctx = context();
    let pass = ViewPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let rbfs = cluster(&bbox);
    let env = Environment::sky(Sky::default());
    let medium = Medium::new(4.0, 0.8, 0.3).unwrap();
    let cam = Camera::framing(bbox.min, bbox.max, 40.0, 16, 12).unwrap();
    let g = grids(&rbfs, [16; 3], &bbox, &medium, &env, cam.eye);
    let a = pass.run(&ctx, &g, &medium, &env, &cam, 0.03, None).unwrap();
    let b = pass.run(&ctx, &g, &medium, &env, &cam, 0.03, None).unwrap();
    assert_eq!(a, b, "the same frame twice");

    let mut bad = g.clone();
    bad.radiance.pop();
    let e = pass
        .run(&ctx, &bad, &medium, &env, &cam, 0.03, None)
        .unwrap_err();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    assert_eq!(
        e.to_string(),
        "the radiance grid has 4095 voxels, the density grid 4096"
    );
    for du in [0.0, -1.0, f64::NAN] {
        let e = pass
            .run(&ctx, &g, &medium, &env, &cam, du, None)
            .unwrap_err();
        assert!(e.to_string().contains("must be positive and finite"), "{e}");
    }
}
