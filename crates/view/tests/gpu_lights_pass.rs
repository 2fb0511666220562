//! The GPU lights pass against its CPU twin `render::lights_pass::lights_pass`, voxel by
//! voxel, on volume-pass grids of the RBF cluster: a sun from above, a back-lit sun
//! (`g = 0.9`, a 6° disk), a grazing sun, a zero-angle sun, a sun below the horizon, point
//! lights outside and inside the smoke (one on a voxel center), several lights at once,
//! `σt = 0` and `σt = 1e4`, a box far from the origin with uneven voxels; no lights or
//! albedo 0 leave the grids untouched, and bad lights are refused.
//!
//! These tests need a GPU adapter (a CPU one will do: Mesa's lavapipe, which
//! `scripts/test.sh` installs) and fail with the reason when there is none.
//!
//! **Tolerance.** Per voxel and channel, with `S = (Ω/4π)·Σ_lights E·p·(T·(1 + σt·τ) +
//! e⁻²⁰)` (the lights' contributions, recomputed here in `f64` from the CPU's
//! transmittance), `|J_gpu − J_cpu| ≤ 2e-5·S + 2e-7·|J_cpu|`. The GPU marches in `f32`:
//! positions relative to the box (absolute error ≈ ε·L, ε = 2⁻²⁴), trilinear weights off
//! by ≈ ε times the voxel index, the step length, a sum of up to ~100 terms: the optical
//! depth `σt·τ` is within ~1e-6 relative of the CPU's, so `T = e^(−σt·τ)` is within
//! ~1e-6·σt·τ relative — hence the `T·σt·τ` term (about 1e-6 relative per unit of optical
//! depth). The phase costs a few ulp: HG in `f32`, and the disk table read at `θc` from
//! `f32` vectors through an `atan` of a few ulp (the shader's own: lavapipe's built-in
//! `atan2`, within Vulkan's 4096 ulp, put `θc` 1.5e-6 rad off, 2e-5 of a `g = 0.9`
//! table's steep side). Measured on lavapipe, beyond one ulp of the stored `J`: at most
//! 2.1e-6·S (the point light in the smoke; 4e-7–1.6e-6 for the others, printed per case),
//! a margin of ten. The `e⁻²⁰` term covers the march's cut-off (`σt·τ > 20`), which `f32`
//! may cross one step apart (`T` below 2e-9 either way), and `2e-7·|J|` the rounding of
//! the stored `f32` sums (the lights add to the volume pass's `J̃`). One decision is not
//! rounding but a different march: where `ℓ/h₀` (the shadow ray's length in steps) lies
//! within rounding of an integer, `n = ⌈ℓ/h₀⌉` may differ by one, and the midpoint rule
//! over `n ± 1` steps differs by its own error. Such voxels are counted (at most 1 % of
//! those lit; 10 % for a point light on a voxel center, whose rays to whole lines of voxel
//! centers are whole numbers of steps) and held to 2 % of `S` (measured: 5.8e-3).

use haze_gpu::{GpuContext, GpuError};
use haze_view::field;
use haze_view::gpu::GridBuffer;
use haze_view::gpu::lights_pass::{LightsPass, SHADOW_CUTOFF};
use haze_view::lights::DiskPhase;
use haze_view::medium::{FOUR_PI, hg};
use haze_view::render::crm::{self, VolumeGrids};
use haze_view::render::lights_pass::{lights_pass, transmittance};
use haze_view::render::{CrmOptions, crm_sources};
use haze_view::{Environment, Medium, PointLight, Sky, Sun};
use haze_volume::Bbox;
use std::time::Instant;

mod common;
use common::{cluster, context, unit_box};

/// The bound on `|ΔJ|/S` (module docs).
const TOL: f64 = 2e-5;
/// The bound on `|ΔJ|/S` where `n` may differ by one step.
const STEP_TOL: f64 = 2e-2;

/// Volume-pass grids of the cluster on `bbox` with `J̃ = 0`, so that the comparison sees
/// the lights alone.
fn dark_grids(bbox: &Bbox, dims: [usize; 3], eye: [f64; 3]) -> VolumeGrids {
    let rbfs = cluster(bbox);
    let source = vec![[vec![0.0], vec![0.0], vec![0.0]]; rbfs.len()];
    crm::volume_pass(&rbfs, &source, 1, dims, bbox, None, eye)
}

