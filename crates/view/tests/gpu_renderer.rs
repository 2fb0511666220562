//! The GPU renderer (`gpu::renderer`: single scattering, the diffusion, the volume and
//! view passes, all on the GPU) against `crm_render`, and its reuse rules: a camera
//! move reuses the sources, and with `g = 0` the grids too, giving the image a fresh
//! render gives; a new frame, medium or lighting recomputes everything.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** The chained volume and view passes match the CPU within 1.2e-6 of the
//! brightest radiance (`gpu_volume_pass.rs`); single scattering on the GPU carries a
//! relative error of up to 3e-5 per unit of optical depth `‖f‖` in `J̃ss`
//! (`gpu_single_scattering.rs`; ‖f‖ ≤ 6 here, so ≤ 2e-4), which the view pass passes on
//! scaled by the in-scattered radiance, itself below the brightest radiance; the diffusion
//! (in `f32` on the GPU, to 1e-6 on the CPU) adds at most `20 ε (1 + κ)` relative
//! (`gpu_diffusion.rs`; κ < 10 for this cluster, so < 3e-5). A pixel may also differ by the
//! march's early exit, `OPAQUE` = 1e-4 of the brightest. So `|ΔI| ≤ 5e-4 · brightest`
//! per pixel and channel leaves a margin of more than 1.5 over the sum. The environment
//! pass of the default `EnvSource::Grid` adds at most 5e-3 of its own brightest `J`
//! (`gpu_env_pass.rs`; measured 2e-4 at this optical depth), a part of the light that the
//! view pass attenuates, within the same bound. Both take the environment grid's depths
//! by the same sweep (`EnvDepths::Sweep`, the default).

use haze_view::gpu::renderer::{GpuFrame, GpuRenderer, LightingOn, Reuse};
use haze_view::render::env_pass::EnvSource;
use haze_view::render::{CrmOptions, MsDiffusion, crm_render};
use haze_view::{Camera, Distant, Environment, LatLong, Medium, PointLight, Sky, Sun};
use haze_volume::Rbf;

mod common;
use common::{context, unit_box};

fn cluster() -> Vec<Rbf> {
    common::cluster(&unit_box())
}

fn camera(eye: [f64; 3]) -> Camera {
    Camera::new(eye, [0.5, 0.5, 0.52], [0.0, 0.0, 1.0], 40.0, 44, 30).unwrap()
}

/// Largest difference relative to the brightest radiance of the CPU image, after
/// asserting the module's bound.
fn compare(gpu: &[[f32; 3]], cpu: &[[f32; 3]], what: &str) -> f64 {
    assert_eq!(gpu.len(), cpu.len(), "{what}");
    let bright = f64::from(cpu.iter().flatten().fold(0.0f32, |a, &b| a.max(b)));
    let mut worst: f64 = 0.0;
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        for k in 0..3 {
            let d = f64::from((g[k] - c[k]).abs());
            assert!(
                d <= 5e-4 * bright,
                "{what}: pixel {i} channel {k}: GPU {g:?}, CPU {c:?} (brightest {bright})"
            );
            worst = worst.max(d / bright);
        }
    }
    println!("{what}: largest difference {worst:.2e} of the brightest pixel");
    worst
}

#[test]
fn frames_match_crm_render_at_every_setting() {
    let ctx = context();
    let rbfs = cluster();
    let bbox = unit_box();
    let dims = [20, 24, 18];
    let env = Environment::sky(Sky::default());
    let cam = camera([0.5, -1.3, 0.85]);
    let frame = GpuFrame {
        key: 0,
        rbfs: &rbfs,
        residual: None,
        dims,
        bbox,
    };
    // The light on either side of the bus.
    for on in [LightingOn::Gpu, LightingOn::Cpu] {
        let mut r = GpuRenderer::new(&ctx, env.clone()).unwrap();
        r.set_lighting(on);
        for (order, multiple, g, sigma_t) in [
            (2, true, 0.0, 5.0),
            (4, true, 0.5, 5.0),
            (4, false, -0.3, 5.0),
            (6, true, 0.2, 12.0),
            (1, true, 0.0, 5.0),
        ] {
            let opts = CrmOptions {
                order,
                multiple,
                ..CrmOptions::default()
            };
            let medium = Medium::new(sigma_t, 0.9, g).unwrap();
            let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &env, &cam, &opts);
            let (image, stats) = r.render(&ctx, &frame, &medium, &cam, &opts).unwrap();
            assert_eq!(stats.reuse, Reuse::Nothing, "a new medium or order");
            assert_eq!(stats.solved, multiple);
            let gpu = image.read(&ctx).unwrap();
            compare(
                &gpu,
                &cpu.pixels,
                &format!(
                    "lighting {on:?}, order {order}, multiple {multiple}, g {g}, σt {sigma_t}"
                ),
            );
            if multiple {
                let d = r.diffusion_stats(&ctx).unwrap().unwrap();
                assert!(d.converged && d.iterations > 0, "{on:?}: {d:?}");
            }
        }
    }
}

#[test]
fn camera_moves_reuse_what_does_not_depend_on_the_camera() {
    let ctx = context();
    let rbfs = cluster();
    let bbox = unit_box();
    let dims = [16, 16, 16];
    let env = Environment::sky(Sky::default());
    let opts = CrmOptions::default();
    let frame = GpuFrame {
        key: 7,
        rbfs: &rbfs,
        residual: None,
        dims,
        bbox,
    };
    let (a, b) = (camera([0.5, -1.3, 0.85]), camera([1.8, 0.2, 0.6]));
    for g in [0.0, 0.6] {
        let medium = Medium::new(6.0, 0.9, g).unwrap();
        // The GPU's own passes (the CPU's grids: `cpu_grids_are_kept_while_their_frame_holds`).
        let mut r = GpuRenderer::new(&ctx, env.clone()).unwrap();
        r.set_lighting(LightingOn::Gpu);
        let (_, first) = r.render(&ctx, &frame, &medium, &a, &opts).unwrap();
        assert_eq!(first.reuse, Reuse::Nothing);
        let (moved, stats) = r.render(&ctx, &frame, &medium, &b, &opts).unwrap();
        let expect = if g == 0.0 {
            Reuse::Grids
        } else {
            Reuse::Sources
        };
        assert_eq!(stats.reuse, expect, "g {g}");
        // The reused image is the fresh one: a new renderer computes everything.
        let mut fresh = GpuRenderer::new(&ctx, env.clone()).unwrap();
        fresh.set_lighting(LightingOn::Gpu);
        let (again, _) = fresh.render(&ctx, &frame, &medium, &b, &opts).unwrap();
        let (moved, again) = (moved.read(&ctx).unwrap(), again.read(&ctx).unwrap());
        let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &env, &b, &opts);
        compare(&moved, &cpu.pixels, &format!("reused, g {g}"));
        compare(&again, &cpu.pixels, &format!("fresh, g {g}"));

        // A knob of the view pass alone (slices) reuses the grids; the residual toggle
        // reuses the sources; a new frame, medium or lighting recomputes everything.
        let slices = CrmOptions {
            slices_per_voxel: 3.0,
            ..opts
        };
        let (_, s) = r.render(&ctx, &frame, &medium, &b, &slices).unwrap();
        assert_eq!(s.reuse, Reuse::Grids);
        let no_residual = CrmOptions {
            residual: false,
            ..slices
        };
        let (_, s) = r.render(&ctx, &frame, &medium, &b, &no_residual).unwrap();
        assert_eq!(s.reuse, Reuse::Sources);
        let next = GpuFrame { key: 8, ..frame };
        let (_, s) = r.render(&ctx, &next, &medium, &b, &opts).unwrap();
        assert_eq!(s.reuse, Reuse::Nothing);
        let thicker = Medium::new(7.0, 0.9, g).unwrap();
        let (_, s) = r.render(&ctx, &next, &thicker, &b, &opts).unwrap();
        assert_eq!(s.reuse, Reuse::Nothing);
        r.set_environment(
            &ctx,
            Environment::sky(Sky {
                sun_direction: [0.0, 0.0, 1.0],
                ..Sky::default()
            }),
        )
        .unwrap();
        let (_, s) = r.render(&ctx, &next, &thicker, &b, &opts).unwrap();
        assert_eq!(s.reuse, Reuse::Nothing);
    }
}