/// Volume-pass grids of the cluster on `bbox` (order-2 sources from the sky), so that the
/// lights add to a non-zero `J̃`.
fn sky_grids(bbox: &Bbox, dims: [usize; 3], medium: &Medium, eye: [f64; 3]) -> VolumeGrids {
    let rbfs = cluster(bbox);
    let opts = CrmOptions {
        order: 2,
        ..CrmOptions::default()
    };
    let sky = Environment::sky(Sky::default());
    let (source, _) = crm_sources(&rbfs, medium, &sky, &opts);
    crm::volume_pass(&rbfs, &source, 2, dims, bbox, None, eye)
}

fn sun(direction: [f64; 3], irradiance: [f64; 3], angle_degrees: f64) -> Sun {
    let n = direction.iter().map(|c| c * c).sum::<f64>().sqrt();
    Sun {
        direction: direction.map(|c| c / n),
        irradiance,
        angle: angle_degrees.to_radians(),
    }
}

fn lit(suns: Vec<Sun>, points: Vec<PointLight>) -> Environment {
    Environment {
        suns,
        points,
        ..Environment::sky(Sky::default())
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `(S per channel, whether a shadow ray's step count is within rounding of changing)` at
/// voxel center `u` (module docs).
fn scale(
    g: &VolumeGrids,
    env: &Environment,
    phases: &[DiskPhase],
    medium: &Medium,
    eye: [f64; 3],
    u: [f64; 3],
) -> ([f64; 3], bool) {
    let density = &g.density;
    let vs = density.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let soft = (0.5 * h0).powi(2) / 3.0;
    let k = medium.albedo / FOUR_PI;
    let v = [0, 1, 2].map(|a| u[a] - eye[a]);
    let n = dot(v, v).sqrt();
    let d = v.map(|c| c / n);
    let mut s_out = [0.0; 3];
    let mut near_step = false;
    // A light's part of S (before the irradiance), and whether its march is near a step
    // change.
    let term = |s: [f64; 3], max_len: f64, p: f64| {
        let t = transmittance(density, medium.sigma_t, u, s, max_len, h0);
        let depth = if t > 0.0 { -t.ln() } else { 1e3 };
        let near = medium.sigma_t > 0.0
            && field::ray_box(u, s, density.bbox()).is_some_and(|(_, t1)| {
                let x = t1.min(max_len) / h0;
                x.round() >= 1.0 && (x - x.round()).abs() < 1e-4
            });
        (k * p * (t * (1.0 + depth) + (-SHADOW_CUTOFF).exp()), near)
    };
    for (sun, phase) in env.suns.iter().zip(phases) {
        let p = phase.eval(dot(sun.direction, d));
        let (f, near) = term(sun.direction, f64::MAX, p);
        near_step |= near;
        for (o, e) in s_out.iter_mut().zip(sun.irradiance) {
            *o += f * e;
        }
    }
    for light in &env.points {
        let w = [0, 1, 2].map(|a| light.position[a] - u[a]);
        let r2 = dot(w, w);
        if r2 == 0.0 {
            for (o, i) in s_out.iter_mut().zip(light.intensity) {
                *o += k * i / soft;
            }
            continue;
        }
        let r = r2.sqrt();
        let s = w.map(|c| c / r);
        let e = light.intensity.map(|i| i / (r2 + soft));
        let (f, near) = term(s, r, hg(medium.g, dot(s, d)));
        near_step |= near;
        for (o, e) in s_out.iter_mut().zip(e) {
            *o += f * e;
        }
    }
    (s_out, near_step)
}

/// The CPU's transmittance, disk phase and angle of each sun at `u`, for failure messages.
fn detail(
    g: &VolumeGrids,
    env: &Environment,
    phases: &[DiskPhase],
    medium: &Medium,
    eye: [f64; 3],
    u: [f64; 3],
) -> String {
    let density = &g.density;
    let vs = density.voxel_size();
    let h0 = vs[0].min(vs[1]).min(vs[2]);
    let v = [0, 1, 2].map(|a| u[a] - eye[a]);
    let n = dot(v, v).sqrt();
    let d = v.map(|c| c / n);
    let mut out = String::new();
    for (sun, phase) in env.suns.iter().zip(phases) {
        let t = transmittance(density, medium.sigma_t, u, sun.direction, f64::MAX, h0);
        let c = dot(sun.direction, d);
        out += &format!(
            "[T {t} p {} θ {}]",
            phase.eval(c),
            c.clamp(-1.0, 1.0).acos()
        );
    }
    out
}

/// What a comparison found: the largest `|ΔJ|/S` away from step-count changes, the
/// voxels at one, and the voxels lit.
#[derive(Debug, Default)]
struct Found {
    worst: f64,
    /// The largest `|ΔJ|/S` at step changes.
    near_worst: f64,
    near_step: usize,
    lit: usize,
}

/// Runs both lights passes on `g` and checks every voxel (module docs).
fn check(
    ctx: &GpuContext,
    pass: &LightsPass,
    g: &VolumeGrids,
    env: &Environment,
    medium: &Medium,
    eye: [f64; 3],
    what: &str,
) -> Found {
    check_with(ctx, pass, g, env, medium, eye, what, 1)
}

/// [`check`], allowing `percent_near_step` % of the voxels lit at a step change.
#[allow(clippy::too_many_arguments)]
fn check_with(
    ctx: &GpuContext,
    pass: &LightsPass,
    g: &VolumeGrids,
    env: &Environment,
    medium: &Medium,
    eye: [f64; 3],
    what: &str,
    percent_near_step: usize,
) -> Found {
    let mut cpu = g.clone();
    let t = Instant::now();
    lights_pass(&mut cpu, env, medium, eye);
    let cpu_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let gpu = pass
        .run(ctx, g, env, medium, eye)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    let gpu_s = t.elapsed().as_secs_f64();
    assert_eq!(gpu.density, g.density, "{what}: the pass wrote a density");
    let dims = g.density.dims();
    let bbox = *g.density.bbox();
    let vs = g.density.voxel_size();
    let mut found = Found::default();
    let phases: Vec<DiskPhase> = env
        .suns
        .iter()
        .map(|s| DiskPhase::new(medium.g, s.angle))
        .collect();
    let lit = haze_view::render::shell::lit_voxels(&g.density);
    for (i, ((gj, cj), before)) in gpu
        .radiance
        .iter()
        .zip(&cpu.radiance)
        .zip(&g.radiance)
        .enumerate()
    {
        if !lit[i] {
            assert_eq!(gj, before, "{what}: voxel {i} away from the smoke was lit");
            continue;
        }
        let idx = [
            i % dims[0],
            (i / dims[0]) % dims[1],
            i / (dims[0] * dims[1]),
        ];
        let u = [0, 1, 2].map(|a| bbox.min[a] + (idx[a] as f64 + 0.5) * vs[a]);
        let (s, near_step) = scale(g, env, &phases, medium, eye, u);
        found.lit += 1;
        found.near_step += usize::from(near_step);
        for c in 0..3 {
            let (p, q) = (f64::from(gj[c]), f64::from(cj[c]));
            assert!(p.is_finite(), "{what}: voxel {i}: {gj:?}");
            let err = (p - q).abs();
            let tol = if near_step { STEP_TOL } else { TOL };
            assert!(
                err <= tol * s[c] + 2e-7 * q.abs(),
                "{what}: voxel {idx:?} channel {c}: GPU {p}, CPU {q}, before {}, S {}{} {}",
                before[c],
                s[c],
                detail(g, env, &phases, medium, eye, u),
                if near_step { " (at a step change)" } else { "" }
            );
            // The measure: beyond one ulp of the stored J (the CPU and the GPU each round
            // their sum to f32).
            if s[c] > 0.0 {
                let ulp = q.abs() * f64::from(f32::EPSILON);
                let e = (err - ulp).max(0.0) / s[c];
                if near_step {
                    found.near_worst = found.near_worst.max(e);
                } else {
                    found.worst = found.worst.max(e);
                }
            }
        }
    }
    assert!(
        found.near_step * 100 <= found.lit * percent_near_step,
        "{what}: {} of {} voxels at a step change",
        found.near_step,
        found.lit
    );
    println!(
        "{what}: max |ΔJ| {:.2e}·S (beyond an ulp of J) over {} lit voxels ({} at a step change, there {:.2e}·S); CPU {cpu_s:.3} s, GPU {gpu_s:.3} s (upload and readback included)",
        found.worst, found.lit, found.near_step, found.near_worst
    );
    found
}

/// Bit for bit the same grids.
fn same(a: &VolumeGrids, b: &VolumeGrids) -> bool {
    a.density == b.density && a.radiance == b.radiance
}

const EYE: [f64; 3] = [0.5, -1.3, 0.85];

#[test]
fn suns_match_the_cpu() {
    let ctx = context();
    let pass = LightsPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let dims = [24; 3];
    for (what, s, g, eye) in [
        (
            "sun from above",
            sun([0.0, 0.0, 1.0], [3.0, 2.8, 2.5], 0.53),
            0.5,
            EYE,
        ),
        (
            "back-lit sun, g 0.9, 6° disk",
            sun([0.05, 1.0, 0.12], [3.0, 2.8, 2.5], 6.0),
            0.9,
            [0.5, -1.3, 0.5],
        ),
        (
            "grazing sun",
            sun([1.0, 0.3, 0.02], [2.0, 2.0, 2.0], 0.53),
            0.3,
            EYE,
        ),
        (
            "zero-angle sun",
            sun([0.4, -0.5, 0.77], [1.0, 2.0, 3.0], 0.0),
            0.6,
            EYE,
        ),
        (
            "sun below the horizon",
            sun([0.3, -0.2, -0.9], [1.5, 1.5, 1.5], 2.0),
            -0.3,
            EYE,
        ),
    ] {
        let medium = Medium::new(8.0, 0.9, g).unwrap();
        let grid = dark_grids(&bbox, dims, eye);
        let env = lit(vec![s], Vec::new());
        let f = check(&ctx, &pass, &grid, &env, &medium, eye, what);
        assert!(f.lit > 1000, "{what}: {f:?}");
    }
}

#[test]
fn point_lights_outside_inside_and_on_a_voxel_center_match_the_cpu() {
    let ctx = context();
    let pass = LightsPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let dims = [24; 3];
    let medium = Medium::new(8.0, 0.9, 0.4).unwrap();
    let grid = dark_grids(&bbox, dims, EYE);
    // The center of voxel (12, 11, 13), in the CPU's arithmetic.
    let vs = grid.density.voxel_size();
    let center = [12.0, 11.0, 13.0].map(|i: f64| i + 0.5);
    let center = [0, 1, 2].map(|a| bbox.min[a] + center[a] * vs[a]);
    assert!(grid.density.get(12, 11, 13) > 0.0);
    // A light on a voxel center puts the shadow rays of whole lines of voxels at whole
    // numbers of steps (distances between voxel centers along the axes and Pythagorean
    // diagonals): up to 10 % of the voxels may take a step more or less than the CPU.
    for (what, position, intensity, percent) in [
        ("point light outside", [1.6, 0.4, 1.2], [2.0, 2.0, 2.0], 1),
        (
            "point light in the smoke",
            [0.52, 0.48, 0.55],
            [0.05, 0.04, 0.03],
            1,
        ),
        (
            "point light on a voxel center",
            center,
            [0.05, 0.04, 0.03],
            10,
        ),
    ] {
        let env = lit(
            Vec::new(),
            vec![PointLight::new(position, intensity).unwrap()],
        );
        check_with(&ctx, &pass, &grid, &env, &medium, EYE, what, percent);
    }
}

#[test]
fn several_lights_clear_and_opaque_smoke_match_the_cpu() {
    let ctx = context();
    let pass = LightsPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let dims = [21, 18, 23];
    let env = lit(
        vec![
            sun([0.2, 0.1, 1.0], [3.0, 2.8, 2.5], 0.53),
            sun([-0.3, 1.0, 0.2], [0.5, 0.7, 1.0], 0.0),
            sun([0.1, 0.9, 0.3], [1.0, 1.0, 1.0], 4.0),
        ],
        vec![
            PointLight::new([1.4, -0.2, 0.3], [1.0, 0.5, 0.2]).unwrap(),
            PointLight::new([0.45, 0.55, 0.5], [0.02, 0.03, 0.04]).unwrap(),
        ],
    );
    for (what, sigma_t) in [
        ("five lights", 8.0),
        ("five lights, σt 0", 0.0),
        ("five lights, σt 1e4", 1e4),
    ] {
        let medium = Medium::new(sigma_t, 0.8, 0.5).unwrap();
        // The lights added to the sky's J̃ (of σt = 8, so the same grids each time).
        let grid = sky_grids(&bbox, dims, &Medium::new(8.0, 0.8, 0.5).unwrap(), EYE);
        check(&ctx, &pass, &grid, &env, &medium, EYE, what);
    }
}

#[test]
fn a_box_far_from_the_origin_with_uneven_voxels_matches_the_cpu() {
    let ctx = context();
    let pass = LightsPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = Bbox::new([120.0, -40.0, 15.0], [121.5, -39.0, 17.0]);
    let dims = [24, 14, 33];
    let eye = [119.2, -41.3, 16.6];
    let medium = Medium::new(6.0, 0.7, 0.5).unwrap();
    let grid = dark_grids(&bbox, dims, eye);
    let env = lit(
        vec![sun([0.3, 0.45, 0.84], [2.0, 2.0, 2.0], 0.53)],
        vec![PointLight::new([120.8, -39.4, 16.1], [0.2, 0.2, 0.2]).unwrap()],
    );
    check(
        &ctx,
        &pass,
        &grid,
        &env,
        &medium,
        eye,
        "far box, uneven voxels",
    );
}

#[test]
fn no_lights_or_albedo_0_leave_the_grids_and_bad_lights_are_refused() {
    let ctx = context();
    let pass = LightsPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = unit_box();
    let medium = Medium::new(8.0, 0.9, 0.4).unwrap();
    let grid = sky_grids(&bbox, [12; 3], &medium, EYE);
    let env = lit(vec![sun([0.0, 0.0, 1.0], [3.0; 3], 0.53)], Vec::new());
    let none = pass
        .run(&ctx, &grid, &Environment::sky(Sky::default()), &medium, EYE)
        .unwrap();
    assert!(same(&none, &grid));
    let black = Medium::new(8.0, 0.0, 0.4).unwrap();
    assert!(same(
        &pass.run(&ctx, &grid, &env, &black, EYE).unwrap(),
        &grid
    ));
    // Twice with the same pass (the phase tables kept): the same grids.
    let a = pass.run(&ctx, &grid, &env, &medium, EYE).unwrap();
    let b = pass.run(&ctx, &grid, &env, &medium, EYE).unwrap();
    assert!(same(&a, &b));
    assert!(!same(&a, &grid));

    let mut bad = env.clone();
    bad.suns[0].direction[0] = f64::NAN;
    let e = pass.run(&ctx, &grid, &bad, &medium, EYE).unwrap_err();
    assert!(matches!(e, GpuError::Input(_)), "{e}");
    assert!(e.to_string().contains("non-finite direction"), "{e}");
    let mut bad = env.clone();
    bad.suns[0].direction = [0.0, 0.0, 1.01];
    let e = pass.run(&ctx, &grid, &bad, &medium, EYE).unwrap_err();
    assert!(e.to_string().contains("not a unit vector"), "{e}");
    let mut bad = env.clone();
    bad.suns[0].angle = 4.0;
    let e = pass.run(&ctx, &grid, &bad, &medium, EYE).unwrap_err();
    assert!(e.to_string().contains("outside [0, π]"), "{e}");
    let bad = lit(
        Vec::new(),
        vec![PointLight {
            position: [0.5, f64::INFINITY, 0.5],
            intensity: [1.0; 3],
        }],
    );
    let e = pass.run(&ctx, &grid, &bad, &medium, EYE).unwrap_err();
    assert!(e.to_string().contains("point light 0"), "{e}");
}

#[test]
fn a_plume_sized_grid_is_timed() {
    // 72×72×96 voxels, one sun: the pass's GPU time from the timestamps (where the device
    // has them: the shadow volume and the lights added from it), against the CPU twin on
    // this machine's cores.
    let ctx = context();
    let pass = LightsPass::new(&ctx).unwrap_or_else(|e| panic!("{e}"));
    let bbox = Bbox::new([0.0; 3], [0.75, 0.75, 1.0]);
    let dims = [72, 72, 96];
    let medium = Medium::new(8.0, 0.9, 0.5).unwrap();
    let grid = dark_grids(&bbox, dims, EYE);
    let env = lit(vec![sun([0.3, 0.2, 0.93], [3.0; 3], 0.53)], Vec::new());
    let buffer = GridBuffer::upload(&ctx, &grid).unwrap();
    // A first run compiles nothing but builds the phase table; time the second.
    pass.run_on(&ctx, &buffer, &env, &medium, EYE).unwrap();
    ctx.finish("warm-up").unwrap();
    ctx.time_stages(true);
    let t = Instant::now();
    pass.run_on(&ctx, &buffer, &env, &medium, EYE).unwrap();
    ctx.finish("lights pass").unwrap();
    let host = t.elapsed().as_secs_f64();
    let times = ctx.take_stage_times().unwrap();
    ctx.time_stages(false);
    let mut cpu = grid.clone();
    let t = Instant::now();
    lights_pass(&mut cpu, &env, &medium, EYE);
    let cpu_s = t.elapsed().as_secs_f64();
    let lit = grid.density.data().iter().filter(|d| **d > 0.0).count();
    println!(
        "lights pass, {dims:?} ({lit} voxels with smoke), one sun: GPU {times:?}, {host:.3} s submitted to finished; CPU twin {cpu_s:.3} s"
    );
    if ctx.has_timestamps() {
        // The shadow volume, then the lights added from it.
        let names: Vec<_> = times.iter().map(|t| t.0).collect();
        assert_eq!(names, ["lights shadow volume", "lights pass"]);
    }
    check(&ctx, &pass, &grid, &env, &medium, EYE, "plume-sized grid");
}