#[test]
fn cpu_grids_are_kept_while_their_frame_holds() {
    // `LightingOn::Cpu`: every grid of light from the CPU (gpu::host_grids), lit by a sky,
    // a sun and a point light with the explicit orders; a camera move keeps the frame's
    // light and rebuilds the grids from the new eye, `g = 0` keeps the grids too, a new
    // albedo and g keep the environment grid; each image is the CPU renderer's from its
    // camera within the view pass's bound.
    let ctx = context();
    let rbfs = cluster();
    let bbox = unit_box();
    let dims = [16, 18, 20];
    let env = sky_sun_and_point(3.0, ([0.7, 0.3, 0.6], [0.5, 0.4, 0.3]));
    let frame = GpuFrame {
        key: 9,
        rbfs: &rbfs,
        residual: None,
        dims,
        bbox,
    };
    let opts = CrmOptions::default();
    let (a, b) = (camera([0.5, -1.3, 0.85]), camera([1.8, 0.2, 0.6]));
    for g in [0.6, 0.0] {
        let medium = Medium::new(8.0, 0.9, g).unwrap();
        let mut r = GpuRenderer::new(&ctx, env.clone()).unwrap();
        r.set_lighting(LightingOn::Cpu);
        let mut check = |cam: &Camera, reuse: Reuse, what: &str| {
            let (image, stats) = r.render(&ctx, &frame, &medium, cam, &opts).unwrap();
            assert_eq!(stats.reuse, reuse, "{what}, g {g}");
            assert_eq!(stats.solved, reuse == Reuse::Nothing, "{what}, g {g}");
            let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &env, cam, &opts);
            compare(
                &image.read(&ctx).unwrap(),
                &cpu.pixels,
                &format!("{what}, g {g}"),
            );
        };
        check(&a, Reuse::Nothing, "first");
        check(&a, Reuse::Grids, "again");
        let moved = if g == 0.0 {
            Reuse::Grids
        } else {
            Reuse::Sources
        };
        check(&b, moved, "moved");
        let solve = r.diffusion_stats(&ctx).unwrap().unwrap();
        assert!(solve.converged && solve.iterations > 0, "{solve:?}");
        assert_eq!(r.env_grid_builds(), 1);
        // A new albedo and g: the frame's light again, on the same environment grid.
        let other = Medium::new(8.0, 0.7, -0.3).unwrap();
        let (image, s) = r.render(&ctx, &frame, &other, &b, &opts).unwrap();
        assert_eq!((s.reuse, r.env_grid_builds()), (Reuse::Nothing, 1));
        let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &other, &env, &b, &opts);
        compare(&image.read(&ctx).unwrap(), &cpu.pixels, "new albedo and g");
        // A new σt or frame computes everything, its environment grid included.
        let thick = Medium::new(10.0, 0.7, -0.3).unwrap();
        r.render(&ctx, &frame, &thick, &b, &opts).unwrap();
        assert_eq!(r.env_grid_builds(), 2);
        let next = GpuFrame { key: 10, ..frame };
        let (_, s) = r.render(&ctx, &next, &thick, &b, &opts).unwrap();
        assert_eq!((s.reuse, r.env_grid_builds()), (Reuse::Nothing, 3));
    }
}

#[test]
fn a_grid_over_the_devices_buffers_is_refused_on_either_side() {
    // One voxel more than the device's storage buffers hold (16 bytes each): a one-line
    // `TooLarge`, whichever side computes the light (the CPU's before computing it).
    let ctx = context();
    let voxels = ctx.storage_limit() / 16 + 1;
    let dims = [256, 256, voxels.div_ceil(256 * 256) as usize];
    let frame = GpuFrame {
        key: 0,
        rbfs: &[],
        residual: None,
        dims,
        bbox: unit_box(),
    };
    let medium = Medium::new(5.0, 0.9, 0.3).unwrap();
    for on in [LightingOn::Cpu, LightingOn::Gpu] {
        let mut r = GpuRenderer::new(&ctx, Environment::sky(Sky::default())).unwrap();
        r.set_lighting(on);
        let cam = camera([0.5, -1.3, 0.85]);
        match r.render(&ctx, &frame, &medium, &cam, &CrmOptions::default()) {
            Err(e @ haze_gpu::GpuError::TooLarge { .. }) => {
                let line = e.to_string();
                assert!(line.contains("volume") && !line.contains('\n'), "{line}");
            }
            other => panic!("{on:?}: {:?}", other.map(|(_, s)| s.reuse)),
        }
    }
}

#[test]
fn a_lat_long_map_lights_and_fills_the_background_as_on_the_cpu() {
    let ctx = context();
    let rbfs = cluster();
    let bbox = unit_box();
    let dims = [16, 16, 16];
    // A map with a warm upper half and a bright patch: texel jumps and an anisotropic light.
    let (w, h) = (32, 16);
    let texels = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if (10..14).contains(&x) && (3..6).contains(&y) {
                [6.0, 5.0, 4.0]
            } else if y < h / 2 {
                [0.9, 0.7, 0.5]
            } else {
                [0.2, 0.25, 0.3]
            }
        })
        .collect();
    let env = Environment::map(LatLong::new(w, h, texels).unwrap());
    let medium = Medium::new(6.0, 0.9, 0.3).unwrap();
    let opts = CrmOptions::default();
    let cam = camera([0.5, -1.3, 0.85]);
    let mut r = GpuRenderer::new(&ctx, Environment::sky(Sky::default())).unwrap();
    r.set_environment(&ctx, env.clone()).unwrap();
    let frame = GpuFrame {
        key: 1,
        rbfs: &rbfs,
        residual: None,
        dims,
        bbox,
    };
    let (image, _) = r.render(&ctx, &frame, &medium, &cam, &opts).unwrap();
    let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &env, &cam, &opts);
    compare(&image.read(&ctx).unwrap(), &cpu.pixels, "lat-long map");
    // A sky the view pass cannot take is refused, and the map stays.
    let bad = Environment::sky(Sky {
        sharpness: -1.0,
        ..Sky::default()
    });
    let e = r.set_environment(&ctx, bad).unwrap_err();
    assert!(e.to_string().contains("sharpness"), "{e}");
    assert!(matches!(r.environment().distant, Distant::Map(_)));
}

/// The built-in sky with a sun `sun_deg` wide, high in the sky, and a point light
/// (position, intensity).
fn sky_sun_and_point(sun_deg: f64, point: ([f64; 3], [f64; 3])) -> Environment {
    let mut env = Environment::sky(Sky::default());
    env.suns.push(Sun {
        direction: [0.3, 0.2, 0.93].map(|c| c / 0.9949f64.sqrt()),
        irradiance: [8.0, 7.5, 6.5],
        angle: sun_deg.to_radians(),
    });
    env.points.push(PointLight::new(point.0, point.1).unwrap());
    env
}

#[test]
fn frames_lit_by_a_sun_and_a_point_light_match_crm_render() {
    // The lights reach the image twice: per voxel through the lights pass (single
    // scattering, shadows marched) and at the centers through the diffusion's source (on
    // the GPU: moments computed on the host and added in `setup`). Both lighting paths,
    // isotropic and forward scattering, with and without the diffusion.
    let ctx = context();
    let rbfs = cluster();
    let bbox = unit_box();
    let dims = [20, 24, 18];
    let env = sky_sun_and_point(0.53, ([1.2, 0.3, 0.6], [1.5, 1.2, 1.0]));
    let frame = GpuFrame {
        key: 3,
        rbfs: &rbfs,
        residual: None,
        dims,
        bbox,
    };
    let (a, b) = (camera([0.5, -1.3, 0.85]), camera([1.8, 0.2, 0.6]));
    for on in [LightingOn::Gpu, LightingOn::Cpu] {
        let mut r = GpuRenderer::new(&ctx, env.clone()).unwrap();
        r.set_lighting(on);
        for (order, multiple, g) in [(4, true, 0.5), (2, true, 0.0), (4, false, 0.8)] {
            let opts = CrmOptions {
                order,
                multiple,
                ..CrmOptions::default()
            };
            let medium = Medium::new(6.0, 0.9, g).unwrap();
            let what = format!("lit, lighting {on:?}, order {order}, multiple {multiple}, g {g}");
            let timed = on == LightingOn::Gpu && multiple && ctx.time_stages(true);
            let (image, stats) = r.render(&ctx, &frame, &medium, &a, &opts).unwrap();
            if timed {
                let names: Vec<&str> = stats.gpu.iter().map(|(n, _)| *n).collect();
                // The lights' shadow volume is the frame's first render's, kept after it
                // (the same frame and σt); the environment grid is rebuilt with the order.
                let shadow = (order, g) == (4, 0.5);
                let expect: Vec<&str> = [
                    "single scattering",
                    "diffusion",
                    "remove single",
                    "volume pass",
                    "grid occupancy",
                    "environment grid",
                    "environment pass",
                    "lights shadow volume",
                    "lights pass",
                    "view pass occupancy",
                    "view pass grid",
                    "view pass",
                ]
                .into_iter()
                .filter(|n| shadow || *n != "lights shadow volume")
                .collect();
                assert_eq!(names, expect);
            }
            ctx.time_stages(false);
            let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &env, &a, &opts);
            compare(&image.read(&ctx).unwrap(), &cpu.pixels, &what);
            // A camera move: with g = 0 the grids (lights included) are reused.
            let (moved, stats) = r.render(&ctx, &frame, &medium, &b, &opts).unwrap();
            let expect = if g == 0.0 {
                Reuse::Grids
            } else {
                Reuse::Sources
            };
            assert_eq!(stats.reuse, expect, "{what}");
            let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &env, &b, &opts);
            compare(
                &moved.read(&ctx).unwrap(),
                &cpu.pixels,
                &format!("{what}, moved"),
            );
        }
        // The sun is most of the light: moving it changes the image.
        let medium = Medium::new(6.0, 0.9, 0.0).unwrap();
        let opts = CrmOptions::default();
        let (lit, _) = r.render(&ctx, &frame, &medium, &a, &opts).unwrap();
        let mut moved = env.clone();
        moved.suns[0].direction = [-0.6, 0.1, 0.8].map(|c| c / 1.01f64.sqrt());
        r.set_environment(&ctx, moved.clone()).unwrap();
        let (other, s) = r.render(&ctx, &frame, &medium, &a, &opts).unwrap();
        assert_eq!(s.reuse, Reuse::Nothing, "new lights recompute everything");
        let (lit, other) = (lit.read(&ctx).unwrap(), other.read(&ctx).unwrap());
        let (cpu, _) = crm_render(&rbfs, None, dims, &bbox, &medium, &moved, &a, &opts);
        compare(&other, &cpu.pixels, &format!("lighting {on:?}, sun moved"));
        let change = lit
            .iter()
            .zip(&other)
            .map(|(p, q)| (p[0] - q[0]).abs())
            .fold(0.0f32, f32::max);
        let bright = lit.iter().flatten().fold(0.0f32, |a, &b| a.max(b));
        assert!(
            change > 0.05 * bright,
            "moving the sun changed the image by {change} (brightest {bright})"
        );
    }
}

#[test]
fn stage_times_come_from_timestamps_where_the_device_has_them() {
    let ctx = context();
    let on = ctx.time_stages(true);
    assert_eq!(on, ctx.has_timestamps());
    let rbfs = cluster();
    let mut r = GpuRenderer::new(&ctx, Environment::sky(Sky::default())).unwrap();
    r.set_lighting(LightingOn::Gpu);
    let frame = GpuFrame {
        key: 0,
        rbfs: &rbfs,
        residual: None,
        dims: [12, 12, 12],
        bbox: unit_box(),
    };
    let medium = Medium::new(5.0, 0.9, 0.0).unwrap();
    let (_, stats) = r
        .render(
            &ctx,
            &frame,
            &medium,
            &camera([0.5, -1.3, 0.85]),
            &CrmOptions::default(),
        )
        .unwrap();
    if on {
        let names: Vec<&str> = stats.gpu.iter().map(|(n, _)| *n).collect();
        assert_eq!(
            names,
            [
                "single scattering",
                "diffusion",
                "remove single",
                "volume pass",
                "grid occupancy",
                "environment grid",
                "environment pass",
                "view pass occupancy",
                "view pass grid",
                "view pass"
            ]
        );
        assert!(stats.gpu.iter().all(|(_, t)| t.is_finite() && *t >= 0.0));
        assert!(stats.gpu.iter().any(|(_, t)| *t > 0.0));
    } else {
        assert!(stats.gpu.is_empty());
    }
    // Off again: nothing is timed.
    ctx.time_stages(false);
    let (_, stats) = r
        .render(
            &ctx,
            &frame,
            &medium,
            &camera([0.4, -1.3, 0.85]),
            &CrmOptions::default(),
        )
        .unwrap();
    assert!(stats.gpu.is_empty());
}

/// The largest difference of the GPU image `gpu` from `crm_render`'s with `opts`, relative
/// to the largest light the multiple scattering adds (`crm_render`'s image less its
/// single scattering), after asserting the bound of the test below and that the orders
/// add light.
fn check_orders(
    gpu: &[[f32; 3]],
    rbfs: &[Rbf],
    dims: [usize; 3],
    medium: &Medium,
    env: &Environment,
    cam: &Camera,
    opts: &CrmOptions,
) -> f64 {
    let bbox = unit_box();
    let (cpu, _) = crm_render(rbfs, None, dims, &bbox, medium, env, cam, opts);
    let single = CrmOptions {
        multiple: false,
        ..*opts
    };
    let (dark, _) = crm_render(rbfs, None, dims, &bbox, medium, env, cam, &single);
    let ms = cpu
        .pixels
        .iter()
        .flatten()
        .zip(dark.pixels.iter().flatten())
        .map(|(c, s)| f64::from(c - s))
        .fold(0.0, f64::max);
    let bright = f64::from(cpu.pixels.iter().flatten().fold(0.0f32, |a, &b| a.max(b)));
    assert!(
        ms > 1e-2 * bright,
        "the orders add {ms} (brightest {bright})"
    );
    let d = gpu
        .iter()
        .flatten()
        .zip(cpu.pixels.iter().flatten())
        .map(|(g, c)| f64::from((g - c).abs()))
        .fold(0.0, f64::max);
    assert!(
        d <= 5e-4 * bright + 1e-2 * ms,
        "{d} (brightest {bright}, ms {ms})"
    );
    d / ms
}

#[test]
fn frames_with_the_explicit_orders_match_crm_render_and_keep_their_cells() {
    // `--diffusion orders` on the GPU (gpu::orders) against the CPU's crm_render with the
    // same options, lit by the sky, a sun and a point light. Beyond the module's bound
    // (5e-4 of the brightest pixel), the orders' twin (tests/gpu_orders.rs) puts J_ms
    // within 5e-3 of its largest, and its first source reads the GPU's environment grid,
    // within 1e-2 of S of the CPU's (gpu_env_pass.rs), S a part of the light: held to
    // 1e-2 of the largest light the multiple scattering adds to a pixel (printed).
    let ctx = context();
    let rbfs = cluster();
    let bbox = unit_box();
    let dims = [16, 16, 20];
    let env = sky_sun_and_point(3.0, ([0.7, 0.3, 0.6], [0.5, 0.4, 0.3]));
    let frame = GpuFrame {
        key: 5,
        rbfs: &rbfs,
        residual: None,
        dims,
        bbox,
    };
    let opts = CrmOptions {
        diffusion: MsDiffusion::Orders {
            factor: 2,
            orders: 2,
        },
        ..CrmOptions::default()
    };
    let (a, b) = (camera([0.5, -1.3, 0.85]), camera([1.8, 0.2, 0.6]));
    let medium = Medium::new(8.0, 0.9, 0.5).unwrap();
    let mut r = GpuRenderer::new(&ctx, env.clone()).unwrap();
    r.set_lighting(LightingOn::Gpu);
    let (image, stats) = r.render(&ctx, &frame, &medium, &a, &opts).unwrap();
    assert!(stats.solved);
    let gpu = image.read(&ctx).unwrap();
    let d = check_orders(&gpu, &rbfs, dims, &medium, &env, &a, &opts);
    println!("orders: largest difference {d:.2e} of the largest multiple scattering");
    let solve = r.diffusion_stats(&ctx).unwrap().unwrap();
    assert!(solve.converged && solve.iterations > 0, "{solve:?}");
    assert_eq!((r.orders_builds(), r.env_grid_builds()), (1, 1));

    // A camera move keeps the cells (and the environment grid): the image is the CPU's.
    let (moved, stats) = r.render(&ctx, &frame, &medium, &b, &opts).unwrap();
    assert_eq!(stats.reuse, Reuse::Sources);
    assert_eq!((r.orders_builds(), r.env_grid_builds()), (1, 1));
    let d = check_orders(
        &moved.read(&ctx).unwrap(),
        &rbfs,
        dims,
        &medium,
        &env,
        &b,
        &opts,
    );
    println!("orders, moved: largest difference {d:.2e} of the largest multiple scattering");
    // A new albedo or g gathers again on the same environment grid.
    let brighter = Medium::new(8.0, 0.95, 0.3).unwrap();
    let (image, _) = r.render(&ctx, &frame, &brighter, &b, &opts).unwrap();
    assert_eq!((r.orders_builds(), r.env_grid_builds()), (2, 1));
    check_orders(
        &image.read(&ctx).unwrap(),
        &rbfs,
        dims,
        &brighter,
        &env,
        &b,
        &opts,
    );
    // The grid's diffusion alone stays on the CPU; the orders need the sky per voxel.
    let grid = CrmOptions {
        diffusion: MsDiffusion::Grid { factor: 2 },
        ..opts
    };
    let e = r
        .render(&ctx, &frame, &medium, &a, &grid)
        .map(|_| ())
        .unwrap_err();
    assert!(e.to_string().contains("CPU only"), "{e}");
    let centers = CrmOptions {
        env_source: EnvSource::Centers,
        ..opts
    };
    let e = r
        .render(&ctx, &frame, &medium, &a, &centers)
        .map(|_| ())
        .unwrap_err();
    assert!(e.to_string().contains("environment pass's grid"), "{e}");
}
